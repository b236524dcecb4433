"""Subspace identification of G from records (behind :mod:`hammerstein.models.lti`).

Multi-record PO-MOESP for A and C, least squares for B, D and the initial
states, the order chosen on held-out records, modal reduction; the
references are those of :mod:`hammerstein.models.lti` (Verhaegen and
Verdult 2007; Ljung 1999).

Length: the identifier's one pass (candidate orders, held-out validation, the final
fit on every record) shares its records and R factors; the decimation and the
balancing of the outputs live apart (``_lti_rate``, ``_lti_scaling``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.models.dynamics import DynamicsError
from hammerstein.core.lazy import lazy_module

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")  # lazy: ~0.1 s CPU of `from hammerstein import ...`

from hammerstein.models._lti_systems import _apply_filter, _records, modal_parameters, sensor_filter
from hammerstein.models._lti_delay import excited_band
from hammerstein.models._lti_modal import keep_modes, mode_shares, real_modal
from hammerstein.models._lti_rate import DYNAMICS_RATE_HZ, decimation_factor, fit_decimated
from hammerstein.models._lti_scaling import balanced_fit

# -- identification ------------------------------------------------------------------
def _powers(lam, N):
    """``lam_i ** k`` for k = 0..N-1, shape (n, N), as cumulative products (one product a sample)."""
    P = np.empty((lam.size, N), dtype=complex)
    P[:, :1] = 1.0
    P[:, 1:] = lam[:, None]
    return np.cumprod(P, axis=1)


def _state_regressors(A, C, u):
    """Regressors of y on B (row-major vec) and on x0 for one record.

    Returns ``RB`` (N, p, n*m) and ``R0`` (N, p, n) with
    ``y_k = RB_k B.ravel() + R0_k x0 (+ D u_k)``, computed in modal
    coordinates (``A = V diag(lam) V^-1``, one first-order recursion per mode
    and input, run by :func:`scipy.signal.lfilter`, that of a complex pole's
    conjugate taken as the conjugate); a loop is used when A is defective.
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    n, (m, N) = A.shape[0], u.shape
    p = C.shape[0]
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) < 1e8:
        Vinv = np.linalg.inv(V)
        CV = C @ V
        W = np.empty((n, m, N), dtype=complex)
        for i in range(n):
            if i and lam[i].imag != 0 and lam[i] == np.conj(lam[i - 1]):
                W[i] = np.conj(W[i - 1])    # u is real: the conjugate pole's recursion
            else:
                W[i] = scipy.signal.lfilter([0.0, 1.0], [1.0, -lam[i]], u.astype(complex), axis=1)
        # the sums over the modes i as matrix products (BLAS) instead of einsum's loops:
        # RB[k, p, a, b] = sum_i CV[p, i] Vinv[i, a] W[i, b, k], R0[k, p, a] = sum_i
        # CV[p, i] Vinv[i, a] lam_i^k
        M = (CV[:, None, :] * Vinv.T[None, :, :]).reshape(p * n, n)           # (p a, i)
        RB = (M @ W.reshape(n, m * N)).real.reshape(p, n, m, N)
        RB = np.ascontiguousarray(RB.transpose(3, 0, 1, 2)).reshape(N, p, n * m)
        R0 = np.ascontiguousarray((M @ _powers(lam, N)).real.reshape(p, n, N).transpose(2, 0, 1))
        return RB, R0
    RB = np.empty((N, p, n * m))
    R0 = np.empty((N, p, n))
    S = np.zeros((n, n * m))
    P = np.eye(n)
    eye_n = np.eye(n)
    for k in range(N):
        RB[k] = C @ S
        R0[k] = C @ P
        S = A @ S + np.einsum("ab,c->abc", eye_n, u[:, k]).reshape(n, n * m)
        P = A @ P
    return RB, R0


