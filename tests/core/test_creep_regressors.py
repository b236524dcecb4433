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

from hammerstein.identification._creep_kernels import lag_states
from hammerstein.identification.creep_identification import (_regressors,
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
    new = lag_states(h, tau, T, stride)
    ref = np.stack([_lags(row, tau, T)[:, ::stride] for row in h])
    assert new.shape == ref.shape == (3, tau.size, -(-N // stride))
    assert np.max(np.abs(new - ref)) <= 1e-13 * np.max(np.abs(ref))


@pytest.mark.parametrize("seed,with_g", [(3, False), (4, True)])
def test_fit_is_the_bounded_least_squares_on_the_columns_by_definition(seed, with_g):
    """Weights, offsets and residuals of the fit (offsets projected out: step means without G,
    normal equations with G) against bounded-variable least squares (BVLS) on the full design
    of columns simulated one by one, weights >= 0 and offsets free (no smoothing)."""
    from types import SimpleNamespace
    from scipy.optimize import lsq_linear
    from hammerstein.identification.creep_identification import CreepIdentifier
    from hammerstein.models.creep import Creep

    rng = np.random.default_rng(seed)
    T, tau = 1e-3, np.array([0.01, 0.1, 1.0])
    mats = None
    if with_g:
        A, B, C, D = _stable_g(rng)
        A *= 0.5
        mats = (A, B, C, D)
    records = []
    for n in (3000, 2403):
        u = np.repeat(rng.uniform(-5, 5, 6), -(-n // 6))[None, :n]
        h = np.vstack([2.0 * u[0], -0.5 * u[0] + 0.3])
        y = np.vstack([Creep(tau, [0.02, 0.01, 0.03]).simulate(h[:1], T)[0],
                       Creep(tau, [0.0, 0.04, 0.01]).simulate(h[1:], T)[0]])
        if with_g:
            y = linear_steps(y, mats, np.zeros(A.shape[0]))[0]
        records.append(SimpleNamespace(u=u, y=y + 0.01 * rng.normal(size=y.shape),
                                       sampling_period=T, source=f"r{n}"))
    offset = np.array([0.5, -0.2])
    model = SimpleNamespace(n_outputs=2, output_names=["x", "y"], output_offset=offset,
                            simulate=lambda v: (np.vstack([2.0 * v[0], -0.5 * v[0] + 0.3])
                                                + offset[:, None], None))
    dyn = None if mats is None else SimpleNamespace(dt=T, A=A, B=B, C=C, D=D)
    ident = CreepIdentifier(tau, smoothing=0.0, max_rows=2000).fit(model, records, dyn)

    stride = int(np.ceil(sum(r.u.shape[1] for r in records) / 2000))
    lag_cols, off_blocks, targets = [], [], []
    for r in records:
        u = r.u
        h = model.simulate(u)[0] - offset[:, None]
        steps = staircase_steps(u)
        n_steps = int(steps[-1]) + 1
        rows = np.arange(0, u.shape[1], stride)
        X = _by_definition(mats, h, steps, n_steps, tau, T, rows)
        lag_cols.append(X[:, :2 * tau.size])
        off_blocks.append(X[:, 2 * tau.size:])
        Gh = h if mats is None else linear_steps(h, mats, np.zeros(mats[0].shape[0]))[0]
        targets.append((r.y - offset[:, None] - Gh)[:, rows].ravel())
    n_off = sum(o.shape[1] for o in off_blocks)
    design = np.zeros((sum(t.size for t in targets), 2 * tau.size + n_off))
    r0, c0 = 0, 2 * tau.size
    for L, O in zip(lag_cols, off_blocks):
        design[r0:r0 + L.shape[0], :2 * tau.size] = L
        design[r0:r0 + L.shape[0], c0:c0 + O.shape[1]] = O
        r0, c0 = r0 + L.shape[0], c0 + O.shape[1]
    target = np.concatenate(targets)
    lower = np.r_[np.zeros(2 * tau.size), np.full(n_off, -np.inf)]
    sol = lsq_linear(design, target, bounds=(lower, np.inf), method="bvls", tol=1e-14).x
    w = sol[:2 * tau.size].reshape(2, tau.size)
    assert np.max(np.abs(ident.weights_ - w)) <= 1e-6 * np.max(np.abs(w))
    offs = np.concatenate([o.ravel() for o in ident.offsets_])
    assert np.max(np.abs(offs - sol[2 * tau.size:])) <= 1e-6 * np.max(np.abs(sol[2 * tau.size:]))
    res = target - design @ sol
    r0 = 0
    per_output = [[], []]
    for t in targets:
        n_r = t.size // 2
        for l in range(2):
            per_output[l].append(res[r0 + l * n_r:r0 + (l + 1) * n_r])
        r0 += t.size
    rms = np.array([np.sqrt(np.mean(np.concatenate(p) ** 2)) for p in per_output])
    assert np.allclose(ident.residual_rms_, rms, rtol=1e-6)
