"""Command-line interface: ``hammerstein run | validate | list | ...``.

One module per subcommand (``hammerstein/cli/<command>.py``), each with a
function ``add_parser(subparsers)`` that adds its parser and sets
``handler=<function(args) -> exit status>``. Subcommands are registered in
:data:`COMMANDS` (name -> module, one-line help); only the module of the
command being run is imported, so ``hammerstein --help`` stays light.

Exit status: 0 on success, 1 when a scenario failed (the others still
run), 2 on usage errors.

stderr carries one line per problem and nothing else: ``error: <file>:
<message>`` for a failed scenario (its problems joined by ``; ``),
``error: <file>: <key>: <message>`` per problem for ``validate``,
``warning: <file>: <case or N cases>: <message>`` per distinct warning of a
scenario that ran (``-v``: per case; ``-q``: none),
``hammerstein <command>: error: <message>`` for a usage error, and any other
Python warning as one ``warning: <Category>: <message>`` line (no traceback).
"""

from __future__ import annotations

import argparse
import atexit
import errno
import importlib
import logging
import os
import re
import signal
import sys
import threading
import warnings

from hammerstein.core._version import VERSION
from hammerstein._cache import numba_cache_dir, use_user_numba_cache
from hammerstein.cli._examples import add_examples
from hammerstein.cli._common import MAX_LINE, WARNING_STATE, SafeStream, one_line, print_err
from hammerstein.core.files import (escape, interrupt, raise_if_interrupted, reset_guard,
                                    reset_interrupt, start_budget)

# One BLAS thread unless the user set one: the run's matrices are small and its
# processes (simulation, figure workers) already use the cores; OpenBLAS threads
# spinning on a loaded machine cost 2-3x the CPU time of the identification
# (benchmarks/cli.py). Set before numpy is first imported (nothing above imports it).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__all__ = ["main", "build_parser", "one_line", "COMMANDS"]


class _Parser(argparse.ArgumentParser):
    """argparse parser whose usage errors are one line on stderr (exit status 2).

    A value starting with a minus sign then a digit is a value, not an option:
    ``--range -20,120`` (an amplifier's negative lower rail) or ``--gain -1e-3``
    read as ``--range=-20,120``, where argparse alone takes only ``-20`` or
    ``-0.5`` as numbers (no option of the commands starts with ``-`` and a digit).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message):
        """Print the usage error as one line on stderr and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see '{self.prog} --help')\n")

    def parse_known_args(self, args=None, namespace=None):
        """argparse's, refusing an option that takes a value given twice.

        argparse keeps the last one: ``excitation --range -10,10 --range 0,100`` drove every
        input over 0..100 V, ten times an x amplifier's rail, with exit 0.
        """
        seen = {}
        tokens = sys.argv[1:] if args is None else list(args)
        for i, token in enumerate(tokens):
            if token == "--":
                break
            if not token.startswith("-") or self._negative_number_matcher.match(token):
                continue
            key = token.split("=", 1)[0]
            value = token.split("=", 1)[1] if "=" in token else \
                (tokens[i + 1] if i + 1 < len(tokens) else "")
            action = self._option_string_actions.get(key)
            if action is None and self.allow_abbrev and key.startswith("--"):
                found = {a for s, a in self._option_string_actions.items() if s.startswith(key)}
                action = found.pop() if len(found) == 1 else None
            if action is None or action.nargs == 0 or isinstance(action, argparse._AppendAction):
                continue
            if action.dest in seen:
                self.error(f"{key}: given twice ({seen[action.dest]!r}, then {value!r}, which "
                           f"would replace it); give it once")
            seen[action.dest] = value
        return super().parse_known_args(args, namespace)


#: What a stray warning is about (shared with the commands, which name the file they
#: are processing): the one input file of the command, else ``hammerstein <command>``.
_WARNING_STATE = WARNING_STATE

#: Arguments naming the files a command reads, in order of importance.
_INPUT_ARGUMENTS = ("scenarios", "data", "source", "actuator", "measured", "drive", "reference")


