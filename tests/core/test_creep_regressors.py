"""The creep fit's regression columns: one simulation of G per output against one per column.

``creep_identification._regressors`` builds the columns from G's response to
each hysteresis output (lagged afterwards: G and the lags are linear and
time-invariant from rest, so they commute) and from G's delayed step
responses (a step's indicator is the difference of two delayed unit steps).
The reference here is the definition: every column's signal simulated
through G on its own, each lag filtered on its own at every sample
(:func:`scipy.signal.lfilter`, as the fit did before its compiled lag kernel)
and kept at the sampled rows. The two are equal to rounding: 1e-12 of the
largest column entry.
"""

import numpy as np
import pytest

from scipy.signal import lfilter

from hammerstein.identification.creep_identification import (_lag_states, _regressors,
                                                              staircase_steps)
from hammerstein.simulation import linear_steps


def _lags(h, tau, T):
    """Each lag ``x[t] = a x[t - 1] + (1 - a) h[t - 1]`` from rest, one filter per lag."""
    a = np.exp(-T / tau)
    return np.vstack([lfilter([0.0, 1.0 - a_k], [1.0, -a_k], h) for a_k in a])


def _stable_g(rng, p=2, n=4):
    A = rng.normal(size=(n, n))
    A *= 0.9 / max(abs(np.linalg.eigvals(A)))
    return A, rng.normal(size=(n, p)), rng.normal(size=(p, n)), rng.normal(size=(p, p))


def _by_definition(mats, h, steps, n_steps, tau, T, rows):
    p, N = h.shape
    through = (lambda s: s) if mats is None else \
        (lambda s: linear_steps(s, mats, np.zeros(mats[0].shape[0]))[0])
    cols = []
    for l in range(p):
        x = _lags(h[l], tau, T)
        for k in range(tau.size):
            s = np.zeros((p, N))
            s[l] = x[k]
            cols.append(through(s)[:, rows].ravel())
    for l in range(p):
        for j in range(n_steps):
            s = np.zeros((p, N))
            s[l] = steps == j
            cols.append(through(s)[:, rows].ravel())
    return np.column_stack(cols)


@pytest.mark.parametrize("seed,with_g", [(0, True), (1, True), (2, False)])
def test_columns_equal_the_per_column_simulation(seed, with_g):
    rng = np.random.default_rng(seed)
    N, T = 900, 1e-3
    u = np.repeat(rng.uniform(-5, 5, 6), N // 6)[None, :]
    steps = staircase_steps(u)
    n_steps = int(steps[-1]) + 1
    h = np.vstack([2.0 * u[0], -0.5 * u[0]]) + 0.1 * rng.normal(size=(2, N))
    tau = np.array([0.003, 0.03, 0.3])
    rows = np.arange(0, N, 4)
    mats = _stable_g(rng) if with_g else None
    new = _regressors(mats, h, steps, n_steps, tau, T, 4)
    ref = _by_definition(mats, h, steps, n_steps, tau, T, rows)
    assert new.shape == ref.shape == (2 * rows.size, 2 * (tau.size + n_steps))
    assert np.max(np.abs(new - ref)) <= 1e-12 * np.max(np.abs(ref))


@pytest.mark.parametrize("N,stride", [(900, 1), (901, 4), (7, 3)])
def test_lag_states_are_the_lags_filtered_one_by_one_at_the_sampled_rows(N, stride):
    rng = np.random.default_rng(N)
    h = rng.normal(size=(3, N))
    tau, T = np.array([0.002, 0.02, 0.2, 2.0]), 1e-3
    new = _lag_states(h, tau, T, stride)
    ref = np.stack([_lags(row, tau, T)[:, ::stride] for row in h])
    assert new.shape == ref.shape == (3, tau.size, -(-N // stride))
    assert np.max(np.abs(new - ref)) <= 1e-13 * np.max(np.abs(ref))
