"""Discrete Preisach hysteresis and multivariable models of mixed components.

The Preisach model (Mayergoyz [1]_) is a weighted sum of relay hysterons
``R_{alpha,beta}``, each switching up when the input rises above alpha and
down when it falls below beta (``alpha >= beta``), over the Preisach plane
of switching pairs. Its memory is the staircase that separates the switched-up
from the switched-down hysterons: a minor loop is wiped out when the input
leaves it (wiping-out property), and the loops it draws are not those of a
classical PI unless its density depends on ``alpha - beta`` only. A density
that also depends on ``(alpha + beta) / 2`` gives asymmetric loops and minor
loops that no PI can reproduce, as real piezo stacks and cantilevers do.

Discretisation used here
------------------------
The input range is cut into ``n_levels`` cells by the edges
``L_0 < ... < L_n`` [V]. Hysteron (i, j), ``j <= i``, rises while the input
crosses cell i (its alpha cell) and falls while it crosses cell j (its beta
cell); its state s is in [-1, 1] and is updated as

``s <- max(rho_i(u), min(rho_j(u), s))``,

with ``rho_i`` the ramp that is -1 below cell i, +1 above it and linear
across it. This is the relay ``R_{alpha,beta}`` smoothed over one cell (the
relay is the limit of a fine grid), so the output is continuous and
piecewise linear in the input instead of a staircase with one step per
level, and the model stays rate independent with the wiping-out memory (the
states are the memory: the staircase of the Preisach plane, one value per
hysteron). Diagonal hysterons (i = i) are reversible ramps.

The output of one component (input u_k to output y_l) is

``y(t) = sum_{j <= i} mu_ij s_ij(t) + sum_n c_n u(t)^n + offset``,

weights ``mu_ij >= 0`` [µm] plus a reversible (anhysteretic) polynomial
``c_1 u + c_2 u^2 + ...`` (``reversible``: the u^2 term bends the loop, the
asymmetry of a real actuator). The weights are given by

* an explicit lower-triangular ``weights`` table, row i = alpha cell,
  column j = beta cell;
* an ``everett`` table on the edges: ``E[a][b]`` (``a > b``) is the output
  change when the input rises from below ``L_b`` to ``L_a`` from negative
  saturation, ``2 sum_{b <= j <= i < a} mu_ij``, so
  ``mu_ij = (E[i+1][j] - E[i][j] - E[i+1][j+1] + E[i][j+1]) / 2``
  (the Everett function, Mayergoyz [1]_ ch. 1);
* a parametric ``density`` over the bias ``b = (alpha + beta)/2`` and the
  half width ``c = (alpha - beta)/2`` of each cell centre:
  ``exp(-(b - bias - tilt c)^2 / (2 bias_width^2)) exp(-(c - coercivity)^2 /
  (2 coercivity_width^2))`` times the cell area (half of it on the diagonal),
  scaled so that the weights sum to ``total`` [µm] (the hysteretic part then
  spans ``2 total`` between saturations). ``tilt`` and ``bias`` make the loop
  asymmetric; a large ``bias_width`` makes the density depend on c only,
  the Preisach form of a classical PI (PI-like minor loops).

The operator itself, :class:`PreisachModel`, lives in
:mod:`hammerstein.models.preisach_operator` and is re-exported here; its
reversible polynomial and the multivariable container of direct transfers and
cross-couplings (which holds any component class) share this module's table
format and its checks.

References
----------
.. [1] I. D. Mayergoyz, *Mathematical Models of Hysteresis and Their
   Applications*, Elsevier, 2003, ch. 1.
"""

from __future__ import annotations

import numpy as np

from hammerstein.models.generalized_pi import GPI_KEYS, GeneralizedPI
from hammerstein.models.hysteresis import PrandtlIshlinskii, component_words
from hammerstein.models.preisach_operator import PreisachModel, _array, _number, _poly
from hammerstein.exceptions import HysteresisError
from hammerstein.simulation import state_vector

__all__ = ["PreisachModel", "Polynomial", "MultivariableHysteresis", "component_from_table",
           "component_to_table", "hysteresis_from_table", "is_mixed_table"]

PREISACH_KEYS = ("kind", "edges", "range", "n_levels", "weights", "everett", "density",
                 "reversible", "offset", "signed", "demagnetised", "demagnetised_centre")
