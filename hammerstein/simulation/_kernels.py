"""Compiled (numba) stepping kernels of the simulation core.

Low-level loops only: they take packed float/int arrays, update the states
in place and never allocate per sample. :mod:`hammerstein.simulation` packs
the models, validates the arguments, and keeps the plain numpy loops that
serve as the test oracle of these kernels (``_oracle``).

Arguments are a few named tuples of arrays (:mod:`._packing`), which numba
passes as structs:

``PIArrays(start, r, W, G)``, a packed multivariable PI model
    ``start`` (m + 1,) int64: the *unique* play operators driven by input k
    are ``start[k]:start[k+1]`` (hysterons of several outputs sharing input,
    threshold and initial state are one play operator, Def. 3.2 of the
    paper: they evolve identically); ``r`` (n_plays,) thresholds [V]; ``W``
    (p, n_plays) weight of each play in each output [µm/V]; ``G`` (p, m)
    pure linear components [µm/V].
``LinearArrays(A, B, C, D)``
    Discrete state space (bending modes; reference pre-filter).
``LawArrays(K_inv, iterations, bound, lowpass, pole, prefiltered)``
    The compensator law.
``ChainState(cu, cvf, cs, xf, ps, x)``
    States of a chain run, updated in place.

The batch kernel (:func:`chain_batch`) takes the same structures with a
leading case axis on every field, and the records ragged: one flat buffer
with per-case offsets, no padding to the longest case. Numba compiles each
kernel on its first call (``cache=True``: once per machine, then loaded from
the on-disk cache), so a run compiles only the kernels it uses; the batch
kernel calls :func:`chain_kernel` with the signature of a single run, so
the two share one compiled chain loop.

Status codes returned by the chain kernels: 0 ok, 1 non-finite input voltage,
2 input voltage beyond the divergence bound.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, uint64

from hammerstein.simulation._packing import (STATUS_BOUND, STATUS_NONFINITE, STATUS_OK, ChainState,
                                             LawArrays, LinearArrays, PIArrays)

__all__ = ["play_kernel", "pi_kernel", "plant_kernel", "chain_kernel", "chain_batch",
           "STATUS_OK", "STATUS_NONFINITE", "STATUS_BOUND"]

# fastmath={'reassoc'} only: lets LLVM vectorise the weighted sums (summation
# order changes, ~1e-15 relative; tests check 1e-9 against the numpy oracle).
# No 'nnan'/'ninf': the divergence checks need exact non-finite semantics;
# no 'contract' (FMA): an identity pre-filter stays exact.
# The helpers are inlined by numba (inline='always') and take these flags
# from the kernel that calls them.
FASTMATH = {"reassoc"}

#: samples of reference pre-filtered ahead of the law in the chain kernel
PREFILTER_BLOCK = 256

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
    for k in range(uint64(start.size - 1)):
        k = uint64(k)
        uk = u[k]
        for j in range(uint64(start[k]), uint64(start[k + 1])):
            j = uint64(j)
            s[j] = _play(s[j], uk, r[j])


@njit(cache=True, inline="always")
def _output(u, W, G, s, y):
    """``y = W s + G u`` (eq. (4)), one output at a time.

    Two-dimensional indexing with unsigned indices, no row views: the
    former ``W[l]`` views and outputs taken in pairs measured 35-40 ns more
    per sample inside the plant and chain loops (a view costs a reference
    count and an array struct at every sample). Same sums in the same order.
    """
    p = uint64(W.shape[0])
    n = uint64(W.shape[1])
    m = uint64(G.shape[1])
    for l in range(p):
        l = uint64(l)
        a0 = 0.0
        for j in range(n):
            j = uint64(j)
            a0 += W[l, j] * s[j]
        for k in range(m):
            k = uint64(k)
            a0 += G[l, k] * u[k]
        y[l] = a0


@njit(cache=True, inline="always")
def _moved_pair(u, start, r, W, G, s, l, l1):
    """Outputs ``l`` and ``l1`` of ``Gamma(u; s)``, the plays moved to ``u`` but not stored.

    One pass over the plays: each play moved to ``u`` (in a register; ``s``
    is not written) is added, weighted, to both outputs; each input's plays
    are summed apart and then added (independent reductions instead of one
    chain through all the inputs); then ``G u``.
    Returns ``(y_l, y_l1)``. With ``l1 == l`` it is one output (computed twice).
    """
    a0 = 0.0
    a1 = 0.0
    for k in range(uint64(start.size - 1)):
        k = uint64(k)
        uk = u[k]
        b0 = 0.0
        b1 = 0.0
        for j in range(uint64(start[k]), uint64(start[k + 1])):
            j = uint64(j)
            vj = _play(s[j], uk, r[j])
            b0 += W[l, j] * vj
            b1 += W[l1, j] * vj
        a0 += b0
        a1 += b1
    for k in range(uint64(G.shape[1])):
        k = uint64(k)
        a0 += G[l, k] * u[k]
        a1 += G[l1, k] * u[k]
    return a0, a1


@njit(cache=True, inline="always")
def _gamma2(u0, u1, start, r, W, G, s):
    """``Gamma(u; s)`` of a 2-input, 2-output model, ``u = (u0, u1)`` in registers.

    The plays of each input summed apart (two independent reductions), then
    ``G u`` summed apart and added last: returns ``(y0, y1)``. The chain
    kernel's 2 x 2 law re-evaluates with it, U kept in registers: with 3
    iterations ~10 ns a sample less than :func:`_moved_pair` on U in memory
    (the 200-frequency Hammerstein sweep's kernel, serial, 130-132 -> 119-123
    ns a sample, load 0.8). The same terms as :func:`_moved_pair`, grouped
    otherwise: results move by rounding only (bit for bit the same on that
    sweep, whose model weights no play of one input in the other output).
    """
    a0 = 0.0
    a1 = 0.0
    for j in range(uint64(start[0]), uint64(start[1])):
        j = uint64(j)
        vj = _play(s[j], u0, r[j])
        a0 += W[0, j] * vj
        a1 += W[1, j] * vj
    b0 = 0.0
    b1 = 0.0
    for j in range(uint64(start[1]), uint64(start[2])):
        j = uint64(j)
        vj = _play(s[j], u1, r[j])
        b0 += W[0, j] * vj
        b1 += W[1, j] * vj
    g0 = G[0, 0] * u0 + G[0, 1] * u1
    g1 = G[1, 0] * u0 + G[1, 1] * u1
    return (a0 + b0) + g0, (a1 + b1) + g1


@njit(cache=True, inline="always")
def _evaluate(u, start, r, W, G, s, y):
    """``y = Gamma(u; s)`` without moving the plays (frozen states).

    Outputs in pairs (:func:`_moved_pair`: one pass over the plays per pair,
    the moved plays kept in registers); an odd last output pairs with
    itself. Measured on the bundled 2x2 model (2 x 16 packed plays), per
    call: 10-11 ns against 21 ns for the former two loops (the moved plays
    stored into a scratch vector, then ``y = W v + G u`` read them back).
    The law's iterations 2 and 3 of a Hammerstein sample are two such calls.
    Each output sums the same terms in the same order (its plays, then
    ``G u``), regrouped only by the vectorisation (``fastmath``
    reassociation): results move by rounding only. The pairs run in a
    ``while`` loop: a ``range`` with a step of 2 around the pass stopped
    LLVM vectorising it (82 ns a call).
    """
    p = W.shape[0]
    l = 0
    while l < p:
        l1 = l + 1 if l + 1 < p else l
        a0, a1 = _moved_pair(u, start, r, W, G, s, uint64(l), uint64(l1))
        y[l] = a0
        y[l1] = a1
        l += 2


@njit(cache=True, fastmath=FASTMATH)
def pi_kernel(u, pi, s, y):
    """Multivariable PI forward model: ``u`` (m, N) -> ``y`` (p, N); ``s`` in/out.

    ``pi`` is a :class:`PIArrays`.

    The play updates of each input are one contiguous, vectorised loop; each
    play is updated once however many outputs it feeds (``W`` columns).
    The bodies of :func:`_commit` and :func:`_output` are written out here on
    purpose: calling them with the column views ``u[:, t]`` and ``y[:, t]``
    measured 0.62-0.99 ns per hysteron update against 0.42-0.51 ns inline
    (the 0.6 ns target of the benchmark).
    """
    start, r, W, G = pi
    m, N = u.shape
    p, n = W.shape
    for t in range(N):
        for k in range(m):
            uk = u[k, t]
            for j in range(uint64(start[k]), uint64(start[k + 1])):
                j = uint64(j)
                s[j] = _play(s[j], uk, r[j])
        for l in range(0, p - 1, 2):          # outputs in pairs share the loads of s
            a0 = 0.0
            a1 = 0.0
            for j in range(uint64(n)):
                j = uint64(j)
                a0 += W[l, j] * s[j]
                a1 += W[l + 1, j] * s[j]
            for k in range(m):
                a0 += G[l, k] * u[k, t]
                a1 += G[l + 1, k] * u[k, t]
            y[l, t] = a0
            y[l + 1, t] = a1
        if p % 2:
            a0 = 0.0
            for j in range(uint64(n)):
                j = uint64(j)
                a0 += W[p - 1, j] * s[j]
            for k in range(m):
                a0 += G[p - 1, k] * u[k, t]
            y[p - 1, t] = a0


@njit(cache=True, inline="always")
def _linear(h, A, B, C, D, x, xn, y):
    """``y = C x + D h``; ``x <- A x + B h`` (discrete state update).

    Takes the matrices, not a ``LinearArrays``: the kernels unpack their
    named tuples once, before the time loop. Unsigned indices throughout
    (no negative-index wrap-around): with signed ones this step measured
    ~40 ns a sample for two states, against ~5 ns.
    """
    q = uint64(D.shape[0])
    k = uint64(D.shape[1])
    nx = uint64(x.size)
    for l in range(q):
        l = uint64(l)
        a = 0.0
        for i in range(nx):
            i = uint64(i)
            a += C[l, i] * x[i]
        for i in range(k):
            i = uint64(i)
            a += D[l, i] * h[i]
        y[l] = a
    for i in range(nx):
        i = uint64(i)
        a = 0.0
        for j in range(nx):
            j = uint64(j)
            a += A[i, j] * x[j]
        for j in range(k):
            j = uint64(j)
            a += B[i, j] * h[j]
        xn[i] = a
    for i in range(nx):
        i = uint64(i)
        x[i] = xn[i]


@njit(cache=True, inline="always")
def _sparse_rows(A, B, C, D):
    """The non-zero entries of ``[[C, D], [A, B]]``, row by row (compressed rows).

    Row l < q is output l, row q + i the update of state i; column j < nx
    is state j, column nx + k input k. Returns ``(ptr, col, val)``: row l's
    entries are ``col[ptr[l]:ptr[l+1]]`` and ``val[...]``, in column order.
    """
    q = D.shape[0]
    k = D.shape[1]
    nx = A.shape[0]
    ptr = np.zeros(q + nx + 1, dtype=np.int64)
    col = np.empty((q + nx) * (nx + k), dtype=np.int64)
    val = np.empty((q + nx) * (nx + k))
    n = 0
    for l in range(q + nx):
        for j in range(nx + k):
            if l < q:
                a = C[l, j] if j < nx else D[l, j - nx]
            else:
                a = A[l - q, j] if j < nx else B[l - q, j - nx]
            if a != 0.0:
                col[n] = j
                val[n] = a
                n += 1
        ptr[l + 1] = n
    return ptr, col, val


@njit(cache=True, inline="always")
def _sparse_linear(ptr, col, val, q, z, zn, y):
    """:func:`_linear` on the non-zero entries of :func:`_sparse_rows`.

    ``z`` (nx + k,) holds the state then the input ``h``; ``y = C x + D h``,
    and the new state ``A x + B h`` goes to ``zn[:nx]`` (``z`` is not
    written: the caller alternates two buffers instead of copying back).
    The reference pre-filter of a Hammerstein compensator (the ZPETC inverse
    of G: a shift register of past reference samples and a few mode
    states) has 22 non-zero entries of 100 on the bundled 2x2 plant; summed
    in column order they differ from the dense sums by rounding only.
    """
    nx = uint64(ptr.size - 1) - uint64(q)
    for l in range(uint64(q)):
        l = uint64(l)
        a = 0.0
        for n in range(uint64(ptr[l]), uint64(ptr[l + 1])):
            n = uint64(n)
            a += val[n] * z[uint64(col[n])]
        y[l] = a
    for i in range(nx):
        i = uint64(i)
        a = 0.0
        for n in range(uint64(ptr[uint64(q) + i]), uint64(ptr[uint64(q) + i + 1])):
            n = uint64(n)
            a += val[n] * z[uint64(col[n])]
        zn[i] = a


@njit(cache=True, fastmath=FASTMATH)
def _prefilter_block(yr, t0, t1, ptr, col, val, z, zn, vb):
    """Pre-filter samples ``t0:t1`` of ``yr`` (p, N) into ``vb[:, :t1 - t0]`` (:func:`_sparse_linear`).

    ``z`` holds the filter state then room for p inputs (the state is
    updated in place; ``zn`` is unused, kept for the signature). Samples
    go in pairs, the state alternating between ``z`` and a second buffer
    (no copy back of the state at every sample: 27 -> 23 ns a sample, best
    of 7, for the bundled plant's 8 states filtered alone; 1-2 ms of ~95 in
    the 200-frequency sweep's kernel). A function of its own called by
    :func:`chain_kernel` (ahead of the law, and to re-step a block up to a
    diverging sample), not inlined: two inlined copies measured ~0.5 s more
    compile CPU.
    """
    p = yr.shape[0]
    nf = z.size - p
    v = np.empty(p)
    z2 = np.empty(z.size)
    t = t0
    while t + 1 < t1:
        for l in range(p):
            z[nf + l] = yr[l, t]
        _sparse_linear(ptr, col, val, p, z, z2, v)
        for l in range(p):
            vb[l, t - t0] = v[l]
        for l in range(p):
            z2[nf + l] = yr[l, t + 1]
        _sparse_linear(ptr, col, val, p, z2, z, v)
        for l in range(p):
            vb[l, t + 1 - t0] = v[l]
        t += 2
    if t < t1:
        for l in range(p):
            z[nf + l] = yr[l, t]
        _sparse_linear(ptr, col, val, p, z, z2, v)
        for l in range(p):
            vb[l, t - t0] = v[l]
        for i in range(nf):
            z[i] = z2[i]


@njit(cache=True, fastmath=FASTMATH)
def _linear_step(h, A, B, C, D, x, xn, y):
    """:func:`_linear` as a compiled function of its own, for :func:`chain_kernel`'s plant.

    Inlined into the chain loop, the plant's linear step measured ~40 ns a
    sample more (chain with 1 iteration, 1 x 1 x 5: 76 -> 36 ns, best of 7;
    2 x 2 x 15: 113 -> 76 ns; C reference 34 and 75 ns) although the same
    step inlined into :func:`plant_kernel` costs ~5 ns; called, it costs a
    call. The same loops with the same flags: results unchanged.
    """
    _linear(h, A, B, C, D, x, xn, y)


@njit(cache=True, fastmath=FASTMATH)
def plant_kernel(u, pi, s, lin, x, y):
    """Hammerstein plant: PI (``PIArrays``) then linear part (``LinearArrays``).

    ``s`` (plays) and ``x`` (linear state) in/out, ``y`` (p, N) out.
    """
    start, r, W, G = pi
    A, B, C, D = lin
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
def chain_kernel(yr, n_samples, law, comp, prefilter, plant, linear, run_plant, state,
                 u_out, y_out):
    """Reference pre-filter -> compensator -> multivariable PI -> linear dynamics, one loop.

    Pre-filter (``law.prefiltered``): ``v = Cf xf + Df Yr(t)``,
    ``xf <- Af xf + Bf Yr(t)`` (``prefilter`` a ``LinearArrays``, stepped on
    its non-zero entries, :func:`_sparse_linear`); else ``v = Yr(t)``. The
    pre-filter does not depend on the law: it runs ahead, ``PREFILTER_BLOCK``
    samples at a time into a scratch block that the law then reads (the
    same operations on the same values as stepping it between the law's
    steps; on the 200-frequency Hammerstein sweep ~9 ms less of ~120 ms of
    kernel CPU: its short sparse rows pipeline better in a loop of their own).
    Compensator (delay): from ``U = U(t-T)``, ``iterations`` times
    ``U <- U + K^-1 (v - Gamma(U; s(t-T)))``, then commit the plays (for a
    2 x 2 model the same sums in scalars, U in registers, ``Gamma`` by
    :func:`_gamma2`; results equal the general loops' to rounding).
    Compensator (low-pass): ``w = U(t-T) - K^-1 Gamma(U(t-T))``,
    ``v_f <- a v_f + (1 - a) w``, ``U = K^-1 v + v_f``, then commit.
    ``comp`` and ``plant`` are ``PIArrays``, ``linear`` the plant's
    ``LinearArrays`` (used when ``run_plant``), ``law`` a ``LawArrays``.
    The ``state`` fields (``ChainState``) are updated in place up to the
    last valid sample.

    Returns
    -------
    (status, sample) : (int, int)
        ``status`` 0, or 1/2 with the diverging sample (``u_out[:, sample]``
        then holds the offending U, outputs stop before it).
    """
    Kinv = law.K_inv
    iterations = law.iterations
    bound = law.bound
    lowpass = law.lowpass
    a = law.pole
    prefiltered = law.prefiltered
    cstart, cr, cW, cG = comp
    pstart, pr, pW, pG = plant
    Af, Bf, Cf, Df = prefilter
    A, B, C, D = linear
    cu, cvf, cs, xf, ps, x = state
    m = cG.shape[1]
    p = cW.shape[0]
    pp = pW.shape[0]
    u = np.empty(m)
    e = np.empty(p)
    yh = np.empty(p)
    yhat = np.empty(p)
    v = np.empty(m)
    ref = np.empty(p)
    nf = xf.size
    # the pre-filter on its non-zero entries; z holds its state then yr(t) (copied back to xf)
    fptr, fcol, fval = _sparse_rows(Af, Bf, Cf, Df)
    z = np.empty(nf + p)
    for i in range(nf):
        z[i] = xf[i]
    zn = np.empty(nf)
    h = np.empty(pp)
    yt = np.empty(pp)
    xn = np.empty(x.size)
    # the delay law of a 2 x 2 model in scalars: ~13 ns a sample less with 3 iterations
    two = m == 2 and p == 2
    k00 = Kinv[0, 0] if two else 0.0
    k01 = Kinv[0, 1] if two else 0.0
    k10 = Kinv[1, 0] if two else 0.0
    k11 = Kinv[1, 1] if two else 0.0
    # Gamma(U(t-T); s(t-T)), reused by the first iteration; later samples
    # get it from the commit (a play moved to U is idempotent at U)
    _evaluate(cu, cstart, cr, cW, cG, cs, yhat)
    # the pre-filter runs ahead over blocks of PREFILTER_BLOCK samples (its outputs in
    # vb): it does not depend on the law, and its short sparse rows run faster in a
    # loop of their own than between the law's steps; zb keeps its state at the
    # block's start, to give xf its state after a diverging sample
    vb = np.empty((p, PREFILTER_BLOCK if prefiltered else 0))
    zb = np.empty(nf)
    for t in range(n_samples):
        tb = t % PREFILTER_BLOCK
        if prefiltered:
            if tb == 0:
                for i in range(nf):
                    zb[i] = z[i]
                _prefilter_block(yr, t, min(t + PREFILTER_BLOCK, n_samples), fptr, fcol, fval,
                                 z, zn, vb)
            for l in range(p):
                ref[l] = vb[l, tb]
        else:
            for l in range(p):
                ref[l] = yr[l, t]
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
                    acc += Kinv[k, l] * ref[l]
                u[k] = acc + cvf[k]
        elif two:      # 2 inputs, 2 outputs: the same sums, in scalars (registers)
            u0 = cu[0]
            u1 = cu[1]
            y0 = yhat[0]
            y1 = yhat[1]
            for it in range(iterations):
                if it > 0:
                    y0, y1 = _gamma2(u0, u1, cstart, cr, cW, cG, cs)
                e0 = ref[0] - y0
                e1 = ref[1] - y1
                u0 += k00 * e0 + k01 * e1
                u1 += k10 * e0 + k11 * e1
            u[0] = u0
            u[1] = u1
        else:
            for k in range(m):
                u[k] = cu[k]
            for it in range(iterations):
                if it == 0:
                    for l in range(p):
                        e[l] = ref[l] - yhat[l]
                else:
                    _evaluate(u, cstart, cr, cW, cG, cs, yh)
                    for l in range(p):
                        e[l] = ref[l] - yh[l]
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
        if status != STATUS_OK:       # the pre-filter's state after sample t
            if prefiltered:
                for i in range(nf):
                    z[i] = zb[i]
                _prefilter_block(yr, t - tb, t + 1, fptr, fcol, fval, z, zn, vb)
            for i in range(nf):
                xf[i] = z[i]
            return status, t
        _commit(u, cstart, cr, cs)
        _output(u, cW, cG, cs, yhat)
        for k in range(m):
            cu[k] = u[k]
        if run_plant:
            _commit(u, pstart, pr, ps)
            _output(u, pW, pG, ps, h)
            _linear_step(h, A, B, C, D, x, xn, yt)
            for l in range(pp):
                y_out[l, t] = yt[l]
    for i in range(nf):
        xf[i] = z[i]
    return STATUS_OK, n_samples


# -- batches: ragged records, every other structure with a leading case axis ----------
@njit(cache=True, inline="always")
def _case_pi(pi, b):
    return PIArrays(pi.start[b], pi.r[b], pi.W[b], pi.G[b])


@njit(cache=True, inline="always")
def _case_linear(lin, b):
    return LinearArrays(lin.A[b], lin.B[b], lin.C[b], lin.D[b])


@njit(cache=True, inline="always")
def _case_law(law, b):
    return LawArrays(law.K_inv[b], law.iterations[b], law.bound[b], law.lowpass[b],
                     law.pole[b], law.prefiltered[b])


@njit(cache=True, inline="always")
def _case_state(st, b):
    """Copies of case b's states, private to the thread that runs it.

    The state rows of neighbouring cases share cache lines (``cu`` is 16
    bytes a case); updated in place at every sample by two threads, they
    would bounce between the cores (false sharing).
    """
    return ChainState(st.cu[b].copy(), st.cvf[b].copy(), st.cs[b].copy(), st.xf[b].copy(),
                      st.ps[b].copy(), st.x[b].copy())


@njit(cache=True, inline="always")
def _store_state(st, b, local):
    """Case b's states back from the thread's copies."""
    for k in range(local.cu.size):
        st.cu[b, k] = local.cu[k]
        st.cvf[b, k] = local.cvf[k]
    for k in range(local.cs.size):
        st.cs[b, k] = local.cs[k]
    for k in range(local.xf.size):
        st.xf[b, k] = local.xf[k]
    for k in range(local.ps.size):
        st.ps[b, k] = local.ps[k]
    for k in range(local.x.size):
        st.x[b, k] = local.x[k]


@njit(cache=True, inline="always")
def _record(flat, offsets, b, rows):
    """Case b's (rows, n_b) record: a C-contiguous view of the ragged ``flat`` buffer."""
    a = offsets[b]
    n = offsets[b + 1] - a
    return flat[rows * a:rows * (a + n)].reshape((rows, n))


@njit(cache=True, fastmath=FASTMATH)
def _batch_case(b, offsets, yr, law, comp, prefilter, plant, linear, run_plant, state,
                u_out, y_out, status, sample):
    """Case b of :func:`chain_batch` (its private state copies live in this frame)."""
    p = comp.W.shape[1]
    m = comp.G.shape[2]
    pp = plant.W.shape[1]
    local = _case_state(state, b)
    st, sm = chain_kernel(_record(yr, offsets, b, p), offsets[b + 1] - offsets[b],
                          _case_law(law, b), _case_pi(comp, b), _case_linear(prefilter, b),
                          _case_pi(plant, b), _case_linear(linear, b), run_plant, local,
                          _record(u_out, offsets, b, m), _record(y_out, offsets, b, pp))
    _store_state(state, b, local)
    status[b] = st
    sample[b] = sm


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def chain_batch(order, offsets, yr, law, comp, prefilter, plant, linear, run_plant, state,
                u_out, y_out, status, sample, worker, thread):
    """Independent chain cases ``order`` (n_cases,) int64, one after the other, without the GIL.

    Records are ragged, not padded: case b's reference is the C-contiguous
    block ``yr[p * offsets[b] : p * offsets[b+1]]`` viewed as (p, n_b), and
    likewise its inputs in ``u_out`` (m rows) and outputs in ``y_out``
    (plant outputs rows); ``offsets`` (n_cases + 1,) int64 are cumulative
    sample counts. The other structures (``LawArrays``, ``PIArrays``,
    ``LinearArrays``, ``ChainState``) carry a leading case axis, zero padded
    to the largest model (zero thresholds, weights and states add exact
    zeros); each case steps a private copy of its states, stored back at
    the end. Each case is :func:`chain_kernel` with the very signature of a
    single run (one compiled loop serves both, so batches equal single runs
    bit for bit).

    ``order`` may be any subset of the cases: the caller runs disjoint
    subsets on several Python threads at once (``nogil``; see
    ``_stepping.simulate_chain_batch``), which compiles in a fraction of the
    time of a numba ``parallel=True`` kernel (measured 7.6 s cold for the
    former ``prange`` version). ``worker`` (n_cases,) int64 receives
    ``thread`` for each case run.
    """
    for i in range(order.size):
        b = order[i]
        worker[b] = thread
        _batch_case(b, offsets, yr, law, comp, prefilter, plant, linear, run_plant, state,
                    u_out, y_out, status, sample)


def threads() -> int:
    """Number of threads of a parallel batch (``numba.get_num_threads()``).

    Returns
    -------
    int
    """
    return numba.get_num_threads()


def set_threads(n: int) -> None:
    """Set the number of threads of a parallel batch (numba's setting, this Python thread only).

    Parameters
    ----------
    n : int
        1 ... ``numba.config.NUMBA_NUM_THREADS``.
    """
    numba.set_num_threads(n)
