"""``hammerstein check``: the regression gate on the command line.

``hammerstein check SCENARIO... --baseline FILE`` runs the scenarios with
:func:`hammerstein.runner.run_scenarios`, compares their metrics with the
baseline file (:func:`hammerstein.scenario.regression.compare_metrics`), prints the
metrics that moved (beyond round-off, ``|delta| > 1e-9 (1 + |baseline|)``,
or not ``ok``; ``--all`` prints every metric) and one summary line.

Exit status: 0 when nothing regressed; 1 on a regression (a metric beyond
tolerance in the bad direction, a missing metric, a new divergence) or a
failed scenario; 2 on usage errors (missing or malformed baseline without
``--update``, bad tolerances, two scenarios with the same name).

``--junit-xml FILE`` also writes the gate as a JUnit XML report, one test
case per scenario (:func:`junit_xml`): a regression is a ``failure`` naming
the metrics that regressed with their baseline and current values, a failed
scenario an ``error``; CI systems show it as tests.

``-q`` prints nothing when the gate passes (errors and, on a failure, the
metrics that failed and the summary line); ``-v`` also prints each
scenario's warnings, one line per distinct warning.

``--update`` rewrites the baseline on purpose: the rows of the scenarios
run are replaced, the other scenarios kept; under an advisory lock
(:func:`hammerstein.core.files.locked`) the baseline is read again, merged
and written to a temporary file that is renamed, so concurrent updates all
land. It writes nothing if a scenario failed.

Ownership: the baseline (``--update``) and the ``--junit-xml`` file are
replaced only when they carry the project's provenance line
(:func:`hammerstein.core.files.carries_provenance`) or with ``--force``; an
output is never one of the inputs (scenarios, baseline, tolerance file). A
``--tolerances`` entry naming no metric of the scenarios or the baseline is
a usage error (a misspelt name would otherwise be ignored).
"""

from __future__ import annotations

import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pandas as pd

from hammerstein.cli._common import number_type, out_dir_problem, out_file_problem, print_err
from hammerstein.cli._output import add_verbosity, print_warnings
from hammerstein.core.files import (FileLimitError, carries_provenance, escape, guard_inputs,
                                    locked, path_problem, provenance_line, replace_problem,
                                    safe_write)
from hammerstein.report._ownership import kept_note
from hammerstein.report.render import figure_selection
from hammerstein.runner import run_pipelined, run_scenarios
from hammerstein.scenario import diskcache
from hammerstein.scenario.regression import (BaselineError, compare_metrics, is_regression,
                                             load_tolerances, merge_baseline, read_baseline,
                                             resolve_tolerances, summary_line, write_baseline)
from hammerstein.simulation import announce_compiles

__all__ = ["add_parser", "run_check", "junit_xml"]

#: Relative move below which a metric is not listed as moved (round-off of a recompiled
#: kernel, of numba's threads or another machine: up to a few 1e-7 measured on the bundled
#: scenarios); it still counts in the comparison.
_ROUNDOFF = 1e-6


HELP = "run scenarios and compare their metrics with a baseline"


