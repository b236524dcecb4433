"""Scenario files, step 1 of 2: validation (what ``hammerstein validate`` runs).

:func:`validate_scenario` reads a scenario file and checks all of it,
collecting EVERY problem before raising one :class:`ScenarioError` whose
lines read ``file: key: message``: unknown keys (with the closest valid
key), types, units and ranges, the plant preset and the names of its inputs
and outputs, the drive and reference signals (generated here, so a signal
at or beyond the Nyquist frequency or too short for ``settle_periods`` is
reported), duplicate case names, the ``identify`` and ``model`` keys of a
case (an ``identify`` table present, its frequency below Nyquist), the
model files named by ``model`` (read and checked), ``[[sweeps]]`` (expanded
into cases) and the ``[stability_map]`` table. A problem is named once, where
it is written (the top-level ``[compensator]``'s ``model`` and ``identify``
are checked once, not per case), and hides only the checks that depend on it
(a misspelt compensator kind is checked as the kind it spells; a signal table
with bad keys still has its outputs named). It builds no compensator,
identifies no model and simulates nothing: that is step 2,
:func:`hammerstein.scenario.resolve.resolve_scenario`.

A file whose top-level ``kind`` is not ``"cases"`` is validated by the entry
of :data:`VALIDATORS` (``"identification"``: measured records,
:func:`hammerstein.scenario.records.load_identification_scenario`).

Length: one pass over a cases file's tables collects every problem; the
bookkeeping that names each problem once, where it is written, and hides only
what depends on it (a sweep's compensator, a wrong output beside its
frequency) needs every table's state at hand, so it is kept in one module.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from hammerstein.signals import references as refs
from hammerstein.core.files import confined_path
from hammerstein.core.numbers import MAX_MAGNITUDE, is_number, plausibility_problem
from hammerstein.core.schema import short_repr
from hammerstein.io.presets import PresetError, load_model, load_plant, read_toml
from hammerstein.scenario.identify_tables import comparison_spec, nyquist_problem
from hammerstein.scenario.validate_records import record_file_problems, record_keys
from hammerstein.scenario.records import load_identification_scenario
from hammerstein.scenario.hardware_route import hardware_start
from hammerstein.scenario.registry import COMPENSATORS, class_problems, model_file_dynamics
from hammerstein.scenario.schema import (CASE, MAX_CASE_SAMPLES, MAX_CASES, MAX_NAME, NAME, PLANT,
                                         TOP, Field, Invalid, ScenarioError, check_table, kind_problem,
                                         known_kind, total_samples_budget)
from hammerstein.scenario.sweeps import check_stability_table, expand_sweeps
from hammerstein.scenario.compensator_table import (check_compensator, clean_keys_problems,
                                                    meant_kind, merge_compensator)
from hammerstein.scenario.montecarlo import is_montecarlo, validate_montecarlo
from hammerstein.scenario.feedback_table import validate_feedback

__all__ = ["CaseSpec", "ScenarioSpec", "VALIDATORS", "read_scenario", "validate_scenario"]


@dataclass
class CaseSpec:
    """A validated case of a scenario (resolved: with its compensator and model).

    Parameters
    ----------
    name : str
    description : str
    mode : {'drive', 'reference'}
    signal_spec : dict
        The validated ``drive`` or ``reference`` table.
    plant_spec, compensator_spec : dict
        Merged plant and (validated, defaults filled) compensator tables.
    plant : HammersteinPlant
    compensator : object or None
        Built compensator (None for drives and ``kind = "none"``); None
        until :func:`hammerstein.scenario.resolve.resolve_scenario`.
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
        Warnings raised while building the compensator (e.g. a convergence
        warning); filled by the resolution.
    model : MultivariablePI or None
        Drives: the model compared with the plant (case keys ``model``,
        ``identify``); None until resolved.
    model_spec : dict or None
        The case's ``model`` and validated ``identify`` entries
        (:func:`hammerstein.scenario.identify_tables.comparison_spec`).
    sweep : dict or None
        ``{sweep, case, compensator, axis, frequency_hz}`` of a sweep case.
    where : str
        Key path of the case in the file (``cases[0]``,
        ``sweeps[1](<case name>)``), for the problems of the resolution.
    identified : list
        What the case identified
        (:class:`hammerstein.scenario.identification.IdentifiedModel`,
        :class:`hammerstein.scenario.identification.IdentifiedDynamics`);
        filled by the resolution.
    notes : list of str
        What the report should say about the case that is not a warning
        (a harmonic of the reference at a bending mode,
        :func:`hammerstein.scenario.resolve.mode_notes`); filled by the
        resolution.
    start_fade : int or None
        The fade-in of a case that started as ``compensate`` starts its drive
        [samples] (:func:`hammerstein.scenario.execute.starts_as_hardware`);
        set when it has run.
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
    sweep: dict | None = None
    where: str = ""
    identified: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    start_fade: int | None = None


