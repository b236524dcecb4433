"""Compiled (numba) stepping kernels of the plants outside the classical PI class.

Arrays only; the wrappers in :mod:`hammerstein.models.preisach`,
:mod:`hammerstein.models.generalized_pi` and :mod:`hammerstein.models.creep`
validate the arguments. States are updated in place, so a chunked run equals
one long run. The numpy oracles of these loops live in the tests
(``tests/core/test_preisach.py``).

``ramp_preisach_kernel(u, edges, row, col, mu, s, y)``
    Discrete Preisach model with ramp hysterons. The switching grid has the
    cell edges ``edges`` (n_levels + 1,) [V]; hysteron ``q`` rises over cell
    ``row[q]`` (its alpha cell) and falls over cell ``col[q]`` (its beta
    cell, ``col <= row``), with state ``s[q]`` in [-1, 1] and weight
    ``mu[q]`` [µm]: ``s <- max(rho_row(u), min(rho_col(u), s))``, where
    ``rho_i(u)`` is -1 below cell i, +1 above it, linear across it. The
    output (without the reversible part) is ``y[t] = sum_q mu[q] s[q]``.
``ramp_preisach_states_kernel(u, edges, row, col, s, out)``
    The same hysterons, every state after every sample: ``out[t, q]`` (the
    regressors of a Preisach identification, all hysterons in one pass over
    the record).
``generalized_play_kernel(u, r, w, gl, gr, s, y)``
    Generalised PI (Al Janaideh, Rakheja and Su): plays
    ``s_j <- max(gamma_l(u) - r_j, min(gamma_r(u) + r_j, s_j))`` with the
    envelopes ``gamma(u) = a0 tanh(a1 u + a2) + a3``; ``y[t] = sum_j w_j s_j``.
``linear_kernel(h, A, B, C, D, x, y)``
    Discrete state space on a record: ``y = C x + D h``, ``x <- A x + B h``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["ramp_preisach_kernel", "ramp_preisach_states_kernel", "preisach_states", "generalized_play_kernel", "linear_kernel", "ramps",
           "preisach_steps", "linear_steps", "generalized_play_steps", "generalized_play_states"]


@njit(cache=True, inline="always")
def _ramp(u, lo, hi):
    """-1 below ``lo``, +1 above ``hi``, linear in between."""
    if u <= lo:
        return -1.0
    if u >= hi:
        return 1.0
    return 2.0 * (u - lo) / (hi - lo) - 1.0


@njit(cache=True, inline="always")
def _clamp(v, up, down):
    """A hysteron's next state ``max(up, min(down, v))`` (``down`` tested first)."""
    if v > down:
        v = down
    if v < up:
        v = up
    return v


@njit(cache=True)
def ramps(u, edges, rho):
    """Ramp value of every grid cell at input ``u`` (``rho`` (n_levels,) out)."""
    for i in range(rho.size):
        rho[i] = _ramp(u, edges[i], edges[i + 1])


#: Fewer hysterons than this many per level: every hysteron is stepped every sample
#: (a regressor's single hysteron, a small cross-coupling), else the cell lists.
CELL_LISTS_PER_LEVEL = 2


