"""Frequency sweeps in scenarios: expansion, batched simulation, stability maps.

A ``[[sweeps]]`` table is a case template without ``frequency`` plus a list
of ``frequencies`` [Hz] (and optionally several compensators side by side)::

    [[sweeps]]
    name = "rms"
    frequencies = [10.0, 50.0, 100.0, 200.0, 420.0]
    reference = { kind = "sine", output = ["x", "y"], amplitude = 50.0, periods = 6 }
    settle_periods = 4
    compensators = { mv-50Hz = { kind = "multivariable" }, per-axis = { kind = "per-axis" } }

``parameter = "<key>"`` with ``values = [...]`` (instead of ``frequencies``)
sweeps any other numeric key of the template (an amplitude, a radius, a
Lissajous figure's ``frequencies`` pair, a raster's ``lines``): cases
``<sweep>-...-<key>-<value>``, the metric drawn against the value (the first
of a pair).

A reference whose kind has two frequencies (``lissajous``: ``frequencies = [f_x,
f_y]`` in the template) is swept by scaling both: each swept f sets f_x = f and
keeps the ratio f_y / f_x, so the figure keeps its shape.

It expands (:func:`expand_sweeps`) into ordinary cases named
``<sweep>-<label>-<axis>-<f>Hz`` (``-<label>`` only with ``compensators``,
``-<axis>`` only when ``output``/``input`` is a list), so ``metrics.csv``
keeps its long format. Sweep cases write no time series and no per-case
figure; each sweep writes ``sweep-<name>.csv`` (wide: ``frequency_hz,
compensator, axis, channel`` then one column per metric) and
``sweep-<name>.png``, the metric (default ``rms_error``) against frequency
in the p x m layout of the paper's Fig. 9: panel (l, k) is output l for the
excitation on axis k ((a) direct x, (b) cross-coupling y_r -> x, (c)
cross-coupling x_r -> y, (d) direct y).

:func:`run_cases` simulates the cases of a scenario: inverse multiplicative
compensators and Hammerstein compensators of sweep cases in batches on the
compiled batch kernel (:func:`hammerstein.simulation.simulate_chain_batch`,
both cores; per-case initial states carry the Hammerstein compensator's
fade-in and preview), the others case by case, with a progress bar on a terminal
(:func:`hammerstein.scenario.progress.progress`, quiet off-terminal).

A top-level ``[stability_map]`` table (``scales`` = list of gain scalings s,
or ``{ start, stop, num }`` log-spaced; optional ``compensators`` as above,
default the scenario's ``[compensator]``) writes ``stability-map.csv`` and
``stability-map.png``: the largest ``rho(I - (s K)^-1 J)`` against s
(:func:`hammerstein.compensation.stability.stability_map`, docs/compensator.md), with the
normalised law (s = 1) and the paper's literal law (K = I) marked.
"""

from __future__ import annotations

import copy
import functools
import re
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hammerstein.compensation.reference_range import check_reference_range
from hammerstein.signals.references import DRIVE_KINDS, REFERENCE_KINDS
from hammerstein.exceptions import HammersteinError
from hammerstein.compensation.stability import stability_map
from hammerstein.scenario.execute import chain_result, fade_samples, run_case, runs_alone
from hammerstein.scenario.progress import progress
from hammerstein.scenario.registry import COMPENSATORS, build_compensator, compensator_kind
from hammerstein.signals.metrics import UNITS
from hammerstein.scenario.schema import (CASE, MAX_NAME, MAX_SWEEP_FREQUENCIES, NAME, Field, Invalid,
                                         short_repr, check_table, choice, name_field, number, string)
from hammerstein.simulation import is_fusable, simulate_chain_batch

__all__ = [
    "SweepSpec",
    "expand_sweeps",
    "run_cases",
    "run_scenario_cases",
    "check_stability_table",
    "stability_map_frame",
    "BATCH_SIZE",
]

#: Sweep cases per call of the batch kernel (the progress bar moves per batch).
BATCH_SIZE = 64


