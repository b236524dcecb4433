"""Judging a trial against the best one from noisy records (``hammerstein.signals.trial_noise``).

Expectations, derived independently of the code:

* white Gaussian noise of standard deviation sigma has the one-sided
  density ``2 sigma^2 / fs`` at every frequency, so the estimate from the
  upper part of the band must find the sigma inserted into a synthetic
  record, whatever low-frequency signal (a 40 µm raster-like triangle) and
  whatever narrow line (a bending mode's ringing) the record also holds;
  its relative spread over noise seeds is ``sqrt(2 / dof)`` of a
  chi-square estimate;
* two measurements of the same error (different noise seeds) are equal
  in truth: neither may be judged worse than the other;
* an error 1.5 times another (RMS 1.5 times), even below the noise's own
  RMS, is worse than 10 % and must be judged worse; one 1.05 times is not
  10 % worse and must not be;
* the score is the noise-free RMS Euclidean error, within a few of its
  standard deviations ``sqrt(Var m) / (2 S)``.
"""

import numpy as np
import pytest

from hammerstein.signals.trial_noise import compare_trials, trial_error, white_noise_sigma
from hammerstein.exceptions import CompensatorError

T = 5e-5          # s, 20 kHz
N = 32000         # a 10 Hz raster of 16 lines


def _triangle(n=N, f=10.0, size=40.0):
    """A fast axis of a raster: a triangle 0 -> size -> 0 at f Hz [µm]."""
    phase = (np.arange(n) * T * f) % 1.0
    return size * (1.0 - np.abs(2.0 * phase - 1.0))


def _error(scale=1.0):
    """A raster-like tracking error: bumps at every line turn plus a slow offset, RMS 0.027 µm."""
    t = np.arange(N) * T
    turns = np.exp(-((((t * 10.0 + 0.25) % 0.5) - 0.25) / 0.06) ** 2)    # at each turn
    return scale * np.vstack([0.06 * turns + 0.01 * np.sin(2 * np.pi * 3 * t),
                              0.04 * turns * np.cos(2 * np.pi * 37 * t)])


@pytest.mark.parametrize("sigma", [0.01, 0.04, 0.2])
def test_the_noise_estimate_finds_the_sigma_inserted(sigma):
    """Within 5 % (about 3 standard deviations of the estimate, sqrt(2 / dof) ~ 1.5 %)."""
    rng = np.random.default_rng(int(sigma * 1000))
    signal = np.vstack([_triangle(), _triangle(f=0.3)])
    ringing = 0.1 * np.sin(2 * np.pi * 1300.0 * np.arange(N) * T)    # a mode, 2.5 sigma's worth
    est = white_noise_sigma(signal + ringing + rng.normal(0.0, sigma, (2, N)), T, 1000.0)
    np.testing.assert_allclose(est.sigma, sigma, rtol=0.05)
    assert est.band_hz == (1000.0, 10000.0)


def test_the_spread_of_the_estimate_is_its_chi_square_spread():
    """Over 60 seeds the relative standard deviation of sigma^2 is sqrt(2 / dof) within 30 %."""
    est = [white_noise_sigma(np.random.default_rng(s).normal(0.0, 0.04, (1, N)), T, 1000.0)
           for s in range(60)]
    var = np.array([e.sigma[0] ** 2 for e in est])
    assert np.std(var) / np.mean(var) == pytest.approx(np.sqrt(2.0 / est[0].dof), rel=0.3)
    assert np.mean(var) == pytest.approx(0.04 ** 2, rel=0.01)


def _measured(error, seed, sigma=0.04):
    return trial_error(error + np.random.default_rng(seed).normal(0.0, sigma, error.shape), T,
                       1000.0)


def test_two_measurements_of_the_same_error_are_never_judged_worse():
    e = _error()
    for seed in range(12):
        a, b = _measured(e, 2 * seed), _measured(e, 2 * seed + 1)
        assert not compare_trials(a, b).worse and not compare_trials(b, a).worse, seed


def test_the_max_would_have_judged_some_of_them_worse():
    """What the max-based judgement did: measured maxima of the same error differ by over 10 %
    for some of these seed pairs (noise-dominated maxima, 4-5 sigma each)."""
    e = _error()
    ratios = []
    for seed in range(12):
        ya = e + np.random.default_rng(2 * seed).normal(0.0, 0.04, e.shape)
        yb = e + np.random.default_rng(2 * seed + 1).normal(0.0, 0.04, e.shape)
        ma, mb = np.max(np.linalg.norm(ya, axis=0)), np.max(np.linalg.norm(yb, axis=0))
        ratios.append(max(ma / mb, mb / ma))
    assert max(ratios) > 1.1


@pytest.mark.parametrize("scale, worse", [(1.5, True), (1.05, False)])
def test_a_genuinely_worse_trial_is_still_judged_worse(scale, worse):
    e = _error()
    assert np.sqrt(np.mean(np.sum(e ** 2, axis=0))) < 0.04      # below the noise's RMS
    for seed in range(6):
        c = compare_trials(_measured(scale * e, 100 + seed), _measured(e, 200 + seed))
        assert c.worse == worse, (seed, c)
        if worse:
            assert c.better is False


def test_the_score_is_the_noise_free_rms():
    e = _error()
    rms = np.sqrt(np.mean(np.sum(e ** 2, axis=0)))
    c = compare_trials(_measured(e, 1), _measured(e, 2))
    # Var m ~ (4 s^2 m + 2 p s^4) / N; S = sqrt(m): sd(S) = sd(m) / (2 S)
    sd = np.sqrt((4 * 0.04 ** 2 * rms ** 2 + 2 * 2 * 0.04 ** 4) / N) / (2 * rms)
    assert abs(c.score - rms) < 4 * sd
    assert abs(c.best_score - rms) < 4 * sd
    np.testing.assert_allclose(c.sigma, 0.04, rtol=0.05)
    # the margin: 3 standard deviations of D = m_k - 1.21 m_b + 0.21 s^2 (the noise estimate's
    # share neglected here), turned into µm at the best's score: sqrt(1.21 S^2 + 3 sd) - 1.1 S
    var_m = (4 * 0.04 ** 2 * rms ** 2 + 2 * 2 * 0.04 ** 4) / N
    expected = np.sqrt(1.21 * rms ** 2 + 3 * np.sqrt(var_m * (1 + 1.1 ** 4))) - 1.1 * rms
    assert c.margin == pytest.approx(expected, rel=0.1)


def test_too_short_a_record_or_band_is_refused():
    with pytest.raises(CompensatorError, match="at least 512 samples"):
        white_noise_sigma(np.zeros((2, 500)), T)
    with pytest.raises(CompensatorError, match="fewer than 4 spectral lines"):
        white_noise_sigma(np.zeros((2, 4000)), T, 9900.0)
    with pytest.raises(CompensatorError, match="outputs"):
        compare_trials(_measured(_error()[:1], 0), _measured(_error(), 1))
