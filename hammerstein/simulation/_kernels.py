"""Compiled (numba) stepping kernels of the simulation core.

Low-level loops only: they take packed float/int arrays, update the states
in place and never allocate per sample. :mod:`hammerstein.simulation` packs
the models, validates the arguments, and keeps the plain numpy loops that
serve as the test oracle of these kernels.

Packed multivariable PI model (see ``simulation.pack_model``)
-------------------------------------------------------------
``start`` (m + 1,) int64
    The *unique* play operators driven by input k are ``start[k]:start[k+1]``
    (hysterons of several outputs sharing input, threshold and initial state
    are one play operator, Def. 3.2 of the paper: they evolve identically).
``r`` (n_plays,) [V]
    Thresholds of the unique play operators.
``W`` (p, n_plays) [µm/V]
    Weight of each play operator in each output (0 where absent).
``G`` (p, m) [µm/V]
    Pure linear components.

Status codes returned by the chain kernels: 0 ok, 1 non-finite input voltage,
2 input voltage beyond the divergence bound.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange, uint64

__all__ = ["play_kernel", "pi_kernel", "plant_kernel", "chain_kernel",
           "chain_batch_serial", "chain_batch_parallel",
           "STATUS_OK", "STATUS_NONFINITE", "STATUS_BOUND"]

# fastmath={'reassoc'} only: lets LLVM vectorise the weighted sums (summation
# order changes, ~1e-15 relative; tests check 1e-9 against the numpy oracle).
# No 'nnan'/'ninf': the divergence checks need exact non-finite semantics.
# The helpers are inlined by numba (inline='always') and take these flags
# from the kernel that calls them.
FASTMATH = {"reassoc"}

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_BOUND = 2


@njit(cache=True, inline="always")
def _play(v, uk, rj):
    """One play-operator step, ``max(u - r, min(u + r, v))`` (eq. (1))."""
    hi = uk + rj
    lo = uk - rj
    v = hi if hi < v else v
    return lo if lo > v else v


@njit(cache=True)
def play_kernel(u, r, s, y):
    """Play operators of one input, eq. (1): ``y`` (n, N) out, ``s`` (n,) in/out."""
    for i in range(uint64(r.size)):
        i = uint64(i)
        v = s[i]
        ri = r[i]
        for t in range(uint64(u.size)):
            t = uint64(t)
            v = _play(v, u[t], ri)
            y[i, t] = v
        s[i] = v


# Indices are cast to uint64 in the hot loops: numba then drops its negative
# index wrap-around, and LLVM vectorises the play updates (vminpd/vmaxpd).
@njit(cache=True, inline="always")
def _commit(u, start, r, s):
    """Move the play operators to the input vector ``u`` (m,) (eq. (1))."""
    for k in range(start.size - 1):
        uk = u[k]
        for j in range(uint64(start[k]), uint64(start[k + 1])):
            j = uint64(j)
            s[j] = _play(s[j], uk, r[j])


@njit(cache=True, inline="always")
def _output(u, W, G, s, y):
    """``y = W s + G u`` (eq. (4)); outputs in pairs share the loads of s."""
    p, n = W.shape
    m = G.shape[1]
    for l in range(0, p - 1, 2):
        W0 = W[l]
        W1 = W[l + 1]
        a0 = 0.0
        a1 = 0.0
        for j in range(uint64(n)):
            j = uint64(j)
            a0 += W0[j] * s[j]
            a1 += W1[j] * s[j]
        for k in range(m):
            a0 += G[l, k] * u[k]
            a1 += G[l + 1, k] * u[k]
        y[l] = a0
        y[l + 1] = a1
    if p % 2:
        W0 = W[p - 1]
        a0 = 0.0
        for j in range(uint64(n)):
            j = uint64(j)
            a0 += W0[j] * s[j]
        for k in range(m):
            a0 += G[p - 1, k] * u[k]
        y[p - 1] = a0


@njit(cache=True, inline="always")
def _evaluate(u, start, r, W, G, s, y):
    """``y = Gamma(u; s)`` without moving the plays (frozen states)."""
    p, n = W.shape
    m = G.shape[1]
    for l in range(p):
        g = 0.0
        for k in range(m):
            g += G[l, k] * u[k]
        y[l] = g
    for k in range(start.size - 1):
        uk = u[k]
        for j in range(uint64(start[k]), uint64(start[k + 1])):
            j = uint64(j)
            v = _play(s[j], uk, r[j])
            for l in range(p):
                y[l] += W[l, j] * v


@njit(cache=True, fastmath=FASTMATH)
def pi_kernel(u, start, r, W, G, s, y):
    """Multivariable PI forward model: ``u`` (m, N) -> ``y`` (p, N); ``s`` in/out.

    The play updates of each input are one contiguous, vectorised loop; each
    play is updated once however many outputs it feeds (``W`` columns).
    The bodies of :func:`_commit` and :func:`_output` are written out here on
    purpose: calling them with the column views ``u[:, t]`` and ``y[:, t]``
    measured 0.62-0.99 ns per hysteron update against 0.42-0.51 ns inline
    (the 0.6 ns target of the benchmark).
    """
    m, N = u.shape
    p, n = W.shape
    for t in range(N):
        for k in range(m):
            uk = u[k, t]
            for j in range(uint64(start[k]), uint64(start[k + 1])):
                j = uint64(j)
                s[j] = _play(s[j], uk, r[j])
        for l in range(0, p - 1, 2):          # outputs in pairs share the loads of s
            W0 = W[l]
            W1 = W[l + 1]
            a0 = 0.0
            a1 = 0.0
            for j in range(uint64(n)):
                j = uint64(j)
                a0 += W0[j] * s[j]
                a1 += W1[j] * s[j]
            for k in range(m):
                a0 += G[l, k] * u[k, t]
                a1 += G[l + 1, k] * u[k, t]
            y[l, t] = a0
            y[l + 1, t] = a1
        if p % 2:
            W0 = W[p - 1]
            a0 = 0.0
            for j in range(uint64(n)):
                j = uint64(j)
                a0 += W0[j] * s[j]
            for k in range(m):
                a0 += G[p - 1, k] * u[k, t]
            y[p - 1, t] = a0


@njit(cache=True, inline="always")
def _linear(h, A, B, C, D, x, xn, y):
    """``y = C x + D h``; ``x <- A x + B h`` (discrete state update)."""
    p = D.shape[0]
    nx = x.size
    for l in range(p):
        a = 0.0
        for i in range(nx):
            a += C[l, i] * x[i]
        for i in range(p):
            a += D[l, i] * h[i]
        y[l] = a
    for i in range(nx):
        a = 0.0
        for j in range(nx):
            a += A[i, j] * x[j]
        for j in range(p):
            a += B[i, j] * h[j]
        xn[i] = a
    for i in range(nx):
        x[i] = xn[i]


@njit(cache=True, fastmath=FASTMATH)
def plant_kernel(u, start, r, W, G, s, A, B, C, D, x, y):
    """Hammerstein plant: PI then linear part; ``s`` and ``x`` in/out, ``y`` (p, N) out."""
    m, N = u.shape
    p = W.shape[0]
    ut = np.empty(m)
    h = np.empty(p)
    yt = np.empty(p)
    xn = np.empty(x.size)
    for t in range(N):
        for k in range(m):
            ut[k] = u[k, t]
        _commit(ut, start, r, s)
        _output(ut, W, G, s, h)
        _linear(h, A, B, C, D, x, xn, yt)
        for l in range(p):
            y[l, t] = yt[l]


@njit(cache=True, fastmath=FASTMATH)
def chain_kernel(yr, n_samples,
                 cstart, cr, cW, cG, Kinv, iterations, bound, lowpass, a,
                 cu, cvf, cs,
                 run_plant, pstart, pr, pW, pG, A, B, C, D, ps, x,
                 u_out, y_out):
    """Compensator -> multivariable PI -> linear dynamics, one loop.

    Compensator (delay): from ``U = U(t-T)``, ``iterations`` times
    ``U <- U + K^-1 (Yr(t) - Gamma(U; s(t-T)))``, then commit the plays.
    Compensator (low-pass): ``v = U(t-T) - K^-1 Gamma(U(t-T))``,
    ``v_f <- a v_f + (1 - a) v``, ``U = K^-1 Yr(t) + v_f``, then commit.
    States ``cu`` (m,), ``cvf`` (m,), ``cs`` (plays), ``ps`` and ``x`` are
    updated in place up to the last valid sample.

    Returns
    -------
    (status, sample) : (int, int)
        ``status`` 0, or 1/2 with the diverging sample (``u_out[:, sample]``
        then holds the offending U, outputs stop before it).
    """
    m = cG.shape[1]
    p = cW.shape[0]
    pp = pW.shape[0]
    u = np.empty(m)
    e = np.empty(p)
    yh = np.empty(p)
    yhat = np.empty(p)
    v = np.empty(m)
    h = np.empty(pp)
    yt = np.empty(pp)
    xn = np.empty(x.size)
    # Gamma(U(t-T); s(t-T)), reused by the first iteration; later samples
    # get it from the commit (a play moved to U is idempotent at U)
    _evaluate(cu, cstart, cr, cW, cG, cs, yhat)
    for t in range(n_samples):
        if lowpass:
            for k in range(m):
                acc = 0.0
                for l in range(p):
                    acc += Kinv[k, l] * yhat[l]
                v[k] = cu[k] - acc
            for k in range(m):
                cvf[k] = a * cvf[k] + (1.0 - a) * v[k]
            for k in range(m):
                acc = 0.0
                for l in range(p):
                    acc += Kinv[k, l] * yr[l, t]
                u[k] = acc + cvf[k]
        else:
            for k in range(m):
                u[k] = cu[k]
            for it in range(iterations):
                if it == 0:
                    for l in range(p):
                        e[l] = yr[l, t] - yhat[l]
                else:
                    _evaluate(u, cstart, cr, cW, cG, cs, yh)
                    for l in range(p):
                        e[l] = yr[l, t] - yh[l]
                for k in range(m):
                    acc = 0.0
                    for l in range(p):
                        acc += Kinv[k, l] * e[l]
                    u[k] += acc
        status = STATUS_OK
        for k in range(m):
            u_out[k, t] = u[k]
            if not np.isfinite(u[k]):
                status = STATUS_NONFINITE
        if status == STATUS_OK:
            for k in range(m):
                if abs(u[k]) > bound:
                    status = STATUS_BOUND
        if status != STATUS_OK:
            return status, t
        _commit(u, cstart, cr, cs)
        _output(u, cW, cG, cs, yhat)
        for k in range(m):
            cu[k] = u[k]
        if run_plant:
            _commit(u, pstart, pr, ps)
            _output(u, pW, pG, ps, h)
            _linear(h, A, B, C, D, x, xn, yt)
            for l in range(pp):
                y_out[l, t] = yt[l]
    return STATUS_OK, n_samples


@njit(cache=True, fastmath=FASTMATH)
def _batch_case(b, yr, lengths, cstart, cr, cW, cG, Kinv, iterations, bound, lowpass, a,
                cu, cvf, cs, pstart, pr, pW, pG, A, B, C, D, ps, x,
                u_out, y_out, status, sample):
    st, sm = chain_kernel(yr[b], lengths[b], cstart[b], cr[b], cW[b], cG[b], Kinv[b],
                          iterations[b], bound[b], lowpass[b], a[b], cu[b], cvf[b], cs[b],
                          True, pstart[b], pr[b], pW[b], pG[b], A[b], B[b], C[b], D[b],
                          ps[b], x[b], u_out[b], y_out[b])
    status[b] = st
    sample[b] = sm


@njit(cache=True, fastmath=FASTMATH)
def chain_batch_serial(yr, lengths, cstart, cr, cW, cG, Kinv, iterations, bound, lowpass, a,
                       cu, cvf, cs, pstart, pr, pW, pG, A, B, C, D, ps, x,
                       u_out, y_out, status, sample):
    """Independent chain cases one after the other (arrays stacked on axis 0)."""
    for b in range(yr.shape[0]):
        _batch_case(b, yr, lengths, cstart, cr, cW, cG, Kinv, iterations, bound, lowpass, a,
                    cu, cvf, cs, pstart, pr, pW, pG, A, B, C, D, ps, x,
                    u_out, y_out, status, sample)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def chain_batch_parallel(order, yr, lengths, cstart, cr, cW, cG, Kinv, iterations, bound,
                         lowpass, a, cu, cvf, cs, pstart, pr, pW, pG, A, B, C, D, ps, x,
                         u_out, y_out, status, sample):
    """Independent chain cases spread over the cores (numba ``prange``).

    ``order`` (n_cases,) lists the cases so that the equal contiguous chunks
    the threads receive hold equal work (see ``simulation._balanced_order``).
    """
    for i in prange(order.size):
        b = order[i]
        _batch_case(b, yr, lengths, cstart, cr, cW, cG, Kinv, iterations, bound, lowpass, a,
                    cu, cvf, cs, pstart, pr, pW, pG, A, B, C, D, ps, x,
                    u_out, y_out, status, sample)


def threads() -> int:
    """Number of threads numba uses for the parallel batch kernel."""
    return numba.get_num_threads()
