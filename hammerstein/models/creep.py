"""Linear creep of a piezoelectric actuator, after the hysteresis.

Creep is the slow drift of the displacement after a voltage step. It is
modelled per output as a linear operator on the hysteresis output h [µm]
(Jung and Gweon [1]_; Croft, Shed and Devasia [2]_):

``y(t) = h(t) + sum_k w_k x_k(t)``, ``tau_k dx_k/dt = h(t) - x_k(t)``,

a sum of first-order lags with time constants ``tau_k`` [s] and weights
``w_k`` [-]. After a step of h the output rises from ``h`` to
``h (1 + sum_k w_k)``. The logarithmic creep law
``y(t) = y(t0) (1 + gamma log10(t / t0))`` is approximated on a time window
by lags with log-spaced time constants (``n`` per decade) of equal weights
``w = gamma / n`` (each lag adds one sigmoid of height ``w`` in ``log10 t``,
so ``n`` of them per decade add ``gamma`` per decade): :meth:`Creep.log_law`.

The lags are simulated exactly at the sampling period T (zero-order hold:
``x_k <- a_k x_k + (1 - a_k) h``, ``a_k = exp(-T / tau_k)``). The plant puts
creep between the hysteresis and the bending modes (creep is a property of
the piezo material, the modes of the mechanical structure it drives); the
two stages are sampled separately, which differs from the ZOH of their
continuous cascade by O(T / tau_min).

References
----------
.. [1] H. Jung, D.-G. Gweon, "Creep characteristics of piezoelectric actuators",
   Rev. Sci. Instrum. 71(4), 2000.
.. [2] D. Croft, G. Shed, S. Devasia, "Creep, hysteresis, and vibration
   compensation for piezoactuators: atomic force microscopy application",
   J. Dyn. Sys., Meas., Control 123(1), 2001.
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.simulation import linear_steps

__all__ = ["Creep", "creep_matrices", "creep_from_table", "creep_to_table", "series_matrices",
           "creep_dynamics", "minimum_phase_margin"]

CREEP_KEYS = ("kind", "time_constants", "weights", "rate_per_decade", "t_min", "t_max",
              "per_decade", "description")


class Creep:
    """Creep of one output: first-order lags after the hysteresis.

    Parameters
    ----------
    time_constants : array_like, shape (n,)
        Lag time constants tau_k [s], positive.
    weights : array_like, shape (n,)
        Weights w_k [-] (fraction of h added by lag k at steady state).
    instantaneous : float
        d [-], the share of h passed at once: ``y = d h + sum_k w_k x_k``
        (default 1, the plant form above). An identified creep
        (:mod:`hammerstein.identification.creep_identification`) has ``d < 1``: the
        hysteresis model, identified on slow sines, already holds the creep
        that is complete at their frequency.

    Raises
    ------
    HysteresisError
        On non-positive time constants, non-finite weights, different lengths
        or a non-positive ``instantaneous``.

    Examples
    --------
    One lag of 1 s and weight 0.1: a unit step of h reaches ``1 + 0.1 (1 - e^-1)``
    after 1 s (here at T = 0.01 s, exactly at the samples):

    >>> import numpy as np
    >>> from hammerstein.models.creep import Creep
    >>> c = Creep([1.0], [0.1])
    >>> y, x = c.simulate(np.ones((1, 101)), 0.01)
    >>> round(float(y[0, -1]), 6), round(float(1 + 0.1 * (1 - np.exp(-1))), 6)
    (1.063212, 1.063212)
    """

    def __init__(self, time_constants, weights, instantaneous=1.0):
        tau = np.atleast_1d(np.array(time_constants, dtype=float))
        w = np.atleast_1d(np.array(weights, dtype=float))
        if tau.ndim != 1 or tau.size == 0 or not np.all(np.isfinite(tau)) or np.any(tau <= 0):
            raise HysteresisError(f"time_constants: expected positive times [s], found "
                                  f"{tau.tolist()}")
        if w.shape != tau.shape or not np.all(np.isfinite(w)):
            raise HysteresisError(f"weights: expected {tau.size} finite values (one per time "
                                  f"constant), found {w.tolist()}")
        if isinstance(instantaneous, bool) or not isinstance(instantaneous, (int, float, np.floating)) \
                or not (np.isfinite(instantaneous) and instantaneous > 0):
            raise HysteresisError(f"instantaneous: expected a positive number, found {instantaneous!r}")
        self.time_constants, self.weights = tau, w
        self.instantaneous = float(instantaneous)

    def __repr__(self):
        d = "" if self.instantaneous == 1.0 else f", instantaneous={self.instantaneous!r}"
        return (f"Creep(time_constants={self.time_constants.tolist()}, "
                f"weights={self.weights.tolist()}{d})")

    @property
    def static_gain(self) -> float:
        """``d + sum_k w_k`` [-]: the output per unit of a constant h once every lag has settled."""
        return self.instantaneous + float(np.sum(self.weights))

    def step_response(self, t):
        """Output after a unit step of h at t = 0 (continuous time).

        ``s(t) = d + sum_k w_k (1 - exp(-t / tau_k))``.

        Parameters
        ----------
        t : array_like, shape (n_times,)
            Times after the step [s], >= 0.

        Returns
        -------
        numpy.ndarray, shape (n_times,)
            [-] (µm per µm of h).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self.instantaneous + (1 - np.exp(-t[:, None] / self.time_constants)) @ self.weights

    @classmethod
    def log_law(cls, rate_per_decade, t_min, t_max, per_decade=2):
        """Lags approximating ``1 + gamma log10(t / t0)`` between t_min and t_max.

        Parameters
        ----------
        rate_per_decade : float
            gamma: relative growth of the displacement per decade of time [-]
            (0.015 for +3 % from 0.1 s to 10 s).
        t_min, t_max : float
            Time window [s] of the law, ``0 < t_min < t_max``.
        per_decade : int
            Lags per decade (>= 1).

        Returns
        -------
        Creep
            Time constants log-spaced from ``t_min`` to ``t_max`` with equal
            weights ``rate_per_decade / per_decade``.

        Raises
        ------
        HysteresisError
            On a wrong window or count.
        """
        if not (np.isfinite(t_min) and np.isfinite(t_max) and 0 < t_min < t_max):
            raise HysteresisError(f"t_min, t_max: expected 0 < t_min < t_max [s], found "
                                  f"{t_min!r}, {t_max!r}")
        if not (isinstance(per_decade, int) and 1 <= per_decade <= 20):
            raise HysteresisError(f"per_decade: expected an integer 1-20, found {per_decade!r}")
        if not np.isfinite(rate_per_decade):
            raise HysteresisError(f"rate_per_decade: expected a number, found {rate_per_decade!r}")
        n = max(1, int(round(np.log10(t_max / t_min) * per_decade)) + 1)
        tau = np.logspace(np.log10(t_min), np.log10(t_max), n)
        return cls(tau, np.full(n, rate_per_decade / per_decade))

    @property
    def n_states(self) -> int:
        """Number of lag states."""
        return self.time_constants.size

    def discrete(self, sampling_period):
        """Exact (ZOH) discrete state space of the lags at the sampling period.

        Parameters
        ----------
        sampling_period : float
            T [s].

        Returns
        -------
        A, B, C, D : numpy.ndarray
            Shapes (n, n), (n, 1), (1, n), (1, 1): ``A = diag(exp(-T/tau))``,
            ``B = 1 - exp(-T/tau)``, ``C = w``, ``D = d`` (``instantaneous``).
        """
        a = np.exp(-float(sampling_period) / self.time_constants)
        return (np.diag(a), (1 - a)[:, None], self.weights[None, :].copy(),
                np.full((1, 1), self.instantaneous))

    def simulate(self, h, sampling_period, initial_state=None):
        """Creep output for a hysteresis output record.

        Parameters
        ----------
        h : array_like, shape (1, n_samples)
            Hysteresis output [µm].
        sampling_period : float
            T [s].
        initial_state : array_like, shape (n,), optional
            Lag states [µm]; zeros by default.

        Returns
        -------
        y : numpy.ndarray, shape (1, n_samples)
            Output with creep [µm].
        final_state : numpy.ndarray, shape (n,)
            Lag states after the last sample.
        """
        x = np.zeros(self.n_states) if initial_state is None else initial_state
        return linear_steps(np.atleast_2d(np.asarray(h, dtype=float)),
                            self.discrete(sampling_period), x)

    def to_table(self):
        """The ``[creep.<output>]`` table (``kind = "lags"``).

        Returns
        -------
        dict
        """
        table = {"kind": "lags", "time_constants": self.time_constants.tolist(),
                 "weights": self.weights.tolist()}
        if self.instantaneous != 1.0:
            table["instantaneous"] = self.instantaneous
        return table


