"""One actuator model type: the registry of hysteresis model classes and what each supports.

Every hysteresis model the package identifies is one of three classes (a
fourth entry, ``mixed``, takes a hand-written model whose direct paths are of
different classes), each with optional creep and linear dynamics around it (a
preset's ``[creep]`` and ``[dynamics]`` tables):

* ``classical``: the multivariable classical Prandtl-Ishlinskii model of the
  paper, with its output map (:class:`~hammerstein.models.hysteresis.MultivariablePI`);
* ``preisach``: a multivariable model whose direct paths are discrete Preisach
  models (:class:`~hammerstein.models.preisach.MultivariableHysteresis` of
  :class:`~hammerstein.models.preisach.PreisachModel`);
* ``generalized``: the same with generalised-PI direct paths
  (:class:`~hammerstein.models.generalized_pi.GeneralizedPI`, Al Janaideh,
  Rakheja and Su, IEEE/ASME Trans. Mechatronics 16(4), 2011).

Each has the same small interface, reached through its :class:`ModelClass`
entry of :data:`MODEL_CLASSES` (never by a branch on the model's type):
forward simulation (the model's own ``simulate(inputs (m, N) [V]) ->
(outputs (p, N) [µm], state)``), the exact inverse where it exists
(:meth:`ModelClass.exact_inverse`), the rate-independent compensators of each
kind (:meth:`ModelClass.compensator`), the preset round trip
(:meth:`ModelClass.to_table`) and its capabilities: the compensator kinds it
supports (:attr:`ModelClass.kinds`); the kind chosen when none is given is
:func:`hammerstein.compensation.kind_choice.choose_kind`'s. A new class is
its module, its entry here (with its exact inverse's builder, :attr:`ModelClass.inverse`), a branch of
:func:`hammerstein.io.model_table.model_from_table` to read its ``[model]``
table, and an example in the registry-wide tests (docs/models-and-kinds.md,
"A new model class").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                           StaticGainCompensator, diagonal_compensator)
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.compensation.mixed_compensators import mixed_compensator
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.io.presets import model_from_table, model_to_table
from hammerstein.exceptions import CompensatorError

__all__ = ["ModelClass", "MODEL_CLASSES", "model_class", "kind_problem", "square_problem",
           "RATE_INDEPENDENT_KINDS"]

#: The rate-independent kinds every class builds (:meth:`ModelClass.compensator`).
RATE_INDEPENDENT_KINDS = ("multivariable", "diagonal", "per-axis", "static-gain")


def _classical_compensator(model, kind, gain="secant", iterations=1, check="error",
                           feedback="delay", cutoff_hz=None, sampling_period=None):
    options = {} if feedback == "delay" else {"feedback": feedback, "cutoff_hz": cutoff_hz,
                                              "sampling_period": sampling_period}
    if kind == "multivariable":
        return InverseMultiplicativeCompensator(model, gain=gain, iterations=iterations,
                                                check=check, **options)
    if kind == "diagonal":
        return diagonal_compensator(model, gain=gain, iterations=iterations, check=check, **options)
    if kind == "per-axis":
        return PerAxisInverseCompensator(model)
    if kind == "static-gain":
        return StaticGainCompensator(model)
    raise CompensatorError(f"kind: expected one of {', '.join(RATE_INDEPENDENT_KINDS)}, "
                           f"found {kind!r}")


def _mixed_compensator(model, kind, gain="secant", iterations=1, check="error", feedback="delay",
                       cutoff_hz=None, sampling_period=None):
    return mixed_compensator(model, kind, gain=gain, iterations=iterations, check=check,
                             feedback=feedback)


def _direct_paths(model):
    comps = getattr(model, "components", None)
    if comps is None or model.n_inputs != model.n_outputs:
        return []
    return [comps[l][l] for l in range(model.n_outputs)]


def _is_preisach(model):
    paths = _direct_paths(model)
    return isinstance(model, MultivariableHysteresis) and bool(paths) and \
        all(isinstance(c, PreisachModel) for c in paths)


def _is_generalized(model):
    paths = _direct_paths(model)
    return isinstance(model, MultivariableHysteresis) and bool(paths) and \
        all(isinstance(c, GeneralizedPI) for c in paths) 


def _is_mixed(model):
    return isinstance(model, MultivariableHysteresis)


@dataclass(frozen=True)
class ModelClass:
    """An entry of the model-class registry :data:`MODEL_CLASSES`.

    Parameters
    ----------
    name : str
        The class's name (``hammerstein identify --model``, scenario
        ``identify.model``).
    label : str
        Words for messages and ``hammerstein list``.
    matches : callable
        ``matches(model) -> bool``: the model is of this class.
    kinds : tuple of str
        The compensator kinds that work with the class (the names of the
        scenario registry ``[compensator] kind``; ``ilc`` starts from one of
        them).
    exact_inverse_kind : str or None
        The rate-independent kind that inverts the model exactly per sample,
        or None when the class has no exact multivariable inverse (the
        classical PI: only its per-axis analytic inverse).
    build : callable
        ``build(model, kind, gain, iterations, check, feedback, cutoff_hz,
        sampling_period) -> compensator`` for the rate-independent kinds
        (:data:`RATE_INDEPENDENT_KINDS`).
    description : str
        One line for ``hammerstein list`` and docs/models-and-kinds.md.
    law_options : tuple of str
        Options of the inverse multiplicative law this class honours.
    inverse : callable, optional
        ``inverse(model, name=..., **options) -> compensator``: the exact
        per-sample inverse of kind ``exact_inverse_kind`` (``options`` are that
        kind's, e.g. ``method``); by default the Preisach root search
        (:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`),
        which takes any model whose direct paths it can bracket.
    """

    name: str
    label: str
    matches: Callable[[Any], bool]
    kinds: tuple
    exact_inverse_kind: str | None
    build: Callable = field(repr=False)
    description: str = ""
    law_options: tuple = ("gain", "iterations", "check", "feedback")
    inverse: Callable | None = field(default=None, repr=False)

    def compensator(self, model, kind, **options):
        """A rate-independent compensator of ``kind`` over ``model``.

        Parameters
        ----------
        model : MultivariablePI or MultivariableHysteresis
            A model of this class.
        kind : {'multivariable', 'diagonal', 'per-axis', 'static-gain'}
        **options
            ``gain``, ``iterations``, ``check``, ``feedback``, ``cutoff_hz``,
            ``sampling_period`` of the law (docs/compensator.md).

        Returns
        -------
        object
            ``simulate(reference (m, N) [µm]) -> (inputs (m, N) [V], state)``.

        Raises
        ------
        CompensatorError
            A kind the class does not support (the message names those it
            does) or the builder's own errors (e.g. a law refused by the
            convergence check).
        """
        if kind not in RATE_INDEPENDENT_KINDS:
            raise CompensatorError(kind_problem(model, kind) or
                                   f"kind: {kind!r} is not a rate-independent kind "
                                   f"({', '.join(RATE_INDEPENDENT_KINDS)})")
        if kind not in self.kinds:        # the entry's own list, not the builder, decides
            raise CompensatorError(kind_problem(model, kind) or
                                   f"kind {kind!r}: not a kind of the {self.label} class")
        return self.build(model, kind, **options)

    def exact_inverse(self, model, name=None, **options):
        """The exact per-sample inverse of ``model``, or None when the class has none.

        Parameters
        ----------
        model : MultivariableHysteresis
            A model of this class.
        name : str, optional
            Label in reports (default the kind's name).
        **options
            Options of the inverse (``method`` of the Preisach root search).

        Returns
        -------
        PreisachInverseCompensator or None
            Its output through ``model`` equals a reachable reference to the
            root tolerance (:mod:`hammerstein.compensation.preisach_inverse`).

        Raises
        ------
        CompensatorError
            A model the root search refuses (e.g. decreasing direct paths).
        """
        if self.exact_inverse_kind is None:
            return None
        build = self.inverse or PreisachInverseCompensator
        return build(model, name=name or self.exact_inverse_kind, **options)

    @staticmethod
    def to_table(model, input_unit="V", output_unit="µm"):
        """The model's ``[model]`` table of a preset (read back by :meth:`from_table`).

        Parameters
        ----------
        model : MultivariablePI or MultivariableHysteresis
        input_unit, output_unit : str

        Returns
        -------
        dict
            :func:`hammerstein.io.presets.model_to_table`.
        """
        return model_to_table(model, input_unit, output_unit)

    @staticmethod
    def from_table(table, source="model"):
        """The model of a ``[model]`` table (the preset round trip).

        Parameters
        ----------
        table : dict
        source : str
            Prefix of messages.

        Returns
        -------
        MultivariablePI or MultivariableHysteresis
            :func:`hammerstein.io.presets.model_from_table`.

        Raises
        ------
        HysteresisError
            On a bad table.
        """
        return model_from_table(table, source)


_ALL_KINDS = ("hammerstein", "multivariable", "diagonal", "per-axis", "static-gain", "ilc")

#: The registry of model classes: name -> :class:`ModelClass` (first match wins).
MODEL_CLASSES: dict[str, ModelClass] = {
    "classical": ModelClass(
        "classical", "classical PI", lambda m: isinstance(m, MultivariablePI), _ALL_KINDS, None,
        _classical_compensator,
        "multivariable classical Prandtl-Ishlinskii model with its output map (paper eq. (3))"),
    "preisach": ModelClass(
        "preisach", "Preisach", _is_preisach, _ALL_KINDS + ("preisach-inverse",),
        "preisach-inverse", _mixed_compensator,
        "discrete Preisach direct paths (relays on a switching grid); Preisach, generalised-PI, "
        "polynomial or gain cross-couplings (a classical-PI one: the multivariable law only)",
        law_options=("gain", "check")),
    "generalized": ModelClass(
        "generalized", "generalized PI", _is_generalized, _ALL_KINDS + ("preisach-inverse",),
        "preisach-inverse", _mixed_compensator,
        "generalised-PI direct paths (plays under rising/falling envelopes); cross-couplings as "
        "for preisach",
        law_options=("gain", "check")),
    "mixed": ModelClass(
        "mixed", "mixed-class", _is_mixed, _ALL_KINDS + ("preisach-inverse",),
        "preisach-inverse", _mixed_compensator,
        "direct paths of different classes (e.g. a model file written by hand)",
        law_options=("gain", "check")),
}


def model_class(model):
    """The registry entry of a model.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis

    Returns
    -------
    ModelClass

    Raises
    ------
    CompensatorError
        A model of no registered class.
    """
    for entry in MODEL_CLASSES.values():
        if entry.matches(model):
            return entry
    raise CompensatorError(f"model: {type(model).__name__} is none of the model classes "
                           f"({', '.join(MODEL_CLASSES)})")


def kind_problem(model, kind, has_dynamics=True, among=None, verb="work"):
    """Why ``kind`` does not work with ``model``, naming the kinds that do (None if it does).

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
    kind : str
        A compensator kind.
    has_dynamics : bool
        The actuator file has linear dynamics (``hammerstein`` and ``ilc``
        need them).
    among : collection of str, optional
        The kinds the caller offers (``export``'s: not ``ilc``); the others
        are not named. All by default.
    verb : str
        How the kinds named are said to work with it (``"export"``: "the
        kinds that export it").

    Returns
    -------
    str or None
    """
    square = square_problem(model)
    if square:                         # no kind inverts a rectangular model
        return square
    entry = model_class(model)
    works = [k for k in entry.kinds if has_dynamics or k not in ("hammerstein", "ilc")]
    if kind in works:
        return None
    why = ("has no dynamics to invert" if kind in entry.kinds else
           f"is a {entry.label} model, which kind {kind!r} does not take")
    named = [k for k in works if among is None or k in among]
    said = "work with it" if verb == "work" else f"{verb} it"
    return (f"kind {kind!r}: the model {why}"
            + (f"; the kinds that {said}: {', '.join(named)}" if named else ""))


def square_problem(model):
    """Why no compensator kind takes ``model``: it is not square (None when it is).

    Every compensator inverts the model output by output (the paper's
    Section 4 law, the exact inverses' Gauss-Seidel over the direct paths,
    the per-axis inverse), so it needs as many inputs as outputs. An
    actuator with more channels than measured outputs (a tube's common z,
    two stacks on one axis) or more outputs than channels (a parasitic tilt)
    is made square on the hardware side: drive one channel per output, or
    measure one output per channel.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis

    Returns
    -------
    str or None
        One line naming the inputs and outputs, or None for a square model.

    Examples
    --------
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> pi = PrandtlIshlinskii([0.0, 1.0], [1.0, 0.2])
    >>> print(square_problem(MultivariablePI([[pi, 0.1]], input_names=["ux", "uz"],
    ...                                      output_names=["x"]))[:100])
    model: every compensator needs as many inputs as outputs (a square model), found 2 inputs (ux, uz) a
    """
    m, p = int(model.n_inputs), int(model.n_outputs)
    if m == p:
        return None
    ins, outs = list(model.input_names), list(model.output_names)
    return (f"model: every compensator needs as many inputs as outputs (a square model), found "
            f"{m} input{'s' if m != 1 else ''} ({', '.join(ins)}) and {p} output"
            f"{'s' if p != 1 else ''} ({', '.join(outs)}): drive one channel per measured "
            f"output (hold the others), or measure one displacement per channel, and identify "
            f"again")
