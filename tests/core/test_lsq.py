"""Least squares on the triangular factor (identification/lsq.py) against scipy's BVLS, the previous solver.

The identifications used ``scipy.optimize.lsq_linear(method="bvls")`` on the
tall regression matrices; they now factor the matrix once and solve the
bounded problem by nnls after eliminating the free variables. Both solve the
same convex problem, so:

* on random problems of full column rank the two minimisers are the same
  point: the objectives agree to rounding (1e-9 relative leaves a factor
  1e4-1e5 above the 1e-14 - 1e-13 measured) and the parameters within the
  problem's conditioning, ``|dx| / |x| <= cond(A) * 1e-12``;
* on the bundled real record every identification class, run once with each
  solver, predicts the same outputs: the difference is the solvers' stopping
  tolerance (BVLS stops at 1e-10 relative optimality), far below the sensor
  noise of the record (0.05 % of its range). The bound, 1e-6 of the output
  range, is 1e3 above the largest difference measured on the realistic 2 x 2
  records (2.6e-9 of the range, Preisach) and 500 below that noise.
* the generalised PI's envelopes come from a nonlinear least-squares search
  whose finite-difference Jacobian (step 1e-4) turns the solvers' 1e-13
  differences into different search paths; both end where the search's own
  tolerance stops it, not at one point. What holds is the identification:
  the training and held-out RMS errors within 1 % of each other (measured:
  0.1 %) and the predictions within 0.1 % of the output range, twice the
  record's noise (measured: 0.023 %).
"""

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from hammerstein.identification import (_record_regression, gpi_identification,
                                        preisach_identification, record_identification)
from hammerstein.io.datafiles import bundled_data, read_record
from hammerstein.identification.lsq import (bounded_lstsq, lstsq_bounded_below,
                                            penalized_bounded_lstsq, r_factor)


def _bvls(A, b, lower, ridge=0.0):
    """The previous solver: BVLS on the whole matrix (a ridge as stacked rows)."""
    A, b = np.asarray(A, float), np.asarray(b, float)
    if ridge > 0:
        col = np.linalg.norm(A, axis=0)
        col = np.where(col > 0, col, 1.0)
        A = np.vstack([A, np.sqrt(ridge) * np.diag(col)])
        b = np.r_[b, np.zeros(A.shape[1])]
    return lsq_linear(A, b, bounds=(lower, np.inf), method="bvls").x


@pytest.mark.parametrize("seed", range(6))
def test_same_minimiser_as_bvls_on_random_problems(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 40))
    A = rng.normal(size=(3000, n)) @ np.diag(10.0 ** rng.uniform(-2, 2, n))
    b = A @ rng.normal(size=n) + rng.normal(size=3000)
    lower = np.where(rng.random(n) < 0.6, rng.normal(size=n), -np.inf)
    x_ref = _bvls(A, b, lower)
    x = lstsq_bounded_below(A, b, lower)
    f_ref, f = np.sum((A @ x_ref - b) ** 2), np.sum((A @ x - b) ** 2)
    assert np.all(x[np.isfinite(lower)] >= lower[np.isfinite(lower)])
    assert abs(f - f_ref) <= 1e-9 * f_ref
    cond = np.linalg.cond(A)
    assert np.linalg.norm(x - x_ref) <= cond * 1e-12 * np.linalg.norm(x_ref)


