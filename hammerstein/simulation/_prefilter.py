"""The chain kernel's reference pre-filter: its plan and its block stepping (compiled).

The pre-filter ``[[C, D], [A, B]]`` (a ZPETC or stable-inversion filter of
the reference, applied ahead of the compensator's law) is split once into
delay lines and dynamic states (:func:`prefilter_plan`); the chain kernel
then filters the reference :data:`~hammerstein.simulation._kernels.PREFILTER_BLOCK`
samples at a time (:func:`_prefilter_block`). Arrays only, as every kernel.
"""

from __future__ import annotations

from __future__ import annotations

import numpy as np
from numba import njit, uint64

from hammerstein.simulation._packing import FASTMATH


@njit(cache=True)
def _prefilter_plan(A, B, C, D):
    """The reference pre-filter ``[[C, D], [A, B]]`` split into delay lines and dynamic states.

    A state whose update is a single entry 1.0 on an input, or on a state
    that is itself a delay of an input, is a *delay state*: it holds input
    ``src`` ``lag`` samples back (``lag`` >= 1), its value is read from the
    reference's history instead of being stepped. Every other state is
    *dynamic* (stepped); so is a second state holding the same input as
    many samples back (its initial value may differ), and whatever copies
    it. The rows that are computed -- the q outputs, then the dynamic
    states' updates -- keep their non-zero entries in column order, split
    where the first dynamic state's entry comes: the *head* before it
    (inputs now, ``lag`` 0, and delay states: known from the reference
    alone) and the *tail* from it on.

    Returns
    -------
    tuple
        ``lag`` (nx,) int64 (0: dynamic), ``src`` (nx,) int64 (the input of
        a delay state), ``dyn`` (nd,) int64 (the dynamic states), ``hist``
        (k, L + 1) int64 (the state holding input l ``d`` samples back, -1
        for none; ``L`` the longest lag); the rows' heads ``sptr`` (q + nd +
        1,), ``sin`` (input), ``slag`` and ``sval``; their tails ``rptr``
        (q + nd + 1,), ``rkind`` (1: a dynamic state, 0: an input or delay
        state), ``rcol`` (the dynamic state's index in ``dyn``, or the
        input), ``rlag`` and ``rval``.
    """
    q = D.shape[0]
    k = D.shape[1]
    nx = A.shape[0]
    one = np.full(nx, -1, dtype=np.int64)      # the column of a row's single entry 1.0
    for i in range(nx):
        cnt = 0
        c = -1
        unit = False
        for j in range(nx + k):
            a = A[i, j] if j < nx else B[i, j - nx]
            if a != 0.0:
                cnt += 1
                c = j
                unit = a == 1.0
        if cnt == 1 and unit:
            one[i] = c
    lag = np.zeros(nx, dtype=np.int64)
    src = np.zeros(nx, dtype=np.int64)
    again = True
    while again:
        lag[:] = 0
        changed = True
        while changed:                        # follow the chains back to an input
            changed = False
            for i in range(nx):
                c = one[i]
                if lag[i] == 0 and c >= 0:
                    if c >= nx:
                        lag[i] = 1
                        src[i] = c - nx
                        changed = True
                    elif lag[c] > 0:
                        lag[i] = lag[c] + 1
                        src[i] = src[c]
                        changed = True
        # one state per (input, lag): a second one may start from another value, so it
        # (and what copies it) is stepped as a dynamic state
        again = False
        for i in range(nx):
            for j in range(i):
                if lag[i] > 0 and lag[j] == lag[i] and src[j] == src[i]:
                    one[i] = -1
                    again = True
    L = 0
    nd = 0
    for i in range(nx):
        L = max(L, lag[i])
        if lag[i] == 0:
            nd += 1
    dyn = np.empty(nd, dtype=np.int64)
    where = np.full(nx, -1, dtype=np.int64)
    hist = np.full((k, L + 1), -1, dtype=np.int64)
    e = 0
    for i in range(nx):
        if lag[i] == 0:
            dyn[e] = i
            where[i] = e
            e += 1
        else:
            hist[src[i], lag[i]] = i
    rows = q + nd
    sptr = np.zeros(rows + 1, dtype=np.int64)
    rptr = np.zeros(rows + 1, dtype=np.int64)
    sin = np.empty(rows * (nx + k), dtype=np.int64)
    slag = np.empty(rows * (nx + k), dtype=np.int64)
    sval = np.empty(rows * (nx + k))
    rkind = np.empty(rows * (nx + k), dtype=np.int64)
    rcol = np.empty(rows * (nx + k), dtype=np.int64)
    rlag = np.empty(rows * (nx + k), dtype=np.int64)
    rval = np.empty(rows * (nx + k))
    ns = 0
    nr = 0
    for w in range(rows):
        tail = False
        for j in range(nx + k):
            if w < q:
                a = C[w, j] if j < nx else D[w, j - nx]
            else:
                a = A[dyn[w - q], j] if j < nx else B[dyn[w - q], j - nx]
            if a == 0.0:
                continue
            static = j >= nx or lag[j] > 0
            tail = tail or not static
            if not tail:                      # before the row's first dynamic state
                sin[ns] = j - nx if j >= nx else src[j]
                slag[ns] = 0 if j >= nx else lag[j]
                sval[ns] = a
                ns += 1
            else:
                rkind[nr] = 0 if static else 1
                rcol[nr] = (j - nx if j >= nx else src[j]) if static else where[j]
                rlag[nr] = (0 if j >= nx else lag[j]) if static else 0
                rval[nr] = a
                nr += 1
        sptr[w + 1] = ns
        rptr[w + 1] = nr
    return lag, src, dyn, hist, sptr, sin, slag, sval, rptr, rkind, rcol, rlag, rval


