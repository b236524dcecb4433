"""The registry of compensator kinds: ``[compensator] kind = ...`` -> builder.

Compensators are built by :func:`build_compensator` from the registry
:data:`COMPENSATORS` (kind -> :class:`CompensatorKind`); add a kind by adding
an entry (its ``fields`` are checked by ``hammerstein validate``, its
``build`` runs when the scenario is resolved, its capabilities say how the
cases run and what the report says; nothing else switches on the kind's
name). A compensator is any object with ``.name`` and
``.simulate(reference (m, N), initial_state=None) -> (inputs (m, N),
final_state)``; one that needs look-ahead also has ``.run_reference(plant,
reference, period_samples, fade_samples) -> ChainResult``. The model a kind is built from
(``model = "plant" | "identified" | <file>``) is resolved by
:func:`hammerstein.scenario.identification.resolve_model`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from hammerstein.models.amplifier import LIMITS
from hammerstein.core.files import confined_path
from hammerstein.compensation.hammerstein_compensator import INVERSIONS, HammersteinCompensator
from hammerstein.compensation.model_classes import MODEL_CLASSES, model_class
from hammerstein.compensation.model_classes import kind_problem as class_kind_problem
from hammerstein.exceptions import CompensatorError
from hammerstein.compensation.ilc import LearningCompensator
from hammerstein.compensation.kind_choice import KIND_GAINS, explicit_law
from hammerstein.models.plant import hardware_start
from hammerstein.io.presets import PresetError, load_creep, load_dynamics, read_toml
from hammerstein.scenario.identification import (ResolveContext, identified_from_records,
                                                 resolve_dynamics, resolve_model)
from hammerstein.scenario.identify_tables import (dynamics_source, hammerstein_identify_table,
                                                  identify_dynamics_table, identify_table)
from hammerstein.scenario.schema import (MAX_ITERATIONS, Field, Invalid, check_table, choice, integer,
                                         kind_problem, known_kind, number, string)

__all__ = ["CompensatorKind", "COMPENSATORS", "build_compensator", "compensator_kind", "class_problems"]


@dataclass
class CompensatorKind:
    """An entry of the compensator registry.

    Parameters
    ----------
    build : callable
        ``build(spec: dict, plant, context: ResolveContext) -> compensator or None``;
        ``spec`` is the validated ``[compensator]`` table (defaults filled).
    fields : dict of str to hammerstein.scenario.schema.Field
        The keys this kind accepts besides ``kind`` (validated by
        ``hammerstein validate``).
    description : str
        One line for ``hammerstein list`` and the README.
    rate_independent : bool
        It compensates the hysteresis only: a case whose frequency reaches
        the plant's dynamics is warned about them.
    batchable : bool
        Sweep cases of this kind may run in the batch kernel
        (:func:`hammerstein.simulation.simulate_chain_batch`) when the built
        compensator is fusable; a ``look_ahead`` kind when its compensator has
        ``fused_run`` (the kernel's law, reference and initial state of its
        ``run_reference``).
    look_ahead : bool
        It needs the whole reference ahead (an inverse of the dynamics): the
        case runs through the compensator's ``run_reference``.
    fades_in : bool
        The reference is faded in from rest over ``fade_in`` [s] of the
        table (default one period, at most the settling the metrics skip).
    compensates : bool
        It tracks references (False: open-loop drives only).
    summary : callable, optional
        ``summary(spec) -> list of str``: notes the report adds to the
        compensator's description (e.g. that it uses the plant's true
        dynamics).
    check : callable, optional
        ``check(spec, plant, base_dir, files, settle_periods, period_samples)
        -> list of "key: message"``: the kind's own checks of ``hammerstein
        validate`` that need the plant and the case (nothing identified or
        built); ``files`` caches the files read.
    """

    build: Callable[[dict, Any, Any], Any]
    fields: dict = field(default_factory=dict)
    description: str = ""
    rate_independent: bool = False
    batchable: bool = False
    look_ahead: bool = False
    fades_in: bool = False
    compensates: bool = True
    summary: Callable | None = None
    check: Callable | None = None


def compensator_kind(spec):
    """The registry entry of a compensator table (``kind``, default ``"none"``).

    Parameters
    ----------
    spec : dict or None
        A validated ``[compensator]`` table.

    Returns
    -------
    CompensatorKind

    Raises
    ------
    ValueError
        Unknown kind (``kind: expected one of ...``, with the closest one).
    """
    kind = (spec or {}).get("kind", "none")
    if not known_kind(kind, COMPENSATORS):
        raise ValueError(f"kind: {kind_problem(kind, COMPENSATORS)[0]}")
    return COMPENSATORS[kind]


def _gain(v):
    if v in ("secant", "midpoint", "identity"):
        return v
    if isinstance(v, list) and v and all(isinstance(r, list) and len(r) == len(v) and
                                         all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                             and np.isfinite(a) for a in r) for r in v):
        return v
    raise Invalid(f"expected 'secant', 'midpoint', 'identity' or a square matrix [[..],[..]] of "
                  f"finite numbers [µm/V], found {v!r}")


def _build_none(spec, plant, context):
    return None


def _build_multivariable(spec, plant, context):
    return _rate_independent(spec, plant, context, "multivariable")


def _spec_model(spec, plant, context):
    """The model of a compensator table (every kind resolves it like "multivariable")."""
    return resolve_model(spec.get("model", "plant"), plant, context, spec.get("identify"))


def _law_options(model, kind, spec):
    """(gain, check) of the law: the table's, else what ``compensate --kind KIND`` takes.

    Without a ``gain`` the kind's own (``midpoint`` for ``hammerstein``,
    ``secant`` for ``multivariable``) when it converges, else the convergent
    gain :func:`hammerstein.compensation.kind_choice.explicit_law` chooses, as
    the commands do: a scenario refused ``kind = "hammerstein"`` on an
    identified classical PI (rho 1.42 with the midpoint) that ``compensate``
    ran with the secant gain (rho 0.777).
    """
    if spec.get("gain") is not None:
        return spec["gain"], spec.get("check", "error")
    options, _ = explicit_law(model, kind, None, spec.get("check"))
    return (options.get("gain", KIND_GAINS.get(kind, "secant")),
            options.get("check", spec.get("check", "error")))


def _rate_independent(spec, plant, context, kind):
    """A rate-independent kind over the table's model, built by the model's class
    (:meth:`hammerstein.compensation.model_classes.ModelClass.compensator`: the law of Theorem 4.1 over a
    classical PI, or over a Preisach / generalised-PI model's own forward operator)."""
    model = _spec_model(spec, plant, context)
    gain, check = (_law_options(model, kind, spec) if kind in ("multivariable", "diagonal") else
                   (spec.get("gain", "secant"), spec.get("check", "error")))
    options = {"gain": gain, "iterations": spec.get("iterations", 1),
               "check": check, "feedback": spec.get("feedback", "delay")}
    if options["feedback"] != "delay":
        options.update(cutoff_hz=spec.get("cutoff_hz"), sampling_period=plant.sampling_period)
    comp = model_class(model).compensator(model, kind, **options)
    if kind in ("multivariable", "diagonal"):
        comp.table_gain = gain             # what the report names (the table may give none)
    return comp


def _build_diagonal(spec, plant, context):
    return _rate_independent(spec, plant, context, "diagonal")


def _build_per_axis(spec, plant, context):
    return _rate_independent(spec, plant, context, "per-axis")


def _build_static_gain(spec, plant, context):
    return _rate_independent(spec, plant, context, "static-gain")


# -- registry of compensator kinds: add entries here ---------------------------------
COMPENSATORS: dict[str, CompensatorKind] = {
    "none": CompensatorKind(_build_none, {}, "no compensator (open-loop drives only)",
                            compensates=False),
    "multivariable": CompensatorKind(
        _build_multivariable,
        {"model": Field(string(), default="plant"),
         "identify": Field(identify_table),
         "gain": Field(_gain, default="secant"),
         "iterations": Field(integer(1, MAX_ITERATIONS), default=1),
         "check": Field(choice("error", "warn", "ignore"), default="error"),
         "feedback": Field(choice("delay", "lowpass")),  # default: the one-sample delay
         "cutoff_hz": Field(number("Hz", 0))},
        "inverse multiplicative compensator of Theorem 4.1, normalised by K (docs/compensator.md)",
        rate_independent=True, batchable=True),
}
_MODEL_KEYS = ("model", "identify")  # the model fields every kind shares with "multivariable"
COMPENSATORS["diagonal"] = CompensatorKind(
    _build_diagonal, dict(COMPENSATORS["multivariable"].fields),
    "the multivariable law on the direct transfers only (cross-couplings left)",
    rate_independent=True, batchable=True)
COMPENSATORS["per-axis"] = CompensatorKind(
    _build_per_axis, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "per-axis analytic inverse PI of Kuhnen & Janocha, direct transfers only (docs/per-axis-inverse.md)",
    rate_independent=True, batchable=True)
COMPENSATORS["static-gain"] = CompensatorKind(
    _build_static_gain, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "no hysteresis compensation: U = K^-1 Yr, K the direct secant gains (reference)",
    rate_independent=True, batchable=True)


def model_file_dynamics(spec, base):
    """A ``kind = "hammerstein"`` table with the linear part ``compensate`` takes from its model.

    With ``model = "<file>"`` whose file has a ``[dynamics]`` table (a preset of
    ``hammerstein identify --dynamics``) and no ``dynamics`` key, ``dynamics``
    defaults to that file: its G and, with ``creep = "auto"``, its ``[creep]``
    are inverted, as ``hammerstein compensate`` on the same file inverts them
    (without it the plant's true G was inverted and the file's creep dropped).
    A table whose G is the plant's (``dynamics = "plant"``, the default without
    ``model =`` or with ``model = "plant"``) and ``creep = "auto"`` inverts the
    plant's creep with it (``creep = "plant"``), as ``compensate`` on the plant's
    preset does (without it an identified preset's creep was left: 1.63 % instead
    of 0.099 % on a tester's 50 Hz sine, drives 0.965 V apart).

    Parameters
    ----------
    spec : dict
        A validated compensator table.
    base : pathlib.Path
        The scenario's directory (relative model paths).

    Returns
    -------
    dict
        ``spec`` itself, or a copy with ``dynamics`` = the model path, or with
        ``creep = "plant"``. A file that cannot be read leaves ``spec`` as is
        (the model's own check names the problem).
    """
    if spec.get("kind") != "hammerstein":
        return spec
    spec = _file_dynamics(spec, base)
    if dynamics_source(spec) == "plant" and spec.get("creep", "auto") == "auto":
        return {**spec, "creep": "plant"}     # G and creep: the plant's linear part, as compensate
    return spec


def _file_dynamics(spec, base):
    """``spec`` with ``dynamics`` = its model file when that file has a ``[dynamics]`` table."""
    model = spec.get("model", "plant")
    if "dynamics" in spec or model in ("plant", "identified"):
        return spec
    try:
        data = read_toml(confined_path(model, base, PresetError), "model file")
    except PresetError:
        return spec
    return {**spec, "dynamics": model} if isinstance(data.get("dynamics"), dict) else spec


def _build_hammerstein(spec, plant, context):
    spec = model_file_dynamics(spec, context.base_dir)
    model = None
    if spec.get("model", "plant") != "identified":
        model = _spec_model(spec, plant, context)
    pi, G = resolve_dynamics(spec, plant, context, model)
    gain, check = _law_options(pi, "hammerstein", spec)
    comp = HammersteinCompensator(
        pi, G, inversion=spec.get("inversion", "zpetc"), gain=gain,
        iterations=spec.get("iterations", 3), check=check,
        feedback=spec.get("feedback", "delay"), cutoff_hz=spec.get("cutoff_hz"),
        sampling_period=plant.sampling_period, creep=_spec_creep(spec, plant, context))
    comp.table_gain = gain
    return comp


def _spec_creep(spec, plant, context):
    """The creep a ``kind = "hammerstein"`` compensator inverts with G (None: none).

    ``creep = "auto"`` (default): the ``[creep]`` of the dynamics file when
    ``dynamics`` is a file (e.g. a preset written by ``hammerstein identify
    --creep-records``) or identified from records with ``identify = {
    records = "excitation", creep = true }`` (the identified creep, as
    ``hammerstein compensate`` inverts it), none with ``dynamics = "plant"`` or
    ``"identified"`` otherwise;
    ``"plant"``: the plant's true creep (an oracle); ``"none"``.
    """
    which = spec.get("creep", "auto")
    if which == "none":
        return None
    if which == "plant":
        return plant.creep
    dyn = dynamics_source(spec)
    identify = spec.get("identify") or {}
    if dyn == "identified" and spec.get("model") == "identified" and "records" in identify:
        cache = context.cache if hasattr(context, "cache") else None
        base = context.base_dir if hasattr(context, "base_dir") else Path(context)
        return identified_from_records(plant, identify, True, cache, base).plant.creep
    if dyn in ("plant", "identified"):
        return None
    base = context.base_dir if hasattr(context, "base_dir") else Path(context)
    return load_creep(confined_path(dyn, base, PresetError), plant.hysteresis.output_names)


def _hammerstein_notes(spec):
    if dynamics_source(spec) == "plant":
        return ["inverts the plant's true dynamics G (an oracle: nothing identified; "
                "dynamics = \"identified\" identifies G)"]
    return []


def _dynamics_problems(spec, plant, base, files, settle, period_samples):
    """Problems of the ``dynamics`` keys of ``kind = "hammerstein"`` (nothing identified).

    ``dynamics`` is "plant", "identified" or a readable dynamics/preset file of
    the plant's size; "plant" and "identified" need a plant with dynamics;
    ``identify_dynamics`` goes with "identified" only; ``fade_in`` must end
    within the settling the metrics skip (not on a plant that starts as
    ``compensate`` does, whose metrics skip the fade-in). Returns ``key: message`` strings.
    """
    dyn = dynamics_source(spec)
    out = []
    if "identify_dynamics" in spec and dyn != "identified":
        out.append(f"identify_dynamics: only used with dynamics = 'identified', found {dyn!r}")
    if dyn in ("plant", "identified"):
        if plant.is_static:
            out.append(f"dynamics: {dyn!r} needs a plant with dynamics (plant.dynamics = true)")
    else:
        try:
            path = confined_path(dyn, base, PresetError)
        except PresetError as exc:
            return out + [f"dynamics: {exc}"]
        if ("dynamics", path) not in files:
            try:
                load_dynamics(path, plant.hysteresis.output_names, plant.sampling_period)
                files[("dynamics", path)] = None
            except PresetError as exc:
                files[("dynamics", path)] = f"dynamics: expected 'plant', 'identified' or a " \
                                            f"dynamics file: {exc}"
        if files[("dynamics", path)]:
            out.append(files[("dynamics", path)])
    fade = spec.get("fade_in")
    # a plant that starts as compensate does: its metrics skip the fade-in, however long
    # (hammerstein.scenario.execute.starts_as_hardware); the record's length is checked with it
    if (fade is not None and not hardware_start(plant)
            and fade > settle * period_samples * plant.sampling_period + 1e-12):
        out.append(f"fade_in: {fade:g} s is longer than the {settle:g} settling periods "
                   f"({settle * period_samples * plant.sampling_period:g} s) the metrics skip")
    return out


COMPENSATORS["hammerstein"] = CompensatorKind(
    _build_hammerstein,
    {**{k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k != "identify"},
     "identify": Field(hammerstein_identify_table),
     "gain": Field(_gain, default="midpoint"),     # smallest rho(I - K^-1 J) for identified PIs
     "iterations": Field(integer(1, MAX_ITERATIONS), default=3),
     "dynamics": Field(string()),          # default: "identified" with model = "identified", else "plant"
     "identify_dynamics": Field(identify_dynamics_table),
     "inversion": Field(choice(*INVERSIONS), default="zpetc"),
     "creep": Field(choice("auto", "plant", "none"), default="auto"),   # inverted with G
     "fade_in": Field(number("s", 0, exclusive=False))},   # default: one period (<= settling)
    "Hammerstein compensator U = Gamma^c(G^-1 Yr): inverse of the linear dynamics (ZPETC, "
    "reference P samples ahead, or stable inversion over a look-ahead) then the multivariable law "
    "(docs/hammerstein-plant.md)",
    batchable=True, look_ahead=True, fades_in=True, summary=_hammerstein_notes,
    check=_dynamics_problems)


def _build_preisach_inverse(spec, plant, context):
    model = _spec_model(spec, plant, context)
    problem = class_kind_problem(model, "preisach-inverse")
    if problem:                  # a classical PI: no exact multivariable inverse
        raise CompensatorError(problem)
    # the class's own exact inverse (the registry's hook; the Preisach root search by default)
    return model_class(model).exact_inverse(model, method=spec.get("method", "root"))


COMPENSATORS["preisach-inverse"] = CompensatorKind(
    _build_preisach_inverse,
    {"model": Field(string(), default="plant"),
     "identify": Field(identify_table),    # model = "identified": as every rate-independent kind
     "method": Field(choice("root", "multiplicative"), default="root")},
    "exact per-sample inverse of a Preisach model (monotone root per direct path), or its "
    "inverse multiplicative law; rate independent (docs/plants.md)",
    rate_independent=True)


# every kind starts from rest (fade_in [s], hammerstein.compensation.drive) and reacts to the plant's
# amplifier limits (limits, hammerstein.models.amplifier; "warn" in scenarios)
for _kind in ("multivariable", "diagonal", "per-axis", "static-gain", "hammerstein", "preisach-inverse"):
    COMPENSATORS[_kind].fields.setdefault("fade_in", Field(number("s", 0, exclusive=False)))
    COMPENSATORS[_kind].fields["limits"] = Field(choice(*LIMITS))   # default "warn"


def _start_table(v):
    """The ``start`` table of kind "ilc": any other kind's table (default { kind = "hammerstein" })."""
    if not isinstance(v, dict):
        raise Invalid(f"expected a compensator table {{ kind = ..., ... }}, found {v!r}")
    kind = v.get("kind", "hammerstein")
    others = [k for k in COMPENSATORS if k not in ("none", "ilc")]
    if not known_kind(kind, others):
        raise Invalid(f"kind: expected one of {', '.join(others)}, found {kind!r}")
    problems = []
    clean = check_table({**v, "kind": kind}, {"kind": Field(lambda x: x), **COMPENSATORS[kind].fields},
                        "", problems, "")
    if problems:
        raise Invalid("; ".join(p.lstrip(": ").strip() for p in problems))
    return clean


def _build_ilc(spec, plant, context):
    start = build_compensator(spec.get("start") or {"kind": "hammerstein"}, plant, context)
    return LearningCompensator(
        start, plant.sampling_period, iterations=spec.get("iterations", 10),
        learning_gain=spec.get("learning_gain", 0.5), q_cutoff_hz=spec.get("q_cutoff_hz", 500.0),
        inversion=spec.get("inversion", "zpetc"), sensor_noise=spec.get("sensor_noise", 0.0),
        seed=spec.get("seed", 0), slope_floor=spec.get("slope_floor"))


# kind "ilc" (hammerstein.compensation.ilc): iterative learning against the simulated plant
COMPENSATORS["ilc"] = CompensatorKind(
    _build_ilc,
    {"start": Field(_start_table),            # default { kind = "hammerstein" }
     "iterations": Field(integer(1, MAX_ITERATIONS), default=10),
     "learning_gain": Field(number("", 0)),   # default 0.5, in (0, 2)
     "q_cutoff_hz": Field(number("Hz", 0)),   # default 500 Hz
     "inversion": Field(choice(*INVERSIONS)),
     "sensor_noise": Field(number("µm", 0, exclusive=False)),   # default 0
     "seed": Field(integer(0, 2**31 - 1)),
     # fraction of the loop's mean slope below which the model's local gain is not inverted
     # (IterativeLearning.limit_update); default by model class: 0.7 Preisach/GPI, 0 classical
     "slope_floor": Field(number("", 0, exclusive=False, maximum=1)),
     "fade_in": Field(number("s", 0, exclusive=False)),
     "limits": Field(choice(*LIMITS))},
    "iterative learning control against the plant from another kind's drive: u_k+1 = "
    "u_k + Q(L e_k), L the inverse Hammerstein model along the trajectory (hammerstein.compensation.ilc)",
    look_ahead=True, fades_in=True)


def build_compensator(spec, plant, context):
    """Build the compensator of a ``[compensator]`` table.

    Parameters
    ----------
    spec : dict
        Validated table; ``kind`` selects the :data:`COMPENSATORS` entry
        (default ``"none"``).
    plant : HammersteinPlant
        The simulated plant (its PI model is ``model = "plant"``).
    context : hammerstein.scenario.identification.ResolveContext or pathlib.Path
        The case's context: the scenario's directory (relative model paths),
        the run's identification cache and the record of what the case
        identified; a directory gives a context of its own.

    Returns
    -------
    object or None
        A compensator, or None for ``kind = "none"``.

    Raises
    ------
    ValueError
        Unknown kind; or the builder's own errors (CompensatorError,
        PresetError), e.g. a law refused by the convergence check.
    """
    entry = compensator_kind(spec)
    if not isinstance(context, ResolveContext):
        context = ResolveContext(Path(context))
    comp = entry.build(spec, plant, context)
    if comp is not None:               # start-up and amplifier reaction (scenario.execute)
        comp.fade_in = spec.get("fade_in")
        comp.limits = spec.get("limits", "warn")
    return comp


def class_problems(name, kind, plant, base, files, identify=None, among=None):
    """Problems of a kind that the class of a known model does not take.

    Run when a scenario is validated, as :func:`build_compensator` would refuse it
    (``preisach-inverse`` over a classical PI validated "ok", then the run failed); an
    ``identify`` table's class is the one it names (``auto``: judged when identified).

    Parameters
    ----------
    name : str or None
        The compensator's ``model`` key (``"plant"``, ``"identified"`` or a file).
    kind : str
        The compensator kind.
    plant : HammersteinPlant or None
        The case's plant (None when its preset did not load).
    base : pathlib.Path
        The scenario's directory.
    files : dict
        Path -> model (or message) of the model files already read.
    identify : dict, optional
        The compensator's ``identify`` table.
    among : collection of str, optional
        The kinds the caller takes (a Monte-Carlo study: not ``ilc``); the others are
        not named as kinds that work. All by default.

    Returns
    -------
    list of str
        ``"kind: message"``, or empty.
    """
    if name in (None, "plant"):
        model = getattr(plant, "hysteresis", None)
    elif name == "identified":       # the class the table names (auto: judged when identified)
        table = identify if isinstance(identify, dict) else {}
        cls = table.get("model", "auto" if "records" in table else "classical")
        entry = MODEL_CLASSES.get(cls)
        if entry is None or kind in entry.kinds:
            return []
        return [f"kind: the model identified is a {entry.label} model (identify.model = "
                f"{cls!r}), which kind {kind!r} does not take; the kinds that work with it: "
                f"{', '.join(k for k in entry.kinds if among is None or k in among)}"]
    else:
        try:
            model = files.get(confined_path(name, base, PresetError))
        except PresetError:
            return []
    if model is None or isinstance(model, str):
        return []
    dynamic = plant is not None and not plant.is_static
    try:     # a static plant: hammerstein and ilc are not named as kinds that work
        problem = class_kind_problem(model, kind, has_dynamics=dynamic or kind in ("hammerstein",
                                                                                   "ilc"),
                                     among=among)
    except CompensatorError:
        return []
    return [f"kind: {problem.split(': ', 1)[-1]}"] if problem else []
