"""Report of a feedback scenario: side-by-side errors, the loop's S and T, the stability check.

:func:`write_feedback_report` writes ``metrics.csv`` (case ``<case>.<mode>``),
``feedback-errors.csv`` (one row per case and mode, the RMS and settled max
errors side by side; ``sweep-<sweep>.csv`` the rows of each sweep; the cases
outside sweeps their ``timeseries-<case>.<mode>.csv``), one figure per reference kind (sweep) with the RMS and
max error against frequency for feedforward alone, feedback alone and both
(:func:`error_frequency_figure`), the linearised loop's figure
(:func:`loop_figure`: ``|S|``, ``|T|`` and noise-to-position per axis) and
``report.md``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import safe_write
from hammerstein.report import figures as plots
from hammerstein.report.shared_model import one_model_lines, shares_model
from hammerstein.report.tables import markdown_table, metrics_frame
from hammerstein.scenario.feedback import MODE_LABELS

__all__ = ["write_feedback_report", "error_table", "error_frequency_figure", "loop_figure"]

_RMS = "rms_euclidean_error"
_MAX = "max_euclidean_error_percent"


def _value(rows, metric):
    for r in rows:
        if r["metric"] == metric:
            return float(r["value"])
    return float("nan")


def error_table(results):
    """One row per case and mode: sweep, compensator, frequency, RMS and settled max errors.

    Parameters
    ----------
    results : list of hammerstein.scenario.feedback.FeedbackCaseResult

    Returns
    -------
    pandas.DataFrame
        Columns ``sweep, case, compensator, frequency_hz, mode,
        rms_error_um, max_error_percent``.
    """
    rows = []
    for r in results:
        sw = r.case.sweep or {}
        rows.append({"sweep": sw.get("sweep", "cases"), "case": r.case.name,
                     "compensator": sw.get("compensator") or "",
                     "frequency_hz": sw.get("frequency_hz", np.nan), "mode": r.mode,
                     "rms_error_um": _value(r.metrics, _RMS),
                     "max_error_percent": _value(r.metrics, _MAX)})
    return pd.DataFrame(rows)


def error_frequency_figure(table, title):
    """RMS and settled max error against frequency, one line per feedforward and mode.

    Parameters
    ----------
    table : pandas.DataFrame
        The rows of one sweep (:func:`error_table`).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        Two panels (RMS [µm], max [% of the radius or amplitude]), log axes.
    """
    fig, axs = plots.grid_figure(1, 2, title, panel_w=4.8, panel_h=3.4, extra_top=0.5)
    groups = list(dict.fromkeys(zip(table["compensator"], table["mode"])))
    markers = {"feedforward": "o", "feedback": "s", "both": "^"}
    for j, (comp, mode) in enumerate(groups):
        rows = table[(table["compensator"] == comp) & (table["mode"] == mode)]
        rows = rows.sort_values("frequency_hz")
        label = MODE_LABELS[mode] + (f" ({comp})" if comp and mode != "feedback" else "")
        if mode == "feedback" and j and any(g[1] == "feedback" for g in groups[:j]):
            continue                           # feedback alone does not depend on the feedforward
        for ax, col in zip(axs[0], ("rms_error_um", "max_error_percent")):
            f = rows["frequency_hz"].to_numpy(float)
            v = rows[col].to_numpy(float)
            ok = np.isfinite(v) & (v > 0)
            ax.plot(f[ok], v[ok], label=label, **{**plots._style(j), "marker": markers[mode],
                                                  "markevery": None})
    for ax, lab in zip(axs[0], ("RMS error [µm]", "settled max error [%]")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(lab)
        ax.grid(True, which="both", alpha=0.3)
    axs[0][1].axhline(0.3, color="0.4", lw=0.8, ls=":")
    handles, labels = axs[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=2, fontsize=7,
               bbox_to_anchor=(0.5, 1.0 - 0.55 / fig.get_figheight()))
    return fig


def loop_figure(analysis, title):
    """``|S|``, ``|T|`` and the noise-to-position gain of each axis of the linearised loop.

    Parameters
    ----------
    analysis : dict
        :func:`hammerstein.scenario.feedback.loop_analysis` output.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        One panel per axis, magnitudes in dB against frequency [Hz].
    """
    names = analysis["outputs"]
    fig, axs = plots.grid_figure(1, len(names), title, panel_w=4.6, panel_h=3.4)
    f = analysis["frequency_hz"]
    for l, name in enumerate(names):
        ax = axs[0][l]
        for j, (key, lab) in enumerate((("S", "|S| (reference to error)"),
                                        ("T", "|T| (reference to position)"),
                                        ("N", "noise to position"))):
            ax.semilogx(f, 20 * np.log10(np.maximum(analysis[key][l], 1e-12)), label=lab,
                        **{**plots._style(j), "markevery": None, "marker": None})
        m = analysis["margins"][l]
        ax.set_title(f"{name}: GM {20 * np.log10(m['gain_margin']):.1f} dB, "
                     f"PM {m['phase_margin']:.0f}°, crossover {m['gain_crossover_hz']:.0f} Hz",
                     fontsize=9)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("magnitude [dB]")
        ax.set_ylim(-60, 15)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    return fig


def _bandwidth_words(b):
    """``5000 Hz`` (one value per axis or a list), ``no low-pass`` without one."""
    if b is None or b == "unlimited":
        return "no low-pass"
    return f"{b} Hz" if not isinstance(b, list) else f"{b} Hz".replace("'unlimited'", "none")


def _side_by_side(table):
    # a [[cases]] row has no sweep frequency: kept as "-" (a NaN key drops the row from the
    # pivot, and the cases' table came out empty)
    table = table.assign(frequency_hz=[("-" if pd.isna(v) else v) for v in table["frequency_hz"]])
    wide = table.pivot_table(index=["sweep", "compensator", "frequency_hz", "case"],
                             columns="mode", values=["rms_error_um", "max_error_percent"])
    wide.columns = [f"{'RMS µm' if a == 'rms_error_um' else 'max %'} {b}" for a, b in wide.columns]
    order = [c for m in ("feedforward", "feedback", "both") for c in wide.columns
             if c.endswith(" " + m)]
    return wide[order].reset_index()


def _timeseries(result):
    case = result.case
    model = case.plant.hysteresis
    cols = {"time_s": case.time}
    for l, name in enumerate(model.output_names):
        cols[f"{name}_ref_um"] = result.reference[l]
        cols[f"{name}_um"] = result.outputs[l]
    for k, name in enumerate(model.input_names):
        cols[f"{name}_V"] = result.inputs[k]
    return pd.DataFrame(cols)


def _one_model(results):
    """The **One model:** paragraph of the cases whose plant is their feedforward's model
    (the cases report has it: a user's report showed the feedforward alone at 0.007 %
    where the stage it stood for was at 4.3 %), or []."""
    cases = [r.case for r in results if r.mode == "feedforward" and r.case.compensator is not None]
    shared = [c.name for c in cases if shares_model(c.plant, c.compensator)]
    return one_model_lines(shared, len(cases), "; the feedback's errors are those of the loop "
                                               "around that same model")


def write_feedback_report(scenario, results, directory, jobs):
    """Write metrics.csv, feedback-errors.csv, sweep-<sweep>.csv, the figures and report.md.

    Cases outside a sweep also get ``timeseries-<case>.<mode>.csv`` (time,
    reference, position, applied voltages).

    Parameters
    ----------
    scenario : hammerstein.scenario.feedback_table.FeedbackScenario
        Run (with ``analysis`` and ``timing``).
    results : list of hammerstein.scenario.feedback.FeedbackCaseResult
    directory : pathlib.Path
        The (temporary) report directory.
    jobs : hammerstein.report.render.FigureJobs
        Receives the figures.
    """
    directory = Path(directory)
    safe_write(directory / "metrics.csv", metrics_frame(results).to_csv(index=False), "metrics table")
    table = error_table(results)
    safe_write(directory / "feedback-errors.csv", table.to_csv(index=False), "error table")
    for sweep in dict.fromkeys(table["sweep"]):
        if sweep != "cases":
            safe_write(directory / f"sweep-{sweep}.csv",
                       table[table["sweep"] == sweep].to_csv(index=False), "sweep table")
    for r in results:                    # the cases outside sweeps: their time series
        if r.case.sweep is None:
            safe_write(directory / f"timeseries-{r.name}.csv", _timeseries(r).to_csv(index=False),
                       "time series")
    a = scenario.analysis
    t = scenario.table
    s = a.get("sensor", t.get("sensor", {}))          # the preset's hardware with the table's keys
    amp = a.get("amplifier", t.get("amplifier", {}))
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description, ""]
    lines += _one_model(results)
    lines += ["Each case runs three ways in the compiled closed-loop kernel: the feedforward "
              "alone (open loop through the amplifier), the feedback alone, and both. Errors "
              "are those of the true position (not the measurement) over the settled window.", "",
              "## Loop", ""]
    lines += [f"- controller, axis {n}: {d}" for n, d in zip(a["outputs"], a["descriptions"])]
    lines += [f"- discretisation: {t.get('method', 'tustin')}; anti-windup: "
              f"{t.get('anti_windup', 'back-calculation')}",
              f"- sensor: {s.get('noise_nm', 0.0):g} nm RMS white noise, bandwidth "
              f"{_bandwidth_words(s.get('bandwidth_hz'))}, delay {s.get('delay', 0)} samples; "
              f"the reference passes through the same filter and delay",
              f"- amplifier: range {amp.get('range', 'unlimited')} V, slew rate "
              f"{amp.get('slew_rate', 'unlimited')} V/s",
              f"- noise to position (linearised): "
              + ", ".join(f"{n} {v:.1f} nm RMS" for n, v in zip(a["outputs"], a["noise_nm"])), ""]
    st = a["stability"]
    lines += ["### Stability check (hysteresis slope range as a sector)", "",
              f"{'Passed' if st['passed'] else 'NOT passed'}: {st['summary']}.", ""]
    mt = pd.DataFrame([{"axis": n, "gain margin [dB]": 20 * np.log10(m["gain_margin"]),
                        "phase margin [deg]": m["phase_margin"],
                        "gain crossover [Hz]": m["gain_crossover_hz"],
                        "phase crossover [Hz]": m["phase_crossover_hz"]}
                       for n, m in zip(a["outputs"], a["margins"])])
    lines += [markdown_table(mt), ""]
    png = directory / "feedback-loop.png"
    jobs.add(png, loop_figure, a, f"{scenario.title}: linearised loop (hysteresis at its "
                                  f"secant gains)")
    lines += [f"![loop]({png.name})", "", "## Errors", ""]
    for sweep in dict.fromkeys(table["sweep"]):
        rows = table[table["sweep"] == sweep]
        if rows["frequency_hz"].notna().sum() > 1 and rows["frequency_hz"].nunique() > 1:
            fig_png = directory / f"feedback-{sweep}.png"
            jobs.add(fig_png, error_frequency_figure, rows,
                     f"{scenario.title}: {sweep}, error against frequency")
            lines += [f"### {sweep}", "", f"![{sweep}]({fig_png.name})", ""]
        else:
            lines += [f"### {sweep}", ""]
        lines += [markdown_table(_side_by_side(rows)), ""]
    tm = scenario.timing
    lines += ["## Timing", "",
              f"{len(results)} runs, {tm['samples']} samples in {tm['wall_s']:.2f} s of wall "
              f"time; {tm['kernel_s_per_sample'] * 1e6:.2f} µs per sample in the kernel, the "
              f"median over the runs (a first run also compiles the kernel when numba's "
              f"cache is cold).", ""]
    safe_write(directory / "report.md", "\n".join(lines), "report")