#: Units of the numeric keys of a ``[creep.<output>]`` table (named when a value is not a number).
CREEP_UNITS = {"time_constants": " [s]", "t_min": " [s]", "t_max": " [s]",
               "rate_per_decade": " [fraction of the step per decade]"}


def creep_from_table(table, where="creep"):
    """A :class:`Creep` from a ``[creep.<output>]`` table.

    ``kind = "lags"`` with ``time_constants`` [s], ``weights`` [-] and
    optional ``instantaneous`` [-] (d, default 1), or
    ``kind = "log"`` with ``rate_per_decade`` [-], ``t_min``, ``t_max`` [s] and
    optional ``per_decade`` (default 2); ``kind = "none"`` for no creep.

    Parameters
    ----------
    table : dict
        The parsed table.
    where : str
        Key path for error messages.

    Returns
    -------
    Creep or None

    Raises
    ------
    HysteresisError
        ``<where>.<key>: ...`` naming the key.
    """
    if not isinstance(table, dict):
        raise HysteresisError(f"{where}: expected a table")
    kind = table.get("kind", "lags")
    need = {"lags": ("time_constants", "weights"), "log": ("rate_per_decade", "t_min", "t_max"),
            "none": ()}
    if not isinstance(kind, str) or kind not in need:
        raise HysteresisError(f"{where}.kind: expected 'lags', 'log' or 'none', found {kind!r}")
    allowed = set(need[kind]) | {"kind", "description"} | (
        {"per_decade"} if kind == "log" else {"instantaneous"} if kind == "lags" else set())
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise HysteresisError(f"{where}.{unknown[0]}: unknown key for kind = {kind!r} "
                              f"(expected {', '.join(need[kind]) or 'nothing'})")
    for key in need[kind]:
        if key not in table:
            raise HysteresisError(f"{where}.{key}: missing (kind = {kind!r} needs "
                                  f"{', '.join(need[kind])})")
    for key in sorted(set(table) - {"kind", "description"}):
        values = table[key] if isinstance(table[key], list) and key in ("time_constants",
                                                                         "weights") else [table[key]]
        for v in values:
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                raise HysteresisError(f"{where}.{key}: expected "
                                      f"{'a list of numbers' if key in need.get('lags') else 'a number'}"
                                      f"{CREEP_UNITS.get(key, '')}, found {v!r}")
    try:
        if kind == "none":
            return None
        if kind == "lags":
            return Creep(table["time_constants"], table["weights"], table.get("instantaneous", 1.0))
        for key in ("rate_per_decade", "t_min", "t_max"):
            if not isinstance(table[key], (int, float)) or isinstance(table[key], bool):
                raise HysteresisError(f"{key}: expected a number, found {table[key]!r}")
        return Creep.log_law(float(table["rate_per_decade"]), float(table["t_min"]),
                             float(table["t_max"]), table.get("per_decade", 2))
    except (HysteresisError, TypeError, ValueError) as exc:
        raise HysteresisError(f"{where}.{exc}") from None


