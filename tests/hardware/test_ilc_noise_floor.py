"""ILC at the noise floor: an error that is noise alone does not move the drive.

Expectations, derived independently of the code:

* on a deterministic plant, a trial whose measured error is sensor noise
  only (the drive already tracks) must leave the next drive where the
  same step leaves it with a noise-free, zero error (``Gamma^c(Gamma(u))``):
  learning that noise could only make the next trial worse;
* far above the noise floor the shrinkage is ~1 (the learning is not slowed);
* white noise alone through Q and a sliding mean of ``n_w`` samples gives a
  window power of ``sigma_Q^2 chi^2_dof / dof`` (closed form of the
  estimator's spread): with the default significance (6 standard
  deviations) the profile is 0 on (almost) every sample, while the plain
  Wiener factor (significance 0) passes noise on a large share of them;
* the period-averaged factor (``last_scale``) is 0 for a noise-only
  periodic error and ~1 for a large one.
"""

import numpy as np
import pytest

from hammerstein.signals import references as refs
from hammerstein.compensation.ilc import IterativeLearning
from hammerstein.exceptions import CompensatorError

NOISE = 0.04      # µm RMS, the sensor noise


def _learning(plant, significance=6.0, q=500.0):
    return IterativeLearning(plant.hysteresis, plant.dynamics, plant.sampling_period,
                             learning_gain=0.8, q_cutoff_hz=q, significance=significance)


def _raster(T):
    _, xy = refs.raster(T, [40.0, 40.0], 4, 40.0, slow="step", smoothing=0.1)
    return xy


@pytest.mark.parametrize("significance, frozen", [(6.0, True), (0.0, False)])
def test_noise_only_error_leaves_the_drive_unchanged(preset_plant, significance, frozen):
    """Deterministic plant, drive that already tracks: measured = output + noise."""
    T = preset_plant.sampling_period
    ilc = _learning(preset_plant, significance)
    u = np.vstack([5.0 + 4.0 * np.sin(2 * np.pi * 40.0 * np.arange(4000) * T),
                   5.0 + 3.0 * np.cos(2 * np.pi * 15.0 * np.arange(4000) * T)])
    y, _ = preset_plant.simulate(u)              # the reference this drive tracks exactly
    canonical = ilc.step(y, u, y)                # zero error: Gamma^c(Gamma(u))
    noisy = y + np.random.default_rng(3).normal(0.0, NOISE, y.shape)
    moved = float(np.max(np.abs(ilc.step(y, u, noisy) - canonical)))
    if frozen:
        assert moved < 1e-9
    else:                                        # the plain Wiener factor learns part of the noise
        assert moved > 1e-3


@pytest.mark.parametrize("amplitude", [1.0, 5.0])
def test_far_above_the_floor_the_shrinkage_is_one(preset_plant, amplitude):
    T = preset_plant.sampling_period
    ilc = _learning(preset_plant)
    t = np.arange(8000) * T
    e = amplitude * np.vstack([np.sin(2 * np.pi * 60.0 * t), np.cos(2 * np.pi * 90.0 * t)])
    e = e + np.random.default_rng(0).normal(0.0, NOISE, e.shape)
    shrink = ilc.noise_shrink_profile(e)
    assert np.min(shrink[200:-200]) > 0.97       # away from the record's ends


def test_white_noise_is_not_learnt_at_the_default_significance(preset_plant):
    ilc0, ilc6 = _learning(preset_plant, 0.0), _learning(preset_plant, 6.0)
    e = np.random.default_rng(11).normal(0.0, NOISE, (2, 40000))
    plain, tested = ilc0.noise_shrink_profile(e), ilc6.noise_shrink_profile(e)
    assert np.mean(plain > 0) > 0.2              # chi-square spread: the window's power exceeds
    assert np.mean(tested > 0) < 1e-3            # its mean often, 1 + 6 sqrt(2/dof) almost never
    assert np.all(tested <= plain)


