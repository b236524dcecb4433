"""Report directory of a scenario: metrics.csv, time series, figures, report.md.

Layout of ``DIR/<scenario name>/`` (written by
:func:`hammerstein.runner.run_scenario` through :func:`write_report`):

* ``metrics.csv``: long format, exactly the columns
  ``case,channel,metric,value,unit``;
* ``timeseries-<case>.csv``: ``time_s``, the references ``<output>_ref_um``
  (compensated cases: the reference tracked, faded in from rest where the
  case fades in), the inputs ``<input>_V`` and the outputs
  ``<output>_um``, to :data:`TIMESERIES_FORMAT` (9 significant digits);
* ``*.png``: input-output maps (open-loop and compensated sines, paper Fig. 5
  and 8), trajectory figures (Fig. 10-13), divergence plots;
* ``report.md``: the cases, how each compensated case starts (faded in, or
  with a step at t = 0 and how large: :func:`start_lines`), the figures
  and the metrics table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.compensation.drive import rest_output
from hammerstein.core.files import markdown_text, safe_write
from hammerstein.signals.references import DRIVE_KINDS, REFERENCE_KINDS, words_number
from hammerstein.report import figures as plots
from hammerstein.report import trajectories
from hammerstein.report.ilc_figure import convergence_figure, iteration_history
from hammerstein.report.render import FigureJobs
from hammerstein.report.definitions import definitions_lines, plural
from hammerstein.report.compensator_words import _compensator_title, _identify_summary
from hammerstein.report.shared_model import shared_model_lines
from hammerstein.report.sweeps import sweep_report_lines
from hammerstein.report.tables import COLUMNS, markdown_table, metrics_frame, write_signals_csv
from hammerstein.scenario.execute import fade_samples
from hammerstein.scenario.registry import COMPENSATORS

__all__ = ["metrics_frame", "timeseries_frame", "timeseries_columns", "write_report", "markdown_table", "COLUMNS",
           "start_lines"]


def timeseries_columns(result):
    """Columns of :func:`timeseries_frame` (name -> values, shape (n_samples,) each).

    Parameters
    ----------
    result : CaseResult

    Returns
    -------
    dict of str to numpy.ndarray
    """
    model = result.spec.plant.hysteresis
    cols = {"time_s": result.spec.time}
    if result.reference is not None:
        for l, o in enumerate(model.output_names):
            cols[f"{o}_ref_um"] = result.reference[l]
    for k, i in enumerate(model.input_names):
        cols[f"{i}_V"] = result.inputs[k]
    for l, o in enumerate(model.output_names):
        cols[f"{o}_um"] = result.outputs[l]
    return cols


def timeseries_frame(result):
    """Time series of one case: time, references, inputs, outputs.

    Parameters
    ----------
    result : CaseResult
        A simulated case (:class:`hammerstein.scenario.execute.CaseResult`):
        time [s] of shape (n_samples,), reference [µm] of shape
        (p, n_samples) or None, inputs [V] of shape (m, n_samples) and
        outputs [µm] of shape (p, n_samples).

    Returns
    -------
    pandas.DataFrame
        Columns ``time_s``, ``<output>_ref_um`` (compensated cases only),
        ``<input>_V``, ``<output>_um``.
    """
    return pd.DataFrame(timeseries_columns(result))


def _plant_label(spec):
    return "hammerstein" if spec.plant_spec.get("dynamics", True) else "static"


_num = words_number


def signal_summary(mode, s, unit=None):
    """A drive or reference table in words: ``sine on x, 50 µm, 50 Hz, 5 periods``.

    The words are the kind's registry entry's
    (:attr:`hammerstein.signals.references.ReferenceKind.summary`).

    Parameters
    ----------
    mode : {'drive', 'reference'}
    s : dict
        The case's ``drive`` or ``reference`` table.
    unit : str, optional
        Its values' unit (default V for a drive, µm for a reference).

    Returns
    -------
    str
        Only the settings that apply; phase and offset only when not zero.
    """
    kinds = DRIVE_KINDS if mode == "drive" else REFERENCE_KINDS
    entry = kinds.get(s.get("kind"))
    unit = unit or ("V" if mode == "drive" else "µm")
    parts = [str(s.get("kind"))] if entry is None else entry.summary(s, unit)
    return ", ".join(p for p in parts if p)


def _signal_summary(spec):
    what = "open-loop drive" if spec.mode == "drive" else "reference"
    return f"{what}: {signal_summary(spec.mode, spec.signal_spec)}"


def compensator_summary(c, compensator=None):
    """A validated ``[compensator]`` table in words, only the settings that apply.

    ``identify`` is shown only with ``model = "identified"``; ``cutoff_hz``
    only with the low-pass feedback law.

    Parameters
    ----------
    c : dict
        The case's compensator table (defaults filled).
    compensator : object, optional
        The compensator built from it: its ``creep`` (None: none inverted)
        makes the creep words exact; without it they follow the table.

    Returns
    -------
    str
        E.g. ``multivariable: plant model, secant gain, 1 iteration``; then
        the notes of the kind's registry entry
        (:attr:`hammerstein.scenario.registry.CompensatorKind.summary`),
        e.g. that a Hammerstein compensator inverts the plant's true dynamics.
    """
    kind = c.get("kind", "none")
    entry = COMPENSATORS.get(kind)
    if entry is not None and not entry.compensates:
        return kind
    model = c.get("model", "plant")
    parts = [_identify_summary(c.get("identify")) if model == "identified"
             else f"{model} model"]
    if "gain" in c:
        g = c["gain"]
        if isinstance(g, str):
            parts.append(f"{g} gain")
        elif isinstance(g, list):
            parts.append("gain K = [" + "; ".join(" ".join(_num(a) for a in row) for row in g)
                         + "] µm/V")
        else:
            parts.append(f"gain {g:g}" if isinstance(g, (int, float)) else f"gain {g}")
    if "iterations" in c:
        parts.append(f"{c['iterations']} iteration{'' if c['iterations'] == 1 else 's'}")
    if c.get("feedback") == "lowpass":
        parts.append(f"low-pass feedback at {_num(c['cutoff_hz'], 'Hz')}"
                     if c.get("cutoff_hz") is not None else "low-pass feedback")
    if c.get("check") not in (None, "error"):
        parts.append(f"convergence check: {c['check']}")
    known = {"kind", "model", "identify", "gain", "iterations", "feedback", "cutoff_hz", "check"}
    parts += [_key_words(c, k, v, compensator) for k, v in c.items()
              if k not in known and isinstance(v, (str, int, float))]
    if entry is not None and entry.summary is not None:
        parts += entry.summary(c)
    return f"{kind}: {', '.join(parts)}"


_INVERSION_WORDS = {"zpetc": "G inverted by ZPETC", "stable": "G inverted by stable inversion"}


def _creep_words(c, which, compensator=None):
    """What ``creep = which`` of a Hammerstein compensator inverts, in words
    (:func:`hammerstein.scenario.registry._spec_creep`'s rule; the built
    ``compensator``, when given, says whether a creep was inverted)."""
    inverted = None if compensator is None else getattr(compensator, "creep", None) is not None
    if which == "none" or inverted is False:
        return "creep not inverted"
    if which == "plant":
        return "the plant's true creep inverted (an oracle)"
    dyn = c.get("dynamics", "identified" if c.get("model") == "identified" else "plant")
    ident = c.get("identify") or {}
    if dyn == "identified" and c.get("model") == "identified" and "records" in ident:
        # records = "files" identifies a creep from its creep_records (records_route)
        asked = ident.get("creep_records") if ident["records"] == "files" else ident.get("creep")
        return "the identified creep inverted" if inverted or (inverted is None and asked) \
            else "creep not inverted"
    if dyn in ("plant", "identified"):
        return "creep not inverted"
    if inverted:
        return f"the creep of {dyn} inverted"
    return "the creep of the dynamics file inverted, if it has one"


def _key_words(c, k, v, compensator=None):
    """One more setting of a compensator table in words (``inversion``, ``creep``...)."""
    if k == "dynamics":
        return {"identified": "dynamics G identified",
                "plant": "the plant's true dynamics G"}.get(v, f"dynamics G from {v}")
    if k == "inversion" and v in _INVERSION_WORDS:
        return _INVERSION_WORDS[v]
    if k == "creep":
        return _creep_words(c, v, compensator)
    if k == "fade_in" and isinstance(v, (int, float)):
        return f"fade-in {_num(v, 's')}"
    if k == "limits":
        return f"amplifier limits: {v}"
    return f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"


def _terms(results):
    """The :data:`hammerstein.report.definitions.TERM_WORDS` keys the report's words use."""
    terms = []
    for r in results:
        c = getattr(r.spec, "compensator_spec", None) or {}
        if isinstance(c.get("gain"), str):
            terms.append(f"{c['gain']} gain")
        if c.get("kind") == "hammerstein":
            inv = c.get("inversion", "zpetc")
            terms.append("ZPETC" if inv == "zpetc" else "stable inversion")
        if getattr(r.spec, "plant_spec", None) is not None:
            terms.append("hammerstein plant")
    return list(dict.fromkeys(terms))


