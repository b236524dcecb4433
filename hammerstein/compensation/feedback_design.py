"""Feedback controllers: designs by name, LTIs given, discretisation, the kernel's controller.

Per axis, a controller is designed by name with physical parameters
(:func:`design_axis`: ``integral``, ``pi``, ``pi-notch``, ``ppf``, ``irc``)
or given as any LTI (transfer function or state space, continuous or
discrete), MIMO by ``state-space`` or ``mixsyn`` (python-control's
synthesis; it needs slycot). Continuous designs are discretised at the
sampling period by :func:`control.sample_system` (:func:`discretise`) into
the :class:`Controller` the closed-loop kernel steps, inputs ``[r; m; f]``
(reference, measurement, feedforward), with the states that integrate
flagged for the anti-windup. The loop itself:
:mod:`hammerstein.compensation.feedback`, which re-exports every public name.

Units: positions µm, voltages V, controller gains V/µm, frequencies Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.exceptions import FeedbackError

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")

__all__ = ["AXIS_KINDS", "METHODS", "AxisDesign", "balanced", "Controller", "design_axis", "discretise",
           "controller_from_lti", "diagonal_controller", "mixsyn_controller",
           "with_reference_filter", "with_internal_model"]

#: controllers designed by name, per axis
AXIS_KINDS = ("integral", "pi", "pi-notch", "ppf", "irc")
#: discretisation methods of :func:`control.sample_system` accepted here
METHODS = ("zoh", "foh", "tustin", "bilinear", "euler", "backward_diff", "matched")

def _pos(value, name, unit):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value <= 0:
        raise FeedbackError(f"{name}: expected a positive number [{unit}], found {value!r}")
    return float(value)


# -- the axis designs -----------------------------------------------------------------
@dataclass
class AxisDesign:
    """A continuous SISO design on the error ``e = r - m`` [µm] -> voltage [V].

    Parameters
    ----------
    system : control.StateSpace
        Continuous, 1 input (the error) or 3 (``[r, m, f]``), 1 output.
    integrators : numpy.ndarray of bool, shape (n_states,)
        States that integrate the error (clamped, back-calculated).
    description : str
        One line with the design's parameters.
    """

    system: control.StateSpace
    integrators: np.ndarray
    description: str


def _notch(f_hz, zeta_zero, zeta_pole):
    w = 2 * np.pi * f_hz
    A = np.array([[0.0, 1.0], [-w * w, -2 * zeta_pole * w]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[0.0, 2 * (zeta_zero - zeta_pole) * w]])
    return A, B, C, np.array([[1.0]])


def design_axis(kind, gain, crossover_hz, zero_hz=None, notch_hz=None, notch_damping=0.05,
                notch_width=0.5, mode_hz=None, ppf_gain=0.5, ppf_damping=0.3,
                feedthrough_ratio=1.5, damping_hz=None, irc_reference="error"):
    """Design one axis' feedback controller by name, with physical parameters.

    Every design acts on the tracking error ``e = r - m`` (so a perfect
    feedforward leaves it idle) and has an integral action of crossover
    ``crossover_hz`` on the axis' DC gain ``gain``:

    ``integral``
        ``K = k_i / s``, ``k_i = 2 pi f_c / g``.
    ``pi``
        ``K = k_p (1 + w_z / s)``, ``|g K(j w_c)| = 1``; ``zero_hz`` defaults
        to ``2 crossover_hz``: on a plant flat up to its modes (a piezo
        stage) the loop is then an integrator up to the zero and flat at
        ``k_p g < 1`` beyond, instead of ``k_p g ~ 1`` from the zero on.
    ``pi-notch``
        The PI in series with a notch at ``notch_hz``:
        ``(s^2 + 2 zeta_z w_n s + w_n^2) / (s^2 + 2 zeta_p w_n s + w_n^2)``
        (``notch_damping`` zeta_z, ``notch_width`` zeta_p).
    ``ppf``
        Positive position feedback (Fanson and Caughey, AIAA J. 28(4),
        1990) on the error, ``-(gamma / g) w_f^2 / (s^2 + 2 zeta_f w_f s +
        w_f^2)`` tuned at ``mode_hz``, plus the integral on the damped
        plant (DC gain ``g / (1 - gamma)``).
    ``irc``
        Integral resonant control (Aphale, Fleming and Moheimani, Smart
        Mater. Struct. 16, 2007): the integral of ``y_hat = m + D_f u``
        with a feedthrough ``D_f = -beta g``, ``k = 2 pi f_d / g``
        (``damping_hz``, default ``mode_hz``), and an outer tracking
        integral. ``irc_reference = "error"`` (default): on the error,
        ``x_i' = k (-e - x_o + D_f x_i)``, ``x_o' = (1 - beta) w_c e``,
        ``u = x_i``: a perfect feedforward leaves it idle, but alone its
        reference reaches the error through ``|S| ~ beta / (beta - 1)``
        between the crossover and the mode. ``"static"``: the feedthrough
        on the whole voltage ``f + x_i`` and the inner reference
        ``(1 - beta) r``, ``x_i' = k (m + D_f (f + x_i) - (1 - beta) r -
        x_o)``, ``x_o' = (1 - beta) w_c (r - m)`` (inputs ``[r, m, f]``):
        quasi-static gain 1 alone, but a feedforward that is not ``r / g``
        (a hysteresis inverse) disturbs it.

    Parameters
    ----------
    kind : {'integral', 'pi', 'pi-notch', 'ppf', 'irc'}
    gain : float
        The axis' DC gain g [µm/V] (hysteresis secant gain times the
        linear part's DC gain).
    crossover_hz : float
        Crossover of the integral (tracking) action [Hz].
    zero_hz, notch_hz, notch_damping, notch_width, mode_hz, ppf_gain, ppf_damping : float
        See above (frequencies in Hz, the rest dimensionless).
    feedthrough_ratio, damping_hz : float
        See above (``irc``).
    irc_reference : {'error', 'static'}
        See above (``irc``).

    Returns
    -------
    AxisDesign
        Continuous state space (1 input, the error; ``irc``: 3 inputs
        ``[r, m, f]``) and its integrator states.

    Raises
    ------
    FeedbackError
        On an unknown kind, a missing or non-positive parameter.

    Examples
    --------
    >>> from hammerstein.compensation.feedback import design_axis
    >>> d = design_axis("pi", gain=5.0, crossover_hz=100.0)
    >>> d.system.nstates, bool(d.integrators[0])
    (1, True)
    """
    if kind not in AXIS_KINDS:
        raise FeedbackError(f"kind: expected one of {AXIS_KINDS}, found {kind!r}")
    g = _pos(gain, "gain", "µm/V")
    fc = _pos(crossover_hz, "crossover_hz", "Hz")
    wc = 2 * np.pi * fc
    if kind == "integral":
        ki = wc / g
        sys = control.ss([[0.0]], [[ki]], [[1.0]], [[0.0]])
        return AxisDesign(sys, np.array([True]), f"integral, k_i = {ki:.4g} V/(µm s) "
                                                 f"(crossover {fc:g} Hz)")
    if kind in ("pi", "pi-notch"):
        fz = 2 * fc if zero_hz is None else _pos(zero_hz, "zero_hz", "Hz")
        kp = 1.0 / (g * math.hypot(1.0, fz / fc))
        ki = kp * 2 * np.pi * fz
        text = f"PI, k_p = {kp:.4g} V/µm, zero {fz:g} Hz (crossover {fc:g} Hz)"
        if kind == "pi":
            sys = control.ss([[0.0]], [[ki]], [[1.0]], [[kp]])
            return AxisDesign(sys, np.array([True]), text)
        if notch_hz is None:
            raise FeedbackError("notch_hz: expected the frequency of the mode to notch [Hz]")
        An, Bn, Cn, Dn = _notch(_pos(notch_hz, "notch_hz", "Hz"),
                                _pos(notch_damping, "notch_damping", "-"),
                                _pos(notch_width, "notch_width", "-"))
        # v = x_i + k_p e (PI), then the notch: x_n' = A_n x_n + B_n v, u = C_n x_n + v
        A = np.zeros((3, 3))
        A[1:, 1:] = An
        A[1:, :1] = Bn
        B = np.array([[ki], [Bn[0, 0] * kp], [Bn[1, 0] * kp]])
        C = np.array([[1.0, Cn[0, 0], Cn[0, 1]]])
        D = np.array([[kp]])
        return AxisDesign(control.ss(A, B, C, D), np.array([True, False, False]),
                          text + f", notch {notch_hz:g} Hz (zeta {notch_damping:g}/"
                                 f"{notch_width:g})")
    if mode_hz is None:
        raise FeedbackError("mode_hz: expected the frequency of the mode to damp [Hz]")
    wf = 2 * np.pi * _pos(mode_hz, "mode_hz", "Hz")
    if kind == "ppf":
        gamma = _pos(ppf_gain, "ppf_gain", "-")
        if gamma >= 1:
            raise FeedbackError(f"ppf_gain: expected < 1 (the PPF loop is unstable at DC "
                                f"beyond), found {gamma!r}")
        zf = _pos(ppf_damping, "ppf_damping", "-")
        ki = wc * (1 - gamma) / g
        # states x_i, x_f1, x_f2: x_f'' = -2 zeta w x_f' - w^2 x_f + e
        A = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -wf * wf, -2 * zf * wf]])
        B = np.array([[ki], [0.0], [1.0]])
        C = np.array([[1.0, -gamma / g * wf * wf, 0.0]])
        return AxisDesign(control.ss(A, B, C, [[0.0]]), np.array([True, False, False]),
                          f"PPF at {mode_hz:g} Hz (gain {gamma:g}, damping {zf:g}) + integral, "
                          f"crossover {fc:g} Hz")
    beta = _pos(feedthrough_ratio, "feedthrough_ratio", "-")
    if beta <= 1:
        raise FeedbackError(f"feedthrough_ratio: expected > 1 (|D_f| above the DC gain), "
                            f"found {beta!r}")
    fd = mode_hz if damping_hz is None else _pos(damping_hz, "damping_hz", "Hz")
    k = 2 * np.pi * fd / g
    Df = -beta * g
    if irc_reference not in ("error", "static"):
        raise FeedbackError(f"irc_reference: expected 'error' or 'static', found "
                            f"{irc_reference!r}")
    text = (f"IRC ({irc_reference}), D_f = {Df:.4g} µm/V, k = {k:.4g} V/(µm s) ({fd:g} Hz) + "
            f"tracking integral, crossover {fc:g} Hz")
    A = np.array([[k * Df, -k], [0.0, 0.0]])
    C = np.array([[1.0, 0.0]])
    if irc_reference == "error":
        # on the error e = r - m: x_i' = k (-e - x_o + D_f x_i), x_o' = (1 - beta) w_c e
        B = np.array([[-k], [(1 - beta) * wc]])
        return AxisDesign(control.ss(A, B, C, [[0.0]]), np.array([True, True]), text)
    # inputs [r, m, f]: x_i' = k (m + D_f (f + x_i) - (1 - beta) r - x_o),
    # x_o' = (1 - beta) w_c (r - m)
    B = np.array([[-k * (1 - beta), k, k * Df], [(1 - beta) * wc, -(1 - beta) * wc, 0.0]])
    return AxisDesign(control.ss(A, B, C, [[0.0, 0.0, 0.0]]), np.array([True, True]), text)


def discretise(system, sampling_period, method="tustin"):
    """Discretise a continuous controller at the sampling period (python-control).

    Parameters
    ----------
    system : control.StateSpace or control.TransferFunction
        Continuous (``dt = 0``).
    sampling_period : float
        T [s].
    method : str
        One of :data:`METHODS`, passed to :func:`control.sample_system`
        (``matched``: SISO only, through the transfer function).

    Returns
    -------
    control.StateSpace
        Discrete, ``dt = sampling_period``. For ``zoh``, ``foh``,
        ``tustin``, ``euler`` and ``backward_diff`` on a state space, the
        states keep their meaning (integrators stay integrators).

    Raises
    ------
    FeedbackError
        On an unknown method, or ``matched`` on a MIMO system.
    """
    if method not in METHODS:
        raise FeedbackError(f"method: expected one of {METHODS}, found {method!r}")
    T = _pos(sampling_period, "sampling_period", "s")
    if method == "matched":
        if system.ninputs != 1 or system.noutputs != 1:
            raise FeedbackError("method: 'matched' discretises SISO transfer functions only")
        return control.ss(control.sample_system(control.tf(system), T, method="matched"))
    return control.ss(control.sample_system(control.ss(system), T, method=method))


# -- controllers -------------------------------------------------------------------------
@dataclass
class Controller:
    """A discrete feedback controller, inputs ``[r; m; f]`` -> voltages (m) [V].

    ``x_c(t+T) = A x_c + B [r; m; f]``, ``v = C x_c + D [r; m; f]``, with the
    reference r and measurement m (p each) [µm] and the feedforward voltages
    f (m) [V] (read by the IRC design; zero columns otherwise); the voltage
    applied is ``f + v``. An error-driven controller ``K(z)`` has
    ``B = [B_e, -B_e, 0]``, ``D = [D_e, -D_e, 0]``.

    Parameters
    ----------
    A, B, C, D : numpy.ndarray
        Shapes (n, n), (n, 2 p + m), (m, n), (m, 2 p + m).
    sampling_period : float
        T [s].
    integrators : numpy.ndarray of bool, shape (n,)
        States the anti-windup acts on.
    descriptions : list of str
        One line per axis (or one for a MIMO design).
    continuous : control.StateSpace or None
        The continuous design on the error (p -> m), before discretisation.
    axes : list of control.StateSpace or None
        A diagonal controller's discrete SISO parts (error l -> voltage l),
        for the per-axis loops; None for a MIMO design.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    sampling_period: float
    integrators: np.ndarray
    descriptions: list = field(default_factory=list)
    continuous: control.StateSpace | None = None
    axes: list | None = None

    @property
    def n_states(self) -> int:
        """Number of controller states."""
        return self.A.shape[0]

    @property
    def n_outputs(self) -> int:
        """Number of voltages m."""
        return self.C.shape[0]

    @property
    def n_measurements(self) -> int:
        """Number of measured positions p."""
        return (self.B.shape[1] - self.C.shape[0]) // 2

    def to_control(self):
        """The discrete controller as a ``control.StateSpace`` with inputs ``[r; m; f]``.

        Returns
        -------
        control.StateSpace
        """
        return control.ss(self.A, self.B, self.C, self.D, self.sampling_period)

    def feedback_part(self):
        """The controller from the measurement ``m`` to the voltage, sign of ``u = -K_y m``.

        Returns
        -------
        control.StateSpace
            ``K_y`` (p -> m), discrete, so that the loop broken at the
            plant's input is ``L = K_y P``.
        """
        p = self.n_measurements
        return control.ss(self.A, -self.B[:, p:2 * p], self.C, -self.D[:, p:2 * p],
                          self.sampling_period)