def _warning_subject(args):
    """The file a stray warning of this command is about (its one input file), else the command."""
    found = []
    for name in _INPUT_ARGUMENTS:
        value = getattr(args, name, None)
        for v in value if isinstance(value, list) else [value]:
            if isinstance(v, str) and v not in found and os.path.isfile(v):
                found.append(v)
    return found[0] if len(found) == 1 else f"hammerstein {getattr(args, 'command', '')}".strip()


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    """warnings.showwarning replacement: one ``warning: <file>: message`` line.

    The file is the command's input (:func:`_warning_subject`); a warning
    repeated (the same overflow in a loop) is printed once. The warning's class
    (``UserWarning``, ``ConvergenceWarning``) is Python's, not the user's: not printed.
    """
    _print_warning(None, message, file)


def _print_warning(source, message, file=None):
    """One ``warning: <file>: [<source>: ]<message>`` line, each distinct one once."""
    body = ' '.join(str(message).split())
    subject = f"{_WARNING_STATE['subject']}: "
    # a message that names the file itself (a preset's aliased mode) is not prefixed twice
    head = ("" if source is None and body.startswith(subject) else subject) + \
        ("" if source is None else f"{source}: ")
    text = f"warning: {head}{body}"
    if text in _WARNING_STATE["said"]:
        return
    _WARNING_STATE["said"].add(text)
    print(escape(text, MAX_LINE), file=sys.stderr if file is None else file)


class _OneLineLog(logging.Handler):
    """Log records of the libraries (matplotlib's "mkdir -p failed", numba, dask) as one
    ``warning: <file>: <logger>: message`` line each, like the stray warnings."""

    def emit(self, record):
        try:
            msg = record.getMessage()
        except Exception:   # noqa: BLE001 - a library's malformed log call must not fail the command
            msg = str(record.msg)
        _print_warning(record.name, msg)


# -- the commands: name -> (module with add_parser(subparsers), one-line help) ------------
#: Every subcommand. Its module defines ``add_parser(subparsers)`` (which sets
#: ``handler=<function(args) -> exit status>``) and imports what the command
#: needs at module level; it is imported only when its command is run (or by
#: :func:`build_parser` without a command), so ``hammerstein --help`` imports
#: none of the numerical stack. Add a command with one line here and a
#: module ``hammerstein/cli/<command>.py``.
COMMANDS = {
    "run": ("hammerstein.cli.run", "simulate scenarios and write reports"),
    "validate": ("hammerstein.cli.validate", "check scenario files without simulating"),
    "list": ("hammerstein.cli.listing", "list bundled presets, compensator kinds and scenarios"),
    "identify": ("hammerstein.cli.identify", "identify a (multivariable) hysteresis model from measured records"),
    "excitation": ("hammerstein.cli.excitation", "write excitation files to play on an actuator before identifying it"),
    "check": ("hammerstein.cli.check", "run scenarios and compare their metrics with a baseline"),
    "replicate": ("hammerstein.cli.replicate", "regenerate the replication report of the paper"),
    "export": ("hammerstein.cli.export", "write a compensator as C99 code or as an FMI 2.0 FMU"),
    "compensate": ("hammerstein.cli.compensate", "write the drive file (input voltages) for a reference"),
    "evaluate": ("hammerstein.cli.evaluate", "metrics and figures of a measured response"),
    "learn": ("hammerstein.cli.learn", "one iterative-learning step from drive and measured files"),
    "warmup": ("hammerstein.cli.warmup", "compile every simulation kernel once into numba's cache"),
}


def _version():
    """This source tree's version (``hammerstein --version``)."""
    return VERSION