def test_local_error_is_learnt_where_it_is(preset_plant):
    """A raster-like error concentrated in one burst: learnt there, not elsewhere."""
    T = preset_plant.sampling_period
    ilc = _learning(preset_plant)
    n = 20000
    e = np.random.default_rng(5).normal(0.0, NOISE, (2, n))
    i = np.arange(n)
    e[0] += 0.5 * np.exp(-0.5 * ((i - 10000) / 150.0) ** 2) * np.sin(2 * np.pi * 100.0 * i * T)
    shrink = ilc.noise_shrink_profile(e)
    assert shrink[10000] > 0.9
    assert np.max(shrink[:8000]) == 0.0 and np.max(shrink[12000:]) == 0.0


@pytest.mark.parametrize("error_um, expected", [(0.0, 0.0), (1.0, 1.0)])
def test_period_averaged_factor(preset_plant, error_um, expected):
    ilc = _learning(preset_plant)
    P, n_p = 200, 20
    u = np.vstack([5.0 + 4.0 * np.sin(2 * np.pi * np.arange(P * n_p) / P)] * 2)
    y, _ = preset_plant.simulate(u)
    i = np.arange(P * n_p)
    err = error_um * np.vstack([np.sin(2 * np.pi * i / P), np.cos(4 * np.pi * i / P)])
    noisy = y - err + np.random.default_rng(2).normal(0.0, NOISE, y.shape)
    ilc.step(y, u, noisy, period_samples=P, steady_from=2 * P)
    assert ilc.last_scale == pytest.approx(expected, abs=0.01)


@pytest.mark.parametrize("bad", [-1.0, float("nan")])
def test_significance_must_be_a_non_negative_number(preset_plant, bad):
    with pytest.raises(CompensatorError, match="significance"):
        _learning(preset_plant, bad)


def _periods(n_p, P, rng, noise, drift):
    """Error (1, n_p P): a repeating triangle, white noise, and ``drift(k)`` µm in period k."""
    i = np.arange(n_p * P)
    k = i // P
    tri = 0.3 * (2.0 * np.abs(2.0 * ((i % P) / P) - 1.0) - 1.0)
    return (tri + noise * rng.standard_normal(i.size) + drift(k))[np.newaxis]


@pytest.mark.parametrize("n_p", [4, 6, 10])
def test_period_drift_of_noise_alone_is_noise(n_p):
    # white noise: both estimates are sigma (unbiased, n_p - 1 and n_p - degree - 1 dof)
    from hammerstein.compensation.ilc import period_drift
    e = _periods(n_p, 2000, np.random.default_rng(n_p), 0.04, lambda k: 0.0 * k)
    s, d = period_drift(e, 2000, 0)
    assert s == pytest.approx(0.04, rel=0.05) and d == pytest.approx(0.04, rel=0.05)


def test_period_drift_tells_a_settling_transient_from_noise():
    # an exponential settling over the periods (a creep lag of 3 periods): its spread about the
    # mean is the RMS of exp(-k/3) about its mean, which a quadratic in k nearly takes out
    from hammerstein.compensation.ilc import period_drift
    n_p, P = 8, 2000
    drift = 0.5 * np.exp(-np.arange(n_p) / 3.0)
    e = _periods(n_p, P, np.random.default_rng(1), 0.02, lambda k: drift[k])
    s, d = period_drift(e, P, 0)
    expected = np.sqrt(np.sum((drift - drift.mean()) ** 2) / (n_p - 1) + 0.02 ** 2)
    assert s == pytest.approx(expected, rel=0.02)
    assert d < 0.03 and s > 5 * d


def test_period_drift_needs_four_periods():
    from hammerstein.compensation.ilc import period_drift
    assert period_drift(np.zeros((1, 3 * 100 + 50)), 100, 0) is None


def test_learn_names_a_drift_taken_for_noise():
    # the note learn adds to a stall or a refused trial, from the error it judged
    from hammerstein.cli.learn import _drift_note
    n_p, P = 8, 500
    drifting = _periods(n_p, P, np.random.default_rng(2), 0.02, lambda k: 0.05 * k)
    noisy = _periods(n_p, P, np.random.default_rng(3), 0.2, lambda k: 0.0 * k)
    (line,) = _drift_note(drifting, P, 0)
    assert "mostly drift" in line and "0.12 µm RMS" in line and "0.02 µm" in line
    assert _drift_note(noisy, P, 0) == []
