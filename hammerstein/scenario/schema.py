"""Scenario files (TOML): schema, validation and resolution.

A scenario names a simulated actuator (``[plant]``), an optional feedforward
compensator (``[compensator]``) and one or more ``[[cases]]``, each an
open-loop voltage ``drive`` (characterisation, paper Fig. 5) or a
compensated ``reference`` trajectory (Fig. 8, 10-13). The full schema is in
the README.

:func:`load_scenario` checks the whole file and collects EVERY problem
(unknown keys with the closest valid key, types, units, ranges, names of
inputs and outputs, signals beyond Nyquist, compensators that refuse to
build) before raising one :class:`ScenarioError` whose lines read
``file: key: message``. ``hammerstein validate`` runs exactly this.
"""

from __future__ import annotations

import difflib
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from hammerstein.core import references as refs
from hammerstein.core.presets import PresetError, load_plant, read_toml
from hammerstein.exceptions import Invalid, ScenarioError

__all__ = [
    "ScenarioError",
    "Field",
    "Invalid",
    "Scenario",
    "CaseSpec",
    "load_scenario",
    "number",
    "integer",
    "string",
    "boolean",
    "choice",
    "name_list",
]


# -- field checkers: value -> normalised value, or raise Invalid -------------------
def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)


def number(unit, minimum=None, exclusive=True):
    """Checker of a finite number [unit], optionally ``> minimum`` (or ``>=``)."""
    def check(v):
        bound = "" if minimum is None else f" {'>' if exclusive else '>='} {minimum:g}"
        if not _is_number(v) or (minimum is not None and (v <= minimum if exclusive else v < minimum)):
            raise Invalid(f"expected a number{bound} [{unit}], found {v!r}")
        return float(v)
    return check


def integer(minimum=0):
    """Checker of an integer ``>= minimum``."""
    def check(v):
        if not isinstance(v, int) or isinstance(v, bool) or v < minimum:
            raise Invalid(f"expected an integer >= {minimum}, found {v!r}")
        return v
    return check


def string(pattern=None, what="a string"):
    """Checker of a string, optionally matching a regular expression."""
    def check(v):
        if not isinstance(v, str) or (pattern is not None and not re.fullmatch(pattern, v)):
            raise Invalid(f"expected {what}, found {v!r}")
        return v
    return check


def boolean():
    """Checker of ``true`` / ``false``."""
    def check(v):
        if not isinstance(v, bool):
            raise Invalid(f"expected true or false, found {v!r}")
        return v
    return check


