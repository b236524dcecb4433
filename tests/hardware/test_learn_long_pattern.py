"""A reference whose whole pattern is long against its motion: a Lissajous figure given its pattern's period.

A user's AFM scanner drew a Lissajous figure (x 37 Hz, y 41 Hz, the pattern
repeating every second) given with ``--period 1``. ``learn``'s plausibility
check compared the measurement with the model's prediction below four times
the period's fundamental (4 Hz): all the motion was filtered away, what was left
(a creep's drift) made a genuine trial "not the response of --drive" (79 %),
and ``evaluate --model --period 1`` gave gains of 0.60 / 0.92 with a false
"the actuator has changed". The band now follows the reference's spectral
centroid where that lies far above the pattern's fundamental
(:func:`hammerstein.cli._learn_checks.band_share`); a circle's and a raster's
band are as before.

Here the pattern is 0.5 s (x 36 Hz, y 40 Hz) and the measurement is the
bundled preset's own prediction of the drive plus a slow drift on x (0.5 µm at
1.5 Hz, a creep the model does not hold): the misfit is then the drift's RMS
over the motion's (the band, 152 Hz, passes both), a closed form.
"""


import numpy as np
import pandas as pd
import pytest

from hammerstein.cli._learn_checks import (BAND_HARMONICS, band_share, measurement_problem,
                                           prediction_misfit, spectral_centroid)
from hammerstein.compensation.drive import drive_fade_samples, read_signals
from hammerstein.io.presets import load_plant
from hammerstein.signals import references as refs
from cli_run import run_cli as _cli

T = 5e-5
PATTERN = 0.5                     # s: x 18 turns, y 20 turns
FX, FY, A = 36.0, 40.0, 15.0
P = int(round(PATTERN / T))       # 10000 samples
DRIFT = 0.5                       # µm on x, at 1.5 Hz


def _lissajous(n):
    t = np.arange(n) * T
    return t, np.vstack([A * np.sin(2 * np.pi * FX * t), A * np.cos(2 * np.pi * FY * t)])


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    d = tmp_path_factory.mktemp("lissajous")
    t, r = _lissajous(4 * P)
    pd.DataFrame({"t": t, "x": r[0], "y": r[1]}).to_csv(d / "ref.csv", index=False,
                                                         float_format="%.12g")
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", "ref.csv", "--period",
               f"{PATTERN:g}", "--out", "u0.csv", cwd=d)
    assert res.returncode == 0, res.stderr
    t, u, _ = read_signals(d / "u0.csv", ["ux", "uy"])
    predicted, _ = load_plant("rakotondrabe-2dof").simulate(u)
    drift = np.vstack([DRIFT * np.sin(2 * np.pi * 1.5 * t), np.zeros_like(t)])
    y = predicted + drift
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(d / "y.csv", index=False)
    return d, r, predicted, y, drift, drive_fade_samples(d / "u0.csv")


# -- the band ----------------------------------------------------------------------------------

def test_a_lissajous_band_is_at_its_centroid_a_circle_and_a_raster_at_their_fundamental():
    _, r = _lissajous(4 * P)
    # the centroid of two equal sines is their mean frequency: 38 Hz
    assert spectral_centroid(r) == pytest.approx(38.0 * T, rel=1e-9)
    assert band_share(P, r) == pytest.approx(BAND_HARMONICS * 38.0 * T, rel=1e-9)
    assert band_share(P) == pytest.approx(BAND_HARMONICS / P)     # without it: 8 Hz
    t = np.arange(4000) * T                                      # a 50 Hz circle, 400 samples
    circle = np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 50 * t)])
    assert band_share(400, circle) == BAND_HARMONICS / 400.0
    _, raster = refs.raster(T, [40.0, 40.0], 16, 40.0, slow="step", smoothing=0.1)
    line = int(round(1 / (40.0 * T)))
    assert band_share(line, raster) == BAND_HARMONICS / float(line)


def test_the_misfit_of_a_genuine_lissajous_trial_is_its_drift(trial):
    _, r, predicted, y, drift, fade = trial
    d = drift[:, fade:]
    p = predicted[:, fade:]
    expected = (np.linalg.norm(d - d.mean(axis=1, keepdims=True))
                / np.linalg.norm(p - p.mean(axis=1, keepdims=True)))      # 2.4 %
    misfit = prediction_misfit(predicted, y, 0, fade, band_share(P, r))
    assert misfit == pytest.approx(expected, rel=0.05)
    assert measurement_problem(predicted, y, ["x", "y"], lambda m: 0, fade, P, r) is None


# -- learn and evaluate with --period the pattern's ------------------------------------------

def test_learn_takes_a_genuine_lissajous_trial_given_its_patterns_period(trial):
    d = trial[0]
    res = _cli("learn", "rakotondrabe-2dof", "--reference", "ref.csv", "--period", f"{PATTERN:g}",
               "--delay", "0", "--drive", "u0.csv", "--measured", "y.csv", "--out", "u1.csv",
               cwd=d)
    assert res.returncode == 0, res.stderr
    assert "not the response of --drive" not in res.stderr
    assert "the actuator has changed" not in res.stderr
    assert (d / "u1.csv").exists()


def test_evaluate_gains_against_the_model_are_one_with_the_patterns_period(trial):
    d = trial[0]
    res = _cli("evaluate", "--reference", "ref.csv", "--period", f"{PATTERN:g}", "--drive",
               "u0.csv", "--measured", "y.csv", "--model", "rakotondrabe-2dof", "--out", "ev/",
               cwd=d)
    assert res.returncode == 0, res.stderr
    assert "the actuator has changed" not in res.stdout + res.stderr
    m = pd.read_csv(d / "ev" / "metrics.csv")
    gains = m[m.metric == "gain_against_model"].set_index("channel").value
    # the drift is 1.5 Hz, uncorrelated with the 36/40 Hz motion over whole periods of both
    assert gains["x"] == pytest.approx(1.0, abs=0.005)
    assert gains["y"] == pytest.approx(1.0, abs=0.005)
