"""Generalised (asymmetric) Prandtl-Ishlinskii operator with envelope functions.

The play operators of the classical PI run under two envelope functions, one
for rising and one for falling inputs (Al Janaideh, Rakheja and Su [1]_):

``s_j(t) = max(gamma_l(u(t)) - r_j, min(gamma_r(u(t)) + r_j, s_j(t - T)))``,
``y(t) = sum_j w_j s_j(t)``, with ``gamma(u) = a0 tanh(a1 u + a2) + a3``.

On a rising input the plays follow the loading envelope ``gamma_l``, on a
falling one the unloading envelope ``gamma_r``; different envelopes give
asymmetric loops, saturating ones the rounding of a real actuator at large
voltages. ``gamma_l = gamma_r = u`` is the classical PI.

References
----------
.. [1] M. Al Janaideh, S. Rakheja, C.-Y. Su, "An analytical generalized
   Prandtl-Ishlinskii model inversion for hysteresis compensation in
   micropositioning control", IEEE/ASME Trans. Mechatronics 16(4), 2011.
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.models.demagnetisation import CycleStart
from hammerstein.simulation import generalized_play_steps

__all__ = ["GeneralizedPI", "envelope"]

GPI_KEYS = ("kind", "thresholds", "weights", "gamma_l", "gamma_r", "offset", "reversible", "rest",
            "demagnetised", "demagnetised_centre")


def _vector(value, name, size=None, ndim=1):
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise HysteresisError(f"{name}: expected numbers, found {value!r}") from None
    if arr.ndim != ndim or not np.all(np.isfinite(arr)) or (size is not None and arr.size != size):
        want = f"{size} finite numbers" if size is not None else "a list of finite numbers"
        raise HysteresisError(f"{name}: expected {want}, found {np.shape(arr)} {value!r}"[:300])
    return arr


def envelope(coefficients, u):
    """Envelope function ``a0 tanh(a1 u + a2) + a3`` of the generalised PI.

    Parameters
    ----------
    coefficients : array_like, shape (4,)
        ``a0`` [µm-equivalent V], ``a1`` [1/V], ``a2`` [-], ``a3`` [V].
    u : array_like
        Input [V].

    Returns
    -------
    numpy.ndarray
        ``gamma(u)``, same shape as ``u``.
    """
    a = np.asarray(coefficients, dtype=float)
    return a[0] * np.tanh(a[1] * np.asarray(u, dtype=float) + a[2]) + a[3]


class GeneralizedPI(CycleStart):
    """Generalised PI operator of one input-output pair (Al Janaideh et al. [1]_).

    Parameters
    ----------
    thresholds : array_like, shape (n,)
        Play thresholds r_j >= 0 [V], strictly increasing.
    weights : array_like, shape (n,)
        Weights w_j [µm/V].
    gamma_l, gamma_r : array_like, shape (4,)
        Loading (rising input) and unloading (falling input) envelopes
        ``a0 tanh(a1 u + a2) + a3`` (see :func:`envelope`); ``a1 > 0`` and
        ``a0 > 0`` so both increase with ``u``.
    offset : float
        Constant added to the output [µm].
    reversible : array_like, shape (d,), optional
        Coefficients ``c_1 .. c_d`` [µm/V^n] of a reversible polynomial
        ``sum_n c_n u^n`` added to the output (e.g. the even u^2 term of a
        cross-coupling, as in the Preisach model's reversible part); none by
        default.
    rest : float
        Rest value ``sigma`` of the plays [V, envelope units]: the play
        outputs at rest at ``u = 0`` are ``sigma`` clipped to each play's
        band (see Notes); 0 by default.
    demagnetised : float
        Amplitude ``A`` [V] of the demagnetising cycle the default initial
        state follows (see Notes); 0 (the default): none, the plays at rest.
    demagnetised_centre : float
        Centre ``c`` [V] of that cycle (default 0).

    Notes
    -----
    The state is the n play outputs [V]. The plays at rest at ``u = 0`` are
    ``s_j = clip(sigma, gamma_l(0) - r_j, gamma_r(0) + r_j)``. Where the
    envelopes are apart at ``u = 0`` (``gamma_l(0) < gamma_r(0)``), a play
    may rest anywhere in its band, and where it rests decides the first
    loops from rest (the initial loading curve and the small loops that never
    wipe it out); ``sigma`` is that place, identified from the initial
    loading curve of the records
    (:class:`~hammerstein.identification.gpi_identification.GeneralizedPIIdentifier`).

    With ``demagnetised = A > 0`` the default initial state is the plays at
    rest driven through the turning points of the demagnetising cycle
    ``c + A (1 - t / D) sin(2 pi f t)`` that ``hammerstein excitation``
    plays before every record
    (:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`):
    the state a real actuator starts each record from, whatever it did
    before. Its decreasing crests leave the plays on a staircase between the
    envelopes, not at one rest value, and the first loops from there are
    shifted against the loops from ``clip(sigma, ...)``: on an outside
    actuator of ``benchmarks/route_defaults.py`` (gpi-13), modelled with the
    plays at rest, the 15 µm circles' mean error was -0.19 / -0.26 µm and
    their worst 2.76-3.33 % of the radius; identified and compensated from
    the demagnetised state, 1.38-2.53 %.

    Raises
    ------
    HysteresisError
        Naming the parameter that is wrong.

    Examples
    --------
    Equal linear-like envelopes reduce to the classical PI; a one-play model
    with threshold 1 V rises by ``u - 1`` after the first volt:

    >>> import numpy as np
    >>> from hammerstein.models.generalized_pi import GeneralizedPI
    >>> g = GeneralizedPI([1.0], [1.0], gamma_l=[1e3, 1e-3, 0, 0], gamma_r=[1e3, 1e-3, 0, 0])
    >>> y, state = g.simulate(np.array([0.0, 2.0, 3.0, 1.0]))
    >>> np.round(y, 3)
    array([0., 1., 2., 2.])
    """

    def __init__(self, thresholds, weights, gamma_l, gamma_r, offset=0.0, reversible=(), rest=0.0,
                 demagnetised=0.0, demagnetised_centre=0.0):
        self.thresholds = _vector(thresholds, "thresholds")
        n = self.thresholds.size
        if n == 0 or np.any(self.thresholds < 0) or np.any(np.diff(self.thresholds) <= 0):
            raise HysteresisError(f"thresholds: expected non-negative, strictly increasing values "
                                  f"[V], found {self.thresholds.tolist()}")
        self.weights = _vector(weights, "weights", n)
        self.gamma_l = _vector(gamma_l, "gamma_l", 4)
        self.gamma_r = _vector(gamma_r, "gamma_r", 4)
        for name, g in (("gamma_l", self.gamma_l), ("gamma_r", self.gamma_r)):
            if g[0] <= 0 or g[1] <= 0:
                raise HysteresisError(f"{name}: expected a0 > 0 and a1 > 0 (an increasing "
                                      f"envelope a0 tanh(a1 u + a2) + a3), found {g.tolist()}")
        self.offset = float(_vector(offset, "offset", ndim=0))
        self.reversible = _vector(reversible, "reversible").reshape(-1)
        self.rest = float(_vector(rest, "rest", ndim=0))
        self._set_cycle(demagnetised, demagnetised_centre)

    def __repr__(self):
        return (f"GeneralizedPI(thresholds={self.thresholds.tolist()}, weights="
                f"{self.weights.tolist()}, gamma_l={self.gamma_l.tolist()}, "
                f"gamma_r={self.gamma_r.tolist()}, offset={self.offset}"
                + (f", reversible={self.reversible.tolist()}" if self.reversible.size else "")
                + (f", rest={self.rest}" if self.rest else "")
                + self._cycle_text() + ")")

    def replace(self, **changes):
        """A copy with some parameters changed.

        Parameters
        ----------
        **changes
            Any key of :meth:`to_table` but ``kind`` (``weights``, ``offset``, ...).

        Returns
        -------
        GeneralizedPI
            Built by :meth:`from_table`, whose errors it raises.
        """
        return GeneralizedPI.from_table({**self.to_table(), **changes})

    def reversible_part(self, u):
        """The reversible polynomial ``sum_n c_n u^n`` [µm] (zero when none is given).

        Parameters
        ----------
        u : array_like
            Input [V].

        Returns
        -------
        numpy.ndarray
            Same shape as ``u``.
        """
        u = np.asarray(u, dtype=float)
        return np.polyval(np.r_[self.reversible[::-1], 0.0], u) if self.reversible.size \
            else np.zeros_like(u)

    @property
    def n_states(self) -> int:
        """Number of state values (one per play)."""
        return self.thresholds.size

    def rest_state(self):
        """The plays at rest at ``u = 0``, ``clip(sigma, gamma_l(0) - r_j, gamma_r(0) + r_j)``.

        Returns
        -------
        numpy.ndarray, shape (n,)
            Play outputs [V].
        """
        lo = envelope(self.gamma_l, 0.0) - self.thresholds
        hi = envelope(self.gamma_r, 0.0) + self.thresholds
        return np.maximum(lo, np.minimum(hi, self.rest))

    def initial_state(self, initial_state=None):
        """Validated copy of a state, or the default initial state (see Notes).

        Parameters
        ----------
        initial_state : array_like, shape (n,), optional
            Play outputs [V].

        Returns
        -------
        numpy.ndarray, shape (n,)

        Raises
        ------
        HysteresisError
            On a wrong shape or non-finite values.
        """
        if initial_state is None:
            if self._start is None:
                s = self.rest_state()
                if self.demagnetised:
                    s = generalized_play_steps(self.demagnetising_input(), self.thresholds,
                                               self.weights, self.gamma_l, self.gamma_r, s)[1]
                self._start = s
            return self._start.copy()
        return _vector(initial_state, "initial_state", self.n_states).copy()

    def simulate(self, u, initial_state=None):
        """Output for an input record (compiled kernel).

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V].
        initial_state : array_like, shape (n,), optional
            Play outputs before the first sample (see :meth:`initial_state`).

        Returns
        -------
        y : numpy.ndarray, shape (n_samples,)
            Output [µm].
        final_state : numpy.ndarray, shape (n,)
            Play outputs after the last sample.

        Raises
        ------
        HysteresisError
            On a non-finite input or a wrong state.
        """
        u = _vector(u, "u")
        s = self.initial_state(initial_state)
        y, s = generalized_play_steps(u, self.thresholds, self.weights, self.gamma_l,
                                      self.gamma_r, s)
        if self.reversible.size:
            y = y + self.reversible_part(u)
        return y + self.offset, s

    def to_table(self):
        """The component's TOML table (``kind = "generalized_pi"``).

        Returns
        -------
        dict
            Keys ``kind``, ``thresholds``, ``weights``, ``gamma_l``,
            ``gamma_r``, ``offset`` and, when there is one, ``reversible``,
            ``rest``, ``demagnetised`` and ``demagnetised_centre`` (not 0).
        """
        table = {"kind": "generalized_pi", "thresholds": self.thresholds.tolist(),
                 "weights": self.weights.tolist(), "gamma_l": self.gamma_l.tolist(),
                 "gamma_r": self.gamma_r.tolist(), "offset": self.offset}
        if self.reversible.size:
            table["reversible"] = self.reversible.tolist()
        for key in ("rest", "demagnetised", "demagnetised_centre"):
            if getattr(self, key):
                table[key] = getattr(self, key)
        return table

    @classmethod
    def from_table(cls, table):
        """Build from a ``kind = "generalized_pi"`` component table.

        Parameters
        ----------
        table : dict
            Keys as written by :meth:`to_table` (``offset``, ``reversible``,
            ``rest``, ``demagnetised`` and ``demagnetised_centre`` optional).

        Returns
        -------
        GeneralizedPI

        Raises
        ------
        HysteresisError
            Naming the missing, unknown or wrong key.
        """
        unknown = sorted(set(table) - set(GPI_KEYS))
        if unknown:
            raise HysteresisError(f"{unknown[0]}: unknown key for kind = 'generalized_pi' "
                                  f"(expected {', '.join(GPI_KEYS[1:])})")
        for key in ("thresholds", "weights", "gamma_l", "gamma_r"):
            if key not in table:
                raise HysteresisError(f"{key}: missing (kind = 'generalized_pi' needs thresholds, "
                                      f"weights, gamma_l and gamma_r)")
        return cls(table["thresholds"], table["weights"], table["gamma_l"], table["gamma_r"],
                   table.get("offset", 0.0), table.get("reversible", ()), table.get("rest", 0.0),
                   table.get("demagnetised", 0.0), table.get("demagnetised_centre", 0.0))
