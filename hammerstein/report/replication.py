"""Replication report of the paper: ``hammerstein replicate``.

:func:`hammerstein.runner.replicate` runs every scenario of
``scenarios/paper/`` into ``reports/paper/<scenario>/``, then
:func:`write_readme` writes ``reports/paper/README.md``: every number the
paper publishes next to ours with their ratio (:data:`PAPER_NUMBERS`, read
from ``paper_numbers.toml`` beside this module; :func:`paper_comparison`),
the Fig. 7 and Fig. 9 trends (:func:`fig09_trends`, :func:`fig07_trends`),
the compensator family on the trajectories of Fig. 10-13
(:func:`family_comparison`), the figures in the paper's numbering, and a
discussion of where we differ and why (docs/compensator.md,
docs/metrics.md, docs/hammerstein-plant.md). Our numbers are always read
from the reports' ``metrics.csv`` files (pandas), never written into this
module.
"""

from __future__ import annotations

import io
import os
import re
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import all_or_nothing, bounded_read_bytes, safe_write
from hammerstein.report import figures as plots
from hammerstein.report.tables import markdown_table

__all__ = [
    "PAPER_NUMBERS",
    "read_metrics",
    "lookup",
    "paper_comparison",
    "family_comparison",
    "fig09_trends",
    "fig07_trends",
    "fig08_identified_figure",
    "GENERATED",
    "README_MARK",
    "foreign_outputs",
    "write_readme",
]

# scenario names (report directories)
FIG05, FIG07, FIG08, FIG09 = ("fig05-characterization", "fig07-model-rms-vs-frequency",
                              "fig08-compensated-sine", "fig09-compensation-rms-vs-frequency")
FIG10, FIG11, FIG12, FIG13 = ("fig10-circles", "fig11-spiral", "fig12-lissajous-3-2",
                              "fig13-lissajous-4-3")
LITERAL, STABILITY = "literal-law-divergence", "stability-map"

#: Every number the paper publishes, where we read ours (``paper_numbers.toml``
#: beside this module): ``figure, quantity, paper, unit, text, scenario, case,
#: channel, metric, factor, setting``. ``factor`` turns our metric into the
#: paper's quantity (0.5: a peak-to-peak into a ± half range). ``setting`` says
#: which of our experiments stands for it.
PAPER_NUMBERS = tomllib.loads(
    resources.files("hammerstein.report").joinpath("paper_numbers.toml").read_text(encoding="utf-8")
)["numbers"]


def read_metrics(root):
    """Read ``<root>/<scenario>/metrics.csv`` of every report directory.

    Parameters
    ----------
    root : str or pathlib.Path

    Returns
    -------
    dict of str to pandas.DataFrame
        Scenario name -> long metrics (``case, channel, metric, value, unit``).
    """
    root = Path(root)
    return {p.parent.name: pd.read_csv(p) for p in sorted(root.glob("*/metrics.csv"))}


def lookup(metrics, scenario, case, channel, metric):
    """One value of a long metrics table, or NaN when absent.

    Parameters
    ----------
    metrics : dict of str to pandas.DataFrame
        :func:`read_metrics` output.
    scenario, case, channel, metric : str

    Returns
    -------
    float
    """
    m = metrics.get(scenario)
    if m is None:
        return np.nan
    v = m[(m["case"] == case) & (m["channel"] == channel) & (m["metric"] == metric)]["value"]
    return float(v.iloc[0]) if len(v) else np.nan