def _metric_kinds(results):
    """Metric -> the reference kinds of the cases holding it (what its percentage divides by)."""
    kinds = {}
    for r in results:
        kind = (getattr(r.spec, "signal_spec", None) or {}).get("kind")
        if getattr(r.spec, "mode", None) != "reference" or kind is None:
            continue
        for row in r.metrics:
            kinds.setdefault(row["metric"], []).append(str(kind))
    return kinds


def settle_words(spec):
    """Where a case's metrics start: ``4 periods: t ≥ 80 ms`` (from t = 0, the fade-in counted).

    Parameters
    ----------
    spec : hammerstein.scenario.validate.CaseSpec
        A resolved case.

    Returns
    -------
    str
        The ``settle_periods``, the time of the window's first sample
        (``round(settle_periods × P) × T``) and, when the case's fade-in
        ends after that sample, that time (where the metrics start for a case
        that started as ``compensate`` starts).
    """
    T = spec.plant.sampling_period
    start = int(round(spec.settle_periods * spec.period_samples))
    kind = (getattr(spec, "signal_spec", None) or {}).get("kind")
    word = "line" if kind == "raster" and spec.mode == "reference" else "period"
    text = f"{plural_number(spec.settle_periods, word)}: t ≥ {_time(start * T)}"
    if spec.mode == "reference":
        try:
            fade = fade_samples(spec)
        except Exception:      # noqa: BLE001 - a words helper never fails a report
            fade = 0
        if fade > start and getattr(spec, "start_fade", None) is not None:
            # started as compensate starts (scenario.execute.starts_as_hardware): measured after it
            text += f" (the fade-in ends later, at t = {_time(fade * T)}: the metrics start there)"
        elif fade > start:
            text += f" (the fade-in ends later, at t = {_time(fade * T)})"
    return text


