"""A measurement started before its drive (a DAQ's pre-trigger) is named by its lag.

A record with 0.2 s of rest before a 20 Hz circle's drive read 226 % in ``evaluate``
with a note that the actuator had changed, and ``learn`` refused it naming four
causes, none a start offset. Here the plant's own response to the drive, with rest
samples put before it: the lag named is the number of samples put there.
"""

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli._hardware import load_actuator
from hammerstein.cli._learn_checks import start_lag
from cli_run import run_cli as _cli

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'
PRE = 400            # samples of rest before the drive: 0.02 s at 50 us, 4 delay spans


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    d = tmp_path_factory.mktemp("pretrigger")
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=d).returncode == 0
    plant = load_actuator("rakotondrabe-2dof")
    u = pd.read_csv(d / "u0.csv", comment="#")
    y, _ = plant.simulate(u[["ux", "uy"]].to_numpy().T, plant.rest_state())
    pd.DataFrame({"t": u.t, "x": y[0], "y": y[1]}).to_csv(d / "m.csv", index=False)
    late = np.concatenate([np.repeat(y[:, :1], PRE, axis=1), y], axis=1)
    T = float(u.t[1] - u.t[0])
    pd.DataFrame({"t": np.arange(late.shape[1]) * T, "x": late[0], "y": late[1]}).to_csv(
        d / "pre.csv", index=False)
    return d, y, late, T


def test_the_lag_is_the_rest_put_before_the_drive(records):
    _, y, late, _ = records
    assert start_lag(y, late[:, :y.shape[1]], 100) == PRE
    assert start_lag(y, y, 100) is None                      # a record from the drive's start


def test_evaluate_names_the_pre_trigger_not_a_changed_actuator(records):
    d, _, _, T = records
    res = _cli("evaluate", "--reference", REF, "--drive", "u0.csv", "--measured", "pre.csv",
               "--model", "rakotondrabe-2dof", "--out", "ev-pre", cwd=d)
    assert res.returncode == 0, res.stderr
    assert f"lags the drive by {PRE} samples ({PRE * T:.4g} s)" in res.stderr, res.stderr
    assert "pre-trigger?" in res.stderr and "the actuator has changed" not in res.stderr
    ok = _cli("evaluate", "--reference", REF, "--drive", "u0.csv", "--measured", "m.csv",
              "--model", "rakotondrabe-2dof", "--out", "ev-ok", cwd=d)
    assert ok.returncode == 0 and "lags the drive" not in ok.stderr, ok.stderr


def test_learn_names_the_pre_trigger_first(records):
    d, _, _, T = records
    res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
               "--measured", "pre.csv", "--out", "u1.csv", cwd=d)
    assert res.returncode == 1 and not (d / "u1.csv").exists()
    assert (f"likely causes, in order: (1) the measured response lags the drive by {PRE} "
            f"samples ({PRE * T:.4g} s)") in res.stderr, res.stderr


def test_learn_refuses_a_pre_trigger_of_whole_periods(tmp_path):
    """A pre-trigger of whole periods aligns the periodic part at the delay: only the fade-in
    differs, the misfit stays low, and ``learn`` learnt from it (a tube's 30 Hz circle
    recorded 0.1 s, 3 periods, early: its next drive 20 % off where the right record's gave
    5.7 %). The lag found beyond the delay search refuses it all the same."""
    ref = '{ kind = "circle", radius = 30, frequency = 100, periods = 40 }'
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    plant = load_actuator("rakotondrabe-2dof")
    u = pd.read_csv(tmp_path / "u0.csv", comment="#")
    y, _ = plant.simulate(u[["ux", "uy"]].to_numpy().T, plant.rest_state())
    T = float(u.t[1] - u.t[0])
    pre = 3 * int(round(0.01 / T))                                 # 3 periods of 100 Hz
    late = np.concatenate([np.repeat(y[:, :1], pre, axis=1), y], axis=1)[:, :y.shape[1]]
    noise = np.random.default_rng(1)                               # a sensor: no flat run
    y, late = (v + 0.03 * noise.standard_normal(v.shape) for v in (y, late))
    pd.DataFrame({"t": u.t, "x": late[0], "y": late[1]}).to_csv(tmp_path / "pre.csv",
                                                                index=False)
    res = _cli("learn", "rakotondrabe-2dof", "--reference", ref, "--drive", "u0.csv",
               "--measured", "pre.csv", "--out", "u1.csv", cwd=tmp_path)
    assert res.returncode == 1 and not (tmp_path / "u1.csv").exists(), res.stderr
    assert (f"likely cause: the measured response lags the drive by {pre} samples "
            f"({pre * T:.4g} s)") in res.stderr, res.stderr
    pd.DataFrame({"t": u.t, "x": y[0], "y": y[1]}).to_csv(tmp_path / "m.csv", index=False)
    ok = _cli("learn", "rakotondrabe-2dof", "--reference", ref, "--drive", "u0.csv",
              "--measured", "m.csv", "--out", "u1.csv", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