def paper_comparison(metrics):
    """The paper's numbers next to ours with their ratio.

    Parameters
    ----------
    metrics : dict of str to pandas.DataFrame
        :func:`read_metrics` output.

    Returns
    -------
    pandas.DataFrame
        One row per :data:`PAPER_NUMBERS` entry: ``figure, quantity,
        setting, paper, ours, unit, ratio`` (ours / paper; NaN when the paper
        number is 0 or ours is missing) and ``source``
        (``scenario/case channel metric``).
    """
    rows = []
    for n in PAPER_NUMBERS:
        ours = lookup(metrics, n["scenario"], n["case"], n["channel"], n["metric"]) * n["factor"]
        ratio = ours / n["paper"] if n["paper"] else np.nan
        rows.append({"figure": n["figure"], "quantity": n["quantity"], "setting": n["setting"],
                     "paper": n["text"], "ours": ours, "unit": n["unit"], "ratio": ratio,
                     "source": f"{n['scenario']}/{n['case']} {n['channel']} {n['metric']}"
                               + (f" x {n['factor']:g}" if n["factor"] != 1 else "")})
    return pd.DataFrame(rows)


_FAMILY = re.compile(r"^family-(?P<trajectory>.+?)-(?P<compensator>mv1|mv3|diagonal|per-axis|static-gain)$")


def family_comparison(metrics):
    """The compensator family side by side on the trajectories (Fig. 10-13).

    Reads the cases ``family-<trajectory>-<label>`` (compensator sweeps of
    the trajectory scenarios).

    Parameters
    ----------
    metrics : dict of str to pandas.DataFrame
        :func:`read_metrics` output (scenario name -> long metrics).

    Returns
    -------
    pandas.DataFrame
        ``trajectory, compensator, max_euclidean_um, rms_euclidean_um,
        max_percent_of_radius, rms_x_um, rms_y_um``.
    """
    rows = []
    for scen in (FIG10, FIG11, FIG12, FIG13):
        m = metrics.get(scen)
        if m is None:
            continue
        for case in dict.fromkeys(m["case"]):
            g = _FAMILY.match(case)
            if not g:
                continue
            get = lambda ch, me: lookup(metrics, scen, case, ch, me)  # noqa: E731
            rows.append({"trajectory": g["trajectory"], "compensator": g["compensator"],
                         "max_euclidean_um": get("x+y", "max_euclidean_error"),
                         "rms_euclidean_um": get("x+y", "rms_euclidean_error"),
                         "max_percent_of_radius": get("x+y", "max_euclidean_error_percent"),
                         "rms_x_um": get("x", "rms_error"), "rms_y_um": get("y", "rms_error")})
    return pd.DataFrame(rows, columns=["trajectory", "compensator", "max_euclidean_um",
                                       "rms_euclidean_um", "max_percent_of_radius", "rms_x_um",
                                       "rms_y_um"])


_SWEEP = re.compile(r"^rms-(?P<label>.+)-(?P<axis>x|y)-(?P<f>[0-9.]+)Hz$")


def _fig09_long(metrics):
    m = metrics.get(FIG09)
    if m is None:
        return pd.DataFrame(columns=["label", "axis", "frequency_hz", "channel", "rms"])
    m = m[m["metric"] == "rms_error"]
    parts = m["case"].str.extract(_SWEEP.pattern)
    out = pd.DataFrame({"label": parts["label"], "axis": parts["axis"],
                        "frequency_hz": parts["f"].astype(float), "channel": m["channel"],
                        "rms": m["value"]}).dropna(subset=["label"])
    return out


def fig09_trends(metrics):
    """Fig. 9 trends: RMS error at chosen frequencies per compensator and transfer.

    Parameters
    ----------
    metrics : dict of str to pandas.DataFrame
        :func:`read_metrics` output (scenario name -> long metrics).

    Returns
    -------
    pandas.DataFrame
        One row per compensator label and transfer (``direct x`` = x for x_r,
        ``cross y_r->x``, ``cross x_r->y``, ``direct y``): RMS error [µm] at
        10, 50, 100, 200 and 420 Hz (NaN if not swept or diverged) and
        ``rise_200_over_50`` (their ratio).
    """
    long = _fig09_long(metrics)
    transfers = [("direct x", "x", "x"), ("cross y_r->x", "y", "x"), ("cross x_r->y", "x", "y"),
                 ("direct y", "y", "y")]
    rows = []
    for label in dict.fromkeys(long["label"]):
        for name, axis, ch in transfers:
            sel = long[(long["label"] == label) & (long["axis"] == axis) & (long["channel"] == ch)]
            at = {f: sel[sel["frequency_hz"] == f]["rms"] for f in (10.0, 50.0, 100.0, 200.0, 420.0)}
            row = {"compensator": label, "transfer": name}
            row.update({f"rms_{f:g}Hz": float(v.iloc[0]) if len(v) else np.nan for f, v in at.items()})
            row["rise_200_over_50"] = row["rms_200Hz"] / row["rms_50Hz"]
            rows.append(row)
    return pd.DataFrame(rows)


