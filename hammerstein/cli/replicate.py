"""``hammerstein replicate [--scenarios DIR] [--out OUT]``: the replication report of the paper.

Runs every scenario of DIR into ``OUT/<scenario>/`` and writes
``OUT/README.md`` (:func:`hammerstein.runner.replicate`,
:mod:`hammerstein.report.replication`).
"""

from __future__ import annotations

from pathlib import Path

from hammerstein.cli._common import out_dir_problem, print_err
from hammerstein.report.replication import GENERATED
from hammerstein.runner import replicate

__all__ = ["add_parser", "handler"]

HELP = "regenerate the replication report of the paper"


def add_parser(subparsers):
    """Register ``hammerstein replicate``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "replicate", help=HELP,
        description="Run every scenario of DIR (default scenarios/paper) into OUT/<scenario>/ and "
                    "write OUT/README.md: the paper's numbers next to ours with their ratios, the "
                    "trends of Fig. 7 and 9, the compensator family, the figures.")
    p.add_argument("--scenarios", default="scenarios/paper", metavar="DIR",
                   help="directory of the paper's scenario files (default scenarios/paper)")
    p.add_argument("--out", default="reports/paper", metavar="OUT",
                   help="directory of the replication: OUT/README.md, its tables and one report "
                        "directory per scenario (default reports/paper)")
    p.add_argument("--force", action="store_true",
                   help="replace OUT/README.md, its tables and report directories even when "
                        "hammerstein did not write them")
    p.set_defaults(handler=handler)


def handler(args):
    """Run the paper's scenarios and write the README; exit status 0, 1 (a scenario failed) or 2.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``args.scenarios`` (directory of the paper's
        scenario files) and ``args.out`` (output directory).

    Returns
    -------
    int
        0 when every scenario ran, 1 when one failed (one line per failure
        on stderr), 2 when ``args.scenarios`` holds no ``*.toml`` scenario or ``args.out``
        cannot be a directory, or a file of the README was not written by
        hammerstein replicate and ``args.force`` is not set (usage error).
    """
    problem = out_dir_problem(args.out)
    if problem:
        print_err(f"hammerstein replicate: error: {problem}")
        return 2
    try:
        outcomes = replicate(args.scenarios, args.out, force=args.force)
    except (FileNotFoundError, FileExistsError) as exc:
        print_err(f"hammerstein replicate: error: {exc}")
        return 2
    except OSError as exc:  # README step: cannot write
        print_err(f"error: {exc.filename or args.out}: cannot write ({exc.strerror or exc})")
        return 1
    except ValueError as exc:  # README step: a special file appeared meanwhile
        print_err(f"error: {' '.join(str(exc).split())}")
        return 1
    for o in outcomes:
        if o.ok:
            print(f"{o.path}: wrote {o.out_dir}/")
        else:
            print_err(f"error: {'; '.join(o.error.splitlines())}")
    written = [name for name in GENERATED if (Path(args.out) / name).is_file()]
    print(f"wrote {Path(args.out) / 'README.md'}" + (
        f" and, beside it, {', '.join(n for n in written if n != 'README.md')}"
        if len(written) > 1 else ""))
    return 0 if all(o.ok for o in outcomes) else 1