def build_parser(command=None):
    """The argparse parser of ``hammerstein``.

    Parameters
    ----------
    command : str, optional
        Only this subcommand's module is imported and its full parser built;
        the others get a placeholder with their one-line help (enough for
        ``hammerstein --help`` and for rejecting an unknown command). Default:
        every subcommand in full.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = _Parser(
        prog="hammerstein",
        description="Multivariable Prandtl-Ishlinskii hysteresis of piezoelectric actuators: "
                    "simulate scenarios, compensate, report.")
    parser.add_argument("--version", action="version", version=f"hammerstein {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for name, (module, help_text) in COMMANDS.items():
        if command is None or name == command:
            importlib.import_module(module).add_parser(sub)
            add_examples(sub.choices[name], name)   # the examples at the end of --help
        else:
            sub.add_parser(name, help=help_text)
    return parser


def _quiet_interrupt_hook(previous):
    """``sys.unraisablehook`` that drops the interruption raised where Python cannot propagate it.

    A signal handled inside a finaliser or a callback printed ``Exception
    ignored in ... _Interrupted: 2`` and a traceback before ``interrupted``;
    the signal is still remembered (:func:`hammerstein.core.files.interrupt`)
    and ends the command at the next check. Any other unraisable error goes
    to ``previous``.
    """
    def hook(unraisable):
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            return
        previous(unraisable)
    return hook


#: Whether a signal ended (or is ending) the current command (:func:`_on_signal`).
_SIGNALLED = [False]


def _quiet_thread_hook(previous):
    """``threading.excepthook`` that drops a thread's error once a signal ends the command.

    The fits' process pool has a manager thread: when Ctrl-C stops the workers, it can
    fail on their pipes while the command says ``interrupted`` and exits, and printed
    ``Exception in thread Thread-1: Traceback ...`` after that line (once in a loaded
    CI run of the Ctrl-C test). Errors of threads before any signal go to ``previous``.
    """
    def hook(args):
        if _SIGNALLED[0]:
            return
        previous(args)
    return hook


def _on_signal(signum, frame):
    # later signals are ignored so that the clean-up in progress (removing a
    # temporary directory) is not interrupted in turn; inside the creation or
    # rename of a temporary the interruption waits for its end
    for sig in _SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    _SIGNALLED[0] = True
    interrupt(signum)


#: Signals that end a command with ``interrupted`` (SIGHUP: the terminal or ssh went away).
_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


def _install_signal_handlers():
    """SIGINT/SIGTERM/SIGHUP -> a KeyboardInterrupt (:func:`hammerstein.core.files.interrupt`); returns the previous handlers (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    nohup = getattr(signal, "SIGHUP", None)
    return {sig: signal.signal(sig, _on_signal) for sig in _SIGNALS
            if not (sig == nohup and signal.getsignal(sig) is signal.SIG_IGN)}  # nohup kept


#: Backends matplotlib knows by name (MPLBACKEND); the reports draw with Agg anyway.
_MPL_BACKENDS = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template", "gtk3agg", "gtk3cairo",
                 "gtk4agg", "gtk4cairo", "macosx", "nbagg", "notebook", "qtagg", "qtcairo",
                 "qt5agg", "qt5cairo", "tkagg", "tkcairo", "webagg", "wx", "wxagg", "wxcairo",
                 "inline", "ipympl", "widget"}