_FIG07 = re.compile(r"(?:^|-)u(?P<input>[a-z]+)-(?P<f>[0-9.]+)Hz$")  # ux-10Hz, <sweep>-ux-10Hz


def fig07_trends(metrics):
    """Fig. 7 trend: model RMS error (model identified at 50 Hz vs plant) per transfer.

    Parameters
    ----------
    metrics : dict of str to pandas.DataFrame
        :func:`read_metrics` output (scenario name -> long metrics).

    Returns
    -------
    pandas.DataFrame
        ``transfer`` (``<output> <- u<input>``), RMS [µm] at 10, 50, 200
        and 420 Hz and ``rise_200_over_50``; empty without the Fig. 7 report.
    """
    m = metrics.get(FIG07)
    if m is None:
        return pd.DataFrame()
    m = m[m["metric"] == "model_rms_error"]
    parts = m["case"].str.extract(_FIG07.pattern)
    long = pd.DataFrame({"input": parts["input"], "f": parts["f"].astype(float),
                         "channel": m["channel"], "rms": m["value"]}).dropna(subset=["input"])
    rows = []
    for (inp, ch), g in long.groupby(["input", "channel"], sort=False):
        row = {"transfer": f"{ch} <- u{inp}"}
        for f in (10.0, 50.0, 200.0, 420.0):
            v = g[g["f"] == f]["rms"]
            row[f"rms_{f:g}Hz"] = float(v.iloc[0]) if len(v) else np.nan
        row["rise_200_over_50"] = row["rms_200Hz"] / row["rms_50Hz"]
        rows.append(row)
    return pd.DataFrame(rows)


def fig08_identified_figure(report_dir, path):
    """Fig. 8 as in the paper: one curve per identification frequency.

    Reads ``timeseries-<case>.csv`` of the Fig. 8 report (cases ``x-axis``,
    ``y-axis`` for 50 Hz and ``id<f>Hz-<axis>-axis``) and draws the last
    period of each in the 2 x 2 compensated-map layout: the figure that
    ``hammerstein run`` writes as ``maps-compensated-hammerstein-by-identification.png``
    in that report, redrawn from the saved time series.

    Parameters
    ----------
    report_dir : pathlib.Path
        ``reports/paper/fig08-compensated-sine``.
    path : pathlib.Path
        PNG to write.

    Returns
    -------
    bool
        False when no time series was found (nothing written).
    """
    report_dir = Path(report_dir)
    curves = []
    for f in (50, 100, 150, 200):
        for k, axis in enumerate("xy"):
            name = f"{axis}-axis" if f == 50 else f"id{f}Hz-{axis}-axis"
            csv = report_dir / f"timeseries-{name}.csv"
            if not csv.exists():
                continue
            ts = pd.read_csv(csv)
            T = float(ts["time_s"].iloc[1] - ts["time_s"].iloc[0])
            P = int(round(1.0 / (f * T)))
            sl = slice(len(ts) - P - 1, len(ts))
            curves.append({"label": f"identified at {f} Hz, tested at {f} Hz", "column": k,
                           "x": ts[f"{axis}_ref_um"].to_numpy()[sl],
                           "outputs": np.vstack([ts["x_um"].to_numpy()[sl], ts["y_um"].to_numpy()[sl]])})
    if not curves:
        return False
    fig = plots.loop_grid(curves, ["x_r [µm]", "y_r [µm]"], ["x [µm]", "y [µm]"],
                          "Fig. 8: compensated maps, hammerstein plant, one compensator per "
                          "identification frequency (last period)",
                          direct_label="compensated direct", cross_label="residual cross-coupling")
    plots.save(fig, path)
    return True


