"""Sweep and stability-map reports: wide tables, figures, ``report.md`` sections.

Each ``[[sweeps]]`` table of a scenario (:class:`hammerstein.scenario.sweeps.SweepSpec`)
writes ``sweep-<name>.csv`` (:func:`sweep_table`: ``frequency_hz,
compensator, axis, channel`` then one column per metric) and
``sweep-<name>.png`` (:func:`sweep_figure`: the metric against frequency in
the p x m layout of the paper's Fig. 9, or one row for a metric of all
outputs together such as ``max_euclidean_error``, channel ``x+y``); a ``[stability_map]`` writes
``stability-map.csv`` and ``stability-map.png`` (:func:`stability_figure`).
:func:`sweep_report_lines` writes them all and returns the ``report.md``
sections.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hammerstein.core.files import safe_write
from hammerstein.signals.metrics import UNITS
from hammerstein.report import figures as plots
from hammerstein.report.definitions import plural
from hammerstein.report.messages import group_warnings
from hammerstein.report.render import FigureJobs
from hammerstein.report.tables import markdown_table, metrics_frame
from hammerstein.report.compensator_words import _compensator_title

__all__ = ["sweep_table", "sweep_figure", "stability_figure", "sweep_report_lines", "metric_label",
           "compensator_legend", "sweep_subject"]


_LETTERS = "abcdefghijklmnopqrstuvwxyz"
_POINTS = ["o", "s", "^", "v", "D", "x"]
_METRIC_LABELS = {
    "rms_error": "RMS error", "max_abs_error": "max |error|",
    "rms_error_percent": "RMS error", "model_rms_error": "model RMS error",
    "model_max_abs_error": "model max |error|", "peak_to_peak": "peak to peak",
    "hysteresis_width": "hysteresis width", "hysteresis_ratio": "hysteresis ratio h/H",
    "cross_coupling_peak_to_peak": "cross-coupling peak to peak",
    "max_euclidean_error": "max Euclidean error", "rms_euclidean_error": "RMS Euclidean error",
    "max_euclidean_error_percent": "max Euclidean error", "diverged_at_time": "divergence time",
}


def metric_label(metric):
    """A metric name in words for axis labels.

    Parameters
    ----------
    metric : str
        Column name of ``metrics.csv``, e.g. ``'model_rms_error'``.

    Returns
    -------
    str
        E.g. ``'model RMS error'``; unknown names with spaces for underscores.
    """
    return _METRIC_LABELS.get(metric, str(metric).replace("_", " "))


def _fmt(f):
    return f"{f:g}"


#: Units of the reference keys a sweep may vary, for its figure's axis.
_PARAMETER_UNITS = {"frequency": "Hz", "amplitude": "µm", "radius": "µm", "offset": "µm",
                    "phase": "deg", "duration": "s", "tau": "s", "settle": "s"}


def sweep_table(spec, metrics):
    """Wide table of one sweep.

    Parameters
    ----------
    spec : hammerstein.scenario.sweeps.SweepSpec
    metrics : pandas.DataFrame
        Long metrics (``case, channel, metric, value, unit``) of the scenario.

    Returns
    -------
    pandas.DataFrame
        One row per (case, channel): ``frequency_hz, compensator, axis,
        channel``, then one column per metric (units in
        :data:`hammerstein.signals.metrics.UNITS`); ordered by compensator, axis,
        channel, frequency. Diverged cases carry ``diverged_at_time`` [s].
    """
    index = pd.DataFrame(spec.cases)
    sub = metrics[metrics["case"].isin(index["case"])]
    if sub.empty:
        return index.assign(channel=pd.Series(dtype=object))[
            ["frequency_hz", "compensator", "axis", "channel"]]
    wide = sub.pivot_table(index=["case", "channel"], columns="metric", values="value",
                           aggfunc="first").reset_index()
    wide.columns.name = None
    out = index.merge(wide, on="case", how="left").drop(columns="case")
    metric_cols = [c for c in out.columns if c not in ("frequency_hz", "compensator", "axis", "channel")]
    order = {lab: k for k, lab in enumerate(dict.fromkeys(index["compensator"]))}
    out = out.assign(_o=out["compensator"].map(order)).sort_values(
        ["_o", "axis", "channel", "frequency_hz"], kind="stable").drop(columns="_o")
    return out[["frequency_hz", "compensator", "axis", "channel"] + metric_cols].reset_index(drop=True)


def _sweep_channels(table, metric, output_names):
    """The channels (panel rows) of a sweep figure: those holding a value of ``metric``.

    Per-output channels in ``output_names`` order, then the channels of all
    outputs together (``x+y``: the Euclidean metrics), each in a row of its
    own. When no channel holds a value (every case diverged), the outputs.
    """
    if metric in table:
        held = table.loc[table[metric].notna(), "channel"]
        held = list(dict.fromkeys(str(c) for c in held))
    else:
        held = []
    rows = [o for o in output_names if o in held] + [c for c in held if c not in output_names]
    return rows or list(output_names)


def _panel_title(spec, channel, k, axis, output_names):
    """What a sweep panel shows: channel, excitation, and whether it is the direct transfer."""
    if channel not in output_names:                      # all outputs together
        what = f"{channel} (all outputs together)"
        if axis == "-":
            return what
        return f"{what}, {axis}_r" if spec.mode == "reference" else f"{what}, drive {axis}"
    if axis == "-":                                       # one multi-axis reference or drive
        src = "the reference" if spec.mode == "reference" else "the drive"
        return f"{channel} for {src}"
    if spec.mode == "reference":
        direct, src = axis == channel, f"{axis}_r"
    else:
        direct, src = k == list(output_names).index(channel), axis
    return f"{'direct' if direct else 'cross-coupling'}: {channel} vs {src}"


def _compensator_words(c):
    """A sweep's compensator table in a few words: kind and where its model comes from."""
    kind = str(c.get("kind", "multivariable"))
    model = c.get("model", "plant")
    if model == "identified":
        ident = c.get("identify") or {}
        f = ident.get("frequency")
        if ident.get("records") == "excitation":
            where = "identified from the excitation records"
        elif ident.get("records") == "files":
            where = "identified from measured records"
        else:
            where = f"identified at {f:g} Hz" if isinstance(f, (int, float)) else "identified"
    elif model == "plant":
        where = "plant's model"
    else:
        where = f"model {Path(str(model)).name}"
    return f"{kind}, {where}"