def balanced(system):
    """A state space scaled by a diagonal similarity so that its rows and columns have
    comparable norms (LAPACK's balancing, :func:`scipy.linalg.matrix_balance` without
    permutation): the same transfer function, the same states up to scale.

    The companion form python-control gives a transfer function spans many decades (a
    PI, a notch and a low-pass at 20 kHz: entries from 1e-23 to 3.6e16), and its
    discretisation warned four times of an ill-conditioned matrix (rcond 1e-19).

    Parameters
    ----------
    system : control.StateSpace

    Returns
    -------
    control.StateSpace
        ``A' = S^-1 A S``, ``B' = S^-1 B``, ``C' = C S`` with S diagonal (powers of 2,
        so that the scaling itself rounds nothing).
    """
    A = np.asarray(system.A, float)
    if A.size == 0:
        return system
    _, (scale, _) = scipy_linalg.matrix_balance(A, permute=False, separate=True)
    return control.ss(A * scale[None, :] / scale[:, None],
                      np.asarray(system.B, float) / scale[:, None],
                      np.asarray(system.C, float) * scale[None, :], system.D, system.dt)


def controller_from_lti(system, sampling_period, method="tustin", integrators=None,
                        description="LTI"):
    """An error-driven :class:`Controller` from any python-control LTI on the error.

    Parameters
    ----------
    system : control.StateSpace or control.TransferFunction
        ``e`` (p) [µm] -> voltages (m) [V]; continuous (discretised by
        ``method``) or discrete with ``dt == sampling_period``.
    sampling_period : float
        T [s].
    method : str
        See :func:`discretise`.
    integrators : array_like of bool, optional
        States the anti-windup acts on (default all).
    description : str
        One line for the report.

    Returns
    -------
    Controller

    Raises
    ------
    FeedbackError
        On a discrete system of another sampling period.
    """
    if isinstance(system, control.TransferFunction):   # its companion form, scaled
        system = balanced(control.ss(system))
    cont = None
    if system.isctime(strict=True):
        cont = control.ss(system)
        d = discretise(system, sampling_period, method)
    else:
        if not np.isclose(system.dt, sampling_period) and system.dt is not True:
            raise FeedbackError(f"controller: discrete with dt = {system.dt}, expected "
                                f"{sampling_period} s")
        d = control.ss(system)
    A, B, C, D = (np.atleast_2d(np.asarray(M, dtype=float)) for M in (d.A, d.B, d.C, d.D))
    n = A.shape[0] if A.size else 0
    if n == 0:
        A, B, C = np.zeros((0, 0)), np.zeros((0, D.shape[1])), np.zeros((D.shape[0], 0))
    mask = np.ones(n, bool) if integrators is None else np.asarray(integrators, bool)
    if mask.shape != (n,):
        raise FeedbackError(f"integrators: expected {n} flags, found {mask.shape}")
    m = D.shape[0]
    return Controller(A, np.hstack([B, -B, np.zeros((n, m))]), C,
                      np.hstack([D, -D, np.zeros((m, m))]), float(sampling_period), mask,
                      [description], cont, [d] if d.ninputs == 1 and d.noutputs == 1 else None)