def _fmt(v, digits=3):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "n/a"
    return f"{v:.{digits}g}"


def _table(df, digits=3):
    return markdown_table(df, floatfmt="{:.%dg}" % digits)


FIGURES = [
    ("Fig. 5", "open-loop hysteresis and cross-couplings (10 V, 50-200 Hz)", FIG05, "maps-open-loop-*.png"),
    ("Fig. 6", "model vs actuator loops at 50 Hz", "fig06-model-validation", "*.png"),
    ("Fig. 7", "RMS error of the 50 Hz model vs frequency", FIG07, "*.png"),
    ("Fig. 8", "compensated maps (per identification frequency; static plant)", FIG08, "maps-compensated-*.png"),
    ("Fig. 9", "RMS error vs frequency of the compensators", FIG09, "sweep-*.png"),
    ("Fig. 10", "circles", FIG10, "*.png"),
    ("Fig. 11", "spiral", FIG11, "*.png"),
    ("Fig. 12", "Lissajous 3/2", FIG12, "*.png"),
    ("Fig. 13", "Lissajous 4/3", FIG13, "*.png"),
    ("Theorem 4.1", "the literal law diverges", LITERAL, "*.png"),
    ("docs/compensator.md", "stability map: rho vs gain scaling", STABILITY, "*.png"),
]


#: Files :func:`write_readme` writes at the root of the replication directory.
GENERATED = ("README.md", "paper-numbers.csv", "family-comparison.csv", "fig09-trends.csv",
             "fig07-trends.csv", "fig08-identified-maps.png")
#: Text every README of :func:`write_readme` holds: the mark that replicate wrote it.
README_MARK = "Generated by `hammerstein replicate`"


def foreign_outputs(root):
    """Files of :data:`GENERATED` under ``root`` that ``hammerstein replicate`` did not write.

    ``README.md`` is ours when it holds :data:`README_MARK`; the other files
    are ours when they sit next to such a README. A file that is not a
    regular file (directory, FIFO, device, dangling symlink) is never ours.

    Parameters
    ----------
    root : str or pathlib.Path
        Replication directory.

    Returns
    -------
    list of str
        One line per file that :func:`write_readme` would replace but may not.
    """
    root = Path(root)
    try:
        readme_ours = README_MARK.encode() in bounded_read_bytes(root / "README.md", "toml", "README")
    except (OSError, ValueError):
        readme_ours = False
    problems = []
    for name in GENERATED:
        p = root / name
        if not os.path.lexists(p):
            continue
        if not p.is_file():
            problems.append(f"{p}: exists and is not a regular file")
        elif not readme_ours:
            problems.append(f"{p}: exists and was not written by hammerstein replicate")
    return problems