@njit(cache=True)
def ramp_preisach_kernel(u, edges, row, col, mu, s, y):
    """Ramp-hysteron Preisach model on a record (see the module docstring).

    Inside switching cell i (``edges[i] <= u < edges[i + 1]``) only the
    hysterons whose rising or falling cell is i move: the others are +1
    (``row < i``), -1 (``col > i``) or keep their state (``col < i <
    row``). So, with at least ``CELL_LISTS_PER_LEVEL`` hysterons per level,
    a sample that stays in the cell of the previous one steps the ~n_levels
    moving hysterons only, and their sum is added to the sum of the others,
    taken once when the input entered the cell; a sample in another cell
    steps every hysteron, as the plain loop does. The output is the same
    function of the states; the sums are grouped differently (the
    non-moving hysterons first, each group in ascending order), so it
    differs from one sum over every hysteron in the last digits, and a
    record cut into chunks gives the same numbers bit for bit (the
    non-moving states do not change inside a cell). A sample equal to the
    previous one repeats its output: the clamps are idempotent (``up <=
    down``), so no state would move and the sum would be the same one.
    """
    n_levels = edges.size - 1
    nq = s.size
    if nq >= CELL_LISTS_PER_LEVEL * n_levels and n_levels > 0:
        _cell_list_steps(u, edges, row, col, mu, s, y)
        return
    rho = np.empty(n_levels)
    for t in range(u.size):
        ut = u[t]
        if t > 0 and ut == u[t - 1]:     # the same clamps again: no state moves
            y[t] = y[t - 1]
            continue
        for i in range(n_levels):
            rho[i] = _ramp(ut, edges[i], edges[i + 1])
        acc = 0.0
        for q in range(nq):
            v = _clamp(s[q], rho[row[q]], rho[col[q]])
            s[q] = v
            acc += mu[q] * v
        y[t] = acc


@njit(cache=True)
def _cell_list_steps(u, edges, row, col, mu, s, y):
    """:func:`ramp_preisach_kernel` by switching cells (see there); s, y in/out."""
    n = edges.size - 1
    nq = s.size
    # one component: the moving hysterons of cell c (-1..n) are index[start[c + 1]:start[c + 2]]
    start, index, _, _, _ = _cell_lists(np.array([0, n + 1]), row, col, mu, np.array([0, nq]))
    rho = np.empty(n)
    cell = -2                     # no cell yet: the first sample steps every hysteron
    const = 0.0
    for t in range(u.size):
        ut = u[t]
        if t > 0 and ut == u[t - 1]:     # the same cell and clamps again: no state moves
            y[t] = y[t - 1]
            continue
        c = -1 if cell == -2 else cell
        while c + 1 <= n and edges[c + 1] <= ut:
            c += 1
        while c >= 0 and edges[c] > ut:
            c -= 1
        if c != cell:             # into another cell: every hysteron, then the fixed sum
            for i in range(n):
                rho[i] = _ramp(ut, edges[i], edges[i + 1])
            const = 0.0
            for q in range(nq):
                v = _clamp(s[q], rho[row[q]], rho[col[q]])
                s[q] = v
                if row[q] != c and col[q] != c:
                    const += mu[q] * v
            cell = c
        acc = 0.0
        if 0 <= c < n:
            rc = _ramp(ut, edges[c], edges[c + 1])
            for k in range(start[c + 1], start[c + 2]):
                q = index[k]
                v = _clamp(s[q], rc if row[q] == c else -1.0,    # row > c
                           rc if col[q] == c else 1.0)           # col < c
                s[q] = v
                acc += mu[q] * v
        y[t] = const + acc


@njit(cache=True)
def ramp_preisach_states_kernel(u, edges, row, col, s, out):
    """Every ramp hysteron's state after every sample, ``out`` (n_samples, n_hysterons); s in/out.

    Per sample the ramps of all cells once, then each hysteron's clamp
    ``max(rho_row, min(rho_col, s))`` as in :func:`ramp_preisach_kernel`'s
    plain loop: the states are those of stepping each hysteron alone.
    """
    n_levels = edges.size - 1
    nq = s.size
    rho = np.empty(n_levels)
    for t in range(u.size):
        ut = u[t]
        for i in range(n_levels):
            rho[i] = _ramp(ut, edges[i], edges[i + 1])
        for q in range(nq):
            v = _clamp(s[q], rho[row[q]], rho[col[q]])
            s[q] = v
            out[t, q] = v


@njit(cache=True, inline="always")
def _envelope(a, u):
    return a[0] * np.tanh(a[1] * u + a[2]) + a[3]


