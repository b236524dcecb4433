"""Command-line interface: ``hammerstein run | validate | list | ...``.

Each subcommand is a function ``add_parser(subparsers)`` that adds its
parser and sets ``handler=<function(args) -> exit status>``. Subcommands
are registered in :data:`COMMANDS` as ``"module:function"`` strings,
imported lazily: add a subcommand with one line there.

Exit status: 0 on success, 1 when a scenario failed (the others still
run), 2 on usage errors.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

__all__ = ["main", "build_parser", "COMMANDS"]


def _print_err(msg):
    print(msg, file=sys.stderr)


# -- run ---------------------------------------------------------------------------
def add_run_parser(subparsers):
    p = subparsers.add_parser(
        "run", help="simulate scenarios and write reports",
        description="Simulate each scenario and write DIR/<scenario name>/ (metrics.csv, "
                    "time series, figures, report.md).")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.add_argument("--out", default="reports", metavar="DIR",
                   help="reports directory (default: reports/)")
    p.set_defaults(handler=_run)


def _run(args):
    from .runner import run_scenario
    status = 0
    for path in args.scenarios:
        outcome = run_scenario(path, args.out)
        if outcome.ok:
            n_cases = outcome.metrics["case"].nunique()
            print(f"{path}: wrote {outcome.out_dir}/ ({n_cases} cases)")
        else:
            _print_err(f"error: {'; '.join(outcome.error.splitlines())}")
            status = 1
    return status


# -- validate ----------------------------------------------------------------------
def add_validate_parser(subparsers):
    p = subparsers.add_parser(
        "validate", help="check scenario files without simulating",
        description="Check scenario files and list every problem as 'file: key: message'.")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.set_defaults(handler=_validate)


def _validate(args):
    from .scenarios import ScenarioError, load_scenario
    status = 0
    for path in args.scenarios:
        try:
            sc = load_scenario(path)
        except ScenarioError as exc:
            for line in exc.problems:
                _print_err(f"error: {line}")
            status = 1
            continue
        print(f"{path}: ok ({len(sc.cases)} cases)")
    return status


# -- list --------------------------------------------------------------------------
def add_list_parser(subparsers):
    p = subparsers.add_parser(
        "list", help="list bundled presets, compensator kinds and scenarios",
        description="List the bundled actuator presets, the compensator kinds and the "
                    "scenario files under DIR (default ./scenarios).")
    p.add_argument("--scenarios", default="scenarios", metavar="DIR",
                   help="directory searched for *.toml scenarios (default: ./scenarios)")
    p.set_defaults(handler=_list)


def _list(args):
    from .presets import bundled_presets
    from .runner import COMPENSATORS
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
    "hammerstein.cli:add_run_parser",
    "hammerstein.cli:add_validate_parser",
    "hammerstein.cli:add_list_parser",
    "hammerstein.identify_cli:add_parser",
    "hammerstein.check_cli:add_parser",
    "hammerstein.replication:add_parser",
]


def build_parser():
    """The argparse parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="hammerstein",
        description="Multivariable Prandtl-Ishlinskii hysteresis of piezoelectric actuators: "
                    "simulate scenarios, compensate, report.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
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
    return int(args.handler(args))


if __name__ == "__main__":
    sys.exit(main())
