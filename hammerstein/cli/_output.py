"""How much the commands print: ``-q/--quiet``, ``-v/--verbose`` and grouped warnings."""

from __future__ import annotations

import sys

from hammerstein.cli._common import print_err
from hammerstein.report.messages import group_warnings

__all__ = ["add_verbosity", "print_warnings", "tty_progress"]


def tty_progress(command):
    """On a terminal, a callable printing ``<command>: <line> ...`` on stderr, else None.

    A long phase's wait is said as it starts (a 2-axis identification at 50 kHz sat
    silent for 22-88 s until everything printed at once); redirected (a log, a test)
    the command stays as quiet as before.

    Parameters
    ----------
    command : str
        The command's name, in front of each line.

    Returns
    -------
    callable or None
        ``progress(line)``; None when stderr is not a terminal.
    """
    try:
        tty = sys.stderr.isatty()
    except (AttributeError, ValueError):
        tty = False
    return (lambda line: print_err(f"{command}: {line} ...")) if tty else None


def add_verbosity(p, verbose_help=None):
    """``-q/--quiet`` (errors only) and ``-v/--verbose`` (per-case warnings, progress) on ``p``.

    ``verbose_help`` replaces the ``-v`` help of ``run`` (a command whose default prints
    the warnings otherwise, e.g. ``check``).
    """
    g = p.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_const", const=-1, dest="verbosity", default=0,
                   help="print errors only")
    g.add_argument("-v", "--verbose", action="store_const", const=1, dest="verbosity",
                   help=verbose_help or "print every case's warnings (not one line per "
                                        "distinct warning) and what is being run")


def print_warnings(path, pairs, verbosity=0):
    """Print a scenario's ``(case, message)`` warnings on stderr.

    ``verbosity`` 0: one line per distinct warning with its cases
    (:func:`hammerstein.report.messages.group_warnings`); 1: one line per
    case and warning; -1: nothing.
    """
    if verbosity < 0:
        return
    if verbosity > 0:
        for case, msg in pairs:
            print_err(f"warning: {path}: {case}: {' '.join(msg.split())}")
        return
    for group in group_warnings(pairs):
        print_err(f"warning: {group.line(path)}")