@njit(cache=True)
def generalized_play_kernel(u, r, w, gl, gr, s, y):
    """Generalised-PI plays under envelope functions (see the module docstring)."""
    nr = r.size
    for t in range(u.size):
        lo = _envelope(gl, u[t])
        hi = _envelope(gr, u[t])
        acc = 0.0
        for j in range(nr):
            v = s[j]
            if v > hi + r[j]:
                v = hi + r[j]
            if v < lo - r[j]:
                v = lo - r[j]
            s[j] = v
            acc += w[j] * v
        y[t] = acc


@njit(cache=True)
def generalized_play_states_kernel(u, r, gl, gr, s, out):
    """Every play's trajectory ``out`` (n_samples, n) under the envelopes; ``s`` in/out."""
    nr = r.size
    for t in range(u.size):
        lo = _envelope(gl, u[t])
        hi = _envelope(gr, u[t])
        for j in range(nr):
            v = s[j]
            if v > hi + r[j]:
                v = hi + r[j]
            if v < lo - r[j]:
                v = lo - r[j]
            s[j] = v
            out[t, j] = v


@njit(cache=True)
def linear_kernel(h, A, B, C, D, x, y):
    """Discrete state space on a record; ``x`` in/out, ``y`` (q, N) out."""
    nx = x.size
    q, k = D.shape
    xn = np.empty(nx)
    for t in range(h.shape[1]):
        for l in range(q):
            a = 0.0
            for i in range(nx):
                a += C[l, i] * x[i]
            for i in range(k):
                a += D[l, i] * h[i, t]
            y[l, t] = a
        for i in range(nx):
            a = 0.0
            for j in range(nx):
                a += A[i, j] * x[j]
            for j in range(k):
                a += B[i, j] * h[j, t]
            xn[i] = a
        for i in range(nx):
            x[i] = xn[i]


def preisach_steps(u, edges, row, col, mu, state):
    """Ramp-hysteron Preisach model on validated arrays (compiled kernel).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    edges : numpy.ndarray, shape (n_levels + 1,)
        Cell edges of the switching grid [V], strictly increasing.
    row, col : numpy.ndarray of int64, shape (n_hysterons,)
        Rising (alpha) and falling (beta) cell of each hysteron, ``col <= row``.
    mu : numpy.ndarray, shape (n_hysterons,)
        Weights [µm].
    state : numpy.ndarray, shape (n_hysterons,)
        Hysteron states in [-1, 1]; not modified.

    Returns
    -------
    y : numpy.ndarray, shape (n_samples,)
        ``sum_q mu_q s_q`` per sample [µm].
    final_state : numpy.ndarray, shape (n_hysterons,)
        States after the last sample.
    """
    s = np.array(state, dtype=float)
    y = np.empty(u.size)
    ramp_preisach_kernel(np.ascontiguousarray(u, dtype=float), edges, row, col, mu, s, y)
    return y, s


