"""Frequency sweeps in scenarios: expansion, batched simulation, tables, figures.

A ``[[sweeps]]`` table is a case template without ``frequency`` plus a list
of ``frequencies`` [Hz] (and optionally several compensators side by side)::

    [[sweeps]]
    name = "rms"
    frequencies = [10.0, 50.0, 100.0, 200.0, 420.0]
    reference = { kind = "sine", output = ["x", "y"], amplitude = 50.0, periods = 6 }
    settle_periods = 4
    compensators = { mv-50Hz = { kind = "multivariable" }, per-axis = { kind = "per-axis" } }

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
compensators of sweep cases in batches on the compiled batch kernel
(:func:`hammerstein.simulation.simulate_chain_batch`, both cores), the
others case by case, with a progress bar on a terminal
(:func:`hammerstein.progress.progress`, quiet off-terminal).

A top-level ``[stability_map]`` table (``scales`` = list of gain scalings s,
or ``{ start, stop, num }`` log-spaced; optional ``compensators`` as above,
default the scenario's ``[compensator]``) writes ``stability-map.csv`` and
``stability-map.png``: the largest ``rho(I - (s K)^-1 J)`` against s
(:func:`hammerstein.stability.stability_map`, NOTES §4), with the
normalised law (s = 1) and the paper's literal law (K = I) marked.
"""

from __future__ import annotations

import copy
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.scenario.schema import NAME, Field, Invalid, check_table, number, string

__all__ = [
    "SweepSpec",
    "expand_sweeps",
    "sweep_table",
    "sweep_figure",
    "run_cases",
    "run_scenario_cases",
    "check_stability_map",
    "sweep_report_lines",
    "BATCH_SIZE",
]

#: Sweep cases per call of the batch kernel (the progress bar moves per batch).
BATCH_SIZE = 16


@dataclass
class SweepSpec:
    """A validated ``[[sweeps]]`` table.

    Attributes
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
    cases : list of dict
        ``{case, compensator, axis, frequency_hz}`` per expanded case.
    """

    name: str
    mode: str
    frequencies: list
    labels: list
    axes: list
    metric: str = "rms_error"
    description: str = ""
    cases: list = field(default_factory=list)


def _frequencies(v):
    if (isinstance(v, list) and v and all(isinstance(f, (int, float)) and not isinstance(f, bool)
                                          and np.isfinite(f) and f > 0 for f in v)):
        if len(set(v)) != len(v):
            raise Invalid(f"expected distinct frequencies [Hz], found duplicates in {v!r}")
        return [float(f) for f in v]
    raise Invalid(f"expected a non-empty list of positive frequencies [Hz], found {v!r}")


def _labelled_tables(v):
    import re
    if not isinstance(v, dict) or not v:
        raise Invalid(f"expected a table of label = {{ kind = ... }} compensator tables, found {v!r}")
    for label, table in v.items():
        if not re.fullmatch(NAME, label):
            raise Invalid(f"label {label!r}: expected letters, digits, '.', '_' or '-'")
        if not isinstance(table, dict):
            raise Invalid(f"{label}: expected a compensator table, found {table!r}")
    return v


_OWN = {
    "name": Field(string(NAME, "a name of letters, digits, '.', '_' or '-'"), required=True),
    "description": Field(string()),
    "frequencies": Field(_frequencies),
    "compensators": Field(_labelled_tables),
    "metric": Field(string(), default="rms_error"),
}


def _fmt(f):
    return f"{f:g}"