def add_parser(subparsers):
    """Register the ``check`` subcommand.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        From :meth:`argparse.ArgumentParser.add_subparsers`
        (:data:`hammerstein.cli.main.COMMANDS` lists this module).

    Returns
    -------
    argparse.ArgumentParser
        The ``check`` parser; its ``handler`` default is :func:`run_check`.
    """
    p = subparsers.add_parser(
        "check", help=HELP,
        description="Run scenarios and compare their metrics.csv with a stored baseline "
                    "(per-metric relative and absolute tolerances). Exit 0 when nothing "
                    "regressed, 1 on a regression or a failed scenario, 2 on usage errors.")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.add_argument("--baseline", required=True, metavar="FILE",
                   help="baseline CSV (columns scenario,case,channel,metric,value,unit)")
    p.add_argument("--update", action="store_true",
                   help="rewrite the baseline rows of these scenarios with the current metrics")
    p.add_argument("--out", metavar="DIR",
                   help="keep the reports, with their figures, in DIR (default: a "
                        "temporary directory, and no figures are drawn)")
    p.add_argument("--rtol", type=number_type(0), metavar="R",
                   help="relative tolerance for every metric (e.g. 0.05 = 5 %%; default: "
                        "per metric, 5 %% for most; docs/regression-gate.md lists them)")
    p.add_argument("--atol", type=number_type(0), metavar="A",
                   help="absolute tolerance for every metric, in its unit (default: per "
                        "metric, e.g. 0.01 µm for the errors, 0.2 for the %% errors)")
    p.add_argument("--tolerances", metavar="TOML",
                   help="per-metric overrides: tables [metric] with rtol, atol, direction")
    p.add_argument("--all", action="store_true", dest="show_all",
                   help="print every compared metric, not only those that moved")
    p.add_argument("--junit-xml", metavar="FILE", dest="junit_xml",
                   help="also write a JUnit XML report: one test case per scenario, failures "
                        "naming the metrics that regressed")
    p.add_argument("--force", action="store_true",
                   help="replace a baseline (--update) or JUnit file that hammerstein did not "
                        "write (by default only a file carrying its 'generated by hammerstein' "
                        "line is replaced); with --out, write a report whose directory holds "
                        "what hammerstein did not write, that being moved aside (never deleted) "
                        "as run --force does")
    add_verbosity(p, "also print the scenarios' warnings, one line per distinct warning (by "
                     "default the gate prints the metrics that moved and its summary only), "
                     "and the cache entries it could not use")
    p.set_defaults(handler=run_check)
    return p


def _err(msg):
    print(f"error: {msg}", file=sys.stderr)


def _command_err(msg):
    print(f"hammerstein check: error: {msg}", file=sys.stderr)


def _usage(msg):      # the same line; the caller exits 2
    _command_err(msg)


def run_check(args):
    """Handler of ``hammerstein check``.

    Parameters
    ----------
    args : argparse.Namespace
        ``scenarios`` (list of paths), ``baseline``, ``update``, ``out``,
        ``rtol``, ``atol``, ``tolerances``, ``show_all``.

    Returns
    -------
    int
        0 nothing regressed (or the baseline was updated); 1 a regression, a
        missing metric, a new divergence or a failed scenario; 2 a usage error
        (baseline missing without ``--update``, malformed or a directory; bad
        tolerances; a scenario file not found; ``--out`` not a directory; two
        scenarios with the same name). Errors go to stderr, one line each.
    """
    baseline_path = Path(args.baseline)
    if path_problem(args.baseline):     # the system refuses to look the name up (ENAMETOOLONG)
        _usage(f"--baseline: {path_problem(args.baseline)}")
        return 2
    try:
        overrides = load_tolerances(args.tolerances) if args.tolerances else None
        tolerance = resolve_tolerances(overrides, rtol=args.rtol, atol=args.atol)
        baseline = None
        if not args.update or baseline_path.exists():
            baseline = read_baseline(baseline_path)
    except BaselineError as exc:
        _usage(" ".join(str(exc).split()))
        return 2
    missing = [s for s in args.scenarios if not Path(s).exists()]
    if missing:
        _usage(f"{missing[0]}: scenario file not found")
        return 2
    force = getattr(args, "force", False)
    inputs = list(args.scenarios) + ([args.tolerances] if args.tolerances else [])
    guard_inputs(*inputs)          # never an output (the baseline is read and rewritten: not here)
    problem = out_dir_problem(args.out) if args.out is not None else None
    if problem is None and args.update:
        problem = out_file_problem(baseline_path, "baseline CSV file", inputs)
        problem = problem.replace("--out", "--baseline", 1) if problem else None
        if problem is None:
            problem = _baseline_problem(baseline_path, inputs, force)
    if problem:
        _usage(problem)
        return 2
    junit = getattr(args, "junit_xml", None)
    problem = out_file_problem(junit, "JUnit XML file", inputs) if junit is not None else None
    if problem is None and junit is not None:
        problem = replace_problem(junit, inputs + [baseline_path], force, "hammerstein check")
        problem = f"--junit-xml: {problem}" if problem else None
    if problem is None and junit is not None and args.out is not None:
        problem = _inside_reports(junit, args.out)
    if problem:
        _usage(problem.replace("--out", "--junit-xml", 1))
        return 2
    try:
        return _check(args, baseline_path, baseline, tolerance, overrides)
    except _Stop as exc:
        _usage(str(exc))
        return 2
    except _JunitError as exc:    # a file the command could not write: docs/cli.md's prefix
        text = str(exc)           # safe_write's own line already names the file
        _command_err(text if text.startswith(f"{escape(junit)}: ") else
                     f"{escape(junit)}: cannot write the JUnit XML file ({text})")
        return 1
    except BaselineError as exc:  # inconsistent metrics from the runner, a baseline not written
        _command_err(" ".join(str(exc).split()))
        return 1
    except OSError as exc:        # baseline not writable
        _usage(f"{escape(baseline_path)}: cannot write the baseline ({exc.strerror or exc})")
        return 2


