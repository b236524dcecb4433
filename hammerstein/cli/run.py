"""``hammerstein run SCENARIO... [--out DIR]``: simulate scenarios, one report directory each.

Validates and resolves each file, simulates its cases and writes
``DIR/<scenario name>/`` (:func:`hammerstein.runner.run_scenario`). A failed
scenario prints one ``error:`` line and the others still run (exit 1).

stderr carries one ``warning:`` line per distinct warning of a scenario,
with the number of cases that raised it (``warning: <file>: 85 cases:
<message>``; numbers that differ between the cases shown as a range);
``report.md`` and ``warnings.csv`` keep every case's own message. ``-v``
prints one line per case and warning instead, and what is being run; ``-q``
prints errors only.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

from hammerstein.cli._common import (one_line, out_dir_problem, print_err, scheduler_type,
                                     set_warning_subject, workers_type)
from hammerstein.core.files import escape, guard_inputs
from hammerstein.cli._output import add_verbosity, print_warnings
from hammerstein.report._ownership import kept_note
from hammerstein.report.render import figure_selection
from hammerstein.scenario import diskcache
from hammerstein.runner import MARKER, remove_stale_temporaries, run_pipelined
from hammerstein.scenario.montecarlo import execution
from hammerstein.simulation import announce_compiles

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
    p.add_argument("--force", action="store_true",
                   help=f"write DIR/<scenario name> even when it holds what hammerstein did not "
                        f"write: that is moved aside to DIR/<scenario name>.kept-<time>, never "
                        f"deleted (by default only a report directory with a {MARKER} file and "
                        f"nothing else, or an empty directory, is replaced)")
    p.add_argument("--figures", default="all", metavar="WHICH",
                   help="figures to draw: 'all' (default, every figure of the reports), "
                        "'none', or comma-separated file name patterns such as "
                        "'maps-*,trajectory-*'; report.md notes each figure left out "
                        "(the figures take most of a run's CPU time)")
    p.add_argument("--workers", type=workers_type, default=None, metavar="N",
                   help="run Monte-Carlo studies on N local dask worker processes "
                        "(default: in this process; at most the machine's cores, "
                        "HAMMERSTEIN_MAX_WORKERS raises the cap)")
    p.add_argument("--scheduler", type=scheduler_type, default=None, metavar="ADDRESS",
                   help="run Monte-Carlo studies on a running dask.distributed scheduler, "
                        "e.g. tcp://127.0.0.1:8786 (see `dask scheduler`, `dask worker`)")
    add_verbosity(p)
    p.set_defaults(handler=handler)


def handler(args):
    """Run the scenarios of ``args.scenarios`` into ``args.out``; exit status 0, 1 or 2.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``args.scenarios`` (list of scenario file paths) and
        ``args.out`` (directory receiving one report directory per scenario).

    Returns
    -------
    int
        0 when every scenario ran, 1 when one failed (one line per failure
        on stderr, the others still run), 2 when ``args.out`` cannot be a
        reports directory (empty, a file, under a file, not writable).
    """
    problem = out_dir_problem(args.out)
    if problem:
        print_err(f"hammerstein run: error: {problem}")
        return 2
    try:
        figures = figure_selection(getattr(args, "figures", "all"))
    except ValueError as exc:
        print_err(f"hammerstein run: error: {exc}")
        return 2
    seen = {"names": [], "drawn": 0}
    if figures is not None and str(args.figures).strip() != "none":
        select = figures

        def figures(path):          # counted: patterns that match no figure are said
            keep = select(path)
            seen["names"].append(Path(path).name)
            seen["drawn"] += bool(keep)
            return keep
    workers, scheduler = getattr(args, "workers", None), getattr(args, "scheduler", None)
    if workers is not None and (workers < 1 or scheduler):
        print_err("hammerstein run: error: --workers: expected a positive number of worker "
                  "processes, without --scheduler")
        return 2
    out = Path(args.out)
    guard_inputs(*args.scenarios)   # a scenario file is never an output
    remove_stale_temporaries(out)
    verbosity = getattr(args, "verbosity", 0)
    announce_compiles(print_err if verbosity >= 0 else None)
    diskcache.set_reporter(print_err if verbosity > 0 else None)   # -v: ignored cache entries   # first run: before compiling
    started, failed = {}, []

    def on_start(path):
        set_warning_subject(path)       # a stray warning names the scenario it came from
        if verbosity > 0:
            print_err(f"{escape(path)}: running ...")
        started[path] = time.perf_counter()

    def on_outcome(path, outcome):
        if outcome.ok:
            n_cases = (outcome.cases if outcome.cases is not None
                       else outcome.metrics["case"].nunique())
            if verbosity >= 0:
                took = f" in {time.perf_counter() - started[path]:.1f} s" if verbosity > 0 else ""
                cases = f"{n_cases} case{'' if n_cases == 1 else 's'}"
                print(f"{escape(path)}: wrote {escape(outcome.out_dir)}/ ({cases}){took}")
                if outcome.kept is not None:
                    print(f"{escape(path)}: {kept_note(outcome.out_dir, outcome.kept)}")
                print_warnings(escape(path), outcome.warnings, verbosity)
                _print_divergences(escape(path), outcome.metrics)
        else:
            print_err(f"error: {one_line(outcome.error, str(path))}")
            failed.append(path)

    # figures of one scenario are drawn (worker processes) while the next one simulates
    try:
        with execution(workers, scheduler):   # Monte-Carlo chunks on dask, or here
            run_pipelined(args.scenarios, out, args.force, on_outcome=on_outcome,
                          on_start=on_start, figures=figures)
    except ValueError as exc:                 # dask missing or scheduler unreachable
        print_err(f"hammerstein run: error: {one_line(str(exc))}")
        return 1
    if seen["names"] and not seen["drawn"]:
        kinds = sorted({re.sub(r"[-_].*", "-*", n) for n in seen["names"]})
        print_err(f"warning: --figures {args.figures!r} matched none of the "
                  f"{len(seen['names'])} figures (their names: {', '.join(kinds[:8])}); "
                  f"report.md names each one left out")
    return 1 if failed else 0


def _print_divergences(path, metrics):
    """One ``warning:`` line naming the cases whose compensator diverged (report.md has the reason)."""
    div = metrics[metrics["metric"] == "diverged_at_time"] if len(metrics) else metrics
    if len(div):
        cases = [f"{c} (t = {v:.4g} s)" for c, v in zip(div["case"], div["value"])]
        more = f", ... ({len(cases) - 5} more)" if len(cases) > 5 else ""
        print_err(f"warning: {path}: the compensator diverged in {len(cases)} case(s): "
                  f"{', '.join(cases[:5])}{more}; the cases stopped there (see report.md)")
