"""Files at another rate than the model's or the drive's: resampled with a note, or refused.

A lab whose stages run at different rates found the conversions silent and inconsistent: a
20 kHz reference resampled onto a 10 kHz model without a word (played at 20 kHz, the circle
runs twice as fast); a 1 kHz reference interpolated into a polygon whose corners chatter, and
cut 9 samples short of its duration; a 50 kHz measurement decimated by ``learn`` (the samples
between dropped) and refused by ``evaluate``; a measurement starting at 12.3 s refused by
``learn`` and accepted by ``evaluate``.
"""


import numpy as np
import pandas as pd
import pytest

from hammerstein.compensation.drive_files import read_signals
from hammerstein.exceptions import DataFileError
from cli_run import run_cli as _cli

T = 1e-4            # the model's (the drive's) sampling period in the file-level tests
REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'


def _csv(path, t, columns):
    pd.DataFrame({"t": t, **columns}).to_csv(path, index=False, float_format="%.12g")
    return path


def _circle(path, step, duration=0.06, jitter=0.0, f=100.0):
    n = int(round(duration / step))
    t = np.arange(n) * step
    if jitter:
        t[1:-1] += np.random.default_rng(1).uniform(-jitter, jitter, n - 2) * step
    return _csv(path, t, {"x": 20 * np.cos(2 * np.pi * f * t), "y": 20 * np.sin(2 * np.pi * f * t)})


@pytest.mark.parametrize("step, jitter, says, coarser", [
    (T, 0.0, False, False),              # the model's rate: as it is
    (T, 0.02, False, False),             # jittered about the model's rate: the same nominal period
    (5e-5, 0.0, True, False),            # 20 kHz onto 10 kHz
    (5e-5, 0.02, True, False),           # 20 kHz, jittered
    (1 / 12000, 0.0, True, False),       # 12 kHz
    (1e-3, 0.0, True, True),             # 1 kHz: ten times coarser
])
def test_a_reference_at_another_rate_is_said_and_covers_its_duration(tmp_path, step, jitter, says,
                                                                     coarser):
    path = _circle(tmp_path / "ref.csv", step, jitter=jitter)
    notes = []
    t, values, period = read_signals(path, ["x", "y"], sampling_period=T, what="--reference",
                                     notes=notes)
    assert period == T and t.size == 600                 # 0.06 s, its last sample's period too
    assert np.allclose(t, np.arange(600) * T)
    assert len(notes) == (1 if says else 0)
    if says:
        assert notes[0].startswith(f"--reference: {path}: sampled every {step:.6g} s, resampled "
                                   f"(interpolated linearly) onto the sampling period 0.0001 s")
        assert ("times coarser: corners at every sample" in notes[0]) == coarser
        assert (f"--sampling-period {step:.6g} computes the drive" in notes[0]) == (not coarser)
    # the circle itself, within what linear interpolation between its samples leaves
    t = t[t <= 0.06 - step * (1 - jitter)]            # within its samples (past them: the last step)
    values = values[:, :t.size]
    angle = 2 * np.pi * 100 * t
    chord = 20 * (1 - np.cos(np.pi * 100 * step * (1 + 2 * jitter)))
    assert np.max(np.hypot(values[0] - 20 * np.cos(angle),
                           values[1] - 20 * np.sin(angle))) <= chord + 1e-6


def test_a_periodic_coarse_reference_continues_past_its_last_sample(tmp_path):
    path = _circle(tmp_path / "ref.csv", 1e-3)
    _, values, _ = read_signals(path, ["x"], sampling_period=T, notes=[], period=0.01)
    # past 0.059 s the polygon runs to its first corner again: 20 µm at 0.06 s
    tail = np.linspace(20 * np.cos(2 * np.pi * 100 * 0.059), 20.0, 11)[:-1]
    assert np.allclose(values[0, 590:], tail)


