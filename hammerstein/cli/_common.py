"""Helpers shared by the command modules: one-line messages on stderr."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from hammerstein.core.files import escape

__all__ = ["print_err", "one_line", "out_dir_problem", "out_file_problem", "SafeStream",
           "MAX_LINE", "add_column_options", "WARNING_STATE", "set_warning_subject"]

#: What a stray warning (a library's ``warnings.warn`` or log record) is about: the
#: input file being processed (:func:`set_warning_subject`), else ``hammerstein
#: <command>``; and the warning lines already printed (each distinct one once).
WARNING_STATE = {"subject": "hammerstein", "said": set()}


def set_warning_subject(subject):
    """Name the file that stray warnings from now on are about.

    Parameters
    ----------
    subject : str
        Printed after ``warning:``, e.g. the scenario file ``hammerstein run``
        is simulating (several scenarios in one run: each its own).
    """
    WARNING_STATE["subject"] = str(subject)

#: Longest line printed on stderr (characters); longer messages are cut with a count.
MAX_LINE = 2000

_KEEP = {"\n", "\t"}


class SafeStream:
    """A text stream that escapes control characters before they reach a terminal.

    Wraps ``sys.stdout`` / ``sys.stderr`` while a command runs: escape
    sequences, NUL, carriage returns and the other control characters of a
    file name, a column name or a title become visible escapes
    (:func:`hammerstein.core.files.escape`), so no output can change the
    window title, clear the screen or overwrite a line. Newlines and tabs
    pass (the messages' own line structure); the places that print a user
    string escape its newlines themselves.

    Parameters
    ----------
    stream : io.TextIOBase
        The stream written to.
    """

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        """Write ``text`` with its control characters (but newline and tab) escaped."""
        if not text.isprintable() and not all(c.isprintable() or c in _KEEP for c in text):
            text = "".join(c if c.isprintable() or c in _KEEP else escape(c) for c in text)
        return self._stream.write(text)

    def __getattr__(self, name):
        return getattr(self._stream, name)



def out_dir_problem(out):
    """Why ``out`` cannot be a reports directory (one line, for a usage error), or None.

    An empty path, a path under an existing file (``f/sub`` with ``f`` a
    file), an existing non-directory, or a directory that cannot be written.
    Nothing is created.
    """
    if not str(out).strip():
        return "--out: empty path; expected a directory"
    p = Path(out)
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    if not p.is_dir():
        what = "exists and is not a directory" if p == Path(out) else "is not a directory"
        return f"--out: {p} {what}"
    if not os.access(p, os.W_OK | os.X_OK):
        return f"--out: {p}: permission denied (cannot write there)"
    return None


def out_file_problem(out, what="file"):
    """Why ``out`` cannot be written as a single file (one line), or None.

    An empty path, a directory, an existing special file (device, FIFO,
    socket) or read-only file, a path under an existing file, a symbolic
    link that cannot be followed (loop), or a directory that cannot be
    written. A symlink is judged by its target.
    """
    if not str(out).strip():
        return f"--out: empty path; expected a {what} name"
    p = Path(out)
    if p.is_symlink():
        try:
            os.stat(p)
        except FileNotFoundError:
            pass  # a dangling link: its target is created
        except OSError as exc:  # a loop of links, a link through a file...
            return f"--out: {out}: cannot follow the symbolic link ({exc.strerror})"
    if p.is_dir():
        return f"--out: {out} is a directory; expected a {what} name"
    if os.path.lexists(p) and p.exists() and not p.is_file():
        return f"--out: {out} is not a regular file (a device, FIFO or socket); expected a {what} name"
    if p.is_file() and (not p.stat().st_mode & 0o222 or not os.access(p, os.W_OK)):
        return f"--out: {out} is read-only; make it writable (chmod u+w) or choose another name"
    problem = out_dir_problem(p.resolve().parent if p.is_symlink() else p.parent)
    return problem.replace("--out: ", f"--out: {out}: ", 1) if problem else None


def add_column_options(p, inputs_help="input columns named otherwise",
                       outputs_help="output columns named otherwise",
                       time_help="time column of the CSV files (default t)"):
    """``--time COL`` (default ``t``), ``--input-columns NAME=COL,...`` and ``--output-columns NAME=COL,...`` on ``p``.

    The column options of the commands that read signal CSV files
    (``compensate``, ``learn``, ``evaluate``): one definition, so their
    names, metavars and defaults cannot drift apart; each command words
    its own help. ``--inputs``/``--outputs``, their former spellings, still
    work (hidden from ``--help``): those names mean the actuator's inputs and
    outputs in ``identify`` and ``excitation``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    inputs_help, outputs_help, time_help : str
        Help texts of ``--input-columns``, ``--output-columns`` and ``--time``.
    """
    p.add_argument("--output-columns", dest="outputs", metavar="NAME=COL,...", help=outputs_help)
    p.add_argument("--input-columns", dest="inputs", metavar="NAME=COL,...", help=inputs_help)
    # the old spellings, kept working: --inputs/--outputs name the actuator's inputs and
    # outputs elsewhere (identify, excitation), not a map of columns
    p.add_argument("--outputs", dest="outputs", help=argparse.SUPPRESS)
    p.add_argument("--inputs", dest="inputs", help=argparse.SUPPRESS)
    p.add_argument("--time", default="t", metavar="COL", help=time_help)


def print_err(msg):
    """Print ``msg`` on stderr as one line: control characters and newlines escaped, at most :data:`MAX_LINE` characters."""
    print(escape(msg, MAX_LINE), file=sys.stderr)


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

    Examples
    --------
    >>> one_line("a.toml: x: bad\\na.toml: y: worse", "a.toml")
    'a.toml: x: bad; y: worse'
    """
    lines = [" ".join(ln.split()) for ln in str(text).splitlines() if ln.strip()]
    if path is None:
        return "; ".join(lines)
    pre = f"{path}: "
    lines = [ln[len(pre):] if ln.startswith(pre) else ln for ln in lines]
    return pre + "; ".join(lines)