class _Stop(Exception):
    """A usage error found after the scenarios ran (exit 2)."""


class _JunitError(Exception):
    """The JUnit XML file could not be written."""


def _inside_reports(junit, out):
    """Why the JUnit file may not go where a scenario's report directory goes, or None.

    Every directory under ``--out`` is a scenario's report, replaced whole
    when the scenario has run: a file written there first was found only
    afterwards, and refused with a message that blamed someone else.
    """
    parent = os.path.realpath(os.path.dirname(os.path.abspath(junit)))
    root = os.path.realpath(out)
    if parent != root and parent.startswith(root.rstrip(os.sep) + os.sep):
        return (f"--junit-xml: {escape(junit)} is inside a scenario's report directory under "
                f"--out {escape(out)}, which check replaces whole; write it elsewhere, e.g. "
                f"{escape(os.path.join(out, 'junit.xml'))}")
    return None


def _baseline_problem(path, inputs, force):
    """Why ``--update`` may not rewrite the baseline at ``path`` (one line), or None."""
    problem = replace_problem(path, inputs, force, "hammerstein check --update")
    return f"--baseline: {problem}" if problem else None


def _unknown_tolerances(overrides, metrics):
    """Metric names of the tolerance file that no compared metric has (misspelt), sorted."""
    return sorted(str(m) for m in (overrides or {}) if m != "*" and m not in metrics)


