"""The regression gate: compare scenario metrics with a stored baseline.

A *metrics table* is the long format of ``metrics.csv`` written by the
runner: columns ``case, channel, metric, value, unit`` (one row per metric
of a case and a channel), optionally with a leading ``scenario`` column.

A *baseline file* is ONE CSV holding the metrics of several scenarios: the
columns ``scenario, case, channel, metric, value, unit``, one row per
metric, the key ``(scenario, case, channel, metric)`` unique. Values are
written with full precision (pandas round-trip repr), so an unchanged
program compares with delta 0. ``hammerstein check --update`` rewrites the
rows of the scenarios it ran and keeps the others (atomically: a temporary
file in the same directory, then a rename).

Tolerances (issue 6, item 5): a metric ``moved`` when
``|current - baseline| > atol + rtol * |baseline|`` (the convention of
:func:`numpy.isclose`). Its direction decides whether the move is a
regression: for errors, cross-couplings and hysteresis widths larger is
worse (``"lower"`` is better), and so for a drive's ``peak_slew``; for
neutral metrics (``peak_to_peak``, ``peak_input``, unknown metrics) any move
beyond tolerance is a regression.
"""

from __future__ import annotations

import io
import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import (FileLimitError, bounded_read_bytes, bounded_read_text,
                                    escape, provenance_line, safe_write)
from hammerstein.exceptions import BaselineError
from hammerstein.io.table_checks import check_size

__all__ = [
    "BaselineError",
    "Tolerance",
    "DEFAULT_TOLERANCES",
    "STATUSES",
    "KEY_COLUMNS",
    "BASELINE_COLUMNS",
    "default_tolerance",
    "resolve_tolerances",
    "load_tolerances",
    "compare_metrics",
    "is_regression",
    "summary_line",
    "read_baseline",
    "write_baseline",
    "merge_baseline",
]

#: Statuses of a compared metric.
STATUSES = ("ok", "regressed", "improved", "missing", "new")
#: Key of a metric row.
KEY_COLUMNS = ["scenario", "case", "channel", "metric"]
#: Columns of a baseline file, in order.
BASELINE_COLUMNS = ["scenario", "case", "channel", "metric", "value", "unit"]
#: Metric whose appearance means a case diverged (the runner's convention).
DIVERGENCE_METRIC = "diverged_at_time"
_DIRECTIONS = ("lower", "higher", "neutral")


@dataclass(frozen=True)
class Tolerance:
    """Allowed move of one metric.

    Parameters
    ----------
    rtol : float
        Relative tolerance [-] (0.05 = 5 %), of ``|baseline|``.
    atol : float
        Absolute tolerance, in the metric's unit (µm, %, s).
    direction : {'lower', 'higher', 'neutral'}
        Which values are better: ``'lower'`` (errors: a rise beyond
        tolerance regresses, a fall improves), ``'higher'``, or
        ``'neutral'`` (any move beyond tolerance regresses).
    """

    rtol: float
    atol: float
    direction: str = "neutral"

    def allowed(self, baseline):
        """Largest accepted ``|current - baseline|`` for a baseline value.

        Parameters
        ----------
        baseline : float
            The baseline value of the metric, in its unit (µm, %, s).

        Returns
        -------
        float
            ``atol + rtol * |baseline|``, in the metric's unit.
        """
        return self.atol + self.rtol * abs(baseline)


_ERROR = Tolerance(rtol=0.05, atol=0.01, direction="lower")        # µm
_RATIO = Tolerance(rtol=0.05, atol=0.2, direction="lower")         # %

