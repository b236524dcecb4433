"""Linear part G: building, checking and exciting it (behind :mod:`hammerstein.models.lti`).

State-space G from matrices, DC gains, modal parameters, continuous
equivalents, sensor filters, broadband excitations and Hammerstein records.
Signals are arrays of shape (n_signals, n_samples) [µm]; the references are
those of :mod:`hammerstein.models.lti`.
"""

from __future__ import annotations

import numpy as np

from hammerstein.models.dynamics import DynamicsError
from hammerstein.core.lazy import lazy_module
from hammerstein.core.numbers import magnitude_problem
from hammerstein.simulation import simulate_hysteresis, simulate_plant

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")  # lazy: ~0.1 s CPU of `from hammerstein import ...`


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