def write_readme(root, outcomes=None):
    """Write ``<root>/README.md`` from the reports under ``root``.

    Parameters
    ----------
    root : str or pathlib.Path
        Directory holding ``<scenario>/metrics.csv`` report directories.
    outcomes : list of ScenarioOutcome, optional
        Failed scenarios are listed.

    Returns
    -------
    pathlib.Path
        The README. Also writes ``paper-numbers.csv``, ``fig09-trends.csv``,
        ``fig07-trends.csv`` and ``family-comparison.csv`` beside it, and
        ``fig08-identified-maps.png`` when the Fig. 8 time series exist.
    """
    root = Path(root)
    metrics = read_metrics(root)
    comp = paper_comparison(metrics)
    fam = family_comparison(metrics)
    t9 = fig09_trends(metrics)
    t7 = fig07_trends(metrics)
    png = io.BytesIO()
    fig8 = (root / FIG08).is_dir() and fig08_identified_figure(root / FIG08, png)

    L = ["# Replication of Rakotondrabe, multivariable classical Prandtl-Ishlinskii (reports/paper)", "",
         "Generated by `hammerstein replicate` from `scenarios/paper/*.toml` (one report "
         "directory per scenario below; every number here is read from their `metrics.csv`). "
         "Plants: *static* = the paper's identified 2x2 PI model alone (rate independent); "
         "*Hammerstein* = that PI followed by the bending modes of the preset (x 310 Hz / ζ 0.15, "
         "y 290 Hz / ζ 0.20). Compensators on the Hammerstein actuator are built from models "
         "identified on it at 50 Hz (least squares, monotone branches, midpoint gain) as the "
         "paper did on its actuator, unless stated.", ""]
    if outcomes:
        failed = [o for o in outcomes if not o.ok]
        if failed:
            L += ["**Scenarios that failed:**", ""] + [f"- `{o.path}`: {o.error}" for o in failed] + [""]
    L += ["## 1. The paper's numbers and ours", "",
          "`ratio` = ours / paper. ± values are half the peak-to-peak range. The paper's trajectory "
          "errors are its ε = sgn(θ)√|θ|, which is not a distance (docs/metrics.md); ours are the Euclidean "
          "error ‖Y_r − Y‖ (max over the settled window).", "",
          _table(comp.assign(paper=comp["paper"].str.replace("|", "\\|", regex=False))), ""]
    # trends
    L += ["## 2. Trends (Fig. 7 and Fig. 9)", ""]
    if not t7.empty:
        L += ["**Fig. 7** (paper: the model error stays low at and below the identification "
              "frequency, 50 Hz, and rises steeply above it). RMS error [µm] between the actuator "
              "and the model identified at 50 Hz, 10 V drives:", "", _table(t7), ""]
    else:
        L += [f"**Fig. 7**: no `model_rms_error` cases found in `{FIG07}`.", ""]
    if not t9.empty:
        L += ["**Fig. 9** (paper: errors lowest for the compensators identified at 50 and 100 Hz, "
              "near and below their identification frequency, rising substantially above it; the "
              "per-axis method [20] does not reduce the cross-couplings). RMS error [µm] of each "
              "transfer (50 µm sine references) at selected frequencies; full table "
              "`fig09-trends.csv` and the sweep in "
              f"`{FIG09}/sweep-rms.csv`:", "", _table(t9), ""]
        L += _fig09_reading(t9)
    # family
    L += ["## 3. The compensator family on the trajectories (Fig. 10-13)", "",
          "Same reference, compensators built from the model identified at 50 Hz: mv1 / mv3 = "
          "multivariable with 1 / 3 fixed-point iterations per sample, diagonal = the same law on "
          "the direct transfers only, per-axis = Kuhnen-Janocha inverse of each direct transfer "
          "(paper ref. [20]), static-gain = U = K⁻¹ Y_r (no hysteresis compensation). Errors "
          "after settling; percent of the radius / amplitude.", ""]
    L += [_table(fam), ""] if not fam.empty else ["(no family cases found)", ""]
    if not fam.empty and {"mv1", "mv3"} <= set(fam["compensator"]):
        w = fam.pivot(index="trajectory", columns="compensator", values="rms_euclidean_um")
        r = (w["mv3"] / w["mv1"]).dropna()
        L += [f"Three fixed-point iterations per sample instead of one change the RMS Euclidean error "
              f"by a factor {_fmt(r.min(), 2)}-{_fmt(r.max(), 2)} over these trajectories (on the "
              f"Hammerstein actuator the remaining error is mostly the bending modes' phase lag, "
              f"which no iteration removes).", ""]
    # figures
    L += ["## 4. Figures in the paper's numbering", ""]
    for num, caption, scen, pattern in FIGURES:
        d = root / scen
        pngs = sorted(d.glob(pattern)) if d.is_dir() else []
        if num == "Fig. 8" and fig8:
            L += [f"### {num}: compensated maps, one curve per identification frequency", "",
                  "![Fig. 8](fig08-identified-maps.png)", ""]
        if not pngs:
            continue
        L += [f"### {num}: {caption}", "", f"Report: [`{scen}/report.md`]({scen}/report.md)", ""]
        L += [f"![{num} {p.name}]({scen}/{p.name})" for p in pngs[:6]] + [""]
        if len(pngs) > 6:
            L += [f"(and {len(pngs) - 6} more in `{scen}/`)", ""]
    L += _discussion(metrics, comp, fam)
    with all_or_nothing():      # the README and its tables together, or none of them
        return _write_files(root, L, comp, fam, t9, t7, png if fig8 else None)