#: Default tolerance per metric name; ``"*"`` applies to unknown metrics.
DEFAULT_TOLERANCES = {
    "rms_error": _ERROR,
    "max_abs_error": _ERROR,
    "rms_euclidean_error": _ERROR,
    "max_euclidean_error": _ERROR,
    "cross_coupling_peak_to_peak": _ERROR,
    "hysteresis_width": _ERROR,
    "rms_error_percent": _RATIO,
    "max_euclidean_error_percent": _RATIO,
    "hysteresis_ratio": _RATIO,
    "peak_to_peak": Tolerance(rtol=0.01, atol=0.01, direction="neutral"),
    # a drive's fastest step [V/s]: slower is gentler on the amplifier, never a regression
    # by itself (a drive that stopped following shows in the errors); faster beyond 5 % is
    "peak_slew": Tolerance(rtol=0.05, atol=1e-9, direction="lower"),
    # a divergence that moves by more than two 50 µs samples
    DIVERGENCE_METRIC: Tolerance(rtol=0.0, atol=1e-4, direction="neutral"),
    "*": Tolerance(rtol=0.05, atol=1e-9, direction="neutral"),
}


def default_tolerance(metric):
    """Default tolerance of a metric name.

    A name of :data:`DEFAULT_TOLERANCES`; otherwise a name containing
    ``error`` or starting with ``cross_coupling`` is an error (lower is
    better; ``*_percent``: the ratio tolerance, else the µm one); anything
    else gets the ``"*"`` entry (neutral).

    Parameters
    ----------
    metric : str

    Returns
    -------
    Tolerance
    """
    if metric in DEFAULT_TOLERANCES:
        return DEFAULT_TOLERANCES[metric]
    if "error" in metric or metric.startswith("cross_coupling"):
        return _RATIO if metric.endswith("_percent") else _ERROR
    return DEFAULT_TOLERANCES["*"]


def _number(value, where):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BaselineError(f"{where}: expected a number, found {value!r}")
    if not (math.isfinite(value) and value >= 0):
        raise BaselineError(f"{where}: expected a finite number >= 0, found {value!r}")
    return float(value)


def resolve_tolerances(overrides=None, rtol=None, atol=None):
    """Tolerance of every metric: defaults, then overrides.

    Parameters
    ----------
    overrides : dict, optional
        ``{metric name or "*": {"rtol": float, "atol": float, "direction":
        str}}``; each given field replaces the default of that metric
        (``"*"``: of every metric, before the metric-specific entries).
    rtol, atol : float, optional
        Replace the relative / absolute tolerance of every metric (the
        command line's ``--rtol`` / ``--atol``), after the overrides.

    Returns
    -------
    callable
        ``tolerance(metric: str) -> Tolerance``.

    Raises
    ------
    BaselineError
        On an unknown field, a negative or non-numeric tolerance, or an
        unknown direction (names the metric and the field).
    """
    overrides = {} if overrides is None else overrides
    if not isinstance(overrides, dict):
        raise BaselineError(f"tolerances: expected a table of metrics, found {overrides!r}")
    parsed = {}
    for metric, spec in overrides.items():
        if not isinstance(spec, dict):
            raise BaselineError(
                f"tolerances: {metric}: expected a table with rtol/atol/direction, found {spec!r}")
        fields = {}
        for key, value in spec.items():
            where = f"tolerances: {metric}.{key}"
            if key in ("rtol", "atol"):
                fields[key] = _number(value, where)
            elif key == "direction":
                if value not in _DIRECTIONS:
                    raise BaselineError(
                        f"{where}: expected one of {', '.join(_DIRECTIONS)}, found {value!r}")
                fields[key] = value
            else:
                raise BaselineError(f"{where}: unknown field (expected rtol, atol or direction)")
        parsed[str(metric)] = fields
    glob = {}
    if rtol is not None:
        glob["rtol"] = _number(rtol, "--rtol")
    if atol is not None:
        glob["atol"] = _number(atol, "--atol")

    def tolerance(metric):
        tol = default_tolerance(metric)
        tol = replace(tol, **parsed.get("*", {}))
        tol = replace(tol, **parsed.get(metric, {}))
        return replace(tol, **glob)

    return tolerance


