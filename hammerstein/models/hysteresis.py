"""Rate-independent hysteresis operators: play, classical and multivariable PI.

Every operator here has memory. Following the contract of
:func:`scipy.signal.max_len_seq`, each simulation function takes explicit
initial play states and returns the final ones, so that a record simulated
in chunks equals the same record simulated at once.

Length: most of it is one class, the multivariable PI (about 540 lines),
whose methods follow the paper's equations (1)-(4) and Def. 3.2 in order;
the scalar operator and the output map it composes are kept beside it.

References
----------
.. [1] M. Rakotondrabe, "Multivariable classical Prandtl-Ishlinskii hysteresis
   modeling and compensation and sensorless control of a nonlinear 2-dof
   piezoactuator", eq. (1)-(4) and Def. 3.2.
.. [2] M. A. Krasnosel'skii and A. V. Pokrovskii, *Systems with Hysteresis*,
   Springer, 1989.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.models.demagnetisation import demagnetising_turning_points
from hammerstein.models.output_map import OutputMap
from hammerstein.simulation import finite_array, simulate_hysteresis, simulate_plays, state_vector

__all__ = [
    "play",
    "cycle_play_states",
    "PrandtlIshlinskii",
    "MultivariablePI",
    "OutputMap",
    "HysteresisError",
]


_as_finite_array = finite_array   # former private name, used across core


def validate_thresholds(thresholds, name="thresholds"):
    """Check play-operator thresholds and return them as a float array.

    Parameters
    ----------
    thresholds : array_like, shape (n_hysterons,)
        Thresholds r_i [V]; finite, non-negative and strictly increasing.
    name : str
        Field name used in error messages.

    Returns
    -------
    numpy.ndarray, shape (n_hysterons,)

    Raises
    ------
    HysteresisError
        If the thresholds are empty, not 1-D, non-finite, negative, unsorted
        or duplicated.
    """
    r = _as_finite_array(thresholds, name, ndim=1)
    if r.size == 0:
        raise HysteresisError(f"{name}: expected at least one threshold, found none")
    if np.any(r < 0):
        raise HysteresisError(
            f"{name}: expected non-negative thresholds, found {r[r < 0][0]:g}")
    if np.any(np.diff(r) <= 0):
        i = int(np.flatnonzero(np.diff(r) <= 0)[0])
        raise HysteresisError(
            f"{name}: expected strictly increasing thresholds, found "
            f"r[{i}]={r[i]:g} followed by r[{i + 1}]={r[i + 1]:g}")
    return r


def play(u, thresholds, initial_state=None):
    """Play (backlash) operators of several thresholds driven by one input.

    ``y_i(t) = max(u(t) - r_i, min(u(t) + r_i, y_i(t - T)))``, eq. (1) of [1]_.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Input signal [V].
    thresholds : array_like, shape (n_hysterons,)
        Thresholds r_i [V], non-negative and strictly increasing.
    initial_state : array_like, shape (n_hysterons,), optional
        Play outputs y_i(0 - T) before the first sample [V]; zeros by default.

    Returns
    -------
    y : numpy.ndarray, shape (n_hysterons, n_samples)
        Play outputs [V].
    final_state : numpy.ndarray, shape (n_hysterons,)
        Play outputs at the last sample, to pass as ``initial_state`` of the
        next chunk.

    Raises
    ------
    HysteresisError
        On non-finite input, invalid thresholds or a state of the wrong shape.
    """
    u = _as_finite_array(u, "u", ndim=1)
    r = validate_thresholds(thresholds)
    state = state_vector(initial_state, r.size, "initial_state")
    return simulate_plays(u, r, state)


def cycle_play_states(thresholds, amplitude, centre=0.0):
    """Play outputs after a demagnetising cycle, from 0.

    Each play of eq. (1) of [1]_ driven from 0 through the turning points of the cycle
    ``c + A (1 - t / D) sin(2 pi f t)`` and its rest
    (:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`): a play's
    output after a monotone piece of input depends on the piece's end alone, so this is
    the state the sampled cycle leaves, whatever its sampling period.

    Parameters
    ----------
    thresholds : array_like, shape (n,)
        Thresholds r_i [V], >= 0 (any order).
    amplitude : float
        ``A`` [V], >= 0 (0: no cycle, zeros returned).
    centre : float
        ``c`` [V].

    Returns
    -------
    numpy.ndarray, shape (n,)
        Play outputs [V].

    Raises
    ------
    ValueError
        On a negative or non-finite amplitude or a non-finite centre.

    Examples
    --------
    A play of threshold 0 follows the input to its rest (0 V); the others stop within
    about ``A / (4 P)`` of it (0.25 V here, 20 periods):

    >>> import numpy as np
    >>> from hammerstein.models.hysteresis import cycle_play_states
    >>> np.round(cycle_play_states([0.0, 2.0, 5.0, 9.9], 20.0), 3)
    array([ 0.   , -0.243, -0.247, -0.149])
    """
    r = np.asarray(thresholds, dtype=float)
    s = np.zeros(r.shape)
    if amplitude == 0:
        return s
    for u in demagnetising_turning_points(amplitude, centre):
        s = np.maximum(u - r, np.minimum(u + r, s))
    return s


@dataclass(frozen=True)
class PrandtlIshlinskii:
    """Classical Prandtl-Ishlinskii (PI) operator, eq. (2) of [1]_.

    ``y(t) = sum_i w_i * play_{r_i}(u)(t)``.

    Parameters
    ----------
    thresholds : array_like, shape (n_hysterons,)
        Thresholds r_i [V] (input units), finite, non-negative, strictly
        increasing.
    weights : array_like, shape (n_hysterons,)
        Weights w_i [µm/V] (output units per input unit); may be negative.

    Raises
    ------
    HysteresisError
        If thresholds are invalid or weights do not match them in length.
    """

    thresholds: np.ndarray
    weights: np.ndarray

    def __post_init__(self):
        r = validate_thresholds(self.thresholds)
        w = _as_finite_array(self.weights, "weights", ndim=1)
        if w.shape != r.shape:
            raise HysteresisError(
                f"weights: expected {r.size} weights to match the thresholds, "
                f"found {w.size}")
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "weights", w)

    @property
    def n_hysterons(self) -> int:
        """Number of play operators (hysterons)."""
        return self.thresholds.size

    def __repr__(self):
        """Class, size and key numbers (no arrays): thresholds [V] and weight sum [µm/V]."""
        r = self.thresholds
        return (f"PrandtlIshlinskii({self.n_hysterons} hysterons, thresholds {r[0]:.4g}..{r[-1]:.4g} V, "
                f"weight sum {float(np.sum(self.weights)):.4g} µm/V)")

    def simulate(self, u, initial_state=None):
        """Output of the PI operator for an input record.

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V].
        initial_state : array_like, shape (n_hysterons,), optional
            Initial play outputs [V]; zeros by default (demagnetised state).

        Returns
        -------
        y : numpy.ndarray, shape (n_samples,)
            Output [µm].
        final_state : numpy.ndarray, shape (n_hysterons,)
            Play outputs after the last sample [V].
        """
        plays, final = play(u, self.thresholds, initial_state)
        return self.weights @ plays, final

    def peak_output(self, amplitude):
        """Output at the maximum of a symmetric periodic input, closed form.

        For an input oscillating between -A and A (after the first half
        period) the loop reaches ``sum_i w_i (A - r_i)`` over the hysterons
        with r_i < A.

        Parameters
        ----------
        amplitude : float
            Input amplitude A [V].

        Returns
        -------
        float
            Peak output [µm].
        """
        active = self.thresholds < amplitude
        return float(np.sum(self.weights[active] * (amplitude - self.thresholds[active])))

    def secant_gain(self, amplitude):
        """Secant gain of the major loop of amplitude A, ``peak_output(A)/A``.

        Parameters
        ----------
        amplitude : float
            Input amplitude A [V], > 0.

        Returns
        -------
        float
            Gain [µm/V] (docs/compensator.md, default compensator normalisation).

        Raises
        ------
        HysteresisError
            When ``amplitude`` is not > 0 (or is NaN).
        """
        if not amplitude > 0:
            raise HysteresisError(f"amplitude: expected > 0, found {amplitude!r}")
        return self.peak_output(amplitude) / amplitude

    def slopes(self):
        """Reachable incremental slopes of the operator.

        After an input reversal the play operators start moving in the order
        of their thresholds, so the slope ``dy/du`` on any branch is one of
        the cumulative sums ``S_j = sum_{i<=j} w_i`` (``S_0 = 0`` in the dead
        band right after a reversal when r_1 > 0).

        Returns
        -------
        numpy.ndarray, shape (n_hysterons + 1,)
            ``[0, S_1, ..., S_n]`` [µm/V].
        """
        return np.concatenate([[0.0], np.cumsum(self.weights)])


_Component = "PrandtlIshlinskii | float | None"


def component_words(output_names, input_names, components, word):
    """``x: ux PI(15), uy gain 0.1; y: ...``: a model's components in words (its repr).

    Parameters
    ----------
    output_names, input_names : sequence of str
    components : sequence of sequences, shape (p, m)
    word : callable
        ``word(component) -> str``.

    Returns
    -------
    str
    """
    return "; ".join(f"{out}: " + ", ".join(f"{inp} {word(c)}" for inp, c in zip(input_names, row))
                     for out, row in zip(output_names, components))


@dataclass
class MultivariablePI:
    """Multivariable classical PI model, eq. (3)/(4) and Def. 3.2 of [1]_.

    ``y_l(t) = sum_k Gamma_lk(u_k(t))`` for p outputs and m inputs; each
    component ``Gamma_lk`` is a classical PI operator with its own thresholds
    and weights, a pure linear gain, or absent. Diagonal components of a
    square model are the direct transfers; the others are cross-couplings.

    Parameters
    ----------
    components : sequence of sequences, shape (p, m)
        ``components[l][k]`` is a :class:`PrandtlIshlinskii` (a hysteresis
        from input k to output l), a float (a linear gain [µm/V]) or ``None``
        (no transfer).
    input_names : sequence of str, optional
        Names of the m inputs (default ``u0, u1, ...``).
    output_names : sequence of str, optional
        Names of the p outputs (default ``y0, y1, ...``).
    input_amplitude : array_like, shape (m,), optional
        Amplitude of the input range each column was identified on [V]
        (used for the secant gains of the compensator and range warnings).
    output_offset : array_like, shape (p,), optional
        Constant added to every output [µm], ``y_l = sum_k Gamma_lk(u_k) +
        c_l`` (the sensor zero of an identified record). Included by
        :meth:`simulate` and by the plant, after its linear part (creep and
        dynamics); the compensators subtract it from the reference (the
        Hammerstein compensator before inverting the linear part). Not included by :meth:`evaluate` (the operator
        ``Gamma`` alone). ``None`` means zeros.
    output_map : sequence of (OutputMap, dict or None), length p, optional
        Static output map per output, the modified PI of Kuhnen [3]_:
        ``y_l = S_l(sum_k Gamma_lk(u_k)) + c_l`` (a dict holds ``knots`` and
        ``slopes``). Applied by :meth:`simulate` and the plant (between the
        PI and the linear dynamics); the compensators track
        ``Gamma(U) = S^-1(Yr - c)`` (:meth:`gamma_reference`). ``None`` (or
        all entries None): the classical PI.
    demagnetised : array_like, shape (m,), optional
        Amplitude ``A_k`` [V] of the demagnetising cycle each input's records
        start after (``demagnetise.csv`` of ``hammerstein excitation``; 0: none),
        which sets the default initial state (Notes). ``None`` (or all zeros):
        every play starts at 0.
    demagnetised_centre : array_like, shape (m,), optional
        Centre ``c_k`` [V] of each input's cycle; zeros by default.
    input_centre : array_like, shape (m,), optional
        Centre of the input range each column was identified on [V]: the range
        is ``input_centre +- input_amplitude`` (a unipolar stack's 0..100 V is
        50 +- 50 V); zeros by default (the paper's symmetric ranges). Used by the
        range warnings (:func:`~hammerstein.compensation.compensators.check_reference_range`).

    Notes
    -----
    The play states of all hysterons are one flat vector of length
    ``n_hysterons``, ordered by output l, then input k, then threshold, as
    listed by :meth:`hysterons`.

    The default initial state is zeros, the paper's virgin state. With
    ``demagnetised`` it is the state the demagnetising cycle ``c_k + A_k (1 - t /
    D) sin(2 pi f t)`` of every input leaves: each play driven from 0 through the
    cycle's turning points
    (:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`),
    exact for any sampling period since a play's output after a monotone piece of
    input depends on the piece's end alone. The cycle's crests fall by ``A / P``
    per period, so it leaves every play of a threshold below ``A`` within
    ``A / (4 P)`` of ``c`` (0.25 V at 20 V and 20 periods), above or below it by
    where the threshold falls between two crests: a sawtooth over the threshold
    of period ``A / P``. That is the state of a model whose thresholds are the
    actuator's own; over a cell of thresholds 1.3 V wide it averages to within
    0.04 V of ``c``, which is why ``hammerstein identify`` keeps an identified
    classical PI's plays at 0 (the virgin state).

    Raises
    ------
    HysteresisError
        If the component grid is not rectangular, a component has the wrong
        type, names do not match the grid, or no component is a hysteresis.

    Examples
    --------
    Two inputs, two outputs: a hysteresis and a linear cross-coupling on
    output x, a small hysteretic cross-coupling and a direct hysteresis on
    output y. On the first rise of ``ux`` the plays of threshold r move by
    ``u - r``: ``x = 1 * 2 + 0.5 * (2 - 1) = 2.5`` at 2 V.

    >>> import numpy as np
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> model = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25]), 0.1],
    ...      [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.0, 1.0], [0.8, 0.4])]],
    ...     input_names=["ux", "uy"], output_names=["x", "y"], input_amplitude=[10.0, 10.0])
    >>> model.n_hysterons
    7
    >>> y, final_state = model.simulate([[0.0, 2.0, 4.0, 2.0, 0.0], [0.0] * 5])
    >>> np.round(y, 3)
    array([[0.  , 2.5 , 6.  , 4.  , 1.  ],
           [0.  , 0.11, 0.25, 0.15, 0.03]])
    """

    components: Sequence[Sequence[object]]
    input_names: Sequence[str] | None = None
    output_names: Sequence[str] | None = None
    input_amplitude: np.ndarray | None = None
    output_offset: np.ndarray | None = None
    output_map: Sequence[object] | None = None
    demagnetised: np.ndarray | None = None
    demagnetised_centre: np.ndarray | None = None
    input_centre: np.ndarray | None = None
    _flat: dict = field(init=False, repr=False)

    def __post_init__(self):
        rows = [list(row) for row in self.components]
        if not rows or not rows[0]:
            raise HysteresisError("components: expected a non-empty p x m grid")
        m = len(rows[0])
        for l, row in enumerate(rows):
            if len(row) != m:
                raise HysteresisError(
                    f"components: expected {m} entries in every row, "
                    f"found {len(row)} in row {l}")
            for k, comp in enumerate(row):
                if comp is None or isinstance(comp, PrandtlIshlinskii):
                    continue
                if isinstance(comp, (int, float, np.floating, np.integer)) and np.isfinite(comp):
                    row[k] = float(comp)
                    continue
                raise HysteresisError(
                    f"components[{l}][{k}]: expected a PrandtlIshlinskii, a "
                    f"finite gain or None, found {comp!r}")
        self.components = rows
        p = len(rows)
        self.input_names = self._names(self.input_names, m, "u", "input_names")
        self.output_names = self._names(self.output_names, p, "y", "output_names")
        if self.input_amplitude is not None:
            amp = _as_finite_array(self.input_amplitude, "input_amplitude", ndim=1)
            if amp.shape != (m,) or np.any(amp <= 0):
                raise HysteresisError(
                    f"input_amplitude: expected {m} positive values, found {amp.tolist()}")
            self.input_amplitude = amp
        if self.input_centre is not None:
            c = _as_finite_array(self.input_centre, "input_centre", ndim=1)
            if c.shape != (m,):
                raise HysteresisError(
                    f"input_centre: expected {m} voltages [V] (one per input), found {c.tolist()}")
            self.input_centre = None if not np.any(c) else c
        if self.output_offset is not None:
            off = _as_finite_array(self.output_offset, "output_offset", ndim=1)
            if off.shape != (p,):
                raise HysteresisError(
                    f"output_offset: expected {p} values (one per output), found {off.tolist()}")
            self.output_offset = None if not np.any(off) else off
        if self.output_map is not None:
            maps = list(self.output_map)
            if len(maps) != p:
                raise HysteresisError(f"output_map: expected {p} entries (one per output, None "
                                      f"for none), found {len(maps)}")
            for l, mp in enumerate(maps):
                if isinstance(mp, dict):
                    extra = set(mp) - {"knots", "slopes"}
                    if extra or "slopes" not in mp:
                        raise HysteresisError(
                            f"output_map[{l}]: expected keys knots and slopes, found {sorted(mp)}")
                    try:
                        maps[l] = OutputMap(mp.get("knots", []), mp["slopes"])
                    except HysteresisError as exc:
                        raise HysteresisError(f"output_map[{l}]: {exc}") from None
                elif mp is not None and not isinstance(mp, OutputMap):
                    raise HysteresisError(f"output_map[{l}]: expected an OutputMap, a dict or "
                                          f"None, found {mp!r}")
            self.output_map = maps if any(mp is not None for mp in maps) else None
        self._set_cycles(m)
        self._flat = self._flatten()
        self._start = None              # the default initial state, computed once

    def _set_cycles(self, m):
        """Validate ``demagnetised`` and ``demagnetised_centre`` (None without a cycle)."""
        amp, centre = self.demagnetised, self.demagnetised_centre
        values = {}
        for name, v in (("demagnetised", amp), ("demagnetised_centre", centre)):
            if v is None:
                values[name] = np.zeros(m)
                continue
            try:
                arr = np.asarray(v, dtype=float)
            except (TypeError, ValueError):
                arr = None
            if arr is None or arr.shape != (m,) or not np.all(np.isfinite(arr)):
                raise HysteresisError(f"{name}: expected {m} finite voltages [V] (one per "
                                      f"input), found {v!r}")
            values[name] = arr.copy()
        if not np.any(values["demagnetised"]) and np.any(values["demagnetised_centre"]):
            raise HysteresisError("demagnetised_centre: the centre of a demagnetising cycle "
                                  "needs its amplitude, demagnetised (one value per input [V])")
        if np.any(values["demagnetised"] < 0):
            raise HysteresisError(f"demagnetised: expected the demagnetising cycles' amplitudes "
                                  f">= 0 [V] (0: none), found {values['demagnetised'].tolist()}")
        if not np.any(values["demagnetised"]):
            self.demagnetised = self.demagnetised_centre = None
            return
        values["demagnetised_centre"][values["demagnetised"] == 0] = 0.0
        self.demagnetised = values["demagnetised"]
        self.demagnetised_centre = values["demagnetised_centre"]

    def replace(self, **changes):
        """A copy with some parameters changed (:func:`dataclasses.replace`).

        Parameters
        ----------
        **changes
            Constructor parameters, e.g. ``demagnetised=[20.0, 20.0]``
            (``demagnetised=None`` drops the cycle's centre too).

        Returns
        -------
        MultivariablePI

        Raises
        ------
        HysteresisError
            On an invalid parameter (as the constructor).
        """
        if changes.get("demagnetised", 1) is None:      # no cycle: no centre either
            changes.setdefault("demagnetised_centre", None)
        return dataclasses.replace(self, **changes)

    def demagnetising_inputs(self):
        """The turning points the default initial state follows, per input.

        Returns
        -------
        list of numpy.ndarray
            Per input, shape (n_points,) [V]
            (:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`;
            empty for an input without a cycle).
        """
        if self.demagnetised is None:
            return [np.zeros(0) for _ in range(self.n_inputs)]
        return [demagnetising_turning_points(a, c) if a > 0 else np.zeros(0)
                for a, c in zip(self.demagnetised, self.demagnetised_centre)]

    # -- static output map (modified PI) -----------------------------------------
    @property
    def has_output_map(self) -> bool:
        """True when some output has a static output map (a modified PI)."""
        return self.output_map is not None

    def _map_rows(self, y, inverse):
        y = np.asarray(y, dtype=float)
        if self.output_map is None:
            return y
        out = np.array(y, dtype=float)
        for l, mp in enumerate(self.output_map):
            if mp is not None:
                out[l] = mp.inverse(y[l]) if inverse else mp.apply(y[l])
        return out

    def output_map_apply(self, h):
        """``S_l(h_l)`` per output (identity without a map).

        Parameters
        ----------
        h : array_like, shape (p, n_samples) or (p,)
            PI outputs ``Gamma(U)`` [µm].

        Returns
        -------
        numpy.ndarray, same shape
            A new array when the model has a map, ``h`` itself otherwise.
        """
        return self._map_rows(h, False)

    def output_map_inverse(self, y):
        """``S_l^-1(y_l)`` per output, exact (identity without a map).

        Parameters
        ----------
        y : array_like, shape (p, n_samples) or (p,)
            Outputs without offset [µm].

        Returns
        -------
        numpy.ndarray, same shape
        """
        return self._map_rows(y, True)

    def gamma_reference(self, reference):
        """``S^-1(Yr - c)``: what ``Gamma(U)`` must follow for the outputs to track ``Yr``.

        Parameters
        ----------
        reference : numpy.ndarray, shape (p, n_samples)
            Reference displacements [µm].

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            ``reference`` itself for a classical PI without offset.
        """
        yr = reference
        if self.output_offset is not None:
            yr = yr - self.output_offset[:, None]
        return self.output_map_inverse(yr) if self.output_map is not None else yr

    @staticmethod
    def _names(names, count, prefix, field_name):
        if names is None:
            return [f"{prefix}{i}" for i in range(count)]
        names = [str(n) for n in names]
        if len(names) != count or len(set(names)) != count:
            raise HysteresisError(
                f"{field_name}: expected {count} distinct names, found {names}")
        return names

    def _flatten(self):
        inp, out, r, w = [], [], [], []
        gain = np.zeros((self.n_outputs, self.n_inputs))
        for l, row in enumerate(self.components):
            for k, comp in enumerate(row):
                if isinstance(comp, PrandtlIshlinskii):
                    inp += [k] * comp.n_hysterons
                    out += [l] * comp.n_hysterons
                    r.append(comp.thresholds)
                    w.append(comp.weights)
                elif comp is not None:
                    gain[l, k] = comp
        if not r:
            raise HysteresisError(
                "components: expected at least one hysteresis component (Def. 3.1)")
        return {
            "input_index": np.asarray(inp, dtype=np.int64),
            "output_index": np.asarray(out, dtype=np.int64),
            "thresholds": np.concatenate(r),
            "weights": np.concatenate(w),
            "gain": gain,
        }

    # -- shape ----------------------------------------------------------------
    @property
    def n_inputs(self) -> int:
        """Number of inputs m."""
        return len(self.components[0])

    @property
    def n_outputs(self) -> int:
        """Number of outputs p."""
        return len(self.components)

    @property
    def n_hysterons(self) -> int:
        """Total number of play operators, the length of the state vector."""
        return self._flat["thresholds"].size

    def size_text(self):
        """The model's size in words, e.g. ``'2x2 PI (ux, uy -> x, y), 40 hysterons'``.

        Returns
        -------
        str
        """
        return (f"{self.n_outputs}x{self.n_inputs} PI ({', '.join(self.input_names)} -> "
                f"{', '.join(self.output_names)}), {self.n_hysterons} hysterons")

    def __repr__(self):
        """Sizes, names and one word per component (no arrays), e.g. for ``print(model)``."""
        def word(comp):
            if comp is None:
                return "-"
            if isinstance(comp, PrandtlIshlinskii):
                return f"PI({comp.n_hysterons})"
            return f"gain {float(comp):.4g}"

        rows = component_words(self.output_names, self.input_names, self.components, word)
        extra = ""
        if self.output_offset is not None and np.any(np.asarray(self.output_offset) != 0):
            extra += ", output_offset [" + ", ".join(
                f"{c:.4g}" for c in np.asarray(self.output_offset, dtype=float)) + "] µm"
        if self.output_map is not None:
            extra += ", output map on " + ", ".join(
                o for o, mp in zip(self.output_names, self.output_map) if mp is not None)
        if self.demagnetised is not None:
            extra += ", demagnetised [" + ", ".join(f"{a:.4g}" for a in self.demagnetised) + "] V"
            if np.any(self.demagnetised_centre):
                extra += " around [" + ", ".join(
                    f"{c:.4g}" for c in self.demagnetised_centre) + "] V"
        return f"MultivariablePI({self.size_text()}; {rows}{extra})"

    def hysterons(self):
        """Flat description of all hysterons, for kernels and interop.

        Returns
        -------
        dict
            ``input_index`` (n_hysterons,) int, ``output_index`` (n_hysterons,)
            int, ``thresholds`` (n_hysterons,) [V], ``weights`` (n_hysterons,)
            [µm/V], and ``gain`` (p, m) [µm/V], the pure linear components.
        """
        return {k: v.copy() for k, v in self._flat.items()}

    def component(self, output, input):
        """Component ``Gamma_lk`` by names or indices.

        Parameters
        ----------
        output : str or int
            Output l, by name or index.
        input : str or int
            Input k, by name or index.

        Returns
        -------
        PrandtlIshlinskii, float or None
            The hysteresis, the linear gain [µm/V] or None (no transfer).

        Raises
        ------
        ValueError
            On an unknown name.
        """
        l = output if isinstance(output, int) else self.output_names.index(output)
        k = input if isinstance(input, int) else self.input_names.index(input)
        return self.components[l][k]

    # -- simulation ------------------------------------------------------------
    def check_inputs(self, u, name="inputs"):
        """Validate an input record and return it as an (m, n_samples) array.

        Parameters
        ----------
        u : array_like, shape (m, n_samples), or (n_samples,) when m = 1
            Input voltages [V].
        name : str
            Field name for error messages.

        Returns
        -------
        numpy.ndarray, shape (m, n_samples)
            Float array (not copied when already one).

        Raises
        ------
        HysteresisError
            If the array is not (m, n_samples) or holds non-finite values.
        """
        u = _as_finite_array(u, name)
        if u.ndim == 1 and self.n_inputs == 1:
            u = u[np.newaxis, :]
        if u.ndim != 2 or u.shape[0] != self.n_inputs:
            raise HysteresisError(
                f"{name}: expected shape ({self.n_inputs}, n_samples), found {u.shape}")
        return u

    def initial_state(self, initial_state=None):
        """Return a valid copy of a flat play-state vector (the default start by default).

        Parameters
        ----------
        initial_state : array_like, shape (n_hysterons,), optional
            Play outputs [V], ordered as :meth:`hysterons`.

        Returns
        -------
        numpy.ndarray, shape (n_hysterons,)
            A new array; by default zeros, or the state the demagnetising cycles
            leave (``demagnetised``, Notes).

        Raises
        ------
        HysteresisError
            On a wrong shape or non-finite values.
        """
        if initial_state is not None or self.demagnetised is None:
            return state_vector(initial_state, self.n_hysterons, "initial_state")
        if self._start is None:
            f = self._flat
            s = np.zeros(self.n_hysterons)
            for k, (a, c) in enumerate(zip(self.demagnetised, self.demagnetised_centre)):
                on = f["input_index"] == k
                s[on] = cycle_play_states(f["thresholds"][on], a, c)
            s.setflags(write=False)
            self._start = s
        return self._start.copy()

    def simulate(self, inputs, initial_state=None):
        """Outputs of the multivariable PI model for an input record, eq. (4).

        Stepped by :func:`hammerstein.simulation.simulate_hysteresis` (compiled
        kernel; ``backend='numpy'`` there is the reference implementation).

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Input voltages [V].
        initial_state : array_like, shape (n_hysterons,), optional
            Initial play outputs [V]; :meth:`initial_state` by default.

        Returns
        -------
        outputs : numpy.ndarray, shape (p, n_samples)
            Displacements [µm], ``output_offset`` included.
        final_state : numpy.ndarray, shape (n_hysterons,)
            Play outputs after the last sample [V].

        Raises
        ------
        HysteresisError
            On a wrongly shaped or non-finite input or state.
        """
        return simulate_hysteresis(self, inputs, initial_state)

    def evaluate(self, inputs, state):
        """Output for one input vector from a frozen play state, no commit.

        ``Gamma(U; s) = sum w * max(U - r, min(U + r, s)) + G U``.

        Parameters
        ----------
        inputs : numpy.ndarray, shape (m,)
            Input voltages [V].
        state : numpy.ndarray, shape (n_hysterons,)
            Play outputs of the previous sample [V].

        Returns
        -------
        outputs : numpy.ndarray, shape (p,)
            Displacements [µm].
        new_state : numpy.ndarray, shape (n_hysterons,)
            Play outputs after this input [V].
        """
        f = self._flat
        ut = inputs[f["input_index"]]
        s = np.maximum(ut - f["thresholds"], np.minimum(ut + f["thresholds"], state))
        y = np.bincount(f["output_index"], weights=f["weights"] * s,
                        minlength=self.n_outputs) + f["gain"] @ inputs
        return y, s

    # -- static properties -----------------------------------------------------
    def secant_gains(self, amplitude=None):
        """Secant gain matrix of the major loops, ``Gamma_lk`` peak over A_k.

        Parameters
        ----------
        amplitude : array_like, shape (m,), optional
            Input amplitudes A_k [V]; defaults to ``input_amplitude``.

        Returns
        -------
        numpy.ndarray, shape (p, m)
            ``K_lk = sum_i w_lki (A_k - r_lki) / A_k`` [µm/V] (docs/compensator.md);
            linear components contribute their gain.

        Raises
        ------
        HysteresisError
            If no amplitude is given and the model has no ``input_amplitude``.
        """
        if amplitude is None:
            if self.input_amplitude is None:
                raise HysteresisError(
                    "input_amplitude: the model has no identified input range; "
                    "give the amplitude explicitly")
            amplitude = self.input_amplitude
        amp = _as_finite_array(amplitude, "amplitude", ndim=1)
        if amp.shape != (self.n_inputs,) or np.any(amp <= 0):
            raise HysteresisError(
                f"amplitude: expected {self.n_inputs} positive values, found {amp.tolist()}")
        K = np.zeros((self.n_outputs, self.n_inputs))
        for l, row in enumerate(self.components):
            for k, comp in enumerate(row):
                if isinstance(comp, PrandtlIshlinskii):
                    K[l, k] = comp.secant_gain(amp[k])
                elif comp is not None:
                    K[l, k] = comp
        return K

    def slope_levels(self, input_index):
        """Reachable slope columns of one input, in order of input travel.

        After a reversal of input k, the hysterons of every component of
        column k start moving when the travel exceeds twice their threshold,
        so the column ``J[:, k]`` of the incremental slope matrix steps
        through cumulative weight sums (docs/compensator.md).

        Parameters
        ----------
        input_index : int
            Column k.

        Returns
        -------
        numpy.ndarray, shape (n_levels, p)
            Each row is a reachable column ``dY/du_k`` [µm/V], the first one
            the dead band right after a reversal.
        """
        comps = [self.components[l][input_index] for l in range(self.n_outputs)]
        levels = sorted({float(r) for c in comps if isinstance(c, PrandtlIshlinskii)
                         for r in c.thresholds})
        columns = []
        for lvl in [-1.0] + levels:
            col = np.zeros(self.n_outputs)
            for l, c in enumerate(comps):
                if isinstance(c, PrandtlIshlinskii):
                    col[l] = c.weights[c.thresholds <= lvl].sum()
                elif c is not None:
                    col[l] = c
            columns.append(col)
        return np.array(columns)