def sweep_subject(spec, results):
    """What a sweep figure's title should name: signal and size, compensator, metric window.

    Parameters
    ----------
    spec : hammerstein.scenario.sweeps.SweepSpec
    results : list of hammerstein.scenario.execute.CaseResult

    Returns
    -------
    str
        E.g. ``"sine, amplitude 30 µm; multivariable, identified at 50 Hz; over
        the last 2 of 8 periods"`` (several compensators: their number; the
        legend names them); empty when no case of the sweep ran.
    """
    names = {c["case"] for c in spec.cases}
    first = next((r for r in results if r.name in names), None)
    if first is None:
        return ""
    sig = getattr(first.spec, "signal_spec", None) or {}
    parts = []
    size = next(((k, sig[k]) for k in ("amplitude", "radius", "size") if
                 isinstance(sig.get(k), (int, float)) and not isinstance(sig.get(k), bool)
                 and k != getattr(spec, "parameter", "frequency")), None)    # not the swept one
    unit = "V" if spec.mode == "drive" else "µm"
    what = str(sig.get("kind", "signal")) + (f", {size[0]} {size[1]:g} {unit}" if size else "")
    parts.append(what)
    labels = [lab for lab in spec.labels if lab]
    if len(labels) > 1:
        parts.append(f"{len(labels)} compensators")
    elif spec.mode != "drive" and getattr(first.spec, "compensator_spec", None):
        parts.append(_compensator_title(first.spec))
    periods = sig.get("periods")
    settle = getattr(first.spec, "settle_periods", None)
    if isinstance(periods, (int, float)) and isinstance(settle, (int, float)):
        parts.append(f"over the last {_fmt(periods - settle)} of {_fmt(periods)} periods")
    return "; ".join(parts)


