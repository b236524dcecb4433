"""Report directory of a scenario: metrics.csv, time series, figures, report.md.

Layout of ``DIR/<scenario name>/`` (written by
:func:`hammerstein.runner.run_scenario` through :func:`write_report`):

* ``metrics.csv``: long format, exactly the columns
  ``case,channel,metric,value,unit``;
* ``timeseries-<case>.csv``: ``time_s``, the references ``<output>_ref_um``
  (compensated cases), the inputs ``<input>_V`` and the outputs
  ``<output>_um``;
* ``*.png``: input-output maps (open-loop and compensated sines, paper Fig. 5
  and 8), trajectory figures (Fig. 10-13), divergence plots;
* ``report.md``: the cases, the figures and the metrics table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.report import figures as plots
from hammerstein.report.sweeps import sweep_report_lines
from hammerstein.report.tables import COLUMNS, markdown_table, metrics_frame

__all__ = ["metrics_frame", "timeseries_frame", "write_report", "markdown_table", "COLUMNS"]


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
    model = result.spec.plant.hysteresis
    cols = {"time_s": result.spec.time}
    if result.reference is not None:
        for l, o in enumerate(model.output_names):
            cols[f"{o}_ref_um"] = result.reference[l]
    for k, i in enumerate(model.input_names):
        cols[f"{i}_V"] = result.inputs[k]
    for l, o in enumerate(model.output_names):
        cols[f"{o}_um"] = result.outputs[l]
    return pd.DataFrame(cols)


def _plant_label(spec):
    return "hammerstein" if spec.plant_spec.get("dynamics", True) else "static"


def _signal_summary(spec):
    s = spec.signal_spec
    skip = {"kind"}
    args = ", ".join(f"{k}={v}" for k, v in s.items() if k not in skip)
    return f"{spec.mode} {s.get('kind')} ({args})"


def _compensator_summary(spec):
    if spec.mode == "drive":
        return "none (open loop)"
    c = spec.compensator_spec
    return ", ".join(f"{k}={v}" for k, v in c.items())


def _last_period(x, P):
    # one full period plus the first sample again, so the loop closes
    return np.concatenate([x[..., -P:], x[..., -P:-P + 1]], axis=-1)


def _figures(scenario, results, directory):
    """Write the figures; return [(caption, file name)]."""
    figs = []
    ok = [r for r in results if r.divergence is None]
    first = results[0].spec.plant.hysteresis
    in_names, out_names = list(first.input_names), list(first.output_names)
    # open-loop maps, grouped by plant
    groups = {}
    for r in ok:
        if r.spec.mode == "drive":
            groups.setdefault(_plant_label(r.spec), []).append(r)
    for label, rs in groups.items():
        curves = [{"label": r.name, "column": r.spec.driven_input,
                   "x": _last_period(r.inputs[r.spec.driven_input], r.spec.period_samples),
                   "outputs": _last_period(r.outputs, r.spec.period_samples)} for r in rs]
        fig = plots.loop_grid(curves, [f"{n} [V]" for n in in_names],
                              [f"{n} [µm]" for n in out_names],
                              f"{scenario.title}: open-loop input-output maps ({label} plant, last period)")
        fname = f"maps-open-loop-{label}.png"
        plots.save(fig, directory / fname)
        figs.append((f"Open-loop hysteresis and cross-couplings, {label} plant", fname))
    # compensated single-axis sines, grouped by plant and compensator
    groups = {}
    for r in ok:
        if r.spec.mode == "reference" and r.spec.loop_channel is not None:
            key = (_plant_label(r.spec), repr(sorted(r.spec.compensator_spec.items())))
            groups.setdefault(key, []).append(r)
    seen = {}
    for (label, _), rs in groups.items():
        seen[label] = seen.get(label, 0) + 1
        curves = [{"label": r.name, "column": r.spec.loop_channel,
                   "x": _last_period(r.reference[r.spec.loop_channel], r.spec.period_samples),
                   "outputs": _last_period(r.outputs, r.spec.period_samples)} for r in rs]
        fig = plots.loop_grid(curves, [f"{n}_r [µm]" for n in out_names],
                              [f"{n} [µm]" for n in out_names],
                              f"{scenario.title}: compensated maps ({label} plant, last period)",
                              direct_label="compensated direct", cross_label="residual cross-coupling")
        fname = f"maps-compensated-{label}{'' if seen[label] == 1 else f'-{seen[label]}'}.png"
        plots.save(fig, directory / fname)
        comp = _compensator_summary(rs[0].spec)
        figs.append((f"Compensated input-output maps, {label} plant, compensator {comp}", fname))
    # diverged compensators
    for r in results:
        if r.divergence is not None:
            fig = plots.divergence_figure(r.inputs, in_names, r.divergence.sample,
                                          r.divergence.reason, f"{r.name}: compensator output until divergence")
            fname = f"divergence-{r.name}.png"
            plots.save(fig, directory / fname)
            figs.append((f"Case {r.name}: the compensator diverged at sample "
                         f"{r.divergence.sample} (t = {r.diverged_at * 1e3:.3g} ms)", fname))
    # trajectories
    traj = [r for r in ok if r.spec.mode == "reference" and r.spec.loop_channel is None]
    for r in traj:
        names = out_names[:2]
        settle = r.spec.settle_periods * r.spec.period_samples * r.spec.plant.sampling_period
        fig = plots.trajectory_figure(r.spec.time, r.reference[:2], r.outputs[:2], names,
                                      f"{scenario.title}: {r.name} ({_plant_label(r.spec)} plant)",
                                      settle_time=settle)
        fname = f"trajectory-{r.name}.png"
        plots.save(fig, directory / fname)
        figs.append((f"Case {r.name}: spatial domain, time domain, tracking error", fname))
    multi = traj
    if len(multi) > 1:
        curves = []
        for r in multi:
            start = int(round(r.spec.settle_periods * r.spec.period_samples))
            curves.append({"label": r.name, "reference": r.reference[:2, start:],
                           "outputs": r.outputs[:2, start:]})
        fig = plots.xy_overlay(curves, out_names[:2], f"{scenario.title}: trajectories (after settling)")
        plots.save(fig, directory / "xy-all.png")
        figs.append(("All trajectories after settling (dashed: references)", "xy-all.png"))
    return figs


def write_report(scenario, results, directory):
    """Write metrics.csv, the time series, the figures and report.md.

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
    results : list of hammerstein.scenario.execute.CaseResult
    directory : pathlib.Path
        Existing (temporary) directory to fill.
    """
    directory = Path(directory)
    frame = metrics_frame(results)
    frame.to_csv(directory / "metrics.csv", index=False)
    sweep_lines = sweep_report_lines(scenario, results, directory, frame)
    results = [r for r in results if getattr(r.spec, "sweep", None) is None]
    frame = frame[frame["case"].isin([r.name for r in results])]
    for r in results:
        timeseries_frame(r).to_csv(directory / f"timeseries-{r.name}.csv", index=False,
                                   float_format="%.6g")
    figs = _figures(scenario, results, directory) if results else []
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description.strip(), ""]
    lines += [f"Scenario `{scenario.path}` (name `{scenario.name}`, seed {scenario.seed}).",
              "Metrics are computed after `settle_periods` periods; loop metrics over the last "
              "full period. The Euclidean error is ||Y_r - Y|| per sample (NOTES §6; the "
              "paper's ε is not a distance and is not used).", "", "## Cases", ""]
    table = pd.DataFrame([{
        "case": r.name,
        "signal": _signal_summary(r.spec),
        "plant": f"{r.spec.plant_spec.get('preset')} ({_plant_label(r.spec)})",
        "compensator": _compensator_summary(r.spec),
        "samples": r.spec.time.size,
        "status": ("ok" if r.divergence is None else
                   f"DIVERGED at sample {r.divergence.sample} "
                   f"(t = {r.diverged_at * 1e3:.3g} ms): {r.divergence.reason}"),
    } for r in results])
    lines += [markdown_table(table), ""] if results else ["(sweep cases only; see below)", ""]
    notes = [(r.name, w) for r in results for w in dict.fromkeys(r.warnings)]
    if notes:
        lines += ["Warnings:", ""] + [f"- `{n}`: {w}" for n, w in notes] + [""]
    lines += ["## Figures", ""]
    for caption, fname in figs:
        lines += [f"### {caption}", "", f"![{caption}]({fname})", ""]
    lines += sweep_lines
    lines += ["## Metrics", "", "Long format in `metrics.csv`; time series in "
              "`timeseries-<case>.csv`.", ""]
    if not frame.empty:
        lines += [markdown_table(frame), ""]
    (directory / "report.md").write_text("\n".join(lines), encoding="utf-8")