def preisach_states(u, edges, row, col, state):
    """State trajectory of every ramp hysteron of a grid on a record (compiled kernel).

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Input [V], finite.
    edges : array_like, shape (n_levels + 1,)
        Cell edges of the switching grid [V], strictly increasing.
    row, col : array_like of int, shape (n_hysterons,)
        Rising (alpha) and falling (beta) cell of each hysteron, ``0 <= col <= row < n_levels``.
    state : array_like, shape (n_hysterons,)
        Hysteron states in [-1, 1] before the first sample; not modified.

    Returns
    -------
    states : numpy.ndarray, shape (n_samples, n_hysterons)
        ``states[t, q]``: state of hysteron q after sample t, in [-1, 1] (the
        same numbers as :func:`preisach_steps` on hysteron q alone).
    final_state : numpy.ndarray, shape (n_hysterons,)
        States after the last sample.

    Raises
    ------
    ValueError
        On mismatched shapes, edges not strictly increasing, cells outside the grid,
        ``col > row`` or a non-finite input.

    Examples
    --------
    >>> import numpy as np
    >>> st, _ = preisach_states(np.array([0.0, 1.0, 0.5]), np.array([-1.0, 0.0, 1.0]),
    ...                         np.array([1, 1]), np.array([0, 1]), np.array([-1.0, -1.0]))
    >>> st.tolist()
    [[-1.0, -1.0], [1.0, 1.0], [1.0, 0.0]]
    """
    u = np.ascontiguousarray(u, dtype=float)
    edges = np.ascontiguousarray(edges, dtype=float)
    row = np.ascontiguousarray(row, dtype=np.int64)
    col = np.ascontiguousarray(col, dtype=np.int64)
    s = np.array(state, dtype=float)
    n = edges.size - 1
    if u.ndim != 1 or edges.ndim != 1 or n < 1 or row.ndim != 1 or row.shape != col.shape \
            or s.shape != row.shape:
        raise ValueError("preisach_states: expected u (N,), edges (n + 1,) with n >= 1, and "
                         "row, col, state of one shape (n_hysterons,)")
    if not np.all(np.diff(edges) > 0):
        raise ValueError("preisach_states: edges must be strictly increasing")
    if row.size and (col.min() < 0 or row.max() >= n or np.any(col > row)):
        raise ValueError("preisach_states: expected 0 <= col <= row < n_levels")
    if not np.all(np.isfinite(u)):
        raise ValueError("preisach_states: the input must be finite")
    out = np.empty((u.size, s.size))
    ramp_preisach_states_kernel(u, edges, row, col, s, out)
    return out, s


def linear_steps(h, matrices, state):
    """Discrete state space ``(A, B, C, D)`` on a record (compiled kernel).

    Parameters
    ----------
    h : numpy.ndarray, shape (k, n_samples)
        Inputs of the linear system.
    matrices : tuple of numpy.ndarray
        ``A`` (n, n), ``B`` (n, k), ``C`` (q, n), ``D`` (q, k).
    state : numpy.ndarray, shape (n,)
        State before the first sample; not modified.

    Returns
    -------
    y : numpy.ndarray, shape (q, n_samples)
        Outputs.
    final_state : numpy.ndarray, shape (n,)
        State after the last sample.
    """
    A, B, C, D = (np.ascontiguousarray(m, dtype=float) for m in matrices)
    x = np.array(state, dtype=float)
    y = np.empty((D.shape[0], h.shape[1]))
    linear_kernel(np.ascontiguousarray(h, dtype=float), A, B, C, D, x, y)
    return y, x


def generalized_play_steps(u, thresholds, weights, gamma_l, gamma_r, state):
    """Generalised-PI plays under envelope functions on validated arrays (compiled kernel).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    thresholds, weights : numpy.ndarray, shape (n,)
        Play thresholds [V] and weights [µm/V].
    gamma_l, gamma_r : numpy.ndarray, shape (4,)
        Envelope coefficients ``a0 tanh(a1 u + a2) + a3``, rising and falling input.
    state : numpy.ndarray, shape (n,)
        Play outputs before the first sample; not modified.

    Returns
    -------
    y : numpy.ndarray, shape (n_samples,)
        ``sum_j w_j s_j`` per sample [µm].
    final_state : numpy.ndarray, shape (n,)
        Play outputs after the last sample.
    """
    s = np.array(state, dtype=float)
    y = np.empty(u.size)
    generalized_play_kernel(np.ascontiguousarray(u, dtype=float), thresholds, weights,
                            gamma_l, gamma_r, s, y)
    return y, s