def plural_number(x, word):
    """``"1 period"``, ``"1.5 periods"``, ``"4 periods"``.

    Parameters
    ----------
    x : float
    word : str

    Returns
    -------
    str
    """
    return f"{x:g} {word if float(x) == 1 else word + 's'}"


def _time(t):
    """A time in s or ms, 4 significant digits."""
    return f"{t:.4g} s" if t >= 1 else f"{t * 1e3:.4g} ms"


def _compensator_summary(spec):
    if spec.mode == "drive":
        return "none (open loop)"
    return compensator_summary(spec.compensator_spec, getattr(spec, "compensator", None))


def _last_period(x, P):
    # one full period plus the first sample again, so the loop closes
    return np.concatenate([x[..., -P:], x[..., -P:-P + 1]], axis=-1)


def _figure_prefix(scenario):
    return plots.scenario_prefix(scenario)


def _join_numbers(values, unit):
    vals = sorted(dict.fromkeys(float(v) for v in values))
    return f"{', '.join(f'{v:g}' for v in vals)} {unit}"


def _signal_words(rs, unit, fallback):
    """'10 V sines at 50, 100 Hz' for the cases of one figure (one signal kind);
    'a 10 V sine at 50 Hz' for one case."""
    kinds = {str(r.spec.signal_spec.get("kind")) for r in rs}
    amps = [r.spec.signal_spec.get("amplitude") for r in rs]
    freqs = [r.spec.signal_spec.get("frequency") for r in rs]
    if len(kinds) != 1 or any(not isinstance(v, (int, float)) or isinstance(v, bool)
                              for v in amps + freqs):
        return fallback
    kind = kinds.pop()
    if len(rs) == 1:
        return f"a {_join_numbers(amps, unit)} {kind} at {_join_numbers(freqs, 'Hz')}"
    return f"{_join_numbers(amps, unit)} {kind}s at {_join_numbers(freqs, 'Hz')}"


