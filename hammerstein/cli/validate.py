"""``hammerstein validate SCENARIO...``: check scenario files without building or simulating.

Runs only the validation step
(:func:`hammerstein.scenario.validate.validate_scenario`): keys, types,
units, ranges, names, signals against Nyquist. What only the resolution of
``hammerstein run`` can find (a failed identification, a compensator refused
by its convergence check, an unreadable model file) is not checked here.
"""

from __future__ import annotations

from hammerstein.cli._common import one_line, print_err
from hammerstein.core.files import escape
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.validate import validate_scenario

__all__ = ["add_parser", "handler"]

HELP = "check scenario files without simulating"


def add_parser(subparsers):
    """Register `hammerstein validate SCENARIO...`: the scenario checks of `run`, without simulating.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "validate", help=HELP,
        description="Check scenario files and list every problem as 'file: key: message' "
                    "(no compensator is built, no model identified, nothing simulated).")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario TOML files")
    p.set_defaults(handler=handler)


def handler(args):
    """Validate each file of ``args.scenarios``; exit status 0 (all valid) or 1.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments; ``args.scenarios`` is the list of scenario file
        paths.

    Returns
    -------
    int
        0 when every file is valid, 1 otherwise (one line per problem on
        stderr; every file is still checked).
    """
    status = 0
    for path in args.scenarios:
        try:
            sc = validate_scenario(path)
        except ScenarioError as exc:
            for line in exc.problems:  # one line per problem: file: key: message
                print_err(f"error: {' '.join(line.split())}")
            status = 1
            continue
        except Exception as exc:  # as run does: one line, the other files still checked
            print_err(f"error: {path}: unexpected {type(exc).__name__}: {one_line(exc)}")
            status = 1
            continue
        said = set()
        for case in getattr(sc, "cases", []):   # implausible magnitudes: valid, but said
            for w in getattr(case, "warnings", []):
                if w not in said:
                    said.add(w)
                    print_err(f"warning: {escape(path)}: {case.name}: {w}")
        n = len(sc.cases)
        print(f"{escape(path)}: ok ({n} case{'' if n == 1 else 's'})")
    return status