def _two_dof_axis(design, sampling_period, method):
    """A one-axis Controller from a design whose system has the inputs ``[r, m, f]``."""
    d = discretise(design.system, sampling_period, method)
    A, B, C, D = (np.atleast_2d(np.asarray(M, dtype=float)) for M in (d.A, d.B, d.C, d.D))
    Be = np.asarray(design.system.B)[:, [0]]
    De = np.zeros((1, 1))
    cont = control.ss(design.system.A, Be, design.system.C, De)   # its reference path
    loop = control.ss(A, -B[:, [1]], C, -D[:, [1]], sampling_period)   # u = -K_y m
    return Controller(A, B, C, D, float(sampling_period), np.asarray(design.integrators, bool),
                      [design.description], cont, [loop])


def diagonal_controller(designs, sampling_period, method="tustin"):
    """The MIMO diagonal controller of per-axis designs, discretised axis by axis.

    Parameters
    ----------
    designs : sequence of AxisDesign or control LTI
        One per axis (axis l drives input l from error l).
    sampling_period : float
        T [s].
    method : str
        See :func:`discretise`.

    Returns
    -------
    Controller
    """
    parts = [(_two_dof_axis(d, sampling_period, method) if d.system.ninputs == 3 else
              controller_from_lti(d.system, sampling_period, method, d.integrators, d.description))
             if isinstance(d, AxisDesign) else controller_from_lti(d, sampling_period, method)
             for d in designs]
    p = len(parts)
    A = scipy_linalg.block_diag(*[c.A for c in parts]) if any(c.n_states for c in parts) \
        else np.zeros((0, 0))
    n = A.shape[0]
    B = np.zeros((n, 3 * p))
    C = np.zeros((p, n))
    D = np.zeros((p, 3 * p))
    i = 0
    for l, c in enumerate(parts):
        k = c.n_states
        for j in range(3):               # the axis' r, m and f columns
            B[i:i + k, j * p + l] = c.B[:, j]
            D[l, j * p + l] = c.D[0, j]
        C[l, i:i + k] = c.C[0]
        i += k
    cont = None
    if all(c.continuous is not None for c in parts):
        cont = control.append(*[c.continuous for c in parts])
    return Controller(A, B, C, D, float(sampling_period),
                      np.concatenate([c.integrators for c in parts]) if n else np.zeros(0, bool),
                      [c.descriptions[0] for c in parts], cont, [c.axes[0] for c in parts])