def choice(*options):
    """Checker of one string among ``options``."""
    def check(v):
        if v not in options:
            hint = difflib.get_close_matches(str(v), options, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise Invalid(f"expected one of {', '.join(map(repr, options))}, found {v!r}{extra}")
        return v
    return check


def name_list(count):
    """Checker of a list of ``count`` strings."""
    def check(v):
        if not (isinstance(v, list) and len(v) == count and all(isinstance(s, str) for s in v)):
            raise Invalid(f"expected a list of {count} names, found {v!r}")
        return v
    return check


def _amplitudes(v):
    if _is_number(v) and v > 0:
        return float(v)
    if isinstance(v, list) and len(v) == 2 and all(_is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a positive number or two [µm], found {v!r}")


def _frequency_pair(v):
    if isinstance(v, list) and len(v) == 2 and all(_is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two positive frequencies [f_x, f_y] [Hz], found {v!r}")


@dataclass
class Field:
    """One key of a scenario table.

    Parameters
    ----------
    check : callable
        ``value -> normalised value``; raises :class:`Invalid`.
    required : bool
        Whether the key must be present.
    default : object
        Value when absent (not checked).
    """

    check: Callable[[Any], Any]
    required: bool = False
    default: Any = None


NAME = r"[A-Za-z0-9][A-Za-z0-9._-]*"

TOP = {
    "name": Field(string(NAME, "a name of letters, digits, '.', '_' or '-'")),
    "title": Field(string()),
    "description": Field(string()),
    "seed": Field(integer(0), default=0),
    "kind": Field(choice("cases")),  # other kinds: runner.SCENARIO_KINDS, dispatched below
    "plant": Field(lambda v: v, required=True),
    "compensator": Field(lambda v: v),
    "cases": Field(lambda v: v),          # required unless [[sweeps]] are given
    "sweeps": Field(lambda v: v),         # hammerstein.sweeps: expanded into cases
    "stability_map": Field(lambda v: v),  # hammerstein.sweeps.check_stability_map
}
PLANT = {
    "preset": Field(string(), required=True),
    "dynamics": Field(boolean(), default=True),
}
CASE = {
    "name": Field(string(NAME, "a name of letters, digits, '.', '_' or '-'"), required=True),
    "description": Field(string()),
    "reference": Field(lambda v: v),
    "drive": Field(lambda v: v),
    "plant": Field(lambda v: v),
    "compensator": Field(lambda v: v),
    "settle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
    "model": Field(string()),     # drives: a model compared with the plant (hammerstein.identified)
    "identify": Field(lambda v: v),
}
_PHASE = Field(number("deg"), default=0.0)
_LENGTH = {"periods": Field(number("periods", 0)), "duration": Field(number("s", 0))}
REFERENCES = {
    "sine": {"output": Field(string(), required=True),
             "amplitude": Field(number("µm", 0), required=True),
             "frequency": Field(number("Hz", 0), required=True),
             "phase": _PHASE, "offset": Field(number("µm"), default=0.0), **_LENGTH},
    "circle": {"radius": Field(number("µm", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
    "spiral": {"radius": Field(number("µm", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "tau": Field(number("s", 0), required=True),
               "duration": Field(number("s", 0), required=True),
               "circle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
               "phase": _PHASE, "outputs": Field(name_list(2))},
    "lissajous": {"amplitude": Field(_amplitudes, required=True),
                  "frequencies": Field(_frequency_pair, required=True),
                  "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
}
DRIVES = {
    "sine": {"input": Field(string(), required=True),
             "amplitude": Field(number("V", 0), required=True),
             "frequency": Field(number("Hz", 0), required=True),
             "phase": _PHASE, "offset": Field(number("V"), default=0.0), **_LENGTH},
}


def check_table(table, schema, where, problems, source):
    """Check a table against a schema, appending problems; return clean dict.

    Unknown keys are reported with the closest valid key (difflib); missing
    required keys and invalid values are reported; defaults are filled in.

    Parameters
    ----------
    table : object
        Parsed TOML value expected to be a table.
    schema : dict of str to Field
    where : str
        Key path prefix (``cases[0].reference``).
    problems : list of str
        Receives ``source: key: message`` lines.
    source : str
        File name.

    Returns
    -------
    dict or None
        Normalised values (None if ``table`` is not a table).
    """
    pre = f"{where}." if where else ""
    if not isinstance(table, dict):
        problems.append(f"{source}: {where}: expected a table, found {table!r}")
        return None
    out = {}
    for key, value in table.items():
        if key not in schema:
            hint = difflib.get_close_matches(key, list(schema), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f" (valid keys: {', '.join(schema)})"
            problems.append(f"{source}: {pre}{key}: unknown key{extra}")
            continue
        try:
            out[key] = schema[key].check(value)
        except Invalid as exc:  # a nested table may report several (subkey, message)
            for sub, msg in getattr(exc, "problems", None) or [(None, str(exc))]:
                problems.append(f"{source}: {pre}{key}{'.' + sub if sub else ''}: {msg}")
    for key, fld in schema.items():
        if key not in table:
            if fld.required:
                problems.append(f"{source}: {pre}{key}: missing (required)")
            elif fld.default is not None:
                out[key] = fld.default
    return out


@dataclass
class CaseSpec:
    """A validated, resolved case of a scenario.

    Attributes
    ----------
    name : str
    description : str
    mode : {'drive', 'reference'}
    signal_spec : dict
        The validated ``drive`` or ``reference`` table.
    plant_spec, compensator_spec : dict
        Merged plant and compensator tables.
    plant : HammersteinPlant
    compensator : object or None
        Built compensator (None for drives and ``kind = "none"``).
    time : numpy.ndarray, shape (n_samples,)
        [s].
    signal : numpy.ndarray, shape (m or p, n_samples)
        Drive voltages [V] or reference displacements [µm].
    period_samples : int
        Samples per period of the excitation (common period for Lissajous).
    settle_periods : float
    driven_input : int or None
        Index of the driven input (drives).
    loop_channel : int or None
        Output carrying a single-axis sine reference.
    scale : float or None
        Amplitude or radius [µm] for percent metrics.
    warnings : list of str
        Warnings raised while building (e.g. a convergence warning).
    model : MultivariablePI or None
        Drives: the model compared with the plant (case keys ``model``,
        ``identify``; :func:`hammerstein.identified.comparison_model`).
    model_spec : dict or None
        The case's ``model`` and validated ``identify`` entries.
    """

    name: str
    description: str
    mode: str
    signal_spec: dict
    plant_spec: dict
    compensator_spec: dict
    plant: Any
    compensator: Any
    time: np.ndarray
    signal: np.ndarray
    period_samples: int
    settle_periods: float
    driven_input: int | None = None
    loop_channel: int | None = None
    scale: float | None = None
    warnings: list = field(default_factory=list)
    model: Any = None
    model_spec: dict | None = None
    sweep: dict | None = None  # {sweep, compensator, axis, frequency_hz} of a sweep case


@dataclass
class Scenario:
    """A validated scenario: metadata and resolved cases."""

    name: str
    title: str
    description: str
    seed: int
    path: Path
    cases: list
    sweeps: list = field(default_factory=list)  # hammerstein.sweeps.SweepSpec
    stability_map: Any = None                   # pandas.DataFrame (hammerstein.sweeps)


def _merge_compensator(top, case):
    top = dict(top or {})
    case = dict(case or {})
    if "kind" in case and case["kind"] != top.get("kind", "none"):
        return case
    return {**top, **case}


def _check_compensator(spec, where, problems, source):
    from hammerstein.runner import COMPENSATORS  # the registry lives with the factory
    kind = spec.get("kind", "none")
    if kind not in COMPENSATORS:
        hint = difflib.get_close_matches(str(kind), list(COMPENSATORS), n=1)
        extra = f" (did you mean {hint[0]!r}?)" if hint else ""
        problems.append(f"{source}: {where}.kind: expected one of "
                        f"{', '.join(map(repr, COMPENSATORS))}, found {kind!r}{extra}")
        return None
    schema = {"kind": Field(lambda v: v), **COMPENSATORS[kind].fields}
    return check_table(spec, schema, where, problems, source)


def _signal(case_where, mode, spec, plant, problems, source):
    """Generate the drive/reference; returns (time, signal, period_s, extras)."""
    kinds = DRIVES if mode == "drive" else REFERENCES
    where = f"{case_where}.{mode}"
    if not isinstance(spec, dict):
        problems.append(f"{source}: {where}: expected a table, found {spec!r}")
        return None
    kind = spec.get("kind")
    if kind not in kinds:
        hint = difflib.get_close_matches(str(kind), list(kinds), n=1)
        extra = f" (did you mean {hint[0]!r}?)" if hint else ""
        problems.append(f"{source}: {where}.kind: expected one of "
                        f"{', '.join(map(repr, kinds))}, found {kind!r}{extra}")
        return None
    n_before = len(problems)
    clean = check_table(spec, {"kind": Field(lambda v: v), **kinds[kind]}, where, problems, source)
    if clean is None or len(problems) > n_before or plant is None:
        return None
    T = plant.sampling_period
    model = plant.hysteresis
    c = {k: v for k, v in clean.items() if k != "kind"}
    extras = {}
    try:
        if mode == "drive":
            t, sig = refs.sine_drive(T, model.input_names, **c)
            extras["driven_input"] = model.input_names.index(c["input"])
            period = 1.0 / c["frequency"]
        elif kind == "sine":
            t, sig = refs.sine(T, model.output_names, **c)
            extras["loop_channel"] = model.output_names.index(c["output"])
            extras["scale"] = c["amplitude"]
            period = 1.0 / c["frequency"]
        else:
            outs = c.pop("outputs", None) or list(model.output_names[:2])
            missing = [o for o in outs if o not in model.output_names]
            if missing or model.n_outputs < 2:
                raise refs.SignalError(f"outputs: expected two of the plant's outputs "
                                       f"{model.output_names}, found {outs}")
            fn = {"circle": refs.circle, "spiral": refs.spiral, "lissajous": refs.lissajous}[kind]
            t, xy = fn(T, **c)
            sig = np.zeros((model.n_outputs, t.size))
            for row, o in zip(xy, outs):
                sig[model.output_names.index(o)] = row
            if kind == "lissajous":
                try:
                    period = refs.lissajous_period(*c["frequencies"])
                except refs.SignalError:
                    period = 1.0 / min(c["frequencies"])
                amp = c["amplitude"]
                extras["scale"] = float(np.max(amp))
            else:
                period = 1.0 / c["frequency"]
                extras["scale"] = c["radius"]
    except refs.SignalError as exc:
        problems.append(f"{source}: {where}.{exc}")
        return None
    return t, sig, max(int(round(period / T)), 1), extras


def _kind_problem(kind, kinds):
    try:
        choice(*kinds)(kind)
    except Invalid as exc:
        return [str(exc)]
    return []


def load_scenario(path):
    """Validate and resolve a scenario file.

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.

    Returns
    -------
    Scenario
        Cases with their plants, built compensators and signals.

    Raises
    ------
    ScenarioError
        Listing every problem found, one ``file: key: message`` per line.
    """
    from hammerstein.runner import build_compensator
    path = Path(path)
    source = str(path)
    try:
        data = read_toml(path)
    except PresetError as exc:
        raise ScenarioError([str(exc)]) from None
    kind = data.get("kind", "cases")
    if kind != "cases":
        from hammerstein.runner import SCENARIO_KINDS  # e.g. "identification" (measured records)
        if kind not in SCENARIO_KINDS:
            raise ScenarioError([f"{source}: kind: {exc}" for exc in _kind_problem(kind, SCENARIO_KINDS)])
        return SCENARIO_KINDS[kind].load(path, data)
    problems = []
    top = check_table(data, TOP, "", problems, source) or {}
    base = path.parent
    plant_top = data.get("plant", {}) if isinstance(data.get("plant", {}), dict) else {}
    comp_top = data.get("compensator", {}) if isinstance(data.get("compensator", {}), dict) else {}
    if "plant" in data:
        check_table(data["plant"], PLANT, "plant", problems, source)
    if "compensator" in data:
        if isinstance(comp_top, dict):
            _check_compensator(comp_top, "compensator", problems, source)
        else:
            problems.append(f"{source}: compensator: expected a table")
    cases_raw = data.get("cases", [])
    if "cases" in data and (not isinstance(cases_raw, list) or not cases_raw):
        problems.append(f"{source}: cases: expected one or more [[cases]] tables")
        cases_raw = []
    if "cases" not in data and "sweeps" not in data:
        problems.append(f"{source}: cases: missing (required)")
    entries, sweep_specs = [(f"cases[{i}]", raw) for i, raw in enumerate(cases_raw)], []
    if "sweeps" in data:
        from hammerstein.scenario.sweeps import expand_sweeps
        more, sweep_specs = expand_sweeps(data["sweeps"], source, problems)
        entries += more
    plants, cases, names = {}, [], set()
    for where, raw in entries:
        n_before = len(problems)
        case = check_table(raw, CASE, where, problems, source)
        if case is None:
            continue
        if "name" in case:
            if case["name"] in names:
                problems.append(f"{source}: {where}.name: duplicate case name {case['name']!r}")
            names.add(case["name"])
        has_ref, has_drive = "reference" in raw, "drive" in raw
        if has_ref == has_drive:
            problems.append(f"{source}: {where}: expected exactly one of reference "
                            f"(compensated) or drive (open loop)")
            continue
        mode = "reference" if has_ref else "drive"
        # plant: merge and load
        pover = raw.get("plant", {})
        pspec = {**plant_top, **(pover if isinstance(pover, dict) else {})}
        plant_clean = check_table(pover, {k: Field(f.check) for k, f in PLANT.items()},
                                  f"{where}.plant", problems, source) if "plant" in raw else {}
        plant = None
        if plant_clean is not None and "preset" in pspec and isinstance(pspec["preset"], str):
            dyn = pspec.get("dynamics", True)
            key = (pspec["preset"], bool(dyn))
            if key not in plants:
                try:
                    plants[key] = load_plant(pspec["preset"], dynamics=bool(dyn), base_dir=base)
                except PresetError as exc:
                    plants[key] = None
                    problems.append(f"{source}: {where}.plant.preset: {exc}")
            plant = plants[key]
        # compensator: merge and check
        cover = raw.get("compensator", {})
        cspec = _merge_compensator(comp_top, cover if isinstance(cover, dict) else {})
        scratch = []
        cclean = _check_compensator(cspec, f"{where}.compensator", scratch, source)
        if "compensator" in raw:
            if isinstance(cover, dict):
                problems.extend(scratch)  # top-level problems are reported once, above
            else:
                problems.append(f"{source}: {where}.compensator: expected a table")
        elif scratch and not any("compensator" in q for q in problems[:n_before]):
            problems.extend(scratch)
        comp_ok = not scratch and cclean is not None
        sig = _signal(where, mode, raw[mode], plant, problems, source)
        kind = cspec.get("kind", "none")
        if mode == "reference" and kind == "none":
            problems.append(f"{source}: {where}.reference: a reference needs a compensator "
                            f"(compensator.kind is 'none'); use drive for an open-loop run")
        if sig is None or len(problems) > n_before or (mode == "reference" and not comp_ok):
            continue
        t, signal, P, extras = sig
        settle = case.get("settle_periods", 1.0)
        need = settle * P + (P if (mode == "drive" or "loop_channel" in extras) else 1)
        if t.size < need:
            problems.append(f"{source}: {where}.settle_periods: {settle:g} periods of settling "
                            f"leave less than {'one period' if need - settle * P > 1 else 'one sample'} "
                            f"of the {t.size}-sample record; lengthen it or settle less")
            continue
        cmp_model, cmp_spec = None, None
        if "model" in raw or "identify" in raw:
            from hammerstein.scenario.identified import comparison_model
            try:
                cmp_model, cmp_spec = comparison_model(raw, mode, plant, base)
            except (ValueError, PresetError) as exc:  # one "key: message" per line
                problems.extend(f"{source}: {where}.{line}" for line in str(exc).splitlines())
                continue
        comp, caught = None, []
        if mode == "reference":
            with warnings.catch_warnings(record=True) as rec:
                warnings.simplefilter("always")
                try:
                    comp = build_compensator(cclean, plant, base)
                except (ValueError, PresetError) as exc:
                    problems.append(f"{source}: {where}.compensator: {exc}")
                    continue
            caught = [str(w.message) for w in rec]
        cases.append(CaseSpec(
            name=case["name"], description=case.get("description", ""), mode=mode,
            signal_spec=dict(raw[mode]), plant_spec=pspec,
            compensator_spec=cclean if cclean is not None else cspec,
            plant=plant, compensator=comp, time=t, signal=signal, period_samples=P,
            settle_periods=settle, warnings=caught, model=cmp_model, model_spec=cmp_spec,
            **extras))
    smap = None
    if "stability_map" in data and isinstance(plant_top.get("preset"), str):
        from hammerstein.scenario.sweeps import check_stability_map
        try:
            smap_plant = load_plant(plant_top["preset"], dynamics=bool(plant_top.get("dynamics", True)),
                                    base_dir=base)
        except PresetError:
            smap_plant = None  # reported with the plant table
        smap = check_stability_map(data["stability_map"], smap_plant, comp_top, base, problems, source)
    if problems:
        raise ScenarioError(problems)
    info = {c["case"]: {"sweep": sp.name, **c} for sp in sweep_specs for c in sp.cases}
    for c in cases:
        c.sweep = info.get(c.name)
    return Scenario(name=top.get("name", path.stem), title=top.get("title", path.stem),
                    description=top.get("description", ""), seed=top.get("seed", 0),
                    path=path, cases=cases, sweeps=sweep_specs, stability_map=smap)