class _BDX0Problem:
    """The least squares of B, D and one x0 per record given A, C [2, Section 9.2.4].

    The output of record r is linear in the shared ``theta = (vec B, vec D)``
    and in its own initial state: ``y_r = Phi_r theta + Psi_r x0_r``
    (:func:`_state_regressors`). Each record's ``[Psi_r, Phi_r, y_r]`` is
    reduced once to its R factor (QR, :func:`numpy.linalg.qr`)
    ``[[R11, R12, z1], [0, R22, z2]]``; minimising over ``x0_r`` leaves
    ``|R22 theta - z2|``, so theta solves the stacked small problems of all
    records (n m (+ p m) unknowns instead of those plus n per record over
    every sample) and ``x0_r = R11^+ (z1 - R12 theta)``: the same least
    squares as over all samples at once, solved for several constraints
    (:meth:`solve`) from one pass over the records. For A in real modal form,
    the problem of a subset of its modes (:meth:`subset`) has the regressor
    columns of those states, and its R factors are those of the same columns
    of the R factors (``Q^T X_sub = R_sub``), without another pass.
    """

    def __init__(self, A, C, ins, outs, feedthrough):
        n, p, m = A.shape[0], C.shape[0], ins[0].shape[0]
        self.A, self.C, self.feedthrough = A, C, feedthrough
        self.n, self.p, self.m = n, p, m
        self.regressors, self.factors = [], []
        for u, y in zip(ins, outs):
            RB, R0 = _state_regressors(A, C, u)
            N = u.shape[1]
            blocks = [R0.reshape(N * p, n), RB.reshape(N * p, n * m)]
            if feedthrough:
                blocks.append(np.einsum("il,bk->kilb", np.eye(p), u).reshape(N * p, p * m))
            blocks.append(y.T.reshape(-1, 1))
            X = np.empty((N * p, sum(b.shape[1] for b in blocks)), order="F")  # LAPACK's layout
            np.concatenate(blocks, axis=1, out=X)
            self.regressors.append(X[:, :-1])
            self.factors.append(np.linalg.qr(X, mode="r"))

    @property
    def top(self):
        """Per record ``[R11, R12, z1]`` (the x0 rows of the R factor)."""
        return [R[:self.n] for R in self.factors]

    @property
    def rest(self):
        """Per record ``[R22, z2]`` (what x0 leaves of the R factor)."""
        return [R[self.n:, self.n:] for R in self.factors]

    def subset(self, states, A, C):
        """The problem of the states ``states`` only, A, C those states' blocks of a modal A, C."""
        n, m, p = self.n, self.m, self.p
        states = np.asarray(states, dtype=int)
        cols = np.concatenate([states, n + (states[:, None] * m + np.arange(m)).ravel(),
                               np.arange(n + n * m, self.factors[0].shape[1])])
        sub = object.__new__(_BDX0Problem)
        sub.A, sub.C, sub.feedthrough = A, C, self.feedthrough
        sub.n, sub.p, sub.m = states.size, p, m
        sub.regressors = [X[:, cols[:-1]] for X in self.regressors]
        sub.factors = [np.linalg.qr(R[:, cols], mode="r") for R in self.factors]
        return sub

    def solve(self, dc=None):
        """B (n, m), D (p, m) and x0 (n_records, n); with ``dc``, under ``G(1) = dc``.

        The constraint ``C (I - A)^-1 B + D = dc`` by the null-space method:
        the particular solution plus a least-squares combination of the null
        space of the constraint.
        """
        n, p, m = self.n, self.p, self.m
        rest = np.vstack(self.rest)
        S, z = rest[:, :-1], rest[:, -1]
        if dc is None:
            theta = np.linalg.lstsq(S, z, rcond=None)[0]
        else:
            E = np.zeros((p * m, S.shape[1]))
            E[:, :n * m] = np.kron(self.C @ np.linalg.solve(np.eye(n) - self.A, np.eye(n)), np.eye(m))
            if self.feedthrough:
                E[:, n * m:] = np.eye(p * m)
            theta_p = np.linalg.lstsq(E, np.asarray(dc, dtype=float).reshape(-1), rcond=None)[0]
            N = scipy_linalg.null_space(E)
            theta = theta_p + N @ np.linalg.lstsq(S @ N, z - S @ theta_p, rcond=None)[0]
        x0 = np.array([np.linalg.lstsq(R[:, :n], R[:, -1] - R[:, n:-1] @ theta, rcond=None)[0]
                       for R in self.top]).reshape(len(self.top), n)
        B = theta[:n * m].reshape(n, m)
        D = theta[n * m:].reshape(p, m) if self.feedthrough else np.zeros((p, m))
        return B, D, x0

    def outputs(self, B, D, x0):
        """Fitted outputs of each record, (p, N) each."""
        theta = np.concatenate([B.ravel()] + ([D.ravel()] if self.feedthrough else []))
        return [(X @ np.concatenate([x, theta])).reshape(-1, self.p).T
                for X, x in zip(self.regressors, x0)]


