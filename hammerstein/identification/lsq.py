"""Linear least squares of the identifications, reduced to their small triangular factor.

Every weight fit of the identifications (classical PI, output map,
Preisach, generalised PI) is a linear least-squares problem on a tall
matrix ``A`` (hundreds of thousands of training rows, tens to hundreds of
columns), some of whose variables are bounded below (non-negative weights,
a monotone slope). Since

``||A x - b||^2 = ||R x - c||^2 + rho^2``   with ``[A | b] = Q [[R, c], [0, rho]]``

(the QR factorisation of the augmented matrix, Golub & Van Loan [1]_ §5.3),
the tall matrix is factored once (:func:`r_factor`, LAPACK ``geqrf``,
without forming Q) and every solve works on the n x n factor. Where many
targets share one matrix (the classical PI's candidate structures and its
output-map alternation), :class:`TallQR` keeps the Householder reflectors
and applies ``Q^T`` to each new target; a fit on a subset S of the
columns then works on ``R[:, S]``, since ``A_S = Q R_S``.

A problem with lower bounds on some variables and the others free
(:func:`bounded_lstsq`) is reduced further: the free variables are
eliminated by a QR factorisation of their columns (the bounded
variables then minimise the part of the residual orthogonal to the free
columns), the bounds are shifted to zero, and what is left is a
non-negative least-squares problem solved by the Lawson-Hanson active set
method [2]_ (:func:`scipy.optimize.nnls`); the free variables follow by
back-substitution. The problem is the same as the one
``scipy.optimize.lsq_linear(..., method="bvls")`` solves (Stark & Parker's
BVLS [3]_), hence the same minimiser when ``A`` has full column rank;
Lawson-Hanson is a compiled loop where BVLS is Python calling a full
least-squares solve per active-set change.

References
----------
.. [1] G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed.,
   Johns Hopkins University Press, 2013.
.. [2] C. L. Lawson and R. J. Hanson, *Solving Least Squares Problems*,
   SIAM, 1995, ch. 23.
.. [3] P. B. Stark and R. L. Parker, "Bounded-variable least-squares: an
   algorithm and applications", *Computational Statistics* 10, 1995.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.linalg.lapack

__all__ = ["r_factor", "TallQR", "bounded_lstsq", "lstsq_bounded_below", "penalized_bounded_lstsq"]

#: Rows of [A | b] factored at a time by :func:`r_factor`.
CHUNK_ROWS = 4096


def r_factor(A, b, groups=None):
    """Triangular factor of the least-squares problem ``min ||A x - b||``.

    Parameters
    ----------
    A : numpy.ndarray, shape (N, n), or list of them
        Regression matrix, or its column blocks (arrays of N rows, 1-D for
        one column) in order: the same factor without stacking them.
    b : numpy.ndarray, shape (N,)
        Target.
    groups : sequence of int, optional
        Row counts of consecutive groups of rows (e.g. records), summing to
        N. The row blocks then never straddle two groups, and the columns of
        ``[A | b]`` constant over a block (an input held still through a
        record, a hysteron that never switches) are factored as one column
        of ones: with ``B = [V, 1 c^T]`` (V the varying columns, c the
        constants), ``[V, 1] = Q [Rv, r1]`` gives ``B = Q [Rv, r1 c^T]``,
        the same factor (to rounding) with a QR of the varying columns only.
        By default the rows are cut every :data:`CHUNK_ROWS` and every column
        factored.

    Returns
    -------
    R : numpy.ndarray, shape (k, n)
        Upper-triangular (trapezoidal when ``N < n``), ``k = min(N, n)``.
    c : numpy.ndarray, shape (k,)
        ``Q^T b`` on the range of ``A``'s factor.
    rho : float
        Norm of the part of ``b`` orthogonal to the columns of ``A``, so that
        ``||A x - b||^2 = ||R x - c||^2 + rho^2`` for every x.

    Raises
    ------
    ValueError
        When ``groups`` are not non-negative row counts summing to N.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> A, b, x = rng.normal(size=(50, 3)), rng.normal(size=50), rng.normal(size=3)
    >>> R, c, rho = r_factor(A, b)
    >>> bool(np.isclose(np.sum((A @ x - b) ** 2), np.sum((R @ x - c) ** 2) + rho ** 2))
    True
    """
    if isinstance(A, (list, tuple)):      # column blocks, never stacked into one tall copy
        blocks = [np.asarray(a, dtype=float).reshape(len(a), -1) for a in A]
    else:
        blocks = [np.asarray(A, dtype=float)]
    b = np.asarray(b, dtype=float)
    N, n = b.shape[0], sum(a.shape[1] for a in blocks)
    edges = np.cumsum([0] + [a.shape[1] for a in blocks])
    # Householder QR block by block (a block of [A | b] fits in the cache), then of the
    # stacked factors: the R of the whole matrix up to the signs of its rows, with
    # Householder's backward stability, about 5x faster than one QR of the tall matrix
    block = max(CHUNK_ROWS, 2 * (n + 1))
    if groups is None:
        cuts = list(range(0, N, block)) + [N]
    else:
        groups = [int(g) for g in groups]
        if any(g < 0 for g in groups) or sum(groups) != N:
            raise ValueError(f"r_factor: groups {groups} do not split the {N} rows")
        cuts = [0]
        for g in groups:
            k = max(1, int(np.ceil(g / block)))      # equal blocks of at most `block` rows
            cuts += [cuts[-1] + int(round(j * g / k)) for j in range(1, k + 1)]
        cuts = sorted(set(cuts))
    parts = []
    buf = np.empty((min(max(np.diff(cuts), default=0), N), n + 1))
    for i, j in zip(cuts[:-1], cuts[1:]):
        rows = j - i
        B = buf[:rows]
        for a, lo, hi in zip(blocks, edges[:-1], edges[1:]):
            B[:, lo:hi] = a[i:j]
        B[:, n] = b[i:j]
        const = np.all(B == B[0], axis=0) if groups is not None else None
        if const is not None and np.count_nonzero(const) > 1:
            var = np.flatnonzero(~const)
            Rn = np.linalg.qr(np.column_stack([B[:, var], np.ones(rows)]), mode="r")
            P = np.empty((Rn.shape[0], n + 1))
            P[:, var] = Rn[:, :var.size]
            P[:, const] = Rn[:, var.size:] * B[0, const]
            parts.append(P)
        else:
            parts.append(np.linalg.qr(B, mode="r"))
    Rb = parts[0] if len(parts) == 1 and groups is None \
        else np.linalg.qr(np.vstack(parts), mode="r")
    k = min(Rb.shape[0], n)
    rho = float(abs(Rb[n, n])) if Rb.shape[0] > n else 0.0
    return Rb[:k, :n], Rb[:k, n].copy(), rho


def _range_basis(M, rtol=1e-12):
    """Orthonormal bases of the range of ``M`` and of its complement, by pivoted QR."""
    Q, Rm, _ = scipy.linalg.qr(M, mode="full", pivoting=True)
    d = np.abs(np.diag(Rm))
    rank = int(np.sum(d > rtol * d[0])) if d.size and d[0] > 0 else 0
    return Q[:, :rank], Q[:, rank:]


def bounded_lstsq(R, c, lower, ridge=0.0):
    """``min ||R x - c||`` subject to ``x >= lower`` (entries ``-inf``: free variables).

    Columns are scaled to unit norm, the free variables eliminated by a
    pivoted QR factorisation of their columns, the bounded ones shifted to
    ``z = x - lower >= 0`` and solved by :func:`scipy.optimize.nnls` on the
    part of the problem orthogonal to the free columns; the free variables
    then by least squares on what is left (see the module notes).

    Parameters
    ----------
    R : numpy.ndarray, shape (k, n)
        Regression matrix, normally the factor of :func:`r_factor`.
    c : numpy.ndarray, shape (k,)
        Target.
    lower : array_like, shape (n,)
        Lower bounds, ``-inf`` for a free variable.
    ridge : float
        ``r`` > 0 adds ``r ||x_s||^2`` (``x_s`` the variables scaled to unit
        column norms) to the objective: a unique minimiser for a
        rank-deficient ``R``, close to the one of least scaled norm.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The minimiser (``x >= lower`` exactly).

    Examples
    --------
    >>> import numpy as np
    >>> R = np.array([[1.0, 0.0], [0.0, 1.0]])
    >>> bounded_lstsq(R, np.array([-1.0, -2.0]), [0.0, -np.inf]).tolist()
    [0.0, -2.0]
    """
    R = np.asarray(R, dtype=float)
    c = np.asarray(c, dtype=float)
    lower = np.asarray(lower, dtype=float)
    n = R.shape[1]
    col = np.linalg.norm(R, axis=0)
    col = np.where(col > 0, col, 1.0)
    Rs = R / col
    if ridge > 0:      # rank-deficient problems: the minimiser of least (scaled) norm
        Rs = np.vstack([Rs, np.sqrt(ridge) * np.eye(n)])
        c = np.concatenate([c, np.zeros(n)])
    lo = lower * col
    bounded = np.isfinite(lo)
    free = ~bounded
    x = np.zeros(n)
    if not bounded.any():
        x = scipy.linalg.lstsq(Rs, c)[0]
        return x / col
    RB = Rs[:, bounded]
    cb = c - RB @ lo[bounded]
    if free.any():
        Q1, Q2 = _range_basis(Rs[:, free])
        M, d = Q2.T @ RB, Q2.T @ cb
    else:
        M, d = RB, cb
    if M.shape[0] == 0:
        z = np.zeros(RB.shape[1])
    else:
        from scipy.optimize import nnls  # lazy: ~0.3 s to import; bounded fits only

        z, _ = nnls(M, d, maxiter=50 * max(M.shape[1], 1))
    x[bounded] = lo[bounded] + z
    if free.any():
        x[free] = scipy.linalg.lstsq(Rs[:, free], cb - RB @ z)[0]
    x /= col
    x[bounded] = np.maximum(x[bounded], lower[bounded])   # the rescaling's last ulp
    return x


def lstsq_bounded_below(A, b, lower):
    """``min ||A x - b||`` subject to ``x >= lower`` on a tall matrix: the factor, then the solve.

    Parameters
    ----------
    A : numpy.ndarray, shape (N, n)
        Regression matrix.
    b : numpy.ndarray, shape (N,)
        Target.
    lower : array_like, shape (n,)
        Lower bounds, ``-inf`` for a free variable.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The minimiser, as :func:`bounded_lstsq` on :func:`r_factor`'s factor.
    """
    R, c, _ = r_factor(A, b)
    return bounded_lstsq(R, c, lower)


def penalized_bounded_lstsq(R, c, D, lam, lower, ridge=0.0):
    """``min ||R x - c||^2 + lam^2 ||D x||^2`` subject to ``x >= lower``, by one QR factorisation.

    The problem of :func:`bounded_lstsq` on the factor of the stacked matrix
    ``[R; lam D]`` (target ``[c; 0]``), with the same column scaling and the
    same ``ridge`` term, solved with one Householder QR instead of three
    factorisations: the columns (scaled to unit norm) are ordered free
    variables first, bounded ones last, and ``[[R, c]; [lam D, 0];
    [sqrt(ridge) I, 0]]`` is reduced to its triangular factor
    ``[[T11, T12, t1]; [0, T22, t2]]``. The free variables minimise the
    first block row exactly for any bounded ones (``T11`` is non-singular
    when ``ridge > 0`` or the free columns have full rank), so the bounded
    variables solve the non-negative least-squares problem on ``(T22,
    t2)`` (:func:`scipy.optimize.nnls`, bounds shifted to zero) and the free
    ones follow by back-substitution. The minimiser is the one of
    :func:`bounded_lstsq` on ``r_factor([R; lam D], [c; 0])`` (unique when
    ``ridge > 0``), to rounding. When ``R`` is square and upper triangular
    with its columns in that order (a data matrix factored free columns
    first), only the rows below it are folded in (LAPACK ``tpqrt``, about
    half the work), and a ``D`` square and upper triangular in that order
    too (the factor of the penalty rows: only ``D^T D`` matters) as a
    triangular block, a fraction of the work again.

    Parameters
    ----------
    R : numpy.ndarray, shape (k, n)
        Regression matrix, normally the factor of :func:`r_factor`.
    c : numpy.ndarray, shape (k,)
        Target.
    D : numpy.ndarray, shape (r, n)
        Penalty rows (``r`` may be 0).
    lam : float
        Penalty weight, ``>= 0``.
    lower : array_like, shape (n,)
        Lower bounds, ``-inf`` for a free variable.
    ridge : float
        ``ridge >= 0`` adds ``ridge ||x_s||^2``, ``x_s`` the variables scaled by
        the column norms of ``[R; lam D]``, as in :func:`bounded_lstsq`.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The minimiser (``x >= lower`` exactly).

    Raises
    ------
    ValueError
        On mismatched shapes, a negative ``lam`` or ``ridge``, or a rank-deficient
        problem without ridge (fewer rows than free variables).

    Examples
    --------
    >>> import numpy as np
    >>> R = np.eye(2)
    >>> x = penalized_bounded_lstsq(R, np.array([-1.0, -2.0]), np.zeros((0, 2)), 0.0,
    ...                             [0.0, -np.inf])
    >>> np.round(x, 12).tolist()
    [0.0, -2.0]
    """
    R = np.asarray(R, dtype=float)
    c = np.asarray(c, dtype=float)
    D = np.asarray(D, dtype=float).reshape(-1, R.shape[1])
    lower = np.asarray(lower, dtype=float)
    k, n = R.shape
    if c.shape != (k,) or lower.shape != (n,):
        raise ValueError(f"penalized_bounded_lstsq: expected c ({k},) and lower ({n},), found "
                         f"{c.shape} and {lower.shape}")
    if not (lam >= 0 and ridge >= 0):
        raise ValueError(f"penalized_bounded_lstsq: lam and ridge must be >= 0, found {lam!r}, "
                         f"{ridge!r}")
    rows = [R, lam * D] if D.shape[0] and lam > 0 else [R]
    col = np.sqrt(sum(np.einsum("ij,ij->j", a, a) for a in rows))
    col = np.where(col > 0, col, 1.0)
    lo = lower * col
    bounded = np.isfinite(lo)
    order = np.r_[np.flatnonzero(~bounded), np.flatnonzero(bounded)]
    nf = n - int(bounded.sum())
    m = sum(a.shape[0] for a in rows)
    Rp = R[:, order]
    if k == n and not np.any(np.tril(Rp, -1)):
        # R triangular in this order (factored free columns first): only the rows below it
        # are folded in, by the triangular-pentagonal QR (LAPACK tpqrt), about half the work
        # of a QR of the whole stack; penalty rows that are themselves a square triangular
        # factor in this order, and the ridge rows (a diagonal), as triangular blocks
        A = np.zeros((n + 1, n + 1), order="F")
        A[:n, :n] = Rp / col[order]
        A[:n, n] = c
        folds = []
        if m > k:
            Dp = rows[1][:, order]
            tri = Dp.shape == (n, n) and not np.any(np.tril(Dp, -1))
            folds.append((Dp / col[order], n if tri else 0))
        if ridge > 0:
            folds.append((np.sqrt(ridge) * np.eye(n), n))
        for Bp, l in folds:
            B = np.zeros((Bp.shape[0], n + 1), order="F")
            B[:, :n] = Bp
            A, _, _, info = scipy.linalg.lapack.dtpqrt(l, min(32, n + 1), A, B, overwrite_a=1,
                                                       overwrite_b=1)
            if info:
                raise ValueError(f"penalized_bounded_lstsq: LAPACK tpqrt failed ({info})")
        T = np.triu(A)
    else:
        S = np.zeros((m + (n if ridge > 0 else 0), n + 1), order="F")
        S[:k, :n] = Rp
        if m > k:
            S[k:m, :n] = rows[1][:, order]
        S[:m, :n] /= col[order]
        S[:k, n] = c
        if ridge > 0:
            S[m + np.arange(n), np.arange(n)] = np.sqrt(ridge)
        if S.shape[0] < n + 1:
            S = np.vstack([S, np.zeros((n + 1 - S.shape[0], n + 1))])
        T = scipy.linalg.qr(S, mode="r", overwrite_a=True, check_finite=False)[0][:n + 1]
    T11, T12, t1 = T[:nf, :nf], T[:nf, nf:n], T[:nf, n]
    if nf and np.min(np.abs(np.diag(T11))) <= 1e-300:
        raise ValueError("penalized_bounded_lstsq: the free variables are not determined "
                         "(rank-deficient; use ridge > 0)")
    lob = lo[order[nf:]]
    z = np.empty(n)
    if n > nf:
        from scipy.optimize import nnls  # lazy: ~0.3 s to import; bounded fits only

        T22, t2 = T[nf:n, nf:n], T[nf:n, n]
        w, _ = nnls(T22, t2 - T22 @ lob, maxiter=50 * (n - nf))
        z[nf:] = lob + w
    if nf:
        z[:nf] = scipy.linalg.solve_triangular(T11, t1 - T12 @ z[nf:], check_finite=False)
    x = np.empty(n)
    x[order] = z / col[order]
    x[bounded] = np.maximum(x[bounded], lower[bounded])   # the rescaling's last ulp
    return x


class TallQR:
    """Householder QR of a tall matrix kept by row blocks, for many targets.

    ``A`` is factored block by block (LAPACK ``geqrf`` on at most
    :data:`CHUNK_ROWS` rows at a time, then on the stacked triangular
    factors: the tall-skinny QR of Demmel et al. [1]_), and the Householder
    reflectors are kept, never formed into Q. :meth:`project` then applies
    ``Q^T`` to a new target (LAPACK ``ormqr``, block by block), so that
    ``||A x - b||^2 = ||R x - c||^2 + rho^2`` for every x, as
    :func:`r_factor` gives for one target. Q^T b costs one pass over the
    reflectors (about ``4 N n`` flops) instead of a factorisation.

    Parameters
    ----------
    A : numpy.ndarray, shape (N, n), or list of them
        Regression matrix with ``N >= n``, or its column blocks (arrays of N
        rows, 1-D for one column) in order.

    Attributes
    ----------
    R : numpy.ndarray, shape (n, n)
        Upper-triangular factor (rows' signs as LAPACK leaves them).

    Raises
    ------
    ValueError
        Fewer rows than columns.

    References
    ----------
    .. [1] J. Demmel, L. Grigori, M. Hoemmen and J. Langou,
       "Communication-optimal parallel and sequential QR and LU
       factorizations", *SIAM J. Sci. Comput.* 34(1), 2012.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> A, b, x = rng.normal(size=(9000, 3)), rng.normal(size=9000), rng.normal(size=3)
    >>> qr = TallQR(A)
    >>> c, rho = qr.project(b)
    >>> bool(np.isclose(np.sum((A @ x - b) ** 2), np.sum((qr.R @ x - c) ** 2) + rho ** 2))
    True
    """

    def __init__(self, A):
        if isinstance(A, (list, tuple)):
            blocks = [np.asarray(a, dtype=float).reshape(len(a), -1) for a in A]
        else:
            blocks = [np.asarray(A, dtype=float)]
        N, n = blocks[0].shape[0], sum(a.shape[1] for a in blocks)
        if N < n:
            raise ValueError(f"A: expected at least as many rows as columns, found {N} x {n}")
        edges = np.cumsum([0] + [a.shape[1] for a in blocks])
        step = max(CHUNK_ROWS, 2 * n)
        starts = list(range(0, N, step))
        if len(starts) > 1 and N - starts[-1] < n:       # every block at least n rows
            starts.pop()
        self._rows = list(zip(starts, starts[1:] + [N]))
        self._n = n
        self._blocks = []
        tops = []
        for lo, hi in self._rows:
            B = np.empty((hi - lo, n), order="F")
            for a, c0, c1 in zip(blocks, edges[:-1], edges[1:]):
                B[:, c0:c1] = a[lo:hi]
            qr, tau, _, info = scipy.linalg.lapack.dgeqrf(B, overwrite_a=True)
            if info != 0:
                raise ValueError(f"A: LAPACK geqrf failed (info {info})")
            self._blocks.append((qr, tau))
            tops.append(np.triu(qr[:n]))
        if len(tops) == 1:
            self._top = None
            self.R = tops[0]
        else:
            qr, tau, _, info = scipy.linalg.lapack.dgeqrf(np.vstack(tops), overwrite_a=True)
            if info != 0:
                raise ValueError(f"A: LAPACK geqrf failed (info {info})")
            self._top = (qr, tau)
            self.R = np.triu(qr[:n])

    @staticmethod
    def _apply(qr, tau, b):
        """``Q^T b`` of one factored block (b: a column vector, not modified)."""
        cq, _, info = scipy.linalg.lapack.dormqr("L", "T", qr, tau, b.reshape(-1, 1).copy(),
                                                 max(1, qr.shape[1]))
        if info != 0:
            raise ValueError(f"b: LAPACK ormqr failed (info {info})")
        return cq[:, 0]

    def project(self, b):
        """``c = Q^T b`` on the range of ``A`` and the norm ``rho`` of the rest.

        Parameters
        ----------
        b : numpy.ndarray, shape (N,)
            Target.

        Returns
        -------
        c : numpy.ndarray, shape (n,)
        rho : float
            ``||A x - b||^2 = ||R x - c||^2 + rho^2`` for every x.

        Raises
        ------
        ValueError
            A target of another length than A's rows.
        """
        b = np.asarray(b, dtype=float)
        if b.shape != (self._rows[-1][1],):
            raise ValueError(f"b: expected shape ({self._rows[-1][1]},), found {b.shape}")
        n, rest, tops = self._n, 0.0, []
        for (lo, hi), (qr, tau) in zip(self._rows, self._blocks):
            cq = self._apply(qr, tau, b[lo:hi])
            tops.append(cq[:n])
            rest += float(cq[n:] @ cq[n:])
        if self._top is None:
            return tops[0].copy(), float(np.sqrt(rest))
        cq = self._apply(*self._top, np.concatenate(tops))
        rest += float(cq[n:] @ cq[n:])
        return cq[:n].copy(), float(np.sqrt(rest))
