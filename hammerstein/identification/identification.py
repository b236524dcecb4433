"""Identification of classical and multivariable Prandtl-Ishlinskii models.

Two monovariable methods, as estimator objects in the style of pysindy /
scikit-learn (``fit`` returns ``self``; fitted attributes end in ``_``):

* :class:`ClosedFormPI`, the closed form of the paper's Appendix (eq. 14-17,
  docs/identification.md): a triangular solve on the shifted ascending branch;
* :class:`LeastSquaresPI`, least squares over the whole record (the paper's
  ref. [18], docs/identification.md): the play outputs for fixed thresholds form a linear
  regressor matrix.

:class:`MultivariableIdentifier` applies either method to every component
``Gamma_lk`` of a multivariable model from records in which one input is
excited at a time (Steps 1-4 of Section 3.3). :func:`fit_report` measures the
fit of a model on a record.

References
----------
.. [1] M. Rakotondrabe, "Multivariable classical Prandtl-Ishlinskii hysteresis
   modeling and compensation and sensorless control of a nonlinear 2-dof
   piezoactuator", Section 3.3, Remark 5.1 and Appendix.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from hammerstein.models.hysteresis import (HysteresisError, MultivariablePI, PrandtlIshlinskii, play,
                                        validate_thresholds)
from hammerstein.identification.lsq import bounded_lstsq, lstsq_bounded_below, r_factor
from hammerstein.exceptions import IdentificationError

__all__ = [
    "IdentificationError",
    "ClosedFormPI",
    "LeastSquaresPI",
    "MultivariableIdentifier",
    "ascending_branches",
    "partition_thresholds",
    "fit_report",
]

#: Fraction of the input span within which a sample counts as "at" an extremum.
_EXTREMUM_BAND = 0.02


# -- record helpers -------------------------------------------------------------
def _signal(value, name):
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise IdentificationError(f"{name}: expected numbers") from None
    if arr.ndim != 1:
        raise IdentificationError(f"{name}: expected a 1-D record, found shape {arr.shape}")
    if arr.size < 3:
        raise IdentificationError(f"{name}: expected at least 3 samples, found {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise IdentificationError(f"{name}: expected finite values, found NaN or inf")
    return arr


def _pair(u, y):
    u = _signal(u, "u")
    y = _signal(y, "y")
    if u.shape != y.shape:
        raise IdentificationError(
            f"y: expected as many samples as u ({u.size}), found {y.size}")
    return u, y


def ascending_branches(u):
    """Complete ascending branches of a periodic input record.

    A complete branch starts at a minimum (a sample within 2 % of the input
    span of the global minimum) and ends at the next maximum (within 2 % of
    the global maximum). A virgin (initial loading) curve from a rest value
    to the first maximum is therefore skipped: the first branch starts at the
    first minimum that is followed by the global maximum.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Input record [V].

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` sample indices of each branch: ``u[start]`` is the
        branch minimum and ``u[stop]`` its maximum (inclusive).

    Raises
    ------
    IdentificationError
        If the record has no complete ascending branch (e.g. less than about
        one period after the virgin curve).
    """
    u = _signal(u, "u")
    lo, hi = u.min(), u.max()
    span = hi - lo
    if not span > 0:
        raise IdentificationError("u: the input is constant; expected a periodic excitation")
    band = _EXTREMUM_BAND * span
    low = u <= lo + band
    high = u >= hi - band
    branches = []
    t = 0
    n = u.size
    while t < n:
        lows = np.flatnonzero(low[t:])
        if lows.size == 0:
            break
        a = t + lows[0]
        highs = np.flatnonzero(high[a:])
        if highs.size == 0:
            break
        b = a + highs[0]                       # first sample of the high region
        # minimum inside the low region before b, maximum inside the high region
        start = a + int(np.argmin(u[a:b]))
        ends = np.flatnonzero(~high[b:])
        c = n if ends.size == 0 else b + ends[0]
        stop = b + int(np.argmax(u[b:c]))
        if ends.size or stop < n - 1:
            branches.append((start, stop))
        t = c
    if not branches:
        raise IdentificationError(
            "u: no complete ascending branch (minimum followed by the maximum) in the "
            "record; record at least one full period after the start-up")
    return branches


def _branch_curve(u, y, start, stop):
    """Monotone (running-maximum) input and mean output of one branch."""
    ub = np.maximum.accumulate(u[start:stop + 1])
    yb = y[start:stop + 1]
    # np.interp needs increasing abscissae: average the outputs of equal inputs
    uq, inv = np.unique(ub, return_inverse=True)
    yq = np.bincount(inv, weights=yb) / np.bincount(inv)
    return uq, yq


def partition_thresholds(u, n_hysterons, partition="time", branch=None):
    """Thresholds r_i from a partition of the ascending half period.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Input record [V] holding at least one complete ascending branch.
    n_hysterons : int
        Number of thresholds n (>= 1).
    partition : {"time", "input"} or array_like
        ``"time"``: ``r_i = u'(t_i)/2`` at ``t_i = i T_a/(n+1)``, i = 1..n,
        the instants that split the ascending half period ``T_a`` into n+1
        equal parts (Remark 5.1, how eq. 12 was made); ``u'`` is the shifted
        input ``u - u_min``. ``"input"``: uniform in voltage,
        ``r_i = (i-1) A/n`` (``r_1 = 0`` is a linear term; A is the half input
        span). An array is returned as given (validated).
    branch : (int, int), optional
        Branch to use for the time partition; by default the first complete
        ascending branch (:func:`ascending_branches`).

    Returns
    -------
    numpy.ndarray, shape (n_hysterons,)
        Strictly increasing thresholds [V].

    Raises
    ------
    IdentificationError
        On an unknown partition, n < 1, or no ascending branch.
    """
    if not isinstance(partition, str):
        try:
            return validate_thresholds(partition, "thresholds")
        except HysteresisError as exc:
            raise IdentificationError(str(exc)) from None
    n = _count(n_hysterons)
    u = _signal(u, "u")
    start, stop = branch if branch is not None else ascending_branches(u)[0]
    if partition == "time":
        seg = np.maximum.accumulate(u[start:stop + 1]) - u[start]
        s = np.arange(1, n + 1) / (n + 1) * (seg.size - 1)
        r = np.interp(s, np.arange(seg.size), seg) / 2.0
    elif partition == "input":
        amplitude = (u[stop] - u[start]) / 2.0
        r = amplitude * np.arange(n) / n
    else:
        raise IdentificationError(
            f"partition: expected 'time', 'input' or an array of thresholds, found {partition!r}")
    if np.any(np.diff(r) <= 0):
        raise IdentificationError(
            f"partition: the {partition!r} partition gives repeated thresholds "
            f"(too few samples on the ascending branch for n = {n})")
    return r


def _count(n):
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
        raise IdentificationError(f"n_hysterons: expected a positive integer, found {n!r}")
    return int(n)


# -- closed form ----------------------------------------------------------------
class ClosedFormPI:
    """Closed-form identification of a classical PI model (Appendix, eq. 14-17).

    The ascending branch from the input minimum to the next maximum is shifted
    to the origin, ``u' = u - u_min``, ``y' = y - y(u_min)``; with bandwidths
    ``bw_i = 2 r_i`` and ``bw_{n+1} = 2A`` (A = half input span; docs/identification.md),
    ``y_j = y'(u' = bw_{j+1}) = sum_{i<=j} (bw_{j+1} - bw_i) w_i`` (eq. 14),
    a lower-triangular system (eq. 15-16) solved for w (eq. 17) with
    :func:`scipy.linalg.solve_triangular`.

    Robustness: every complete ascending branch of the record is used (the
    virgin curve before the first minimum is skipped, see
    :func:`ascending_branches`); each branch is made monotone (running
    maximum of the input), shifted by its own minimum, and evaluated at the
    points ``u' = 0, bw_2, ..., bw_{n+1}`` by linear interpolation; the
    values are then **averaged over the branches** (noise reduction), which
    keeps the solve exact when the breakpoints fall on samples. A non-zero
    output mean is returned as ``offset_``.

    Parameters
    ----------
    n_hysterons : int
        Number of hysterons n (ignored when ``partition`` is an array).
    partition : {"time", "input"} or array_like, shape (n,)
        Threshold partition, see :func:`partition_thresholds`. Explicit
        thresholds must lie in ``[0, A)`` [V].

    Attributes
    ----------
    thresholds_ : numpy.ndarray, shape (n,)
        Thresholds r_i [V].
    weights_ : numpy.ndarray, shape (n,)
        Weights w_i [µm/V].
    offset_ : float
        Output offset [µm]: the steady loop is ``model_(u) + offset_`` when
        the play states start from the loop (``u_min + r_i`` at the branch
        start); for a symmetric input this is the loop centre.
    model_ : PrandtlIshlinskii
    amplitude_ : float
        Half input span A [V] (mean over branches).
    input_center_ : float
        Mid input of the branches [V].
    branches_ : list of (int, int)
        Sample ranges of the branches used.
    branch_state_ : numpy.ndarray, shape (n,)
        Play states at the start of a steady ascending branch,
        ``u_min + r_i`` [V] (initial state to reproduce the loop).
    """

    def __init__(self, n_hysterons=15, partition="time"):
        self.n_hysterons = n_hysterons
        self.partition = partition

    def fit(self, u, y, branches=None):
        """Identify the weights from an input/output record.

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V], periodic (sine or triangle), at least one complete
            ascending branch after any start-up.
        y : array_like, shape (n_samples,)
            Measured output [µm].
        branches : list of (int, int), optional
            Complete ascending branches to use, ``(start, stop)`` sample
            indices of a minimum and the following maximum (inclusive);
            found by :func:`ascending_branches` by default. Only their
            samples enter the fit (the rest of the record may be held out).

        Returns
        -------
        self

        Raises
        ------
        IdentificationError
            If the record has no complete ascending branch, the thresholds do
            not fit in ``[0, A)``, or the system is singular.
        """
        u, y = _pair(u, y)
        if branches is None:
            branches = ascending_branches(u)
        else:
            branches = [(int(a), int(b)) for a, b in branches]
            if not branches or any(not 0 <= a < b < u.size or u[b] <= u[a] for a, b in branches):
                raise IdentificationError(
                    f"branches: expected (start, stop) of ascending branches inside the record, "
                    f"found {branches}")
        r = partition_thresholds(u, self.n_hysterons, self.partition, branches[0])
        spans = np.array([u[b] - u[a] for a, b in branches])
        amplitude = float(spans.mean() / 2.0)
        if r[-1] >= amplitude:
            raise IdentificationError(
                f"thresholds: expected all below the half input span A = {amplitude:g} V, "
                f"found r_n = {r[-1]:g} V")
        bw = np.append(2.0 * r, 2.0 * amplitude)
        points = np.concatenate([[0.0], bw[1:]])
        values = []
        starts = []
        for a, b in branches:
            uq, yq = _branch_curve(u, y, a, b)
            v = np.interp(points + u[a], uq, yq)
            values.append(v - v[0])
            starts.append(v[0])
        yj = np.mean(values, axis=0)[1:]
        A = np.tril(bw[1:, None] - bw[None, :-1])
        if np.any(np.diag(A) <= 0):
            raise IdentificationError("thresholds: singular matrix A (repeated bandwidths)")
        w = scipy.linalg.solve_triangular(A, yj, lower=True)
        u_min = float(np.mean([u[a] for a, _ in branches]))
        self.thresholds_ = r
        self.weights_ = w
        self.amplitude_ = amplitude
        self.input_center_ = u_min + amplitude
        self.branches_ = branches
        self.branch_state_ = u_min + r
        self.offset_ = float(np.mean(starts) - np.sum(w * (u_min + r)))
        self.model_ = PrandtlIshlinskii(r, w)
        return self


# -- least squares ----------------------------------------------------------------
class LeastSquaresPI:
    """Least-squares identification of a classical PI model (ref. [18]).

    For fixed thresholds the PI output is linear in the weights,
    ``y = Phi w + c``, with ``Phi`` (n_samples, n) the play outputs
    (:func:`hammerstein.models.hysteresis.play`) over the whole record and c an
    optional output offset. The solve uses :func:`scipy.linalg.lstsq`
    (unconstrained) or :func:`hammerstein.identification.lsq.bounded_lstsq` on the
    regression's triangular factor (bounded / non-negative weights; the
    offset is never bounded; :func:`scipy.optimize.lsq_linear` for bounds on
    both sides).

    ``bounds="monotone"`` constrains the model instead of the weights: the
    unknowns become the cumulative sums ``S_j = sum_{i<=j} w_i`` (the slopes
    reachable on a branch, docs/compensator.md), bounded by ``S_j >= min_slope`` (or
    ``<= -min_slope`` for a decreasing transfer). The fitted operator is then
    strictly monotone, hence invertible (Kuhnen: ``S_i > 0``) and compensable
    with ``rho(I - K^-1 J) < 1`` for a suitable K. Use it for direct
    transfers identified where phase lag makes the loops overshoot after a
    reversal (negative slopes that no compensator can invert).

    Parameters
    ----------
    thresholds : array_like, shape (n,), optional
        Thresholds r_i [V]; by default built from ``n_hysterons`` and
        ``partition`` on the record (:func:`partition_thresholds`).
    n_hysterons : int
        Number of hysterons when thresholds are not given.
    partition : {"time", "input"}
        Partition when thresholds are not given.
    bounds : None, "nonnegative", "monotone" or (float, float)
        Weight bounds [µm/V]: unconstrained, ``w >= 0``, cumulative sums
        ``|S_j| >= min_slope`` (monotone model), or ``lo <= w <= hi``.
    offset : bool
        Fit a constant output offset [µm] too.
    min_slope : float, optional
        Smallest slope [µm/V] of a monotone fit; default 10 % of the
        record's secant slope ``(y(u_max) - y(u_min)) / (u_max - u_min)``.

    Attributes
    ----------
    thresholds_, weights_ : numpy.ndarray, shape (n,)
        [V] and [µm/V].
    offset_ : float
        Output offset [µm] (0 when ``offset=False``).
    model_ : PrandtlIshlinskii
    amplitude_ : float
        Half input span of the fitted samples [V].
    residual_rms_ : float
        RMS of ``y - model(u) - offset`` over the fitted samples [µm].
    """

    def __init__(self, thresholds=None, n_hysterons=15, partition="time",
                 bounds=None, offset=True, min_slope=None):
        self.thresholds = thresholds
        self.n_hysterons = n_hysterons
        self.partition = partition
        self.bounds = bounds
        self.offset = offset
        self.min_slope = min_slope

    def _bounds(self, n):
        b = self.bounds
        if b is None or (isinstance(b, str) and b == "none"):
            return None
        if isinstance(b, str) and b == "nonnegative":
            lo, hi = 0.0, np.inf
        elif isinstance(b, str) and b == "monotone":
            return "monotone"
        else:
            try:
                lo, hi = (float(v) for v in b)
            except (TypeError, ValueError):
                raise IdentificationError(
                    f"bounds: expected None, 'nonnegative', 'monotone' or (lo, hi), "
                    f"found {b!r}") from None
            if not lo < hi:
                raise IdentificationError(f"bounds: expected lo < hi, found {b!r}")
        lower = np.full(n + bool(self.offset), lo)
        upper = np.full(n + bool(self.offset), hi)
        if self.offset:
            lower[-1], upper[-1] = -np.inf, np.inf
        return lower, upper

    def fit(self, u, y, skip=0, initial_state=None, sampling_period=None, skip_seconds=None):
        """Fit the weights (and offset) over the record.

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V].
        y : array_like, shape (n_samples,)
            Measured output [µm].
        skip : int or "auto"
            Burn-in samples: simulated to warm up the play states but left
            out of the fit. Zero play states at the record start are right
            when the record starts from 0 V in the demagnetised state; for a
            record that starts elsewhere (a jump, a sensor offset before the
            drive, a start-up transient), skip about one period. ``"auto"``
            skips to the start of the first complete ascending branch
            (:func:`ascending_branches`), i.e. the virgin curve only warms up
            the play states.
        initial_state : array_like, shape (n,), optional
            Play states before the first sample [V]; zeros by default.
        sampling_period : float, optional
            Sampling period [s], needed with ``skip_seconds``.
        skip_seconds : float, optional
            Burn-in given as a duration [s] (overrides ``skip``).

        Returns
        -------
        self

        Raises
        ------
        IdentificationError
            On invalid records, thresholds, bounds or burn-in.
        """
        u, y = _pair(u, y)
        if skip_seconds is not None:
            if sampling_period is None or not sampling_period > 0:
                raise IdentificationError(
                    "sampling_period: expected a positive period [s] with skip_seconds")
            skip = int(round(skip_seconds / sampling_period))
        if isinstance(skip, str) and skip == "auto":
            skip = int(ascending_branches(u)[0][0])
        if not isinstance(skip, (int, np.integer)) or not 0 <= skip <= u.size - 2:
            if skip_seconds is not None:  # in the unit the user gave
                raise IdentificationError(
                    f"skip: expected a burn-in in [0, {(u.size - 2) * sampling_period:g}] s, "
                    f"found {skip_seconds:g} s")
            raise IdentificationError(
                f"skip: expected a sample count in [0, {u.size - 2}], found {skip!r}")
        if self.thresholds is not None:
            r = partition_thresholds(u, None, self.thresholds)
        else:
            r = partition_thresholds(u[skip:], self.n_hysterons, self.partition)
        try:
            phi, _ = play(u, r, initial_state)
        except HysteresisError as exc:
            raise IdentificationError(str(exc)) from None
        X = phi[:, skip:].T
        if self.offset:
            X = np.column_stack([X, np.ones(X.shape[0])])
        target = y[skip:]
        bounds = self._bounds(r.size)
        if bounds is None:
            coef, *_ = scipy.linalg.lstsq(X, target)
        elif isinstance(bounds, str):  # monotone: solve for the cumulative sums S
            coef = self._solve_monotone(X, target, u[skip:], y[skip:], r.size)
        else:
            # the tall problem reduced to its n x n triangular factor before the solve
            R, c, _ = r_factor(X, target)
            if np.all(np.isinf(bounds[1])):
                coef = bounded_lstsq(R, c, bounds[0])
            else:
                from scipy.optimize import lsq_linear  # lazy: ~0.3 s to import; two-sided bounds

                coef = lsq_linear(R, c, bounds=bounds, method="bvls").x
        w = coef[:r.size]
        c = float(coef[-1]) if self.offset else 0.0
        self.thresholds_ = r
        self.weights_ = w
        self.offset_ = c
        self.model_ = PrandtlIshlinskii(r, w)
        self.amplitude_ = float(np.ptp(u[skip:]) / 2.0)
        self.residual_rms_ = float(np.sqrt(np.mean((target - X @ coef) ** 2)))
        return self


    def _solve_monotone(self, X, target, u, y, n):
        """Least squares over S = cumsum(w) with |S_j| >= min_slope."""
        i_max, i_min = int(np.argmax(u)), int(np.argmin(u))
        secant = (y[i_max] - y[i_min]) / max(u[i_max] - u[i_min], 1e-300)
        s_min = self.min_slope if self.min_slope is not None else 0.1 * abs(secant)
        if not (np.isfinite(s_min) and s_min >= 0):
            raise IdentificationError(f"min_slope: expected a slope >= 0 [µm/V], found {s_min!r}")
        sign = 1.0 if secant >= 0 else -1.0
        # w = M S with M the first-difference matrix; flip the sign so the
        # bound is always S' >= s_min
        M = np.eye(n) - np.eye(n, k=-1)
        Xs = X.copy()
        Xs[:, :n] = sign * (X[:, :n] @ M)
        lower = np.full(X.shape[1], s_min)
        if self.offset:
            lower[-1] = -np.inf
        # the same problem on the triangular factor of Xs = Q R (||Xs c - t||^2 =
        # ||R c - Q^T t||^2 + const): the bounded solver works on a k x k system
        # instead of an n_samples x k one (Q itself is never formed)
        sol = lstsq_bounded_below(Xs, target, lower)
        coef = sol.copy()
        coef[:n] = sign * (M @ sol[:n])
        return coef


_METHODS = {"closed-form": ClosedFormPI, "least-squares": LeastSquaresPI}


def make_identifier(method="closed-form", **options):
    """Monovariable identifier by name.

    Parameters
    ----------
    method : {"closed-form", "least-squares"}
    **options
        Constructor options of :class:`ClosedFormPI` / :class:`LeastSquaresPI`.

    Returns
    -------
    ClosedFormPI or LeastSquaresPI
        A new identifier built with ``options``.

    Raises
    ------
    IdentificationError
        On an unknown method or option.
    """
    if method not in _METHODS:
        raise IdentificationError(
            f"method: expected one of {sorted(_METHODS)}, found {method!r}")
    try:
        return _METHODS[method](**options)
    except TypeError as exc:
        raise IdentificationError(f"{method}: {exc}") from None


# -- multivariable ----------------------------------------------------------------
class MultivariableIdentifier:
    """Multivariable PI identification, Steps 1-4 of Section 3.3 of [1]_.

    Record k excites input k alone (the others at zero) and records all p
    outputs; each component ``Gamma_lk`` is identified from ``(u_k, y_l)``
    by the monovariable method. Works for square and rectangular models.

    Parameters
    ----------
    method : {"closed-form", "least-squares"}
    n_hysterons : int or array_like of int, shape (p, m)
        Hysterons per component, shared or per component n_lk.
    **options
        Other options of the monovariable identifier (``partition``,
        ``bounds``, ``offset``...). ``bounds="monotone"`` is applied to the
        direct transfers (l == k) only; cross-couplings, which need not be
        monotone, are fitted unconstrained.

    Attributes
    ----------
    model_ : MultivariablePI
        With ``input_amplitude`` the half span of each excitation [V].
    offsets_ : numpy.ndarray, shape (p, m)
        Output offset of each component fit [µm] (not part of the model).
    fit_rms_ : numpy.ndarray, shape (p, m)
        RMS error [µm] of each component ``y_l - Gamma_lk(u_k) - offset``
        over its record (zero initial play states).
    identifiers_ : list of list
        The fitted monovariable identifiers, shape (p, m).

    Examples
    --------
    Records simulated from a known 2x2 model, one per excited input; with
    the model's thresholds given, least squares recovers the direct weights:

    >>> import numpy as np
    >>> from hammerstein import MultivariableIdentifier, MultivariablePI, PrandtlIshlinskii
    >>> true = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 2.0, 4.0], [1.0, 0.5, 0.25]), PrandtlIshlinskii([0.0, 3.0], [0.05, 0.02])],
    ...      [PrandtlIshlinskii([0.0, 3.0], [0.04, 0.01]), PrandtlIshlinskii([0.0, 2.0, 4.0], [0.8, 0.4, 0.2])]])
    >>> drive = 10 * np.sin(2 * np.pi * np.arange(1000) / 400)       # [V]
    >>> records = []
    >>> for k in range(2):
    ...     u = np.zeros((2, drive.size))
    ...     u[k] = drive
    ...     records.append((u, true.simulate(u)[0]))
    >>> ident = MultivariableIdentifier("least-squares", thresholds=[0.0, 2.0, 4.0])
    >>> model = ident.fit(records, ["ux", "uy"], ["x", "y"]).model_
    >>> np.round(model.component("x", "ux").weights, 3)
    array([1.  , 0.5 , 0.25])
    >>> np.round(model.component("y", "uy").weights, 3)
    array([0.8, 0.4, 0.2])
    >>> model.input_amplitude
    array([10., 10.])
    """

    def __init__(self, method="closed-form", n_hysterons=15, **options):
        self.method = method
        self.n_hysterons = n_hysterons
        self.options = options

    def fit(self, records, input_names=None, output_names=None, fit_options=None):
        """Identify every component from one record per excited input.

        Parameters
        ----------
        records : sequence of (inputs, outputs)
            One pair per input k, in input order: ``inputs`` (m, n_samples)
            [V] with only row k non-zero, ``outputs`` (p, n_samples) [µm].
        input_names, output_names : sequence of str, optional
            Names stored in the model.
        fit_options : dict, optional
            Extra keyword arguments of the monovariable ``fit`` (e.g.
            ``skip`` for least squares).

        Returns
        -------
        self

        Raises
        ------
        IdentificationError
            If records are missing, mis-shaped, excite another input than
            their own, or a component cannot be identified.
        """
        records = list(records)
        if not records:
            raise IdentificationError("records: expected one record per input, found none")
        m = len(records)
        arrays = []
        for k, rec in enumerate(records):
            try:
                U, Y = rec[-2], rec[-1]
                U = np.atleast_2d(np.asarray(U, dtype=float))
                Y = np.atleast_2d(np.asarray(Y, dtype=float))
            except (TypeError, ValueError, IndexError):
                raise IdentificationError(
                    f"records[{k}]: expected (inputs (m, N), outputs (p, N))") from None
            if U.shape[0] != m:
                raise IdentificationError(
                    f"records[{k}]: expected inputs of shape ({m}, N) (one record per "
                    f"input), found {U.shape}")
            if Y.shape[1] != U.shape[1]:
                raise IdentificationError(
                    f"records[{k}]: expected outputs with {U.shape[1]} samples, found {Y.shape}")
            others = np.delete(U, k, axis=0)
            if others.size and np.max(np.abs(others)) > 1e-9 * max(np.max(np.abs(U[k])), 1.0):
                raise IdentificationError(
                    f"records[{k}]: expected only input {k} excited, found other inputs non-zero")
            arrays.append((U, Y))
        p = arrays[0][1].shape[0]
        if any(Y.shape[0] != p for _, Y in arrays):
            raise IdentificationError("records: expected the same number of outputs in every record")
        n = np.asarray(self.n_hysterons, dtype=object)
        n = np.full((p, m), self.n_hysterons, dtype=object) if n.ndim == 0 else n
        if n.shape != (p, m):
            raise IdentificationError(
                f"n_hysterons: expected an integer or a ({p}, {m}) array, found shape {n.shape}")
        comps = [[None] * m for _ in range(p)]
        idents = [[None] * m for _ in range(p)]
        offsets = np.zeros((p, m))
        rms = np.zeros((p, m))
        amplitude = np.zeros(m)
        for k, (U, Y) in enumerate(arrays):
            for l in range(p):
                opts = dict(self.options)
                if opts.get("bounds") == "monotone" and l != k:
                    opts["bounds"] = None
                ident = make_identifier(self.method, n_hysterons=int(n[l, k]), **opts)
                try:
                    ident.fit(U[k], Y[l], **(fit_options or {}))
                except IdentificationError as exc:
                    raise IdentificationError(f"component ({l}, {k}): {exc}") from None
                idents[l][k] = ident
                comps[l][k] = ident.model_
                offsets[l, k] = ident.offset_
                pred, _ = ident.model_.simulate(U[k])
                rms[l, k] = np.sqrt(np.mean((Y[l] - pred - ident.offset_) ** 2))
                amplitude[k] = max(amplitude[k], ident.amplitude_)
        self.model_ = MultivariablePI(comps, input_names, output_names, amplitude)
        self.offsets_ = offsets
        self.fit_rms_ = rms
        self.identifiers_ = idents
        return self


# -- validation -------------------------------------------------------------------
def fit_report(model, u, y, offset=0.0, start=0, initial_state=None):
    """Fit quality of a classical PI model on a record.

    The model is simulated over the whole record (so that the play states are
    warmed up by the samples before ``start``) and compared with the
    measurement from sample ``start`` on.

    Parameters
    ----------
    model : PrandtlIshlinskii
    u : array_like, shape (n_samples,)
        Input [V].
    y : array_like, shape (n_samples,)
        Measured output [µm].
    offset : float
        Output offset added to the model output [µm].
    start : int
        First sample of the evaluation window.
    initial_state : array_like, shape (n_hysterons,), optional
        Play states before the first sample [V]; zeros by default.

    Returns
    -------
    dict
        ``rms_um`` RMS error [µm], ``rms_percent_of_range`` RMS error over the
        measured output range (peak to peak) of the window [%],
        ``max_abs_um`` largest absolute error [µm], ``output_range_um`` [µm],
        ``n_samples`` in the window.

    Raises
    ------
    IdentificationError
        On invalid records or window.
    """
    u, y = _pair(u, y)
    if not 0 <= start < u.size - 1:
        raise IdentificationError(f"start: expected a sample index in [0, {u.size - 2}], found {start}")
    pred, _ = model.simulate(u, initial_state)
    err = y[start:] - pred[start:] - offset
    rng = float(np.ptp(y[start:]))
    rms = float(np.sqrt(np.mean(err ** 2)))
    return {"rms_um": rms,
            "rms_percent_of_range": 100.0 * rms / rng if rng > 0 else float("inf"),
            "max_abs_um": float(np.max(np.abs(err))),
            "output_range_um": rng,
            "n_samples": int(err.size)}