@pytest.mark.parametrize("seed, ridge", [(0, 0.0), (1, 0.0), (2, 1e-12), (3, 1e-12), (4, 1e-8)])
def test_penalized_solver_equals_bvls_on_the_stacked_matrix(seed, ridge):
    """One QR of [R; lam D; ridge] = BVLS on [A; lam D] (ridge rows scaled by its column norms)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 40))
    A = rng.normal(size=(2000, n)) @ np.diag(10.0 ** rng.uniform(-1.5, 1.5, n))
    b = A @ rng.normal(size=n) + rng.normal(size=2000)
    D = np.vstack([np.diff(np.eye(n), 2, axis=0), np.diff(np.eye(n), 1, axis=0)])
    D = D[:, rng.permutation(n)]
    lam = float(10.0 ** rng.uniform(-2, 1))
    lower = np.where(rng.random(n) < 0.6, rng.normal(size=n), -np.inf)
    R, c, _ = r_factor(A, b)
    x = penalized_bounded_lstsq(R, c, D, lam, lower, ridge=ridge)
    stacked, target = np.vstack([A, lam * D]), np.r_[b, np.zeros(D.shape[0])]
    x_ref = _bvls(stacked, target, lower, ridge)
    assert np.all(x[np.isfinite(lower)] >= lower[np.isfinite(lower)])
    obj = lambda z: np.sum((stacked @ z - target) ** 2)    # noqa: E731
    assert abs(obj(x) - obj(x_ref)) <= 1e-9 * obj(x_ref)
    assert np.linalg.norm(x - x_ref) <= np.linalg.cond(stacked) * 1e-12 * np.linalg.norm(x_ref)
    # and the previous path: bounded_lstsq on the factor of the stacked matrix
    Rs, cs, _ = r_factor(np.vstack([R, lam * D]), np.r_[c, np.zeros(D.shape[0])])
    x_old = bounded_lstsq(Rs, cs, lower, ridge=ridge)
    assert np.linalg.norm(x - x_old) <= np.linalg.cond(stacked) * 1e-13 * np.linalg.norm(x_old)
    # the data factored free columns first (R triangular in the solver's order: tpqrt path)
    free = ~np.isfinite(lower)
    order = np.r_[np.flatnonzero(free), np.flatnonzero(~free)]
    Rf, cf, _ = r_factor(A[:, order], b)
    Rf_orig = np.empty_like(Rf)
    Rf_orig[:, order] = Rf
    x_tp = penalized_bounded_lstsq(Rf_orig, cf, D, lam, lower, ridge=ridge)
    # and the penalty rows as their triangular factor in that order (only D^T D matters)
    Dt = np.empty((n, n))
    Dt[:, order] = np.linalg.qr(D[:, order], mode="r")
    x_dt = penalized_bounded_lstsq(Rf_orig, cf, Dt, lam, lower, ridge=ridge)
    for z in (x_tp, x_dt):
        assert np.all(z[~free] >= lower[~free])
        assert abs(obj(z) - obj(x_ref)) <= 1e-9 * obj(x_ref)
        assert np.linalg.norm(z - x) <= np.linalg.cond(stacked) * 1e-13 * np.linalg.norm(x)


@pytest.mark.parametrize("sizes", [(5000, 3000), (3000, 3000, 3000), (100, 7000, 1)])
def test_factor_by_groups_with_still_columns_keeps_the_objective(sizes):
    """Columns constant within a group (another input held still) factored as one column of ones:
    the same objective for every x, the same least-squares solution, the same factor up to the
    signs of its rows."""
    rng = np.random.default_rng(len(sizes))
    n, N = 30, sum(sizes)
    A = rng.normal(size=(N, n))
    r0, cols = 0, rng.permutation(n - 1)
    for g, size in enumerate(sizes):          # full rank: each column still in one group at most
        still = cols[9 * g:9 * g + 9]
        A[r0:r0 + size, still] = rng.choice([-1.0, 1.0, 0.3], still.size)
        r0 += size
    A[:, -1] = 1.0
    b = A @ rng.normal(size=n) + 0.1 * rng.normal(size=N)
    R, c, rho = r_factor(A, b, groups=sizes)
    R1, c1, rho1 = r_factor(A, b)
    assert np.allclose(np.abs(R), np.abs(R1), rtol=1e-10, atol=1e-10 * np.abs(R1).max())
    assert rho == pytest.approx(rho1, rel=1e-10)
    for x in (rng.normal(size=n), np.linalg.lstsq(A, b, rcond=None)[0]):
        full = np.sum((A @ x - b) ** 2)
        assert np.sum((R @ x - c) ** 2) + rho ** 2 == pytest.approx(full, rel=1e-10)
    with pytest.raises(ValueError, match="do not split"):
        r_factor(A, b, groups=[N - 1])


def test_penalized_solver_names_bad_arguments():
    with pytest.raises(ValueError, match="lam and ridge"):
        penalized_bounded_lstsq(np.eye(2), np.ones(2), np.zeros((0, 2)), -1.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="expected c"):
        penalized_bounded_lstsq(np.eye(2), np.ones(3), np.zeros((0, 2)), 0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="not determined"):
        penalized_bounded_lstsq(np.zeros((2, 2)), np.ones(2), np.zeros((0, 2)), 0.0,
                                [-np.inf, -np.inf])


def test_factor_keeps_the_objective_and_handles_short_matrices():
    rng = np.random.default_rng(1)
    for N, n in [(10000, 7), (3, 5), (5000, 1)]:
        A, b, x = rng.normal(size=(N, n)), rng.normal(size=N), rng.normal(size=n)
        R, c, rho = r_factor(A, b)
        assert R.shape == (min(N, n), n)
        assert np.isclose(np.sum((A @ x - b) ** 2), np.sum((R @ x - c) ** 2) + rho ** 2,
                          rtol=1e-12)
    # all bounds active / none: the problem's own solution
    R = np.eye(3)
    assert bounded_lstsq(R, np.array([-1.0, 2.0, -3.0]), np.zeros(3)).tolist() == [0.0, 2.0, 0.0]
    assert np.allclose(bounded_lstsq(R, np.array([-1.0, 2.0, -3.0]), np.full(3, -np.inf)),
                       [-1.0, 2.0, -3.0])


def _record():
    return read_record(bundled_data(), input=2, output=1, time=0)


FITS = {
    "classical": lambda rec: record_identification.identify_records(rec),
    "preisach": lambda rec: preisach_identification.identify_preisach_records(rec, n_levels=12),
    "generalized": lambda rec: gpi_identification.identify_gpi_records(rec, n_plays=8),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FITS))
def test_identifications_on_the_bundled_record_equal_the_bvls_ones(name, monkeypatch):
    rec = _record()
    new = FITS[name](rec)
    reference = lambda R, c, lower, ridge=0.0: _bvls(R, c, lower, ridge)  # noqa: E731
    for module in (_record_regression, preisach_identification, gpi_identification):
        if hasattr(module, "bounded_lstsq"):
            monkeypatch.setattr(module, "bounded_lstsq", reference)
    monkeypatch.setattr(_record_regression, "lstsq_bounded_below", _bvls)
    old = FITS[name](rec)
    span = float(np.ptp(rec.y))
    pred_tol, rms_tol = (1e-3, 1e-2) if name == "generalized" else (1e-6, 1e-6)
    for p_new, p_old in zip(new.predictions, old.predictions):
        assert np.max(np.abs(p_new - p_old)) <= pred_tol * span
    assert new.validation, "the bundled record holds out its last loops"
    for w_new, w_old in zip(new.train + new.validation, old.train + old.validation):
        if name == "generalized":   # a nonlinear search: another path may end lower (measured
            # 1.1 % lower on another processor's BLAS kernels), never more than 1 % higher
            assert w_old["rms"] * (1 - 3 * rms_tol) <= w_new["rms"] <= w_old["rms"] * (1 + rms_tol)
        else:
            assert w_new["rms"] == pytest.approx(w_old["rms"], rel=rms_tol)
    assert new.structure == old.structure
