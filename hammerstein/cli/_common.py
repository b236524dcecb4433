"""Helpers shared by the command modules: one-line messages on stderr."""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
from pathlib import Path

from hammerstein.core.files import carries_provenance, escape, path_problem, same_file

__all__ = ["print_err", "one_line", "out_dir_problem", "out_file_problem", "SafeStream",
           "MAX_LINE", "add_column_options", "WARNING_STATE", "set_warning_subject",
           "number_type", "integer_type", "workers_type", "max_workers", "scheduler_type"]

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

    With ``max_line`` (stderr), no line is longer than ``max_line``
    characters whichever way it is written (one ``print``, several
    ``write`` calls): the rest of a longer line is replaced by `` ...
    (cut)``, so a message quoting a 140 000-character CSV cell stays one
    readable line.

    Parameters
    ----------
    stream : io.TextIOBase
        The stream written to.
    max_line : int, optional
        Longest line written (characters); default unlimited.
    """

    _CUT = " ... (cut)"

    def __init__(self, stream, max_line=None):
        self._stream = stream
        self._max = max_line
        self._col = 0           # characters of the current line already written

    def write(self, text):
        """Write ``text`` with its control characters (but newline and tab) escaped."""
        if not text.isprintable() and not all(c.isprintable() or c in _KEEP for c in text):
            text = "".join(c if c.isprintable() or c in _KEEP else escape(c) for c in text)
        if self._max is not None:
            text = self._cap(text)
        try:
            return self._stream.write(text)
        except BrokenPipeError:          # `| head`: the reader has gone, the work goes on
            self._reader_gone()
            return len(text)

    def flush(self):
        """Flush; a reader that has gone is not an error (the stream then writes to /dev/null)."""
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._reader_gone()

    def _reader_gone(self):
        """Point the stream's descriptor at /dev/null: a command whose stdout reader has gone
        (``hammerstein run ... | head -1``) finishes its work and exits with its own status
        (it stopped with exit 1 and no word, its report half done under ``set -o pipefail``)."""
        try:
            fd = self._stream.fileno()
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, fd)
            os.close(devnull)
        except (OSError, ValueError, AttributeError):
            pass

    def _cap(self, text):
        """``text`` with every line cut at ``max_line`` characters (counting earlier writes)."""
        room = self._max - len(self._CUT)
        parts = text.split("\n")
        out = []
        for i, part in enumerate(parts):
            if i:
                self._col = 0
            if self._col > room:              # already cut: drop the rest of the line
                part = ""
            elif self._col + len(part) > self._max:
                part = part[:room - self._col] + self._CUT
                self._col = room + 1
            else:
                self._col += len(part)
            out.append(part)
        return "\n".join(out)

    def __getattr__(self, name):
        return getattr(self._stream, name)



def out_dir_problem(out, follow_link=False):
    """Why ``out`` cannot be a reports directory (one line, for a usage error), or None.

    An empty path, a symbolic link (one planted at the directory's name, e.g.
    in a shared ``/tmp``, would send the files, ``--force`` replacing what
    is there, wherever it points), a path under an existing file (``f/sub``
    with ``f`` a file), an existing non-directory, or a directory that
    cannot be written, or a path the system refuses to name (a name over
    255 bytes, :func:`hammerstein.core.files.path_problem`). Nothing is created. ``follow_link=True`` takes a
    symbolic link for its target (the directory of a single output file,
    such as macOS's ``/tmp``, which a user names but never owns).
    """
    if not str(out).strip():
        return "--out: empty path; expected a directory"
    if str(out).strip() == "-":      # by convention stdout, never a directory named '-'
        return "--out: '-' (standard output) is not written to; expected a directory"
    if path_problem(out):            # a name over 255 bytes: ENAMETOOLONG at the first look
        return f"--out: {path_problem(out)}"
    p = Path(out)
    if os.path.islink(p) and not follow_link:
        return (f"--out: {p} is a symbolic link to {os.path.realpath(p)}; an output directory is "
                f"never followed through a link: give the directory itself")
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    if not p.is_dir():
        what = "exists and is not a directory" if p == Path(out) else "is not a directory"
        return f"--out: {p} {what}"
    if not os.access(p, os.W_OK | os.X_OK):
        return f"--out: {p}: permission denied (cannot write there)"
    return None


def written_by_hammerstein(path):
    """Whether the regular file ``path`` was written by this project (bounded read).

    Its provenance mark (:func:`hammerstein.core.files.carries_provenance`: a
    model, metrics, baseline, report or PNG file) or a drive file's first line
    (``# hammerstein <command> drive``).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    bool
        False also when the file cannot be read.
    """
    return carries_provenance(path) or is_drive_file(path)


def is_drive_file(path):
    """Whether ``path`` starts with a drive file's header (``# hammerstein <command> drive``).

    The header itself, not any line starting ``# hammerstein`` (a user's
    ``# hammerstein notes`` was taken for a drive and replaced). At most 200
    bytes are read.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    bool
        False also when the file cannot be read.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(200)
    except OSError:
        return False
    return re.match(rb"# hammerstein [a-z-]+ drive\b", head.removeprefix(b"\xef\xbb\xbf")) is not None


def out_file_problem(out, what="file", inputs=()):
    """Why ``out`` cannot be written as a single file (one line), or None.

    An empty path, a path ending with a separator, a directory, an existing special file (device, FIFO,
    socket) or read-only file, a path under an existing file, a symbolic
    link that cannot be followed (loop), or a directory that cannot be
    written, or a path the system refuses to name (a name over 255 bytes).
    A symlink is judged by its target, and followed only to a file this
    project wrote (its provenance mark, or a drive file's first line): a
    link to any other file, or a dangling one, is refused with or without
    ``--force`` (one planted at the name, e.g. in a shared ``/tmp``, would send
    the output wherever it points, ``--force`` replacing what is there; an
    output directory is never followed through a link either). A link to
    one of ``inputs`` (the files the command reads) is named as such.
    """
    if not str(out).strip():
        return f"--out: empty path; expected a {what} name"
    if str(out).strip() == "-":      # by convention stdout: a file named '-' was written instead
        return (f"--out: '-' (standard output) is not written to; expected a {what} name "
                f"(./- for a file of that name)")
    if path_problem(out):            # a name over 255 bytes: ENAMETOOLONG at the first look
        return f"--out: {path_problem(out)}"
    if str(out).endswith(("/", os.sep)) or (os.altsep and str(out).endswith(os.altsep)):
        # 'newdir/' names a directory: a file named newdir was written (and 'wrote newdir/')
        return f"--out: {out} ends with a separator, a directory's name; expected a {what} name"
    p = Path(out)
    if p.is_symlink():
        real = os.path.realpath(p)
        try:
            os.stat(p)
        except FileNotFoundError:          # a dangling link
            return (f"--out: {escape(out)} is a symbolic link to {escape(real)}, which does "
                    f"not exist; a file is never created through a link, with or without "
                    f"--force (one planted at the name would write wherever it points): remove "
                    f"the link or choose another name")
        except OSError as exc:  # a loop of links, a link through a file...
            return f"--out: {out}: cannot follow the symbolic link ({exc.strerror})"
        given = next((i for i in inputs if i is not None and os.path.lexists(i)
                      and same_file(real, i)), None)
        if given is not None:       # the more useful message of the two
            return (f"--out: {escape(out)} is also an input of this command ({escape(given)}); "
                    f"an input is never an output: choose another name")
        if os.path.isfile(real) and not written_by_hammerstein(real):
            return (f"--out: {escape(out)} is a symbolic link to {escape(real)}, which "
                    f"hammerstein did not write; a file is never replaced through a link, with "
                    f"or without --force (one planted at the name would send the {what} "
                    f"there): give {escape(real)} itself, remove the link or choose another "
                    f"name")
    link = (f" (a symbolic link to {escape(os.path.realpath(p))})" if p.is_symlink() else "")
    if p.is_dir():
        return f"--out: {out}{link} is a directory; expected a {what} name"
    if os.path.lexists(p) and p.exists() and not p.is_file():
        return (f"--out: {out}{link} is not a regular file (a device, FIFO or socket); expected "
                f"a {what} name")
    if p.is_file() and (not p.stat().st_mode & 0o222 or not os.access(p, os.W_OK)):
        return f"--out: {out} is read-only; make it writable (chmod u+w) or choose another name"
    problem = out_dir_problem(p.resolve().parent if p.is_symlink() else p.parent, follow_link=True)
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


def _words(low, high, low_open):
    if low is not None and high is not None:
        return f"a number in {'(' if low_open else '['}{low:g}, {high:g}]"
    if low is not None:
        return f"a number {'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"a number <= {high:g}"
    return "a finite number"


def number_type(low=None, high=None, low_open=False, unit=""):
    """An argparse ``type``: a real, finite, normal number in a range (the CLI's one checker).

    ``nan``, ``inf``, ``1e999``, a subnormal (``5e-324``, which overflows
    when divided into), a complex or a boolean spelling are refused, and
    so is a value outside ``[low, high]`` (``(low, high]`` with
    ``low_open``). argparse prints the message as one usage line (exit 2),
    prefixed with the option's name.

    Parameters
    ----------
    low, high : float, optional
        Bounds, inclusive (``low`` exclusive when ``low_open``).
    low_open : bool
        Whether ``low`` itself is refused (a positive number: ``low=0,
        low_open=True``).
    unit : str
        Unit named in the message (``"s"``, ``"Hz"``, ``"V"``).

    Returns
    -------
    callable
        ``text -> float``, raising :class:`argparse.ArgumentTypeError`.

    Examples
    --------
    >>> number_type(0, low_open=True, unit="s")("5e-5")
    5e-05
    >>> number_type(0, low_open=True, unit="s")("5e-324")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a number > 0 [s], found '5e-324' (subnormal)
    """
    expected = _words(low, high, low_open) + (f" [{unit}]" if unit else "")

    def parse(text):
        shown = escape(repr(text), 60)
        try:
            v = float(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"expected {expected}, found {shown}") from None
        # the checker of hammerstein.core.numbers.number_problem for a parsed float (that module
        # imports numpy, which `hammerstein --help` must not)
        problem = ("not finite" if not math.isfinite(v) else
                   "subnormal" if v != 0.0 and abs(v) < sys.float_info.min else None)
        if problem:
            raise argparse.ArgumentTypeError(f"expected {expected}, found {shown} ({problem})")
        if (low is not None and (v < low or (low_open and v == low))) or \
                (high is not None and v > high):
            raise argparse.ArgumentTypeError(f"expected {expected}, found {shown}")
        return v
    parse.__name__ = "number"
    return parse


def integer_type(low=None, high=None):
    """An argparse ``type``: an integer (ASCII digits, optional sign) in ``[low, high]``.

    Parameters
    ----------
    low, high : int, optional
        Inclusive bounds.

    Returns
    -------
    callable
        ``text -> int``, raising :class:`argparse.ArgumentTypeError` with
        the range in the message (``expected an integer 1..100000, found
        '1000000000'``).
    """
    if low is not None and high is not None:
        expected = f"an integer {low}..{high}"
    elif low is not None:
        expected = f"an integer >= {low}"
    else:
        expected = "an integer"

    def parse(text):
        t = str(text).strip()
        digits = t[1:] if t[:1] in "+-" else t
        if not (digits.isascii() and digits.isdigit()) or len(digits) > 30:
            raise argparse.ArgumentTypeError(f"expected {expected}, found {escape(repr(text), 60)}")
        v = int(t)
        if (low is not None and v < low) or (high is not None and v > high):
            raise argparse.ArgumentTypeError(f"expected {expected}, found {escape(repr(text), 60)}")
        return v
    parse.__name__ = "integer"
    return parse


def workers_type(text):
    """An argparse ``type`` for ``--workers``: 1 .. the machine's cores (``os.cpu_count``).

    More local workers than cores only multiply the memory and the load
    (each is a process with its own copy of the model), so the value is
    capped by the machine; ``HAMMERSTEIN_MAX_WORKERS`` raises the cap (e.g.
    for a machine whose ``os.cpu_count`` underestimates what it may use).

    Parameters
    ----------
    text : str

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer >= 1, or more than the cap (the message names it and
        the override).
    """
    n = integer_type(1)(text)
    cap = max_workers()
    if n > cap:
        raise argparse.ArgumentTypeError(
            f"{n} workers is more than the {cap} this machine has cores for (os.cpu_count); "
            f"use at most {cap}, or raise the cap with HAMMERSTEIN_MAX_WORKERS=N")
    return n


def max_workers():
    """Most local dask workers: ``HAMMERSTEIN_MAX_WORKERS`` if a positive integer, else the cores.

    Returns
    -------
    int
        At least 1.
    """
    text = os.environ.get("HAMMERSTEIN_MAX_WORKERS", "").strip()
    if text.isascii() and text.isdigit() and int(text) > 0:
        return int(text)
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(int(cores), 1)


_HOST = re.compile(r"^(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.-]{0,252}[A-Za-z0-9])?)$")


def scheduler_type(text):
    """An argparse ``type`` for ``--scheduler``: ``[tcp://]HOST:PORT``, parsed before connecting.

    Only TCP is accepted: ``tls://`` needs certificates that the command
    line does not configure, ``inproc://`` names a scheduler inside another
    process (unreachable from this one), and other schemes are not dask
    transports. The port must be 1-65535 (``99999`` would make the client
    wait its whole time-out before failing).

    Parameters
    ----------
    text : str
        ``tcp://127.0.0.1:8786``, ``127.0.0.1:8786``, ``[::1]:8786``.

    Returns
    -------
    str
        The address with its scheme (``tcp://HOST:PORT``).

    Raises
    ------
    argparse.ArgumentTypeError
        One line saying what is wrong and what is expected.
    """
    shown = escape(repr(text), 80)
    t = str(text).strip()
    scheme, sep, rest = t.partition("://")
    if not sep:
        scheme, rest = "tcp", t
    scheme = scheme.lower()
    if scheme != "tcp":
        why = {"tls": "needs TLS certificates, which the command line does not configure",
               "inproc": "names a scheduler inside another process, unreachable from this one"}
        raise argparse.ArgumentTypeError(
            f"expected tcp://HOST:PORT, found {shown} ({scheme}:// "
            f"{why.get(scheme, 'is not a transport hammerstein uses')})")
    host, colon, port = rest.rpartition(":")
    if not colon or not host or not _HOST.match(host):
        raise argparse.ArgumentTypeError(f"expected tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786), "
                                         f"found {shown}")
    if not (port.isascii() and port.isdigit() and 1 <= int(port) <= 65535):
        raise argparse.ArgumentTypeError(f"expected a port 1..65535 in tcp://HOST:PORT, found "
                                         f"{shown}")
    return f"tcp://{host}:{int(port)}"