def _drive_summary(rs):
    return _signal_words(rs, "V", "open-loop drives")


def _reference_summary(rs):
    return _signal_words(rs, "µm", "compensated references")


def _identified_frequency(spec):
    c = spec.compensator_spec
    if c.get("model") == "identified":
        return float(c.get("identify", {}).get("frequency", float("nan")))
    return None


def _figures(scenario, results, directory, jobs):
    """Add the figure jobs to ``jobs``; return [(caption, file name)].

    Figure titles say what each file shows (plant, drives or compensator),
    not the scenario's title. Open-loop drives compared with a model are
    drawn in the model-vs-plant maps only (``hammerstein.report.identified``).
    """
    figs = []
    ok = [r for r in results if r.divergence is None]
    first = results[0].spec.plant.hysteresis
    in_names, out_names = list(first.input_names), list(first.output_names)
    prefix = _figure_prefix(scenario)
    # open-loop maps, grouped by plant (drives with a model comparison have their own maps)
    groups = {}
    for r in ok:
        if r.spec.mode == "drive" and getattr(r, "model_outputs", None) is None:
            groups.setdefault(_plant_label(r.spec), []).append(r)
    for label, rs in groups.items():
        curves = [{"label": r.name, "column": r.spec.driven_input,
                   "x": _last_period(r.inputs[r.spec.driven_input], r.spec.period_samples),
                   "outputs": _last_period(r.outputs, r.spec.period_samples)} for r in rs]
        fname = f"maps-open-loop-{label}.png"
        jobs.add(directory / fname, plots.loop_grid, curves, [f"{n} [V]" for n in in_names],
                 [f"{n} [µm]" for n in out_names],
                 f"{prefix}: open-loop input-output maps, {label} plant, "
                 f"{_drive_summary(rs)} (last period)")
        figs.append((f"Open-loop hysteresis and cross-couplings, {label} plant", fname))
    # compensated single-axis sines, grouped by plant and compensator
    groups = {}
    for r in ok:
        if r.spec.mode == "reference" and r.spec.loop_channel is not None:
            key = (_plant_label(r.spec), repr(sorted(r.spec.compensator_spec.items())))
            groups.setdefault(key, []).append(r)
    seen = {}
    identified = {}
    for (label, _), rs in groups.items():
        seen[label] = seen.get(label, 0) + 1
        curves = [{"label": r.name, "column": r.spec.loop_channel,
                   "x": _last_period(r.reference[r.spec.loop_channel], r.spec.period_samples),
                   "outputs": _last_period(r.outputs, r.spec.period_samples)} for r in rs]
        comp = _compensator_title(rs[0].spec)
        fname = f"maps-compensated-{label}{'' if seen[label] == 1 else f'-{seen[label]}'}.png"
        jobs.add(directory / fname, plots.loop_grid, curves, [f"{n}_r [µm]" for n in out_names],
                 [f"{n} [µm]" for n in out_names],
                 f"{prefix}: compensated maps, {label} plant, {comp}; "
                 f"{_reference_summary(rs)} (last period)",
                 direct_label="compensated direct", cross_label="residual cross-coupling")
        figs.append((f"Compensated input-output maps, {label} plant, {comp}", fname))
        f_id = _identified_frequency(rs[0].spec)
        if f_id is not None:
            identified.setdefault(label, []).append((f_id, rs))
    # several identified models on one plant: one overlay as the paper's Fig. 8
    for label, groups_f in identified.items():
        if len({f for f, _ in groups_f}) < 2:
            continue
        curves = []
        for f_id, rs in sorted(groups_f, key=lambda g: g[0]):
            for r in rs:
                f_ref = r.spec.signal_spec.get("frequency")
                tested = f", tested at {f_ref:g} Hz" if isinstance(f_ref, (int, float)) else ""
                curves.append({"label": f"identified at {f_id:g} Hz{tested}",
                               "column": r.spec.loop_channel,
                               "x": _last_period(r.reference[r.spec.loop_channel], r.spec.period_samples),
                               "outputs": _last_period(r.outputs, r.spec.period_samples)})
        fname = f"maps-compensated-{label}-by-identification.png"
        jobs.add(directory / fname, plots.loop_grid, curves, [f"{n}_r [µm]" for n in out_names],
                 [f"{n} [µm]" for n in out_names],
                 f"{prefix}: compensated maps, {label} plant, one compensator per "
                 f"identification frequency (last period)",
                 direct_label="compensated direct", cross_label="residual cross-coupling")
        figs.append((f"Compensated input-output maps, {label} plant, compensators identified at "
                     f"{_join_numbers([f for f, _ in groups_f], 'Hz')} (as the paper's Fig. 8)", fname))
    # diverged compensators
    for r in results:
        if r.divergence is not None:
            fname = f"divergence-{r.name}.png"
            jobs.add(directory / fname, trajectories.divergence_figure, r.inputs, in_names,
                     r.divergence.sample, r.divergence.reason,
                     f"{prefix}: {r.name}, {_compensator_title(r.spec)}: "
                     f"compensator output until divergence")
            figs.append((f"Case {r.name}: the compensator diverged at sample "
                         f"{r.divergence.sample} (t = {r.diverged_at * 1e3:.3g} ms)", fname))
    # trajectories
    traj = [r for r in ok if r.spec.mode == "reference" and r.spec.loop_channel is None]
    for r in traj:
        names = out_names                      # every output (z too); the XY plot: the first two
        settle = r.spec.settle_periods * r.spec.period_samples * r.spec.plant.sampling_period
        fname = f"trajectory-{r.name}.png"
        jobs.add(directory / fname, trajectories.trajectory_figure, r.spec.time, r.reference,
                 r.outputs, names,
                 f"{prefix}: {r.name}, {_plant_label(r.spec)} plant, {_compensator_title(r.spec)}",
                 settle_time=settle, inputs=r.inputs, input_names=in_names,
                 fade_time=fade_samples(r.spec) * r.spec.plant.sampling_period)
        figs.append((f"Case {r.name}: spatial domain, time domain (displacements, input "
                     f"voltages), tracking error", fname))
    for r in ok:                       # kind "ilc": error per learning trial
        its, mx, rms = iteration_history(r.metrics, out_names)
        if its.size:
            fname = f"convergence-{r.name}.png"
            scale = r.spec.signal_spec.get("radius", r.spec.signal_spec.get("amplitude"))
            jobs.add(directory / fname, convergence_figure, its, mx, rms, out_names,
                     f"{prefix}: {r.name}, iterative learning: tracking error per trial",
                     scale if isinstance(scale, (int, float)) else None)
            figs.append((f"Case {r.name}: iterative learning, max and RMS tracking error per "
                         f"axis against the trial", fname))
    if len(traj) > 1:
        curves = []
        for r in traj:
            start = int(round(r.spec.settle_periods * r.spec.period_samples))
            curves.append({"label": r.name, "reference": r.reference[:2, start:],
                           "outputs": r.outputs[:2, start:]})
        drawn = ", ".join(r.name for r in traj)
        jobs.add(directory / "xy-all.png", trajectories.xy_overlay, curves, out_names[:2],
                 f"{prefix}: the XY trajectories of {drawn} after settling")
        figs.append((f"The XY trajectories of {drawn} after settling (dashed: references; a "
                      f"case that drives one output is drawn on its own only)", "xy-all.png"))
    return figs


