"""Linear part G of the Hammerstein actuator: validation, identification, comparison.

The Hammerstein plant is ``U [V] -> Gamma (multivariable PI) -> H [µm] -> G -> Y
[µm]``. This module builds G from explicit matrices
(:func:`state_space_dynamics`), identifies a discrete G from records of the
PI outputs H (computed by an identified PI model) and the measured
displacements Y (:class:`DynamicsIdentifier`, :func:`identify_dynamics`),
designs broadband excitations (:func:`excitation`) and compares frequency
responses (:func:`compare_frequency_responses`).

Signals are arrays of shape (n_signals, n_samples) [µm]; a list of such
arrays is a list of records.

References
----------
.. [1] P. Van Overschee and B. De Moor, "N4SID: Subspace algorithms for the
   identification of combined deterministic-stochastic systems",
   Automatica 30(1), 75-93, 1994.
.. [2] M. Verhaegen and V. Verdult, *Filtering and System Identification: A
   Least Squares Approach*, Cambridge University Press, 2007 (PO-MOESP,
   Sections 9.6 and 10; estimation of B, D and x0 given A and C, Section 9.2.4).
.. [3] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
   Prentice Hall, 1999 (fit percentage, AIC, cross-validation, Section 16).
.. [4] R. Pintelon and J. Schoukens, *System Identification: A Frequency
   Domain Approach*, 2nd ed., Wiley-IEEE, 2012 (random-phase multisines;
   Section 6.3, a pure delay as the linear phase of a frequency response).
.. [5] G. F. Franklin, J. D. Powell and M. L. Workman, *Digital Control of
   Dynamic Systems*, 3rd ed., Addison-Wesley, 1998 (Section 4.3: the
   zero-order hold lags by half a sampling period).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.models.dynamics import DynamicsError
from hammerstein.core.lazy import lazy_module
from hammerstein.core.numbers import magnitude_problem
from hammerstein.simulation import simulate_hysteresis, simulate_plant

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")  # lazy: ~0.1 s CPU of `from hammerstein import ...`

__all__ = [
    "state_space_dynamics",
    "dc_gain",
    "align_dc_gain",
    "modal_parameters",
    "continuous_system",
    "sensor_filter",
    "excitation",
    "hammerstein_records",
    "DynamicsIdentifier",
    "identify_dynamics",
    "excited_band",
    "frf_h1",
    "MeasurementDelay",
    "estimate_measurement_delay",
    "compare_frequency_responses",
]


# -- validation ----------------------------------------------------------------------
def _matrix(value, key):
    try:
        M = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DynamicsError(f"dynamics.{key}: expected a numeric matrix (array of arrays), "
                            f"found {type(value).__name__}: {exc}") from None
    if M.ndim != 2:
        raise DynamicsError(f"dynamics.{key}: expected a matrix (array of arrays), found "
                            f"{M.ndim} dimension(s), shape {M.shape}")
    if not np.all(np.isfinite(M)):
        raise DynamicsError(f"dynamics.{key}: expected finite values, found NaN or inf")
    return M


def state_space_dynamics(A, B, C, D=None, names=None):
    """Validated continuous-time MIMO linear dynamics G from its matrices.

    ``dx/dt = A x + B h``, ``y = C x + D h``, where h (p,) are the PI outputs
    [µm] and y (p,) the displacements [µm]. The DC gain is whatever the
    matrices give (``-C A^-1 B + D``, reported by :func:`dc_gain`); it is not
    forced to the identity.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix [1/s]; every eigenvalue must have a negative real part.
    B : array_like, shape (n, p)
        Input matrix (p columns, one per PI output).
    C : array_like, shape (p, n)
        Output matrix (p rows, one per displacement).
    D : array_like, shape (p, p), optional
        Feedthrough [-]; zeros by default.
    names : sequence of str, optional
        Names of the p axes: inputs ``<name>_h``, outputs ``<name>``.

    Returns
    -------
    control.StateSpace
        Continuous-time system, p inputs, p outputs, n states.

    Raises
    ------
    DynamicsError
        On a non-numeric, non-finite or wrongly shaped matrix, a non-square
        system, or an eigenvalue of A with a non-negative real part; the
        message names the key (``dynamics.A: ...``).

    Examples
    --------
    >>> wn = 2 * 3.141592653589793 * 300.0
    >>> G = state_space_dynamics([[0.0, wn], [-wn, -0.3 * wn]], [[0.0], [wn]], [[1.0, 0.0]])
    >>> G.ninputs, G.noutputs, round(float(dc_gain(G)[0, 0]), 6)
    (1, 1, 1.0)
    """
    A = _matrix(A, "A")
    B = _matrix(B, "B")
    C = _matrix(C, "C")
    n = A.shape[0]
    if A.shape != (n, n) or n == 0:
        raise DynamicsError(f"dynamics.A: expected a non-empty square matrix, found shape {A.shape}")
    if B.shape[0] != n:
        raise DynamicsError(f"dynamics.B: expected {n} rows (one per state of A), found shape {B.shape}")
    p = B.shape[1]
    if p == 0:
        raise DynamicsError("dynamics.B: expected at least one column (one per PI output), found 0")
    if C.shape != (p, n):
        raise DynamicsError(
            f"dynamics.C: expected shape ({p}, {n}) (one row per displacement, as many as the "
            f"{p} columns of B; one column per state), found {C.shape}")
    D = np.zeros((p, p)) if D is None else _matrix(D, "D")
    if D.shape != (p, p):
        raise DynamicsError(f"dynamics.D: expected shape ({p}, {p}), found {D.shape}")
    eig = np.linalg.eigvals(A)
    if np.any(eig.real >= 0):
        bad = eig[eig.real >= 0]
        raise DynamicsError(
            "dynamics.A: expected an asymptotically stable system (every eigenvalue with "
            f"Re < 0), found {np.array2string(bad, precision=4)} [1/s]")
    names = [f"y{i}" for i in range(p)] if names is None else [str(s) for s in names]
    if len(names) != p:
        raise DynamicsError(f"dynamics.names: expected {p} names, found {len(names)}")
    return control.ss(A, B, C, D, inputs=[f"{s}_h" for s in names], outputs=names,
                      name="state_space_dynamics")


def dc_gain(system):
    """Static gain matrix of a stable continuous or discrete system.

    Parameters
    ----------
    system : control.StateSpace or control.TransferFunction
        p x p system.

    Returns
    -------
    numpy.ndarray, shape (p, p)
        ``G(s=0)`` or ``G(z=1)`` [µm/µm].
    """
    return np.atleast_2d(np.asarray(control.dcgain(system), dtype=float)).reshape(
        system.noutputs, system.ninputs)


def align_dc_gain(system, reference):
    """The same dynamics with the DC gain of another system: ``G G(0)^-1 R(0)``.

    A Hammerstein model ``G(Gamma(U))`` is identifiable only up to a static
    invertible matrix N (``G N^-1`` and ``N Gamma`` give the same actuator):
    a PI characterised quasi-statically absorbs the DC gain G(0) of the true
    dynamics (cross-coupling included), and the identified G comes out with
    ``G_id(0) ~ I``. Compare an identified G with ``align_dc_gain(G_true,
    numpy.eye(p))``, not with ``G_true``.

    Parameters
    ----------
    system : control.StateSpace
        p x p stable system (continuous or discrete), invertible DC gain.
    reference : control.StateSpace or array_like, shape (p, p)
        p x p system whose DC gain is taken, or that DC gain itself
        (``numpy.eye(p)``: unit DC gain; exact zeros of a decoupled G stay
        exact zeros when its G(0) is diagonal).

    Returns
    -------
    control.StateSpace
        ``system`` followed (on its inputs) by the static matrix
        ``G(0)^-1 R(0)``; same states, poles, ``dt`` and signal names.

    Raises
    ------
    DynamicsError
        When the DC gain of ``system`` is singular.

    Examples
    --------
    >>> wn = 2 * 3.141592653589793 * 300.0
    >>> G = state_space_dynamics([[0.0, wn], [-wn, -0.3 * wn]], [[0.0], [2 * wn]], [[1.0, 0.0]])
    >>> R = state_space_dynamics([[-wn]], [[wn]], [[1.0]])
    >>> round(float(dc_gain(align_dc_gain(G, R))[0, 0]), 9)
    1.0
    """
    G0 = dc_gain(system)
    try:
        R0 = dc_gain(reference) if hasattr(reference, "ninputs") else np.asarray(reference, float)
        N = np.linalg.solve(G0, R0)
    except np.linalg.LinAlgError:
        raise DynamicsError("dynamics: the DC gain G(0) is singular: cannot align it") from None
    return control.ss(system.A, system.B @ N, system.C, system.D @ N, system.dt,
                      inputs=system.input_labels, outputs=system.output_labels)


def modal_parameters(system):
    """Natural frequencies and damping ratios of the poles of a system.

    For a discrete system the poles are mapped by ``s = ln(z) / T``.

    Parameters
    ----------
    system : control.StateSpace
        Continuous or discrete system.

    Returns
    -------
    frequency_hz : numpy.ndarray, shape (n_modes,)
        Undamped natural frequency ``|s| / 2 pi`` [Hz], ascending, one per
        real pole or complex pair.
    damping_ratio : numpy.ndarray, shape (n_modes,)
        ``-Re(s) / |s|`` [-].
    """
    poles = np.asarray(system.poles(), dtype=complex)
    if system.isdtime(strict=True):
        poles = np.log(poles) / system.dt
    poles = poles[poles.imag >= -1e-9 * np.maximum(np.abs(poles), 1.0)]
    wn = np.abs(poles)
    zeta = np.where(wn > 0, -poles.real / np.where(wn > 0, wn, 1.0), 1.0)
    order = np.argsort(wn)
    return wn[order] / (2 * np.pi), zeta[order]


def continuous_system(system):
    """Continuous-time system whose ZOH discretisation is the given one.

    ``A_c = logm(A_d) / T``, ``B_c = (A_d - I)^-1 A_c B_d`` (inverse of the
    zero-order-hold map), C and D unchanged.

    Parameters
    ----------
    system : control.StateSpace
        Discrete system with no pole on the non-positive real axis.

    Returns
    -------
    control.StateSpace
        Continuous-time system.

    Raises
    ------
    DynamicsError
        If the system is not discrete or has a pole at or left of z = 0
        (no real matrix logarithm) or at z = 1.
    """
    if not system.isdtime(strict=True):
        raise DynamicsError("dynamics: expected a discrete-time system")
    Ad, Bd = np.asarray(system.A), np.asarray(system.B)
    z = np.linalg.eigvals(Ad)
    if np.any((np.abs(z.imag) < 1e-12) & (z.real <= 0)) or np.any(np.abs(z - 1) < 1e-12):
        raise DynamicsError("dynamics.A: a pole at z <= 0 or z = 1 has no continuous ZOH equivalent")
    Ac = np.real(scipy_linalg.logm(Ad)) / system.dt
    Bc = np.linalg.solve(Ad - np.eye(Ad.shape[0]), Ac @ Bd)
    return control.ss(Ac, Bc, np.asarray(system.C), np.asarray(system.D),
                      inputs=system.input_labels, outputs=system.output_labels)


# -- sensor --------------------------------------------------------------------------
def sensor_filter(sensor, sampling_period):
    """Discrete transfer function of a sensor's low-pass, as it measures.

    The :class:`hammerstein.identification.sensors.Sensor` low-pass is the first-order
    ``wc / (s + wc)`` discretised by the bilinear transform; this returns the
    same ``(b, a)`` polynomials (in ``z^-1``) that ``Sensor.measure`` runs.

    Parameters
    ----------
    sensor : Sensor or None
        Object with ``bandwidth_hz`` [Hz] (None: no filter).
    sampling_period : float
        T [s].

    Returns
    -------
    (b, a) : tuple of numpy.ndarray or None
        Filter coefficients, or None when the sensor has no low-pass.
    """
    bw = None if sensor is None else getattr(sensor, "bandwidth_hz", None)
    if bw is None:
        return None
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    wc = 2 * np.pi * float(bw)
    b, a, _ = scipy.signal.cont2discrete(([wc], [1.0, wc]), sampling_period, method="bilinear")
    return np.ravel(b), np.ravel(a)


def _apply_filter(ba, signal):
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    b, a = ba
    zi = scipy.signal.lfilter_zi(b, a)
    return np.vstack([scipy.signal.lfilter(b, a, row, zi=zi * row[0])[0] for row in signal])


# -- excitation ----------------------------------------------------------------------
def excitation(sampling_period, n_inputs, amplitude, f_max=2000.0, f_min=None, period=0.05,
               periods=3, offset=0.0, seed=0):
    """Random-phase multisine records, one per input in turn.

    Record k drives input k with ``offset + a sum_j cos(2 pi f_j t + phi_j)``
    on the grid ``f_j = j / period`` in ``[f_min, f_max]`` (flat amplitude
    spectrum, phases uniform in [0, 2 pi), Pintelon & Schoukens [4]), scaled
    so that its peak deviation from ``offset`` is ``amplitude``; the other
    inputs stay at ``offset``. Several periods allow the start-up transient
    to be discarded or estimated.

    Parameters
    ----------
    sampling_period : float
        T [s].
    n_inputs : int
        Number of inputs m.
    amplitude : float or array_like, shape (m,)
        Peak deviation per input [V] (or [µm] when exciting G directly).
    f_max : float
        Highest excited frequency [Hz], below the Nyquist frequency.
    f_min : float, optional
        Lowest excited frequency [Hz]; default ``1 / period``.
    period : float
        Multisine period [s] (frequency resolution ``1 / period``).
    periods : int
        Number of periods per record.
    offset : float or array_like, shape (m,)
        Constant level of every input [V].
    seed : int
        Seed of the random phases.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    records : list of numpy.ndarray, each shape (m, n_samples)
        One record per input.

    Raises
    ------
    ValueError
        On a non-positive amplitude, period or sampling period, or an empty
        frequency band.

    Examples
    --------
    >>> t, recs = excitation(5e-5, 2, 1.0, f_max=1000.0, period=0.01, periods=2)
    >>> len(recs), recs[0].shape, bool(abs(abs(recs[0][0]).max() - 1.0) < 1e-12)
    (2, (2, 400), True)
    """
    T = float(sampling_period)
    if not (np.isfinite(T) and T > 0):
        raise ValueError(f"sampling_period: expected > 0 s, found {sampling_period!r}")
    if not (np.isfinite(period) and period > 0) or int(periods) < 1:
        raise ValueError(f"period, periods: expected > 0 s and >= 1, found {period!r}, {periods!r}")
    m = int(n_inputs)
    amp = np.broadcast_to(np.asarray(amplitude, dtype=float), (m,))
    off = np.broadcast_to(np.asarray(offset, dtype=float), (m,))
    if not np.all(np.isfinite(amp)) or np.any(amp <= 0):
        raise ValueError(f"amplitude: expected positive values, found {amplitude!r}")
    n_period = int(round(period / T))
    df = 1.0 / (n_period * T)
    f_lo = df if f_min is None else float(f_min)
    f_hi = min(float(f_max), 0.5 / T * 0.98)
    j = np.arange(max(1, int(np.ceil(f_lo / df - 1e-9))), int(np.floor(f_hi / df + 1e-9)) + 1)
    if j.size == 0:
        raise ValueError(f"f_min, f_max: no multiple of 1/period = {df:g} Hz in [{f_lo}, {f_hi}] Hz")
    rng = np.random.default_rng(seed)
    t = np.arange(n_period * int(periods)) * T
    records = []
    for k in range(m):
        phases = rng.uniform(0, 2 * np.pi, j.size)
        one = np.cos(2 * np.pi * np.outer(j * df, t[:n_period]) + phases[:, None]).sum(axis=0)
        one = amp[k] * one / np.max(np.abs(one))
        u = np.repeat(off[:, None], t.size, axis=1).astype(float)
        u[k] += np.tile(one, int(periods))
        records.append(u)
    return t, records


def hammerstein_records(plant, model, voltages, sensor=None):
    """Simulate identification records of G on a Hammerstein plant.

    For each voltage record, the plant is simulated from rest, its outputs
    are measured through ``sensor``, and the PI outputs are computed by the
    (identified) PI ``model`` from the same voltages.

    Parameters
    ----------
    plant : HammersteinPlant
    model : MultivariablePI
        PI model used to compute the inputs of G (m inputs [V] -> p [µm]).
    voltages : list of array_like, each shape (m, n_samples)
        [V], e.g. from :func:`excitation`.
    sensor : Sensor, optional

    Returns
    -------
    inputs : list of numpy.ndarray, each shape (p, n_samples)
        ``Gamma_model(U)`` [µm].
    outputs : list of numpy.ndarray, each shape (p, n_samples)
        Measured displacements [µm].
    """
    inputs, outputs = [], []
    for u in voltages:
        y, _ = simulate_plant(plant, u)
        if sensor is not None:
            y = sensor.measure(y, plant.sampling_period)
        h, _ = simulate_hysteresis(model, u)
        inputs.append(h)
        outputs.append(y)
    return inputs, outputs


# -- identification ------------------------------------------------------------------
def _records(inputs, outputs):
    if isinstance(inputs, np.ndarray) or (isinstance(inputs, (list, tuple)) and inputs
                                          and np.ndim(inputs[0]) == 1):
        inputs, outputs = [inputs], [outputs]
    ins, outs = [], []
    for i, (u, y) in enumerate(zip(inputs, outputs, strict=True)):
        u = np.atleast_2d(np.asarray(u, dtype=float))
        y = np.atleast_2d(np.asarray(y, dtype=float))
        if u.ndim != 2 or y.ndim != 2 or u.shape[1] != y.shape[1]:
            raise DynamicsError(f"records[{i}]: expected inputs (m, N) and outputs (p, N) of equal "
                                f"length, found {u.shape} and {y.shape}")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
            raise DynamicsError(f"records[{i}]: expected finite signals")
        for what, a in (("inputs", u), ("outputs", y)):   # LAPACK fails (DLASCL) beyond it
            problem = magnitude_problem(a)
            if problem:
                raise DynamicsError(f"records[{i}]: {what}: {problem}")
        if ins and (u.shape[0] != ins[0].shape[0] or y.shape[0] != outs[0].shape[0]):
            raise DynamicsError(f"records[{i}]: signal counts differ from record 0")
        ins.append(u)
        outs.append(y)
    if not ins:
        raise DynamicsError("records: expected at least one record")
    return ins, outs


def _state_regressors(A, C, u):
    """Regressors of y on B (row-major vec) and on x0 for one record.

    Returns ``RB`` (N, p, n*m) and ``R0`` (N, p, n) with
    ``y_k = RB_k B.ravel() + R0_k x0 (+ D u_k)``, computed in modal
    coordinates (``A = V diag(lam) V^-1``, one first-order recursion per mode
    and input, run by :func:`scipy.signal.lfilter`); a loop is used when A is
    defective.
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
            for b in range(m):
                W[i, b] = scipy.signal.lfilter([0.0, 1.0], [1.0, -lam[i]], u[b].astype(complex))
        # the sums over the modes i as matrix products (BLAS) instead of einsum's loops:
        # RB[k, p, a, b] = sum_i CV[p, i] Vinv[i, a] W[i, b, k], R0[k, p, a] = sum_i
        # CV[p, i] Vinv[i, a] lam_i^k
        M = (CV[:, None, :] * Vinv.T[None, :, :]).reshape(p * n, n)           # (p a, i)
        RB = (M @ W.reshape(n, m * N)).real.reshape(p, n, m, N)
        RB = np.ascontiguousarray(RB.transpose(3, 0, 1, 2)).reshape(N, p, n * m)
        powers = lam[:, None] ** np.arange(N)[None, :]
        R0 = np.ascontiguousarray((M @ powers).real.reshape(p, n, N).transpose(2, 0, 1))
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


