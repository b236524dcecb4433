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

``--update`` rewrites the baseline on purpose: the rows of the scenarios
run are replaced, the other scenarios kept; the file is written to a
temporary file and renamed. It writes nothing if a scenario failed.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

from hammerstein.runner import run_scenarios
from hammerstein.scenario.regression import (BaselineError, compare_metrics, is_regression,
                                             load_tolerances, merge_baseline, read_baseline,
                                             resolve_tolerances, summary_line, write_baseline)

__all__ = ["add_parser", "run_check"]

#: Relative move below which a metric is not listed as moved (round-off of a
#: recompiled kernel); it still counts in the comparison.
_ROUNDOFF = 1e-9


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
                   help="keep the reports in DIR (default: a temporary directory)")
    p.add_argument("--rtol", type=float, metavar="R",
                   help="relative tolerance for every metric (e.g. 0.05 = 5 %%)")
    p.add_argument("--atol", type=float, metavar="A",
                   help="absolute tolerance for every metric, in its unit")
    p.add_argument("--tolerances", metavar="TOML",
                   help="per-metric overrides: tables [metric] with rtol, atol, direction")
    p.add_argument("--all", action="store_true", dest="show_all",
                   help="print every compared metric, not only those that moved")
    p.set_defaults(handler=run_check)
    return p


def _err(msg):
    print(f"error: {msg}", file=sys.stderr)


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
    try:
        overrides = load_tolerances(args.tolerances) if args.tolerances else None
        tolerance = resolve_tolerances(overrides, rtol=args.rtol, atol=args.atol)
        baseline = None
        if not args.update or baseline_path.exists():
            baseline = read_baseline(baseline_path)
    except BaselineError as exc:
        _err(" ".join(str(exc).split()))
        return 2
    missing = [s for s in args.scenarios if not Path(s).is_file()]
    if missing:
        _err(f"{missing[0]}: scenario file not found")
        return 2
    if args.out is not None and Path(args.out).exists() and not Path(args.out).is_dir():
        _err(f"--out: {args.out} exists and is not a directory")
        return 2
    try:
        return _check(args, baseline_path, baseline, tolerance)
    except BaselineError as exc:  # inconsistent metrics from the runner
        _err(" ".join(str(exc).split()))
        return 1
    except OSError as exc:        # baseline not writable
        _err(f"{baseline_path}: cannot write the baseline ({exc.strerror or exc})")
        return 2


def _check(args, baseline_path, baseline, tolerance):
    outcomes = _run(args.scenarios, args.out)
    names = [o.name for o in outcomes]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        _err(f"scenario name {dup[0]!r} is used by several files; names must be unique in a baseline")
        return 2
    failed = [o for o in outcomes if not o.ok]
    for o in failed:
        _err(f"scenario failed: {'; '.join(str(o.error).splitlines())}")
    ok = [o for o in outcomes if o.ok]
    current = (pd.concat([o.metrics.assign(scenario=o.name) for o in ok], ignore_index=True)
               if ok else None)

    if args.update:
        if failed:
            _err(f"{baseline_path}: not updated because {len(failed)} scenario(s) failed")
            return 1
        merged = merge_baseline(baseline, current)
        write_baseline(merged, baseline_path)
        print(f"{baseline_path}: updated {len(current)} metrics of {len(ok)} scenario(s) "
              f"({len(merged)} metrics in the file)")
        return 0

    if current is None:
        print(f"check: no scenario ran -> FAIL ({len(failed)} failed)")
        return 1
    run_names = set(current["scenario"])
    unknown = sorted(run_names - set(baseline["scenario"]))
    base = baseline[baseline["scenario"].isin(run_names)]
    result = compare_metrics(current, base, tolerance)
    moved = result["delta"].abs() > _ROUNDOFF * (1.0 + result["baseline"].abs())
    listed = ((result["status"] != "ok") | moved) & ~result["scenario"].isin(unknown)
    shown = result if args.show_all else result[listed]
    if len(shown):
        with pd.option_context("display.width", 200, "display.max_rows", None,
                               "display.max_columns", None):
            print(shown.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
    else:
        print("no metric moved")
    if unknown:
        print(f"note: scenario(s) not in {baseline_path}: {', '.join(unknown)} "
              f"(their metrics are 'new'; add them with --update)")
    line = summary_line(result, n_scenarios=len(ok))
    if failed:
        line = f"{line.rsplit(' -> ', 1)[0]}; {len(failed)} scenario(s) failed -> FAIL"
    print(line)
    return 1 if failed or is_regression(result).any() else 0


def _run(paths, out):
    if out is not None:
        return run_scenarios(paths, out)
    with tempfile.TemporaryDirectory(prefix="hammerstein-check-") as tmp:
        return run_scenarios(paths, tmp)