def _scan_figures(scenario, results, directory, jobs):
    """Error maps of the scanned (raster-style) references, one job per case; [(caption, file name)].

    A reference kind is scanned when its registry entry has ``scan``
    (:class:`hammerstein.signals.references.ReferenceKind`).
    """
    figs = []
    for r in results:
        s = r.spec.signal_spec
        entry = REFERENCE_KINDS.get(s.get("kind")) if r.spec.mode == "reference" else None
        if entry is None or entry.scan is None or r.divergence is not None:
            continue
        names = list(r.spec.plant.hysteresis.output_names)
        scan = entry.scan(r.spec.time, s, names)
        fast, slow = names.index(scan["fast"]), names.index(scan["slow"])
        e = r.reference - r.outputs
        fname = f"{s['kind']}-error-{r.name}.png"
        jobs.add(
            directory / fname, trajectories.raster_error_map,
            r.reference[fast], e[[fast, slow]],
            [f"{names[fast]}_r - {names[fast]} (fast)", f"{names[slow]}_r - {names[slow]} (slow)"],
            scan["line"], scan["trace"], scan["extent"], names[fast],
            f"{scenario.title}: {r.name}, tracking error per scan line", 200,
            scan.get("start", 0.0))
        figs.append((f"Case {r.name}: tracking error per scan line against the fast-axis "
                     f"position (trace and retrace)", fname))
    return figs