def load_tolerances(path):
    """Read tolerance overrides from a TOML file.

    The file holds one table per metric name (or ``["*"]`` for all), e.g.
    ``[rms_error]`` with ``rtol = 0.1`` and ``atol = 0.02``.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    dict
        Suitable for :func:`resolve_tolerances`.

    Raises
    ------
    BaselineError
        If the file is missing or not valid TOML.
    """
    path = Path(path)
    try:
        table = tomllib.loads(bounded_read_text(path, "toml", "tolerance file"))
    except FileNotFoundError:
        raise BaselineError(f"{path}: tolerance file not found") from None
    except FileLimitError as exc:
        raise BaselineError(str(exc)) from None
    except UnicodeDecodeError:
        raise BaselineError(f"{path}: not a readable TOML file (not UTF-8 text)") from None
    except RecursionError:
        raise BaselineError(f"{path}: not a readable TOML file (nested too deeply)") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise BaselineError(f"{path}: not a readable TOML file ({exc})") from None
    resolve_tolerances(table)  # validate now, with the file's name in the error
    return table


def _normalise(frame, name):
    """Validated copy of a metrics table with a ``scenario`` column."""
    if not isinstance(frame, pd.DataFrame):
        raise BaselineError(f"{name}: expected a pandas DataFrame, found {type(frame).__name__}")
    missing = [c for c in BASELINE_COLUMNS[1:] if c not in frame.columns]
    if missing:
        raise BaselineError(f"{name}: missing column(s) {', '.join(missing)} "
                            f"(expected {', '.join(BASELINE_COLUMNS)})")
    out = frame.copy()
    if "scenario" not in out.columns:
        out.insert(0, "scenario", "")
    out = out[BASELINE_COLUMNS]
    for col in ("scenario", "case", "channel", "metric", "unit"):
        out[col] = out[col].fillna("").astype(str)
    text = out["value"].astype(str).str.strip().str.lower()
    if pd.api.types.is_bool_dtype(out["value"]) or text.isin(["true", "false"]).any():
        i = int(np.flatnonzero(text.isin(["true", "false"]).to_numpy())[0])
        raise BaselineError(f"{name}: value: expected a number, found the boolean "
                            f"{str(out['value'].iloc[i])!r} (row {i + 1}, metric "
                            f"{escape(out['metric'].iloc[i], 60)})")
    values = pd.to_numeric(out["value"], errors="coerce")
    bad = values.isna() & out["value"].notna() & (text != "nan")
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise BaselineError(f"{name}: value: expected a number, found "
                            f"{escape(repr(out['value'].iloc[i]), 60)} (row {i + 1}, metric "
                            f"{escape(out['metric'].iloc[i], 60)})")
    out["value"] = values.astype(float)
    dup = out.duplicated(KEY_COLUMNS)
    if dup.any():
        row = out[dup].iloc[0]
        raise BaselineError(f"{name}: duplicated metric {row['scenario']}/{row['case']}/"
                            f"{row['channel']}/{row['metric']}")
    return out.reset_index(drop=True)