def _fit_bdx0(A, C, ins, outs, feedthrough, dc=None):
    """Least-squares B, D and one x0 per record given A, C [2, Section 9.2.4].

    With ``dc`` (p, m), under the linear equality constraint
    ``G(1) = C (I - A)^-1 B + D = dc`` (null-space method: the particular
    solution plus a least-squares combination of the null space of the
    constraint). Returns B, D, x0 and the simulated outputs of each record.
    """
    n, p, m = A.shape[0], C.shape[0], ins[0].shape[0]
    R = len(ins)
    n_shared = n * m + (p * m if feedthrough else 0)
    rows, rhs = [], []
    for r, (u, y) in enumerate(zip(ins, outs)):
        RB, R0 = _state_regressors(A, C, u)
        N = u.shape[1]
        blocks = [RB]
        if feedthrough:
            blocks.append(np.einsum("il,bk->kilb", np.eye(p), u).reshape(N, p, p * m))
        X0 = np.zeros((N, p, n * R))
        X0[:, :, r * n:(r + 1) * n] = R0
        blocks.append(X0)
        rows.append(np.concatenate(blocks, axis=2).reshape(N * p, -1))
        rhs.append(y.T.reshape(-1))
    X, rhs = np.vstack(rows), np.concatenate(rhs)
    if dc is None:
        theta = np.linalg.lstsq(X, rhs, rcond=None)[0]
    else:
        E = np.zeros((p * m, X.shape[1]))
        E[:, :n * m] = np.kron(C @ np.linalg.solve(np.eye(n) - A, np.eye(n)), np.eye(m))
        if feedthrough:
            E[:, n * m:n_shared] = np.eye(p * m)
        theta_p = np.linalg.lstsq(E, np.asarray(dc, dtype=float).reshape(-1), rcond=None)[0]
        N = scipy_linalg.null_space(E)
        theta = theta_p + N @ np.linalg.lstsq(X @ N, rhs - X @ theta_p, rcond=None)[0]
    B = theta[:n * m].reshape(n, m)
    D = theta[n * m:n_shared].reshape(p, m) if feedthrough else np.zeros((p, m))
    x0 = theta[n_shared:].reshape(R, n)
    yhat = [(X @ theta).reshape(-1, p).T for X in rows]
    return B, D, x0, yhat


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
    W += (lam[:, None] ** np.arange(u.shape[1])[None, :]) * (Vinv @ x0)[:, None]
    return (C @ V @ W).real + D @ u