@dataclass
class ScenarioSpec:
    """A validated scenario of kind ``"cases"`` (nothing built or identified yet).

    Parameters
    ----------
    name, title, description : str
    seed : int
    path : pathlib.Path
    cases : list of CaseSpec
    sweeps : list of hammerstein.scenario.sweeps.SweepSpec
    stability_map : dict or None
        Checked ``[stability_map]`` table
        (:func:`hammerstein.scenario.sweeps.check_stability_table`).
    stability_plant : HammersteinPlant or None
        The top-level plant the stability map is computed on.
    compensator_top : dict
        The top-level ``[compensator]`` table (the stability map's default).
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
    stability_map: dict | None = None
    stability_plant: Any = None
    compensator_top: dict = field(default_factory=dict)
    kind: str = "cases"


def read_scenario(path):
    """Parse a scenario file: ``(path, data)``; raises ScenarioError for unreadable TOML.

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.

    Returns
    -------
    (pathlib.Path, dict)
        The path and the parsed TOML document.

    Raises
    ------
    ScenarioError
        If the file is missing, unreadable, not UTF-8 or not valid TOML
        (one problem line, from :func:`hammerstein.io.presets.read_toml`).
    """
    path = Path(path)
    try:
        return path, read_toml(path, "scenario file")
    except PresetError as exc:
        raise ScenarioError([str(exc)]) from None


def _ignored_env(var):
    """``"; its value 'abc' is not a positive integer, the default applies"`` for a bad override, else ``""``."""
    text = os.environ.get(var)
    if text is None or (text.strip().isascii() and text.strip().isdigit() and int(text) > 0):
        return ""
    return f"; its value {text!r} is not a positive integer, the default applies"


def _predicted_samples(entry, c, T):
    """Samples the signal of a checked table ``c`` will have (before generating it)."""
    if "duration" in c:
        return c["duration"] / T
    period = entry.period_of(c)
    if c.get("periods") is None or period is None:
        return 0.0  # e.g. a file reference: as long as its file (bounded in bytes)
    return c["periods"] * period / T


def _signal(case_where, mode, spec, plant, problems, source, base=None, budget=None,
            case_limit=MAX_CASE_SAMPLES):
    """Generate the drive/reference; returns (time, signal, period_samples, extras).

    ``budget``: ``{"limit", "used", "over"}`` samples per scenario; a signal
    beyond it is reported once (later ones are then not generated).
    ``case_limit``: samples of a scenario case (None: a hardware command's
    reference, bounded as any record, ``HAMMERSTEIN_MAX_RECORD_SAMPLES``).
    """
    kinds = refs.DRIVE_KINDS if mode == "drive" else refs.REFERENCE_KINDS
    where = f"{case_where}.{mode}"
    if not isinstance(spec, dict):
        problems.append(f"{source}: {where}: expected a table, found {spec!r}")
        return None
    kind = spec.get("kind")
    if not known_kind(kind, kinds):
        problems += [f"{source}: {where}.kind: {msg}" for msg in kind_problem(kind, kinds)]
        return None
    n_before = len(problems)
    entry = kinds[kind]
    fields = entry.fields
    if plant is None and "output" in fields and "output" not in spec:
        # the plant did not load (said with it): a one-output plant needs no output, which
        # was told "output: missing (required)" of such a file
        fields = {**fields, "output": Field(fields["output"].check)}
    clean = check_table(spec, {"kind": Field(lambda v: v), **fields}, where, problems, source)
    if clean is not None and len(problems) > n_before and plant is not None:
        # the signal cannot be generated, but its axes are still named against the plant's
        problems.extend(f"{source}: {where}.{msg}" for msg in _axis_problems(clean, plant, mode))
    if clean is None or len(problems) > n_before or plant is None:
        return None
    T = plant.sampling_period
    model = plant.hysteresis
    names = list(model.input_names if mode == "drive" else model.output_names)
    c = {k: v for k, v in clean.items() if k != "kind"}
    n = _predicted_samples(entry, c, T)
    if case_limit is not None and case_limit < n <= refs.MAX_SAMPLES:   # beyond: the generator's
        problems.append(f"{source}: {where}: the record would have {n:.3g} samples; expected at "
                        f"most {case_limit:.3g} per case ({case_limit * T:g} s at "
                        f"T = {T:g} s)")
        return None
    if budget is not None and n <= refs.MAX_SAMPLES:
        if budget["over"]:
            return None
        if budget["used"] + n > budget["limit"]:
            budget["over"] = True
            problems.append(f"{source}: {where}: its {n:.3g} samples bring the scenario to "
                            f"{budget['used'] + n:.3g}; expected at most {budget['limit']:.3g} "
                            f"samples per scenario (shorten the records, or raise "
                            f"HAMMERSTEIN_MAX_SAMPLES{_ignored_env('HAMMERSTEIN_MAX_SAMPLES')})")
            return None
    try:
        t, sig, period, extras = entry.generate(c, T, names, base)
    except refs.SignalError as exc:
        problems.append(f"{source}: {where}.{exc}")
        problems.extend(f"{source}: {where}.{msg}" for msg in
                        _beside_axis(entry, clean, str(exc), T, names, base))
        return None
    problem = _magnitude_problem(c, sig, "µm" if mode == "reference" else "V")
    if problem:     # the simulation refuses it (hammerstein.simulation._packing)
        problems.append(f"{source}: {where}{problem}")
        return None
    return t, sig, max(int(round(period / T)), 1), extras


#: Keys of a signal table that name the plant's outputs (inputs) it is on.
_AXIS_KEYS = ("output", "input", "outputs")


def _beside_axis(entry, clean, said, T, names, base):
    """What a signal whose output (input) the plant lacks would still be told.

    ``said``: the generator's problem. When it names an axis key the plant does
    not hold (``output: expected one of ['x', 'y'], found 'z'``), the signal is
    generated again on the plant's first output(s) instead: a frequency at or
    above Nyquist does not depend on the output. Returns the ``key: message``
    of that second try, if it names another key; else nothing.
    """
    key = said.split(":", 1)[0]
    if key not in _AXIS_KEYS or key not in clean or not names:
        return []
    stand_in = {k: v for k, v in clean.items() if k != "kind"}
    stand_in[key] = [str(n) for n in names[:2]] if key == "outputs" else str(names[0])
    try:
        entry.generate(stand_in, T, names, base)
    except refs.SignalError as exc:
        if str(exc).split(":", 1)[0] != key:
            return [str(exc)]
    return []


def _axis_problems(clean, plant, mode):
    """``key: message`` for each output (input) named in a checked signal table that the plant lacks."""
    model = plant.hysteresis
    names = [str(n) for n in (model.input_names if mode == "drive" else model.output_names)]
    out = []
    for key in ("output", "input"):
        if isinstance(clean.get(key), str) and clean[key] not in names:
            out.append(f"{key}: expected one of {names}, found {clean[key]!r}")
    outs = clean.get("outputs")
    if isinstance(outs, list) and any(o not in names for o in outs):
        out.append(f"outputs: expected outputs of the plant {names}, found {outs}")
    return out


def _written_at(line, source, where, places):
    """``line`` about a key of the compensator table of case ``where`` named where the key is
    written (``places``: key -> ``sweeps[0].compensators.<label>``; None: a case's own table).

    ``<where>.compensator.<key>...: message`` and ``<where>.compensator: <key>...: message``
    (a model's problem, :func:`_model_problems`) move to ``<place>.<key>...: message``; a
    model file's own message to ``<place>.model: message``; any other line is kept.
    """
    head = f"{source}: {where}.compensator"
    if not places or not line.startswith(head):
        return line
    rest = line[len(head):]
    if rest.startswith("."):
        key = re.split(r"[.:\[]", rest[1:], maxsplit=1)[0]
        return f"{source}: {places[key]}{rest}" if key in places else line
    if rest.startswith(": "):
        msg = rest[2:]
        key = re.split(r"[.:\[]", msg, maxsplit=1)[0]
        if key in places:
            return f"{source}: {places[key]}.{msg}"
        if "model" in places:
            return f"{source}: {places['model']}.model: {msg}"
    return line


def _placed(lines, source, where, places, problems):
    """``lines`` of the compensator table of case ``where`` as :func:`_written_at` names them;
    a sweep case's (``places`` given) less those already in ``problems`` (said once)."""
    if not places:
        return list(lines)
    out = []
    for line in (_written_at(q, source, where, places) for q in lines):
        if line not in problems and line not in out:
            out.append(line)
    return out


def _said_at_top(line, own, where, source, problems):
    """True when ``line`` is about a key the case inherits and was said, in the same
    words, of the top-level compensator table."""
    head = f"{source}: {where}.compensator."
    if not line.startswith(head):
        return False
    key = line[len(head):].split(":", 1)[0].split(".", 1)[0]
    return key not in own and f"{source}: compensator.{line[len(head):]}" in problems


def _fade_problems(fade, feedback, plant, settle, P, n, where):
    """A case's ``compensator.fade_in`` [s] against its record of ``n`` samples.

    On a plant whose drives start at rest (:func:`hardware_start`) the metrics skip the
    fade-in, so something must remain after it; the feedback route measures from the
    ``settle`` settling periods of ``P`` samples on, whatever the plant. Returns the
    problems, each prefixed by ``where``.
    """
    if fade is None or not hardware_start(plant):
        return []
    T = plant.sampling_period
    if feedback and fade > settle * P * T + 1e-12:
        return [f"{where}.compensator.fade_in: {fade:g} s is longer than the {settle:g} "
                f"settling periods ({settle * P * T:g} s) the metrics skip"]
    if not feedback and fade >= n * T - 1e-12:
        return [f"{where}.compensator.fade_in: {fade:g} s leaves nothing of the {n * T:g} s "
                f"record to measure; expected less than {n * T:g} s"]
    return []


def _one_output(spec, plant):
    """A reference table with ``output`` filled in on a plant with one output (nothing to choose)."""
    names = list(plant.hysteresis.output_names) if plant is not None else []
    kind = spec.get("kind") if isinstance(spec, dict) else None
    entry = refs.REFERENCE_KINDS.get(kind) if isinstance(kind, str) else None
    if len(names) == 1 and entry is not None and "output" in entry.fields and "output" not in spec:
        return {**spec, "output": str(names[0])}
    return spec


def _magnitude_problem(spec, signal, unit):
    """``".key: ... beyond the limit 1e+150"`` for a signal the simulation would refuse, else ``""``.

    The key is the table's first value beyond :data:`MAX_MAGNITUDE` (e.g.
    ``radius``); a signal beyond it from values each within (an offset plus
    an amplitude) is named by its peak.
    """
    if not signal.size or np.max(np.abs(signal)) <= MAX_MAGNITUDE:
        return ""
    for key, value in spec.items():
        for v in (value if isinstance(value, list) else [value]):
            if is_number(v) and abs(v) > MAX_MAGNITUDE:
                return f".{key}: {v:g} {unit} is beyond the limit {MAX_MAGNITUDE:.0e}"
    return (f": its peak {np.max(np.abs(signal)):.3g} {unit} is beyond the limit "
            f"{MAX_MAGNITUDE:.0e}")


def _model_problems(name, identify, plant, base, files):
    """Problems of a ``model`` key that need no identification and no compensator.

    ``"identified"``: the ``identify`` table is present and its frequency below
    Nyquist; a file name: the model file reads (``files`` caches path ->
    message or None). Returns ``key: message`` strings.
    """
    if name in (None, "plant"):
        return []
    if name == "identified":
        if identify is None:
            return ["identify: missing (required with model = 'identified'), "
                    "e.g. identify = { frequency = 50.0 }"]
        if identify.get("records") == "files":      # measured records: the files are there
            return record_file_problems(identify, base, plant)
        problem = nyquist_problem(identify, plant)
        if problem is None and plant is not None:
            n = identify.get("periods", 3) / identify["frequency"] / plant.sampling_period
            if n > MAX_CASE_SAMPLES:
                problem = (f"identify.frequency: {identify['frequency']:g} Hz for "
                           f"{identify.get('periods', 3)} periods would record {n:.3g} samples "
                           f"per input; expected at most {MAX_CASE_SAMPLES:.3g}")
        return [problem] if problem else []
    try:
        path = confined_path(name, base, PresetError)
    except PresetError as exc:
        return [str(exc)]
    if path not in files:
        try:
            files[path] = load_model(path)
        except PresetError as exc:
            files[path] = str(exc)
    if isinstance(files[path], str):
        return [files[path]]
    model, pm = files[path], getattr(plant, "hysteresis", None)
    if pm is not None and (model.n_inputs, model.n_outputs) != (pm.n_inputs, pm.n_outputs):
        return [f"{name}: the model has {model.n_inputs} input(s) {list(model.input_names)} and "
                f"{model.n_outputs} output(s) {list(model.output_names)}; the plant has "
                f"{pm.n_inputs} {list(pm.input_names)} and {pm.n_outputs} {list(pm.output_names)}"]
    return []


def _top_model_problems(comp, plant, base, files):
    """Problems of the top-level ``[compensator]``'s ``model`` and ``identify`` keys.

    Checked once, named where they are written (``compensator.identify.<key>``),
    whatever the cases: a missing record file is not a problem of the first
    case that reaches it. A misspelt kind is checked as the kind it spells;
    an ``identify`` table with problems of its own still has its record
    files looked for, and their columns read (:func:`record_keys`). Returns
    ``(lines, raw)``: the ``compensator...: message`` lines and the
    :func:`_model_problems` messages they came from (a case that inherits the
    table skips those).
    """
    kind = comp.get("kind", "none")
    kind = kind if known_kind(kind, COMPENSATORS) else meant_kind(kind)
    name = comp.get("model", "plant")
    if kind is None or "model" not in COMPENSATORS[kind].fields or not isinstance(name, str):
        return [], []
    identify = comp.get("identify")
    if name == "identified" and identify is not None:
        try:
            identify = COMPENSATORS[kind].fields["identify"].check(identify)
        except Invalid:     # reported by the table's check; its files are still looked for
            if not (isinstance(identify, dict) and identify.get("records") == "files"):
                return [], []
            # and their columns, unless the keys that name them are wrong
            kept, known = record_keys(identify)
            return _placed_top(record_file_problems(kept, base, plant if known else None))
    if plant is None and name == "identified" and isinstance(identify, dict) \
            and identify.get("records") != "files":
        return [], []       # its frequency is checked against the plant's Nyquist: none loaded
    return _placed_top(_model_problems(name, identify, plant, base, files))


def _placed_top(msgs):
    lines = [f"compensator.{m}" if m.startswith("identify") else f"compensator.model: {m}"
             for m in msgs]
    return lines, msgs


def _plausibility(mode, signal, spec):
    """Warnings on a case's signal beyond a piezoelectric actuator's plausible range (a unit slip)."""
    unit = "µm" if mode == "reference" else "V"
    found = []
    if signal.size:
        problem = plausibility_problem(np.max(np.abs(signal)), unit, f"{mode} peak")
        if problem:
            found.append(f"{mode}: {problem}")
    f = spec.get("frequency") if isinstance(spec, dict) else None
    for v in (f if isinstance(f, list) else [f]):
        problem = plausibility_problem(v, "Hz", "frequency") if is_number(v) else None
        if problem:
            found.append(f"{mode}.frequency: {problem}")
    return found


def _check_map_compensators(smap, plant, base, files, problems, source):
    """Check the ``[stability_map.compensators]`` tables as a case's compensator is checked."""
    for label, spec in (smap.get("compensators") or {}).items():
        where, n_before = f"stability_map.compensators.{label}", len(problems)
        clean = check_compensator(spec, where, problems, source)
        if clean is None or len(problems) > n_before or "model" not in COMPENSATORS[clean.get("kind", "none")].fields:
            continue
        more = _model_problems(clean.get("model", "plant"), clean.get("identify"), plant, base, files)
        problems.extend(f"{source}: {where}: {msg}" for msg in more)


def _validate_cases(path, data, feedback=False):
    """Validate a scenario of kind ``"cases"``; ScenarioSpec or ScenarioError.

    ``feedback``: the cases of a feedback scenario, where a reference may run
    without a feedforward (``kind = "none"``: the loop alone).
    """
    source, base, problems = str(path), path.parent, []
    top = check_table(data, TOP, "", problems, source) or {}
    if "name" not in data and not (re.fullmatch(NAME, path.stem) and len(path.stem) <= MAX_NAME):
        problems.append(f"{source}: name: missing, and the file name {path.stem[:MAX_NAME]!r} is not "
                        f"usable as the report directory name (at most {MAX_NAME} letters, digits, "
                        f"'.', '_' or '-', starting with a letter or digit); give name = \"...\"")
    plant_top = data.get("plant", {}) if isinstance(data.get("plant", {}), dict) else {}
    comp_top = data.get("compensator", {}) if isinstance(data.get("compensator", {}), dict) else {}
    if "plant" in data:
        check_table(data["plant"], PLANT, "plant", problems, source)
    if "compensator" in data:
        if isinstance(data["compensator"], dict):      # comp_top is {} for anything else
            check_compensator(comp_top, "compensator", problems, source)
        else:    # compensator = "multivariable" ran as kind 'none' without a word
            problems.append(f"{source}: compensator: expected a table, e.g. [compensator] "
                            f"kind = \"multivariable\", found {short_repr(data['compensator'])}")
    cases_raw = data.get("cases", [])
    if "cases" in data and (not isinstance(cases_raw, list) or not cases_raw):
        problems.append(f"{source}: cases: expected one or more [[cases]] tables")
        cases_raw = []
    if "cases" not in data and "sweeps" not in data:
        problems.append(f"{source}: cases: missing (required)")
    entries, sweep_specs = [(f"cases[{i}]", raw) for i, raw in enumerate(cases_raw)], []
    places = {}             # a sweep case's compensator keys -> where they are written
    if "sweeps" in data:
        more, sweep_specs = expand_sweeps(data["sweeps"], source, problems, places)
        entries += more
    plants, cases, names, model_files = {}, [], set(), {}
    if len(entries) > MAX_CASES:
        problems.append(f"{source}: cases: {len(entries)} cases (sweeps expanded); expected at "
                        f"most {MAX_CASES}")
        entries = []
    budget = {"limit": total_samples_budget(), "used": 0, "over": False}
    if not entries and isinstance(plant_top.get("preset"), str):
        try:        # no case loads it below: its problems are still reported with the others
            load_plant(plant_top["preset"], dynamics=bool(plant_top.get("dynamics", True)),
                       base_dir=base)
        except PresetError as exc:
            problems.append(f"{source}: plant.preset: {exc}")

    def once(line):  # a problem of a top-level table, found per case, is listed once
        if line not in problems:
            problems.append(line)

    def plant_of(preset, dynamics):
        key = (preset, bool(dynamics))
        if key not in plants:
            plants[key] = load_plant(preset, dynamics=bool(dynamics), base_dir=base)
        return plants[key]

    top_model = [], []      # the top-level compensator's model: checked once, named there
    class_said = set()      # (kind, model, problem) of _class_problems already reported
    if isinstance(comp_top, dict) and "model" in comp_top:
        top_plant = None
        if isinstance(plant_top.get("preset"), str):
            try:
                top_plant = plant_of(plant_top["preset"], plant_top.get("dynamics", True))
            except PresetError:
                pass        # reported with the plant table
        top_model = _top_model_problems(comp_top, top_plant, base, model_files)
        problems.extend(f"{source}: {line}" for line in top_model[0])

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
            try:
                plant = plant_of(pspec["preset"], pspec.get("dynamics", True))
            except PresetError as exc:
                plants[(pspec["preset"], bool(pspec.get("dynamics", True)))] = None
                key = f"{where}.plant" if isinstance(pover, dict) and "preset" in pover else "plant"
                problems.append(f"{source}: {key}.preset: {exc}")
            if plant is not None and pspec.get("dynamics") is True and plant.is_static:
                key = f"{where}.plant" if "dynamics" in plant_clean else "plant"
                once(f"{source}: {key}.dynamics: true, but the preset {pspec['preset']!r} has no "
                     f"[dynamics] (or kind = 'none'); set dynamics = false for its static plant")
        # compensator: merge and check
        cover = raw.get("compensator", {})
        cspec = merge_compensator(comp_top, cover if isinstance(cover, dict) else {})
        scratch = []
        cclean = check_compensator(cspec, f"{where}.compensator", scratch, source,
                                    own=cover if isinstance(cover, dict) else {})
        spot = places.get(where)        # a sweep case's table: named where written, once
        if "compensator" in raw:
            if isinstance(cover, dict):
                # top-level problems are reported once, above: an inherited key's message
                # said there word for word is not repeated under every case with a table
                shown = [q for q in scratch if not _said_at_top(q, cover, where, source, problems)]
                scratch = [_written_at(q, source, where, spot) for q in scratch]
                problems.extend(_placed(shown, source, where, spot, problems))
            else:
                problems.append(f"{source}: {where}.compensator: expected a table")
        elif scratch and not any("compensator" in q for q in problems[:n_before]):
            problems.extend(scratch)
        comp_ok = not scratch and cclean is not None
        if comp_ok and plant is not None and cclean.get("feedback") == "lowpass":
            nyquist = 0.5 / plant.sampling_period
            if cclean["cutoff_hz"] >= nyquist:
                key = f"{where}.compensator" if "cutoff_hz" in cover else "compensator"
                key = (spot or {}).get("cutoff_hz", key)
                once(f"{source}: {key}.cutoff_hz: expected 0 < cutoff_hz < {nyquist:g} Hz (the "
                     f"plant's Nyquist frequency), found {cclean['cutoff_hz']:g}")
                comp_ok = False
        sig_spec = _one_output(raw[mode], plant) if mode == "reference" else raw[mode]
        sig = _signal(where, mode, sig_spec, plant, problems, source, base, budget)
        kind = cspec.get("kind", "none")
        if (mode == "reference" and known_kind(kind, COMPENSATORS) and not COMPENSATORS[kind].compensates
                and not feedback):
            problems.append(f"{source}: {where}.reference: a reference needs a compensator "
                            f"(compensator.kind is {kind!r}); use drive for an open-loop run")
        if sig is None or any(q not in scratch for q in problems[n_before:]):
            continue
        t, signal, P, extras = sig
        budget["used"] += t.size
        settle = case.get("settle_periods", 1.0)
        need = settle * P + (P if (mode == "drive" or "loop_channel" in extras) else 1)
        if t.size < need:   # the case's own, said also when the compensator table has a problem
            problems.append(f"{source}: {where}.settle_periods: {settle:g} periods of settling "
                            f"leave less than {'one period' if need - settle * P > 1 else 'one sample'} "
                            f"of the {t.size}-sample record; lengthen it or settle less")
            continue
        if mode == "reference" and not comp_ok:
            # the kind's own checks of the keys that are right: every problem said at once;
            # a model that cannot be read leaves the keys whose defaults follow it unjudged
            wrong = []
            if (cclean is not None and known_kind(kind, COMPENSATORS)
                    and "model" in COMPENSATORS[kind].fields and "model" in cclean
                    and not {"model", "identify"} - set(cclean) & set(cspec)):
                wrong = _model_problems(cclean["model"], cclean.get("identify"), plant, base,
                                        model_files)
                if not ({"model", "identify"} & set(cover if isinstance(cover, dict) else {})):
                    wrong = [m for m in wrong if m not in top_model[1]]   # said at the top
                problems.extend(_placed([f"{source}: {where}.compensator: {msg}" for msg in wrong],
                                        source, where, spot, problems))
            if not wrong:
                problems.extend(f"{source}: {where}.compensator.{msg}" for msg in
                                clean_keys_problems(cspec, cclean, plant, base, model_files,
                                                    settle, P))
            fade = cspec.get("fade_in")     # a right fade_in judged beside the wrong keys
            fade_said = any(".fade_in:" in q for q in problems[n_before:]) or (
                "fade_in" not in (cover if isinstance(cover, dict) else {})
                and any(q.startswith(f"{source}: compensator.fade_in:") for q in problems))
            if not fade_said and isinstance(fade, (int, float)) \
                    and not isinstance(fade, bool) and np.isfinite(fade) and fade >= 0:
                problems.extend(_fade_problems(float(fade), feedback, plant, settle, P, t.size,
                                               f"{source}: {where}"))
            continue
        if len(problems) > n_before:
            continue
        cmp_spec = None
        if "model" in raw or "identify" in raw:
            try:
                cmp_spec = comparison_spec(raw, mode)
            except ValueError as exc:  # one "key: message" per line
                problems.extend(f"{source}: {where}.{line}" for line in str(exc).splitlines())
                continue
        model_wrong = False
        if mode == "reference" and "model" in COMPENSATORS[kind].fields:
            more = _model_problems(cclean.get("model", "plant"), cclean.get("identify"), plant, base,
                                   model_files)
            model_wrong = bool(more)
            if not more:     # the class registry: a kind the model's class does not take
                cls = class_problems(cclean.get("model", "plant"), kind, plant, base,
                                      model_files, cclean.get("identify"))
                said = (kind, str(cclean.get("model", "plant")), tuple(cls))
                if cls and said in class_said:
                    cls = []            # one mistake, said once: where it first appears
                class_said.add(said)
                more = cls
            own = cover if isinstance(cover, dict) else {}
            if not ({"model", "identify"} & set(own)) and cspec.get("kind") == comp_top.get("kind"):
                more = [m for m in more if m not in top_model[1]]  # reported at the top, once
            problems.extend(_placed([f"{source}: {where}.compensator: {msg}" for msg in more],
                                    source, where, spot, problems))
        if cclean is not None:      # a model file's dynamics and creep, as compensate takes them
            cclean = model_file_dynamics(cclean, base)
        if mode == "reference" and COMPENSATORS[kind].check is not None:   # the kind's own checks
            more = COMPENSATORS[kind].check(cclean, plant, base, model_files, settle, P)
            if model_wrong and "dynamics" not in cspec:     # its default follows the model
                more = [m for m in more if not m.startswith(("dynamics", "identify_dynamics"))]
            problems.extend(f"{source}: {where}.compensator.{msg}" for msg in more)
        if mode == "reference":
            problems.extend(_fade_problems((cclean or {}).get("fade_in"), feedback, plant,
                                           settle, P, t.size, f"{source}: {where}"))
        if cmp_spec is not None:
            more = _model_problems(cmp_spec["model"], cmp_spec.get("identify"), plant, base,
                                   model_files)
            problems.extend(f"{source}: {where}.model: {msg}" for msg in more)
        if len(problems) > n_before:
            continue
        cases.append(CaseSpec(
            name=case["name"], description=case.get("description", ""), mode=mode,
            signal_spec=dict(sig_spec), plant_spec=pspec,
            compensator_spec=cclean if cclean is not None else cspec,
            plant=plant, compensator=None, time=t, signal=signal, period_samples=P,
            settle_periods=settle, model_spec=cmp_spec, where=where, **extras))
        cases[-1].warnings.extend(_plausibility(mode, signal, sig_spec))
    smap, smap_plant = None, None
    if "stability_map" in data and isinstance(plant_top.get("preset"), str):
        try:
            smap_plant = plant_of(plant_top["preset"], plant_top.get("dynamics", True))
        except PresetError:
            smap_plant = None  # reported with the plant table
        smap = check_stability_table(data["stability_map"], problems, source)
        if smap is not None:
            _check_map_compensators(smap, smap_plant, base, model_files, problems, source)
    if problems:
        raise ScenarioError(problems)
    info = {c["case"]: {"sweep": sp.name, **c} for sp in sweep_specs for c in sp.cases}
    for c in cases:
        c.sweep = info.get(c.name)
    return ScenarioSpec(name=top.get("name", path.stem), title=top.get("title", path.stem),
                        description=top.get("description", ""), seed=top.get("seed", 0),
                        path=path, cases=cases, sweeps=sweep_specs, stability_map=smap,
                        stability_plant=smap_plant, compensator_top=comp_top)


#: Validators of the top-level ``kind`` of a scenario file: ``(path, data) -> spec``
#: (``data`` the parsed TOML), raising ScenarioError with every problem. A new
#: kind also needs an entry in :data:`hammerstein.runner.SCENARIO_KINDS`.
VALIDATORS: dict[str, Callable] = {
    "cases": _validate_cases,
    "identification": load_identification_scenario,
    "monte-carlo": validate_montecarlo,
    "feedback": lambda path, data: validate_feedback(
        path, data, lambda p, d: _validate_cases(p, d, feedback=True)),
}


def validate_scenario(path):
    """Validate a scenario file (step 1 of 2; nothing is built or simulated).

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.

    Returns
    -------
    ScenarioSpec or hammerstein.scenario.records.RecordScenario
        The validated scenario: cases with their plants and signals, but no
        compensator and no identified or loaded model yet
        (:func:`hammerstein.scenario.resolve.resolve_scenario` builds them).

    Raises
    ------
    ScenarioError
        Listing every problem found, one ``file: key: message`` per line.

    Examples
    --------
    >>> from hammerstein.scenario.validate import validate_scenario
    >>> spec = validate_scenario("scenarios/default.toml")  # doctest: +SKIP
    >>> spec.cases[0].compensator is None                    # doctest: +SKIP
    True
    """
    path, data = read_scenario(path)
    kind = data.get("kind", "cases")
    if kind == "cases" and is_montecarlo(data):   # [[sweeps]] kind = "monte-carlo"
        kind = "monte-carlo"
    if not known_kind(kind, VALIDATORS):
        raise ScenarioError([f"{path}: kind: {msg}" for msg in kind_problem(kind, VALIDATORS)])
    return VALIDATORS[kind](path, data)
