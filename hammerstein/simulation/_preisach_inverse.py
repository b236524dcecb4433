"""Compiled (numba) exact per-sample inverse of a multivariable Preisach / generalised-PI model.

Arrays only; :class:`hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`
packs and validates them. ``preisach_inverse_kernel`` runs, per sample, Gauss-Seidel over
the outputs, each a monotone root of its direct path with the states frozen, then commits
every state (or the inverse multiplicative law). The exported C
(:mod:`hammerstein.export.c_exact`) is this kernel step for step: the same root search,
the same sums in the same order.

Reference counting: every function below but :func:`preisach_inverse_kernel` is
compiled with ``_nrt=False`` (no numba runtime: it neither allocates nor returns an
array). With the runtime, each call took and released a reference to each of its
15-30 array arguments, with atomic operations: on an identified 2 x 2, 30-level
Preisach model (about 50 calls per sample) that was about half the kernel's time,
12.4 -> 6.7 µs per sample. So the allocating kernel only allocates and calls
:func:`_samples`, which runs the loop. The hot loops' indices are cast to uint64
(numba then drops its negative-index wrap-around, as in :mod:`._kernels`): 6.7 -> 5.3 µs.
The arithmetic is the same, bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64

from hammerstein.simulation._preisach import _cell_lists, _clamp, _ramp

__all__ = ["preisach_inverse_kernel", "BRACKET_STEP", "BRACKET_GROWTH", "SECANT_OVERSHOOT",
           "AITKEN_SWEEP"]


# -- exact inverse of a multivariable Preisach model -------------------------------
@njit(cache=True, _nrt=False)
def _component(c, u, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, s):
    """Output of component c at input u from states s (which do not move: :func:`_move` does).

    A component is ramp hysterons ``q_off[c]:q_off[c+1]`` (cells in ``E``) or
    generalised plays ``p_off[c]:p_off[c+1]`` (thresholds ``pr``, weights
    ``pw``, envelopes ``env[c] = gamma_l | gamma_r``), plus a polynomial; its
    states start at ``s[s_off[c]]`` (hysterons, then plays).
    """
    e0 = e_off[c]
    base = s_off[c] - q_off[c]
    acc = 0.0
    for q in range(q_off[c], q_off[c + 1]):
        i = e0 + row[q]
        j = e0 + col[q]
        up = _ramp(u, E[i], E[i + 1])
        down = _ramp(u, E[j], E[j + 1])
        v = s[base + q]
        if v > down:
            v = down
        if v < up:
            v = up
        acc += mu[q] * v
    if p_off[c + 1] > p_off[c]:
        base = s_off[c] + q_off[c + 1] - q_off[c] - p_off[c]
        lo, hi = _envelopes(env, c, u)
        for j in range(p_off[c], p_off[c + 1]):
            acc += pw[j] * _play_state(s[base + j], lo, hi, pr[j])
    poly = 0.0
    for n in range(rev.shape[1] - 1, -1, -1):
        poly = (poly + rev[c, n]) * u
    return acc + poly + off[c]


@njit(cache=True, _nrt=False)
def _move(c, u, E, e_off, row, col, q_off, pr, p_off, env, s_off, s, start, index, moved):
    """Move the states of component c to input u (the commit at a sample's solution).

    Inside u's switching cell i the ramps of the other cells are exactly +1
    (below) or -1 (above). A hysteron whose rising and falling cells both lie
    outside the cells from the last move's (``moved[c]``) to u's has the same
    two ramps as at the last move, where it was clamped already, and clamping
    again changes nothing: only the hysterons moving inside those cells
    (``index[start[g]:start[g + 1]]``, :func:`_cell_lists`) are clamped;
    at the first move (``moved[c] < -1``) those of every cell, which are all
    of them (a hysteron in two cells' lists is clamped twice: the same
    state). The result is that of clamping every hysteron, bit for bit. The
    plays all move.
    """
    if q_off[c + 1] > q_off[c]:
        e0 = e_off[c]
        n = e_off[c + 1] - e0 - 1
        base = s_off[c] - q_off[c]
        i = _cell_of(u, E, e0, n)
        rho = _ramp(u, E[e0 + i], E[e0 + i + 1]) if 0 <= i < n else 0.0
        last = moved[c]
        if last < -1:               # the first move: every cell's hysterons, i.e. all of them
            a, b = 0, n - 1
        else:
            a = max(min(last, i), 0)
            b = min(max(last, i), n - 1)
        for j in range(a, b + 1):
            g = e0 + c + j + 1
            for k in range(start[g], start[g + 1]):
                q = index[k]
                s[base + q] = _moved_state(s[base + q], row[q], col[q], i, rho)
        moved[c] = i
    if p_off[c + 1] > p_off[c]:
        base = s_off[c] + q_off[c + 1] - q_off[c] - p_off[c]
        lo, hi = _envelopes(env, c, u)
        for j in range(p_off[c], p_off[c + 1]):
            s[base + j] = _play_state(s[base + j], lo, hi, pr[j])


@njit(cache=True, _nrt=False)
def _envelopes(env, c, u):
    """The lower and upper envelopes of component c's generalised plays at input u
    (``env[c] = gamma_l | gamma_r``, each ``a tanh(b u + c) + d``)."""
    return (env[c, 0] * np.tanh(env[c, 1] * u + env[c, 2]) + env[c, 3],
            env[c, 4] * np.tanh(env[c, 5] * u + env[c, 6]) + env[c, 7])


@njit(cache=True, _nrt=False)
def _play_state(v, lo, hi, r):
    """A generalised play's state clamped between its envelopes, threshold r apart."""
    if v > hi + r:
        v = hi + r
    if v < lo - r:
        v = lo - r
    return v


@njit(cache=True, _nrt=False)
def _moved_state(v, r, k, i, rho):
    """A hysteron's state clamped between its rising ramp (cell r) and its falling one (cell k)
    at an input in cell i, whose own ramp is rho (other cells: +1 below i, -1 above)."""
    return _clamp(v, rho if r == i else (1.0 if r < i else -1.0),
                  rho if k == i else (1.0 if k < i else -1.0))


@njit(cache=True, _nrt=False)
def _cell_of(u, E, e0, n):
    """Switching cell of ``u`` on a component's grid ``E[e0:e0 + n + 1]``: the number of edges
    ``<= u`` minus one (-1 below the grid, n above it); one cell for every ``u``."""
    i = -1
    for j in range(n + 1):
        if E[uint64(e0 + j)] <= u:
            i = j
    return i


@njit(cache=True, _nrt=False)
def _frozen(c, u, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, s,
            cell, const, start, index, kstart, kindex, fixed, mx, my, mn, mlast):
    """Output of component c at input u, the states s frozen (one sample's root search).

    In u's switching cell i (``_cell_lists``) the hysterons that do not move
    add ``fixed[g]`` plus the kept states ``mu s`` (four sums by position mod
    4, ``(a0 + a1) + (a2 + a3)``), once per sample and cell into
    ``const[c]`` (``cell[c]`` remembers i, -2 for none); the cell's moving
    hysterons are added at u (two sums by position parity), then the plays
    and the polynomial as in ``_component``. The exported C code sums in this
    order. The component's last two values of the sample are kept (``mx``,
    ``my``: (p m, 2); ``mn`` how many, ``mlast`` the slot written last): a
    repeated input returns the value computed before, and the two kept are
    the root's secant (the exported C's memo).
    """
    for k in range(mn[c]):        # the component's last two values in this sample
        if mx[c, k] == u:
            return my[c, k]
    e0 = e_off[c]
    n = e_off[c + 1] - e0 - 1
    base = s_off[c] - q_off[c]
    acc = 0.0
    if q_off[c + 1] > q_off[c]:
        i = _cell_of(u, E, e0, n)
        g = e0 + c + i + 1
        if cell[c] != i:
            a0 = a1 = a2 = a3 = 0.0          # four sums: independent additions
            k0 = kstart[g]
            for k in range(k0, kstart[g + 1]):
                q = kindex[uint64(k)]
                v = s[uint64(base + q)]
                if v > 1.0:
                    v = 1.0
                if v < -1.0:
                    v = -1.0
                w = mu[uint64(q)] * v
                j = (k - k0) & 3
                if j == 0:
                    a0 += w
                elif j == 1:
                    a1 += w
                elif j == 2:
                    a2 += w
                else:
                    a3 += w
            const[c] = fixed[g] + ((a0 + a1) + (a2 + a3))
            cell[c] = i
        acc = const[c]
        if 0 <= i < n:
            rho = _ramp(u, E[e0 + i], E[e0 + i + 1])     # the one ramp not -1 or +1 here
            b0 = b1 = 0.0                                # two sums (position even, odd)
            k0 = start[g]
            for k in range(k0, start[g + 1]):
                q = index[uint64(k)]
                uq = uint64(q)
                up = rho if row[uq] == i else -1.0         # row > i
                down = rho if col[uq] == i else 1.0        # col < i
                v = s[uint64(base + q)]
                if v > down:
                    v = down
                if v < up:
                    v = up
                if (k - k0) & 1:
                    b1 += mu[uq] * v
                else:
                    b0 += mu[uq] * v
            acc += b0 + b1
    # the plays and the polynomial as _component adds them, written out
    # here too: the root search's evaluation makes no call (a numba call with this many arrays
    # costs about as much as a Preisach component's evaluation; inline="always" tripled the
    # compile time)
    if p_off[c + 1] > p_off[c]:
        base = s_off[c] + q_off[c + 1] - q_off[c] - p_off[c]
        lo = env[c, 0] * np.tanh(env[c, 1] * u + env[c, 2]) + env[c, 3]
        hi = env[c, 4] * np.tanh(env[c, 5] * u + env[c, 6]) + env[c, 7]
        for j in range(p_off[c], p_off[c + 1]):
            v = s[base + j]
            if v > hi + pr[j]:
                v = hi + pr[j]
            if v < lo - pr[j]:
                v = lo - pr[j]
            acc += pw[j] * v
    poly = 0.0
    for d in range(rev.shape[1] - 1, -1, -1):
        poly = (poly + rev[c, d]) * u
    y = acc + poly + off[c]
    if mn[c] < 2:                 # kept: a repeated input, and the root's secant
        k = mn[c]
        mn[c] += 1
    else:
        k = 1 - mlast[c]
    mlast[c] = k
    mx[c, k] = u
    my[c, k] = y
    return y


#: First step of the bracket search around the guess, as a fraction of the input range,
#: and its growth factor when the secant cannot guide it: the root moves by ~1e-6-1e-3 of
#: the range between Gauss-Seidel sweeps and samples.
BRACKET_STEP = 1e-5
BRACKET_GROWTH = 16.0
#: The bracket's next probe overshoots the secant's root of its last two probes by this
#: factor (the component is piecewise linear: on one piece the secant's root is the root).
SECANT_OVERSHOOT = 1.02
#: After this Gauss-Seidel sweep (0-based) of a sample, each input is extrapolated once from
#: its last three sweeps (Aitken's delta-squared: the sweeps of a coupled 2 x 2 model contract
#: by a nearly constant factor, about 0.03 on the outside actuators' models).
AITKEN_SWEEP = 2


@njit(cache=True, _nrt=False)
def _root(c, target, guess, lo, hi, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off,
          rev, off, s, tol, cell, const, start, index, kstart, kindex, fixed, mx, my, mn, mlast):
    """u in [lo, hi] with component c = target (Illinois false position; clipped).

    The component is non-decreasing in u. First a Newton probe on the secant of
    the component's last two values in the sample (``_frozen``; on one linear
    piece of the component it is the root); then the root is bracketed from
    ``guess`` (the current estimate: the previous sweep's or sample's input),
    or from the probe when it fell on the guess's side, by steps from
    ``BRACKET_STEP (hi - lo)``, each to the secant root of the last two probes
    overshot by ``SECANT_OVERSHOOT`` (``BRACKET_GROWTH`` times the last step
    when that is not larger), up to the bound, which is returned when the
    target is out of reach there (as from a bracket of the whole range); then
    Illinois false position inside the bracket, to ``|f| <= tol`` or a
    bracket of 1e-13 relative.
    """
    x = min(max(guess, lo), hi)
    fx = _frozen(c, x, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, s,
               cell, const, start, index, kstart, kindex, fixed, mx, my, mn, mlast) - target
    if abs(fx) <= tol:
        return x
    bracketed = False
    a = fa = b = fb = 0.0
    if mn[c] == 2 and mx[c, 0] != mx[c, 1]:
        slope = (my[c, 1] - my[c, 0]) / (mx[c, 1] - mx[c, 0])
        if slope > 0.0:
            z = min(max(x - fx / slope, lo), hi)
            if z != x:
                fz = _frozen(c, z, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev,
                           off, s, cell, const, start, index, kstart, kindex, fixed, mx, my,
                           mn, mlast) - target
                if abs(fz) <= tol:
                    return z
                if (fz < 0.0) == (fx < 0.0):      # on the guess's side: bracket on from there
                    x, fx = z, fz
                else:
                    bracketed = True
                    if z > x:
                        a, fa, b, fb = x, fx, z, fz
                    else:
                        a, fa, b, fb = z, fz, x, fx
    if not bracketed:
        step = BRACKET_STEP * (hi - lo)
        if fx < 0.0:                       # the root is above x
            a, fa = x, fx
            while True:
                b = x + step
                if b >= hi:
                    b = hi
                    fb = _frozen(c, hi, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off,
                               rev, off, s, cell, const, start, index, kstart, kindex, fixed,
                               mx, my, mn, mlast) - target
                    if fb <= 0.0:
                        return hi
                    break
                fb = _frozen(c, b, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev,
                           off, s, cell, const, start, index, kstart, kindex, fixed, mx, my,
                           mn, mlast) - target
                if fb >= 0.0:
                    break
                grown = step * BRACKET_GROWTH
                if fb > fa:
                    sec = (b - x) + (b - a) * (-fb) / (fb - fa) * SECANT_OVERSHOOT
                    step = sec if sec > step else grown
                else:
                    step = grown
                a, fa = b, fb
        else:                              # the root is below x
            b, fb = x, fx
            while True:
                a = x - step
                if a <= lo:
                    a = lo
                    fa = _frozen(c, lo, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off,
                               rev, off, s, cell, const, start, index, kstart, kindex, fixed,
                               mx, my, mn, mlast) - target
                    if fa >= 0.0:
                        return lo
                    break
                fa = _frozen(c, a, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev,
                           off, s, cell, const, start, index, kstart, kindex, fixed, mx, my,
                           mn, mlast) - target
                if fa <= 0.0:
                    break
                grown = step * BRACKET_GROWTH
                if fb > fa:
                    sec = (x - a) + (b - a) * fa / (fb - fa) * SECANT_OVERSHOOT
                    step = sec if sec > step else grown
                else:
                    step = grown
                b, fb = a, fa
        if abs(fa) <= tol:
            return a
        if abs(fb) <= tol:
            return b
    side = 0
    for _ in range(200):
        x = (a * fb - b * fa) / (fb - fa)
        if not (a < x < b):
            x = 0.5 * (a + b)
        fx = _frozen(c, x, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, s,
                   cell, const, start, index, kstart, kindex, fixed, mx, my, mn, mlast) - target
        if abs(fx) <= tol or b - a <= 1e-13 * (1.0 + abs(x)):
            return x
        if fx < 0.0:
            a, fa = x, fx
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = x, fx
            if side == 1:
                fa *= 0.5
            side = 1
    return x


@njit(cache=True, _nrt=False)
def _samples(yr, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off,
             present, s, lo, hi, exact, K_inv, u, tol, max_sweeps, ut, g, start,
             index, kstart, kindex, fixed, cell, const, mx, my, mn, mlast, moved,
             h0, h1, h2):
    """:func:`preisach_inverse_kernel`'s loop over the samples, on the arrays it allocated.

    Everything that :func:`preisach_inverse_kernel` allocates is passed in (``ut``,
    ``g``, the cell lists, the memo and the Aitken history): compiled without the
    reference counting of numba's runtime (``_nrt=False``, see the module
    docstring). Returns the number of samples whose sweeps did not converge.
    """
    p, N = yr.shape
    m = p
    unconverged = 0
    for t in range(N):
        if exact:
            for c in range(p * m):
                cell[c] = -2           # the states moved: no cell summed yet, no value kept
                mn[c] = 0
                mlast[c] = 0
            converged = False
            omega = 1.0
            for rnd in range(5):        # plain sweeps; if they cycle, under-relaxed ones
                for sweep in range(max_sweeps):
                    delta = 0.0
                    for l in range(p):
                        target = yr[l, t]
                        for k in range(m):
                            c = l * m + k
                            if k != l and present[c]:
                                target -= _frozen(c, ut[k], E, e_off, row, col, mu, q_off, pr,
                                                pw, p_off, env, s_off, rev, off, s, cell, const,
                                                start, index, kstart, kindex, fixed, mx, my, mn,
                                                mlast)
                        new = _root(l * m + l, target, ut[l], lo[l], hi[l], E, e_off, row, col,
                                    mu, q_off, pr, pw, p_off, env, s_off, rev, off, s, tol, cell,
                                    const, start, index, kstart, kindex, fixed, mx, my, mn, mlast)
                        if abs(new - ut[l]) > delta:
                            delta = abs(new - ut[l])
                        ut[l] = new if omega == 1.0 else ut[l] + omega * (new - ut[l])
                    if delta <= 1e-11:
                        converged = True
                        break
                    if rnd == 0:        # Aitken's extrapolation, once, from the last three sweeps
                        for k in range(m):
                            h2[k] = h1[k]
                            h1[k] = h0[k]
                            h0[k] = ut[k]
                        if sweep == AITKEN_SWEEP:
                            for k in range(m):
                                d1 = h0[k] - h1[k]
                                d0 = h1[k] - h2[k]
                                if d1 != d0 and abs(d1) < abs(d0):
                                    ua = h0[k] - d1 * d1 / (d1 - d0)
                                    if lo[k] < ua < hi[k]:
                                        ut[k] = ua
                if converged:
                    break
                omega *= 0.5
            if not converged:
                unconverged += 1
        else:
            for l in range(p):
                g[l] = 0.0
                for k in range(m):
                    c = l * m + k
                    if present[c]:
                        g[l] += _component(c, ut[k], E, e_off, row, col, mu, q_off, pr, pw, p_off,
                                           env, s_off, rev, off, s)
            for k in range(m):
                a = ut[k]
                for l in range(p):
                    a += K_inv[k, l] * (yr[l, t] - g[l])
                ut[k] = min(max(a, lo[k]), hi[k])
        for l in range(p):
            for k in range(m):
                c = l * m + k
                if present[c]:
                    _move(c, ut[k], E, e_off, row, col, q_off, pr, p_off, env, s_off, s, start,
                          index, moved)
        for k in range(m):
            u[k, t] = ut[k]
    return unconverged


@njit(cache=True)
def preisach_inverse_kernel(yr, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off,
                            present, s, lo, hi, exact, K_inv, u_prev, u, tol, max_sweeps):
    """Inputs u (m, N) that make the model follow yr (p = m, N); states s, u_prev in/out.

    ``exact``: per sample, Gauss-Seidel over the outputs, each a monotone
    scalar root of its direct path (cross-couplings at the current estimate),
    then every state committed at the solution; after the sweep
    ``AITKEN_SWEEP`` of the first round each input is extrapolated once
    (Aitken's delta-squared from its last three sweeps, kept when it contracts
    and stays inside the bounds); sweeps that do not settle in
    ``max_sweeps`` (a cycle where a direct path is nearly flat against a
    cross-coupling) are repeated under-relaxed, ``u += omega (root - u)`` with
    omega = 1/2, 1/4, 1/8, 1/16. During the sweeps the states are frozen and
    each component is evaluated by ``_frozen`` (per switching cell: the
    hysterons that do not move summed once, then the cell's own; the same
    function as ``_component``, summed in another order). Otherwise the
    inverse multiplicative law ``u_t = u_{t-1} + K^-1 (yr_t - Gamma(u_{t-1}))``.
    Returns the number of samples whose sweeps did not converge.
    """
    p, N = yr.shape
    m = p
    ut = np.empty(m)
    g = np.empty(p)
    unconverged = 0
    for k in range(m):
        ut[k] = u_prev[k]
    start, index, kstart, kindex, fixed = _cell_lists(e_off, row, col, mu, q_off)
    cell = np.empty(p * m, np.int64)
    const = np.empty(p * m)
    mx = np.zeros((p * m, 2))
    my = np.zeros((p * m, 2))
    mn = np.zeros(p * m, np.int64)
    mlast = np.zeros(p * m, np.int64)
    moved = np.full(p * m, -2, np.int64)    # no move yet in this call: the first moves every state
    h0 = np.empty(m)
    h1 = np.empty(m)
    h2 = np.empty(m)
    unconverged = _samples(yr, E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off,
                           present, s, lo, hi, exact, K_inv, u, tol, max_sweeps, ut, g, start,
                           index, kstart, kindex, fixed, cell, const, mx, my, mn, mlast, moved,
                           h0, h1, h2)
    for k in range(m):
        u_prev[k] = ut[k]
    return unconverged