class _MultiRecordMOESP:
    """PO-MOESP column space of the extended observability matrix, several records.

    Uses nfoursid's :class:`~nfoursid.nfoursid.NFourSID` (block Hankel
    matrices and the QR/LQ step of PO-MOESP, Verhaegen & Verdult [2], p. 329),
    with the Hankel columns of every record side by side, so that no column
    straddles two records. A and C follow from the shift invariance of the
    estimated extended observability matrix ``Gamma_i = U_n S_n^(1/2)``
    ([2], Section 9.6): ``C = Gamma_i[:p]``,
    ``A = pinv(Gamma_i[:-p]) Gamma_i[p:]``. (nfoursid's own
    ``system_identification`` regresses consecutive columns of a state
    sequence, which is not valid across record boundaries.)
    """

    def __init__(self, ins, outs, block_rows):
        import pandas as pd  # lazy: nfoursid's interface takes DataFrames
        from nfoursid.nfoursid import NFourSID  # lazy: only when dynamics are identified
        from nfoursid.utils import Utils
        m, p = ins[0].shape[0], outs[0].shape[0]
        cols_u = [f"u{i}" for i in range(m)]
        cols_y = [f"y{i}" for i in range(p)]
        frame = pd.DataFrame(np.concatenate([ins[0], outs[0]]).T, columns=cols_u + cols_y)
        sid = NFourSID(frame, output_columns=cols_y, input_columns=cols_u,
                       num_block_rows=block_rows)
        i = block_rows
        blocks = []
        for u, y in zip(ins, outs):
            uh = Utils.block_hankel_matrix(u.T, i)
            yh = Utils.block_hankel_matrix(y.T, i)
            blocks.append(np.concatenate([uh[:, i:], uh[:, :-i], yh[:, :-i], yh[:, i:]]))
        stacked = np.concatenate(blocks, axis=1)
        r = np.linalg.qr(stacked.T, mode="r").T
        y_rows, u_rows = p * i, m * i
        sid.R32 = r[-y_rows:, u_rows:-y_rows]
        sid.R22 = r[u_rows:-y_rows, u_rows:-y_rows]
        sid.R32_decomposition = Utils.eigenvalue_decomposition(sid.R32)
        self.nfoursid = sid
        self.p = p
        dec = sid.R32_decomposition
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
    unit_dc_gain : bool
        Fit B (and D) under the linear constraint ``G(z=1) = I`` (the
        static gain belongs to a quasi-statically identified hysteresis
        model); the unconstrained ``G(1)`` is kept in
        ``dc_gain_unconstrained_``. Default False.
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
        T [s].

    References
    ----------
    See the module references [1]-[3].

    Examples
    --------
    >>> import numpy as np, control
    >>> from hammerstein.models.dynamics import bending_modes, discretize
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

    @staticmethod
    def _subspace(ins, outs, block_rows):
        return _MultiRecordMOESP(ins, outs, block_rows)

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
                  else [int(v) for v in self.validation_records]}
        G = self.system_
        fitted = {k: np.asarray(getattr(G, k), dtype=float).tolist() for k in "ABCD"}
        fitted.update({"dt": float(G.dt), "name": str(G.name), "order_": int(self.order_),
                       "sampling_period_": float(self.sampling_period_)})
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
        T = float(sampling_period)
        if not (np.isfinite(T) and T > 0):
            raise DynamicsError(f"sampling_period: expected a positive time [s], found {sampling_period!r}")
        if not 0 < self.validation_fraction <= 0.9:
            raise DynamicsError(f"validation_fraction: expected in (0, 0.9], found {self.validation_fraction!r}")
        ins, outs = _records(inputs, outputs)
        ba = sensor_filter(self.sensor, T)
        if ba is not None:
            ins = [_apply_filter(ba, u) for u in ins]
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
            self.validation_ = ("whole held-out record(s) " + ", ".join(str(r) for r in held)
                                + " (initial state estimated on each)")
        else:
            split = [int(round(u.shape[1] * (1 - self.validation_fraction))) for u in ins]
            est_in = [u[:, :s] for u, s in zip(ins, split)]
            est_out = [y[:, :s] for y, s in zip(outs, split)]
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
                model, info = self._candidate(*sid.system_ac(int(n)), est_in, est_out, band, T)
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
            if np.all(np.isnan(fits)):
                why = "; ".join(f"order {c['order']}: {c.get('rejected', '')}" for c in infos[:4])
                raise DynamicsError(f"order: no candidate order gave an acceptable model ({why})")
            best = np.nanmax(fits)
            chosen = int(candidates[np.flatnonzero(fits >= best - self.order_tolerance)[0]])
        sid_all = self._subspace(ins, outs, block_rows)
        final, info = self._candidate(*sid_all.system_ac(chosen), ins, outs, band, T)
        ref = models.get(chosen)
        if final is None or (ref is not None and final[0].shape != ref[0].shape):
            if ref is None:
                raise DynamicsError(f"order: the model of order {chosen} is rejected: "
                                    f"{info.get('rejected', 'no mode left')}")
            A, C = ref[0], ref[2]   # stable and checked on the estimation records
            B, D, x0, yhat = _fit_bdx0(A, C, ins, outs, self.feedthrough, self._dc(p))
        else:
            sid = sid_all
            A, B, C, D, x0 = final
            _, _, _, yhat = _fit_bdx0(A, C, ins, outs, self.feedthrough, self._dc(p))
        B0, D0, _, _ = _fit_bdx0(A, C, ins, outs, self.feedthrough, None)
        self.dc_gain_unconstrained_ = C @ np.linalg.solve(np.eye(A.shape[0]) - A, B0) + D0
        fit_all = _fit_percent(np.concatenate(outs, axis=1), np.concatenate(yhat, axis=1))
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
        return np.eye(p) if self.unit_dc_gain else None

    def _candidate(self, A, C, ins, outs, band, T):
        """A candidate model from (A, C): stable, no pole far below the band, no cancelled mode.

        Returns ``((A, B, C, D, x0), info)`` or ``(None, info)``; ``info`` holds
        the kept ``modes`` ([Hz, damping]) and what was ``dropped`` or ``rejected``.
        """
        info = {"dropped": []}
        z = np.linalg.eigvals(A)
        if np.max(np.abs(z)) >= 1:
            info["rejected"] = f"unstable (pole |z| = {np.max(np.abs(z)):.4g})"
            return None, info
        p = C.shape[0]
        prune = self.low_pole_fraction > 0 or self.cancel_tolerance > 0
        if prune:
            modal = _real_modal(A, C, T)
            if modal is not None:
                A, C, mode_of, freq, zeta = modal
                low = self.low_pole_fraction * band[0]
                slow = np.flatnonzero(freq < low)
                for i in slow:
                    info["dropped"].append(f"pole at {freq[i]:.3g} Hz (damping {zeta[i]:.2f}) below "
                                           f"{low:.3g} Hz, far below the excited band from {band[0]:.3g} Hz")
                A, C, mode_of, freq, zeta = _keep_modes(A, C, mode_of, freq, zeta,
                                                        np.setdiff1d(np.arange(freq.size), slow))
                if A.shape[0] == 0:
                    info["rejected"] = "every pole below the excited band"
                    return None, info
                if self.cancel_tolerance > 0:
                    B, D, _, _ = _fit_bdx0(A, C, ins, outs, self.feedthrough, self._dc(p))
                    share = _mode_shares(A, B, C, D, mode_of, band, T)
                    weak = np.flatnonzero(share < self.cancel_tolerance)
                    if weak.size and weak.size < freq.size:
                        for i in weak:
                            info["dropped"].append(
                                f"near-cancelled mode at {freq[i]:.4g} Hz (its largest gain is "
                                f"{100 * share[i]:.2g} % of G's in the band)")
                        A, C, mode_of, freq, zeta = _keep_modes(
                            A, C, mode_of, freq, zeta, np.setdiff1d(np.arange(freq.size), weak))
        B, D, x0, _ = _fit_bdx0(A, C, ins, outs, self.feedthrough, self._dc(p))
        sysd = control.ss(A, B, C, D, dt=T)
        f, zz = modal_parameters(sysd)
        info["modes"] = [[float(a), float(b)] for a, b in zip(f, zz)]
        return (A, B, C, D, x0), info

    def _validate(self, model, ins, outs, held, split):
        """Measured and simulated outputs of the held-out parts, concatenated."""
        A, B, C, D, x0 = model
        if split is None:
            yv, yh = [], []
            for r in held:
                u, y = ins[r], outs[r]
                y_zero = _simulate(A, B, C, D, u, np.zeros(A.shape[0]))
                _, R0 = _state_regressors(A, C, u)
                xr = np.linalg.lstsq(R0.reshape(-1, A.shape[0]), (y - y_zero).T.reshape(-1),
                                     rcond=None)[0]
                yv.append(y)
                yh.append(_simulate(A, B, C, D, u, xr))
            return np.concatenate(yv, axis=1), np.concatenate(yh, axis=1)
        yv = np.concatenate([y[:, s:] for y, s in zip(outs, split)], axis=1)
        yh = np.concatenate([_simulate(A, B, C, D, u, x)[:, s:]
                             for u, s, x in zip(ins, split, x0)], axis=1)
        return yv, yh


