"""``learn`` refuses a measured response that is not the drive's (swapped, another drive's, saturated).

The measured responses are the bundled preset's prediction of the drive (an
actuator 4 % stronger, 40 nm of noise) made wrong by hand as a user's
mistakes make them: the channels swapped under a correct header, the
response of a drive for twice the radius, the x sensor held at one value for
30 samples. Each was learnt from without a word (a next drive as wrong as
the record); each is now refused with one line naming the cause, exit 1 and
nothing written. A genuine trial on an actuator far from its model (25 %
stronger, a 3 µm ringing at 700 Hz) is still learnt from.
"""


import numpy as np
import pandas as pd

from hammerstein.cli._learn_checks import MISFIT_LIMIT, flat_runs, prediction_misfit
from hammerstein.compensation.drive import read_signals
from hammerstein.io.presets import load_plant
from cli_run import run_cli as _cli

REF = '{ kind = "circle", radius = 15, frequency = 100, periods = 12 }'
REF2 = '{ kind = "circle", radius = 30, frequency = 100, periods = 12 }'


def _measure(drive, out, gain=1.04, extra=None):
    t, u, _ = read_signals(drive, ["ux", "uy"])
    y, _ = load_plant("rakotondrabe-2dof").simulate(gain * u)
    y = y + np.random.default_rng(0).normal(0, 0.04, y.shape)
    if extra is not None:
        y = extra(t, y)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(out, index=False)
    return t, y


def _learn(cwd, measured="y.csv", drive="u.csv"):
    return _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", drive,
                "--measured", measured, "--out", "next.csv", "--history", "hist",
                "--delay", "0", cwd=cwd)


def _refused(res, cwd):
    assert res.returncode == 1, res.stdout + res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hammerstein learn: error: --measured: not the "
                                                   "response of --drive"), res.stderr
    assert not (cwd / "next.csv").exists() and not (cwd / "hist").exists()
    return lines[0]


def test_swapped_channels_are_refused_and_named(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u.csv",
                cwd=tmp_path).returncode == 0
    t, y = _measure(tmp_path / "u.csv", tmp_path / "y.csv")
    # the same record, the header x,y over the data y,x
    pd.DataFrame({"t": t, "x": y[1], "y": y[0]}).to_csv(tmp_path / "swapped.csv", index=False)
    line = _refused(_learn(tmp_path, "swapped.csv"), tmp_path)
    assert ("(1) the channels swapped: the column read as y holds x, the column read as x holds "
            "y") in line and "--output-columns x=y,y=x" in line
    assert line.index("(1) the channels") < line.index("(2) a measurement of another drive") \
        < line.index("(3) the sensor saturated")
    # the genuine record is learnt from, and so is the swapped one read as the line says
    res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u.csv", "--measured",
               "swapped.csv", "--output-columns", "x=y,y=x", "--out", "next.csv", "--delay", "0",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    (tmp_path / "next.csv").unlink()
    assert _learn(tmp_path).returncode == 0 and (tmp_path / "next.csv").exists()


def test_another_drives_measurement_is_refused(tmp_path):
    for ref, name in ((REF, "u.csv"), (REF2, "u30.csv")):
        assert _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", name,
                    cwd=tmp_path).returncode == 0
    _measure(tmp_path / "u30.csv", tmp_path / "y30.csv")      # the 30 µm drive's response
    line = _refused(_learn(tmp_path, "y30.csv"), tmp_path)
    # the error is the 15 µm the radii differ by, 100 % of the 15 µm circle's motion
    pct = float(line.split("prediction of the drive is ")[1].split(" %")[0])
    assert 85 < pct < 115, line
    assert "(1) the channels swapped (no other order of the columns fits)" in line
    assert "(2) a measurement of another drive" in line


def test_a_saturated_sensor_is_refused_with_its_output_value_and_samples(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u.csv",
                cwd=tmp_path).returncode == 0
    i0 = 2000                     # of 2400 samples: settled, after the fade-in and two periods

    def held(t, y):
        y = y.copy()
        y[0, i0:i0 + 30] = 17.5                   # x at the sensor's end of range
        return y
    _measure(tmp_path / "u.csv", tmp_path / "y.csv", extra=held)
    line = _refused(_learn(tmp_path), tmp_path)
    assert (f"; likely cause: the sensor saturated or clipped: x stays at 17.5 µm over samples "
            f"{i0}..{i0 + 29} (30 samples)") in line


def test_a_genuine_trial_far_from_the_model_is_learnt_from(tmp_path):
    # 25 % stronger than the model, and a 3 µm mode at 700 Hz the model does not have
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u.csv",
                cwd=tmp_path).returncode == 0
    ring = lambda t, y: y + 3.0 * np.sin(2 * np.pi * 700 * t)     # noqa: E731
    _measure(tmp_path / "u.csv", tmp_path / "y.csv", gain=1.25, extra=ring)
    res = _learn(tmp_path)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "next.csv").exists()


def test_misfit_and_flat_runs_on_known_signals():
    t = np.arange(4000) / 4000
    p = np.vstack([np.cos(2 * np.pi * 5 * t), np.sin(2 * np.pi * 5 * t)])
    # twice the prediction: the error is the prediction itself, a misfit of exactly 1
    assert abs(prediction_misfit(p, 2 * p) - 1.0) < 1e-12
    # an offset is no misfit; a 10 % gain error is 0.1
    assert prediction_misfit(p, p + 3.0) < 1e-12
    assert abs(prediction_misfit(p, 1.1 * p) - 0.1) < 1e-12
    # swapped: x - y of a circle has twice its RMS, sqrt(2) over the motion
    assert abs(prediction_misfit(p, p[::-1]) - np.sqrt(2)) < 1e-3
    assert MISFIT_LIMIT < 1.0
    m = p.copy()
    m[0, 1000:1040] = 0.25                # where x moves fastest
    # delayed by 7 samples: the run is found where it is in the measured record
    d = np.hstack([np.repeat(m[:, :1], 7, axis=1), m[:, :-7]])
    assert flat_runs(p, d, lag=7) == [(0, 0.25, 1007, 1046)]
    assert flat_runs(p, p) == []