def generalized_play_states(u, thresholds, gamma_l, gamma_r, state):
    """Trajectory of every generalised play on validated arrays (compiled kernel).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    thresholds : numpy.ndarray, shape (n,)
        Play thresholds [V].
    gamma_l, gamma_r : numpy.ndarray, shape (4,)
        Envelope coefficients ``a0 tanh(a1 u + a2) + a3``, rising and falling input.
    state : numpy.ndarray, shape (n,)
        Play outputs before the first sample; not modified.

    Returns
    -------
    states : numpy.ndarray, shape (n_samples, n)
        Play outputs after each sample.
    final_state : numpy.ndarray, shape (n,)
        Play outputs after the last sample.
    """
    s = np.array(state, dtype=float)
    out = np.empty((u.size, s.size))
    generalized_play_states_kernel(np.ascontiguousarray(u, dtype=float),
                                   np.ascontiguousarray(thresholds, dtype=float),
                                   np.ascontiguousarray(gamma_l, dtype=float),
                                   np.ascontiguousarray(gamma_r, dtype=float), s, out)
    return out, s


@njit(cache=True)
def _cell_lists(e_off, row, col, mu, q_off):
    """Which hysterons move, and which keep their state, inside each switching cell.

    Cell i of component c (i = -1 below its grid, ``0 .. n-1`` across it, n
    above it) is the global cell ``g = e_off[c] + c + i + 1``. Inside cell i
    the ramps of the other cells are exactly +1 (below) or -1 (above): a
    hysteron with ``row < i`` is +1, one with ``col > i`` is -1, one with
    ``col < i < row`` keeps its state, and only those with ``row == i`` or
    ``col == i`` move with the input.

    Parameters
    ----------
    e_off : numpy.ndarray of int64, shape (n_components + 1,)
        Offsets of each component's cell edges (``n + 1`` edges each).
    row, col : numpy.ndarray of int64, shape (n_hysterons,)
        Rising and falling cell of each hysteron (within its component).
    mu : numpy.ndarray, shape (n_hysterons,)
        Hysteron weights [µm].
    q_off : numpy.ndarray of int64, shape (n_components + 1,)
        Offsets of each component's hysterons.

    Returns
    -------
    start, index : numpy.ndarray of int64
        The moving hysterons of cell g: ``index[start[g]:start[g + 1]]``
        (ascending); ``start`` has ``e_off[-1] + n_components + 1`` entries.
    kstart, kindex : numpy.ndarray of int64
        The hysterons that keep their state in cell g, likewise.
    fixed : numpy.ndarray, shape (e_off[-1] + n_components,)
        ``sum_{row < i} mu - sum_{col > i} mu`` of each cell [µm] (ascending q).
    """
    nc = e_off.size - 1
    ncell = e_off[nc] + nc
    start = np.zeros(ncell + 1, np.int64)
    kstart = np.zeros(ncell + 1, np.int64)
    fixed = np.zeros(ncell)
    for c in range(nc):
        n = e_off[c + 1] - e_off[c] - 1
        for i in range(-1, n + 1):
            g = e_off[c] + c + i + 1
            a = 0.0
            b = 0.0
            for q in range(q_off[c], q_off[c + 1]):
                if row[q] == i or col[q] == i:
                    start[g + 1] += 1
                elif col[q] < i < row[q]:
                    kstart[g + 1] += 1
                elif row[q] < i:
                    a += mu[q]
                else:
                    b += mu[q]
            fixed[g] = a - b
    for g in range(ncell):
        start[g + 1] += start[g]
        kstart[g + 1] += kstart[g]
    index = np.empty(start[ncell], np.int64)
    kindex = np.empty(kstart[ncell], np.int64)
    for c in range(nc):
        n = e_off[c + 1] - e_off[c] - 1
        for i in range(-1, n + 1):
            g = e_off[c] + c + i + 1
            k = start[g]
            j = kstart[g]
            for q in range(q_off[c], q_off[c + 1]):
                if row[q] == i or col[q] == i:
                    index[k] = q
                    k += 1
                elif col[q] < i < row[q]:
                    kindex[j] = q
                    j += 1
    return start, index, kstart, kindex, fixed