def compare_metrics(current, baseline, tolerances=None):
    """Compare a metrics table with its baseline, metric by metric.

    Parameters
    ----------
    current, baseline : pandas.DataFrame
        Long-format metrics tables, columns ``case, channel, metric, value,
        unit`` and optionally ``scenario`` (missing: the same scenario "").
    tolerances : dict or callable, optional
        Overrides for :func:`resolve_tolerances` (``{metric: {rtol, atol,
        direction}}``) or the callable it returns; defaults
        :data:`DEFAULT_TOLERANCES`.

    Returns
    -------
    pandas.DataFrame
        One row per metric of either table, baseline order first, then the
        new metrics; columns ``scenario, case, channel, metric, unit,
        baseline, current, delta`` (current - baseline), ``rel_delta``
        (delta / |baseline|, NaN when the baseline is 0), ``tolerance`` (the
        allowed |delta|) and ``status``, one of :data:`STATUSES`:

        - ``ok``: within tolerance (or both NaN);
        - ``regressed``: moved beyond tolerance in the bad direction (any
          direction for a neutral metric), became or stopped being NaN, or
          changed unit; also a new ``diverged_at_time`` of a case that is in
          the baseline (the case diverged where it did not);
        - ``improved``: moved beyond tolerance in the good direction;
        - ``missing``: in the baseline, not in the current table (counts as
          a regression: see :func:`is_regression`);
        - ``new``: only in the current table (not a regression), e.g. every
          metric of a case or scenario absent from the baseline.

    Raises
    ------
    BaselineError
        If a table lacks a column, holds a non-numeric value or a duplicated
        metric, or a tolerance override is invalid.
    """
    tol_of = tolerances if callable(tolerances) else resolve_tolerances(tolerances)
    cur = _normalise(current, "current metrics")
    base = _normalise(baseline, "baseline")
    merged = base.merge(cur, on=KEY_COLUMNS, how="outer", suffixes=("_b", "_c"),
                        indicator=True, sort=False)
    order = {k: i for i, k in enumerate(map(tuple, base[KEY_COLUMNS].to_numpy()))}
    n = len(order)
    merged["_order"] = [order.get(k, n + i) for i, k in
                        enumerate(map(tuple, merged[KEY_COLUMNS].to_numpy()))]
    merged = merged.sort_values("_order", kind="stable").reset_index(drop=True)

    base_cases = set(map(tuple, base[["scenario", "case"]].to_numpy()))
    rows = []
    for rec in merged.to_dict("records"):
        tol = tol_of(rec["metric"])
        b, c = rec["value_b"], rec["value_c"]
        unit = rec["unit_c"] if isinstance(rec["unit_c"], str) else rec["unit_b"]
        allowed = tol.allowed(b) if rec["_merge"] != "right_only" else float("nan")
        delta = c - b if rec["_merge"] == "both" else float("nan")
        rel = delta / abs(b) if rec["_merge"] == "both" and b != 0 else float("nan")
        if rec["_merge"] == "left_only":
            status = "missing"
        elif rec["_merge"] == "right_only":
            diverged = (rec["metric"] == DIVERGENCE_METRIC
                        and (rec["scenario"], rec["case"]) in base_cases)
            status = "regressed" if diverged else "new"
        else:
            status = _status(b, c, allowed, tol.direction, rec["unit_b"] != rec["unit_c"])
        rows.append({"scenario": rec["scenario"], "case": rec["case"],
                     "channel": rec["channel"], "metric": rec["metric"], "unit": unit,
                     "baseline": b, "current": c, "delta": delta, "rel_delta": rel,
                     "tolerance": allowed, "status": status})
    columns = ["scenario", "case", "channel", "metric", "unit", "baseline", "current",
               "delta", "rel_delta", "tolerance", "status"]
    return pd.DataFrame(rows, columns=columns)


def _status(b, c, allowed, direction, unit_changed):
    if unit_changed:
        return "regressed"
    if math.isnan(b) or math.isnan(c):
        return "ok" if math.isnan(b) and math.isnan(c) else "regressed"
    delta = c - b
    if abs(delta) <= allowed:
        return "ok"
    if direction == "lower":
        return "regressed" if delta > 0 else "improved"
    if direction == "higher":
        return "regressed" if delta < 0 else "improved"
    return "regressed"


def is_regression(comparison):
    """Rows of a comparison that fail the gate.

    Parameters
    ----------
    comparison : pandas.DataFrame
        Result of :func:`compare_metrics`.

    Returns
    -------
    pandas.Series of bool
        True for ``regressed`` and ``missing`` rows.
    """
    return comparison["status"].isin(["regressed", "missing"])


def summary_line(comparison, n_scenarios=None):
    """One line counting the statuses, ending in PASS or FAIL.

    Parameters
    ----------
    comparison : pandas.DataFrame
        Result of :func:`compare_metrics`.
    n_scenarios : int, optional
        Number of scenarios compared (default: distinct ``scenario`` values).

    Returns
    -------
    str
    """
    counts = comparison["status"].value_counts()
    n_sc = comparison["scenario"].nunique() if n_scenarios is None else n_scenarios
    parts = ", ".join(f"{int(counts.get(s, 0))} {s}" for s in STATUSES)
    verdict = "FAIL" if is_regression(comparison).any() else "PASS"
    return f"check: {len(comparison)} metrics in {n_sc} scenario(s): {parts} -> {verdict}"