def creep_to_table(creeps, outputs):
    """The ``[creep]`` table of a preset.

    Parameters
    ----------
    creeps : sequence of (Creep or None), length p
        Creep per output.
    outputs : sequence of str
        Output names.

    Returns
    -------
    dict
        ``{output: table}`` for the outputs with creep.
    """
    return {name: c.to_table() for name, c in zip(outputs, creeps) if c is not None}


def creep_matrices(creeps, sampling_period):
    """Block-diagonal discrete state space of the creep of p outputs.

    Parameters
    ----------
    creeps : sequence of (Creep or None), length p
        Creep per output (None: output passed through).
    sampling_period : float
        T [s].

    Returns
    -------
    A, B, C, D : numpy.ndarray
        (n, n), (n, p), (p, n), (p, p) with n the total number of lags.
    """
    p = len(creeps)
    n = sum(c.n_states for c in creeps if c is not None)
    A, B, C, D = np.zeros((n, n)), np.zeros((n, p)), np.zeros((p, n)), np.eye(p)
    i = 0
    for l, c in enumerate(creeps):
        if c is None:
            continue
        a, b, cc, _ = c.discrete(sampling_period)
        j = i + c.n_states
        A[i:j, i:j], B[i:j, l], C[l, i:j], D[l, l] = a, b[:, 0], cc[0], c.instantaneous
        i = j
    return A, B, C, D