def expand_sweeps(sweeps, source, problems):
    """Expand ``[[sweeps]]`` tables into raw case tables.

    Parameters
    ----------
    sweeps : object
        The parsed ``sweeps`` value (a list of tables).
    source : str
        File name, for the problem lines.
    problems : list of str
        Receives ``source: sweeps[i].key: message`` lines.

    Returns
    -------
    entries : list of (str, dict)
        ``(where, raw case table)`` for the scenario loader; ``where`` reads
        ``sweeps[i](<case name>)``.
    specs : list of SweepSpec
    """
    from hammerstein.scenario.schema import CASE
    if not isinstance(sweeps, list) or not all(isinstance(s, dict) for s in sweeps):
        problems.append(f"{source}: sweeps: expected one or more [[sweeps]] tables")
        return [], []
    case_keys = {k: f for k, f in CASE.items() if k != "name"}
    schema = {**case_keys, **_OWN}
    entries, specs = [], []
    for i, raw in enumerate(sweeps):
        where = f"sweeps[{i}]"
        n0 = len(problems)
        clean = check_table(raw, schema, where, problems, source)
        if clean is None or len(problems) > n0:
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
        if freqs is None and not clean.get("compensators"):
            problems.append(f"{source}: {where}: expected frequencies = [...] [Hz], "
                            f"compensators = {{ label = {{...}} }}, or both")
            continue
        if freqs is not None and ("frequency" in sig or "frequencies" in sig):
            problems.append(f"{source}: {where}.{mode}.frequency: given by the sweep's "
                            f"frequencies; remove it from the template")
            continue
        axis_key = "output" if mode == "reference" else "input"
        axes = sig.get(axis_key)
        axes = axes if isinstance(axes, list) and axes else [axes]
        comps = clean.get("compensators")
        labels = list(comps) if comps else [None]
        template = {k: copy.deepcopy(raw[k]) for k in case_keys if k in raw}
        spec = SweepSpec(clean["name"], mode, freqs or [], labels,
                         axes, clean["metric"], clean.get("description", ""))
        for label in labels:
            for axis in axes:
                for f in freqs or [None]:
                    parts = [clean["name"]] + ([label] if label else []) + \
                            ([str(axis)] if len(axes) > 1 else []) + \
                            ([f"{_fmt(f)}Hz"] if f is not None else [])
                    case = copy.deepcopy(template)
                    case["name"] = "-".join(parts)
                    case[mode] = dict(sig) if f is None else {**sig, "frequency": f}
                    if axis is not None:
                        case[mode][axis_key] = axis
                    if label:  # merged into the template's override like any case override
                        base = case.get("compensator", {})
                        same = comps[label].get("kind", base.get("kind")) == base.get("kind")
                        case["compensator"] = {**base, **comps[label]} if same else dict(comps[label])
                    entries.append((f"{where}({case['name']})", case))
                    spec.cases.append({"case": case["name"], "compensator": label or "-",
                                       "axis": "-" if axis is None else str(axis),
                                       "frequency_hz": sig.get("frequency", np.nan)
                                       if f is None else f})
        specs.append(spec)
    return entries, specs


# -- simulation -------------------------------------------------------------------------
def run_cases(cases, desc="cases"):
    """Simulate every case of a scenario; sweep cases batched where possible.

    Parameters
    ----------
    cases : list of hammerstein.scenarios.CaseSpec
    desc : str
        Label of the progress bar (shown only on a terminal).

    Returns
    -------
    list of hammerstein.runner.CaseResult
        In the order of ``cases``; divergences are results.
    """
    from hammerstein.core.compensators import check_reference_range
    from hammerstein.scenario.progress import progress
    from hammerstein.runner import chain_result, run_case
    from hammerstein.simulation import _fusable, simulate_chain_batch
    results = [None] * len(cases)
    batchable = [i for i, c in enumerate(cases)
                 if getattr(c, "sweep", None) is not None and c.mode == "reference"
                 and _fusable(c.compensator)]
    rest = [i for i in range(len(cases)) if i not in set(batchable)]
    n_sweep = sum(1 for c in cases if getattr(c, "sweep", None) is not None)
    bar = progress(total=len(cases), desc=desc, unit="case") if n_sweep else None
    try:
        # long cases first, so the batches hold similar work
        batchable.sort(key=lambda i: -cases[i].signal.shape[1])
        for start in range(0, len(batchable), BATCH_SIZE):
            chunk = batchable[start:start + BATCH_SIZE]
            caught = {}
            for i in chunk:
                with warnings.catch_warnings(record=True) as rec:
                    warnings.simplefilter("always")
                    check_reference_range(cases[i].compensator.model, cases[i].signal)
                caught[i] = list(cases[i].warnings) + [str(w.message) for w in rec]
            outs = simulate_chain_batch([cases[i].compensator for i in chunk],
                                        [cases[i].plant for i in chunk],
                                        [cases[i].signal for i in chunk])
            for i, res in zip(chunk, outs):
                results[i] = chain_result(cases[i], res, caught[i])
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
    """:func:`run_cases` on a scenario's cases (the runner's "cases" kind)."""
    return run_cases(scenario.cases, desc=scenario.name)