def _check(args, baseline_path, baseline, tolerance, overrides=None):
    diskcache.set_reporter((lambda line: print(line, file=sys.stderr))
                           if getattr(args, "verbosity", 0) > 0 else None)  # -v: ignored cache entries
    announce_compiles((lambda message: print(message, file=sys.stderr))   # first run: one
                      if getattr(args, "verbosity", 0) >= 0 else None)      # line before compiling
    outcomes = _run(args.scenarios, args.out, getattr(args, "force", False))
    for o in outcomes:
        if getattr(o, "kept", None) is not None:
            print(kept_note(o.out_dir, o.kept), file=sys.stderr)
    names = [o.name for o in outcomes]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        _usage(f"scenario name {dup[0]!r} is used by several files; names must be unique in a baseline")
        return 2
    failed = [o for o in outcomes if not o.ok]
    for o in failed:
        _err(f"scenario failed: {'; '.join(str(o.error).splitlines())}")
    ok = [o for o in outcomes if o.ok]
    verbosity = getattr(args, "verbosity", 0)
    if verbosity > 0:
        for o in ok:
            print_warnings(o.path, o.warnings, 0)
    junit = getattr(args, "junit_xml", None)
    current = (pd.concat([o.metrics.assign(scenario=o.name) for o in ok], ignore_index=True)
               if ok else None)

    known = set(current["metric"]) if current is not None else set()
    if baseline is not None:
        known |= set(baseline["metric"])
    unknown_tol = _unknown_tolerances(overrides, known) if current is not None else []
    if unknown_tol:
        raise _Stop(f"--tolerances: {escape(args.tolerances)}: no metric named "
                    f"{', '.join(map(repr, unknown_tol[:5]))} in these scenarios or the baseline "
                    f"(misspelt? known: {', '.join(sorted(known)[:12])}"
                    f"{', ...' if len(known) > 12 else ''})")
    if args.update:
        if failed:
            _err(f"{baseline_path}: not updated because {len(failed)} scenario(s) failed")
            return 1
        # read-modify-write under a lock: concurrent updates of one baseline all land
        with locked(baseline_path):
            baseline = read_baseline(baseline_path) if baseline_path.exists() else None
            problem = _baseline_problem(baseline_path, [], getattr(args, "force", False))
            if problem:   # it changed hands while the scenarios ran
                raise _Stop(problem)
            merged = merge_baseline(baseline, current)
            write_baseline(merged, baseline_path)
        if junit is not None:
            _write_junit(junit, outcomes, None, args)
        if verbosity >= 0:
            print(f"{baseline_path}: updated {len(current)} metrics of {len(ok)} scenario(s) "
                  f"({len(merged)} metrics in the file)")
        return 0

    if current is None:
        if junit is not None:
            _write_junit(junit, outcomes, None, args)
        print(f"check: no scenario ran -> FAIL ({len(failed)} failed)")
        return 1
    run_names = set(current["scenario"])
    unknown = sorted(run_names - set(baseline["scenario"]))
    base = baseline[baseline["scenario"].isin(run_names)]
    result = compare_metrics(current, base, tolerance)
    moved = result["delta"].abs() > _ROUNDOFF * (1.0 + result["baseline"].abs())
    listed = ((result["status"] != "ok") | moved) & ~result["scenario"].isin(unknown)
    shown = result if args.show_all else result[listed]
    if junit is not None:
        _write_junit(junit, outcomes, result, args)
    regressed = bool(failed) or bool(is_regression(result).any())
    if verbosity < 0:  # quiet: nothing on success; what failed and the verdict otherwise
        if regressed:
            bad = result[is_regression(result)]
            if len(bad):
                with pd.option_context("display.width", 200, "display.max_rows", None,
                                       "display.max_columns", None):
                    print(bad.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
            line = summary_line(result, n_scenarios=len(ok))
            if failed:
                line = f"{line.rsplit(' -> ', 1)[0]}; {len(failed)} scenario(s) failed -> FAIL"
            print(line)
        return 1 if regressed else 0
    if len(shown):
        with pd.option_context("display.width", 200, "display.max_rows", None,
                               "display.max_columns", None):
            print(shown.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
    else:
        print("no metric moved")
    if unknown:
        print_err(f"note: scenario(s) not in {baseline_path}: {', '.join(unknown)} "
                  f"(their metrics are 'new'; add them with --update)")
    line = summary_line(result, n_scenarios=len(ok))
    if failed:
        line = f"{line.rsplit(' -> ', 1)[0]}; {len(failed)} scenario(s) failed -> FAIL"
    print(line)
    return 1 if failed or is_regression(result).any() else 0


def _fmt(v):
    return "nan" if pd.isna(v) else f"{v:.6g}"


def junit_xml(outcomes, comparison=None):
    """The gate as a JUnit XML tree: one ``testcase`` per scenario.

    Parameters
    ----------
    outcomes : list of hammerstein.runner.ScenarioOutcome
        The scenarios run, in order.
    comparison : pandas.DataFrame, optional
        :func:`hammerstein.scenario.regression.compare_metrics` of the
        scenarios that ran (None: no comparison, e.g. ``--update``).

    Returns
    -------
    xml.etree.ElementTree.ElementTree
        ``<testsuites><testsuite name="hammerstein check">`` with one
        ``<testcase classname="hammerstein.check" name="<scenario>">`` per
        scenario (``file`` its path): a ``<failure>`` lists every metric
        that regressed or is missing (``case/channel/metric: baseline ->
        current unit (tolerance ...)``); a scenario that failed to run has
        an ``<error>``; a scenario not in the baseline passes and says so in
        ``<system-out>``.
    """
    suite = ET.Element("testsuite", name="hammerstein check")
    n_fail = n_err = 0
    for o in outcomes:
        case = ET.SubElement(suite, "testcase", classname="hammerstein.check", name=str(o.name),
                             file=str(o.path))
        if not o.ok:
            n_err += 1
            err = ET.SubElement(case, "error", message=" ".join(str(o.error).split())[:500],
                                type="ScenarioFailed")
            err.text = str(o.error)
            continue
        if comparison is None:
            continue
        rows = comparison[comparison["scenario"] == o.name]
        if rows.empty or (rows["status"] == "new").all():
            ET.SubElement(case, "system-out").text = (
                f"{o.name}: not in the baseline ({len(rows)} new metrics)")
            continue
        bad = rows[is_regression(rows)]
        if len(bad):
            n_fail += 1
            lines = [f"{r.case}/{r.channel}/{r.metric}: {r.status}, baseline {_fmt(r.baseline)} "
                     f"-> current {_fmt(r.current)} {r.unit} (allowed ±{_fmt(r.tolerance)})"
                     for r in bad.itertuples()]
            names = sorted(dict.fromkeys(f"{r.metric} of {r.case}/{r.channel}"
                                         for r in bad.itertuples()))
            more = f" and {len(names) - 3} more" if len(names) > 3 else ""
            fail = ET.SubElement(case, "failure", type="MetricRegressed",
                                 message=f"{len(bad)} metric(s) regressed: "
                                         f"{', '.join(names[:3])}{more}")
            fail.text = "\n".join(lines)
    suite.set("tests", str(len(outcomes)))
    suite.set("failures", str(n_fail))
    suite.set("errors", str(n_err))
    suite.set("skipped", "0")
    root = ET.Element("testsuites", name="hammerstein check", tests=str(len(outcomes)),
                      failures=str(n_fail), errors=str(n_err))
    root.append(suite)
    return ET.ElementTree(root)


def _write_junit(path, outcomes, comparison, args=None):
    """Write :func:`junit_xml` to ``path`` atomically (temporary file, then rename)."""
    tree = junit_xml(outcomes, comparison)
    ET.indent(tree)

    def write(fh):
        fh.write(b"<?xml version='1.0' encoding='utf-8'?>\n")
        fh.write(provenance_line("check", "xml").encode())
        tree.write(fh, encoding="utf-8", xml_declaration=False)
    if (os.path.exists(path) and not carries_provenance(path)
            and not getattr(args, "force", False)):
        raise _Stop(f"--junit-xml: {escape(path)}: was replaced by a file hammerstein did not "
                    f"write while the scenarios ran; not overwritten")
    try:
        safe_write(path, write, "JUnit XML file")
    except FileLimitError as exc:  # became a special or read-only file meanwhile
        raise _JunitError(str(exc)) from None
    except OSError as exc:
        raise _JunitError(exc.strerror or str(exc)) from None


def _run(paths, out, force=False):
    if out is not None:     # --force as run's: what hammerstein did not write is moved aside
        return run_scenarios(paths, out, force)
    with tempfile.TemporaryDirectory(prefix="hammerstein-check-") as tmp:
        # the reports are thrown away: only their metrics are compared, so no figure is drawn
        return run_pipelined(paths, tmp, figures=figure_selection("none"))