def series_matrices(first, second):
    """Discrete state space of two systems in series (``first`` then ``second``).

    Parameters
    ----------
    first, second : tuple of numpy.ndarray
        ``(A, B, C, D)`` of each; the outputs of ``first`` feed ``second``.

    Returns
    -------
    A, B, C, D : numpy.ndarray
        States of ``first`` then of ``second``.
    """
    A1, B1, C1, D1 = (np.asarray(m, dtype=float) for m in first)
    A2, B2, C2, D2 = (np.asarray(m, dtype=float) for m in second)
    n1, n2 = A1.shape[0], A2.shape[0]
    A = np.block([[A1, np.zeros((n1, n2))], [B2 @ C1, A2]])
    B = np.vstack([B1, B2 @ D1])
    C = np.hstack([D2 @ C1, C2])
    return A, B, C, D2 @ D1


def minimum_phase_margin(creep, sampling_period):
    """How far the discrete creep is from losing minimum phase.

    The ZOH creep of one output is ``c(z) = d + sum_k w_k (1 - a_k) / (z - a_k)``,
    ``a_k = exp(-T / tau_k)``. On and outside the unit circle ``|z| >= 1``,
    ``Re (1 - a) / (z - a) >= -(1 - a) / (1 + a)`` (the image of the circle
    is a circle through ``1`` and ``-(1 - a) / (1 + a)``), so with ``w_k >= 0``
    ``Re c(z) >= d - sum_k w_k (1 - a_k) / (1 + a_k) > 0``: no zero there when
    the margin is positive. A positive sum of lags is a positive-real
    operator; in continuous time ``d + sum w_k / (1 + s tau_k)`` has positive
    real part in the closed right half-plane for any ``d > 0``.

    Parameters
    ----------
    creep : Creep
    sampling_period : float
        T [s].

    Returns
    -------
    float
        ``d - sum_k |w_k| (1 - a_k) / (1 + a_k)`` [-]; positive: minimum phase
        (its zeros, the poles of its inverse, lie inside the unit circle).
    """
    a = np.exp(-float(sampling_period) / creep.time_constants)
    w = creep.weights
    bound = np.sum(np.where(w >= 0, w * (1 - a) / (1 + a), np.abs(w)))
    return float(creep.instantaneous - bound)


def creep_dynamics(creeps, dynamics):
    """The discrete linear part ``G (I + C)``: creep per output, then G.

    The same discretisation as the plant's (creep and G sampled separately,
    :class:`hammerstein.models.plant.HammersteinPlant`); the
    creep is checked minimum phase (:func:`minimum_phase_margin`), so the
    combined system has the zeros of G and those of the creep, the latter
    inside the unit circle: its ZPETC or stable inverse (Croft, Shed and
    Devasia [2]_ invert creep and vibration together) inverts the creep
    exactly.

    Parameters
    ----------
    creeps : sequence of (Creep or None), length p
    dynamics : control.StateSpace
        Discrete p x p G (``dt`` = T).

    Returns
    -------
    control.StateSpace
        Discrete p x p, states of the creep then of G.

    Raises
    ------
    HysteresisError
        On a creep count other than p or a creep that is not minimum phase
        (weights negative beyond the margin).
    """
    import control  # lazy: python-control is loaded by the callers that invert G

    T = float(dynamics.dt)
    creeps = list(creeps)
    if len(creeps) != dynamics.noutputs:
        raise HysteresisError(f"creep: expected {dynamics.noutputs} entries (one per output), "
                              f"found {len(creeps)}")
    for l, c in enumerate(creeps):
        if c is not None and minimum_phase_margin(c, T) <= 0:
            raise HysteresisError(f"creep: output {l} is not minimum phase at T = {T:g} s "
                                  f"(instantaneous {c.instantaneous:g} below the bound of its "
                                  f"weights); it cannot be inverted")
    mats = series_matrices(creep_matrices(creeps, T),
                           tuple(np.asarray(M, dtype=float) for M in
                                 (dynamics.A, dynamics.B, dynamics.C, dynamics.D)))
    return control.ss(*mats, T)