def _simulate(A, B, C, D, u, x0):
    """Response of (A, B, C, D) to u (m, N) from x0 [µm].

    In modal coordinates (``A = V diag(lam) V^-1``): one first-order
    recursion per mode on ``V^-1 B u`` (:func:`scipy.signal.lfilter`), the
    same sums as :func:`_state_regressors` without forming its (N, p, n m)
    regressors; through them when A is defective.
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) >= 1e8:
        RB, R0 = _state_regressors(A, C, u)
        return (RB @ B.ravel() + R0 @ x0).T + D @ u
    Vinv = np.linalg.inv(V)
    z = Vinv @ (B @ u).astype(complex)                      # (n, N) modal inputs
    W = np.stack([scipy.signal.lfilter([0.0, 1.0], [1.0, -lam_i], z_i) for lam_i, z_i in zip(lam, z)])
    W += _powers(lam, u.shape[1]) * (Vinv @ x0)[:, None]
    return (C @ V @ W).real + D @ u


class _MultiRecordMOESP:
    """PO-MOESP column space of the extended observability matrix, several records.

    The block Hankel matrices and the QR/LQ step of PO-MOESP (Verhaegen &
    Verdult [2], p. 329; the construction of nfoursid's
    :class:`~nfoursid.nfoursid.NFourSID`), with the Hankel columns of every
    record side by side, so that no column straddles two records. A and C
    follow from the shift invariance of the estimated extended observability
    matrix ``Gamma_i = U_n S_n^(1/2)`` ([2], Section 9.6): ``C = Gamma_i[:p]``,
    ``A = pinv(Gamma_i[:-p]) Gamma_i[p:]``. (nfoursid's own
    ``system_identification`` regresses consecutive columns of a state
    sequence, which is not valid across record boundaries.) The block
    Hankel matrices (the values of nfoursid's ``Utils.block_hankel_matrix``)
    are written straight into one array, one block row (a slice of a record)
    at a time instead of one column at a time, and only ``nfoursid.utils`` is
    imported (``nfoursid.nfoursid`` loads matplotlib.pyplot, ~0.3 s).

    With ``prior`` (the step on part of the data) and ``known`` (per record,
    how many of its leading Hankel columns ``prior`` holds), the R factor of
    ``prior`` stands for those columns: the QR of ``[R_prior; new columns]``
    has the R factor of all columns up to the signs of its rows, which only
    change the signs of columns of R32, not its left singular vectors and
    singular values (all that A and C are taken from).
    """

    def __init__(self, ins, outs, block_rows, prior=None, known=None):
        from nfoursid.utils import Utils  # lazy: only when dynamics are identified
        m, p = ins[0].shape[0], outs[0].shape[0]
        i = block_rows
        # the block rows [future u; past u; past y; future y] of every record side by side,
        # written straight into one array (rows = Hankel rows, after prior's R factor)
        starts = [0 if known is None else int(known[r]) for r in range(len(ins))]
        n_cols = [max(u.shape[1] - k0 - 2 * i + 1, 0) for u, k0 in zip(ins, starts)]
        head = 0 if prior is None else prior.R.shape[0]
        X = np.empty((2 * (m + p) * i, head + sum(n_cols)))
        if prior is not None:
            X[:, :head] = prior.R.T
        c0 = head
        for u, y, k0, nc in zip(ins, outs, starts, n_cols):
            if nc == 0:
                continue
            rows = 0
            for x, lag in ((u, i), (u, 0), (y, 0), (y, i)):
                c = x.shape[0]
                for t in range(i):    # X[rows + t c + ch, c0 + j] = x[ch, k0 + lag + t + j]
                    X[rows + t * c:rows + (t + 1) * c, c0:c0 + nc] = x[:, k0 + lag + t:][:, :nc]
                rows += i * c
            c0 += nc
        self.R = np.linalg.qr(X.T, mode="r")
        r = self.R.T
        y_rows, u_rows = p * i, m * i
        self.R32 = r[-y_rows:, u_rows:-y_rows]
        self.R22 = r[u_rows:-y_rows, u_rows:-y_rows]
        self.p = p
        dec = Utils.eigenvalue_decomposition(self.R32)
        self.singular_values = np.diag(dec.eigenvalues)
        self.left = dec.left_orthogonal

    def system_ac(self, n):
        """A (n, n) and C (p, n) of an order-n model."""
        p = self.p
        gamma = self.left[:, :n] * np.sqrt(self.singular_values[:n])[None, :]
        C = gamma[:p]
        A = np.linalg.lstsq(gamma[:-p], gamma[p:], rcond=None)[0]
        return A, C


def _fit_percent(y, yhat):
    """NRMSE fit per output [%], Ljung [3]: 100 (1 - |y - yhat| / |y - mean y|)."""
    e = np.linalg.norm(y - yhat, axis=1)
    d = np.linalg.norm(y - y.mean(axis=1, keepdims=True), axis=1)
    return 100.0 * (1.0 - e / np.where(d > 0, d, 1.0))


#: The largest departure of the records' own static gain from the identity [-] for which
#: ``unit_dc_gain`` imposes ``G(1) = I`` on every candidate (the value of identify's
#: static-gain warning); beyond it the order is chosen with the records' gain (:meth:`DynamicsIdentifier._unit_dc`).
STATIC_GAIN_STEP = 0.05
#: ... and the free fit scaled to ``G(1) = I`` is kept only while its gain at the bottom of the
#: excited band stays within this of ``I`` (largest entry of ``|Re G(f_lo) - I|``, balanced
#: units): the scaling moves the level the hysteresis model owns, not the band's gain.
FREE_GAIN_BAND_STEP = 0.25


@dataclass
class DynamicsIdentifier:
    """Subspace identification of the discrete linear part G from records.

    The estimator, in the scikit-learn / pysindy style: parameters in the
    constructor, :meth:`fit` on records, fitted attributes ending in ``_``.

    **Algorithm.** (1) The input records (PI outputs ``H = Gamma(U)`` [µm])
    are, when a ``sensor`` with a low-pass is given, filtered by the same
    discrete low-pass S(z) that the sensor applies to the displacements.
    S is scalar (the same first-order filter on every channel), so
    ``S G = G S`` and the measured ``Y_m = S G H + noise`` equals
    ``G (S H) + noise``: fitting G from ``(S H, Y_m)`` identifies G alone,
    without the sensor pole (z = 0.52 for 2 kHz at 20 kHz), which therefore
    never enters the inverse of the actuator. (2) The A and C matrices are
    estimated by the subspace method of ``nfoursid`` (PO-MOESP with past
    inputs and outputs as instruments [1, 2]) on the records concatenated
    in time (the few Hankel columns that straddle a record boundary are a
    negligible bias for records of thousands of samples). (3) Given A and
    C, the output is linear in B, D and one initial state per record; they
    are estimated by linear least squares over all records [2, Section
    9.2.4], so separate records (one per excited input) are combined
    exactly and start-up transients are modelled, not discarded. By default
    ``D = 0``: the ZOH-sampled actuator cannot react within the sample in
    which the PI output is applied (relative degree >= 1), and a small
    spurious D estimated from noise would make the inverse ill-conditioned.

    **Order selection.** Each record is split in time: the first
    ``1 - validation_fraction`` is used for estimation, the rest for
    validation. For every candidate order 1..``max_order`` that gives a
    stable model, the model is simulated over the whole record (with the
    estimated initial state) and the NRMSE fit [%] on the validation part is
    computed (cross-validation, Ljung [3], Section 16.4). The chosen order
    is the smallest whose validation fit is within ``order_tolerance``
    percentage points of the best; the singular values of the subspace step
    (``singular_values_``, whose gap shows the order as well) and Akaike's
    criterion on the validation residuals (``aic_``) are reported for
    inspection. The chosen order is then refitted on the full records (if
    that refit of A is unstable, A and C of the estimation parts are kept and
    only B, D and the initial states are refitted).

    Parameters
    ----------
    order : int, optional
        Fixed model order n; chosen from the data when None.
    max_order : int
        Largest candidate order.
    block_rows : int, optional
        Block rows of the Hankel matrices (``num_block_rows`` of nfoursid);
        default ``max(10, 2 * max_order // p + 4)``.
    sensor : Sensor, optional
        Sensor whose low-pass filtered the outputs (see Algorithm); noise and
        quantisation are treated as output noise.
    feedthrough : bool
        Estimate D (default False: D = 0).
    validation_fraction : float
        Fraction of each record kept for validation, in (0, 0.9].
    order_tolerance : float
        Percentage points of validation fit traded for a smaller order.
    lag_tolerance : float
        Percentage points of validation fit a candidate holding a lag below
        its first bending mode (a pole, or a pair damped at
        ``zeta >= 1 / sqrt(2)``, which has no resonance) must gain over the
        best candidate without one to be chosen; 0 (default) chooses on the
        fit alone. A hysteresis model's error on the broadband records is
        rate independent, and a subspace fit draws it as such a lag: on two
        outside stages (one mode per axis at 2.5 kHz, at 900 Hz) the orders
        above held lags at 12-153 Hz for 0.25-1.33 points of held-out fit,
        and they cost a 50 Hz circle 5.5 against 2.9 % of its radius, a
        20 Hz one 35.8 against 5.3 % (``identify`` uses 3 points,
        :data:`~hammerstein.identification.record_identification.DYNAMICS_DEFAULTS`).
    unit_dc_gain : bool
        Return G with ``G(z=1) = I`` (the static gain belongs to a
        quasi-statically identified hysteresis model): B (and D) fitted under
        that linear constraint; the unconstrained ``G(1)`` is kept in
        ``dc_gain_unconstrained_``. Where it departs from ``I`` by more than
        :data:`STATIC_GAIN_STEP`, the candidates are fitted and chosen again
        with the records' own static gain and the chosen one scaled on its
        inputs to ``G(1) = I`` (:meth:`_unit_dc`; the fits reported are then
        those of the shape with the records' gain). Default False.
    band_hz : tuple of float, optional
        Excited band ``(f_lo, f_hi)`` [Hz]; default estimated from the input
        spectra (:func:`excited_band`).
    low_pole_fraction : float
        Poles with a natural frequency below ``low_pole_fraction * f_lo`` are
        removed from a candidate (the data cannot show them) and B refitted;
        0 (default) keeps them.
    cancel_tolerance : float
        Modes whose largest gain in the band is below this fraction of G's
        largest gain there (near pole-zero cancellations) are removed and B
        refitted; 0 (default) keeps them.
    validation_records : tuple of int, optional
        Indices of records held out whole to choose the order (their
        initial states are estimated on them); default: the last
        ``validation_fraction`` of every record.
    require_continuous : bool
        Reject a candidate order with a real pole at z <= 0 (its reason in
        ``candidates_``): such a G has no continuous ZOH equivalent
        (:func:`hammerstein.models.lti.continuous_system`), which a preset
        stores. Default False: the discrete G is used as it is.
    max_rate_hz : float, optional
        Records at 2.5 times this rate or more are low-pass filtered and
        decimated (zero phase, by the largest odd factor that keeps the rate
        at or above it), the model returned at the records' period through
        continuous time (:mod:`hammerstein.models._lti_rate`). Default 1e4
        Hz: records at 20 kHz and below are fitted as they are; None: never.

    Attributes
    ----------
    system_ : control.StateSpace
        Identified discrete system, ``dt = sampling_period``, p inputs, p outputs.
    order_ : int
        Chosen order.
    singular_values_ : numpy.ndarray
        Singular values of the subspace (R32) matrix, descending.
    orders_ : numpy.ndarray
        Candidate orders examined.
    validation_fit_ : numpy.ndarray, shape (n_candidates,)
        Mean validation fit [%] per candidate (NaN when unstable).
    aic_ : numpy.ndarray, shape (n_candidates,)
        Akaike's criterion per candidate (NaN when unstable).
    fit_percent_ : numpy.ndarray, shape (p,)
        Fit [%] per output of the final model over all records.
    initial_states_ : numpy.ndarray, shape (n_records, order_)
        Estimated initial state of each record.
    dc_gain_unconstrained_ : numpy.ndarray, shape (p, p)
        ``G(1)`` of the final A, C with B, D fitted without the constraint.
    dc_gain_scaled_ : bool
        True when the order was chosen with the records' own static gain and
        the model scaled to ``G(1) = I`` (see ``unit_dc_gain``).
    dc_gain_step_ : float or None
        The first fit's largest ``|G(1) - I|`` (balanced units) that decided it
        (``unit_dc_gain`` only).
    candidates_ : list of dict
        Per candidate order: ``order``, kept ``modes`` ([Hz, damping]),
        ``dropped`` poles, ``rejected`` reason, ``validation_fit_percent``.
    candidate_order_ : int
        The chosen candidate order (``order_`` may be smaller after removals).
    band_hz_ : tuple of float
        Excited band used [Hz].
    validation_ : str
        What was held out to choose the order.
    sampling_period_ : float
        T [s] (of ``system_``).
    decimation_ : int
        Decimation factor q (1: fitted at T); when q > 1 every other fitted
        attribute but ``system_`` is that of the fit at ``q T``.

    References
    ----------
    See the module references [1]-[3].

    Examples
    --------
    >>> import numpy as np, control
    >>> from hammerstein.models.dynamics import bending_modes, discretize
    >>> from hammerstein.models.lti import DynamicsIdentifier, excitation
    >>> G = discretize(bending_modes([300.0], [0.2]), 5e-5)
    >>> t, (u,) = excitation(5e-5, 1, 1.0, period=0.02, periods=2)
    >>> y = control.forced_response(G, U=u).outputs.reshape(1, -1)
    >>> ident = DynamicsIdentifier(max_order=4).fit(u, y, 5e-5)
    >>> ident.order_, bool(ident.fit_percent_[0] > 99.9)
    (2, True)
    """

    order: int | None = None
    max_order: int = 8
    block_rows: int | None = None
    sensor: object = None
    feedthrough: bool = False
    validation_fraction: float = 0.3
    order_tolerance: float = 0.1
    unit_dc_gain: bool = False
    band_hz: tuple | None = None
    low_pole_fraction: float = 0.5
    cancel_tolerance: float = 0.0
    validation_records: tuple | None = None
    require_continuous: bool = False
    max_rate_hz: float | None = DYNAMICS_RATE_HZ
    lag_tolerance: float = 0.0

    @staticmethod
    def _subspace(ins, outs, block_rows, prior=None, known=None):
        return _MultiRecordMOESP(ins, outs, block_rows, prior, known)

    _FITTED_ARRAYS = ("singular_values_", "orders_", "validation_fit_", "aic_", "fit_percent_",
                      "initial_states_", "dc_gain_unconstrained_")

    def to_dict(self):
        """The parameters (but the sensor) and fitted attributes as plain data (for JSON).

        Returns
        -------
        dict
            ``params`` (order, max_order, block_rows, feedthrough,
            validation_fraction, order_tolerance) and ``fitted``:
            ``A``, ``B``, ``C``, ``D`` (nested lists), ``dt`` [s] and
            ``name`` of ``system_``, ``order_``, ``sampling_period_`` and
            the arrays (nested lists; NaN where the array has NaN).

        Raises
        ------
        DynamicsError
            If the identifier is not fitted.
        """
        if not hasattr(self, "system_"):
            raise DynamicsError("to_dict: the identifier is not fitted (call fit first)")
        params = {"order": None if self.order is None else int(self.order),
                  "max_order": int(self.max_order),
                  "block_rows": None if self.block_rows is None else int(self.block_rows),
                  "feedthrough": bool(self.feedthrough),
                  "validation_fraction": float(self.validation_fraction),
                  "order_tolerance": float(self.order_tolerance),
                  "unit_dc_gain": bool(self.unit_dc_gain),
                  "band_hz": None if self.band_hz is None else [float(v) for v in self.band_hz],
                  "low_pole_fraction": float(self.low_pole_fraction),
                  "cancel_tolerance": float(self.cancel_tolerance),
                  "validation_records": None if self.validation_records is None
                  else [int(v) for v in self.validation_records],
                  "require_continuous": bool(self.require_continuous),
                  "max_rate_hz": None if self.max_rate_hz is None else float(self.max_rate_hz),
                  "lag_tolerance": float(self.lag_tolerance)}
        G = self.system_
        fitted = {k: np.asarray(getattr(G, k), dtype=float).tolist() for k in "ABCD"}
        fitted.update({"dt": float(G.dt), "name": str(G.name), "order_": int(self.order_),
                       "sampling_period_": float(self.sampling_period_),
                       "decimation_": int(getattr(self, "decimation_", 1))})
        fitted.update({k: np.asarray(getattr(self, k)).tolist() for k in self._FITTED_ARRAYS})
        fitted.update({"candidates_": self.candidates_, "validation_": self.validation_,
                       "candidate_order_": int(self.candidate_order_),
                       "band_hz_": [float(v) for v in self.band_hz_]})
        return {"params": params, "fitted": fitted}

    @classmethod
    def from_dict(cls, data, sensor=None):
        """A fitted identifier from :meth:`to_dict` (round trip: equal arrays, same system).

        Parameters
        ----------
        data : dict
            From :meth:`to_dict`.
        sensor : Sensor, optional
            The sensor parameter (not part of the data).

        Returns
        -------
        DynamicsIdentifier

        Raises
        ------
        DynamicsError
            If ``data`` lacks a key or holds matrices of inconsistent shapes.
        """
        try:
            ident = cls(**data["params"], sensor=sensor)
            f = data["fitted"]
            mats = [np.array(f[k], dtype=float, ndmin=2) for k in "ABCD"]
            ident.system_ = control.ss(*mats, dt=f["dt"], name=f["name"])
            ident.order_ = int(f["order_"])
            ident.sampling_period_ = float(f["sampling_period_"])
            ident.decimation_ = int(f.get("decimation_", 1))
            for k in cls._FITTED_ARRAYS:
                setattr(ident, k, np.array(f[k], dtype=int if k == "orders_" else float))
            ident.candidates_ = list(f["candidates_"])
            ident.candidate_order_ = int(f["candidate_order_"])
            ident.validation_ = str(f["validation_"])
            ident.band_hz_ = tuple(float(v) for v in f["band_hz_"])
        except (KeyError, TypeError, ValueError) as exc:
            raise DynamicsError(f"from_dict: not a fitted identifier ({exc})") from None
        return ident

    def fit(self, inputs, outputs, sampling_period):
        """Identify G from one or several records.

        Outputs of unequal scales (µrad beside µm) are balanced first
        (:func:`hammerstein.models._lti_scaling.balanced_fit`).

        Parameters
        ----------
        inputs : array_like, shape (p, n_samples), or list of them
            PI outputs ``Gamma(U)`` [µm] of each record.
        outputs : array_like, shape (p, n_samples), or list of them
            Measured displacements [µm] of each record.
        sampling_period : float
            T [s].

        Returns
        -------
        DynamicsIdentifier
            self, fitted.

        Raises
        ------
        DynamicsError
            On malformed records or parameters, or when no candidate order
            gives a stable model.
        """
        ins, outs = _records(inputs, outputs)
        self._free_gain = False
        self.dc_gain_step_ = None
        balanced_fit(self, ins, outs, sampling_period)
        if self.decimation_ > 1:         # the decimated records' own fit() decided and scaled
            return self
        if self.unit_dc_gain:
            # judged in the balanced units the fit ran in (an output in µrad beside one in
            # µm would make an off-diagonal entry of 1e-4 one of 1)
            G1 = np.asarray(self.dc_gain_unconstrained_, dtype=float)
            scale = getattr(self, "output_scales_", None)
            if scale is not None:
                G1 = (G1 / np.asarray(scale)[:, None]) * np.asarray(scale)[None, :]
            step = np.abs(G1 - np.eye(outs[0].shape[0]))
            self.dc_gain_step_ = float(step.max()) if np.all(np.isfinite(step)) else None
            if np.all(np.isfinite(step)) and step.max() > STATIC_GAIN_STEP:
                # the records' gain is not the hysteresis model's (its small loops): chosen
                # with G(1) = I imposed, the fit made that gain step with slow pole pairs
                self._free_gain = True
                balanced_fit(self, ins, outs, sampling_period)
                band_gain = _band_bottom_gain(self.system_, self.band_hz_[0], scale)
                if band_gain is None or band_gain > FREE_GAIN_BAND_STEP:
                    # the scaling to G(1) = I reached into the band: the free fit made its
                    # static gain with a slow lag below or at the band's bottom (a 7.1 Hz lag,
                    # G(1) 0.48 where the records show 1.0-1.2), and scaled by it G doubled in
                    # the band (a 20 µm circle at 30 Hz missed by 55 %): G(1) = I imposed
                    self._free_gain = False
                    balanced_fit(self, ins, outs, sampling_period)
        self.dc_gain_scaled_ = bool(self._free_gain)
        return self

    def _fit(self, inputs, outputs, sampling_period):
        """:meth:`fit` without the balancing of the outputs (its parameters, result, errors)."""
        T = float(sampling_period)
        if not (np.isfinite(T) and T > 0):
            raise DynamicsError(f"sampling_period: expected a positive time [s], found {sampling_period!r}")
        if not 0 < self.validation_fraction <= 0.9:
            raise DynamicsError(f"validation_fraction: expected in (0, 0.9], found {self.validation_fraction!r}")
        ins, outs = _records(inputs, outputs)
        ba = sensor_filter(self.sensor, T)
        if ba is not None:
            ins = [_apply_filter(ba, u) for u in ins]
        q = decimation_factor(T, self.max_rate_hz)
        if q > 1:
            return fit_decimated(self, ins, outs, T, q)
        self.decimation_ = 1
        p = outs[0].shape[0]
        block_rows = self.block_rows or max(10, 2 * self.max_order // p + 4)
        if self.order is not None:
            if not (isinstance(self.order, (int, np.integer)) and 1 <= self.order <= p * block_rows):
                raise DynamicsError(f"order: expected an integer in [1, {p * block_rows}], found {self.order!r}")
            candidates = np.array([int(self.order)])
        else:
            if not (isinstance(self.max_order, (int, np.integer)) and self.max_order >= 1):
                raise DynamicsError(f"max_order: expected an integer >= 1, found {self.max_order!r}")
            candidates = np.arange(1, min(int(self.max_order), p * block_rows) + 1)
        band = excited_band(ins, T) if self.band_hz is None else tuple(float(v) for v in self.band_hz)
        held = sorted({int(r) for r in (self.validation_records or ())})
        if held and (held[0] < 0 or held[-1] >= len(ins) or len(held) == len(ins)):
            raise DynamicsError(f"validation_records: expected indices of some (not all) of the "
                                f"{len(ins)} records, found {held}")
        if held:
            est_idx = [r for r in range(len(ins)) if r not in held]
            est_in, est_out = [ins[r] for r in est_idx], [outs[r] for r in est_idx]
            split = None
            known = [u.shape[1] - 2 * block_rows + 1 if r in est_idx else 0
                     for r, u in enumerate(ins)]
            self.validation_ = ("whole held-out record(s) " + ", ".join(str(r) for r in held)
                                + " (initial state estimated on each)")
        else:
            split = [int(round(u.shape[1] * (1 - self.validation_fraction))) for u in ins]
            est_in = [u[:, :s] for u, s in zip(ins, split)]
            est_out = [y[:, :s] for y, s in zip(outs, split)]
            known = [s - 2 * block_rows + 1 for s in split]
            self.validation_ = f"the last {100 * self.validation_fraction:.0f} % of each record"
        if min(u.shape[1] for u in est_in) <= 4 * block_rows:
            raise DynamicsError(f"records: too short for {block_rows} block rows "
                                f"(estimation parts of {min(u.shape[1] for u in est_in)} samples)")
        fits = np.full(candidates.size, np.nan)
        aic = np.full(candidates.size, np.nan)
        infos, models = [], {}
        if True:    # every candidate (a fixed order too) is checked and validated
            sid = self._subspace(est_in, est_out, block_rows)
            for i, n in enumerate(candidates):
                model, info, _ = self._candidate(*sid.system_ac(int(n)), est_in, est_out, band, T)
                info["order"] = int(n)
                models[int(n)] = model
                if model is not None:
                    yv, yh = self._validate(model, ins, outs, held, split)
                    fits[i] = float(np.mean(_fit_percent(yv, yh)))
                    info["validation_fit_percent"] = float(fits[i])
                    E = yv - yh
                    n_par = model[0].shape[0] * (model[0].shape[0] + 2 * p) + (
                        p * p if self.feedthrough else 0)
                    _, logdet = np.linalg.slogdet(E @ E.T / E.shape[1] + 1e-30 * np.eye(p))
                    aic[i] = E.shape[1] * logdet + 2 * n_par
                infos.append(info)
            if np.all(np.isnan(fits)) and self.order is not None:
                raise DynamicsError(f"order: the model of order {self.order} is rejected: "
                                    f"{infos[0].get('rejected', 'no mode left')}")
            if np.all(np.isnan(fits)):
                raise DynamicsError(f"order: no candidate order gave an acceptable model "
                                    f"({rejections(infos)})")
            fits = _without_lags(fits, infos, self.lag_tolerance)
            best = np.nanmax(fits)
            chosen = int(candidates[np.flatnonzero(fits >= best - self.order_tolerance)[0]])
        # the estimation parts' Hankel columns enter through their R factor
        sid_all = self._subspace(ins, outs, block_rows, sid, known)
        final, info, problem = self._candidate(*sid_all.system_ac(chosen), ins, outs, band, T)
        ref = models.get(chosen)
        if final is None or (ref is not None and final[0].shape != ref[0].shape):
            if ref is None:
                raise DynamicsError(f"order: the model of order {chosen} is rejected: "
                                    f"{info.get('rejected', 'no mode left')}")
            A, C = ref[0], ref[2]   # stable and checked on the estimation records
            problem = _BDX0Problem(A, C, ins, outs, self.feedthrough)
            B, D, x0 = problem.solve(self._dc(p))
        else:
            sid = sid_all
            A, B, C, D, x0 = final
        yhat = problem.outputs(B, D, x0)
        B0, D0, _ = problem.solve(None)   # the same records' R factors, without the constraint
        self.dc_gain_unconstrained_ = C @ np.linalg.solve(np.eye(A.shape[0]) - A, B0) + D0
        fit_all = _fit_percent(np.concatenate(outs, axis=1), np.concatenate(yhat, axis=1))
        if self.unit_dc_gain and getattr(self, "_free_gain", False):
            B, D = self._unit_dc(A, B, C, D, problem)
        self.system_ = control.ss(A, B, C, D, dt=T, name="identified_dynamics")
        self.order_ = int(A.shape[0])
        self.candidate_order_ = chosen
        self.singular_values_ = sid.singular_values.copy()
        self.orders_ = candidates
        self.validation_fit_ = fits
        self.aic_ = aic
        self.candidates_ = infos
        self.band_hz_ = band
        self.fit_percent_ = np.asarray(fit_all)
        self.initial_states_ = x0
        self.sampling_period_ = T
        return self

    def _dc(self, p):
        """The constraint on G(1) of the candidates' B, D fits: ``I`` with ``unit_dc_gain``,
        none when the records' own static gain decides (:meth:`_unit_dc` scales the chosen
        model after the order was chosen)."""
        return np.eye(p) if self.unit_dc_gain and not getattr(self, "_free_gain", False) \
            else None

    def _unit_dc(self, A, B, C, D, problem):
        """B, D of the chosen model with ``G(1) = I``: ``G M``, ``M = G(1)^-1`` (right, on G's
        inputs, the hysteresis model's outputs), or the constrained least squares when G(1)
        is near-singular.

        The records' own static gain (``dc_gain_unconstrained_``) differs from the
        identity where the hysteresis model draws the multisines' small loops with
        another gain than the actuator's (a Bouc-Wen stage: 0.88 and 0.94). Imposed
        in each candidate's least squares, ``G(1) = I`` left the fit a gain step to
        make in the band, which it made with slow, overdamped pole pairs (85.7 and
        282 Hz besides the 350 and 410 Hz modes, order 7 chosen): drives led the
        position by 2-4 samples, 15 µm circles at 50 Hz missed by 17.3 % of the radius.
        Fitted with the records' gain and scaled to ``G(1) = I`` afterwards, the same
        records give order 4 with the two modes alone, 5.3 %. Only where the records'
        ``G(1)`` departs from ``I`` by more than :data:`STATIC_GAIN_STEP`: there ``G(1)``
        of a free fit is an extrapolation below the band, and scaled by it the bundled
        realistic-2dof's identified dynamics drove its 50 µm circle at 50 Hz to 4.7 %
        instead of 1.0 %.
        """
        G1 = C @ np.linalg.solve(np.eye(A.shape[0]) - A, B) + D
        if not np.all(np.isfinite(G1)) or np.linalg.cond(G1) > 1e6:
            B, D, _ = problem.solve(np.eye(C.shape[0]))
            return B, D
        M = np.linalg.inv(G1)
        return B @ M, D @ M

    def _candidate(self, A, C, ins, outs, band, T):
        """A candidate model from (A, C): stable, no pole far below the band, no cancelled mode.

        Returns ``((A, B, C, D, x0), info, problem)`` or ``(None, info, None)``;
        ``info`` holds the kept ``modes`` ([Hz, damping]) and what was
        ``dropped`` or ``rejected``, ``problem`` the :class:`_BDX0Problem` of
        the returned A, C on the records (for other constraints or the fitted
        outputs).
        """
        info = {"dropped": []}
        problem = None
        z = np.linalg.eigvals(A)
        if np.max(np.abs(z)) >= 1:
            info["rejected"] = f"unstable (pole |z| = {np.max(np.abs(z)):.4g})"
            return None, info, None
        p = C.shape[0]
        prune = self.low_pole_fraction > 0 or self.cancel_tolerance > 0
        if prune:
            modal = real_modal(A, C, T)
            if modal is not None:
                A, C, mode_of, freq, zeta = modal
                low = self.low_pole_fraction * band[0]
                slow = np.flatnonzero(freq < low)
                for i in slow:
                    info["dropped"].append(f"pole at {freq[i]:.3g} Hz (damping {zeta[i]:.2f}) below "
                                           f"{low:.3g} Hz, far below the excited band from {band[0]:.3g} Hz")
                A, C, mode_of, freq, zeta = keep_modes(A, C, mode_of, freq, zeta,
                                                        np.setdiff1d(np.arange(freq.size), slow))
                if A.shape[0] == 0:
                    info["rejected"] = "every pole below the excited band"
                    return None, info, None
                if self.cancel_tolerance > 0:
                    problem = _BDX0Problem(A, C, ins, outs, self.feedthrough)
                    B, D, _ = problem.solve(self._dc(p))
                    share = mode_shares(A, B, C, D, mode_of, band, T)
                    weak = np.flatnonzero(share < self.cancel_tolerance)
                    if weak.size and weak.size < freq.size:
                        for i in weak:
                            info["dropped"].append(
                                f"near-cancelled mode at {freq[i]:.4g} Hz (its largest gain is "
                                f"{100 * share[i]:.2g} % of G's in the band)")
                        keep = np.setdiff1d(np.arange(freq.size), weak)
                        states = np.flatnonzero(np.isin(mode_of, keep))
                        A, C, mode_of, freq, zeta = keep_modes(A, C, mode_of, freq, zeta, keep)
                        problem = problem.subset(states, A, C)    # B refitted on the kept modes
        z = np.linalg.eigvals(A)
        neg = (np.abs(z.imag) < 1e-12) & (z.real <= 0)
        if self.require_continuous and np.any(neg):     # no real logm: the preset's continuous G (inverse ZOH) cannot exist
            info["rejected"] = (f"a real pole at z <= 0, which has no continuous ZOH "
                                f"equivalent: a mode at or beyond the Nyquist frequency "
                                f"{0.5 / T:.4g} Hz, aliased, or noise (z = {np.min(z.real[neg]):.3g})")
            return None, info, None
        if problem is None:
            problem = _BDX0Problem(A, C, ins, outs, self.feedthrough)
        B, D, x0 = problem.solve(self._dc(p))
        sysd = control.ss(A, B, C, D, dt=T)
        f, zz = modal_parameters(sysd)
        info["modes"] = [[float(a), float(b)] for a, b in zip(f, zz)]
        return (A, B, C, D, x0), info, problem

    def _validate(self, model, ins, outs, held, split):
        """Measured and simulated outputs of the held-out parts, concatenated."""
        A, B, C, D, x0 = model
        if split is None:     # each held-out record from its own least-squares initial state
            yv, yh = [], []
            for r in held:
                u, y = ins[r], outs[r]
                RB, R0 = _state_regressors(A, C, u)
                y_zero = (RB @ B.ravel()).T + D @ u
                R0 = R0.reshape(-1, A.shape[0])
                xr = np.linalg.lstsq(R0, (y - y_zero).T.reshape(-1), rcond=None)[0]
                yv.append(y)
                yh.append(y_zero + (R0 @ xr).reshape(-1, y.shape[0]).T)
            return np.concatenate(yv, axis=1), np.concatenate(yh, axis=1)
        yv = np.concatenate([y[:, s:] for y, s in zip(outs, split)], axis=1)
        yh = np.concatenate([_simulate(A, B, C, D, u, x)[:, s:]
                             for u, s, x in zip(ins, split, x0)], axis=1)
        return yv, yh




#: A pole pair damped at least this much has no resonance (a second-order lag's magnitude
#: peaks only for ``zeta < 1 / sqrt(2)``): with real poles, a lag.
LAG_DAMPING = 1.0 / np.sqrt(2.0)


def _lag_below_first_mode(modes):
    """Whether ``modes`` ([Hz, damping] pairs) hold a lag below their lowest resonant mode."""
    if not modes:
        return False
    resonant = [f for f, z in modes if z < LAG_DAMPING]
    return bool(resonant) and any(z >= LAG_DAMPING and f < min(resonant) for f, z in modes)


def _without_lags(fits, infos, tolerance):
    """``fits`` with NaN for the candidates whose lag below the first mode gains too little.

    A candidate holding a lag below its first bending mode stays a choice
    only where its held-out fit beats the best candidate without one by more
    than ``tolerance`` percentage points; each one left out says so in its
    ``info["rejected"]``.
    """
    if tolerance <= 0:
        return fits
    lagged = np.array([_lag_below_first_mode(info.get("modes")) for info in infos])
    clean = np.where(lagged, np.nan, fits)
    if not lagged.any() or np.all(np.isnan(clean)):
        return fits
    j = int(np.nanargmax(clean))
    best_clean = clean[j]
    out = fits.copy()
    for i in np.flatnonzero(lagged & ~np.isnan(fits)):
        if fits[i] <= best_clean + tolerance:
            out[i] = np.nan
            if fits[i] > best_clean:        # chosen on the fit alone, it could have been
                infos[i]["rejected"] = (
                    f"a lag below its first bending mode for {fits[i] - best_clean:+.2f} points "
                    f"of held-out fit over order {infos[j].get('order', j + 1)} without one "
                    f"(kept above +{tolerance:g}: a hysteresis model's error draws such lags)")
    return out


def rejections(candidates):
    """Why each candidate order was rejected, one clause per reason (every order named).

    Parameters
    ----------
    candidates : list of dict
        ``candidates_`` of a :class:`DynamicsIdentifier`: ``order`` and ``rejected``.

    Returns
    -------
    str
        E.g. ``"orders 1, 2: unstable (pole |z| = 1.002, 1.005); order 3: ..."``: the
        orders whose reasons differ only in their parenthesised numbers share a clause.

    Examples
    --------
    >>> rejections([{"order": 1, "rejected": "unstable (pole |z| = 1.002)"},
    ...             {"order": 2, "rejected": "unstable (pole |z| = 1.005)"},
    ...             {"order": 3, "rejected": "every pole below the excited band"}])
    'orders 1, 2: unstable (pole |z| = 1.002, 1.005); order 3: every pole below the excited band'
    """
    groups = {}
    for c in candidates:
        text = str(c.get("rejected", "") or "not rejected")
        head, sep, tail = text.partition(" (")
        key = (head, tail.rsplit("=", 1)[0] if sep and tail.endswith(")") else text)
        groups.setdefault(key, []).append((int(c["order"]), text, tail[:-1] if sep else ""))
    parts = []
    for (head, _), items in groups.items():
        orders = ", ".join(str(o) for o, _, _ in items)
        label = f"order{'s' if len(items) > 1 else ''} {orders}: "
        if len(items) == 1:
            parts.append(label + items[0][1])
            continue
        first = items[0][2]
        stem = first.rsplit("=", 1)[0] + "= " if "=" in first else ""
        values = ", ".join(t.rsplit("=", 1)[1].strip() if "=" in t else t for _, _, t in items)
        parts.append(f"{label}{head} ({stem}{values})" if first else label + head)
    return "; ".join(parts)


def identify_dynamics(inputs, outputs, sampling_period, order=None, max_order=8, sensor=None,
                      **options):
    """Identify the discrete linear part G from records (see :class:`DynamicsIdentifier`).

    Parameters
    ----------
    inputs : array_like, shape (p, n_samples), or list of them
        PI outputs ``Gamma(U)`` [µm] computed by the identified PI model.
    outputs : array_like, shape (p, n_samples), or list of them
        Measured displacements [µm].
    sampling_period : float
        T [s].
    order : int, optional
        Fixed order; chosen from the data when None.
    max_order : int
        Largest candidate order.
    sensor : Sensor, optional
        Sensor that measured the outputs; its low-pass is kept out of G.
    **options
        Other :class:`DynamicsIdentifier` parameters (``block_rows``,
        ``feedthrough``, ``validation_fraction``, ``order_tolerance``).

    Returns
    -------
    DynamicsIdentifier
        Fitted; the model is ``.system_``.

    Raises
    ------
    DynamicsError
    """
    return DynamicsIdentifier(order=order, max_order=max_order, sensor=sensor,
                              **options).fit(inputs, outputs, sampling_period)


def _band_bottom_gain(system, f_lo, scale=None):
    """Largest entry of ``|Re G(f_lo) - I|`` of a square ``G`` (in balanced units), or None."""
    if not (f_lo and np.isfinite(f_lo)) or system.noutputs != system.ninputs:
        return None
    try:                                  # python-control evaluates G at a point of z
        G = np.atleast_2d(np.asarray(system(np.exp(2j * np.pi * float(f_lo) * system.dt))))
    except (np.linalg.LinAlgError, ValueError):
        return None
    if scale is not None:
        G = (G / np.asarray(scale)[:, None]) * np.asarray(scale)[None, :]
    d = np.abs(np.real(G) - np.eye(G.shape[0]))
    return float(d.max()) if np.all(np.isfinite(d)) else None
