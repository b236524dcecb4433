"""``hammerstein run SCENARIO... [--out DIR]``: simulate scenarios, one report directory each.

Validates and resolves each file, simulates its cases and writes
``DIR/<scenario name>/`` (:func:`hammerstein.runner.run_scenario`). A failed
scenario prints one ``error:`` line and the others still run (exit 1).
"""

from __future__ import annotations

from pathlib import Path

from hammerstein.cli._common import one_line, print_err
from hammerstein.runner import run_scenario

__all__ = ["add_parser", "handler"]

HELP = "simulate scenarios and write reports"


def add_parser(subparsers):
    """Register `hammerstein run SCENARIO... [--out DIR]`: simulate scenarios, write one report directory each.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "run", help=HELP,
        description="Simulate each scenario and write DIR/<scenario name>/ (metrics.csv, "
                    "time series, figures, report.md).")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.add_argument("--out", default="reports", metavar="DIR",
                   help="reports directory (default: reports/)")
    p.set_defaults(handler=handler)


def handler(args):
    """Run the scenarios of ``args.scenarios`` into ``args.out``; exit status 0, 1 or 2."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        print_err(f"hammerstein run: error: --out: {out} exists and is not a directory")
        return 2
    status, taken = 0, {}
    for path in args.scenarios:
        outcome = run_scenario(path, args.out, taken)
        if outcome.ok:
            taken[outcome.name] = outcome.path
            n_cases = outcome.metrics["case"].nunique()
            print(f"{path}: wrote {outcome.out_dir}/ ({n_cases} cases)")
            for case, msg in outcome.warnings:
                print_err(f"warning: {path}: {case}: {' '.join(msg.split())}")
            _print_divergences(path, outcome.metrics)
        else:
            print_err(f"error: {one_line(outcome.error, str(path))}")
            status = 1
    return status


def _print_divergences(path, metrics):
    """One ``warning:`` line naming the cases whose compensator diverged (report.md has the reason)."""
    div = metrics[metrics["metric"] == "diverged_at_time"] if len(metrics) else metrics
    if len(div):
        cases = [f"{c} (t = {v:.4g} s)" for c, v in zip(div["case"], div["value"])]
        more = f", ... ({len(cases) - 5} more)" if len(cases) > 5 else ""
        print_err(f"warning: {path}: the compensator diverged in {len(cases)} case(s): "
                  f"{', '.join(cases[:5])}{more}; the cases stopped there (see report.md)")