def with_reference_filter(controller, sensor):
    """The controller with its reference input passed through a replica of the sensor.

    ``K'([r; m]) = K([S r; m])``: the error is formed against the reference
    delayed and filtered as the measurement is, so the sensor's lag is not
    mistaken for a tracking error (a two-degree-of-freedom structure).

    Parameters
    ----------
    controller : Controller
        Inputs ``[r; m]`` (2 p).
    sensor : control.StateSpace
        Discrete sensor with its delay, p -> p (:meth:`Sensor.to_control`).

    Returns
    -------
    Controller
        States: the replica's, then the controller's (the replica's are no
        integrators).
    """
    p = controller.n_measurements
    m = controller.n_outputs
    Af, Bf, Cf, Df = (np.asarray(M, float) for M in (sensor.A, sensor.B, sensor.C, sensor.D))
    nf = Af.shape[0] if Af.size else 0
    Af, Bf, Cf = Af.reshape(nf, nf), Bf.reshape(nf, p), Cf.reshape(p, nf)
    A, B, C, D = controller.A, controller.B, controller.C, controller.D
    Br, Bm, Dr, Dm = B[:, :p], B[:, p:], D[:, :p], D[:, p:]     # Bm, Dm: m and f columns
    n = A.shape[0]
    A2 = np.block([[Af, np.zeros((nf, n))], [Br @ Cf, A]])
    B2 = np.block([[Bf, np.zeros((nf, p + m))], [Br @ Df, Bm]])
    C2 = np.hstack([Dr @ Cf, C])
    D2 = np.hstack([Dr @ Df, Dm])
    return Controller(A2, B2, C2, D2, controller.sampling_period,
                      np.concatenate([np.zeros(nf, bool), controller.integrators]),
                      list(controller.descriptions), controller.continuous, controller.axes)