def read_baseline(path):
    """Read a baseline CSV file.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    pandas.DataFrame
        Columns :data:`BASELINE_COLUMNS`.

    Raises
    ------
    BaselineError
        One line naming the file: missing, empty, not CSV, a missing column,
        a non-numeric or infinite value or a duplicated metric. Leading
        ``#`` comment lines (the provenance line) and a UTF-8 byte-order mark
        are skipped.
    """
    path = Path(path)
    if path.is_dir():
        raise BaselineError(f"{path}: is a directory, expected a baseline CSV file")
    if not path.exists():
        raise BaselineError(f"{path}: baseline file not found (create it with --update)")
    try:
        raw = bounded_read_bytes(path, "baseline", "baseline CSV file").removeprefix(b"\xef\xbb\xbf")
        while raw.startswith(b"#"):  # the provenance line (and any comment line above the header)
            raw = raw.split(b"\n", 1)[1] if b"\n" in raw else b""
        check_size(raw, ",", path, BaselineError)      # rows x the widest line, before parsing
        frame = pd.read_csv(io.BytesIO(raw), dtype={c: str for c in KEY_COLUMNS + ["unit"]},
                            keep_default_na=False, na_values={"value": ["nan", "NaN"]})
    except FileLimitError as exc:
        raise BaselineError(str(exc)) from None
    except pd.errors.EmptyDataError:
        raise BaselineError(f"{path}: empty baseline file (expected columns "
                            f"{', '.join(BASELINE_COLUMNS)})") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError) as exc:
        raise BaselineError(f"{path}: not a readable CSV file "
                            f"({' '.join(str(exc).split())})") from None
    if "scenario" not in frame.columns:
        raise BaselineError(f"{path}: missing column scenario "
                            f"(expected {', '.join(BASELINE_COLUMNS)})")
    frame = _normalise(frame, str(path))
    inf = np.isinf(frame["value"].to_numpy())
    if inf.any():
        i = int(np.flatnonzero(inf)[0])
        row = frame.iloc[i]
        raise BaselineError(f"{path}: value: expected a finite number, found {row['value']} "
                            f"(row {i + 1}, metric {row['scenario']}/{row['case']}/"
                            f"{row['channel']}/{row['metric']}); an infinite baseline would "
                            f"pass any value")
    return frame


def merge_baseline(old, new):
    """Replace the rows of the scenarios in ``new``; keep the other scenarios.

    Parameters
    ----------
    old : pandas.DataFrame or None
        Existing baseline (columns :data:`BASELINE_COLUMNS`).
    new : pandas.DataFrame
        Fresh metrics with a ``scenario`` column.

    Returns
    -------
    pandas.DataFrame
        The baseline's scenarios in their order, each replaced where it
        stood, then the scenarios it did not have, in the order of
        ``new``: a baseline kept in version control changes by the rows
        whose values changed, not by a reordering.
    """
    new = _normalise(new, "current metrics")
    if old is None or old.empty:
        return new.reset_index(drop=True)
    old = _normalise(old, "baseline")
    fresh = set(new["scenario"])
    order = list(dict.fromkeys([*old["scenario"], *new["scenario"]]))
    parts = [(new if name in fresh else old).query("scenario == @name") for name in order]
    return pd.concat(parts, ignore_index=True)


def write_baseline(frame, path):
    """Write a baseline CSV atomically (:func:`hammerstein.core.files.safe_write`).

    Its first line is the project's provenance comment
    (:func:`hammerstein.core.files.provenance_line`): ``check --update``
    replaces only a baseline that carries it (or with ``--force``), and
    :func:`read_baseline` skips it.

    An exclusive temporary file next to ``path`` is renamed over it: a
    replaced file keeps its permissions, a symlink's target is written, a
    target that is not a regular file is refused.

    Parameters
    ----------
    frame : pandas.DataFrame
        Columns :data:`BASELINE_COLUMNS`.
    path : str or pathlib.Path
        Target file; its directory is created if needed.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    BaselineError
        Malformed metrics, or a target that is not a regular file.
    OSError
        The directory cannot be created or written.
    """
    frame = _normalise(frame, "baseline")
    path = Path(path)
    try:
        safe_write(path, provenance_line("check --update") +
                   frame.to_csv(index=False, lineterminator="\n"), "baseline CSV file")
    except FileLimitError as exc:
        raise BaselineError(str(exc)) from None
    return path