# -- tables and figures -----------------------------------------------------------------
def sweep_table(spec, metrics):
    """Wide table of one sweep.

    Parameters
    ----------
    spec : SweepSpec
    metrics : pandas.DataFrame
        Long metrics (``case, channel, metric, value, unit``) of the scenario.

    Returns
    -------
    pandas.DataFrame
        One row per (case, channel): ``frequency_hz, compensator, axis,
        channel``, then one column per metric (units in
        :data:`hammerstein.metrics.UNITS`); ordered by compensator, axis,
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


def sweep_figure(table, spec, output_names, title, metric=None):
    """Metric against frequency, panel (l, k) = output l for the excitation on axis k.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`sweep_table` output.
    spec : SweepSpec
    output_names : sequence of str
        The plant's outputs (panel rows).
    title : str
    metric : str, optional
        Column to plot (default ``spec.metric``).

    Returns
    -------
    matplotlib.figure.Figure
        Log-scaled metric axis when all values are positive; cases that
        diverged have no point.
    """
    from hammerstein.report import figures as plots
    from hammerstein.core.metrics import UNITS
    plt = plots.plt
    metric = metric or spec.metric
    axes_names = [a if a is not None else "-" for a in spec.axes]
    p, m = len(output_names), len(axes_names)
    fig, axs = plt.subplots(p, m, figsize=(4.8 * m, 3.6 * p), squeeze=False)
    letters = "abcdefghijklmnopqrstuvwxyz"
    unit = UNITS.get(metric, "")
    for l, out in enumerate(output_names):
        for k, axis in enumerate(axes_names):
            ax = axs[l][k]
            rows = table[(table["channel"] == out) & (table["axis"] == axis)]
            for j, lab in enumerate(dict.fromkeys(table["compensator"])):
                r = rows[rows["compensator"] == lab].sort_values("frequency_hz")
                if metric in r and r[metric].notna().any():
                    ax.plot(r["frequency_hz"], r[metric], label=lab, **plots._style(j))
            vals = rows[metric] if metric in rows else pd.Series(dtype=float)
            if vals.notna().any() and (vals.dropna() > 0).all():
                ax.set_yscale("log")
            direct = (spec.mode == "reference" and axis == out) or \
                     (spec.mode == "drive" and k == l)
            src = f"{axis}_r" if spec.mode == "reference" else axis
            kind = "direct" if direct else "cross-coupling"
            ax.set_title(f"({letters[l * m + k]}) {kind}: {out} vs {src}", fontsize=10)
            ax.set_xlabel("frequency [Hz]")
            ax.set_ylabel(f"{metric} of {out} [{unit}]" if unit else f"{metric} of {out}")
            ax.grid(True, which="both", alpha=0.3)
            if ax.lines:
                ax.legend(fontsize=7, loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


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


def check_stability_map(table, plant, compensator_top, base_dir, problems, source):
    """Validate a ``[stability_map]`` table and compute the maps.

    Parameters
    ----------
    table : object
        Parsed ``stability_map`` value.
    plant : HammersteinPlant or None
        The scenario's top-level plant (identified models are identified on it).
    compensator_top : dict
        The scenario's ``[compensator]`` table (default compensator).
    base_dir : pathlib.Path
    problems : list of str
    source : str

    Returns
    -------
    pandas.DataFrame or None
        Columns ``compensator, scale, max_radius, min_radius, converges``
        and ``K_<output>``; ``attrs['laws']`` maps each label to its
        ``literal_scale``, ``literal_max_radius``, ``normalised_max_radius``.
    """
    from hammerstein.runner import build_compensator
    from hammerstein.core.stability import stability_map
    clean = check_table(table, STABILITY, "stability_map", problems, source)
    if clean is None or "scales" not in clean or plant is None:
        return None
    comps = clean.get("compensators") or {"compensator": compensator_top}
    frames, laws = [], {}
    for label, spec in comps.items():
        spec = {**spec, "check": "ignore"} if spec.get("kind", "none") in ("multivariable", "diagonal") \
            else spec
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                comp = build_compensator(spec, plant, base_dir)
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


def stability_figure(frame, title):
    """Largest ``rho(I - (s K)^-1 J)`` against the gain scaling s (log-log).

    Marks rho = 1 (convergence limit), s = 1 (normalised law, K the direct
    secant gains) and, per compensator, the paper's literal law K = I at its
    equivalent scale with its exact radius.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from hammerstein.report import figures as plots
    plt = plots.plt
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
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
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


