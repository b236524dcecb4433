"""Report of a Monte-Carlo robustness study (``[[sweeps]] kind = "monte-carlo"``).

Per study ``<name>``: ``montecarlo-<name>.csv`` (:func:`quantile_table`:
``frequency_hz, channel, metric, p50, p95, p99, max, unit, cases, diverged,
quantiles``, the last column ``exact`` or ``histogram``),
``montecarlo-<name>.png`` (:func:`quantile_figure`: P50/P95/P99/max of each
metric against frequency) and, while every case's metrics are kept,
``montecarlo-<name>-cases.csv`` (``case, frequency_hz`` then one column per
``<channel>:<metric>``). ``metrics.csv`` holds the quantiles in the long
format of every report (case = study name, metric
``<metric>_<p50|p95|p99|max>_at_<f>Hz``), so ``hammerstein check`` gates
them like any metric.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import safe_write
from hammerstein.report import figures as plots
from hammerstein.report.scenario import compensator_summary
from hammerstein.report.tables import markdown_table, metrics_frame

__all__ = ["quantile_table", "quantile_figure", "write_montecarlo_report"]

_TAGS = ("p50", "p95", "p99", "max")


def _vary_words(quantity, spec):
    """``weights: relative sd 1 % (normal)``, ``noise: sd 0.02 µm`` (not the Python dict)."""
    if "sd" in spec:
        return f"{quantity}: sd {spec['sd']:g} µm"
    return (f"{quantity}: relative sd {100 * spec['relative_sd']:g} % "
            f"({spec.get('distribution', 'normal')})")


def quantile_table(result):
    """The quantiles of one study as a table.

    Parameters
    ----------
    result : hammerstein.scenario.montecarlo.MonteCarloResult

    Returns
    -------
    pandas.DataFrame
        One row per (frequency, channel, metric): ``frequency_hz, channel,
        metric, p50, p95, p99, max`` [µm], ``unit``, ``cases``, ``diverged``,
        ``quantiles`` (``exact`` or ``histogram``).
    """
    s = result.study
    rows = []
    for j, f in enumerate(s.frequencies):
        for c, (ch, met) in enumerate(s.columns):
            rows.append({"frequency_hz": f, "channel": ch, "metric": met,
                         **{t: result.quantiles[a, j, c] for a, t in enumerate(_TAGS)},
                         "unit": "µm", "cases": s.cases, "diverged": int(result.diverged[j]),
                         "quantiles": "exact" if result.exact else "histogram"})
    return pd.DataFrame(rows)


def quantile_figure(table, title):
    """P50, P95, P99 and max of each metric against frequency, one panel per (channel, metric).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`quantile_table` output.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        Log-scaled error axes when all plotted values are positive and finite
        (infinite values, diverged runs, are not drawn); each y axis names its
        metric; where P99 is the largest case everywhere (fewer than 100
        cases) one line is drawn, labelled ``MAX = P99``.
    """
    panels = list(dict.fromkeys(zip(table["channel"], table["metric"])))
    # with fewer than 100 cases P99 is the largest case: one line, said so in the legend (the
    # P99 line hid under MAX's)
    p99, top = table["p99"].to_numpy(dtype=float), table["max"].to_numpy(dtype=float)
    same = bool(np.all((p99 == top) | ~(np.isfinite(p99) & np.isfinite(top))))
    ncol = 2
    nrow = -(-len(panels) // ncol)
    fig, axs = plots.grid_figure(nrow, ncol, title, panel_w=4.6, panel_h=3.0, extra_top=0.3)
    for n, (ch, met) in enumerate(panels):
        ax = axs[n // ncol][n % ncol]
        rows = table[(table["channel"] == ch) & (table["metric"] == met)].sort_values("frequency_hz")
        for j, tag in enumerate(_TAGS):
            if same and tag == "p99":
                continue
            v = rows[tag].to_numpy(dtype=float)
            ok = np.isfinite(v)
            label = "MAX = P99" if same and tag == "max" else tag.upper()
            ax.plot(rows["frequency_hz"].to_numpy()[ok], v[ok], label=label,
                    **{**plots._style(j), "marker": "os^D"[j], "markevery": None})
        vals = rows[list(_TAGS)].to_numpy(dtype=float)
        vals = vals[np.isfinite(vals)]
        if vals.size and (vals > 0).all():
            ax.set_yscale("log")
            plots.plain_log_labels(ax.yaxis)
        ax.set_title(f"{met.replace('_', ' ')}, {ch}", fontsize=10)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"{met.replace('_', ' ')} [µm]")
        ax.grid(True, alpha=0.3)
        if n == 0:
            ax.legend(fontsize=8, ncol=4)
    for n in range(len(panels), nrow * ncol):
        axs[n // ncol][n % ncol].set_visible(False)
    plots.suptitle(fig, title)
    return fig


def write_montecarlo_report(scenario, results, directory, jobs):
    """Write metrics.csv, the quantile tables and figures and report.md of a study.

    Parameters
    ----------
    scenario : hammerstein.scenario.montecarlo.MonteCarloScenario
    results : list of hammerstein.scenario.montecarlo.MonteCarloResult
    directory : pathlib.Path
        The (temporary) report directory.
    jobs : hammerstein.report.render.FigureJobs
        Receives the figures.
    """
    directory = Path(directory)
    safe_write(directory / "metrics.csv", metrics_frame(results).to_csv(index=False), "metrics file")
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description, ""]
    lines += [f"Monte-Carlo robustness study: the compensator "
              f"({compensator_summary(scenario.compensator_spec)}) is "
              f"built once from the nominal model and run against plants drawn around it "
              f"(seed {scenario.seed}; case i depends only on the seed and i).", ""]
    loop = results[0].study.loop if results and getattr(scenario, "feedback", None) else None
    if loop is not None:                 # [feedback]: hammerstein.scenario.montecarlo
        ctrl, sensor, amp = loop[0], loop[1], loop[2]
        lines += ["Every drawn plant runs in closed loop, the compensator as feedforward; the "
                  "loop is designed on the nominal plant: "
                  + "; ".join(ctrl.descriptions) + f". Sensor: {1e3 * sensor.noise_rms:g} nm RMS, "
                  + (f"{sensor.bandwidth_hz:g} Hz low-pass" if sensor.bandwidth_hz else
                     "no low-pass") + f", delay {sensor.delay} samples; amplifier: "
                  + ("no limits" if amp is None else
                     f"range {np.min(amp.low):g} to {np.max(amp.high):g} V") + "; anti-windup "
                  f"{loop[3]}. Errors are those of the true position.", ""]
    for res in results:
        s = res.study
        table = quantile_table(res)
        safe_write(directory / f"montecarlo-{s.name}.csv", table.to_csv(index=False), "table")
        png = directory / f"montecarlo-{s.name}.png"
        jobs.add(png, quantile_figure, table,
                 f"{scenario.title}: {s.name}, {s.cases} plants x {len(s.frequencies)} frequencies")
        if res.values is not None:
            cols = [f"{ch}:{m}" for ch, m in s.columns]
            n, F, M = res.values.shape
            frame = pd.DataFrame(res.values.reshape(n * F, M), columns=cols)
            frame.insert(0, "frequency_hz", np.tile(np.asarray(s.frequencies), n))
            frame.insert(0, "case", np.repeat(np.arange(n), F))
            safe_write(directory / f"montecarlo-{s.name}-cases.csv", frame.to_csv(index=False),
                       "table")
        vary = ", ".join(_vary_words(k, v) for k, v in s.vary.items()) or \
            "nothing (every plant the nominal one)"
        lines += [f"## {s.name}", ""] + ([s.description.strip(), ""] if s.description else []) + [
                  f"{s.cases} plants x {len(s.frequencies)} frequencies; varied: {vary}. "
                  f"Quantiles {'exact' if res.exact else 'from the streaming histogram'}; "
                  f"diverged runs: {int(res.diverged.sum())}.", "",
                  f"![{s.name}]({png.name})", "",
                  markdown_table(table[["frequency_hz", "channel", "metric", "p50", "p95", "p99",
                                        "max", "diverged"]]), ""]
        if res.warnings:
            lines += ["Warnings of the nominal build:", ""] + [f"- {w}" for w in res.warnings] + [""]
    safe_write(directory / "report.md", "\n".join(lines), "report")
