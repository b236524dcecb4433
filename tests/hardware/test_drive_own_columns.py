"""``learn`` and ``evaluate`` read the drive file by its own columns, not the measured file's.

A DAQ's measured file named its time ``Time``: ``learn --time Time`` failed with
"--drive: drive-base.csv: no column 'Time'" (the drive, written by ``compensate``, has
``t``), while ``evaluate`` accepted the same options. ``evaluate`` without ``--model``
judged x and y although the drive's header names the one-output actuator it was
computed for: "--measured: ...: no column 'y' for y (columns: t, u, x ...)".
"""

import numpy as np
import pandas as pd
import pytest

from hammerstein import MultivariablePI, PrandtlIshlinskii
from hammerstein.cli._hardware import load_actuator
from hammerstein.io.presets import save_model
from cli_run import run_cli as _cli

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'
SINE = '{ kind = "sine", amplitude = 8, offset = 12, frequency = 20, periods = 6 }'


@pytest.fixture(scope="module")
def daq(tmp_path_factory):
    """A drive of compensate and the plant's response to it, in t,x,y and in a DAQ's names."""
    d = tmp_path_factory.mktemp("daq")
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=d).returncode == 0
    plant = load_actuator("rakotondrabe-2dof")
    u = pd.read_csv(d / "u0.csv", comment="#")
    y, _ = plant.simulate(u[["ux", "uy"]].to_numpy().T, plant.rest_state())
    y = y + 0.3 * np.sin(2 * np.pi * 300 * u.t.to_numpy())    # something to learn from
    pd.DataFrame({"t": u.t, "x": y[0], "y": y[1]}).to_csv(d / "m.csv", index=False)
    pd.DataFrame({"Y_pos": y[1], "Time": u.t, "X_pos": y[0]}).to_csv(d / "daq.csv", index=False)
    return d


def test_learn_time_names_the_measured_files_column_not_the_drives(daq):
    plain = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
                 "--measured", "m.csv", "--out", "u1.csv", cwd=daq)
    assert plain.returncode == 0, plain.stderr
    named = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
                 "--measured", "daq.csv", "--time", "Time", "--output-columns",
                 "x=X_pos,y=Y_pos", "--out", "u1-daq.csv", cwd=daq)
    assert named.returncode == 0, named.stderr
    # the same measurement under other column names: the same next drive
    a = pd.read_csv(daq / "u1.csv", comment="#")
    b = pd.read_csv(daq / "u1-daq.csv", comment="#")
    assert list(b.columns) == list(a.columns) and len(a) == 1200
    np.testing.assert_array_equal(b.to_numpy(), a.to_numpy())


def test_evaluate_without_model_judges_the_drives_one_output_actuator(tmp_path):
    model = MultivariablePI([[PrandtlIshlinskii([0.0, 2.0, 5.0, 9.0], [1.0, 0.4, 0.2, 0.1])]],
                            input_amplitude=[20.0], input_names=["u"], output_names=["z"])
    save_model(model, tmp_path / "stack.toml", {"note": "test"})
    assert _cli("compensate", "stack.toml", "--sampling-period", "1e-4", "--reference", SINE,
                "--out", "d.csv", cwd=tmp_path).returncode == 0
    d = pd.read_csv(tmp_path / "d.csv", comment="#")
    t = d.t.to_numpy()
    z = 12 + 8 * np.sin(2 * np.pi * 20 * t) + 0.25      # the reference, 0.25 µm high
    pd.DataFrame({"t": t, "u": d.u, "z": z}).to_csv(tmp_path / "meas.csv", index=False)
    res = _cli("evaluate", "--reference", SINE, "--drive", "d.csv", "--measured", "meas.csv",
               "--out", "ev", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    m = pd.read_csv(tmp_path / "ev" / "metrics.csv")
    err = m[(m.channel == "z") & (m.metric == "max_abs_error")].value.to_numpy()
    assert err.size == 1 and err[0] == pytest.approx(0.25, abs=1e-9)
    # the drive's actuator moved away: the default x, y, and the missing column named
    (tmp_path / "stack.toml").rename(tmp_path / "gone.toml")
    res = _cli("evaluate", "--reference", SINE, "--drive", "d.csv", "--measured", "meas.csv",
               "--out", "ev2", cwd=tmp_path)
    assert res.returncode == 1
    assert "no column 'x' for x" in res.stderr and res.stderr.count("\n") == 1