def _write_files(root, L, comp, fam, t9, t7, png):
    for name, frame in (("paper-numbers.csv", comp), ("family-comparison.csv", fam),
                        ("fig09-trends.csv", t9), ("fig07-trends.csv", t7)):
        safe_write(root / name, frame.to_csv(index=False, float_format="%.6g"), "CSV file", root=root)
    if png is not None:
        safe_write(root / "fig08-identified-maps.png", png.getvalue(), "figure", root=root)
    return safe_write(root / "README.md", "\n".join(L), "README", root=root)


def _fig09_reading(t9):
    """Sentences on the Fig. 9 trends, computed from the table."""
    L = []
    def get(label, transfer, col):
        r = t9[(t9["compensator"] == label) & (t9["transfer"] == transfer)]
        return float(r[col].iloc[0]) if len(r) else np.nan
    mv, pa, sg = "mv-50Hz", "per-axis-50Hz", "static-gain-50Hz"
    if mv in set(t9["compensator"]):
        rise = [get(mv, t, "rise_200_over_50") for t in ("direct x", "direct y")]
        L += [f"- Multivariable compensator identified at 50 Hz: direct RMS error "
              f"{_fmt(get(mv, 'direct x', 'rms_10Hz'))} / {_fmt(get(mv, 'direct y', 'rms_10Hz'))} µm "
              f"(x / y) at 10 Hz, {_fmt(get(mv, 'direct x', 'rms_50Hz'))} / "
              f"{_fmt(get(mv, 'direct y', 'rms_50Hz'))} µm at 50 Hz, rising "
              f"{_fmt(rise[0], 2)}x / {_fmt(rise[1], 2)}x by 200 Hz and reaching "
              f"{_fmt(get(mv, 'direct x', 'rms_420Hz'))} / {_fmt(get(mv, 'direct y', 'rms_420Hz'))} µm "
              f"at 420 Hz (towards the bending modes)."]
    if pa in set(t9["compensator"]) and sg in set(t9["compensator"]):
        for tr in ("cross y_r->x", "cross x_r->y"):
            L += [f"- {tr} at 50 Hz: per-axis {_fmt(get(pa, tr, 'rms_50Hz'))} µm vs uncompensated "
                  f"(static gain) {_fmt(get(sg, tr, 'rms_50Hz'))} µm vs multivariable "
                  f"{_fmt(get(mv, tr, 'rms_50Hz'))} µm: the per-axis baseline leaves the "
                  f"cross-coupling at {100 * get(pa, tr, 'rms_50Hz') / get(sg, tr, 'rms_50Hz'):.0f} % "
                  f"of its uncompensated level, the multivariable law cuts it "
                  f"{_fmt(get(pa, tr, 'rms_50Hz') / get(mv, tr, 'rms_50Hz'), 2)}x below the baseline."]
    hi = [lab for lab in ("mv-150Hz", "mv-200Hz") if lab in set(t9["compensator"])]
    for lab in hi:
        L += [f"- {lab}: direct x RMS {_fmt(get(lab, 'direct x', 'rms_10Hz'))} µm at 10 Hz and "
              f"{_fmt(get(lab, 'direct x', 'rms_50Hz'))} µm at 50 Hz (vs "
              f"{_fmt(get(mv, 'direct x', 'rms_50Hz'))} µm for mv-50Hz): identified where the "
              f"phase lag bends the loops, it is worse below its identification frequency, as in the "
              f"paper; its rho(I - K⁻¹J) is about 1, so 1 iteration per sample barely contracts."]
    return L + [""]