def _model_rest(compensator):
    """max |output at rest| [µm] of a compensator's hysteresis model, or None without one."""
    model = getattr(compensator, "model", None)
    if model is None or not hasattr(model, "simulate"):
        return None
    try:
        return float(np.max(np.abs(rest_output(model))))
    except (TypeError, ValueError, AttributeError):
        return None


def start_lines(results, atol=1e-9):
    """The report's lines on how each compensated case starts: faded in, or with a step.

    A reference case starts from rest (0 V, 0 µm). Its reference is either
    faded in (:func:`hammerstein.scenario.execute.fade_samples` > 0) or
    starts at rest, or it starts with a step: the paper's circles start at
    (R, 0), which the simulated compensator asks for in one sample. The
    hardware commands never do (``hammerstein compensate`` fades in over a
    duration); the report says where and how large the step is.

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult
    atol : float
        A first sample within ``atol`` [µm] of rest is at rest.

    Returns
    -------
    list of str
        Markdown lines (a heading, one bullet per start, cases grouped, and
        one naming the cases whose ``peak_slew`` is that first step from 0 V,
        with the largest slew over the settled window); empty without a
        reference case.
    """
    groups, slews = {}, []
    for r in results:
        spec = r.spec
        if r.reference is None or getattr(spec, "signal", None) is None:
            continue
        first = np.asarray(spec.signal, dtype=float)[:, 0]
        step = float(np.linalg.norm(first))
        fade = fade_samples(spec)
        T = spec.plant.sampling_period
        names = list(spec.plant.hysteresis.output_names)
        u0 = np.max(np.abs(np.asarray(r.inputs, dtype=float)[:, 0])) if r.inputs is not None \
            and np.size(r.inputs) else 0.0
        rest = _model_rest(spec.compensator)
        if fade > 0 and u0 > 1e-6 and rest is not None and rest <= atol:
            # the model rests at 0 µm: the inverse's preview acts on the fade from its first
            # sample (the report blamed a rest the model does not have)
            text = (f"the reference is faded in from 0 µm over {fade * T * 1e3:.4g} ms "
                    f"({fade} samples) from the first sample, with no sample at rest before "
                    f"it: the compensator's inverse of the dynamics previews the samples "
                    f"ahead, so the drive starts at {u0:.3g} V, not 0 V (`hammerstein "
                    f"compensate` holds the start at rest before its fade)")
        elif fade > 0 and u0 > 1e-6:
            # faded from 0 µm, not from the model's output at 0 V: the first voltage is a step
            text = (f"the reference is faded in from 0 µm over {fade * T * 1e3:.4g} ms "
                    f"({fade} samples), but the compensator's model does not rest at 0 µm at "
                    f"0 V, so the drive jumps from 0 V to {u0:.3g} V in the first sample "
                    f"(`hammerstein compensate` instead fades in from the model's output at 0 V)")
        elif fade > 0:
            text = f"faded in from rest over {fade * T * 1e3:.4g} ms ({fade} samples)"
        elif step <= atol:
            text = "at rest (its first sample is 0 µm): no step"
        else:
            at = ", ".join(f"{n} = {v:.4g} µm" for n, v in zip(names, first))
            text = (f"with a step at t = 0: the reference starts at {at}, {step:.4g} µm from "
                    f"rest in one sample (as in the paper's figures; the hardware commands "
                    f"never do this: `hammerstein compensate` fades in over a duration)")
        groups.setdefault(text, []).append(r.name)
        slew = _start_slew(r)
        if slew is not None:
            slews.append((r.name, *slew))
    if not groups:
        return []
    lines = ["Start of each compensated case (from rest):", ""]
    for text, cases in groups.items():
        shown = ", ".join(f"`{c}`" for c in cases[:6]) + (
            f" and {len(cases) - 6} more" if len(cases) > 6 else "")
        lines.append(f"- {shown}: {text}")
    if slews:
        shown = ", ".join(f"`{c}` ({a:.4g} V/s at t = 0; at most {b:.4g} V/s over the settled "
                          f"window)" for c, a, b in slews[:6]) + (
            f" and {len(slews) - 6} more" if len(slews) > 6 else "")
        lines.append(f"- `peak_slew` is this start's first step from 0 V, larger than any slew "
                     f"after it, in {shown}")
    return lines + [""]


