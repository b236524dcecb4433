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

Length: the chain kernel is one compiled loop (law, compensator, plant and
their inlined helpers, which numba must see with the kernel's fastmath flags)
and the batch kernel calls it with the same signature, so they stay in one
module; the reference pre-filter's planning and block stepping are in
``_prefilter``.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, uint64
from numba.core import types
from numba.extending import overload

from hammerstein.simulation._packing import (FASTMATH, STATUS_BOUND, STATUS_NONFINITE, STATUS_OK,
                                             ChainState, LawArrays, LinearArrays, PIArrays)
from hammerstein.simulation._prefilter import _prefilter_block, _prefilter_plan, prefilter_plan  # noqa: F401

__all__ = ["play_kernel", "pi_kernel", "plant_kernel", "chain_kernel", "chain_batch",
           "STATUS_OK", "STATUS_NONFINITE", "STATUS_BOUND"]


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


@njit(cache=True)
def inverse_play_kernel(v, r, e, s, u):
    """Inverse play of threshold ``r`` ignoring motions of ``v`` up to ``e``.

    ``u`` (N,) out; ``s`` = [y(-T), d(-T)] in/out: the last output that moved (the
    anchor) and the offset ``u - y``.
    """
    a = s[0]
    d = s[1]
    for t in range(uint64(v.size)):
        t = uint64(t)
        vt = v[t]
        if vt > a + e:
            a = vt
            d = r
        elif vt < a - e:
            a = vt
            d = -r
        u[t] = a + d
    s[0] = a
    s[1] = d


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


#: threshold of the ordering check of :func:`_ordered_plays`, relative to the largest |r| and |s|
ORDER_TOLERANCE = 1e-12


@njit(cache=True, inline="always")
def _ordered_plays(start, r, W, s, k, tol):
    """Number of weighted plays of input k in the order the 2 x 2 law's closed form needs, or -1.

    The plays of input k are ``start[k]:start[k+1]``; trailing plays with no
    weight in any output (the padding of :func:`pack_model`, the zero
    padding of a batch) are left out. Returns their count ``L`` when the
    thresholds are non-decreasing and the play states are ordered as any
    input history leaves them: ``s_j + r_j`` non-decreasing and ``s_j - r_j``
    non-increasing in j (play outputs are 1-Lipschitz in the threshold, and
    a play step on sorted thresholds keeps both orders). Else -1 (play
    states given out of that order). ``tol`` [V] absorbs the rounding of
    the play steps. Runs once per kernel call, before the time loop.
    """
    lo = start[k]
    L = start[k + 1] - lo
    while L > 0:
        used = False
        for l in range(W.shape[0]):
            if W[l, lo + L - 1] != 0.0:
                used = True
        if used:
            break
        L -= 1
    for i in range(1, L):
        j = lo + i
        if (r[j] < r[j - 1] or s[j] + r[j] < s[j - 1] + r[j - 1] - tol
                or s[j] - r[j] > s[j - 1] - r[j - 1] + tol):
            return -1
    return L


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
def _stacked_matrix(A, B, C, D):
    """``M = [[C, D], [A, B]]`` ((q + nx, nx + k)), the state space as one matrix.

    :func:`_linear_stacked` steps it; the chain kernel builds it once per
    call, before its time loop.
    """
    q = D.shape[0]
    k = D.shape[1]
    nx = A.shape[0]
    M = np.empty((q + nx, nx + k))
    for l in range(q):
        for i in range(nx):
            M[l, i] = C[l, i]
        for i in range(k):
            M[l, nx + i] = D[l, i]
    for r in range(nx):
        for i in range(nx):
            M[q + r, i] = A[r, i]
        for i in range(k):
            M[q + r, nx + i] = B[r, i]
    return M


@njit(cache=True, inline="always")
def _linear_stacked(h, M, x, w, y):
    """:func:`_linear` on the stacked matrix ``M`` of :func:`_stacked_matrix`, inlined.

    ``w = M [x; h]``, each row's state terms and input terms in two loops
    as :func:`_linear` sums them (the same loops on the same values: results
    bit for bit those of :func:`_linear`, so the chain's plant part stays
    :func:`plant_kernel`'s), then ``y = w[:q]`` and ``x <- w[q:]`` (``w``
    scratch, ``M``'s rows). For :func:`chain_kernel`'s plant, which formerly
    called :func:`_linear` compiled apart, passing eight array structs a
    call: with the linear step left out the 1 x 1 x 5 chain
    took 19.4 ns a sample against 34.3 ns with it, and :func:`_linear`
    inlined into the chain loop measured ~35 ns more (1 x 1 x 5 34 -> 69 ns,
    2 x 2 x 15 71 -> 101-107, 6 x 6 x 5 200 -> 234; cause not pinned down).
    One matrix, inlined, on ``benchmarks/kernels_vs_c.py``'s chain, best of
    15 alternated, outputs unchanged bit for bit: 1 iteration 1 x 1 x 5
    31.7 -> 22.8 ns, 2 x 2 x 15 69.0 -> 64.0, 3 x 3 x 20 115.0 -> 110.5,
    4 x 4 x 30 187.1 -> 182.8, 6 x 6 x 50 471.9 -> 466.9, 6 x 6 x 5
    202.2 -> 208.5; 3 iterations 1 x 1 x 5 66.7 -> 54.2, 2 x 2 x 15
    95.9 -> 85.8, 6 x 6 x 5 350.0 -> 357.7 (load 5 on 2 cores).
    """
    nx = uint64(x.size)
    k = uint64(M.shape[1]) - nx
    q = uint64(M.shape[0]) - nx
    for r in range(uint64(M.shape[0])):
        r = uint64(r)
        a = 0.0
        for j in range(nx):
            j = uint64(j)
            a += M[r, j] * x[j]
        for j in range(k):
            j = uint64(j)
            a += M[r, nx + j] * h[j]
        w[r] = a
    for l in range(q):
        l = uint64(l)
        y[l] = w[l]
    for i in range(nx):
        i = uint64(i)
        x[i] = w[q + i]


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
def chain_kernel(yr, n_samples, law, comp, plan, slopes, plant, linear, run_plant, state,
                 u_out, y_out):
    """Reference pre-filter -> compensator -> multivariable PI -> linear dynamics, one loop.

    Pre-filter (``law.prefiltered``): ``v = Cf xf + Df Yr(t)``,
    ``xf <- Af xf + Bf Yr(t)``, given as ``plan``, the split of
    :func:`_prefilter_plan` (its delay lines read from the reference, its
    other terms summed a block at a time, :func:`_prefilter_block`);
    else ``v = Yr(t)``; ``plan`` None (no pre-filter) compiles the kernel
    without the pre-filter's code, about 0.6 s less of a cold first run's
    compile. The plan is made by the caller: a single run in
    Python (``_prefilter_plan.py_func``, so that a run without a batch does
    not compile the planner: about 1.4 s of a cold first run), a batch case
    in :func:`_batch_case`. The
    pre-filter does not depend on the law: it runs ahead, ``PREFILTER_BLOCK``
    samples at a time into a scratch block that the law then reads (the
    same operations on the same values as stepping it between the law's
    steps).
    Compensator (delay): from ``U = U(t-T)``, ``iterations`` times
    ``U <- U + K^-1 (v - Gamma(U; s(t-T)))``, then commit the plays (for a
    2 x 2 model the same sums in scalars, U in registers, ``Gamma`` by
    :func:`_gamma2`; results equal the general loops' to rounding).
    Compensator (low-pass): ``w = U(t-T) - K^-1 Gamma(U(t-T))``,
    ``v_f <- a v_f + (1 - a) w``, ``U = K^-1 v + v_f``, then commit.
    Plant (``run_plant``): the step of sample t - 1 (PI then ``linear``, on
    ``U(t-1)``) runs at the top of sample t, ahead of the law's step of
    sample t, which does not depend on it (the last sample's after the
    loop): the same operations on the same values as stepping it after the
    commit of sample t - 1, with the law's chain of dependent evaluations
    next to independent work (on the 200-frequency sweep's kernel, serial,
    2 rounds alternated, medians of 7, load 2.0: hammerstein 115.8/115.5 ->
    112.8/111.7 ns a sample, rate independent 78.3/79.0 -> 76.1/76.9).
    ``slopes`` is None, or for a 2 x 2 law with 2 or 3 iterations and delay
    feedback the table of :func:`~hammerstein.simulation._packing.law_slopes`,
    with which the law runs in closed form where ``Gamma`` is linear around
    ``U(t-T)`` (see the comment in the code): the same law, results equal to
    rounding (the iterations' chain of dependent evaluations becomes one
    product: on the 200-frequency Hammerstein sweep's kernel, 3 iterations
    cost about what 1 does). A None argument compiles the kernel without
    that code (numba prunes the branches), so runs that never use it compile
    less.
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
    # the pre-filter's delay lines and dynamic states; z holds its state (copied back to xf)
    z = np.empty(nf)
    for i in range(nf):
        z[i] = xf[i]
    if plan is not None:        # (a None plan compiles a kernel without the pre-filter)
        fH = np.empty((p, plan[3].shape[1] - 1 + PREFILTER_BLOCK if prefiltered else 0))
        fS = np.empty((p + plan[2].size, PREFILTER_BLOCK if prefiltered else 0))
        fX = np.empty((plan[2].size, PREFILTER_BLOCK + 1))
    h = np.empty(pp)
    yt = np.empty(pp)
    M = _stacked_matrix(A, B, C, D)       # the plant's state space as one matrix
    wx = np.empty(M.shape[0])
    # the delay law of a 2 x 2 model in scalars: ~13 ns a sample less with 3 iterations
    two = m == 2 and p == 2
    k00 = Kinv[0, 0] if two else 0.0
    k01 = Kinv[0, 1] if two else 0.0
    k10 = Kinv[1, 0] if two else 0.0
    k11 = Kinv[1, 1] if two else 0.0
    # Gamma(U(t-T); s(t-T)), reused by the first iteration; later samples
    # get it from the commit (a play moved to U is idempotent at U)
    _evaluate(cu, cstart, cr, cW, cG, cs, yhat)
    # The 2 x 2 delay law in closed form (2 or 3 iterations). After a commit at U, the
    # plays of input k lying at U_k - r (bit for bit as the play step leaves them) follow
    # any rise of U_k; with the orders of _ordered_plays they are a prefix aup[k] of the
    # sorted plays, and the next one starts moving once the rise passes
    # gup[k] = s_j + r_j - U_k (j = aup[k]). Within those gaps Gamma(U + dU) =
    # Gamma(U) + S dU, S[l, k] the prefix's weights plus G[l, k] (sup, read from the
    # table slopes[l, start[k] + k + a]); likewise for a fall (adn, gdn, sdn). The
    # iterations d <- d + K^-1 (e - S d) from d = 0 then are d_i = N_i e, N_1 = K^-1,
    # N_(i+1) = (I - K^-1 S) N_i + K^-1: the law's chain of dependent evaluations
    # becomes one product, valid when every evaluated d_i keeps the directions of S
    # within the gaps (else the iterations run as written). A rise keeps the rising
    # prefix (its plays stay at U - r) and restarts the falling one, a fall the
    # opposite: the prefixes depend on the state alone, so chunked runs equal whole
    # runs. (Written in the loop, not in an inlined helper: a helper taking arrays and
    # branching measured 20-40 ns a sample of reference counting.)
    closed_form = False
    if slopes is not None:      # (a None argument compiles a kernel without any of this)
        closed_form = two and (iterations == 2 or iterations == 3) and not lowpass
        L0 = -1
        L1 = -1
        if closed_form:
            big = 1.0
            for j in range(cr.size):
                big = max(big, abs(cr[j]), abs(cs[j]))
            L0 = _ordered_plays(cstart, cr, cW, cs, 0, ORDER_TOLERANCE * big)
            L1 = _ordered_plays(cstart, cr, cW, cs, 1, ORDER_TOLERANCE * big)
            closed_form = L0 > 0 and L1 > 0
        nL = np.array([L0, L1])
        aup = np.full(2, -1, dtype=np.int64)    # -1: slopes not yet set
        adn = np.full(2, -1, dtype=np.int64)
        gup = np.full(2, -1.0)
        gdn = np.full(2, -1.0)
        sup = np.zeros((2, 2))
        sdn = np.zeros((2, 2))
        ub = np.empty(2 if closed_form else 0)  # U before the last commit (its move's direction)
        for k in range(ub.size):
            ub[k] = cu[k]
    s00, s10, s01, s11 = np.nan, np.nan, np.nan, np.nan
    m200, m201, m210, m211 = 0.0, 0.0, 0.0, 0.0
    m300, m301, m310, m311 = 0.0, 0.0, 0.0, 0.0
    # the pre-filter runs ahead over blocks of PREFILTER_BLOCK samples (its outputs in
    # vb): it does not depend on the law, and its short sparse rows run faster in a
    # loop of their own than between the law's steps; zb keeps its state at the
    # block's start, to give xf its state after a diverging sample
    vb = np.empty((p, PREFILTER_BLOCK if prefiltered else 0))
    zb = np.empty(nf)
    for t in range(n_samples):
        tb = t % PREFILTER_BLOCK
        filtered = False
        if plan is not None:
            if prefiltered:
                if tb == 0:
                    for i in range(nf):
                        zb[i] = z[i]
                    _prefilter_block(yr, t, min(t + PREFILTER_BLOCK, n_samples), plan, z, vb,
                                     fH, fS, fX)
                for l in range(p):
                    ref[l] = vb[l, tb]
                filtered = True
        if not filtered:
            for l in range(p):
                ref[l] = yr[l, t]
        if run_plant and t > 0:
            # the plant's step of sample t - 1 (its input U(t-1) = cu), ahead of the law's
            # step of sample t: the two do not depend on each other, and the law's
            # iterations are a chain of dependent evaluations the plant's work fills
            _commit(cu, pstart, pr, ps)
            _output(cu, pW, pG, ps, h)
            _linear_stacked(h, M, x, wx, yt)
            for l in range(pp):
                y_out[l, t - 1] = yt[l]
        if slopes is not None:
            if closed_form:   # prefixes, gaps, slopes around U(t-T)
                for k in range(2):
                    uk = cu[k]
                    lo = cstart[k]
                    L = nL[k]
                    ia = max(aup[k], 0) if uk >= ub[k] else 0
                    ib = max(adn[k], 0) if uk <= ub[k] else 0
                    while ia < L and cs[lo + ia] == uk - cr[lo + ia]:
                        ia += 1
                    while ib < L and cs[lo + ib] == uk + cr[lo + ib]:
                        ib += 1
                    ju = lo + min(ia, L - 1)
                    jd = lo + min(ib, L - 1)
                    gu = (cs[ju] + cr[ju]) - uk
                    gd = (uk + cr[jd]) - cs[jd]
                    gup[k] = gu if ia < L else np.inf
                    gdn[k] = gd if ib < L else np.inf
                    if ia != aup[k]:         # the slopes change with the prefixes only
                        sup[0, k] = slopes[0, lo + k + ia]
                        sup[1, k] = slopes[1, lo + k + ia]
                        aup[k] = ia
                    if ib != adn[k]:
                        sdn[0, k] = slopes[0, lo + k + ib]
                        sdn[1, k] = slopes[1, lo + k + ib]
                        adn[k] = ib
                    ub[k] = uk
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
            e0 = ref[0] - yhat[0]
            e1 = ref[1] - yhat[1]
            closed = False
            if slopes is not None:
                if closed_form:   # (see above): d_1 = K^-1 e sets the directions
                    f0 = k00 * e0 + k01 * e1
                    f1 = k10 * e0 + k11 * e1
                    up0 = f0 >= 0.0
                    up1 = f1 >= 0.0
                    q00 = sup[0, 0] if up0 else sdn[0, 0]
                    q10 = sup[1, 0] if up0 else sdn[1, 0]
                    q01 = sup[0, 1] if up1 else sdn[0, 1]
                    q11 = sup[1, 1] if up1 else sdn[1, 1]
                    if q00 != s00 or q10 != s10 or q01 != s01 or q11 != s11:
                        s00, s10, s01, s11 = q00, q10, q01, q11
                        a00 = 1.0 - (k00 * q00 + k01 * q10)        # I - K^-1 S
                        a01 = -(k00 * q01 + k01 * q11)
                        a10 = -(k10 * q00 + k11 * q10)
                        a11 = 1.0 - (k10 * q01 + k11 * q11)
                        m200 = (a00 * k00 + a01 * k10) + k00      # N_2
                        m201 = (a00 * k01 + a01 * k11) + k01
                        m210 = (a10 * k00 + a11 * k10) + k10
                        m211 = (a10 * k01 + a11 * k11) + k11
                        m300 = (a00 * m200 + a01 * m210) + k00    # N_3
                        m301 = (a00 * m201 + a01 * m211) + k01
                        m310 = (a10 * m200 + a11 * m210) + k10
                        m311 = (a10 * m201 + a11 * m211) + k11
                    g0 = gup[0] if up0 else gdn[0]
                    g1 = gup[1] if up1 else gdn[1]
                    h0 = m200 * e0 + m201 * e1                   # d_2
                    h1 = m210 * e0 + m211 * e1
                    if iterations == 3:
                        closed = ((abs(f0) <= g0) & (abs(f1) <= g1) & ((h0 >= 0.0) == up0)
                                  & ((h1 >= 0.0) == up1) & (abs(h0) <= g0) & (abs(h1) <= g1))
                        h0 = m300 * e0 + m301 * e1               # d_3
                        h1 = m310 * e0 + m311 * e1
                    else:
                        closed = (abs(f0) <= g0) & (abs(f1) <= g1)
                    u[0] = cu[0] + h0
                    u[1] = cu[1] + h1
            if not closed:
                u0 = cu[0]
                u1 = cu[1]
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
            if plan is not None:
                if prefiltered:
                    for i in range(nf):
                        z[i] = zb[i]
                    _prefilter_block(yr, t - tb, t + 1, plan, z, vb, fH, fS, fX)
            for i in range(nf):
                xf[i] = z[i]
            return status, t
        _commit(u, cstart, cr, cs)
        _output(u, cW, cG, cs, yhat)
        for k in range(m):
            cu[k] = u[k]
    if run_plant and n_samples > 0:   # the plant's step of the last sample
        _commit(cu, pstart, pr, ps)
        _output(cu, pW, pG, ps, h)
        _linear_stacked(h, M, x, wx, yt)
        for l in range(pp):
            y_out[l, n_samples - 1] = yt[l]
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


def _case_plan(prefilter, b):
    """Case b's pre-filter plan (:func:`_prefilter_plan`), or None without pre-filters."""


def _case_slopes(slopes, b):
    """Case b's closed-form law table, or None without tables."""


# Chosen by the argument's type when the calling kernel compiles: a None pre-filter (or
# table) gives a None plan (or table), so chain_batch compiles the one chain_kernel
# specialisation it calls. (An `if prefilter is None:` on an array argument is not pruned
# by numba: both branches, and so every specialisation, would be compiled.)
@overload(_case_plan, jit_options={"cache": True})
def _case_plan_impl(prefilter, b):
    if isinstance(prefilter, types.NoneType):
        return lambda prefilter, b: None

    def plan(prefilter, b):
        Af, Bf, Cf, Df = _case_linear(prefilter, b)
        return _prefilter_plan(Af, Bf, Cf, Df)
    return plan


@overload(_case_slopes, jit_options={"cache": True})
def _case_slopes_impl(slopes, b):
    if isinstance(slopes, types.NoneType):
        return lambda slopes, b: None
    return lambda slopes, b: slopes[b]


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
def _batch_case(b, offsets, yr, law, comp, prefilter, slopes, plant, linear, run_plant, state,
                u_out, y_out, status, sample):
    """Case b of :func:`chain_batch` (its private state copies live in this frame)."""
    p = comp.W.shape[1]
    m = comp.G.shape[2]
    pp = plant.W.shape[1]
    local = _case_state(state, b)
    st, sm = chain_kernel(_record(yr, offsets, b, p), offsets[b + 1] - offsets[b],
                          _case_law(law, b), _case_pi(comp, b), _case_plan(prefilter, b),
                          _case_slopes(slopes, b), _case_pi(plant, b), _case_linear(linear, b),
                          run_plant, local, _record(u_out, offsets, b, m),
                          _record(y_out, offsets, b, pp))
    _store_state(state, b, local)
    status[b] = st
    sample[b] = sm


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def chain_batch(order, offsets, yr, law, comp, prefilter, slopes, plant, linear, run_plant, state,
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

    ``prefilter`` is None when no case has a reference pre-filter (a kernel
    compiled without it). ``slopes`` is None (a kernel compiled without the
    closed-form 2 x 2 law)
    or the cases' :func:`~hammerstein.simulation._packing.law_slopes` tables
    (B, 2, n_cols), zero padded; a case whose law does not take the closed
    form ignores its row.

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
        _batch_case(b, offsets, yr, law, comp, prefilter, slopes, plant, linear, run_plant,
                    state, u_out, y_out, status, sample)


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
