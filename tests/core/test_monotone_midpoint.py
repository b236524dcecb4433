"""Monotone least-squares identification and the midpoint compensator gain.

Expectations are derived independently: the optimal relaxation of a scalar
fixed-point step over slopes in [S_min, S_max] has contraction
(S_max - S_min) / (S_max + S_min); a monotone model is recovered exactly when
the constraint is inactive.
"""

import numpy as np
import pytest

import hammerstein as hs
from hammerstein.identification.identification import LeastSquaresPI


def _siso(weights, thresholds):
    return hs.MultivariablePI([[hs.PrandtlIshlinskii(thresholds, weights)]],
                              input_amplitude=[10.0])


@pytest.mark.parametrize("weights", [[4.0, 1.0, 0.5], [2.0, -0.5, 3.0], [1.0, 0.2, -0.1]])
def test_midpoint_gain_gives_optimal_contraction(weights):
    model = _siso(weights, [0.1, 2.0, 5.0])
    S = np.cumsum(weights)
    K = hs.midpoint_gains(model)
    np.testing.assert_allclose(K, [(S.min() + S.max()) / 2], rtol=1e-12)
    report = hs.convergence_report(model, "midpoint")
    np.testing.assert_allclose(report.max_radius, (S.max() - S.min()) / (S.max() + S.min()),
                               rtol=1e-12)


def test_midpoint_gain_refuses_non_monotone_direct_transfer():
    model = _siso([1.0, -2.0, 0.5], [0.1, 2.0, 5.0])
    with pytest.raises(hs.CompensatorError, match="slope .* <= 0"):
        hs.midpoint_gains(model)


def _sine(n_periods=3, n=2000, amplitude=10.0):
    t = np.arange(n_periods * n)
    return amplitude * np.sin(2 * np.pi * t / n)


def test_monotone_fit_recovers_a_monotone_model_exactly():
    r = np.array([0.0, 1.0, 3.0, 6.0])
    w = np.array([3.0, -1.0, 0.5, 1.5])  # cumulative sums 3, 2, 2.5, 4 > 0
    u = _sine()
    y, _ = hs.PrandtlIshlinskii(r, w).simulate(u)
    fit = LeastSquaresPI(thresholds=r, bounds="monotone", offset=False).fit(u, y)
    np.testing.assert_allclose(fit.weights_, w, atol=1e-9)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_monotone_fit_bounds_every_slope(sign):
    # a loop whose slope turns negative after each reversal (a lagging output)
    r = np.array([0.0, 0.5, 2.0, 5.0])
    w = sign * np.array([-1.0, 2.5, 1.0, 0.5])
    u = _sine()
    y, _ = hs.PrandtlIshlinskii(r, w).simulate(u)
    fit = LeastSquaresPI(thresholds=r, bounds="monotone", min_slope=0.2, offset=False).fit(u, y)
    S = sign * np.cumsum(fit.weights_)
    assert np.all(S >= 0.2 - 1e-9)
    # unconstrained least squares reproduces the non-monotone truth instead
    free = LeastSquaresPI(thresholds=r, offset=False).fit(u, y)
    np.testing.assert_allclose(free.weights_, w, atol=1e-9)
