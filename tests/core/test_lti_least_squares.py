"""The linear algebra behind DynamicsIdentifier and frf_h1, against the plain formulations.

The record-by-record R factors of B/D/x0 against one least squares over every sample of
every record (the initial states as columns of their own), the subspace step built from a
prior R factor against the same step on all columns, the broadcast csd against one csd
per pair.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from hammerstein.models._lti_delay import frf_h1
from hammerstein.models._lti_modal import real_modal as _real_modal
from hammerstein.models._lti_subspace import (_BDX0Problem, _MultiRecordMOESP,
                                              _state_regressors)

rng = np.random.default_rng(3)


def _system(n=4, p=2, m=2, seed=3):
    """A stable A with two complex pairs, random B, C: state recursion data."""
    r = np.random.default_rng(seed)
    Q = r.standard_normal((n, n))
    blocks = scipy.linalg.block_diag(*[0.95 * np.array([[np.cos(w), np.sin(w)],
                                                         [-np.sin(w), np.cos(w)]])
                                       for w in (0.1, 0.4)][:n // 2])
    A = Q @ blocks @ np.linalg.inv(Q)
    return A, r.standard_normal((n, m)), r.standard_normal((p, n))


def _records(A, B, C, D, lengths, noise, seed=4):
    r = np.random.default_rng(seed)
    ins, outs = [], []
    for N in lengths:
        u = r.standard_normal((B.shape[1], N))
        x = r.standard_normal(A.shape[0])
        y = np.empty((C.shape[0], N))
        for k in range(N):
            y[:, k] = C @ x + D @ u[:, k]
            x = A @ x + B @ u[:, k]
        ins.append(u)
        outs.append(y + noise * r.standard_normal(y.shape))
    return ins, outs


def _loop_regressors(A, C, u):
    """y_k = C sum_j A^(k-1-j) B u_j + C A^k x0 as regressors on vec B (row-major) and x0."""
    n, (m, N) = A.shape[0], u.shape
    RB, R0 = np.empty((N, C.shape[0], n * m)), np.empty((N, C.shape[0], n))
    S, P = np.zeros((n, n * m)), np.eye(n)
    for k in range(N):
        RB[k], R0[k] = C @ S, C @ P
        S = A @ S + np.kron(np.eye(n), u[:, k][None, :])    # d x / d vec B of B u_k
        P = A @ P
    return RB, R0


def test_state_regressors_equal_the_state_recursion():
    A, B, C = _system()
    u = rng.standard_normal((2, 500))
    for got, want in zip(_state_regressors(A, C, u), _loop_regressors(A, C, u)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.max(np.abs(want)))


def _direct(A, C, ins, outs, feedthrough, dc):
    """One least squares over all samples: columns vec B, vec D, then x0 of each record."""
    n, p, m, R = A.shape[0], C.shape[0], ins[0].shape[0], len(ins)
    rows, rhs = [], []
    for r, (u, y) in enumerate(zip(ins, outs)):
        RB, R0 = _loop_regressors(A, C, u)
        N = u.shape[1]
        blocks = [RB]
        if feedthrough:
            blocks.append(np.einsum("il,bk->kilb", np.eye(p), u).reshape(N, p, p * m))
        X0 = np.zeros((N, p, n * R))
        X0[:, :, r * n:(r + 1) * n] = R0
        blocks.append(X0)
        rows.append(np.concatenate(blocks, axis=2).reshape(N * p, -1))
        rhs.append(y.T.reshape(-1))
    X, b = np.vstack(rows), np.concatenate(rhs)
    n_shared = n * m + (p * m if feedthrough else 0)
    if dc is None:
        theta = np.linalg.lstsq(X, b, rcond=None)[0]
    else:      # minimise |X theta - b| subject to G(1) = dc (KKT system)
        E = np.zeros((p * m, X.shape[1]))
        E[:, :n * m] = np.kron(C @ np.linalg.inv(np.eye(n) - A), np.eye(m))
        if feedthrough:
            E[:, n * m:n_shared] = np.eye(p * m)
        K = np.block([[X.T @ X, E.T], [E, np.zeros((p * m, p * m))]])
        theta = np.linalg.solve(K, np.concatenate([X.T @ b, np.ravel(dc)]))[:X.shape[1]]
    B = theta[:n * m].reshape(n, m)
    D = theta[n * m:n_shared].reshape(p, m) if feedthrough else np.zeros((p, m))
    return B, D, theta[n_shared:].reshape(R, n), [(Xr @ theta).reshape(-1, p).T for Xr in rows]


@pytest.mark.parametrize("feedthrough", [False, True])
@pytest.mark.parametrize("dc", [None, "unit"])
def test_record_factors_solve_the_least_squares_over_every_sample(feedthrough, dc):
    A, B, C = _system()
    D = 0.3 * np.ones((2, 2)) if feedthrough else np.zeros((2, 2))
    ins, outs = _records(A, B, C, D, [300, 250, 400], noise=0.05)
    dc = None if dc is None else np.eye(2)
    problem = _BDX0Problem(A, C, ins, outs, feedthrough)
    got = problem.solve(dc)
    want = _direct(A, C, ins, outs, feedthrough, dc)
    for g, w in zip(got, want[:3]):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-8 * max(1.0, np.max(np.abs(w))))
    for g, w in zip(problem.outputs(*got), want[3]):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-8 * np.max(np.abs(w)))
    if dc is not None:       # the constraint holds: C (I - A)^-1 B + D = I
        Bg, Dg, _ = got
        np.testing.assert_allclose(C @ np.linalg.solve(np.eye(4) - A, Bg) + Dg, np.eye(2),
                                   atol=1e-10)


def test_noise_free_records_give_back_the_system():
    A, B, C = _system()
    ins, outs = _records(A, B, C, np.zeros((2, 2)), [200, 300], noise=0.0)
    Bg, Dg, _ = _BDX0Problem(A, C, ins, outs, False).solve()
    np.testing.assert_allclose(Bg, B, atol=1e-9)
    assert not Dg.any()


def test_subset_of_modes_equals_a_fresh_problem_on_those_modes():
    A, B, C = _system()
    modal = _real_modal(A, C, 5e-5)
    Am, Cm, mode_of = modal[0], modal[1], modal[2]
    ins, outs = _records(A, B, C, np.zeros((2, 2)), [300, 350], noise=0.1)
    keep = np.flatnonzero(mode_of == mode_of[-1])          # the states of one mode
    As, Cs = Am[np.ix_(keep, keep)], Cm[:, keep]
    sub = _BDX0Problem(Am, Cm, ins, outs, False).subset(keep, As, Cs)
    fresh = _BDX0Problem(As, Cs, ins, outs, False)
    for dc in (None, np.eye(2)):
        for g, w in zip(sub.solve(dc), fresh.solve(dc)):
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(w))))


def _hankel(x, i):
    """Block Hankel matrix by its definition: column j stacks x[:, j], ..., x[:, j + i - 1]."""
    return np.column_stack([x[:, j:j + i].T.ravel() for j in range(x.shape[1] - i + 1)])


def test_subspace_matrix_is_po_moesp_of_the_records_hankel_columns():
    A, B, C = _system()
    ins, outs = _records(A, B, C, np.zeros((2, 2)), [400, 300], noise=0.01)
    i = 5
    blocks = []
    for u, y in zip(ins, outs):
        uh, yh = _hankel(u, i), _hankel(y, i)
        blocks.append(np.vstack([uh[:, i:], uh[:, :-i], yh[:, :-i], yh[:, i:]]))
    L = np.linalg.qr(np.hstack(blocks).T, mode="r").T
    want = np.linalg.svd(L[-2 * i:, 2 * i:-2 * i], compute_uv=False)
    sid = _MultiRecordMOESP(ins, outs, i)
    np.testing.assert_allclose(sid.singular_values, want, rtol=1e-12, atol=1e-12 * want[0])


@pytest.mark.parametrize("held", [True, False])
def test_subspace_from_a_prior_r_factor_equals_the_step_on_all_columns(held):
    """Held-out records (whole records added) and split records (columns added at the end)."""
    A, B, C = _system()
    ins, outs = _records(A, B, C, np.zeros((2, 2)), [400, 300, 350], noise=0.01)
    i = 5
    if held:
        est_in, est_out, known = ins[:2], outs[:2], [u.shape[1] - 2 * i + 1 for u in ins[:2]] + [0]
    else:
        split = [250, 200, 300]
        est_in = [u[:, :s] for u, s in zip(ins, split)]
        est_out = [y[:, :s] for y, s in zip(outs, split)]
        known = [s - 2 * i + 1 for s in split]
    prior = _MultiRecordMOESP(est_in, est_out, i)
    combined = _MultiRecordMOESP(ins, outs, i, prior, known)
    direct = _MultiRecordMOESP(ins, outs, i)
    np.testing.assert_allclose(combined.singular_values, direct.singular_values, rtol=1e-10,
                               atol=1e-12 * direct.singular_values[0])
    for n in (2, 4):          # the same system up to a change of basis: same poles, same Markov
        Ac, Cc = combined.system_ac(n)
        Ad, Cd = direct.system_ac(n)
        np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(Ac)),
                                   np.sort_complex(np.linalg.eigvals(Ad)), atol=1e-9)
        np.testing.assert_allclose(np.abs(Cc), np.abs(Cd), atol=1e-9)


def test_frf_h1_equals_one_csd_per_pair():
    """The broadcast csd against the H1 estimate built pair by pair (Bendat & Piersol)."""
    T, m, p = 1e-3, 2, 3
    ins = [rng.standard_normal((m, 4000)) for _ in range(2)]
    outs = [scipy.signal.lfilter([0.0, 0.4], [1.0, -0.6], rng.standard_normal((p, m)) @ u, axis=1)
            + 0.01 * rng.standard_normal((p, 4000)) for u in ins]
    nper = 1024
    Suu = sum(np.array([[scipy.signal.csd(u[b], u[a], fs=1 / T, nperseg=nper)[1]
                         for b in range(m)] for a in range(m)]) for u in ins)
    Syu = sum(np.array([[scipy.signal.csd(u[a], y[c], fs=1 / T, nperseg=nper)[1]
                         for a in range(m)] for c in range(p)]) for u, y in zip(ins, outs))
    want = np.stack([Syu[:, :, k] @ np.linalg.inv(Suu[:, :, k]) for k in range(1, Suu.shape[2])],
                    axis=-1)
    f, H = frf_h1(ins, outs, T, nperseg=nper)
    assert f[0] == pytest.approx(1 / (nper * T)) and H.shape == (p, m, nper // 2)
    np.testing.assert_allclose(H, want, rtol=1e-12, atol=1e-12 * np.max(np.abs(want)))