DENSITY_KEYS = ("kind", "total", "bias", "bias_width", "tilt", "coercivity", "coercivity_width")
POLYNOMIAL_KEYS = ("kind", "coefficients", "offset")
PI_KEYS = ("kind", "thresholds", "weights", "gain")
KINDS = ("preisach", "generalized_pi", "polynomial", "pi")


class Polynomial:
    """Reversible (anhysteretic) component ``c_1 u + c_2 u^2 + ... + offset``.

    An even cross-coupling is ``coefficients = [0, c_2]``.

    Parameters
    ----------
    coefficients : array_like, shape (n,)
        ``c_1, c_2, ...`` [µm/V^n].
    offset : float
        Constant [µm].

    Raises
    ------
    HysteresisError
        On non-finite values.
    """

    n_states = 0

    def __init__(self, coefficients, offset=0.0):
        self.coefficients = _array(coefficients, "coefficients")
        self.offset = _number(offset, "offset")

    def __repr__(self):
        return f"Polynomial({self.coefficients.tolist()}, offset={self.offset})"

    def initial_state(self, initial_state=None):
        """The (empty) state.

        Parameters
        ----------
        initial_state : array_like, shape (0,), optional
            Ignored when None.

        Returns
        -------
        numpy.ndarray, shape (0,)
        """
        return state_vector(initial_state, 0, "initial_state")

    def simulate(self, u, initial_state=None):
        """Output for an input record.

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V].
        initial_state : array_like, shape (0,), optional
            Empty state.

        Returns
        -------
        y : numpy.ndarray, shape (n_samples,)
            Output [µm].
        final_state : numpy.ndarray, shape (0,)
        """
        u = _array(u, "u")
        return _poly(self.coefficients, u) + self.offset, self.initial_state(initial_state)

    def to_table(self):
        """The component's TOML table (``kind = "polynomial"``).

        Returns
        -------
        dict
        """
        return {"kind": "polynomial", "coefficients": self.coefficients.tolist(),
                "offset": self.offset}


class _ClassicalPI:
    """Adapter: a classical PI operator or a gain as a component with ``n_states``."""

    def __init__(self, op):
        self.op = op
        self.n_states = op.n_hysterons if isinstance(op, PrandtlIshlinskii) else 0

    def initial_state(self, initial_state=None):
        return state_vector(initial_state, self.n_states, "initial_state")

    def simulate(self, u, initial_state=None):
        if isinstance(self.op, PrandtlIshlinskii):
            return self.op.simulate(u, self.initial_state(initial_state))
        return float(self.op) * np.asarray(u, dtype=float), np.zeros(0)

    def to_table(self):
        if isinstance(self.op, PrandtlIshlinskii):
            return {"kind": "pi", "thresholds": self.op.thresholds.tolist(),
                    "weights": self.op.weights.tolist()}
        return {"kind": "pi", "gain": float(self.op)}


def component_from_table(comp, where, shared_thresholds=None):
    """One component of a mixed ``[model]`` table.

    Parameters
    ----------
    comp : dict
        ``kind = "preisach"`` (keys ``edges`` or ``range`` + ``n_levels``;
        one of ``weights``, ``everett``, ``density``; optional
        ``reversible``, ``offset``), ``"generalized_pi"`` (``thresholds``,
        ``weights``, ``gamma_l``, ``gamma_r``, ``offset``), ``"polynomial"``
        (``coefficients``, ``offset``) or ``"pi"`` (the default: classical
        PI ``weights`` with ``thresholds`` or the model's shared ones, or a
        ``gain``).
    where : str
        Key path for messages (``model.components.x.ux``).
    shared_thresholds : list of float, optional
        The model's shared classical-PI thresholds [V].

    Returns
    -------
    PreisachModel, GeneralizedPI, Polynomial, PrandtlIshlinskii or float

    Raises
    ------
    HysteresisError
        ``<where>.<key>: <what was expected>``.
    """
    if not isinstance(comp, dict):
        raise HysteresisError(f"{where}: expected a table")
    kind = comp.get("kind", "pi")
    if kind not in KINDS:
        raise HysteresisError(f"{where}.kind: expected one of {', '.join(KINDS)}, found {kind!r}")
    keys = {"preisach": PREISACH_KEYS, "generalized_pi": GPI_KEYS, "polynomial": POLYNOMIAL_KEYS,
            "pi": PI_KEYS}[kind]
    unknown = sorted(set(comp) - set(keys))
    if unknown:
        raise HysteresisError(f"{where}.{unknown[0]}: unknown key for kind = {kind!r} (expected "
                              f"{', '.join(k for k in keys if k != 'kind')})")
    try:
        if kind == "generalized_pi":
            return GeneralizedPI.from_table(comp)
        if kind == "polynomial":
            if "coefficients" not in comp:
                raise HysteresisError("coefficients: missing (c_1, c_2, ... [µm/V^n])")
            return Polynomial(comp["coefficients"], comp.get("offset", 0.0))
        if kind == "pi":
            if "gain" in comp:
                if "weights" in comp or "thresholds" in comp:
                    raise HysteresisError("gain: give either gain or weights, not both")
                return _number(comp["gain"], "gain")
            if "weights" not in comp:
                raise HysteresisError("weights: missing (or give a gain)")
            r = comp.get("thresholds", shared_thresholds)
            if r is None:
                raise HysteresisError("thresholds: missing (and no shared model.thresholds)")
            return PrandtlIshlinskii(r, comp["weights"])
        return _preisach_from_table(comp)
    except HysteresisError as exc:
        raise HysteresisError(f"{where}.{exc}") from None