@dataclass
class SweepSpec:
    """A validated ``[[sweeps]]`` table.

    Parameters
    ----------
    name : str
    mode : {'reference', 'drive'}
    frequencies : list of float
        [Hz], in the given order.
    labels : list of str or None
        Compensator labels (``[None]`` without ``compensators``).
    axes : list of str or None
        Excited outputs (references) or inputs (drives); ``[None]`` when the
        template leaves it to the signal kind (circles, Lissajous...).
    metric : str
        Metric plotted against frequency.
    description : str
        The sweep's ``description`` key (empty when absent).
    cases : list of dict
        ``{case, compensator, axis, frequency_hz}`` per expanded case
        (``frequency_hz`` holds the swept value of a ``parameter`` sweep).
    parameter : str
        The swept key of the signal template: ``"frequency"`` for a
        ``frequencies`` sweep, else the sweep's ``parameter``; then
        ``frequencies`` holds its ``values`` (the first of a pair).
    """

    name: str
    mode: str
    frequencies: list
    labels: list
    axes: list
    metric: str = "rms_error"
    description: str = ""
    cases: list = field(default_factory=list)
    parameter: str = "frequency"


def _frequencies(v):
    if (isinstance(v, list) and v and all(isinstance(f, (int, float)) and not isinstance(f, bool)
                                          and np.isfinite(f) and f > 0 for f in v)):
        if len(v) > MAX_SWEEP_FREQUENCIES:
            raise Invalid(f"expected at most {MAX_SWEEP_FREQUENCIES} frequencies, found {len(v)}")
        if len(set(v)) != len(v):
            raise Invalid(f"expected distinct frequencies [Hz], found duplicates in {v!r}")
        return [float(f) for f in v]
    raise Invalid(f"expected a non-empty list of positive frequencies [Hz], found {short_repr(v)}")