def _start_slew(r):
    """(peak_slew, settled peak slew) [V/s] of a case whose peak_slew is its first step from
    0 V (the start-up), else None; both over all inputs."""
    u = getattr(r, "inputs", None)
    if u is None or np.size(u) < 2:
        return None
    u = np.asarray(u, dtype=float)
    T = r.spec.plant.sampling_period
    first = float(np.max(np.abs(u[:, 0]))) / T
    rest = np.abs(np.diff(u, axis=1)) / T
    start = int(round(r.spec.settle_periods * r.spec.period_samples))
    settled = float(np.max(rest[:, max(start - 1, 0):])) if rest[:, max(start - 1, 0):].size else 0.0
    if not np.isfinite(first) or first <= max(float(np.max(rest)), 0.0) or first <= 1e-12:
        return None
    return first, settled


#: Format of the time series' values: 9 significant digits keep every sample time of a case
#: of up to 1000 s at 100 kHz apart (6, the default of the other tables, gave 12.3456 s
#: for two samples at 20 kHz past 10 s) and a drive to 1e-8 of its range.
TIMESERIES_FORMAT = "%.9g"


def write_report(scenario, results, directory, jobs=None):
    """Write metrics.csv, the time series, the figures and report.md.

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
    results : list of hammerstein.scenario.execute.CaseResult
    directory : pathlib.Path
        Existing (temporary) directory to fill.
    jobs : hammerstein.report.render.FigureJobs, optional
        Collects the figures (the caller waits for them); default: drawn here.
    """
    directory = Path(directory)
    jobs = FigureJobs() if jobs is None else jobs
    frame = metrics_frame(results)
    safe_write(directory / "metrics.csv", frame.to_csv(index=False), "metrics file")
    shown = list(dict.fromkeys(frame["metric"]))         # the sweep tables show them as well
    kinds, terms = _metric_kinds(results), _terms(results)
    sweep_lines = sweep_report_lines(scenario, results, directory, frame, jobs)
    results = [r for r in results if getattr(r.spec, "sweep", None) is None]
    frame = frame[frame["case"].isin([r.name for r in results])]
    for r in results:
        write_signals_csv(directory / f"timeseries-{r.name}.csv", timeseries_columns(r),
                          float_format=TIMESERIES_FORMAT)
    figs = _figures(scenario, results, directory, jobs) if results else []
    figs += _scan_figures(scenario, results, directory, jobs)
    lines = [f"# {markdown_text(scenario.title)}", ""]
    if scenario.description:
        lines += [scenario.description.strip(), ""]
    lines += [f"Scenario `{scenario.path}` (name `{scenario.name}`, seed {scenario.seed}).", ""]
    lines += definitions_lines(shown, kinds, terms=terms, paper=True)
    if results:
        table = pd.DataFrame([{
            "case": r.name,
            "signal": _signal_summary(r.spec),
            "plant": f"{r.spec.plant_spec.get('preset')} ({_plant_label(r.spec)})",
            "compensator": _compensator_summary(r.spec),
            "samples": r.spec.time.size,
            "metrics from": settle_words(r.spec),
            "status": ("ok" if r.divergence is None else
                       f"DIVERGED at sample {r.divergence.sample} "
                       f"(t = {r.diverged_at * 1e3:.3g} ms): {r.divergence.reason}"),
        } for r in results])
        lines += ["## Cases", "", markdown_table(table), ""]
        lines += shared_model_lines(results)
    lines += start_lines(results)
    lines += _grouped_lines("Warnings:", [(r.name, w) for r in results
                                         for w in dict.fromkeys(r.warnings)])
    lines += _grouped_lines("Notes:", [(r.name, n) for r in results for n in r.spec.notes])
    if figs:
        lines += ["## Figures", ""]
    for caption, fname in figs:
        lines += [f"### {caption}", "", f"![{caption}]({fname})", ""]
    lines += sweep_lines
    files = "All metrics in long format: `metrics.csv`"
    if results:
        files += (f"; the time series of the {plural(len(results), 'case')} above in "
                  f"`timeseries-<case>.csv`")
    elif sweep_lines:
        files += " (the sweep tables above are wide views of its rows)"
    lines += ["## Metrics", "", files + ".", ""]
    if not frame.empty:
        lines += [markdown_table(frame), ""]
    safe_write(directory / "report.md", "\n".join(lines), "report")


def _grouped_lines(heading, pairs):
    """``heading`` and one bullet per distinct message, naming the cases that raised it."""
    groups = {}
    for case, text in pairs:
        groups.setdefault(text, []).append(case)
    if not groups:
        return []
    out = [heading, ""]
    for text, cases in groups.items():
        names = ", ".join(f"`{c}`" for c in cases[:6]) + (
            f" and {len(cases) - 6} more" if len(cases) > 6 else "")
        out.append(f"- {names}: {text}")
    return out + [""]
