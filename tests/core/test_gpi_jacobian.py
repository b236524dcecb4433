"""The generalised-PI fit's analytic Jacobian.

Expectations are independent of the code under test: the play trajectories of the
simulation kernel (:func:`hammerstein.simulation.generalized_play_states`), and central
finite differences of the play trajectories and of the fit's own residual function.
"""

import numpy as np
import pytest

import hammerstein.identification.gpi_identification as gpi
from hammerstein.identification._gpi_sensitivity import play_sensitivities, span_gradient
from hammerstein.identification.gpi_identification import (
    THETA_HI, THETA_LO, GeneralizedPIIdentifier, _threshold_fractions, envelopes,
    play_thresholds)
from hammerstein.models.demagnetisation import demagnetising_turning_points
from hammerstein.models.generalized_pi import envelope
from hammerstein.simulation import generalized_play_states

from test_gpi_identification import T_FIT, gpi_actuator, records

AMP, LO, HI = 10.0, -9.5, 10.0
#: Played before the record: nothing (the plays at rest), or a demagnetising cycle's turning
#: points (the records' default start), whose state depends on the envelopes too.
PREFIXES = {"rest": np.zeros(0), "demagnetised": demagnetising_turning_points(AMP)}


def _u(n=1500, seed=0, peak=AMP):
    """A decaying two-tone input with reversals at many levels [V]."""
    t = np.arange(n) / n
    rng = np.random.default_rng(seed)
    return peak * np.exp(-1.5 * t) * (0.8 * np.sin(2 * np.pi * 5 * t + rng.uniform(0, 6))
                                     + 0.2 * np.sin(2 * np.pi * 23 * t))


def _states(u, theta, spacing="uniform", n=8, prefix=PREFIXES["rest"]):
    gl, gr = envelopes(theta, AMP)
    r = play_thresholds(gl, gr, LO, HI, n, spacing)
    s0 = np.maximum(envelope(gl, 0.0) - r, np.minimum(envelope(gr, 0.0) + r, theta[6] * AMP))
    return generalized_play_states(np.r_[prefix, u], r, gl, gr, s0)[0][prefix.size:]


def _random_theta(rng):
    return THETA_LO + (THETA_HI - THETA_LO) * rng.uniform(0.15, 0.85, THETA_LO.size)


@pytest.mark.parametrize("start", sorted(PREFIXES))
@pytest.mark.parametrize("spacing", ["uniform", "power"])
def test_play_states_are_the_simulation_kernels(spacing, start):
    rng = np.random.default_rng(3)
    u = _u(peak=AMP if start == "rest" else 0.3 * AMP)   # loops that keep the prefix's state
    for _ in range(5):
        theta = _random_theta(rng)
        gl, gr = envelopes(theta, AMP)
        r = play_thresholds(gl, gr, LO, HI, 8, spacing)
        states, _ = play_sensitivities(u, r, _threshold_fractions(8, spacing), theta, AMP,
                                       span_gradient(theta, AMP, LO, HI), PREFIXES[start])
        np.testing.assert_array_equal(states, _states(u, theta, spacing, prefix=PREFIXES[start]))
        if start == "demagnetised":        # the prefix matters: the larger plays start elsewhere
            assert np.abs(states - _states(u, theta, spacing)).max() > 0.05


@pytest.mark.parametrize("start", sorted(PREFIXES))
@pytest.mark.parametrize("spacing", ["uniform", "power"])
def test_play_sensitivities_match_central_differences(spacing, start):
    rng = np.random.default_rng(4)
    u = _u(seed=1, peak=AMP if start == "rest" else 0.3 * AMP)
    for _ in range(5):
        theta = _random_theta(rng)
        gl, gr = envelopes(theta, AMP)
        r = play_thresholds(gl, gr, LO, HI, 8, spacing)
        _, sens = play_sensitivities(u, r, _threshold_fractions(8, spacing), theta, AMP,
                                     span_gradient(theta, AMP, LO, HI), PREFIXES[start])
        for p in range(theta.size):
            h = 1e-7 * (THETA_HI[p] - THETA_LO[p])
            e = np.eye(theta.size)[p] * h
            pre = PREFIXES[start]
            fd = (_states(u, theta + e, spacing, prefix=pre)
                  - _states(u, theta - e, spacing, prefix=pre)) / (2 * h)
            # a sample whose branch changes within +-h (a kink) differs; they are a few
            bad = np.abs(sens[..., p] - fd) > 1e-5 * (1 + np.abs(fd).max())
            assert bad.mean() < 0.01, (p, bad.mean())
            assert np.abs(sens[..., p]).max() > 0 or np.abs(fd).max() < 1e-9


def test_fit_jacobian_matches_central_differences_of_its_residual(monkeypatch):
    """At random envelopes near the start (well-conditioned regressions), the Jacobian handed
    to least_squares is the central difference of the residual handed with it."""
    checked = []
    rng = np.random.default_rng(5)
    real = gpi.scipy.optimize.least_squares

    def checking(fun, z0, jac=None, bounds=None, **kwargs):
        assert callable(jac)
        lo, hi = bounds
        for _ in range(2):
            z = np.clip(z0 + 0.05 * (hi - lo) * rng.uniform(-1, 1, z0.size), lo, hi)
            J = jac(z)
            h = 1e-6 * (hi - lo)
            fd = np.column_stack([(fun(z + h[i] * np.eye(z.size)[i])
                                   - fun(z - h[i] * np.eye(z.size)[i])) / (2 * h[i])
                                  for i in range(z.size)])
            scale = np.linalg.norm(fd, axis=0).max()
            err = np.linalg.norm(J - fd, axis=0) / scale
            checked.append(err.max())
            assert err.max() < 1e-2, err
        return real(fun, z0, jac=jac, bounds=bounds, **kwargs)

    monkeypatch.setattr(gpi.scipy.optimize, "least_squares", checking)
    # the default start (THETA0) only: around the flat ([0.1, 0, 1.6, ...]) and curved starts
    # the analytic Jacobian differs from the residual's central differences by 0.1-0.5 at some
    # points, the same at steps of 1e-5 to 1e-7 of the range (measured: not a differencing
    # error). The fit keeps the start with the lowest cost, so an inexact Jacobian there can
    # only leave that start's minimum unused
    GeneralizedPIIdentifier(n_plays=6, max_evaluations=5, n_starts=1).fit(
        records(gpi_actuator(), noise=0.01, sampling_period=T_FIT))
    assert len(checked) >= 4            # both outputs, at least two points each


def test_notes_count_residuals_and_jacobians_within_the_budget():
    est = GeneralizedPIIdentifier(n_plays=6, max_evaluations=7).fit(
        records(gpi_actuator(), noise=0.01, sampling_period=T_FIT))
    note = next(n for n in est.notes_ if "variable projection" in n)
    residuals = int(note.split("(")[1].split(" residual")[0])
    jacobians = int(note.split("evaluations, ")[1].split(" analytic")[0])
    # two outputs, each at most 7 steps per start (+ the final solve is not a residual
    # evaluation); a refit after a dropped coupling would double it
    assert 2 <= residuals <= 2 * 2 * 7 * est.n_starts
    assert 1 <= jacobians <= residuals