@pytest.mark.parametrize("m, residue", [(2, 0.0), (4, 0.0), (5, 0.2)])
def test_a_faster_measurement_is_averaged_over_each_drive_period(tmp_path, m, residue):
    """A ramp plus noise alternating every fine sample: the block mean centred on the drive's
    samples keeps the ramp undelayed and averages the alternation (to 1/5 for five samples,
    to nothing with half-weighted ends for an even number); a decimation kept all of it."""
    n = 400
    j = np.arange(n * m)
    t = j * (T / m)
    path = _csv(tmp_path / "m.csv", t, {"x": 1e3 * t + (-1.0) ** j})
    notes = []
    tk, y, period = read_signals(path, ["x"], sampling_period=T, what="--measured",
                                 upsample=False, notes=notes)
    assert period == T and tk.size == n
    assert np.allclose(np.abs(y[0, 1:] - 1e3 * tk[1:]), residue)
    assert notes == [f"--measured: {path}: sampled every {T / m:.6g} s, {m} samples per sampling "
                     f"period of 0.0001 s: averaged over each period (a block mean centred on the "
                     f"drive's samples, which lowers the noise)"]


@pytest.mark.parametrize("step", [2e-4, 1.2e-4])
def test_a_slower_measurement_is_refused(tmp_path, step):
    path = _circle(tmp_path / "m.csv", step)
    with pytest.raises(DataFileError, match=rf"^--measured: .*m\.csv: sampled every {step:g} s, "
                                            rf"{step / T:.4g} sampling periods of 0\.0001 s: "
                                            rf"slower than the drive"):
        read_signals(path, ["x"], sampling_period=T, what="--measured", upsample=False, notes=[])


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A drive of rakotondrabe-2dof (5e-5 s) and its reference measured at 1, 4 and 1/2 times
    its rate, and from 12.3 s."""
    d = tmp_path_factory.mktemp("lab")
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=d).returncode == 0
    Td = 5e-5
    n = len(pd.read_csv(d / "u0.csv", comment="#"))
    for name, step, start in [("m1", Td, 0.0), ("m4", Td / 4, 0.0), ("mslow", 2 * Td, 0.0),
                              ("mlate", Td, 12.3)]:
        t = np.arange(int(round(n * Td / step))) * step
        _csv(d / f"{name}.csv", t + start, {"x": 30 * np.cos(2 * np.pi * 100 * t),
                                            "y": 30 * np.sin(2 * np.pi * 100 * t)})
    return d


def _learn(d, measured):
    return _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
                "--measured", measured, "--out", f"u1-{measured}", "--force", cwd=d)


def _evaluate(d, measured):
    return _cli("evaluate", "--reference", REF, "--drive", "u0.csv", "--measured", measured,
                "--out", f"ev-{measured}", cwd=d)


def test_evaluate_and_learn_average_a_faster_measurement_alike(lab):
    note = ("note: --measured: m4.csv: sampled every 1.25e-05 s, 4 samples per sampling period "
            "of 5e-05 s: averaged over each period")
    assert _evaluate(lab, "m1.csv").returncode == 0
    for res in (_evaluate(lab, "m4.csv"), _learn(lab, "m4.csv")):
        assert res.returncode == 0, res.stderr
        assert note in res.stderr and "dropped" not in res.stderr
    scores = [pd.read_csv(lab / f"ev-{m}" / "metrics.csv") for m in ("m1.csv", "m4.csv")]
    native, averaged = (s.loc[s.metric == "max_euclidean_error", "value"].iloc[0] for s in scores)
    assert averaged == pytest.approx(native, abs=0.05)       # the circle, averaged over 50 µs


@pytest.mark.parametrize("measured, says", [
    ("mslow.csv", "--measured: mslow.csv: sampled every 0.0001 s, 2 sampling periods of 5e-05 s: "
                  "slower than the drive"),
    ("mlate.csv", "--measured: mlate.csv: starts at 12.3 s; expected t = 0 first (subtract "
                  "12.3 s from its time column"),
])
def test_evaluate_and_learn_refuse_alike(lab, measured, says):
    for command, res in (("evaluate", _evaluate(lab, measured)), ("learn", _learn(lab, measured))):
        assert res.returncode == 1
        assert res.stderr.startswith(f"hammerstein {command}: error: {says}"), res.stderr
        assert res.stderr.count("\n") == 1