def prefilter_plan(prefilter):
    """:func:`_prefilter_plan` of a pre-filter, computed in Python (nothing compiled).

    Parameters
    ----------
    prefilter : LinearArrays
        ``A`` (nx, nx), ``B`` (nx, p), ``C`` (p, nx), ``D`` (p, p) of the
        reference pre-filter (:func:`~hammerstein.simulation._packing.identity_filter`
        when there is none).

    Returns
    -------
    tuple
        The plan :func:`chain_kernel` takes: the same arrays, of the same
        types, as the compiled :func:`_prefilter_plan` returns (a structural
        split and copies of the non-zero entries, so the values are equal).
    """
    return _prefilter_plan.py_func(*(np.ascontiguousarray(a, dtype=float) for a in prefilter))


@njit(cache=True, fastmath=FASTMATH)
def _prefilter_block(yr, t0, t1, plan, z, vb, H, S, X):
    """Pre-filter samples ``t0:t1`` of ``yr`` (p, N) into ``vb[:, :t1 - t0]``.

    ``v = C x + D r``, ``x <- A x + B r`` on the split of
    :func:`_prefilter_plan` (``plan``); ``z`` (nx,) is the filter state,
    updated in place to the state after sample ``t1 - 1``; ``H`` (p, L +
    PREFILTER_BLOCK), ``S`` (q + nd, PREFILTER_BLOCK) and ``X`` (nd,
    PREFILTER_BLOCK + 1) are scratch. The reference's last ``L`` samples
    before ``t0`` (the delay states) and the block's samples go into ``H``;
    every computed row (outputs, dynamic states) first sums, for all the
    block's samples at once (one loop over the samples per term:
    vectorised), its terms up to its first dynamic state; then the dynamic
    states are stepped sample by sample (their remaining terms, in column
    order, into ``X``); then the outputs' remaining terms are added, again
    one term at a time over the whole block. Each sample's sums are those of
    the former compressed-row step -- the same non-zero terms, in column
    order, from 0.0 -- so the outputs and states are the same bits
    (inputs and outputs of the 200-frequency Hammerstein sweep bit for bit
    those of the compressed-row step), chunked runs equal one run wherever
    a block starts; a delay state holds the copied value itself (a -0.0
    stays -0.0, where ``0.0 + 1.0 * x`` gave +0.0). Alone, on the ZPETC
    inverse of the bundled 2x2 plant (8 states: 6 delay states, 2 modes; 22
    non-zero entries), 20-22 -> 7.5 ns a sample (min of 7, load ~3): the
    compressed-row step gathered 22 entries a sample; 4 of them remain
    sample by sample. A function of its own called by :func:`chain_kernel`
    (ahead of the law, and to re-step a block up to a diverging sample),
    not inlined.
    """
    lag, src, dyn, hist, sptr, sin, slag, sval, rptr, rkind, rcol, rlag, rval = plan
    p = uint64(yr.shape[0])
    q = uint64(vb.shape[0])
    L = uint64(hist.shape[1] - 1)
    nd = uint64(dyn.size)
    n = uint64(t1 - t0)
    t0 = uint64(t0)
    for l in range(p):
        l = uint64(l)
        for d in range(uint64(1), L + uint64(1)):
            d = uint64(d)
            i = hist[l, d]
            H[l, L - d] = z[uint64(i)] if i >= 0 else 0.0
        for k in range(n):
            k = uint64(k)
            H[l, L + k] = yr[l, t0 + k]
    for w in range(q + nd):
        w = uint64(w)
        for k in range(n):
            k = uint64(k)
            S[w, k] = 0.0
        for m in range(uint64(sptr[w]), uint64(sptr[w + uint64(1)])):
            m = uint64(m)
            a = sval[m]
            l = uint64(sin[m])
            o = L - uint64(slag[m])
            for k in range(n):
                k = uint64(k)
                S[w, k] += a * H[l, o + k]
    for e in range(nd):
        e = uint64(e)
        X[e, 0] = z[uint64(dyn[e])]
    feedback = False          # does a dynamic state's update read a dynamic state?
    for e in range(nd):
        e = uint64(e)
        if rptr[q + e + uint64(1)] > rptr[q + e]:
            feedback = True
    if not feedback:          # no: each state is its row's head, shifted one sample (vectorised)
        for e in range(nd):
            e = uint64(e)
            for k in range(n):
                k = uint64(k)
                X[e, k + uint64(1)] = S[q + e, k]
    for k in range(n if feedback else 0):  # the dynamic states, sample by sample: X[:, k] before sample k
        k = uint64(k)
        for e in range(nd):
            e = uint64(e)
            w = q + e
            a = S[w, k]
            for m in range(uint64(rptr[w]), uint64(rptr[w + uint64(1)])):
                m = uint64(m)
                if rkind[m]:
                    a += rval[m] * X[uint64(rcol[m]), k]
                else:
                    a += rval[m] * H[uint64(rcol[m]), L - uint64(rlag[m]) + k]
            X[e, k + uint64(1)] = a
    for w in range(q):        # then the outputs' remaining terms, in order, over the block
        w = uint64(w)
        for m in range(uint64(rptr[w]), uint64(rptr[w + uint64(1)])):
            m = uint64(m)
            a = rval[m]
            c = uint64(rcol[m])
            if rkind[m]:
                for k in range(n):
                    k = uint64(k)
                    S[w, k] += a * X[c, k]
            else:
                o = L - uint64(rlag[m])
                for k in range(n):
                    k = uint64(k)
                    S[w, k] += a * H[c, o + k]
        for k in range(n):
            k = uint64(k)
            vb[w, k] = S[w, k]
    for e in range(nd):
        e = uint64(e)
        z[uint64(dyn[e])] = X[e, n]
    for i in range(uint64(z.size)):
        i = uint64(i)
        if lag[i] > 0:
            z[i] = H[uint64(src[i]), L + n - uint64(lag[i])]
