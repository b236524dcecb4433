"""Feedback around the Hammerstein actuator: controller design, discretisation, loop, stability.

The standard architecture of sensor-equipped piezo stages (surveys: Devasia,
Eleftheriou and Moheimani, IEEE TCST 15(5), 2007; Clayton, Tien, Leang, Zou
and Devasia, ASME JDSMC 131, 2009): a position sensor, a discrete feedback
controller acting on the tracking error, and a sensorless hysteresis /
dynamics compensator as feedforward::

    r ──► feedforward ──f──┐
    │                      ▼
    └──► (+) ─e─► K(z) ──► (+) ─u─► amplifier ─a─► Gamma ─h─► creep, G(z) ─► y
          ▲ -                                                               │
          └──── sensor: low-pass, delay z^-d ◄── (+) noise ◄────────────────┘

Per axis, a controller is designed by name with physical parameters
(:func:`design_axis`: ``integral``, ``pi``, ``pi-notch``, ``ppf``, ``irc``)
or given as any LTI (transfer function or state space, continuous or
discrete), MIMO by ``state-space`` or ``mixsyn`` (python-control's
synthesis; it needs slycot). Continuous designs are discretised at the
sampling period by :func:`control.sample_system` (``zoh``, ``tustin``, ...).
:class:`FeedbackLoop` runs the nonlinear loop in the compiled kernel of
:mod:`hammerstein.simulation` and gives the linearised loop (hysteresis
replaced by its secant gain) to python-control: sensitivity S,
complementary sensitivity T, margins, noise-to-position, and the stability
check of the loop with the hysteresis' slope range as a sector
(:meth:`FeedbackLoop.stability_check`: circle criterion per axis, small gain
for the MIMO loop).

The designs, the discretisation and the kernel's :class:`Controller` are in
:mod:`hammerstein.compensation.feedback_design` (re-exported here); this
module holds the sensor, the amplifier and the loop.

Length: one concept, the loop: its simulation, its linearisation (S, T,
margins, noise) and its stability check all read the same packed plant,
controller, sensor and amplifier of :class:`FeedbackLoop`.

Units: positions µm, voltages V, controller gains V/µm, frequencies Hz.
"""

from __future__ import annotations

import copy
import math
import warnings
from dataclasses import dataclass

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.compensation.preisach_inverse import component_arrays
from hammerstein.exceptions import CompensatorError, FeedbackError
from hammerstein.simulation import (AW_BACK, AW_CLAMP, AW_NONE, ComponentArrays, LinearArrays,
                                    LoopArrays, LoopState, empty_components, empty_pi, pack_model,
                                    simulate_closed_loop)
from hammerstein.compensation.feedback_design import (AXIS_KINDS, METHODS, AxisDesign, Controller,
                                                      _pos, controller_from_lti, design_axis,
                                                      diagonal_controller, discretise,
                                                      mixsyn_controller, with_internal_model,
                                                      with_reference_filter)

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = ["AXIS_KINDS", "METHODS", "ANTI_WINDUP", "Controller", "Sensor", "AmplifierLimits",
           "FeedbackLoop", "LoopResult", "design_axis", "discretise", "hysteresis_slopes",
           "linearised_plant", "controller_from_lti", "diagonal_controller", "mixsyn_controller",
           "with_reference_filter", "AxisDesign", "with_internal_model"]

#: anti-windup schemes
ANTI_WINDUP = ("back-calculation", "clamping", "none")

#: The widest sector factor :meth:`FeedbackLoop.stability_check` looks for.
SECTOR_FACTOR_MAX = 1000.0


def _sector_factor(H, k1, k2):
    """The largest s in [1, :data:`SECTOR_FACTOR_MAX`] for which the sector
    ``[k1 / s, s k2]`` meets the circle criterion's disc condition
    ``Re[(1 + k1 H)(1 + k2 H)^*] > 0`` on the frequencies of ``H`` (the loop without the
    hysteresis' gain, one complex value per frequency): how far the slopes may spread
    beyond those measured before the criterion fails (Khalil, Nonlinear Systems, 3rd ed.,
    Theorem 7.1). Bisection on log s; the condition is monotone in s (a wider sector's
    disc contains the narrower one's)."""
    def holds(s):
        return bool(np.all(np.real((1 + k1 / s * H) * np.conj(1 + s * k2 * H)) > 0))
    if holds(SECTOR_FACTOR_MAX):
        return SECTOR_FACTOR_MAX
    lo, hi = 0.0, np.log(SECTOR_FACTOR_MAX)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if holds(np.exp(mid)) else (lo, mid)
    return float(np.exp(lo))