def _fill_standard_fds():
    """Open /dev/null on a closed fd 0, 1 or 2 (``>&-``), so that no file the command
    writes takes its number and ``print`` has somewhere to go."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            try:
                new = os.open(os.devnull, os.O_RDWR)
            except OSError:
                return
            if new != fd:
                os.dup2(new, fd)
                os.close(new)
    for name, fd in (("stdout", 1), ("stderr", 2)):
        stream = getattr(sys, name)
        if stream is None:
            try:
                setattr(sys, name, open(fd, "w", encoding="utf-8", errors="backslashreplace",
                                        closefd=False))
            except OSError:
                pass
        elif hasattr(stream, "reconfigure"):
            try:  # PYTHONIOENCODING=ascii: a unit (µm) must not fail a finished command
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError):
                pass


def _writable_dir(path):
    """Whether ``path`` (or its nearest existing parent) is a directory one can write."""
    p = os.path.abspath(path)
    while not os.path.exists(p) and os.path.dirname(p) != p:
        p = os.path.dirname(p)
    return os.path.isdir(p) and os.access(p, os.W_OK | os.X_OK)


def _numba_cache_dir():
    """A private temporary numba cache: ``$TMPDIR/hammerstein-numba-<uid>`` (mode 0700, ours)."""
    import tempfile
    base = os.path.join(tempfile.gettempdir(), f"hammerstein-numba-{os.getuid()}")
    try:
        os.mkdir(base, 0o700)
    except FileExistsError:
        pass
    except OSError:
        return tempfile.mkdtemp(prefix="hammerstein-numba-")
    st = os.lstat(base)
    import stat as stat_
    if (not stat_.S_ISDIR(st.st_mode) or st.st_uid != os.getuid()
            or st.st_mode & 0o022):     # someone else's or writable by others: not trusted
        return tempfile.mkdtemp(prefix="hammerstein-numba-")
    return base


def _prepare_environment():
    """Check the environment variables of the dependencies before they are imported.

    ``NUMBA_NUM_THREADS`` that is not a positive integer and an unknown
    ``MPLBACKEND`` are removed; with no writable place for numba's cache
    (package directory and ``~/.cache`` read-only, ``NUMBA_CACHE_DIR``
    unset or not writable) a private temporary cache is used. Each change
    is one ``note:`` line on stderr.

    Returns
    -------
    list of str
        The notes printed.
    """
    notes = []
    threads = os.environ.get("NUMBA_NUM_THREADS")
    if threads is not None and not (threads.strip().isascii() and threads.strip().isdigit()
                                    and 0 < int(threads) <= 4096):
        del os.environ["NUMBA_NUM_THREADS"]
        notes.append(f"note: NUMBA_NUM_THREADS={escape(threads, 40)!s} is not a positive "
                     f"integer; ignored")
    backend = os.environ.get("MPLBACKEND")
    if backend is not None and backend.strip().lower() not in _MPL_BACKENDS \
            and not backend.startswith("module://"):
        del os.environ["MPLBACKEND"]
        notes.append(f"note: MPLBACKEND={escape(backend, 40)} is not a matplotlib backend; "
                     f"ignored (the figures are drawn with Agg)")
    cache = os.environ.get("NUMBA_CACHE_DIR", "").strip()
    user = numba_cache_dir()   # the user's cache directory (hammerstein/_cache.py)
    ok = user is not None and _writable_dir(user)
    if not ok:
        try:
            where = _numba_cache_dir()
        except OSError:
            where = None
        if where is not None:
            os.environ["NUMBA_CACHE_DIR"] = where
            notes.append(f"note: no writable cache for the compiled kernels "
                         f"({'NUMBA_CACHE_DIR' if cache else 'home directory'} read-only); "
                         f"using {where}")
    for line in notes:
        print_err(line)
    return notes


def _guard_kernel_cache():
    """A numba cache that cannot be written (full disk, quota, read-only) costs one
    ``note:`` line, not the run (``guard_cache_writes`` of ``hammerstein/simulation/_compile.py``).

    Only when the command's module has loaded the kernels (``list``, ``--help``
    stay free of numba).
    """
    if "hammerstein.simulation" in sys.modules:
        importlib.import_module("hammerstein.simulation._compile").guard_cache_writes(print_err)


#: Commands that choose themselves how to announce kernel compilations (``-q``/``-v``; warmup
#: prints each workload's)
_OWN_NOTICES = ("run", "check", "warmup")


def _announce_compiles(command):
    """A first run of any other command says, on stderr, that it waits for the compiler.

    ``compensate`` on a cold cache waited 10 s (against 2 s warm) without a word.
    Only when the command's module has loaded the kernels.
    """
    if command not in _OWN_NOTICES and "hammerstein.simulation" in sys.modules:
        importlib.import_module("hammerstein.simulation._compile").announce_compiles(print_err)


#: Commands that run scenarios: on a cold numba cache their chain kernel is compiled in a
#: helper process while they import, validate and resolve (``prefetch`` in
#: ``hammerstein/simulation/_compile.py``).
_PREFETCHING = ("run", "check")


def _prefetch_kernels(command, argv):
    """Start compiling the chain kernel on another core, before the command's imports.

    Only for :data:`_PREFETCHING` commands that name an existing file and ask
    for no help; a failure to start the helper is not an error (the run
    compiles the kernel itself).
    """
    if command not in _PREFETCHING or any(a in ("-h", "--help") for a in argv):
        return
    files = [a for a in argv if a != command and os.path.isfile(a)]
    if not files:
        return
    try:
        importlib.import_module("hammerstein.simulation._compile").prefetch(
            "hammerstein" if any(_mentions_hammerstein(f) for f in files) else "default")
    except Exception:       # noqa: BLE001 - an optimisation never fails a run
        pass


#: A scenario's compensator table of kind "hammerstein" (inline or not); a hint only
_HAMMERSTEIN_KIND = re.compile(rb'kind\s*=\s*["\']hammerstein["\']')


def _mentions_hammerstein(path, limit=1 << 20):
    """True when the first ``limit`` bytes of ``path`` name a ``kind = "hammerstein"`` table.

    Which chain kernel the helper compiles (:func:`_prefetch_kernels`): a
    hint read before validation, bounded, never an error (False).
    """
    try:
        with open(path, "rb") as fh:
            return bool(_HAMMERSTEIN_KIND.search(fh.read(limit)))
    except OSError:
        return False


def _command(argv):
    """The subcommand named in ``argv`` (its first argument not starting with '-'), or None."""
    for a in argv:
        if not a.startswith("-"):
            return a if a in COMMANDS else None
    return None


def main(argv=None):
    """The ``hammerstein`` command as a function; the console script is :func:`run`.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 1 a scenario failed (or the output could
        not be written: a full disk), 2 usage error, 130 interrupted by
        SIGINT (Ctrl-C), 143 by SIGTERM, 129 by SIGHUP; an interruption
        prints the one line ``interrupted`` and removes the temporary
        directory of the report in progress.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    # before any command module imports numba (warmup's does, at its top), which reads
    # NUMBA_CACHE_DIR once: the kernels go to the user's cache, never into the package's sources
    use_user_numba_cache()
    _fill_standard_fds()
    reset_interrupt()        # a signal an embedding program received before is not this command's
    _SIGNALLED[0] = False
    thread_hook = threading.excepthook
    threading.excepthook = _quiet_thread_hook(thread_hook)
    previous = _install_signal_handlers()
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = SafeStream(sys.stdout), SafeStream(sys.stderr, MAX_LINE)  # no raw control chars
    unraisable = sys.unraisablehook
    sys.unraisablehook = _quiet_interrupt_hook(unraisable)
    try:
        try:
            code = _main(argv)
        except Exception:
            raise_if_interrupted()   # raised outside the handler's try (the imports of the parser)
            raise
        return _flush_output(code)
    except KeyboardInterrupt as exc:  # SIGINT or SIGTERM: one line, no traceback
        signum = getattr(exc, "signum", signal.SIGINT)
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        print_err("interrupted")
        return 128 + int(signum)
    finally:
        sys.unraisablehook = unraisable
        threading.excepthook = thread_hook
        reset_guard()        # an embedding program's later writes are its own
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        reset_interrupt()    # after the handlers: no signal of this command comes later
        sys.stdout, sys.stderr = streams


