"""Command-line interface: ``hammerstein run | validate | list | ...``.

Each subcommand is a function ``add_parser(subparsers)`` that adds its
parser and sets ``handler=<function(args) -> exit status>``. Subcommands
are registered in :data:`COMMANDS` as ``"module:function"`` strings,
imported lazily: add a subcommand with one line there.

Exit status: 0 on success, 1 when a scenario failed (the others still
run), 2 on usage errors.

stderr carries one line per problem and nothing else: ``error: <file>:
<message>`` for a failed scenario (its problems joined by ``; ``),
``error: <file>: <key>: <message>`` per problem for ``validate``,
``warning: <file>: <case>: <message>`` per warning of a scenario that ran,
``hammerstein <command>: error: <message>`` for a usage error, and any other
Python warning as one ``warning: <Category>: <message>`` line (no traceback).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from pathlib import Path

__all__ = ["main", "build_parser", "one_line", "COMMANDS"]


def _print_err(msg):
    print(msg, file=sys.stderr)


def one_line(text, path=None):
    """Fold a multi-line message into one line, without a repeated ``path: `` prefix.

    Parameters
    ----------
    text : str
        Message, one problem per line (e.g. ``ScenarioOutcome.error``).
    path : str, optional
        File name that prefixes each problem; kept once, at the front.

    Returns
    -------
    str
        ``path: problem 1; problem 2; ...`` on one line.
    """
    lines = [" ".join(ln.split()) for ln in str(text).splitlines() if ln.strip()]
    if path is None:
        return "; ".join(lines)
    pre = f"{path}: "
    lines = [ln[len(pre):] if ln.startswith(pre) else ln for ln in lines]
    return pre + "; ".join(lines)


class _Parser(argparse.ArgumentParser):
    """argparse parser whose usage errors are one line on stderr (exit status 2)."""

    def error(self, message):
        """Print the usage error as one line on stderr and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see '{self.prog} --help')\n")


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    """warnings.showwarning replacement: one ``warning: Category: message`` line."""
    print(f"warning: {category.__name__}: {' '.join(str(message).split())}",
          file=sys.stderr if file is None else file)


# -- run ---------------------------------------------------------------------------
def add_run_parser(subparsers):
    """Register `hammerstein run SCENARIO... [--out DIR]`: simulate scenarios, write one report directory each.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "run", help="simulate scenarios and write reports",
        description="Simulate each scenario and write DIR/<scenario name>/ (metrics.csv, "
                    "time series, figures, report.md).")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.add_argument("--out", default="reports", metavar="DIR",
                   help="reports directory (default: reports/)")
    p.set_defaults(handler=_run)


def _run(args):
    from hammerstein.runner import run_scenario
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        _print_err(f"hammerstein run: error: --out: {out} exists and is not a directory")
        return 2
    status, taken = 0, {}
    for path in args.scenarios:
        outcome = run_scenario(path, args.out, taken)
        if outcome.ok:
            taken[outcome.name] = outcome.path
            n_cases = outcome.metrics["case"].nunique()
            print(f"{path}: wrote {outcome.out_dir}/ ({n_cases} cases)")
            for case, msg in outcome.warnings:
                _print_err(f"warning: {path}: {case}: {' '.join(msg.split())}")
            _print_divergences(path, outcome.metrics)
        else:
            _print_err(f"error: {one_line(outcome.error, str(path))}")
            status = 1
    return status


def _print_divergences(path, metrics):
    """One ``warning:`` line naming the cases whose compensator diverged (report.md has the reason)."""
    div = metrics[metrics["metric"] == "diverged_at_time"] if len(metrics) else metrics
    if len(div):
        cases = [f"{c} (t = {v:.4g} s)" for c, v in zip(div["case"], div["value"])]
        more = f", ... ({len(cases) - 5} more)" if len(cases) > 5 else ""
        _print_err(f"warning: {path}: the compensator diverged in {len(cases)} case(s): "
                   f"{', '.join(cases[:5])}{more}; the cases stopped there (see report.md)")


# -- validate ----------------------------------------------------------------------
def add_validate_parser(subparsers):
    """Register `hammerstein validate SCENARIO...`: the scenario checks of `run`, without simulating.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "validate", help="check scenario files without simulating",
        description="Check scenario files and list every problem as 'file: key: message'.")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.set_defaults(handler=_validate)


def _validate(args):
    from hammerstein.scenario.schema import ScenarioError, load_scenario
    status = 0
    for path in args.scenarios:
        try:
            sc = load_scenario(path)
        except ScenarioError as exc:
            for line in exc.problems:  # one line per problem: file: key: message
                _print_err(f"error: {' '.join(line.split())}")
            status = 1
            continue
        except Exception as exc:  # as run does: one line, the other files still checked
            _print_err(f"error: {path}: {type(exc).__name__}: {one_line(exc)}")
            status = 1
            continue
        print(f"{path}: ok ({len(sc.cases)} cases)")
    return status


# -- list --------------------------------------------------------------------------
def add_list_parser(subparsers):
    """Register `hammerstein list [--scenarios DIR]`: presets, compensator kinds and scenario files.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "list", help="list bundled presets, compensator kinds and scenarios",
        description="List the bundled actuator presets, the compensator kinds and the "
                    "scenario files under DIR (default ./scenarios).")
    p.add_argument("--scenarios", default="scenarios", metavar="DIR",
                   help="directory searched for *.toml scenarios (default: ./scenarios)")
    p.set_defaults(handler=_list)


def _list(args):
    from hammerstein.core.presets import bundled_presets
    from hammerstein.runner import COMPENSATORS
    print("presets:")
    for name, path in sorted(bundled_presets().items()):
        print(f"  {name}  ({path})")
    print("compensator kinds:")
    for name, kind in COMPENSATORS.items():
        print(f"  {name}: {kind.description}")
    root = Path(args.scenarios)
    files = sorted(root.rglob("*.toml")) if root.is_dir() else []
    print(f"scenarios under {root}/:" if files else
          f"scenarios: none found under {root}/ (run from the repository root)")
    for f in files:
        print(f"  {f}")
    return 0


# -- command registrations: one line per subcommand ("module:add_parser") ------------
COMMANDS = [
    "hammerstein.cli.main:add_run_parser",
    "hammerstein.cli.main:add_validate_parser",
    "hammerstein.cli.main:add_list_parser",
    "hammerstein.cli.identify:add_parser",
    "hammerstein.cli.check:add_parser",
    "hammerstein.report.replication:add_parser",
]


def build_parser():
    """The argparse parser with every registered subcommand."""
    parser = _Parser(
        prog="hammerstein",
        description="Multivariable Prandtl-Ishlinskii hysteresis of piezoelectric actuators: "
                    "simulate scenarios, compensate, report.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for entry in COMMANDS:
        module, func = entry.split(":")
        getattr(importlib.import_module(module), func)(sub)
    return parser


def main(argv=None):
    """Entry point of the ``hammerstein`` console script.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 1 a scenario failed, 2 usage error.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: usage error (2) or --help (0)
        return int(exc.code or 0)
    with warnings.catch_warnings():  # stray warnings: one line each, no source line
        warnings.showwarning = _one_line_warning
        try:
            return int(args.handler(args))
        except Exception as exc:  # a bug, not bad input: still one line, no traceback
            if os.environ.get("HAMMERSTEIN_DEBUG"):
                raise
            _print_err(f"hammerstein {args.command}: error: unexpected {type(exc).__name__}: "
                       f"{one_line(exc)} (HAMMERSTEIN_DEBUG=1 shows the traceback)")
            return 1


if __name__ == "__main__":
    sys.exit(main())