def _preisach_from_table(comp):
    model = _preisach_weights_from_table(comp)
    start = {k: comp[k] for k in ("demagnetised", "demagnetised_centre") if k in comp}
    return model.replace(**start) if start else model


def _preisach_weights_from_table(comp):
    if "edges" in comp:
        if "range" in comp or "n_levels" in comp:
            raise HysteresisError("edges: give either edges or range and n_levels, not both")
        edges = _array(comp["edges"], "edges")
    else:
        for key in ("range", "n_levels"):
            if key not in comp:
                raise HysteresisError(f"{key}: missing (give edges, or range = [lo, hi] [V] and "
                                      f"n_levels)")
        lo_hi = _array(comp["range"], "range")
        n = comp["n_levels"]
        if lo_hi.size != 2 or not lo_hi[0] < lo_hi[1]:
            raise HysteresisError(f"range: expected [lo, hi] with lo < hi [V], found {comp['range']!r}")
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 400:
            raise HysteresisError(f"n_levels: expected an integer 1-400, found {n!r}")
        edges = np.linspace(lo_hi[0], lo_hi[1], n + 1)
    given = [k for k in ("weights", "everett", "density") if k in comp]
    if len(given) != 1:
        raise HysteresisError(f"{'weights' if not given else given[1]}: expected exactly one of "
                              f"weights, everett or density")
    rev, off = comp.get("reversible", ()), comp.get("offset", 0.0)
    if given[0] == "weights":
        return PreisachModel(edges, comp["weights"], rev, off, comp.get("signed", False))
    if "signed" in comp:
        raise HysteresisError(f"signed: only with explicit weights, found with {given[0]}")
    if given[0] == "everett":
        return PreisachModel.from_everett(edges, comp["everett"], rev, off)
    dens = comp["density"]
    if not isinstance(dens, dict):
        raise HysteresisError("density: expected a table (kind = 'gaussian', total, ...)")
    unknown = sorted(set(dens) - set(DENSITY_KEYS))
    if unknown or dens.get("kind", "gaussian") != "gaussian" or "total" not in dens:
        bad = unknown[0] if unknown else ("kind" if dens.get("kind", "gaussian") != "gaussian"
                                          else "total")
        raise HysteresisError(f"density.{bad}: expected kind = 'gaussian' with total and optional "
                              f"{', '.join(DENSITY_KEYS[2:])}")
    args = {k: v for k, v in dens.items() if k != "kind"}
    try:
        return PreisachModel.from_density(edges, reversible=rev, offset=off, **args)
    except HysteresisError as exc:
        raise HysteresisError(f"density.{exc}") from None


def component_to_table(comp):
    """The TOML table of a component (inverse of :func:`component_from_table`).

    Parameters
    ----------
    comp : PreisachModel, GeneralizedPI, Polynomial, PrandtlIshlinskii or float

    Returns
    -------
    dict
    """
    if isinstance(comp, (PreisachModel, GeneralizedPI, Polynomial)):
        return comp.to_table()
    return _ClassicalPI(comp).to_table()