def _discussion(metrics, comp, fam):
    def ours(scen, case, ch, me):
        return lookup(metrics, scen, case, ch, me)
    lit = ours(LITERAL, "literal-K-identity", "x+y", "diverged_at_time")
    s50 = ours(FIG10, "circle-50um-static", "x+y", "max_euclidean_error_percent")
    h50 = ours(FIG10, "circle-50um", "x+y", "max_euclidean_error_percent")
    hx = ours(FIG05, "ux-50Hz", "x", "hysteresis_ratio")
    sx = ours(FIG05, "ux-50Hz-static", "x", "hysteresis_ratio")
    L = ["## 5. Where we differ, and why", "",
         f"- **The compensator law (docs/compensator.md).** Theorem 4.1 as printed, U(t) = Y_r(t) + U(t−T) − "
         f"Γ(U(t−T)), is a fixed-point iteration that converges only if ρ(I − J) < 1; the model's "
         f"direct slopes are 3.6-9.9 µm/V, so ρ reaches 3-9 and the literal law diverges (here at "
         f"t = {_fmt(lit * 1e3 if np.isfinite(lit) else np.nan)} ms, `{LITERAL}`). Everything above "
         f"uses the normalised law U(t) = U(t−T) + K⁻¹(Y_r(t) − Γ(U(t−T))) (K = direct secant gains "
         f"for the paper's model, the midpoint gains for identified models); the stability map "
         f"(`{STABILITY}`) shows where both sit.",
         "- **The error measure (docs/metrics.md).** The paper's ε = sgn(θ)√|θ|, θ = (x_r + y_r)² − (x + y)², "
         "is not a distance (it reports several µm for a 0.3 µm error and can vanish for a large one). "
         "We report the Euclidean error ‖Y_r − Y‖ and per-axis errors, so our trajectory percentages "
         "and the paper's 2 % are not the same measure; the ratios above compare them anyway.",
         f"- **Phase lag of the simulated actuator (docs/hammerstein-plant.md).** The paper gives only a 400-500 Hz "
         f"bandwidth; our bending modes add 3-4° of lag at 50 Hz, which widens the 50 Hz loops "
         f"(h/H x {_fmt(hx)} % on the Hammerstein actuator against {_fmt(sx)} % for the paper's model "
         f"alone). A model identified on the actuator at 50 Hz absorbs that lag at 50 Hz and at the "
         f"10 V identification amplitude only: on 50 µm references at other frequencies, and on the "
         f"minor loops of the 15 and 30 µm circles, the rate-independent compensator cannot cancel it, "
         f"so our Hammerstein trajectory errors ({_fmt(h50)} % on the 50 µm circle) are several times "
         f"the paper's 2 %, while the compensator alone on the static plant reaches {_fmt(s50)} %. "
         f"For the same reason its error also rises somewhat *below* 50 Hz, which the paper's data "
         f"show much less.",
         "- **Models identified at 150-200 Hz.** On our actuator they need least squares with monotone "
         "branches (otherwise negative slopes, not invertible) and the midpoint gain; even then "
         "ρ(I − K⁻¹J) ≈ 1.0, so they are run with `check = \"warn\"` and a divergence would be "
         "reported as a result (`diverged_at_time`).",
         "- **What reproduces.** The open-loop numbers of Fig. 5 on the paper's model, the linearised "
         "direct transfers and ±0.1-0.2 µm residual cross-couplings of Fig. 8 on the static plant, the "
         "shape of Fig. 7 and Fig. 9 (low error near and below the identification frequency, steep "
         "rise towards the bending modes), and the central claim: the multivariable compensator "
         "removes cross-couplings that the per-axis inverse [20] leaves at their uncompensated level.",
         ""]
    return L