def _margins(L, T):
    """``(gm, pm, wpc, wgc)`` of a discrete SISO loop, checked on its frequency response."""
    omega = np.logspace(np.log10(2 * np.pi * 0.1), np.log10(np.pi / T), 4000)[:-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, _, wpc, wgc, _ = control.stability_margins(L)
        fgm, fpm, _, fwpc, fwgc, _ = control.stability_margins(control.frd(L, omega))

    def close(a, b, tol):
        return (not np.isfinite(a) and not np.isfinite(b)) or abs(a - b) <= tol

    if close(gm, fgm, 0.02 * max(abs(fgm), 1e-9)) and close(pm, fpm, 1.0):
        return gm, pm, wpc, wgc
    return fgm, fpm, fwpc, fwgc


# -- the plant, linearised ----------------------------------------------------------------
def hysteresis_slopes(model, amplitude=None, n_samples=4000):
    """Secant gains and the range of local slopes of a hysteresis model.

    Each input in turn is driven by a sine of decaying amplitude (major then
    minor loops, from the demagnetised state) while the others rest at 0;
    the local slopes are ``dh_l / du_k`` over the samples where ``|du_k|``
    is above 1e-6 of the amplitude.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        m inputs [V] -> p outputs [µm].
    amplitude : array_like, shape (m,), optional
        Drive amplitude per input [V]; the model's ``input_amplitude`` by
        default (10 V without one).
    n_samples : int
        Samples of each drive.

    Returns
    -------
    secant : numpy.ndarray, shape (p, m)
        ``(max h - min h) / 2 A`` of the first (major) loop, signed [µm/V].
    low, high : numpy.ndarray, shape (p, m)
        Smallest and largest local slope [µm/V] (the sector of the loop's
        stability check).
    """
    m, p = model.n_inputs, model.n_outputs
    amp = getattr(model, "input_amplitude", None) if amplitude is None else amplitude
    amp = np.full(m, 10.0) if amp is None else np.broadcast_to(np.asarray(amp, float), (m,))
    t = np.linspace(0.0, 1.0, n_samples)
    shape = np.sin(2 * np.pi * 8 * t) * np.clip(1.25 - t, 0.05, 1.0)
    secant, low, high = np.zeros((p, m)), np.zeros((p, m)), np.zeros((p, m))
    for k in range(m):
        u = np.zeros((m, n_samples))
        u[k] = amp[k] * shape
        y, _ = model.simulate(u)
        major = slice(n_samples // 16, n_samples // 8 + n_samples // 16)
        du = np.diff(u[k])
        ok = np.abs(du) > 1e-6 * amp[k]
        for l in range(p):
            seg = y[l, major]
            s = np.diff(y[l])[ok] / du[ok]
            sign = 1.0 if np.median(s) >= 0 else -1.0
            secant[l, k] = sign * (seg.max() - seg.min()) / (2 * amp[k])
            low[l, k], high[l, k] = s.min(), s.max()
    return secant, low, high


def linearised_plant(plant, gain=None):
    """The plant with its hysteresis replaced by a gain matrix, as a discrete state space.

    Parameters
    ----------
    plant : HammersteinPlant
        Its linear part (creep then modes) ``plant.matrices``.
    gain : array_like, shape (p, m), optional
        Hysteresis gain [µm/V]; the secant gains of
        :func:`hysteresis_slopes` by default.

    Returns
    -------
    control.StateSpace
        Discrete, m inputs [V] -> p outputs [µm], ``dt = T``.
    """
    K0 = hysteresis_slopes(plant.hysteresis)[0] if gain is None else np.asarray(gain, float)
    A, B, C, D = plant.matrices
    T = plant.sampling_period
    if A.shape[0] == 0:
        return control.ss([], [], [], D @ K0, T)
    return control.ss(A, B @ K0, C, D @ K0, T)


# -- sensor and amplifier -----------------------------------------------------------------
@dataclass
class Sensor:
    """Position sensor: white noise, first-order bandwidth, delay.

    ``m = LP(y(t - d T) + n(t - d T))`` with ``n`` white, ``noise_rms`` per
    axis, added before the delay and the sensor's low-pass (so the noise reaching the loop is
    band limited by it), and the low-pass ``m_t = a m_{t-1} + (1 - a) z_t``
    with ``a = exp(-2 pi f_b T)``.

    Parameters
    ----------
    noise_rms : float
        RMS of the white noise [µm] (40 nm: 0.04).
    bandwidth_hz : float or None
        -3 dB frequency of the low-pass [Hz]; None: none.
    delay : int
        Samples of delay d (conversion, transport).
    """

    noise_rms: float = 0.0
    bandwidth_hz: float | None = None
    delay: int = 0

    def matrices(self, p, sampling_period):
        """Discrete ``(A, B, C, D)`` of the low-pass on p axes (empty without bandwidth).

        Parameters
        ----------
        p : int
            Number of axes.
        sampling_period : float
            T [s].

        Returns
        -------
        tuple of numpy.ndarray
        """
        if self.bandwidth_hz is None:
            return np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p)
        a = math.exp(-2 * math.pi * self.bandwidth_hz * sampling_period)
        return a * np.eye(p), (1 - a) * np.eye(p), a * np.eye(p), (1 - a) * np.eye(p)

    def to_control(self, p, sampling_period):
        """The sensor with its delay as a discrete ``control.StateSpace`` (p -> p).

        Parameters
        ----------
        p : int
            Number of axes.
        sampling_period : float
            T [s].

        Returns
        -------
        control.StateSpace
        """
        s = control.ss(*self.matrices(p, sampling_period), sampling_period)
        if self.delay:
            z = control.tf([1], [1] + [0] * self.delay, sampling_period)
            s = control.ss(control.append(*[control.ss(z) for _ in range(p)])) * s
        return s


@dataclass
class AmplifierLimits:
    """The amplifier's range and slew rate inside the loop.

    Parameters
    ----------
    low, high : float or array_like, shape (m,)
        Range [V].
    slew_rate : float or array_like, shape (m,)
        Largest ``|du/dt|`` [V/s]; inf for none.
    """

    low: object = -10.0
    high: object = 10.0
    slew_rate: object = math.inf


# -- the loop --------------------------------------------------------------------------------
@dataclass
class LoopResult:
    """One closed-loop run.

    Parameters
    ----------
    outputs : numpy.ndarray, shape (p, n_samples)
        Positions [µm].
    inputs : numpy.ndarray, shape (m, n_samples)
        Applied voltages [V].
    measurements : numpy.ndarray, shape (p, n_samples)
        Sensor outputs [µm].
    final_state : hammerstein.simulation.LoopState
        For a chunked continuation.
    """

    outputs: np.ndarray
    inputs: np.ndarray
    measurements: np.ndarray
    final_state: LoopState


class FeedbackLoop:
    """Feedback (and feedforward) around a Hammerstein plant, in the compiled kernel.

    Parameters
    ----------
    plant : HammersteinPlant
        Hysteresis (classical multivariable PI, or Preisach / generalised-PI /
        polynomial components) then creep and modes.
    controller : Controller or None
        Discrete, inputs ``[r; m]``; None: feedforward alone (open loop
        through the amplifier).
    sensor : Sensor, optional
        Default: ideal (no noise, bandwidth or delay).
    amplifier : AmplifierLimits or None
        Range and slew rate; None: unlimited.
    anti_windup : {'back-calculation', 'clamping', 'none'}
        Back-calculation ``x_c += K_aw (a - u)`` on the integrator states
        with ``K_aw = T / tracking_time`` per channel (Astrom and Hagglund);
        clamping (conditional integration) keeps each one while the channel
        it drives most is limited and its update would push that channel
        further past the limit: per channel, so that one axis's saturation
        does not freeze another's controller, and released as soon as the
        error turns (a transfer-function controller, all of whose states
        count as integrators, locked up in a limit cycle at 165-212 % of a
        circle's radius when every state froze on any saturation).
    tracking_time : float, optional
        Back-calculation time constant [s]; default 1 / (2 pi 100 Hz).
    reference_filter : bool
        Compare the measurement with the reference as the sensor would see
        it, ``e = S(z) z^-d r - m`` (:func:`with_reference_filter`), so that
        a perfect feedforward leaves only the noise in the error; False:
        ``e = r - m``.

    Attributes
    ----------
    controller : Controller or None
        The controller the kernel runs (with the reference filter).
    designed : Controller or None
        The controller as given.

    Raises
    ------
    FeedbackError
        On sizes that do not match, an algebraic loop (a static plant with
        no sensor delay), or a hysteresis the kernel cannot step.

    References
    ----------
    Devasia, Eleftheriou and Moheimani, "A survey of control issues in
    nanopositioning", IEEE TCST 15(5), 2007.
    """

    def __init__(self, plant, controller, sensor=None, amplifier=None,
                 anti_windup="back-calculation", tracking_time=None, reference_filter=True):
        self.plant, self.designed = plant, controller
        self._rest = None
        self.reference_filter = bool(reference_filter)
        self.sensor = Sensor() if sensor is None else sensor
        self.amplifier = amplifier
        if anti_windup not in ANTI_WINDUP:
            raise FeedbackError(f"anti_windup: expected one of {ANTI_WINDUP}, found "
                                f"{anti_windup!r}")
        self.anti_windup = anti_windup
        self.tracking_time = (1 / (2 * np.pi * 100.0) if tracking_time is None
                              else _pos(tracking_time, "tracking_time", "s"))
        model = plant.hysteresis
        m, p = model.n_inputs, model.n_outputs
        self.m, self.p = m, p
        T = plant.sampling_period
        if not isinstance(self.sensor.delay, int) or self.sensor.delay < 0:
            raise FeedbackError(f"sensor.delay: expected a number of samples >= 0, found "
                                f"{self.sensor.delay!r}")
        self._pack_plant(plant)
        if controller is not None and self.reference_filter:
            controller = with_reference_filter(controller, self.sensor.to_control(p, T))
        self.controller = c = controller
        if c is not None:
            if c.n_outputs != m or c.n_measurements != p:
                raise FeedbackError(f"controller: expected {p} measurements -> {m} voltages, "
                                    f"found {c.n_measurements} -> {c.n_outputs}")
            if not np.isclose(c.sampling_period, T):
                raise FeedbackError(f"controller: sampled at {c.sampling_period} s, the plant "
                                    f"at {T} s")
        As, Bs, Cs, Ds = self.sensor.matrices(p, T)
        if c is None:
            Ak, Bk, Ck, Dk = np.zeros((0, 0)), np.zeros((0, 2 * p + m)), np.zeros((m, 0)), \
                np.zeros((m, 2 * p + m))
            mask = np.zeros(0, bool)
        else:
            Ak, Bk, Ck, Dk, mask = c.A, c.B, c.C, c.D, c.integrators
        n = Ak.shape[0]
        Kaw = np.zeros((n, m))
        aw = AW_NONE
        drives = np.full(n, -1, np.int64)     # the channel each integrator drives most, -1 none
        for i in np.flatnonzero(mask):
            if np.any(Ck[:, i]):
                drives[i] = int(np.argmax(np.abs(Ck[:, i])))
        if anti_windup == "back-calculation" and n:
            aw = AW_BACK
            for i in np.flatnonzero(mask):   # each integrator tracks the channel it drives most
                k = max(int(drives[i]), 0)
                Kaw[i, k] = T / self.tracking_time / (Ck[k, i] if Ck[k, i] != 0 else 1.0)
        elif anti_windup == "clamping" and n:
            aw = AW_CLAMP
        if amplifier is None:
            low, high, slew = np.full(m, -np.inf), np.full(m, np.inf), np.full(m, np.inf)
        else:
            low = np.broadcast_to(np.asarray(amplifier.low, float), (m,)).copy()
            high = np.broadcast_to(np.asarray(amplifier.high, float), (m,)).copy()
            slew = np.broadcast_to(np.asarray(amplifier.slew_rate, float), (m,)) * T
            if np.any(low >= high):
                raise FeedbackError(f"amplifier: expected low < high, found {low} and {high}")
        self._loop = LoopArrays(*(np.ascontiguousarray(M, dtype=float)
                                  for M in (As, Bs, Cs, Ds, Ak, Bk, Ck, Dk, Kaw)),
                                drives,                   # whose limit clamps it
                                low, high, np.ascontiguousarray(slew, dtype=float), self._y_off,
                                int(self.sensor.delay), aw)


    def _pack_plant(self, plant):
        """The plant's kernel arrays (linear part, hysteresis), its output offset."""
        model = plant.hysteresis
        m, p = model.n_inputs, model.n_outputs
        A, B, C, D = (np.ascontiguousarray(M, dtype=float) for M in plant.matrices)
        if self.sensor.delay == 0 and np.any(D != 0):
            raise FeedbackError("sensor.delay: the plant passes the hysteresis straight to the "
                                "position (static plant or D != 0): give a delay >= 1 sample")
        self._plant_arrays = LinearArrays(A, B, C, D)
        if isinstance(model, MultivariablePI):
            if getattr(model, "has_output_map", False):
                raise FeedbackError("plant: a classical PI with an output map (the modified PI "
                                    "`identify` may choose) cannot run in the closed-loop "
                                    "kernel; identify with --output-map none, or --model "
                                    "preisach or generalized")
            self._kind = 0
            self._pi = pack_model(model).arrays
            self._components = empty_components(m, p)
            off = getattr(model, "output_offset", None)
            self._y_off = np.zeros(p) if off is None else np.asarray(off, float).copy()
        elif isinstance(model, MultivariableHysteresis):
            try:
                arrays = component_arrays(model)
            except CompensatorError as exc:
                raise FeedbackError(f"plant: {exc}") from None
            self._kind = 1
            self._pi = empty_pi(m, p)
            self._components = ComponentArrays(*arrays)
            self._y_off = np.zeros(p)
        else:
            raise FeedbackError(f"plant: the closed-loop kernel steps a MultivariablePI or a "
                                f"MultivariableHysteresis, found {type(model).__name__}")

    def with_plant(self, plant):
        """The same loop (controller, sensor, amplifier, anti-windup) around another plant.

        Cheaper than a new :class:`FeedbackLoop` (nothing of the controller
        is rebuilt): for the drawn plants of a Monte-Carlo study.

        Parameters
        ----------
        plant : HammersteinPlant
            Same inputs, outputs and sampling period as this loop's plant.

        Returns
        -------
        FeedbackLoop

        Raises
        ------
        FeedbackError
            When the plant's shape or sampling period differs.
        """
        model = plant.hysteresis
        if (model.n_inputs, model.n_outputs) != (self.m, self.p) or \
                not np.isclose(plant.sampling_period, self.plant.sampling_period):
            raise FeedbackError(f"plant: expected {self.m} inputs, {self.p} outputs at "
                                f"{self.plant.sampling_period} s, found {model.n_inputs}, "
                                f"{model.n_outputs} at {plant.sampling_period} s")
        new = copy.copy(self)
        new.plant, new._rest = plant, None
        new._pack_plant(plant)
        new._loop = self._loop._replace(y_off=new._y_off)
        return new

    def __repr__(self):
        """The plant's name and the controller's lines."""
        ctrl = "none" if self.controller is None else "; ".join(self.controller.descriptions)
        return f"FeedbackLoop(plant={self.plant.name!r}, controller={ctrl!r})"

    @property
    def arrays(self):
        """The kernel's fixed arrays of the loop (controller, sensor, amplifier, anti-windup).

        Returns
        -------
        hammerstein.simulation.LoopArrays
        """
        return self._loop

    def initial_state(self):
        """The loop at rest: the plant's default state, zero filters and controller.

        Returns
        -------
        hammerstein.simulation.LoopState
        """
        if self._rest is None:          # the plant at rest, packed once per loop
            plant_state = self.plant.initial_state()
            nh = self.plant.hysteresis.n_hysterons
            s = plant_state[:nh].copy()
            if self._kind == 0:
                s = pack_model(self.plant.hysteresis, s).plays(s)
            self._rest = (s, plant_state[nh:].copy())
        s, lin = self._rest
        return LoopState(s.copy(), lin.copy(), np.zeros(self._loop.As.shape[0]),
                         np.zeros((self.p, max(self.sensor.delay, 1))), np.zeros(1, np.int64),
                         np.zeros(self._loop.Ak.shape[0]), np.zeros(self.m))

    def noise(self, n_samples, seed=0):
        """White sensor noise of the loop's RMS.

        Parameters
        ----------
        n_samples : int
            Length.
        seed : int
            Seed of :func:`numpy.random.default_rng`.

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            [µm].
        """
        rng = np.random.default_rng(seed)
        return self.sensor.noise_rms * rng.standard_normal((self.p, n_samples))

    def simulate(self, reference, feedforward=None, noise=None, initial_state=None, seed=0):
        """Run the loop on a reference (compiled kernel).

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            Reference positions [µm].
        feedforward : array_like, shape (m, n_samples), optional
            Feedforward voltages [V] (a compensator's output); zeros by default.
        noise : array_like, shape (p, n_samples), optional
            Sensor noise [µm]; by default :meth:`noise` with ``seed``.
        initial_state : hammerstein.simulation.LoopState, optional
            The state to continue from (copied); :meth:`initial_state` by default.
        seed : int
            Seed of the default noise.

        Returns
        -------
        LoopResult

        Raises
        ------
        HysteresisError
            On wrongly shaped or non-finite records.
        """
        r = np.atleast_2d(np.asarray(reference, dtype=float))
        n = r.shape[1]
        f = np.zeros((self.m, n)) if feedforward is None else feedforward
        nz = self.noise(n, seed) if noise is None else noise
        st = self.initial_state() if initial_state is None else \
            LoopState(*(np.array(a, copy=True) for a in initial_state))
        y, a, meas = simulate_closed_loop(self._kind, self._pi, self._components,
                                          self._plant_arrays, self._loop, r, f, nz, st)
        return LoopResult(y, a, meas, st)

    # -- the linearised loop ------------------------------------------------------------
    def linear_plant(self, gain=None):
        """The linearised plant (:func:`linearised_plant`), cached for the secant gains.

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.

        Returns
        -------
        control.StateSpace
        """
        if gain is not None:
            return linearised_plant(self.plant, gain)
        if not hasattr(self, "_linear"):
            self._slopes = hysteresis_slopes(self.plant.hysteresis)
            self._linear = linearised_plant(self.plant, self._slopes[0])
        return self._linear

    def loop_transfer(self, gain=None):
        """Loop broken at the plant's input, ``L = K_y S_d P`` (m -> m), discrete.

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.

        Returns
        -------
        control.StateSpace

        Raises
        ------
        FeedbackError
            Without a controller.
        """
        if self.controller is None:
            raise FeedbackError("controller: none (feedforward alone has no loop)")
        T = self.plant.sampling_period
        return self.designed.feedback_part() * self.sensor.to_control(self.p, T) * \
            self.linear_plant(gain)

    def closed_loop(self, gain=None):
        """Sensitivity S and complementary sensitivity T of the linearised loop (python-control).

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.

        Returns
        -------
        S : control.StateSpace
            Reference ``r`` to the error ``r - y`` (p -> p), with the sensor.
        T : control.StateSpace
            Reference to position ``y`` (p -> p).
        N : control.StateSpace
            Sensor noise to position ``y`` (p -> p).

        Raises
        ------
        FeedbackError
            Without a controller.
        """
        if self.controller is None:
            raise FeedbackError("controller: none (feedforward alone has no loop)")
        cl = self.closed_system(gain)
        p, Ts = self.p, self.plant.sampling_period
        T = cl[:p, :p]
        N = cl[:p, p:]
        S = control.ss(np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p), Ts) - T
        return S, T, N

    def closed_system(self, gain=None):
        """The linearised closed loop as one state space, inputs ``[r; n]``, outputs ``[y; u]``.

        States: the plant's linear part, the sensor (its delay included),
        the controller, so that a controller's state serves both its
        reference and its measurement inputs (a series ``T = loop * K_r``
        would duplicate it).

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.

        Returns
        -------
        control.StateSpace
            Discrete; inputs reference r (p) and sensor noise n (p) [µm];
            outputs positions y (p) [µm] and voltages u (m) [V].

        Raises
        ------
        FeedbackError
            Without a controller, or for an algebraic loop.
        """
        if self.controller is None:
            raise FeedbackError("controller: none (feedforward alone has no loop)")
        Ts = self.plant.sampling_period
        p, m = self.p, self.m
        P = self.linear_plant(gain)
        Sd = self.sensor.to_control(p, Ts)
        # u -> [y; z] with z = Sd y; then the noise enters as Sd n
        Ap, Bp, Cp, Dp = (np.asarray(M, float).reshape(s) for M, s in
                          ((P.A, (P.nstates, P.nstates)), (P.B, (P.nstates, m)),
                           (P.C, (p, P.nstates)), (P.D, (p, m))))
        As, Bs, Cs, Ds = (np.asarray(M, float).reshape(s) for M, s in
                          ((Sd.A, (Sd.nstates, Sd.nstates)), (Sd.B, (Sd.nstates, p)),
                           (Sd.C, (p, Sd.nstates)), (Sd.D, (p, p))))
        c = self.controller
        Ak, Br, Bm, Ck, Dr, Dm = (c.A, c.B[:, :p], c.B[:, p:2 * p], c.C, c.D[:, :p],
                                  c.D[:, p:2 * p])
        npl, ns, nk = Ap.shape[0], As.shape[0], Ak.shape[0]
        # m = Cs xs + Ds (Cp xp + Dp u + n);  u = Ck xk + Dr r + Dm m
        E = np.eye(m) - Dm @ Ds @ Dp
        if abs(np.linalg.det(E)) < 1e-12:
            raise FeedbackError("the loop is algebraic (I - D_k D_s D_p singular)")
        Ei = np.linalg.inv(E)
        # u = Ei [Dm Ds Cp xp + Dm Cs xs + Ck xk + Dr r + Dm Ds n]
        Ux = Ei @ np.hstack([Dm @ Ds @ Cp, Dm @ Cs, Ck])
        Ur = Ei @ Dr
        Un = Ei @ Dm @ Ds
        n = npl + ns + nk
        X = np.eye(n)
        Mx = Ds @ Cp @ X[:npl] + Cs @ X[npl:npl + ns] + Ds @ Dp @ Ux   # m as a function of x
        Mr, Mn = Ds @ Dp @ Ur, Ds @ Dp @ Un + Ds
        A = np.zeros((n, n))
        B = np.zeros((n, 2 * p))
        A[:npl] = Ap @ X[:npl] + Bp @ Ux
        B[:npl] = np.hstack([Bp @ Ur, Bp @ Un])
        A[npl:npl + ns] = As @ X[npl:npl + ns] + Bs @ (Cp @ X[:npl] + Dp @ Ux)
        B[npl:npl + ns] = np.hstack([Bs @ Dp @ Ur, Bs @ (Dp @ Un + np.eye(p))])
        A[npl + ns:] = Ak @ X[npl + ns:] + Bm @ Mx
        B[npl + ns:] = np.hstack([Br + Bm @ Mr, Bm @ Mn])
        C = np.vstack([Cp @ X[:npl] + Dp @ Ux, Ux])
        D = np.vstack([np.hstack([Dp @ Ur, Dp @ Un]), np.hstack([Ur, Un])])
        return control.ss(A, B, C, D, Ts)

    def margins(self, gain=None):
        """Gain and phase margins of each axis' loop, the other loops open (python-control).

        :func:`control.stability_margins` of the loop; when its result
        disagrees with the same function on the loop's frequency response
        over 4000 points from 0.1 Hz to Nyquist (more than 2 % or 1 degree;
        python-control's polynomial method loses the high-order loops of a
        plant with creep), the frequency-response result is kept.
        The loop of axis l is ``K_l(z) S(z) P_ll(z)`` (a diagonal controller's
        discrete part, the sensor with its delay, the linearised plant's
        direct path), the series python-control forms; a MIMO controller's
        is the (l, l) entry of :meth:`loop_transfer`.

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.

        Returns
        -------
        list of dict
            Per axis: ``gain_margin`` [-] (inf when none), ``phase_margin``
            [deg], ``gain_crossover_hz``, ``phase_crossover_hz`` [Hz], from
            :func:`control.stability_margins` of ``L_ll``.
        """
        T = self.plant.sampling_period
        out = []
        axes = self.controller.axes
        P = self.linear_plant(gain)
        L = self.loop_transfer(gain) if axes is None else None
        sensor = self.sensor.to_control(1, T)
        for l in range(min(self.p, self.m)):
            Ll = L[l, l] if axes is None else axes[l] * sensor * P[l, l]
            gm, pm, wpc, wgc = _margins(Ll, T)
            out.append({"gain_margin": float(gm), "phase_margin": float(pm),
                        "gain_crossover_hz": float(wgc) / (2 * np.pi),
                        "phase_crossover_hz": float(wpc) / (2 * np.pi), "sampling_period": T})
        return out

    def noise_to_position(self, gain=None, n_samples=20000):
        """RMS position [µm] per axis caused by the sensor noise, through the linearised loop.

        ``sqrt(sum_k |h_lj[k]|^2) sigma`` summed over the noise inputs j, with
        h the impulse response of N (the H2 norm of the discrete system).

        Parameters
        ----------
        gain : array_like, shape (p, m), optional
            Hysteresis gain [µm/V]; the secant gains by default.
        n_samples : int
            Length of the impulse responses.

        Returns
        -------
        numpy.ndarray, shape (p,)
        """
        _, _, N = self.closed_loop(gain)
        A, B, C, D = (np.asarray(M) for M in (N.A, N.B, N.C, N.D))
        if np.max(np.abs(np.linalg.eigvals(A)), initial=0.0) >= 1:
            return np.full(self.p, np.inf)
        # discrete Gramian W = A W A' + B B' (doubling, accurate for poles near 1);
        # ||N||_2^2 = diag(C W C' + D D')
        W = B @ B.T                      # Smith's doubling: W = sum_k A^k B B' A'^k
        Ak = A.copy()
        for _ in range(64):
            if not W.size:
                break
            W = W + Ak @ W @ Ak.T
            Ak = Ak @ Ak
            if np.max(np.abs(Ak), initial=0.0) < 1e-300:
                break
        var = np.diag(C @ W @ C.T + D @ D.T)
        return np.sqrt(np.maximum(var, 0.0)) * self.sensor.noise_rms

    def stability_check(self, n_frequencies=2000):
        """Stability of the loop with the hysteresis' slope range as a sector.

        Per axis, the circle criterion (discrete form): with the local
        slopes of the direct path in ``[k1, k2]`` (:func:`hysteresis_slopes`),
        ``H(z) = K_yll S_d P_ll(z) / g_ll`` (the loop without the hysteresis'
        gain), the loop is absolutely stable when the linear loop with
        ``(k1 + k2) / 2`` is stable and ``Re[(1 + k1 H)(1 + k2 H)^*] > 0`` on the
        unit circle (the Nyquist plot avoids the disc on ``[-1/k1, -1/k2]``).
        For the MIMO loop, the small gain theorem on the deviation from the
        secant gains: ``sup sigma_max(M) * delta < 1`` with ``M`` the loop's
        transfer from a gain perturbation back to itself and ``delta`` the
        largest slope deviation (spectral norm of the deviation bounds).

        Parameters
        ----------
        n_frequencies : int
            Frequencies on the unit circle (log spaced from 0.01 Hz to Nyquist).

        Returns
        -------
        dict
            ``axes``: per axis ``{sector_low, sector_high, stable_midpoint,
            circle_margin, passed, sector_factor}``: ``circle_margin`` the smallest
            ``Re[(1 + k1 H) / (1 + k2 H)]`` on the unit circle (positive: the disc
            avoided; it tends to ``k1 / k2`` where ``|H|`` is large, an integrator's
            low frequencies, so it does not rank loops), ``sector_factor`` the
            robustness of a loop that passes, the largest s for which the sector
            ``[k1 / s, s k2]`` still meets the disc condition (None when it fails); ``small_gain``: ``{value, passed}``;
            ``passed``: every axis and the MIMO test (or the axes when the
            small gain is conservative); ``summary``: one line.

        Raises
        ------
        FeedbackError
            Without a controller.
        """
        if self.controller is None:
            raise FeedbackError("controller: none (feedforward alone has no loop)")
        self.linear_plant()
        K0, low, high = self._slopes
        Ts = self.plant.sampling_period
        w = np.logspace(np.log10(2 * np.pi * 0.01), np.log10(np.pi / Ts), n_frequencies)
        Lunit = self.loop_transfer(np.eye(self.p, self.m))   # the loop at unit hysteresis gain
        A, B, C, D = self.plant.matrices
        axes = []
        ok_all = True
        for l in range(min(self.p, self.m)):
            k1, k2 = max(low[l, l], 0.0), high[l, l]
            Kmid = K0.copy()
            Kmid[l, l] = 0.5 * (k1 + k2)
            S, _, _ = self.closed_loop(Kmid)
            stable = bool(np.all(np.abs(control.poles(S)) < 1.0))
            H = Lunit[l, l](np.exp(1j * w * Ts), squeeze=False)[0, 0]
            crit = np.real((1 + k1 * H) * np.conj(1 + k2 * H))
            margin = float(np.min(crit / (np.abs(1 + k2 * H) ** 2 + 1e-300)))
            passed = stable and margin > 0
            ok_all &= passed
            axes.append({"sector_low": float(k1), "sector_high": float(k2),
                         "stable_midpoint": stable, "circle_margin": margin, "passed": passed,
                         "sector_factor": _sector_factor(H, k1, k2) if passed else None})
        # small gain around the secant gains: h = K0 u + w, w = Delta u; M: w -> u
        Delta = np.maximum(np.abs(high - K0), np.abs(K0 - low))
        delta = float(np.linalg.norm(Delta, 2))
        Sd = self.sensor.to_control(self.p, Ts)
        G = control.ss(A, B, C, D, Ts) if A.shape[0] else control.ss([], [], [], D, Ts)
        F = self.designed.feedback_part() * Sd * G
        M = -1 * control.feedback(F, control.ss([], [], [], K0, Ts), sign=-1)
        Mw = M(np.exp(1j * w * Ts), squeeze=False)
        peak = float(max(np.linalg.svd(Mw[:, :, i], compute_uv=False)[0] for i in range(len(w))))
        small = {"value": peak * delta,
                 "passed": bool(peak * delta < 1 and np.all(np.abs(control.poles(M)) < 1))}
        passed = ok_all or small["passed"]
        names = list(self.plant.hysteresis.output_names)
        def why(a):
            if a["passed"]:
                s = a["sector_factor"]
                if s >= SECTOR_FACTOR_MAX:
                    return f"met, and on a sector {SECTOR_FACTOR_MAX:g} times wider each way"
                return (f"met, and up to [{a['sector_low'] / s:.3g}, {a['sector_high'] * s:.3g}] "
                        f"µm/V ({s:.3g} times wider each way)")
            if not a["stable_midpoint"]:      # a positive margin then says nothing
                return "NOT met: the loop is unstable at the sector's midpoint gain"
            return f"NOT met (margin {a['circle_margin']:.3g} <= 0)"

        summary = "; ".join(
            f"axis {names[l]}: sector [{a['sector_low']:.3g}, {a['sector_high']:.3g}] µm/V, circle "
            f"criterion {why(a)}" for l, a in enumerate(axes))
        summary += (f"; MIMO small gain {small['value']:.3g} "
                    + ("(< 1: met)" if small["passed"] else
                       "(>= 1: not met, conservative)" if small["value"] >= 1 else
                       "(< 1, but the loop M is unstable: not met)"))
        return {"axes": axes, "small_gain": small, "passed": bool(passed), "summary": summary}