def _values(v):
    def ok(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
    if (isinstance(v, list) and v and all(ok(x) or (isinstance(x, list) and x and all(map(ok, x)))
                                          for x in v)):
        if len(v) > MAX_SWEEP_FREQUENCIES:
            raise Invalid(f"expected at most {MAX_SWEEP_FREQUENCIES} values, found {len(v)}")
        if len({repr(x) for x in v}) != len(v):
            raise Invalid(f"expected distinct values, found duplicates in {short_repr(v)}")
        return v
    raise Invalid(f"expected a non-empty list of numbers (or of lists of numbers, for a key "
                  f"such as frequencies = [f_x, f_y]), found {short_repr(v)}")


#: Keys of a signal template that a parameter sweep may not vary (not numbers).
_NOT_SWEPT = {"kind", "output", "outputs", "input", "file", "columns", "time", "slow"}


def _labelled_tables(v):
    if not isinstance(v, dict) or not v:
        raise Invalid(f"expected a table of label = {{ kind = ... }} compensator tables, found {v!r}")
    for label, table in v.items():
        if not re.fullmatch(NAME, label) or len(label) > MAX_NAME:
            raise Invalid(f"label {short_repr(label)}: expected at most {MAX_NAME} letters, digits, "
                          f"'.', '_' or '-'")
        if not isinstance(table, dict):
            raise Invalid(f"{label}: expected a compensator table, found {table!r}")
    return v


_OWN = {
    "name": Field(name_field(), required=True),
    "description": Field(string()),
    "frequencies": Field(_frequencies),
    "parameter": Field(string()),            # another numeric key of the template ...
    "values": Field(_values),                # ... and its values
    "compensators": Field(_labelled_tables),
    "metric": Field(choice(*UNITS), default="rms_error"),  # a metric the cases compute
}


#: Keys of a sweep whose problems leave its cases to expand (and be checked).
_NOT_EXPANDED = ("metric", "description")


def _fmt(f):
    return f"{f:g}"


def expand_sweeps(sweeps, source, problems, places=None):
    """Expand ``[[sweeps]]`` tables into raw case tables.

    Parameters
    ----------
    sweeps : object
        The parsed ``sweeps`` value (a list of tables).
    source : str
        File name, for the problem lines.
    problems : list of str
        Receives ``source: sweeps[i].key: message`` lines.
    places : dict, optional
        Receives, per expanded case's ``where``, ``{key: where it is written}``
        for the keys of its compensator table (``sweeps[i].compensators.<label>``
        or the template's ``sweeps[i].compensator``): a problem of the table is
        named there once, not once per case.

    Returns
    -------
    entries : list of (str, dict)
        ``(where, raw case table)`` for the scenario loader; ``where`` reads
        ``sweeps[i](<case name>)``.
    specs : list of SweepSpec
    """
    if not isinstance(sweeps, list) or not all(isinstance(s, dict) for s in sweeps):
        problems.append(f"{source}: sweeps: expected one or more [[sweeps]] tables")
        return [], []
    case_keys = {k: f for k, f in CASE.items() if k != "name"}
    schema = {**case_keys, **_OWN}
    entries, specs, seen = [], [], {}
    for i, raw in enumerate(sweeps):
        where = f"sweeps[{i}]"
        n0 = len(problems)
        clean = check_table(raw, schema, where, problems, source)
        if clean is not None and "name" in clean:
            if clean["name"] in seen:  # each sweep writes sweep-<name>.csv and .png
                problems.append(f"{source}: {where}.name: duplicate sweep name {clean['name']!r} "
                                f"(also sweeps[{seen[clean['name']]}]); give each sweep its own name")
            seen.setdefault(clean["name"], i)
        # a bad metric or description spoils no case: the cases are still expanded and checked
        own = tuple(f"{source}: {where}.{k}:" for k in _NOT_EXPANDED)
        if clean is None or any(not q.startswith(own) for q in problems[n0:]):
            continue
        has_ref, has_drive = "reference" in raw, "drive" in raw
        if has_ref == has_drive:
            problems.append(f"{source}: {where}: expected exactly one of reference (compensated) "
                            f"or drive (open loop) as the case template")
            continue
        mode = "reference" if has_ref else "drive"
        sig = raw[mode]
        if not isinstance(sig, dict):
            problems.append(f"{source}: {where}.{mode}: expected a table, found {sig!r}")
            continue
        freqs = clean.get("frequencies")
        parameter = clean.get("parameter")
        if (parameter is None) != (clean.get("values") is None):
            problems.append(f"{source}: {where}: expected parameter = \"<key>\" and values = "
                            f"[...] together")
            continue
        if parameter is not None:
            kind = (REFERENCE_KINDS if mode == "reference" else DRIVE_KINDS).get(_kind_key(sig))
            keys = sorted(k for k in (kind.fields if kind is not None else {})
                          if k not in _NOT_SWEPT)
            if freqs is not None:
                problems.append(f"{source}: {where}: expected frequencies = [...] or parameter "
                                f"= ... with values = [...], not both")
                continue
            if kind is not None and parameter not in keys:
                problems.append(f"{source}: {where}.parameter: {short_repr(parameter)} is not a "
                                f"numeric key of a {sig.get('kind')} {mode}; expected one of "
                                f"{', '.join(keys)}")
                continue
            if parameter in sig:
                problems.append(f"{source}: {where}.{mode}.{parameter}: given by the sweep's "
                                f"values; remove it from the template")
                continue
        if freqs is None and parameter is None and not clean.get("compensators"):
            problems.append(f"{source}: {where}: expected frequencies = [...] [Hz], "
                            f"compensators = {{ label = {{...}} }}, or both")
            continue
        scale_pair = False      # a Lissajous-like kind: frequencies = [f_1, f_2] scaled to f_1 = f
        if freqs is not None:
            kind = (REFERENCE_KINDS if mode == "reference" else DRIVE_KINDS).get(_kind_key(sig))
            keys = kind.fields if kind is not None else {"frequency": None}
            if "frequency" in keys:
                if "frequency" in sig:
                    problems.append(f"{source}: {where}.{mode}.frequency: given by the sweep's "
                                    f"frequencies; remove it from the template")
                    continue
            elif "frequencies" in keys:
                pair = sig.get("frequencies")
                if not (isinstance(pair, list) and len(pair) == 2
                        and all(isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0
                                for x in pair)):
                    problems.append(f"{source}: {where}.{mode}.frequencies: expected the figure's "
                                    f"two frequencies [f_1, f_2] [Hz] in the template; each swept "
                                    f"frequency f replaces f_1 and scales f_2 with it (the ratio "
                                    f"f_2/f_1 is kept), found {short_repr(pair)}")
                    continue
                scale_pair = True
            else:
                problems.append(f"{source}: {where}.frequencies: a {sig.get('kind')} {mode} has no "
                                f"frequency to sweep; compare compensators on it with "
                                f"compensators = {{ ... }} and no frequencies")
                continue
        axis_key = "output" if mode == "reference" else "input"
        axes = sig.get(axis_key)
        axes = axes if isinstance(axes, list) and axes else [axes]
        comps = clean.get("compensators")
        labels = list(comps) if comps else [None]
        template = {k: copy.deepcopy(raw[k]) for k in case_keys if k in raw}
        values = clean.get("values")
        first = [v[0] if isinstance(v, list) else v for v in values] if values else None
        spec = SweepSpec(clean["name"], mode, freqs or first or [], labels,
                         axes, clean.get("metric", "rms_error"), clean.get("description", ""),
                         parameter=parameter or "frequency")
        for label in labels:
            for axis in axes:
                for n, f in enumerate(freqs or values or [None]):
                    if values is not None:
                        shown = "x".join(_fmt(x) for x in f) if isinstance(f, list) else _fmt(f)
                        tail = [f"{parameter}-{shown}"]
                    else:
                        tail = [f"{_fmt(f)}Hz"] if f is not None else []
                    parts = [clean["name"]] + ([label] if label else []) + \
                            ([str(axis)] if len(axes) > 1 else []) + tail
                    case = copy.deepcopy(template)
                    case["name"] = "-".join(parts)
                    if values is not None:
                        case[mode] = {**sig, parameter: f}
                    elif f is None:
                        case[mode] = dict(sig)
                    elif scale_pair:
                        f1, f2 = sig["frequencies"]
                        case[mode] = {**sig, "frequencies": [f, f * (f2 / f1)]}
                    else:
                        case[mode] = {**sig, "frequency": f}
                    if axis is not None:
                        case[mode][axis_key] = axis
                    base = case.get("compensator", {})
                    written = ({k: f"{where}.compensator" for k in base}
                               if isinstance(base, dict) else {})
                    if label:  # merged into the template's override like any case override
                        same = comps[label].get("kind", base.get("kind")) == base.get("kind")
                        case["compensator"] = {**base, **comps[label]} if same else dict(comps[label])
                        written = {**(written if same else {}),
                                   **{k: f"{where}.compensators.{label}" for k in comps[label]}}
                    entries.append((f"{where}({case['name']})", case))
                    if places is not None and written:
                        places[entries[-1][0]] = written
                    swept = first[n] if values is not None else f
                    spec.cases.append({"case": case["name"], "compensator": label or "-",
                                       "axis": "-" if axis is None else str(axis),
                                       "frequency_hz": sig.get("frequency", np.nan)
                                       if swept is None else swept})
        specs.append(spec)
    return entries, specs


# -- simulation -------------------------------------------------------------------------
def _batchable(case):
    """True when a sweep case may run in the batch kernel (its inputs are prepared later)."""
    if getattr(case, "sweep", None) is None or case.mode != "reference":
        return False
    kind = compensator_kind(case.compensator_spec)
    if not kind.batchable:
        return False
    if kind.look_ahead:          # fade-in and preview prepared by the compensator's fused_run
        return (getattr(case.plant, "amplifier", None) is None
                and callable(getattr(case.compensator, "fused_run", None)))
    return not runs_alone(case) and is_fusable(case.compensator)


def _prepared(case):
    """``(law or compensator, kernel reference, initial state, warnings, check)`` of a batchable case.

    A look-ahead kind (kind "hammerstein") gets what its ``run_reference``
    feeds the chain kernel (``fused_run``: fade-in, preview, inverse of G at
    rest); None when the compensator has no fused law (the case then runs
    alone). ``check`` is the reference check that
    :func:`hammerstein.scenario.execute.run_case` runs on that reference
    (``simulate_chain``'s ``law.check_reference`` on the lead reference, or
    :func:`check_reference_range` on the signal), left to
    :func:`_check_references`, which runs it for a whole batch at once.
    """
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        if compensator_kind(case.compensator_spec).look_ahead:
            fused = case.compensator.fused_run(case.signal, case.period_samples,
                                               fade_samples(case))
            if fused is None:
                return None
            law, reference, state = fused
            comp, check = law, law.check_reference
        else:
            comp, reference, state = case.compensator, case.signal, None
            check = functools.partial(check_reference_range, case.compensator.model)
    return comp, reference, state, list(case.warnings) + [str(w.message) for w in rec], check


def _prepared_chunk(cases):
    """:func:`_prepared` of a batch's cases: ``{index: prepared or None}``.

    The look-ahead cases of one compensator with ``fused_runs`` (kind
    "hammerstein") get their start-up computed together
    (``HammersteinCompensator.fused_runs``: the same values as ``fused_run``
    case by case, in a few numpy calls for all of them). Should that emit a
    warning, the group is prepared again case by case, so each case's
    warnings are its own, as in the one-by-one run.
    """
    out, groups = {}, {}
    for i, case in cases.items():
        if (compensator_kind(case.compensator_spec).look_ahead
                and callable(getattr(case.compensator, "fused_runs", None))):
            groups.setdefault(id(case.compensator), []).append(i)
        else:
            out[i] = _prepared(case)
    for members in groups.values():
        comp = cases[members[0]].compensator
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            fused = comp.fused_runs([cases[i].signal for i in members],
                                    [cases[i].period_samples for i in members],
                                    [fade_samples(cases[i]) for i in members])
        if rec:
            for i in members:
                out[i] = _prepared(cases[i])
            continue
        for i, f in zip(members, fused):
            out[i] = None if f is None else (f[0], f[1], f[2], list(cases[i].warnings),
                                             f[0].check_reference)
    return out


def _range_model(check):
    """The model of a ``partial(check_reference_range, model)`` check, else None."""
    if (isinstance(check, functools.partial) and check.func is check_reference_range
            and len(check.args) == 1 and not check.keywords):
        return check.args[0]
    return None


def _check_references(prepared):
    """Run the reference checks of a batch's prepared cases, in place (warnings appended).

    The range check (:func:`check_reference_range`) of the cases sharing one
    model runs once on their references side by side, silently: the ratio of
    the concatenation is the largest ratio of the cases (a maximum per output),
    so when it stays within the identified range no case would warn. Only
    when it does not (or the check raises) does each case of that model run
    its own check, exactly as the one-by-one run does (same warnings, same
    errors). Other checks run per case.
    """
    groups = {}
    for i, prep in prepared.items():
        model = _range_model(prep[4])
        if model is None:
            if prep[4] is not None:
                _check_one(prep)
            continue
        groups.setdefault(id(model), (model, []))[1].append(i)
    for model, members in groups.values():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ratio = check_reference_range(
                    model, np.concatenate([prepared[i][1] for i in members], axis=1), warn=False)
            clean = ratio is None or not np.any(ratio > 1 + 1e-9)
        except HammersteinError:     # the per-case checks below raise it for their case
            clean = False
        if not clean:
            for i in members:
                _check_one(prepared[i])


def _check_one(prep):
    """One case's reference check, its warnings appended to the case's list."""
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        prep[4](prep[1])
    prep[3].extend(str(w.message) for w in rec)


def run_cases(cases, desc="cases"):
    """Simulate every case of a scenario; sweep cases batched where possible.

    Sweep cases of a ``batchable`` compensator kind
    (:class:`hammerstein.scenario.registry.CompensatorKind`) run in the batch
    kernel (:func:`hammerstein.simulation.simulate_chain_batch`), each from
    its own initial compensator state: for kind "hammerstein" the faded-in
    lead reference and the ZPETC inverse's start state (or ``V = G^-1 Yr``
    of the stable inversion), as its ``run_reference`` does
    (``HammersteinCompensator.fused_run``). Results equal the one-by-one run
    (:func:`hammerstein.scenario.execute.run_case`).

    Parameters
    ----------
    cases : list of hammerstein.scenario.validate.CaseSpec
    desc : str
        Label of the progress bar (shown only on a terminal).

    Returns
    -------
    list of hammerstein.scenario.execute.CaseResult
        In the order of ``cases``; divergences are results.
    """
    results = [None] * len(cases)
    batchable = [i for i, c in enumerate(cases) if _batchable(c)]
    rest = [i for i in range(len(cases)) if i not in set(batchable)]
    n_sweep = sum(1 for c in cases if getattr(c, "sweep", None) is not None)
    bar = progress(total=len(cases), desc=desc, unit="case") if n_sweep else None
    try:
        # look-ahead kinds (a pre-filter in the law) apart, so no batch pads one kind's
        # arrays to the other's; long cases first, so the batches hold similar work
        batchable.sort(key=lambda i: (compensator_kind(cases[i].compensator_spec).look_ahead,
                                      -cases[i].signal.shape[1]))
        groups = [[i for i in batchable if compensator_kind(cases[i].compensator_spec).look_ahead == g]
                  for g in (False, True)]
        for group in groups:
            for start in range(0, len(group), BATCH_SIZE):
                chunk = []
                prepared = {}
                members = group[start:start + BATCH_SIZE]
                preps = _prepared_chunk({i: cases[i] for i in members})
                for i in members:
                    if preps[i] is None:
                        rest.append(i)
                        continue
                    chunk.append(i)
                    prepared[i] = preps[i]
                _check_references(prepared)
                outs = simulate_chain_batch([prepared[i][0] for i in chunk],
                                            [cases[i].plant for i in chunk],
                                            [prepared[i][1] for i in chunk],
                                            compensator_states=[prepared[i][2] for i in chunk])
                for i, res in zip(chunk, outs):
                    results[i] = chain_result(cases[i], res, prepared[i][3])
                if bar is not None:
                    bar.update(len(chunk))
        for i in rest:
            results[i] = run_case(cases[i])
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return results


def run_scenario_cases(scenario):
    """:func:`run_cases` on a scenario's cases (the runner's "cases" kind).

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
        A resolved scenario; its name labels the progress display.

    Returns
    -------
    list of hammerstein.scenario.execute.CaseResult
        In the order of ``scenario.cases``; divergences are results.
    """
    return run_cases(scenario.cases, desc=scenario.name)


# -- stability map ----------------------------------------------------------------------
def _scales(v):
    if isinstance(v, dict):
        problems = []
        c = check_table(v, {"start": Field(number("-", 0), required=True),
                            "stop": Field(number("-", 0), required=True),
                            "num": Field(lambda n: n if isinstance(n, int) and not isinstance(n, bool)
                                         and 2 <= n <= 2000 else
                                         (_ for _ in ()).throw(Invalid(f"expected an integer 2..2000, found {n!r}"))),
                            }, "", problems, "")
        if problems:
            raise Invalid("; ".join(q[2:] for q in problems))
        return np.geomspace(c["start"], c["stop"], c.get("num", 50)).tolist()
    if isinstance(v, list) and v and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                         and np.isfinite(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a list of positive gain scalings or {{ start, stop, num }}, found {v!r}")


STABILITY = {
    "scales": Field(_scales, required=True),
    "compensators": Field(_labelled_tables),
}


def _kind_key(table, default=None):
    """A table's ``kind`` when it is a string, else None (a list or table would not hash)."""
    kind = table.get("kind", default) if isinstance(table, dict) else None
    return kind if isinstance(kind, str) else None


def check_stability_table(table, problems, source):
    """Check a ``[stability_map]`` table (nothing is built or computed).

    Parameters
    ----------
    table : object
        Parsed ``stability_map`` value.
    problems : list of str
        Receives ``source: stability_map.key: message`` lines.
    source : str
        File name.

    Returns
    -------
    dict or None
        ``scales`` (list of gain scalings) and optionally ``compensators``
        (label -> compensator table); None when the table is unusable.
    """
    clean = check_table(table, STABILITY, "stability_map", problems, source)
    if clean is None or "scales" not in clean:
        return None
    return clean


def stability_map_frame(clean, plant, compensator_top, context, problems, source):
    """Build the compensators of a checked ``[stability_map]`` table and compute the maps.

    Parameters
    ----------
    clean : dict
        :func:`check_stability_table` output.
    plant : HammersteinPlant
        The scenario's top-level plant (identified models are identified on it).
    compensator_top : dict
        The scenario's ``[compensator]`` table (default compensator).
    context : hammerstein.scenario.identification.ResolveContext or pathlib.Path
        The scenario's directory and identification cache.
    problems : list of str
        Receives ``source: stability_map.compensators.<label>: message``
        for a compensator that cannot be built or mapped.
    source : str

    Returns
    -------
    pandas.DataFrame or None
        Columns ``compensator, scale, max_radius, min_radius, converges``
        and ``K_<output>``; ``attrs['laws']`` maps each label to its
        ``literal_scale``, ``literal_max_radius``, ``normalised_max_radius``
        (:func:`hammerstein.compensation.stability.stability_map`).
    """
    comps = clean.get("compensators") or {"compensator": compensator_top}
    frames, laws = [], {}
    for label, spec in comps.items():
        entry = COMPENSATORS.get(_kind_key(spec, "none"))
        if entry is not None and entry.rate_independent and "check" in entry.fields:
            spec = {**spec, "check": "ignore"}   # the map shows where the law converges
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                comp = build_compensator(spec, plant, context)
            df = stability_map(comp, clean["scales"])
        except Exception as exc:  # report as a problem of this label
            problems.append(f"{source}: stability_map.compensators.{label}: {exc}")
            continue
        laws[label] = dict(df.attrs)
        frames.append(df.assign(compensator=label))
    if not frames:
        return None
    out = pd.concat(frames, ignore_index=True)
    cols = ["compensator"] + [c for c in out.columns if c != "compensator"]
    out = out[cols]
    out.attrs["laws"] = laws
    return out