# -- report outputs ---------------------------------------------------------------------
def sweep_report_lines(scenario, results, directory, metrics=None):
    """Write the sweep CSVs/figures and the stability map of a scenario.

    Parameters
    ----------
    scenario : hammerstein.scenarios.Scenario
    results : list of hammerstein.runner.CaseResult
    directory : pathlib.Path
    metrics : pandas.DataFrame, optional
        Long metrics of ``results`` (computed when omitted).

    Returns
    -------
    list of str
        Markdown lines for ``report.md`` (sections with the figures and the
        files written); empty when the scenario has no sweep and no map.
    """
    from hammerstein.report import figures as plots
    from hammerstein.report.scenario import markdown_table, metrics_frame
    directory = Path(directory)
    specs = getattr(scenario, "sweeps", None) or []
    smap = getattr(scenario, "stability_map", None)
    if not specs and smap is None:
        return []
    if metrics is None:
        metrics = metrics_frame(results)
    lines = []
    outputs = list(results[0].spec.plant.hysteresis.output_names) if results else []
    for spec in specs:
        table = sweep_table(spec, metrics)
        csv = f"sweep-{spec.name}.csv"
        table.to_csv(directory / csv, index=False, float_format="%.6g")
        png = None
        if len(spec.frequencies) > 1:
            png = f"sweep-{spec.name}.png"
            fig = sweep_figure(table, spec, outputs,
                               f"{scenario.title}: {spec.metric} vs frequency ({spec.name})")
            plots.save(fig, directory / png)
        n_div = int(table["diverged_at_time"].notna().groupby(
            [table["compensator"], table["axis"], table["frequency_hz"]]).any().sum()) \
            if "diverged_at_time" in table else 0
        lines += [f"## Sweep `{spec.name}`", ""]
        if spec.description:
            lines += [spec.description.strip(), ""]
        what = [f"compensators {', '.join(l or '-' for l in spec.labels)}"]
        if spec.axes != [None]:
            what.append(f"axes {', '.join(str(a) for a in spec.axes)}")
        if spec.frequencies:
            what.append(f"frequencies {', '.join(_fmt(f) for f in spec.frequencies)} Hz")
        lines += [f"{len(spec.cases)} cases: {'; '.join(what)}. Table: `{csv}` "
                  f"(long rows also in `metrics.csv`). Diverged cases: {n_div}.", ""]
        if png:
            lines += [f"![{spec.metric} vs frequency]({png})", ""]
        else:  # a comparison of compensators: the table itself
            keep = [c for c in ("frequency_hz", "compensator", "axis", "channel", "rms_error",
                                "max_abs_error", "cross_coupling_peak_to_peak", "rms_euclidean_error",
                                "max_euclidean_error", "max_euclidean_error_percent",
                                "diverged_at_time") if c in table]
            lines += [markdown_table(table[keep]), ""]
        names = [c["case"] for c in spec.cases]
        warned = {}
        for r in results:
            if r.name in names:
                for w in dict.fromkeys(r.warnings):
                    warned[w] = warned.get(w, 0) + 1
        if warned:
            lines += ["Warnings:", ""] + [f"- {n} case(s): {w}" for w, n in warned.items()] + [""]
    if smap is not None:
        smap.to_csv(directory / "stability-map.csv", index=False, float_format="%.6g")
        plots.save(stability_figure(smap, f"{scenario.title}"), directory / "stability-map.png")
        laws = pd.DataFrame([{"compensator": k, **v} for k, v in smap.attrs.get("laws", {}).items()])
        lines += ["## Stability map", "",
                  "Largest spectral radius of the fixed-point iteration over the model's reachable "
                  "slope matrices against the gain scaling s (K = s x direct secant gains; "
                  "NOTES §4). Table: `stability-map.csv`.", "",
                  "![stability map](stability-map.png)", ""]
        if not laws.empty:
            lines += [markdown_table(laws), ""]
    return lines
