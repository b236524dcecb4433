"""Reports of identified models and model-vs-plant drives (paper Fig. 6, 7).

:func:`report_identified` saves the identified models the case results carry
(:func:`hammerstein.report.model_files.save_identified_models`) and appends
their sections to ``report.md``: the plant-vs-model loop grids of open-loop
drives with a comparison model (Fig. 6), ``model-outputs-<case>.csv`` and,
for 3 or more drive frequencies, the model RMS error against frequency
(:func:`model_rms_table`, ``model-rms-vs-frequency.csv`` and ``.png``, Fig. 7).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import append_text, safe_write
from hammerstein.report.figures import scenario_prefix
from hammerstein.report.model_figures import model_loop_grid, rms_vs_frequency_figure
from hammerstein.report.model_files import save_identified_dynamics, save_identified_models
from hammerstein.report.tables import markdown_table, write_signals_csv
from hammerstein.models.lti import align_dc_gain, compare_frequency_responses
from hammerstein.report.dynamics_figure import dynamics_bode_figure_from_data, state_space_data
from hammerstein.report.definitions import plural
from hammerstein.report.render import FigureJobs
from hammerstein.report.shared_model import SHARED_MODEL_WORDS, shared_model_cases

__all__ = ["report_identified", "model_rms_table", "order_words"]


def report_identified(scenario, results, directory, jobs=None):
    """Report hook: save the identified models and list them in ``report.md``.

    Called by :func:`hammerstein.runner.run_scenario` after
    :func:`hammerstein.report.scenario.write_report`; does nothing for a scenario
    without identified models or model-vs-plant drives. Writes the model
    files, ``model-outputs-<case>.csv``, the plant-vs-model loop grids
    (Fig. 6) and, for 3 or more drive frequencies, ``model-rms-vs-frequency.csv``
    and ``.png`` (Fig. 7); sweep cases are left to their sweep's report.

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
    results : list of hammerstein.scenario.execute.CaseResult
    directory : pathlib.Path
        The report directory being written (contains ``report.md``).
    jobs : hammerstein.report.render.FigureJobs, optional
        Collects the figures (the caller waits for them); default: drawn here.
    """
    directory = Path(directory)
    jobs = FigureJobs() if jobs is None else jobs
    rows = save_identified_models(results, directory)
    _report_dynamics(results, directory, jobs)
    # sweep cases ([[sweeps]], hammerstein.scenario.sweeps) are reported by their sweep's table and figure
    results = [r for r in results if getattr(r.spec, "sweep", None) is None]
    figs = _comparison_figures(scenario, results, directory, jobs)
    if not rows and not figs:
        return
    lines = []
    if figs:
        lines += ["", "## Model vs plant", "",
                  "Open-loop drives compared with a model (rate-independent PI, no dynamics) "
                  "driven by the same voltages: metrics `model_rms_error` and "
                  "`model_max_abs_error` [µm] per output (plant minus model, after settling; the "
                  "paper's RMS_error_model, Section 5.3); model outputs in "
                  "`model-outputs-<case>.csv`.", ""]
        for caption, fname in figs:
            lines += [f"### {caption}", "", f"![{caption}]({fname})", ""]
        for caption, fname, table in _frequency_tables(scenario, results, directory, jobs):
            lines += [f"### {caption}", "", f"![{caption}]({fname[0]})", "",
                      f"Table: [`{fname[1]}`]({fname[1]}).", "", markdown_table(table), ""]
    if not rows:
        append_text(directory / "report.md", "\n".join(lines) + "\n", "report")
        return
    lines += ["", "## Identified models", "",
             f"Identified {_how_identified([r['identify'] for r in rows])}; loadable with "
             "`model = \"<file>\"`.", "",
             "| model file | plant | used as | cases |", "|---|---|---|---|"]
    by_file = {}
    for r in rows:
        by_file.setdefault((r["file"], r["plant"], r["role"]), []).append(r["case"])
    for (fname, plant, role), cases in by_file.items():
        shown = ", ".join(cases) if len(cases) <= 4 else f"{', '.join(cases[:3])}, ... ({len(cases)} cases)"
        lines.append(f"| [`{fname}`]({fname}) | {plant} | {role} | {shown} |")
    append_text(directory / "report.md", "\n".join(lines) + "\n", "report")


def _last_period(x, P):
    return np.concatenate([x[..., -P:], x[..., -P:-P + 1]], axis=-1)


def _how_identified(tables):
    """How the ``identify`` tables of the listed models identified them, in words."""
    words = {"files": "from the measured record files the case's `identify` table names",
             "excitation": "from the excitation records (`hammerstein excitation`) recorded on the "
                           "case's plant"}
    sine = "on the case's plant by a sine on each input in turn (Section 3.3, Steps 1-4)"
    found = dict.fromkeys(words.get(t.get("records"), sine) for t in tables)
    return "; ".join(found)


def _model_label(spec):
    if spec.get("model") == "identified":
        i = spec["identify"]
        if "records" in i:
            return f"model identified from {i['records']} records ({i.get('model', 'auto')})"
        return f"model identified at {i['frequency']:g} Hz ({i.get('method', 'closed-form')})"
    return f"model {spec.get('model')}"


def _drive_words(rs):
    """'10, 5 V sines at 50 Hz' for the drive cases of a figure."""
    def join(vals, unit):
        return f"{', '.join(f'{v:g}' for v in dict.fromkeys(float(x) for x in vals))} {unit}"
    try:
        return (f"{join([r.spec.signal_spec['amplitude'] for r in rs], 'V')} sines at "
                f"{join([r.spec.signal_spec['frequency'] for r in rs], 'Hz')}")
    except (KeyError, TypeError, ValueError):
        return "open-loop drives"


def _comparison_figures(scenario, results, directory, jobs):
    """Plant-vs-model loop grids (Fig. 6) and model output CSVs; [(caption, file)]."""
    groups = {}
    for r in results:
        if getattr(r, "model_outputs", None) is None:
            continue
        model = r.spec.plant.hysteresis
        cols = {"time_s": r.spec.time}
        cols.update({f"{o}_model_um": r.model_outputs[l] for l, o in enumerate(model.output_names)})
        write_signals_csv(directory / f"model-outputs-{r.name}.csv", cols)
        label = "hammerstein" if not r.spec.plant.is_static else "static"
        groups.setdefault((label, _model_label(r.spec.model_spec)), []).append(r)
    figs = []
    for i, ((label, mlabel), rs) in enumerate(groups.items()):
        model = rs[0].spec.plant.hysteresis
        P = lambda r: r.spec.period_samples  # noqa: E731
        curves = [{"label": r.name, "column": r.spec.driven_input,
                   "x": _last_period(r.inputs[r.spec.driven_input], P(r)),
                   "plant": _last_period(r.outputs, P(r)),
                   "model": _last_period(r.model_outputs, P(r))} for r in rs]
        fname = f"model-vs-plant-{label}{'' if i == 0 else f'-{i + 1}'}.png"
        jobs.add(directory / fname, model_loop_grid, curves,
                 [f"{n} [V]" for n in model.input_names], [f"{n} [µm]" for n in model.output_names],
                 f"{scenario_prefix(scenario)}: {label} plant (solid) vs {mlabel} "
                 f"(dashed), {_drive_words(rs)} (last period)")
        figs.append((f"Model vs plant: {label} plant, {mlabel}", fname))
    return figs


def model_rms_table(results):
    """Model error against drive frequency of the model-vs-plant drive cases.

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult

    Returns
    -------
    pandas.DataFrame
        One row per case and output: ``plant`` ('hammerstein' or
        'static'), ``model`` (label), ``input`` (driven input), ``output``,
        ``amplitude_V``, ``frequency_hz``, ``model_rms_error`` and
        ``model_max_abs_error`` [µm]; sorted by plant, model, input, output,
        frequency.
    """
    rows = []
    for r in results:
        if getattr(r, "model_outputs", None) is None or r.spec.mode != "drive":
            continue
        spec = r.spec
        vals = {(m["channel"], m["metric"]): m["value"] for m in r.metrics}
        for o in spec.plant.hysteresis.output_names:
            rows.append({"plant": "hammerstein" if not spec.plant.is_static else "static",
                         "model": _model_label(spec.model_spec),
                         "input": spec.plant.hysteresis.input_names[spec.driven_input],
                         "output": o, "amplitude_V": float(spec.signal_spec["amplitude"]),
                         "frequency_hz": float(spec.signal_spec["frequency"]),
                         "model_rms_error": vals[(o, "model_rms_error")],
                         "model_max_abs_error": vals[(o, "model_max_abs_error")]})
    cols = ["plant", "model", "input", "output", "amplitude_V", "frequency_hz",
            "model_rms_error", "model_max_abs_error"]
    frame = pd.DataFrame(rows, columns=cols)
    return frame.sort_values(cols[:6], kind="stable").reset_index(drop=True)


def _frequency_tables(scenario, results, directory, jobs):
    """Fig. 7: model RMS error vs drive frequency for every (plant, model, amplitude)
    group with 3 or more drive frequencies; writes CSV and figure."""
    table = model_rms_table(results)
    out = []
    groups = [(key, g) for key, g in table.groupby(["plant", "model", "amplitude_V"], sort=False)
              if g["frequency_hz"].nunique() >= 3]
    for i, ((plant, mlabel, amp), g) in enumerate(groups):
        first = next(r for r in results if getattr(r, "model_outputs", None) is not None)
        model = first.spec.plant.hysteresis
        suffix = "" if i == 0 else f"-{i + 1}"
        fig_name, csv_name = f"model-rms-vs-frequency{suffix}.png", f"model-rms-vs-frequency{suffix}.csv"
        safe_write(directory / csv_name, g.to_csv(index=False, float_format="%.6g"), "table")
        f_id = None
        for r in results:
            ms = getattr(r.spec, "model_spec", None) or {}
            if ms.get("model") == "identified" and _model_label(ms) == mlabel:
                f_id = ms["identify"]["frequency"]
                break
        jobs.add(directory / fig_name, rms_vs_frequency_figure, g, list(model.input_names),
                 list(model.output_names),
                 f"{scenario_prefix(scenario)}: RMS error of the {mlabel} against the "
                 f"{plant} plant, {amp:g} V drives", identification_hz=f_id)
        wide = g.pivot_table(index="frequency_hz", columns=["output", "input"],
                             values="model_rms_error")
        wide.columns = [f"{o}<-{k} [µm]" for o, k in wide.columns]
        out.append((f"Model RMS error vs drive frequency ({plant} plant, {mlabel}, {amp:g} V)",
                    (fig_name, csv_name), wide.reset_index()))
    return out


def _report_dynamics(results, directory, jobs):
    """Section "Identified dynamics": Bode figure identified vs true G (all entries), fits."""
    rows = save_identified_dynamics(results, directory)
    if not rows:
        return
    lines = ["", "## Identified dynamics (Hammerstein compensator)", "",
             "G identified by subspace identification (PO-MOESP) from random-phase multisines on "
             "each input in turn, with the identified PI's outputs as its inputs; order: the best "
             "fit on held-out data (the last 30 % of each record) among the candidate orders "
             "tried (one, when the order is fixed), listed below; the sensor's low-pass is "
             "kept out of G. The PI, characterised quasi-statically, holds the static gain "
             "G(0) of the actuator (cross-coupling included), so the identified G has "
             "G_id(0) ~ I: it is compared with the true G brought to unit DC gain, "
             "G_true G_true(0)^-1 (the product G Gamma is what is identified). "
             "Relative error: |G_id - G_true G_true(0)^-1| divided by the largest true gain "
             "of the same row.", ""]
    shared = set(shared_model_cases(results))
    for i, r in enumerate(rows, start=1):
        ident, plant, meta = r["identifier"], r["plant"], r["metadata"]
        fname = f"dynamics-bode-{i}.png"
        true = align_dc_gain(plant.dynamics, np.eye(plant.dynamics.noutputs))
        cmp_ = compare_frequency_responses(ident.system_, true, [10.0, 100.0, 200.0, 300.0])
        # the plant is the compensator's model, its G what was identified: G against itself
        one = (sorted(shared.intersection(r["cases"]))
               if np.max(cmp_["relative_error"]) < 1e-6 else [])
        jobs.add(directory / fname, dynamics_bode_figure_from_data, state_space_data(ident.system_),
                 state_space_data(true), labels=("identified", "true G G(0)^-1"),
                 title=f"Identified vs true G ({plant.name}), order {ident.order_}"
                       + (" - one model: G compared with itself" if one else ""))
        cases = r["cases"]
        used = ", ".join(f"`{c}`" for c in cases[:8]) + (
            f" and {len(cases) - 8} more" if len(cases) > 8 else "")
        lines += [f"### Dynamics {i}", "",
                  f"Used by {plural(len(cases), 'case')}: {used}.", "",
                  *([f"**One model:** the true G below is the G identified for "
                     f"{', '.join(f'`{c}`' for c in one[:8])}{' and more' if len(one) > 8 else ''}"
                     f" (the figure compares G with itself): {SHARED_MODEL_WORDS}.", ""]
                    if one else []),
                  f"![Identified vs true G]({fname})", "",
                  f"- {order_words(ident, r.get('summary'))}",
                  f"- fit over all records per output: "
                  f"{', '.join(f'{v:.2f} %' for v in ident.fit_percent_)}",
                  f"- natural frequencies {', '.join(f'{v:.2f}' for v in meta['natural_frequency_hz'])}"
                  f" Hz, damping {', '.join(f'{v:.3f}' for v in meta['damping_ratio'])}",
                  "- largest relative error at 10 / 100 / 200 / 300 Hz: "
                  + " / ".join(f"{100 * v:.2f} %" for v in cmp_["relative_error"].max(axis=(0, 1))),
                  f"- files: [`{r['dynamics_file']}`]({r['dynamics_file']})"
                  + (f", {r.get('pi_class', 'PI')} [`{r['pi_file']}`]({r['pi_file']})"
                     if r["pi_file"] else ""), ""]
    append_text(directory / "report.md", "\n".join(lines) + "\n", "report")


def order_words(ident, summary=None):
    """The order of identified dynamics and every candidate order tried, in words.

    Parameters
    ----------
    ident : hammerstein.models.lti.DynamicsIdentifier
        Fitted (``order_``, ``candidate_order_``, ``orders_``,
        ``validation_fit_``, ``candidates_``).
    summary : dict, optional
        The dynamics summary of ``identify``'s pipeline
        (:func:`hammerstein.identification.identification_pipeline.identify_pipeline`:
        ``candidate_order``, ``chosen_on``, ``candidates``). Its search, run
        before the creep was identified, is listed; ``ident`` (fitted again
        through the creep at the order kept) gives the order and its fit.

    Returns
    -------
    str
        E.g. ``order 6: candidate order 8 (the best held-out fit) with 2
        states removed (...); held-out fit by candidate order: 1: rejected
        (unstable ...), ..., 8: 99.76 %``.
    """
    if summary and summary.get("candidates"):
        chosen = int(summary["candidate_order"])
        infos = {int(c["order"]): c for c in summary["candidates"]}
        tried = [f"{n}: {c['held_out_fit_percent']:.2f} %" if "held_out_fit_percent" in c
                 and not c.get("rejected") else
                 (f"{n}: rejected ({c['rejected']})" if c.get("rejected") else f"{n}: rejected")
                 for n, c in infos.items()]
    else:
        chosen = int(getattr(ident, "candidate_order_", ident.order_))
        infos = {int(c.get("order", -1)): c for c in (getattr(ident, "candidates_", None) or [])}
        tried = []
        for n, v in zip(ident.orders_, ident.validation_fit_):
            n = int(n)
            if np.isfinite(v):
                tried.append(f"{n}: {v:.2f} %")
            else:
                why = infos.get(n, {}).get("rejected")
                tried.append(f"{n}: rejected ({why})" if why else f"{n}: rejected")
    text = f"order {ident.order_}"
    if ident.order_ != chosen:
        dropped = infos.get(chosen, {}).get("dropped") or []
        how = "chosen by its held-out fit" if len(tried) > 1 else "the one order tried"
        text += (f": candidate order {chosen} ({how}), with "
                 f"{plural(chosen - ident.order_, 'state')} removed"
                 + (f" ({'; '.join(dropped)})" if dropped else ""))
    kind = "candidate order" if len(tried) > 1 else "the one order tried"
    text = f"{text}; held-out (validation) fit by {kind}: {', '.join(tried)}"
    if summary and summary.get("candidates") and summary.get("chosen_on"):
        text += f" (chosen on {summary['chosen_on']})"
    return text