def _flush_output(code):
    """Flush stdout: a full disk or a failing device turns success into 1 with one line.

    A reader that has gone (broken pipe) or a closed stdout is not an error.
    """
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
    except (OSError, ValueError) as exc:
        _silence_stdout()
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EIO, errno.EDQUOT,
                                                        errno.EFBIG):
            print_err(f"hammerstein: error: cannot write the output ({exc.strerror})")
            return code or 1
    return code


def _silence_stdout():
    """Point fd 1 at /dev/null so that the interpreter's last flush cannot fail."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)
        sys.stdout = SafeStream(open(1, "w", closefd=False))
    except OSError:
        pass


def _command_parser(parser, command):
    """The sub-parser of ``command`` (the top-level parser without one)."""
    for action in parser._actions:
        choices = getattr(action, "choices", None)
        if isinstance(choices, dict) and command in choices:
            return choices[command]
    return parser


def _main(argv):
    """:func:`main` without the signal handling."""
    if not any(a == "--version" for a in argv) or _command(argv) is not None:
        _prepare_environment()
    command = _command(argv)
    start_budget()
    reset_guard()     # the inputs a command declares are its own
    _prefetch_kernels(command, argv)
    parser = build_parser(command) if command is not None else build_parser("")
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:              # named by the command's parser, not the top-level one
            _command_parser(parser, command).error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # argparse: usage error (2) or --help (0)
        return int(exc.code or 0)
    _guard_kernel_cache()
    _announce_compiles(command)
    _WARNING_STATE["subject"] = _warning_subject(args)
    _WARNING_STATE["said"] = set()
    root = logging.getLogger()
    log_handler = None
    if not root.handlers:   # else the embedding program chose where logs go
        log_handler = _OneLineLog(logging.WARNING)
        root.addHandler(log_handler)
    with warnings.catch_warnings():  # stray warnings: one line each, no source line
        warnings.showwarning = _one_line_warning
        try:
            return int(args.handler(args))
        except BrokenPipeError:  # `hammerstein list | head`: the reader has gone; say nothing
            _silence_stdout()
            return 1
        except OSError as exc:  # stdout on a full disk
            if exc.filename is None and exc.errno in (errno.ENOSPC, errno.EIO, errno.EDQUOT):
                _silence_stdout()
                print_err(f"hammerstein {args.command}: error: cannot write the output "
                          f"({exc.strerror})")
                return 1
            if os.environ.get("HAMMERSTEIN_DEBUG"):
                raise
            print_err(f"hammerstein {args.command}: error: unexpected {type(exc).__name__}: "
                      f"{escape(one_line(exc))} (HAMMERSTEIN_DEBUG=1 shows the traceback)")
            return 1
        except Exception as exc:  # a bug, not bad input: still one line, no traceback
            raise_if_interrupted()   # a signal's doing (e.g. a module whose import it cut short)
            if os.environ.get("HAMMERSTEIN_DEBUG"):
                raise
            print_err(f"hammerstein {args.command}: error: unexpected {type(exc).__name__}: "
                      f"{escape(one_line(exc), 500)} (HAMMERSTEIN_DEBUG=1 shows the traceback)")
            return 1
        finally:
            if log_handler is not None:
                root.removeHandler(log_handler)


def run(argv=None):
    """The console script: :func:`main`, then exit without the interpreter's teardown.

    Once the command is done, every file it wrote is closed and its figure
    workers have exited; what is left is the interpreter freeing its modules
    (numba, scipy, pandas, matplotlib), about 0.3 s a user would wait for
    nothing. This flushes the standard streams, runs the ``atexit``
    handlers (logging, multiprocessing) and ends the process with
    ``os._exit``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    NoReturn
        The process exits with :func:`main`'s status.
    """
    # the console process's threads (the fits' pool manager) may fail on the pipes of the
    # workers a signal stopped until the process ends, after main has returned
    threading.excepthook = _quiet_thread_hook(threading.excepthook)
    code = main(argv)
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said
            pass
    if code >= 128 and threading.current_thread() is threading.main_thread():
        # interrupted: the same signal sent again to the process group (a terminal's Ctrl-C,
        # timeout's) would cut the exit handlers short with a KeyboardInterrupt traceback
        # ("Exception ignored in atexit callback ... _exit_function") after "interrupted"
        for sig in _SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
    atexit._run_exitfuncs()
    os._exit(code)


if __name__ == "__main__":
    run()