def compensator_legend(spec, results):
    """Legend words of a sweep's compensator labels (``mv-50Hz`` -> ``multivariable, identified at 50 Hz``).

    Labels whose compensators read the same in words keep their label in
    brackets, so that the legend tells them apart.

    Parameters
    ----------
    spec : hammerstein.scenario.sweeps.SweepSpec
    results : list of hammerstein.scenario.execute.CaseResult

    Returns
    -------
    dict of str to str
        Label -> words; labels of no case are left out.
    """
    label_of = {c["case"]: c["compensator"] for c in spec.cases}
    words = {}
    for r in results:
        label = label_of.get(r.name)
        if label and label != "-" and label not in words:
            table = getattr(r.spec, "compensator_spec", None) or {}
            words[label] = _compensator_words(table)
    counts = pd.Series(list(words.values())).value_counts() if words else {}
    return {k: (f"{v} ({k})" if counts[v] > 1 else v) for k, v in words.items()}


def sweep_figure(table, spec, output_names, title, metric=None, names=None):
    """Metric against frequency, panel (l, k) = channel l for the excitation on axis k.

    The panel rows are the channels holding a value of the metric: the
    outputs for per-output metrics (the p x m layout of the paper's Fig. 9),
    the row of all outputs together (channel ``x+y``) for the Euclidean
    metrics.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`sweep_table` output.
    spec : hammerstein.scenario.sweeps.SweepSpec
    output_names : sequence of str
        The plant's outputs.
    title : str
    metric : str, optional
        Column to plot (default ``spec.metric``).
    names : dict of str to str, optional
        Legend words of the compensator labels (:func:`compensator_legend`);
        a label without words is shown as written.

    Returns
    -------
    matplotlib.figure.Figure
        Log-scaled metric axis when all values are positive; cases that
        diverged have no point; a panel without any value says so.
    """
    metric = metric or spec.metric
    axes_names = [a if a is not None else "-" for a in spec.axes]
    channels = _sweep_channels(table, metric, output_names)
    p, m = len(channels), len(axes_names)
    labels = list(dict.fromkeys(table["compensator"]))
    names = names or {}
    # one legend for the whole figure, under the title; none for a single unnamed series
    named = not (len(labels) == 1 and labels[0] in ("-", "", None))
    ncol = plots.legend_columns([names.get(lab, lab) for lab in labels],
                                plots.grid_width(m, 4.8), fontsize=8, most=3)
    band = (-(-len(labels) // ncol) * 0.2 + 0.15) if named else 0.0
    fig, axs = plots.grid_figure(p, m, title, panel_w=4.8, panel_h=3.3, extra_top=band)
    unit = UNITS.get(metric, "")
    what = metric_label(metric)
    handles = {}
    swept = getattr(spec, "parameter", "frequency")
    x = "frequency_hz" if swept == "frequency" else swept     # the table's column of the values
    for l, out in enumerate(channels):
        for k, axis in enumerate(axes_names):
            ax = axs[l][k]
            rows = table[(table["channel"] == out) & (table["axis"] == axis)]
            for j, lab in enumerate(labels):
                r = rows[rows["compensator"] == lab].sort_values(x)
                if metric in r and r[metric].notna().any():
                    style = {**plots._style(j), "marker": _POINTS[j % len(_POINTS)],
                             "markevery": None}           # every swept frequency is a point
                    line, = ax.plot(r[x], r[metric], label=names.get(lab, lab),
                                    **style)
                    handles.setdefault(lab, line)
            vals = rows[metric] if metric in rows else pd.Series(dtype=float)
            if vals.notna().any() and (vals.dropna() > 0).all():
                ax.set_yscale("log")
                plots.readable_log_ticks(ax, vals)       # the largest point under a label
            elif not vals.notna().any():
                ax.text(0.5, 0.5, f"no data: no case has a {what}\n(diverged or not computed)",
                        transform=ax.transAxes, ha="center", va="center", fontsize=9)
            panel = _panel_title(spec, out, k, axis, output_names)
            ax.set_title(f"({_LETTERS[(l * m + k) % 26]}) {panel}", fontsize=10, y=1.0)
            unit_x = _PARAMETER_UNITS.get(swept)
            ax.set_xlabel(f"{swept} [{unit_x}]" if unit_x else str(swept))
            ax.set_ylabel(f"{what}, {out} [{unit}]" if unit else f"{what}, {out}")
            ax.grid(True, which="major", alpha=0.3)
            ax.grid(True, which="minor", alpha=0.12)
    if named and handles:
        W, H = fig.get_size_inches()
        top = fig.subplotpars.top * H
        fig.legend(list(handles.values()), [h.get_label() for h in handles.values()],
                   loc="lower center", ncol=ncol,
                   fontsize=8, frameon=False, bbox_to_anchor=(0.5, (top + 0.3) / H))
    plots.suptitle(fig, title)
    return fig


def stability_figure(frame, title):
    """Largest ``rho(I - (s K)^-1 J)`` against the gain scaling s (log-log).

    Marks rho = 1 (convergence limit), s = 1 (normalised law, K the direct
    secant gains) and, per compensator, the paper's literal law K = I at its
    equivalent scale with its exact radius.

    Parameters
    ----------
    frame : pandas.DataFrame
        Stability map (:func:`hammerstein.scenario.sweeps.stability_map_frame`):
        columns ``compensator, scale, max_radius``; ``attrs['laws']`` maps a
        compensator label to its ``literal_scale``, ``literal_max_radius``
        and ``normalised_max_radius`` (each optional).
    title : str
        Axes title.

    Returns
    -------
    matplotlib.figure.Figure
        The caller saves and closes it.
    """
    plt = plots.plt
    W, legend_w = 11.0, 3.6
    top = plots._title_height(title, W) + 0.05
    fig, ax = plt.subplots(figsize=(W, top + 4.6 + 0.6))
    plots.fixed_layout(fig, left=0.8, right=legend_w, bottom=0.6, top=top)
    laws = frame.attrs.get("laws", {})
    for j, (label, g) in enumerate(frame.groupby("compensator", sort=False)):
        line, = ax.plot(g["scale"], g["max_radius"], label=f"{label}: max rho", **plots._style(j))
        law = laws.get(label, {})
        if "literal_scale" in law:
            ax.plot([law["literal_scale"]], [law["literal_max_radius"]], "v", color=line.get_color(),
                    markersize=9, label=f"{label}: literal law K = I (rho {law['literal_max_radius']:.3g})")
        if "normalised_max_radius" in law:
            ax.plot([1.0], [law["normalised_max_radius"]], "o", color=line.get_color(), markersize=8,
                    label=f"{label}: normalised law s = 1 (rho {law['normalised_max_radius']:.3g})")
    ax.axhline(1.0, color="k", linewidth=1, linestyle=":")
    ax.text(frame["scale"].min(), 1.05, "rho = 1: convergence limit", fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("gain scaling s (K = s x direct secant gains)")
    ax.set_ylabel("max rho(I - (sK)^-1 J) over reachable slopes")
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.12)
    # outside the axes, on the right: the curves fill the whole plot
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    plots.suptitle(fig, title)
    return fig


def _shown_columns(table):
    """The sweep table without its empty columns and the rows of no shown metric.

    The channels of the inputs (``ux``, ``uy``) hold only ``peak_input`` and
    ``peak_slew``, which the report's table does not show; a column without
    a value, or an ``axis`` column of ``-`` throughout (a reference on two
    axes), says nothing.
    """
    index = [c for c in ("frequency_hz", "compensator", "axis", "channel") if c in table]
    values = [c for c in table.columns if c not in index]
    out = table[table[values].notna().any(axis=1)] if values else table
    drop = [c for c in values if out[c].isna().all()]
    drop += [c for c in ("axis", "compensator") if c in out and (out[c] == "-").all()]
    return out.drop(columns=drop).reset_index(drop=True)


def _settle_line(results):
    """Where the metrics of a sweep's cases start (one line), or ''."""
    if not results:
        return ""
    settles = sorted({float(r.spec.settle_periods) for r in results})
    starts = {}
    for r in results:
        T = r.spec.plant.sampling_period
        f = (r.spec.signal_spec or {}).get("frequency")
        key = f if isinstance(f, (int, float)) else None
        starts[key] = int(round(r.spec.settle_periods * r.spec.period_samples)) * T
    periods = "/".join(f"{v:g}" for v in settles)
    words = f"Metrics from sample round(settle_periods × P), settle_periods = {periods} " \
            f"(counted from t = 0, the fade-in included)"
    known = sorted((f, t) for f, t in starts.items() if f is not None)
    if known:
        shown = known if len(known) <= 3 else [known[0], known[-1]]
        at = ", ".join(f"t ≥ {_time(t)} at {f:g} Hz" for f, t in shown)
        words += f": {at}" if len(known) <= 3 else f": from t ≥ {_time(shown[0][1])} at " \
            f"{shown[0][0]:g} Hz to t ≥ {_time(shown[1][1])} at {shown[1][0]:g} Hz"
    return words + "."


def _time(t):
    return f"{t:.4g} s" if t >= 1 else f"{t * 1e3:.4g} ms"


def _warning_lines(spec, results):
    """The warnings of a sweep's cases, one bullet per message template
    (:func:`hammerstein.report.messages.group_warnings`) naming the compensators,
    axes and frequencies of the cases it applies to."""
    groups = group_warnings((r.name, w) for r in results for w in dict.fromkeys(r.warnings))
    if not groups:
        return []
    by_case = {c["case"]: c for c in spec.cases}
    lines = ["Warnings:", ""]
    for g in groups:
        rows = [by_case[c] for c in g.cases if c in by_case]
        where = []
        labels = list(dict.fromkeys(str(r["compensator"]) for r in rows
                                    if r.get("compensator") not in (None, "-")))
        if labels:
            where.append(f"{'compensator' if len(labels) == 1 else 'compensators'} "
                         f"{', '.join(labels)}")
        axes = list(dict.fromkeys(str(r["axis"]) for r in rows if r.get("axis") not in (None, "-")))
        if axes and len(spec.axes) > 1:
            where.append(f"{'axis' if len(axes) == 1 else 'axes'} {', '.join(axes)}")
        values = sorted({float(r["frequency_hz"]) for r in rows
                         if isinstance(r.get("frequency_hz"), (int, float))})
        if values and len(spec.frequencies) > 1:
            unit = _PARAMETER_UNITS.get(getattr(spec, "parameter", "frequency"), "")
            where.append(", ".join(_fmt(v) for v in values) + (f" {unit}" if unit else ""))
        lines.append(f"- {plural(g.count, 'case')}" + (f" ({'; '.join(where)})" if where else "")
                     + f": {g.message}")
    return lines + [""]


def sweep_report_lines(scenario, results, directory, metrics=None, jobs=None):
    """Write the sweep CSVs/figures and the stability map of a scenario.

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
    results : list of hammerstein.scenario.execute.CaseResult
    directory : pathlib.Path
    metrics : pandas.DataFrame, optional
        Long metrics of ``results`` (computed when omitted).
    jobs : hammerstein.report.render.FigureJobs, optional
        Collects the figures (the caller waits for them); default: drawn here.

    Returns
    -------
    list of str
        Markdown lines for ``report.md`` (sections with the figures and the
        files written); empty when the scenario has no sweep and no map.
    """
    directory = Path(directory)
    specs = getattr(scenario, "sweeps", None) or []
    smap = getattr(scenario, "stability_map", None)
    if not specs and smap is None:
        return []
    if metrics is None:
        metrics = metrics_frame(results)
    jobs = FigureJobs() if jobs is None else jobs
    lines = []
    outputs = list(results[0].spec.plant.hysteresis.output_names) if results else []
    for spec in specs:
        table = sweep_table(spec, metrics)
        csv = f"sweep-{spec.name}.csv"
        swept = getattr(spec, "parameter", "frequency")
        if swept != "frequency":
            table = table.rename(columns={"frequency_hz": swept})
        safe_write(directory / csv, table.to_csv(index=False, float_format="%.6g"), "table")
        png = None
        if len(spec.frequencies) > 1:
            png = f"sweep-{spec.name}.png"
            several = sum(len(s.frequencies) > 1 for s in specs) > 1
            jobs.add(directory / png, sweep_figure, table, spec, outputs,
                     f"{plots.scenario_prefix(scenario)}: {metric_label(spec.metric)} "
                     f"vs {getattr(spec, 'parameter', 'frequency')}"
                     + (f" ({spec.name})" if several else "")
                     + (f" ({subject})" if (subject := sweep_subject(spec, results)) else ""),
                     names=compensator_legend(spec, results))
        n_div = int(table["diverged_at_time"].notna().groupby(
            [table["compensator"], table["axis"], table[swept if swept != "frequency" else
                                                        "frequency_hz"]]).any().sum()) \
            if "diverged_at_time" in table else 0
        lines += [f"## Sweep `{spec.name}`", ""]
        if spec.description:
            lines += [spec.description.strip(), ""]
        mine = [r for r in results if r.name in {c["case"] for c in spec.cases}]
        if spec.labels == [None]:      # the scenario's compensator: say which
            table0 = getattr(mine[0].spec, "compensator_spec", None) if mine else None
            what = [f"compensator: {_compensator_words(table0)}" if table0
                    else "no compensator (open-loop drives)"]
        else:
            what = [f"compensators {', '.join(spec.labels)}"]
        if spec.axes != [None]:
            what.append(f"axes {', '.join(str(a) for a in spec.axes)}")
        if spec.frequencies and getattr(spec, "parameter", "frequency") != "frequency":
            what.append(f"{spec.parameter} {', '.join(_fmt(f) for f in spec.frequencies)}")
        elif spec.frequencies:
            what.append(f"frequencies {', '.join(_fmt(f) for f in spec.frequencies)} Hz")
        lines += [f"{plural(len(spec.cases), 'case')}: {'; '.join(what)}. Table: `{csv}` "
                  f"(long rows also in `metrics.csv`). Diverged cases: {n_div}.", ""]
        settle = _settle_line(mine)
        if settle:
            lines += [settle, ""]
        if png:
            lines += [f"![{spec.metric} vs {getattr(spec, 'parameter', 'frequency')}]({png})", ""]
        else:  # a comparison of compensators: the table itself
            keep = [c for c in ("frequency_hz", "compensator", "axis", "channel", "rms_error",
                                "max_abs_error", "cross_coupling_peak_to_peak", "rms_euclidean_error",
                                "max_euclidean_error", "max_euclidean_error_percent",
                                "diverged_at_time") if c in table]
            lines += [markdown_table(_shown_columns(table[keep])), ""]
        lines += _warning_lines(spec, mine)
    if smap is not None:
        safe_write(directory / "stability-map.csv", smap.to_csv(index=False, float_format="%.6g"),
                   "table")
        jobs.add(directory / "stability-map.png", stability_figure, smap, f"{scenario.title}")
        laws = pd.DataFrame([{"compensator": k, **v} for k, v in smap.attrs.get("laws", {}).items()])
        lines += ["## Stability map", "",
                  "Largest spectral radius of the fixed-point iteration over the model's reachable "
                  "slope matrices against the gain scaling s (K = s x direct secant gains; "
                  "docs/compensator.md). Table: `stability-map.csv`.", "",
                  "![stability map](stability-map.png)", ""]
        if not laws.empty:
            lines += [markdown_table(laws), ""]
    return lines