def excited_band(inputs, sampling_period, threshold=0.01):
    """Frequency band excited by the input records (Welch power spectral density).

    The band spans the frequencies whose summed input power spectral density
    is at least ``threshold`` times its largest value (the excited lines of
    a flat multisine, the passband of a filtered noise).

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Input records [any unit].
    sampling_period : float
        T [s].
    threshold : float
        Relative density that counts as excited.

    Returns
    -------
    (f_lo, f_hi) : tuple of float
        Lowest and highest excited frequency [Hz] (above 0).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(20000) * 1e-4
    >>> u = np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 700 * t)
    >>> lo, hi = excited_band([u[None, :]], 1e-4)
    >>> bool(40 < lo < 55 and 690 < hi < 710)
    True
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    T = float(sampling_period)
    total = None
    for u in inputs:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        nper = int(min(u.shape[1], 2 ** 18))     # resolution of the whole record
        f, pxx = scipy.signal.welch(u - u.mean(axis=1, keepdims=True), fs=1.0 / T,
                                    nperseg=nper, axis=1)
        pxx = np.interp(np.linspace(0, 0.5 / T, 2 ** 16 + 1), f, pxx.sum(axis=0))
        total = pxx if total is None else total + pxx
    f = np.linspace(0, 0.5 / T, 2 ** 16 + 1)
    dens = total[1:]
    excited = np.flatnonzero(dens >= threshold * dens.max())
    if excited.size == 0:
        return float(f[1]), float(f[-1])
    return float(f[1:][excited[0]]), float(f[1:][excited[-1]])


def frf_h1(inputs, outputs, sampling_period, nperseg=None):
    """H1 estimate of a p x m frequency response from several records.

    ``H(f) = S_yu(f) S_uu(f)^-1`` with the cross- and auto-spectral density
    matrices summed over the records (Welch averages,
    :func:`scipy.signal.csd`, Hann window), so that records exciting one
    input each combine into the full matrix (Bendat & Piersol, *Random
    Data*, 4th ed., Wiley 2010, Section 9.3; Pintelon & Schoukens [4]).

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Inputs of G [µm] per record.
    outputs : list of array_like, each shape (p, n_samples)
        Measured outputs [µm] per record.
    sampling_period : float
        T [s].
    nperseg : int, optional
        Welch segment length; default the largest power of two up to a
        quarter of the shortest record (at least 256 samples).

    Returns
    -------
    frequency_hz : numpy.ndarray, shape (n_freq,)
        [Hz], without 0.
    H : numpy.ndarray, shape (p, m, n_freq)
        Complex frequency response [µm/µm]; NaN where ``S_uu`` is singular.

    Examples
    --------
    >>> import numpy as np, scipy.signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 20000))
    >>> y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.5], u)
    >>> f, H = frf_h1([u], [y], 1e-3)
    >>> bool(abs(abs(H[0, 0, 0]) - 1.0) < 0.02)
    True
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    ins, outs = _records(inputs, outputs)
    T = float(sampling_period)
    if nperseg is None:
        shortest = min(u.shape[1] for u in ins)
        nperseg = max(256, 2 ** int(np.floor(np.log2(max(shortest // 4, 2)))))
        nperseg = min(nperseg, shortest)
    m, p = ins[0].shape[0], outs[0].shape[0]
    Suu = Syu = f = None
    for u, y in zip(ins, outs):
        uu = np.empty((m, m, nperseg // 2 + 1), complex)
        yu = np.empty((p, m, nperseg // 2 + 1), complex)
        for a in range(m):
            for b in range(m):
                f, uu[a, b] = scipy.signal.csd(u[b], u[a], fs=1 / T, nperseg=nperseg)
            for c in range(p):
                f, yu[c, a] = scipy.signal.csd(u[a], y[c], fs=1 / T, nperseg=nperseg)
        Suu = uu if Suu is None else Suu + uu
        Syu = yu if Syu is None else Syu + yu
    H = np.full((p, m, f.size), np.nan, complex)
    for k in range(1, f.size):
        S = Suu[:, :, k]
        if np.linalg.cond(S) < 1e8:
            H[:, :, k] = Syu[:, :, k] @ np.linalg.inv(S)
    return f[1:], H[:, :, 1:]


@dataclass(frozen=True)
class MeasurementDelay:
    """Acquisition delay estimated from broadband records (:func:`estimate_measurement_delay`).

    Parameters
    ----------
    delay : int
        Estimated delay [samples] (the nearest integer to ``samples``);
        meaningful only when ``problem`` is None.
    samples : float
        Group delay of the measured frequency response over the fit band
        minus the half sample of the zero-order hold [samples].
    band_hz : tuple of float
        Fit band ``(f_lo, f_hi)`` [Hz]: the upper half of the excited band.
    std : float
        Standard deviation of ``samples`` [samples] (least squares on the
        phase, inflated for the correlation of neighbouring Welch lines).
    halves : tuple of float
        ``samples`` fitted on the lower and on the upper half of the fit
        band separately [samples] (a pure delay gives the same on both).
    residual_deg : float
        Weighted RMS of the phase left once the delay and one constant phase
        per transfer are removed [deg].
    n_lines : int
        Frequency lines used.
    problem : str or None
        Why the estimate is not trusted (phase not a straight line, output
        ahead of the input, band too narrow), else None.
    """

    delay: int
    samples: float
    band_hz: tuple
    std: float
    halves: tuple
    residual_deg: float
    n_lines: int
    problem: str | None = None

    @property
    def method(self):
        """One line: how the delay was found [text]."""
        return (f"phase slope of the measured H1 frequency response over "
                f"{self.band_hz[0]:.4g}-{self.band_hz[1]:.4g} Hz ({self.n_lines} lines): group "
                f"delay {self.samples + 0.5:.2f} samples less the zero-order hold's 0.5 = "
                f"{self.samples:.2f} +- {self.std:.2f} (halves of the band {self.halves[0]:.2f} / "
                f"{self.halves[1]:.2f}), phase residual {self.residual_deg:.2g} deg")


#: Largest spread [samples] between the two half-band estimates of a pure delay, beyond twice
#: the standard deviation of their difference.
DELAY_HALVES_TOLERANCE = 0.25
#: Inflation of a least-squares standard deviation over Hann-windowed, half-overlapping Welch
#: lines (neighbouring lines share about half their data).
WELCH_LINE_CORRELATION = 2.0
#: Fewest frequency lines in the fit band.
DELAY_MIN_LINES = 8


def _phase_slope(H, f, T, tau, weights):
    """``tau`` [samples] refined by weighted least squares on the wrapped residual phase.

    Model per transfer ``ab``: ``angle(H_ab(f) exp(j 2 pi f tau T)) = c_ab - 2 pi f T s``;
    returns ``(tau + s, weighted RMS residual [rad], standard deviation of tau [samples])``,
    the last from the least-squares covariance inflated by
    :data:`WELCH_LINE_CORRELATION` (neighbouring Welch lines are not independent).
    """
    for _ in range(3):
        R = H * np.exp(2j * np.pi * f * tau * T)
        rows, rhs, wts, cols = [], [], [], []
        n_tr = R.shape[0]
        for k in range(n_tr):
            ref = np.sum(weights[k] * R[k])
            ph = np.angle(R[k] * np.conj(ref))
            a = np.zeros((f.size, n_tr + 1))
            a[:, k] = 1.0
            a[:, -1] = -2 * np.pi * f * T
            rows.append(a)
            rhs.append(ph)
            wts.append(weights[k])
        A, b, w = np.vstack(rows), np.concatenate(rhs), np.sqrt(np.concatenate(wts))
        Aw = A * w[:, None]
        sol = np.linalg.lstsq(Aw, b * w, rcond=None)[0]
        tau = tau + sol[-1]
        res = (b - A @ sol) * w
    dof = max(b.size - sol.size, 1)
    cov = np.linalg.pinv(Aw.T @ Aw) * (np.sum(res ** 2) / dof)
    std = float(np.sqrt(max(cov[-1, -1], 0.0)) * WELCH_LINE_CORRELATION)
    return tau, float(np.sqrt(np.sum(res ** 2) / np.sum(w ** 2))), std


def estimate_measurement_delay(inputs, outputs, sampling_period, band_hz=None):
    """Integer acquisition delay of records, from the phase of their frequency response.

    A measured output that lags its input by ``d`` samples multiplies the
    frequency response by ``exp(-j 2 pi f d T)``: a phase falling linearly
    with frequency, 360 d f T degrees (540 deg for d = 3 at 10 kHz and
    20 kHz), while the phase of an actuator's bending modes settles to a
    constant (a multiple of -90 deg per relative degree) above them [4]. The
    H1 estimate (:func:`frf_h1`) of every transfer is taken over the upper
    half of the excited band (:func:`excited_band`), where a piezo
    actuator's modes are behind (10 Hz - 5 kHz multisines at 20 kHz:
    2.5-5 kHz); the common group delay ``tau`` of all transfers is the
    maximum over ``tau`` of ``sum_ab |sum_f H_ab(f) exp(j 2 pi f tau T)|``
    (a coherent sum, robust to phase wrapping; ``tau`` searched up to a
    quarter of the Welch segment, both signs), refined by weighted least
    squares on the residual phase (weights ``|H_ab(f)|^2``; one constant
    phase per transfer). A sampled actuator with no acquisition delay lags
    by the half sample of the zero-order hold [5]: the delay is
    ``round(tau - 0.5)``. The estimate is independent of the hysteresis
    model and of the model order of G (the records' inputs are taken as
    they are: a rate-independent hysteresis adds no linear phase).

    The estimate is refused (``problem``) when the fit band holds fewer than
    8 lines; when the two halves of the band give delays further apart
    than 0.25 samples plus twice the standard deviation of their difference
    (the phase is not a delay's straight line: a mode in the band); when
    the distance of the estimate to the nearest integer plus twice its
    standard deviation exceeds half a sample (noise, or a filter's fraction
    of a sample, leaves two integers possible); or when the outputs lead
    the inputs by a sample or more.

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Inputs of each record [V, or any unit].
    outputs : list of array_like, each shape (p, n_samples)
        Measured outputs of each record [µm, or any unit].
    sampling_period : float
        T [s].
    band_hz : tuple of float, optional
        Fit band ``(f_lo, f_hi)`` [Hz]; default the upper half of the
        excited band.

    Returns
    -------
    MeasurementDelay
        ``delay`` [samples], the fractional estimate, the band, the
        residual and ``problem`` (None when the estimate is trusted).

    Raises
    ------
    DynamicsError
        On malformed records (shapes, non-finite values) or a non-positive
        sampling period.

    Examples
    --------
    >>> import numpy as np, scipy.signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 16000))
    >>> y = scipy.signal.lfilter([0.0, 0.1], [1.0, -0.9], u)    # a lag sampled by a ZOH
    >>> estimate_measurement_delay([u], [y], 5e-5).delay, estimate_measurement_delay(
    ...     [u], [np.roll(y, 3)], 5e-5).delay
    (0, 3)
    """
    T = float(sampling_period)
    if not (np.isfinite(T) and T > 0):
        raise DynamicsError(f"sampling_period: expected a positive time [s], found "
                            f"{sampling_period!r}")
    ins, outs = _records(inputs, outputs)
    ins = [u - u.mean(axis=1, keepdims=True) for u in ins]
    outs = [y - y.mean(axis=1, keepdims=True) for y in outs]
    if band_hz is None:
        top = excited_band(ins, T)[1]
        band_hz = (0.5 * top, top)
    lo, hi = (float(v) for v in band_hz)
    f, H = frf_h1(ins, outs, T)
    seg = int(round(1.0 / (T * (f[1] - f[0])))) if f.size > 1 else 0
    sel = (f >= lo) & (f <= hi) & np.all(np.isfinite(H), axis=(0, 1))
    f, H = f[sel], H[:, :, sel].reshape(H.shape[0] * H.shape[1], int(sel.sum()))
    if f.size < DELAY_MIN_LINES:
        return MeasurementDelay(0, float("nan"), (lo, hi), float("nan"), (float("nan"),) * 2,
                                float("nan"), int(f.size), f"only {f.size} frequency lines in "
                                             f"{lo:.4g}-{hi:.4g} Hz (at least "
                                             f"{DELAY_MIN_LINES}: a longer or broader record)")
    weights = np.abs(H) ** 2
    reach = max(seg // 4, 4)
    grid = np.arange(-reach, reach + 0.125, 0.25)
    # coherent sum per transfer for every tau of the grid: (n_grid, n_transfers)
    J = np.abs(np.exp(2j * np.pi * T * grid[:, None] * f[None, :]) @ H.T).sum(axis=1)
    tau, res, std = _phase_slope(H, f, T, float(grid[np.argmax(J)]), weights)
    mid = 0.5 * (lo + hi)
    halves, hstd = [], []
    for part in (f < mid, f >= mid):
        t_h, _, s_h = _phase_slope(H[:, part], f[part], T, tau, weights[:, part])
        halves.append(t_h - 0.5)
        hstd.append(s_h)

    samples = tau - 0.5
    delay = int(np.round(samples))
    problem = None
    res_deg = float(np.degrees(res))
    spread = abs(halves[0] - halves[1])
    if not spread <= DELAY_HALVES_TOLERANCE + 2 * np.hypot(*hstd):
        problem = (f"the phase over {lo:.4g}-{hi:.4g} Hz is not a delay's straight line (the "
                   f"band's halves give {halves[0]:.2f} and {halves[1]:.2f} samples, "
                   f"+-{hstd[0]:.2f} and +-{hstd[1]:.2f}): a mode in the band?")
    elif not abs(samples - delay) + 2 * std <= 0.5:
        problem = (f"{samples:.2f} +- {std:.2f} samples does not single out one integer (noise "
                   f"over {lo:.4g}-{hi:.4g} Hz, phase residual {res_deg:.2g} deg, or a "
                   f"fraction of a sample from a filter)")
    elif delay < 0:
        problem = (f"the outputs lead the inputs by {-samples:.2f} samples (columns swapped, or "
                   f"clocks not shared?)")
    return MeasurementDelay(delay, float(samples), (lo, hi), float(std),
                            tuple(float(h) for h in halves), res_deg, int(f.size), problem)


def _real_modal(A, C, T):
    """Real modal form: ``(A_m, C_m, mode_of_state, frequency_hz, damping)`` or None.

    One 1 x 1 block per real pole, one 2 x 2 block ``[[sigma, omega], [-omega,
    sigma]]`` per complex pair; None when the eigenvectors are ill-conditioned.
    Natural frequency ``|s| / 2 pi`` [Hz] and damping ``-Re s / |s|`` of
    each mode from ``s = ln(z) / T``.
    """
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        return None
    cols, mode_of, poles = [], [], []
    for i in np.argsort(np.abs(lam)):
        if lam[i].imag < -1e-12:
            continue
        if lam[i].imag > 1e-12:
            cols += [V[:, i].real, V[:, i].imag]
            mode_of += [len(poles)] * 2
        else:
            cols.append(V[:, i].real)
            mode_of.append(len(poles))
        poles.append(lam[i])
    Tm = np.column_stack(cols)
    if Tm.shape != A.shape or np.linalg.cond(Tm) > 1e10:
        return None
    Am = np.linalg.solve(Tm, A @ Tm)
    s = np.log(np.asarray(poles, dtype=complex)) / T
    wn = np.abs(s)
    zeta = np.where(wn > 0, -s.real / np.where(wn > 0, wn, 1), 1.0)
    return Am, C @ Tm, np.asarray(mode_of), wn / (2 * np.pi), zeta


def _keep_modes(A, C, mode_of, freq, zeta, keep):
    idx = np.flatnonzero(np.isin(mode_of, keep))
    renum = {int(old): new for new, old in enumerate(keep)}
    return (A[np.ix_(idx, idx)], C[:, idx], np.array([renum[int(m)] for m in mode_of[idx]], int),
            freq[keep], zeta[keep])


def _mode_shares(A, B, C, D, mode_of, band, T):
    """Largest gain of each mode's term in the band over the largest gain of G there."""
    f = np.logspace(np.log10(max(band[0], 1e-3)), np.log10(min(band[1], 0.49 / T)), 200)
    z = np.exp(2j * np.pi * f * T)
    n_modes = int(mode_of.max()) + 1 if mode_of.size else 0
    total = np.zeros(f.size)
    share = np.zeros(n_modes)
    terms = []
    for i in range(n_modes):
        idx = np.flatnonzero(mode_of == i)
        Ai, Bi, Ci = A[np.ix_(idx, idx)], B[idx], C[:, idx]
        G = np.stack([Ci @ np.linalg.solve(zk * np.eye(idx.size) - Ai, Bi) for zk in z])
        terms.append(np.linalg.norm(G, 2, axis=(1, 2)))
    Gall = np.stack([C @ np.linalg.solve(zk * np.eye(A.shape[0]) - A, B) + D for zk in z])
    total = np.linalg.norm(Gall, 2, axis=(1, 2))
    for i, g in enumerate(terms):
        share[i] = g.max() / max(total.max(), 1e-300)
    return share


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


# -- comparison ----------------------------------------------------------------------
def compare_frequency_responses(identified, true, frequencies_hz=None):
    """Frequency responses of an identified and a reference system, all p x p entries.

    Parameters
    ----------
    identified, true : control.StateSpace or control.TransferFunction
        p x p systems (continuous or discrete; a discrete one is evaluated
        on ``z = exp(j w T)``).
    frequencies_hz : array_like, shape (n_freq,), optional
        [Hz]; default 200 log-spaced points from 1 Hz to 0.9 Nyquist (of
        the discrete systems, else 5 kHz).

    Returns
    -------
    dict
        ``frequency_hz`` (n_freq,); ``identified`` and ``true`` complex
        (p, p, n_freq); ``error`` ``|G_id - G_true|`` (p, p, n_freq);
        ``relative_error`` the error divided by the largest true gain of
        the same output row at that frequency (so that off-diagonal entries
        of a decoupled system have a meaningful scale) [-].
    """
    dts = [s.dt for s in (identified, true) if s.isdtime(strict=True)]
    if frequencies_hz is None:
        f_hi = 0.45 / min(dts) if dts else 5000.0
        frequencies_hz = np.logspace(0, np.log10(f_hi), 200)
    f = np.asarray(frequencies_hz, dtype=float)
    w = 2 * np.pi * f
    Gi = np.asarray(control.frequency_response(identified, w).complex).reshape(
        identified.noutputs, identified.ninputs, f.size)
    Gt = np.asarray(control.frequency_response(true, w).complex).reshape(
        true.noutputs, true.ninputs, f.size)
    err = np.abs(Gi - Gt)
    scale = np.max(np.abs(Gt), axis=1, keepdims=True)
    return {"frequency_hz": f, "identified": Gi, "true": Gt, "error": err,
            "relative_error": err / np.where(scale > 0, scale, 1.0)}
