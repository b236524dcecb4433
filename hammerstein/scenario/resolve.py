"""Scenario files, step 2 of 2: resolution (what ``hammerstein run`` adds to validation).

:func:`resolve_scenario` turns a validated scenario
(:func:`hammerstein.scenario.validate.validate_scenario`) into what execution
needs: it identifies the ``model = "identified"`` models on their plants
(:mod:`hammerstein.scenario.identification`, once per run), reads the model files,
builds every compensator (:func:`hammerstein.scenario.registry.build_compensator`,
whose convergence check may refuse a law) and computes the
``[stability_map]``. Problems found only here are collected and raised as
one :class:`ScenarioError` with the same ``file: key: message`` lines as the
validation. :func:`load_scenario` runs both steps.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.shaping import mode_note
from hammerstein.models.dynamics import SampledSystem
from hammerstein.core.files import confined_path
from hammerstein.io.presets import PresetError, load_dynamics, read_toml
from hammerstein.scenario.identification import ResolveContext, resolve_comparison_model
from hammerstein.scenario.identification_cache import IdentificationCache
from hammerstein.scenario.rate_warning import dynamics_effect, rate_independent_warning
from hammerstein.scenario.registry import build_compensator, compensator_kind
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.sweeps import stability_map_frame
from hammerstein.scenario.validate import ScenarioSpec, validate_scenario

__all__ = ["Scenario", "resolve_scenario", "load_scenario", "dynamics_warning", "mode_notes"]



@dataclass
class Scenario:
    """A resolved scenario of kind ``"cases"``: metadata and ready-to-run cases.

    Parameters
    ----------
    name, title, description : str
    seed : int
    path : pathlib.Path
    cases : list of hammerstein.scenario.validate.CaseSpec
        With their compensators and comparison models.
    sweeps : list of hammerstein.scenario.sweeps.SweepSpec
    stability_map : pandas.DataFrame or None
        :func:`hammerstein.scenario.sweeps.stability_map_frame`.
    kind : str
        ``"cases"``.
    """

    name: str
    title: str
    description: str
    seed: int
    path: Path
    cases: list
    sweeps: list = field(default_factory=list)
    stability_map: Any = None
    kind: str = "cases"


def _identified_dynamics(case, base):
    """(sampled G, label) of the dynamics in the case's model file, or None.

    The model of the compensator (or the comparison model of a drive) named
    by a file that has a ``[dynamics]`` table (a preset written by
    ``hammerstein identify --dynamics``): what was measured, not the plant.
    """
    spec = (case.model_spec if case.mode == "drive" else case.compensator_spec) or {}
    name = spec.get("model")
    if base is None or not isinstance(name, str) or name in ("plant", "identified"):
        return None
    try:
        path = confined_path(name, base, PresetError)
        data = read_toml(path)
        if "dynamics" not in data:
            return None
        G = load_dynamics(path, list(case.plant.hysteresis.output_names),
                          case.plant.sampling_period)
    except (PresetError, ValueError, OSError):
        return None                      # the build reports a bad file
    # not identified_from: that names the hysteresis records, not the multisines G came from
    return SampledSystem.from_system(G), f"the linear dynamics of {path.name}"


def _moved(case, sig, n):
    """Indices of the outputs a reference (the inputs a drive) moves; all when unnamed."""
    key, names = (("input", case.plant.hysteresis.input_names) if case.mode == "drive"
                  else ("output", case.plant.hysteresis.output_names))
    named = sig.get(key)
    named = [named] if isinstance(named, str) else named
    if not isinstance(named, list) or not named or not all(m in names for m in named) \
            or len(names) != n:
        return slice(None)
    return [list(names).index(m) for m in named]


def dynamics_warning(case, base=None):
    """One warning when a rate-independent treatment meets frequencies the dynamics shape.

    A case warns when its plant has dynamics and its highest reference (or
    drive) frequency f is above :data:`~hammerstein.scenario.rate_warning.RESONANCE_FRACTION` of the first
    resonance, or where ``|G(f) G(0)^-1 - I|_2`` exceeds its ``GAIN_DEVIATION``, and it is
    a reference tracked by a rate-independent compensator kind (capability
    ``rate_independent`` of :class:`hammerstein.scenario.registry.CompensatorKind`) or an open-loop
    drive compared with a static (PI-only) model.

    The dynamics judged are what was identified when the case's model is a
    file with a ``[dynamics]`` table (``hammerstein identify --dynamics``
    writes one; the message says so and names the records and the preset),
    else the plant's.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
    base : pathlib.Path, optional
        The scenario's directory (model files are relative to it); None:
        the plant's dynamics.

    Returns
    -------
    str or None
        The warning, pointing to ``kind = "hammerstein"``.
    """
    plant = case.plant
    if plant is None or plant.is_static:
        return None
    kind = (case.compensator_spec or {}).get("kind", "none")
    static_model = case.mode == "drive" and case.model_spec is not None
    rate_independent = compensator_kind(case.compensator_spec).rate_independent
    if not (static_model or (case.mode == "reference" and rate_independent)):
        return None
    sig = case.signal_spec or {}
    f = max(np.atleast_1d(sig.get("frequencies", sig.get("frequency", 0.0))), default=0.0)
    if not f > 0:
        return None
    found = _identified_dynamics(case, base)
    lin, what = found if found else (plant.sampled_dynamics, "the plant's linear dynamics")
    if lin is None:
        return None
    # the columns of the outputs (inputs, for a drive) the case moves: a sine on y was given
    # the whole matrix's figure, x's mode at 400 Hz (842 % where y's own was about 100 %)
    effect = dynamics_effect(lin, f, what, _moved(case, sig, lin.frequency_response_hz(
        [1.0]).shape[0]))
    if effect is None:
        return None
    if static_model:
        return (f"the comparison model is static (PI only): {effect}, which it does not "
                f"model (docs/hammerstein-plant.md)")
    return rate_independent_warning(kind, effect)


def mode_notes(case):
    """The note ``hammerstein compensate`` gives the same reference, for a built case.

    A case whose compensator inverts linear dynamics (kind
    ``"hammerstein"``: the creep and bending modes it identified or was
    given) gets :func:`hammerstein.compensation.shaping.mode_note` of that
    linear part on the case's reference: the harmonic of the reference's main
    frequency that a bending mode passes at least twice its static gain, where
    what the hysteresis model gets wrong reaches the position that many times
    larger. Rate-independent kinds get :func:`dynamics_warning` instead.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
        With its built compensator (None: no note).

    Returns
    -------
    list of str
        Zero or one note.
    """
    comp = case.compensator
    if case.mode != "reference" or not isinstance(comp, HammersteinCompensator):
        return []
    lin = comp.dynamics
    note = mode_note((lin.A, lin.B, lin.C, lin.D), case.plant.sampling_period, case.signal,
                     case.period_samples)
    return [note] if note else []


#: the options of the inverse multiplicative law, which a compensator whose static part is the
#: model's exact inverse does not run
LAW_OPTIONS = ("gain", "iterations", "check", "feedback", "cutoff_hz")
#: the key naming the exact static part in a shown compensator table (the report prints it)
EXACT_KEY = "static part:"


def shown_spec(spec, comp):
    """The compensator table as it runs: what the report names.

    A compensator whose static part is its model's exact inverse (``kind =
    "hammerstein"`` on a Preisach or generalised-PI model: ``exact_static``)
    runs no gain law; its table's law options (filled with their defaults,
    ``midpoint`` gain, 3 iterations) are left out and :data:`EXACT_KEY` names
    the exact inverse instead (a tester's report said "midpoint gain, 3
    iterations" for the exact Preisach inverse). A table that gives no
    ``gain`` is shown with the gain its law took (``table_gain``: the kind's
    own, or the convergent one when that does not converge).

    Parameters
    ----------
    spec : dict or None
        The validated compensator table.
    comp : object or None
        The compensator built from it.

    Returns
    -------
    dict or None
        ``spec`` itself, a copy with the gain that ran, or a copy without
        :data:`LAW_OPTIONS` and with :data:`EXACT_KEY`.
    """
    if not spec:
        return spec
    if not getattr(comp, "exact_static", False):
        gain = getattr(comp, "table_gain", None)
        if "gain" in spec or gain is None:
            return spec
        # a table without a gain: the one the builder took (the kind's own, or the convergent)
        return {**spec, "gain": gain.tolist() if isinstance(gain, np.ndarray) else gain}
    out = {k: v for k, v in spec.items() if k not in LAW_OPTIONS}
    out[EXACT_KEY] = "the exact inverse of its model (no gain, no iterations)"
    return out


def canonical_key(value):
    """A hashable key equal for equal tables (dicts in any key order, arrays by content).

    Parameters
    ----------
    value : object
        A validated table: dicts, lists, tuples, numbers, strings, paths,
        numpy arrays, None; anything else by identity (distinct objects
        never compare equal, which only costs a second build).

    Returns
    -------
    tuple or object
        Hashable.

    Examples
    --------
    >>> canonical_key({"b": [1.0, 2], "a": "x"}) == canonical_key({"a": "x", "b": (1.0, 2)})
    True
    """
    if isinstance(value, dict):
        return ("dict", tuple(sorted((str(k), canonical_key(v)) for k, v in value.items())))
    if isinstance(value, (list, tuple)):
        return ("seq", tuple(canonical_key(v) for v in value))
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, (str, int, float, bool, type(None), Path, np.generic)):
        return (type(value).__name__, value)
    return ("object", type(value).__qualname__, id(value))


def resolve_scenario(spec, cache=None):
    """Identify, load and build what a validated scenario needs (step 2 of 2).

    Parameters
    ----------
    spec : ScenarioSpec or hammerstein.scenario.records.RecordScenario
        From :func:`hammerstein.scenario.validate.validate_scenario`. Other
        kinds than ``"cases"`` (identification scenarios) need no resolution
        and are returned as they are.
    cache : hammerstein.scenario.identification_cache.IdentificationCache, optional
        The identifications to share (default: a new cache for this
        scenario, backed by the on-disk cache).

    Returns
    -------
    Scenario
        Cases with their compensators (and the warnings raised while
        building them), comparison models and identifications
        (``CaseSpec.identified``); the stability map.

    Raises
    ------
    ScenarioError
        Every problem of the resolution, one ``file: key: message`` per line:
        a failed identification, an unreadable or wrongly sized model file, a
        compensator refused by its convergence check, a stability-map
        compensator that cannot be built.
    """
    if not isinstance(spec, ScenarioSpec):
        return spec
    source, base, problems, cases = str(spec.path), spec.path.parent, [], []
    run = ResolveContext(base, IdentificationCache() if cache is None else cache)
    built, warned = {}, {}   # canonical table and plant -> (compensator, error, identified), warnings
    failed = {}              # canonical table and plant -> (error, the cases using it): said once
    for case in spec.cases:
        model, context = None, run.for_case()
        if case.model_spec is not None:
            try:
                model = resolve_comparison_model(case.model_spec, case.plant, context)
            except (ValueError, PresetError) as exc:  # one "key: message" per line
                problems.extend(f"{source}: {case.where}.{line}" for line in str(exc).splitlines())
                continue
        comp, caught = None, list(case.warnings)     # the validation's (implausible values)
        if case.mode == "reference":
            # one build (identification, convergence report) per distinct table and plant
            key = (canonical_key(case.compensator_spec), id(case.plant))
            if key not in built:
                before = len(context.identified)
                with warnings.catch_warnings(record=True) as rec:
                    warnings.simplefilter("always")
                    try:
                        built[key] = (build_compensator(case.compensator_spec, case.plant, context),
                                      None, list(context.identified[before:]))
                    except (ValueError, PresetError) as exc:
                        built[key] = (None, exc, [])
                warned[key] = [str(w.message) for w in rec]
            else:                       # the build's identifications belong to every case using it
                context.identified.extend(built[key][2])
            comp, error, _ = built[key]
            if error is not None:     # one line per table that failed, naming every case using it
                failed.setdefault(key, (error, []))[1].append(f"{case.where}.compensator")
                continue
            caught += list(warned[key])
        extra = dynamics_warning(case, base)
        if extra:
            caught.append(extra)
        case = replace(case, compensator=comp, model=model, warnings=caught,
                       identified=list(context.identified),
                       compensator_spec=shown_spec(case.compensator_spec, comp))
        cases.append(replace(case, notes=mode_notes(case)))
    problems += [f"{source}: {', '.join(wheres)}: {error}" for error, wheres in failed.values()]
    smap = None
    if spec.stability_map is not None and spec.stability_plant is not None:
        smap = stability_map_frame(spec.stability_map, spec.stability_plant, spec.compensator_top,
                                   run.for_case(), problems, source)
    if problems:
        raise ScenarioError(problems)
    return Scenario(name=spec.name, title=spec.title, description=spec.description,
                    seed=spec.seed, path=spec.path, cases=cases, sweeps=spec.sweeps,
                    stability_map=smap)


def load_scenario(path):
    """Validate and resolve a scenario file (both steps).

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.

    Returns
    -------
    Scenario or hammerstein.scenario.records.RecordScenario
        Cases with their plants, built compensators and signals.

    Raises
    ------
    ScenarioError
        Listing every problem found, one ``file: key: message`` per line
        (the validation's; when there are none, the resolution's).

    Examples
    --------
    >>> from hammerstein.scenario.resolve import load_scenario
    >>> sc = load_scenario("scenarios/default.toml")  # doctest: +SKIP
    >>> [c.name for c in sc.cases]                     # doctest: +SKIP
    """
    return resolve_scenario(validate_scenario(path))