def _continuous(system):
    """Continuous equivalent of a discrete state space (inverse of the zero-order hold)."""
    T = system.dt
    A, B = np.asarray(system.A), np.asarray(system.B)
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:], M[n:, n:] = A, B, np.eye(m)
    L = scipy_linalg.logm(M).real / T
    return control.ss(L[:n, :n], L[:n, n:], system.C, system.D)


def mixsyn_controller(plant_linear, sampling_period, bandwidth_hz, max_sensitivity=2.0,
                      effort=0.1, method="tustin"):
    """Mixed-sensitivity H-infinity controller (python-control's ``mixsyn``; needs slycot).

    Weights: ``W1 = (s / M + w_b) / (s + w_b 1e-4)`` on S per axis, the
    constant ``effort`` on the control sensitivity; the plant is the
    continuous equivalent (inverse zero-order hold) of the linearised loop.

    Parameters
    ----------
    plant_linear : control.StateSpace
        Discrete linearised plant (:func:`linearised_plant`).
    sampling_period : float
        T [s].
    bandwidth_hz : float
        Sensitivity bandwidth w_b [Hz].
    max_sensitivity : float
        Peak of |S| allowed, M.
    effort : float
        Weight on the control sensitivity [V/µm]^-1.
    method : str
        Discretisation (:func:`discretise`).

    Returns
    -------
    Controller

    Raises
    ------
    FeedbackError
        When slycot (python-control's synthesis backend) is not installed, or
        the synthesis fails.
    """
    try:
        import slycot  # noqa: F401  (third-party: python-control's synthesis backend)
    except ImportError:
        raise FeedbackError("mixsyn: python-control's H-infinity synthesis needs slycot, "
                            "which is not installed (pip install slycot)") from None
    wb = 2 * np.pi * _pos(bandwidth_hz, "bandwidth_hz", "Hz")
    G = _continuous(plant_linear)
    p = G.noutputs
    w1 = control.append(*[control.ss(control.tf([1 / max_sensitivity, wb], [1, wb * 1e-4]))
                          for _ in range(p)])
    w2 = control.append(*[control.ss([], [], [], [[effort]]) for _ in range(p)])
    try:
        K, _, _ = control.mixsyn(G, w1, w2, None)
    except Exception as exc:  # slycot's errors are of its own classes
        raise FeedbackError(f"mixsyn: the synthesis failed: {exc}") from exc
    return controller_from_lti(K, sampling_period, method,
                               description=f"mixsyn, bandwidth {bandwidth_hz:g} Hz, "
                                           f"M = {max_sensitivity:g}, effort {effort:g}")