class MultivariableHysteresis:
    """Multivariable hysteresis whose components may be of any class.

    ``y_l(t) = sum_k Gamma_lk(u_k(t)) (+ output_offset_l)``, each component a
    :class:`PreisachModel`, a
    :class:`~hammerstein.models.generalized_pi.GeneralizedPI`, a
    :class:`Polynomial`, a classical
    :class:`~hammerstein.models.hysteresis.PrandtlIshlinskii`, a gain [µm/V] or
    None, as the multivariable PI of the paper (eq. (3)) with other operators.
    Duck-types the parts of
    :class:`~hammerstein.models.hysteresis.MultivariablePI` a plant needs
    (``n_inputs``, ``n_outputs``, ``n_hysterons`` = length of the flat
    state, names, ``check_inputs``, ``initial_state``, ``simulate``);
    ``packable = False`` tells the simulation layer that the fused PI kernels
    cannot run it.

    Parameters
    ----------
    components : sequence of sequences, shape (p, m)
        ``components[l][k]`` from input k to output l.
    input_names, output_names : sequence of str, optional
        Names (default ``u0, ...`` / ``y0, ...``).
    input_amplitude : array_like, shape (m,), optional
        Input range per input [V].

    Attributes
    ----------
    input_range : numpy.ndarray, shape (m, 2), or None
        ``[low, high]`` per input [V] of the records the model was
        identified on (set on reading a file whose ``[amplifier]`` comes
        from the records); its exact inverse keeps its inputs there. None:
        ``+-1.2 input_amplitude``.

    Notes
    -----
    The flat state is the components' states in order of output l, then
    input k (see each class for its own state).

    Raises
    ------
    HysteresisError
        On a non-rectangular grid, a component of another type, or wrong names.

    Examples
    --------
    A Preisach direct path with an even (u^2) cross-coupling:

    >>> import numpy as np
    >>> from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
    >>> direct = PreisachModel.from_density(np.linspace(-10, 10, 21), total=20.0, coercivity=2.0,
    ...                                     coercivity_width=2.0, reversible=[1.0])
    >>> model = MultivariableHysteresis([[direct], [Polynomial([0.0, 0.03])]],
    ...                                 input_names=["ux"], output_names=["x", "y"])
    >>> y, state = model.simulate(np.array([[0.0, 10.0, 0.0, -10.0]]))
    >>> np.round(y[1], 2)
    array([0., 3., 0., 3.])
    >>> bool(y[0, 1] > 29.9), bool(y[0, 3] < -29.9), model.n_hysterons
    (True, True, 210)
    """

    packable = False
    output_offset = None
    has_output_map = False
    input_range = None

    def __init__(self, components, input_names=None, output_names=None, input_amplitude=None):
        rows = [list(r) for r in components]
        if not rows or not rows[0] or any(len(r) != len(rows[0]) for r in rows):
            raise HysteresisError("components: expected a non-empty rectangular p x m grid")
        self._adapted = []
        for l, row in enumerate(rows):
            for k, c in enumerate(row):
                if isinstance(c, (int, float, np.floating, np.integer)) and not isinstance(c, bool):
                    c = row[k] = _number(c, f"components[{l}][{k}]")
                if c is None:
                    continue
                if isinstance(c, (PreisachModel, GeneralizedPI, Polynomial)):
                    self._adapted.append((l, k, c))
                elif isinstance(c, (PrandtlIshlinskii, float)):
                    self._adapted.append((l, k, _ClassicalPI(c)))
                else:
                    raise HysteresisError(f"components[{l}][{k}]: expected a PreisachModel, "
                                          f"GeneralizedPI, Polynomial, PrandtlIshlinskii, gain or "
                                          f"None, found {c!r}")
        self.components = rows
        p, m = len(rows), len(rows[0])
        self.input_names = self._names(input_names, m, "u", "input_names")
        self.output_names = self._names(output_names, p, "y", "output_names")
        self.input_amplitude = None
        if input_amplitude is not None:
            amp = _array(input_amplitude, "input_amplitude")
            if amp.shape != (m,) or np.any(amp <= 0):
                raise HysteresisError(f"input_amplitude: expected {m} positive values, found "
                                      f"{amp.tolist()}")
            self.input_amplitude = amp
        sizes = [c.n_states for _, _, c in self._adapted]
        self._slices = np.concatenate([[0], np.cumsum(sizes)]).astype(int) if sizes else np.zeros(1, int)

    @staticmethod
    def _names(names, count, prefix, field_name):
        if names is None:
            return [f"{prefix}{i}" for i in range(count)]
        names = [str(n) for n in names]
        if len(names) != count or len(set(names)) != count:
            raise HysteresisError(f"{field_name}: expected {count} distinct names, found {names}")
        return names

    def __repr__(self):
        """Sizes, names and one word per component (no arrays), e.g. for ``print(model)``."""
        def word(c):
            if c is None:
                return "-"
            if isinstance(c, PreisachModel):
                return f"Preisach({c.n_levels} levels)"
            if isinstance(c, GeneralizedPI):
                return f"generalised PI({c.thresholds.size})"
            if isinstance(c, Polynomial):
                return f"polynomial({c.coefficients.size})"
            if isinstance(c, PrandtlIshlinskii):
                return f"PI({c.n_hysterons})"
            return f"gain {float(c):.4g}"

        rows = component_words(self.output_names, self.input_names, self.components, word)
        return (f"MultivariableHysteresis({self.n_outputs}x{self.n_inputs} "
                f"({', '.join(self.input_names)} -> {', '.join(self.output_names)}), "
                f"{self.n_hysterons} states; {rows})")

    def size_text(self):
        """The model's size in words, e.g. ``'2x2 Preisach (ux, uy -> x, y), 1860 states'``.

        The class word is the components' (``Preisach``, ``generalised PI``, or
        ``mixed``), as :meth:`~hammerstein.models.hysteresis.MultivariablePI.size_text`
        says ``PI``.

        Returns
        -------
        str
        """
        kinds = {type(c).__name__ for row in self.components for c in row
                 if isinstance(c, (PreisachModel, GeneralizedPI, PrandtlIshlinskii))}
        word = ("Preisach" if kinds == {"PreisachModel"} else "generalised PI"
                if kinds == {"GeneralizedPI"} else "PI" if kinds == {"PrandtlIshlinskii"}
                else "mixed")
        return (f"{self.n_outputs}x{self.n_inputs} {word} ({', '.join(self.input_names)} -> "
                f"{', '.join(self.output_names)}), {self.n_hysterons} states")

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
        """Length of the flat state vector."""
        return int(self._slices[-1])

    def component(self, output, input):
        """One component, by index or name.

        Parameters
        ----------
        output, input : int or str
            Output and input index or name.

        Returns
        -------
        object
            The component (None when absent).
        """
        l = output if isinstance(output, int) else self.output_names.index(output)
        k = input if isinstance(input, int) else self.input_names.index(input)
        return self.components[l][k]

    def check_inputs(self, u, name="inputs"):
        """Validate an input record as an (m, n_samples) float array.

        Parameters
        ----------
        u : array_like, shape (m, n_samples)
            Input voltages [V].
        name : str
            Field name for messages.

        Returns
        -------
        numpy.ndarray, shape (m, n_samples)

        Raises
        ------
        HysteresisError
            On a wrong shape or non-finite values.
        """
        try:
            arr = np.asarray(u, dtype=float)
        except (TypeError, ValueError):
            raise HysteresisError(f"{name}: expected numbers") from None
        if arr.ndim == 1 and self.n_inputs == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[0] != self.n_inputs:
            raise HysteresisError(f"{name}: expected shape ({self.n_inputs}, n_samples), found "
                                  f"{arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise HysteresisError(f"{name}: expected finite values")
        return arr

    def initial_state(self, initial_state=None):
        """Validated copy of a flat state, or every component's default state.

        Parameters
        ----------
        initial_state : array_like, shape (n_hysterons,), optional
            Flat state (see Notes of the class).

        Returns
        -------
        numpy.ndarray, shape (n_hysterons,)

        Raises
        ------
        HysteresisError
            On a wrong length or values a component refuses.
        """
        if initial_state is None:
            parts = [c.initial_state() for _, _, c in self._adapted]
            return np.concatenate(parts) if parts else np.zeros(0)
        s = state_vector(initial_state, self.n_hysterons, "initial_state")
        for q, (_, _, c) in enumerate(self._adapted):
            c.initial_state(s[self._slices[q]:self._slices[q + 1]])
        return s

    def simulate(self, inputs, initial_state=None):
        """Outputs for an input record; each component stepped by its compiled kernel.

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Input voltages [V].
        initial_state : array_like, shape (n_hysterons,), optional
            Flat state; every component's default by default.

        Returns
        -------
        outputs : numpy.ndarray, shape (p, n_samples)
            Outputs [µm].
        final_state : numpy.ndarray, shape (n_hysterons,)
            Flat state after the last sample.

        Raises
        ------
        HysteresisError
            On a wrongly shaped or non-finite input or state.
        """
        u = self.check_inputs(inputs)
        s = self.initial_state(initial_state)
        y = np.zeros((self.n_outputs, u.shape[1]))
        final = np.empty_like(s)
        for q, (l, k, c) in enumerate(self._adapted):
            a, b = self._slices[q], self._slices[q + 1]
            yk, final[a:b] = c.simulate(u[k], s[a:b])
            y[l] += yk
        return y, final

    def to_table(self, input_unit="V", output_unit="µm"):
        """The ``[model]`` table (mixed components, each with its ``kind``).

        Parameters
        ----------
        input_unit, output_unit : str
            Unit names stored with the model.

        Returns
        -------
        dict
        """
        table = {"inputs": list(self.input_names), "outputs": list(self.output_names),
                 "input_unit": input_unit, "output_unit": output_unit}
        if self.input_amplitude is not None:
            table["input_amplitude"] = self.input_amplitude.tolist()
        comps = {}
        for l, out in enumerate(self.output_names):
            for k, inp in enumerate(self.input_names):
                c = self.components[l][k]
                if c is not None:
                    comps.setdefault(out, {})[inp] = component_to_table(c)
        table["components"] = comps
        return table

    @classmethod
    def from_table(cls, table, source="model"):
        """Build from a parsed mixed ``[model]`` table.

        Parameters
        ----------
        table : dict
            ``inputs``, ``outputs``, optional ``input_amplitude`` [V],
            ``thresholds`` (shared classical-PI thresholds), ``input_unit``,
            ``output_unit``, and ``components.<output>.<input>`` tables (see
            :func:`component_from_table`).
        source : str
            Prefix of messages (file name).

        Returns
        -------
        MultivariableHysteresis

        Raises
        ------
        HysteresisError
            ``<source>: model.<key>: ...`` naming every wrong key.
        """
        return hysteresis_from_table(table, source)


MODEL_TABLE_KEYS = ("inputs", "outputs", "input_amplitude", "thresholds", "input_unit",
                    "output_unit", "components")


def is_mixed_table(table):
    """True when a ``[model]`` table has a component of a kind other than the classical PI.

    Parameters
    ----------
    table : dict
        Parsed ``[model]`` table.

    Returns
    -------
    bool
    """
    comps = table.get("components") if isinstance(table, dict) else None
    if not isinstance(comps, dict):
        return False
    return any(isinstance(c, dict) and c.get("kind", "pi") != "pi"
               for row in comps.values() if isinstance(row, dict) for c in row.values())


def hysteresis_from_table(table, source="model"):
    """A :class:`MultivariableHysteresis` from a parsed ``[model]`` table.

    Parameters
    ----------
    table : dict
        See :meth:`MultivariableHysteresis.from_table`.
    source : str
        Prefix of messages (file name).

    Returns
    -------
    MultivariableHysteresis

    Raises
    ------
    HysteresisError
        ``<source>: model.<key>: ...``, every problem of the table in one message.
    """
    problems = [f"model.{k}: unknown key (expected {', '.join(MODEL_TABLE_KEYS)})"
                for k in table if k not in MODEL_TABLE_KEYS]
    inputs, outputs = table.get("inputs"), table.get("outputs")
    for key, val in (("inputs", inputs), ("outputs", outputs)):
        if not (isinstance(val, list) and val and all(isinstance(v, str) for v in val)):
            problems.append(f"model.{key}: expected a non-empty list of names")
    comps = table.get("components", {})
    if not isinstance(comps, dict):
        problems.append("model.components: expected a table of tables")
    if problems:
        raise HysteresisError(f"{source}: " + "; ".join(problems))
    grid = [[None] * len(inputs) for _ in outputs]
    for out, row in comps.items():
        if out not in outputs or not isinstance(row, dict):
            problems.append(f"model.components.{out}: unknown output or not a table (outputs "
                            f"are {outputs})")
            continue
        for inp, comp in row.items():
            where = f"model.components.{out}.{inp}"
            if inp not in inputs:
                problems.append(f"{where}: unknown input (inputs are {inputs})")
                continue
            try:
                grid[outputs.index(out)][inputs.index(inp)] = component_from_table(
                    comp, where, table.get("thresholds"))
            except HysteresisError as exc:
                problems.append(str(exc))
    if problems:
        raise HysteresisError(f"{source}: " + "; ".join(problems))
    try:
        return MultivariableHysteresis(grid, inputs, outputs, table.get("input_amplitude"))
    except HysteresisError as exc:
        raise HysteresisError(f"{source}: model.{exc}") from None