def with_internal_model(design, loop_response, sampling_period, frequencies_hz,
                        decay_periods=2.0):
    """A design with internal-model (resonant) elements at given frequencies, in series.

    The internal model principle (Francis and Wonham, Automatica 12(5),
    1976): a loop whose controller holds a model of a periodic signal's
    generator (poles at ``±j w_h``) rejects that signal in steady state,
    ``|S(j w_h)| = 0``. Each element is the phase-compensated resonator
    ``R_h(s) = k_h w_h (s cos phi_h + w_h sin phi_h) / (s^2 + w_h^2)``,
    applied to the error before the design (``K' = K (1 + sum_h R_h)``).
    Closing it around the loop ``L = K S P`` factors the characteristic
    equation as ``(1 + L)(1 + T sum_h R_h)``, ``T = L / (1 + L)``; for each
    harmonic the phase lead ``phi_h = -arg T(j w_h)`` makes ``T R_h`` a
    positive gain near ``w_h``, and the error at ``w_h`` decays as
    ``exp(-k_h |T(j w_h)| w_h t / 2)``: ``k_h = 3 f_1 / (pi |T| f_h
    decay_periods)`` makes it ``e^-3`` after ``decay_periods`` periods of the
    first frequency given, ``f_1``. ``w_h`` is pre-warped,
    ``(2/T) tan(w_h T / 2)``, so that Tustin puts the poles exactly on the
    unit circle at ``w_h``. Discretise with ``method = "tustin"``.

    Parameters
    ----------
    design : AxisDesign
        One-input (error) design.
    loop_response : callable
        ``z -> L(z)``: the axis' discrete loop without the internal models
        (:meth:`hammerstein.compensation.feedback.FeedbackLoop.loop_transfer`),
        for the phase leads and gains.
    sampling_period : float
        T [s].
    frequencies_hz : sequence of float
        The frequencies to reject [Hz] (a periodic reference's fundamental
        and harmonics), each below the Nyquist frequency.
    decay_periods : float
        Periods of the first frequency for each element's error to decay to e^-3.

    Returns
    -------
    AxisDesign
        States: two per element, then the design's (the elements' are no
        integrators for the anti-windup).

    Raises
    ------
    FeedbackError
        For a frequency at or above Nyquist, a non-positive decay, a
        three-input design, or a loop with ``T(j w_h) = 0``.
    """
    T = float(sampling_period)
    if design.system.ninputs != 1:
        raise FeedbackError("internal_model_hz: needs a design on the error (one input)")
    decay = _pos(decay_periods, "internal_model_decay", "periods")
    freqs = [_pos(f, "internal_model_hz", "Hz") for f in frequencies_hz]
    if not freqs:
        return design
    for f in freqs:
        if f >= 0.5 / T:
            raise FeedbackError(f"internal_model_hz: {f:g} Hz is not below the Nyquist "
                                f"frequency {0.5 / T:g} Hz")
    f1 = freqs[0]
    n0 = design.system.nstates
    A0, B0, C0, D0 = (np.atleast_2d(np.asarray(M, float)).reshape(shape) for M, shape in
                      ((design.system.A, (n0, n0)), (design.system.B, (n0, 1)),
                       (design.system.C, (1, n0)), (design.system.D, (1, 1))))
    nr = 2 * len(freqs)
    Ar, Br, Cr = np.zeros((nr, nr)), np.zeros((nr, 1)), np.zeros((1, nr))
    for i, f in enumerate(freqs):
        w = 2 * np.pi * f
        L = complex(loop_response(np.exp(1j * w * T)))
        Tc = L / (1 + L)
        if abs(Tc) == 0:
            raise FeedbackError(f"internal_model_hz: the loop does not pass {f:g} Hz (T = 0)")
        phi = -np.angle(Tc)
        k = 3.0 / (abs(Tc) * np.pi * decay) * (f1 / f)   # e^-3 after decay periods of f1
        wd = 2 / T * np.tan(w * T / 2)
        j = 2 * i
        Ar[j:j + 2, j:j + 2] = [[0.0, 1.0], [-wd * wd, 0.0]]
        Br[j + 1, 0] = 1.0
        Cr[0, j:j + 2] = [k * wd * wd * np.sin(phi), k * wd * np.cos(phi)]
    # w = e + Cr x_r feeds the design
    A = np.block([[Ar, np.zeros((nr, n0))], [B0 @ Cr, A0]])
    B = np.vstack([Br, B0])
    C = np.hstack([D0 @ Cr, C0])
    text = design.description + ", internal model at " + ", ".join(f"{f:g}" for f in freqs) + " Hz"
    return AxisDesign(control.ss(A, B, C, D0), np.concatenate([np.zeros(nr, bool),
                                                              np.asarray(design.integrators, bool)]),
                      text)
