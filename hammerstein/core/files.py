"""Bounded reads and safe writes of the files the project reads and writes.

Every file hammerstein reads (scenario, preset, model, tolerance, baseline and
data files) goes through :func:`bounded_read_bytes` / :func:`bounded_read_text`:
the path must name a regular file (not a directory, device or FIFO; a symlink
is followed) no larger than a size limit, checked *before* reading, so
``model = "/dev/zero"`` fails at once instead of filling the memory.

Every single file it writes (model, preset and baseline files) goes through
:func:`safe_write`: the content is written to a temporary file created
exclusively (``O_EXCL``, unique name ``.<name>.<random>.hammerstein-tmp``)
next to the target, then renamed over it, so a reader never sees a
half-written file and an interrupted write leaves the target untouched. A
target that exists but is not a regular file is refused; a symlink's target
is written (the link stays); a read-only target is refused (a rename would
bypass its protection); a replaced file keeps its permission bits and a new
one gets the user's umask.

Limits (bytes), overridable with environment variables:

==========================  ==============================  ===========
what                        variable                        default
==========================  ==============================  ===========
TOML (scenario/preset/model HAMMERSTEIN_MAX_TOML_BYTES      4 MiB
/tolerances)
data records (CSV/text)     HAMMERSTEIN_MAX_DATA_BYTES      256 MiB
baseline CSV                HAMMERSTEIN_MAX_BASELINE_BYTES  64 MiB
==========================  ==============================  ===========
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
import threading
from contextlib import contextmanager
from pathlib import Path

from hammerstein.exceptions import FileLimitError, OutputError
from hammerstein.core import _stale
from hammerstein.core._stale import STALE_TMP_S, _read_only_mount, _remove_stale_temporaries  # noqa: F401
# user strings, provenance and locks, owners of temporaries and scenario paths live in
# private modules; this module is their public face (every name importable from here)
from hammerstein.core._strings import (C_HEADERS, C_RESERVED, EXCERPT, MAX_NAME_CHARS,
                                       c_name_problem, escape, markdown_escape, markdown_text,
                                       name_problem)
from hammerstein.core._provenance import (LOCK_TIMEOUT, PROVENANCE, carries_provenance, locked,
                                          png_provenance, provenance_line, replace_problem,
                                          same_file, hash_blocks)
from hammerstein.core._dirs import file_digest, make_directory  # noqa: F401 (public here)
from hammerstein.core._owners import owner_alive, owner_token, parse_owner, release_owner
from hammerstein.core._paths import (ALLOW_ENV, MAX_NAME_BYTES, MAX_PATH_CHARS, confined_path,
                                     path_problem, recorded_paths)

__all__ = ["FileLimitError", "LIMITS", "limit", "check_regular", "bounded_read_bytes", "file_digest", "make_directory",
           "bounded_read_text", "safe_write", "start_budget", "umask", "TMP_SUFFIX", "deferred_signals",
           "reset_interrupt", "interrupt", "raise_if_interrupted", "file_limit_problem",
           "all_or_nothing", "PROVENANCE", "provenance_line", "png_provenance",
           "carries_provenance", "same_file", "hash_blocks", "replace_problem", "locked", "LOCK_TIMEOUT",
           "escape", "markdown_escape", "markdown_text", "EXCERPT", "owner_token", "release_owner",
           "parse_owner", "owner_alive", "ALLOW_ENV", "path_problem", "confined_path",
           "MAX_PATH_CHARS", "MAX_NAME_BYTES", "OutputError", "guard_inputs", "reset_guard",
           "output_problem", "name_problem", "append_text", "replace_directory", "c_name_problem", "MAX_NAME_CHARS", "C_RESERVED",
           "C_HEADERS", "recorded_paths", "removed_if_failed"]

for _name in ("c_name_problem", "escape", "markdown_escape", "markdown_text", "name_problem", "carries_provenance",
              "locked", "png_provenance", "provenance_line", "replace_problem", "same_file", "hash_blocks",
              "owner_alive", "owner_token", "parse_owner", "release_owner", "confined_path",
              "path_problem", "recorded_paths"):
    globals()[_name].__module__ = __name__      # documented as this module's
del _name

#: Default size limits [bytes] and the environment variables overriding them.
LIMITS = {
    "toml": ("HAMMERSTEIN_MAX_TOML_BYTES", 4 * 2**20),
    "data": ("HAMMERSTEIN_MAX_DATA_BYTES", 256 * 2**20),
    "baseline": ("HAMMERSTEIN_MAX_BASELINE_BYTES", 64 * 2**20),
    "cache": ("HAMMERSTEIN_MAX_CACHE_BYTES", 64 * 2**20),
    "total": ("HAMMERSTEIN_MAX_TOTAL_BYTES", 1024 * 2**20),
}

_BUDGET = {"active": False, "used": 0, "seen": set()}


def start_budget():
    """Start counting the bytes of the data files a command reads (the command line calls it).

    While counted, :func:`bounded_read_bytes` of ``kind="data"`` refuses a
    file that would take the total over :func:`limit` ``("total")``
    (``HAMMERSTEIN_MAX_TOTAL_BYTES``, default 1 GiB), so that many files
    each under the per-file limit cannot exhaust the memory together.
    """
    _BUDGET["active"], _BUDGET["used"], _BUDGET["seen"] = True, 0, set()

#: Suffix of the temporary files of :func:`safe_write`.
TMP_SUFFIX = _stale.TMP_SUFFIX


def _size(n):
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= scale:
            text = f"{n / scale:.4g} {unit}"
            return text if n % scale == 0 else f"{text} ({n} bytes)"  # never "4 MiB > 4 MiB"
    return f"{n} bytes"


def _positive_int(text):
    """``int(text)`` when ``text`` is ASCII digits of a positive integer, else None (``²`` is not)."""
    text = (text or "").strip()
    if text.isascii() and text.isdigit() and int(text) > 0:
        return int(text)
    return None


def _hint(kind):
    """``raise it with VAR=BYTES``, noting an override that is not a positive integer."""
    var = LIMITS[kind][0]
    text = os.environ.get(var)
    bad = "" if text is None or _positive_int(text) else \
        f"; its value {text!r} is not a positive integer, the default applies"
    return f"raise it with {var}=BYTES{bad}"


def limit(kind):
    """The size limit [bytes] of a kind of file.

    The environment variable of :data:`LIMITS` overrides the default; a
    value that is not a positive integer is ignored.

    Parameters
    ----------
    kind : {'toml', 'data', 'baseline', 'cache', 'total'}
        Key of :data:`LIMITS`.

    Returns
    -------
    int
        Largest accepted size [bytes].
    """
    var, default = LIMITS[kind]
    return _positive_int(os.environ.get(var)) or default


def check_regular(path, what="file"):
    """``os.stat`` of ``path`` if it is a regular file (a symlink is followed).

    Parameters
    ----------
    path : str or pathlib.Path
    what : str
        What the file should be, for messages.

    Returns
    -------
    os.stat_result

    Raises
    ------
    FileNotFoundError
        If nothing is at ``path``.
    FileLimitError
        A directory, device, FIFO or socket.
    """
    st = os.stat(path)  # follows symlinks; FileNotFoundError passes through
    if stat.S_ISDIR(st.st_mode):
        raise FileLimitError(f"{path}: is a directory, expected a {what}")
    if not stat.S_ISREG(st.st_mode):
        raise FileLimitError(f"{path}: not a regular file (a device, FIFO or socket), "
                             f"expected a {what}")
    return st


def file_limit_problem(path, kind="data", what="file"):
    """Why :func:`bounded_read_bytes` would refuse ``path``, told before anything is read, or None.

    For validation that reads nothing (``validate``): the same words as the
    read's :class:`FileLimitError` for a file that is not a regular file or
    is larger than the limit; the read itself checks again on its open file.

    Parameters
    ----------
    path : str or pathlib.Path
    kind : {'toml', 'data', 'baseline', 'cache', 'total'}
        Selects the size limit.
    what : str
        What the file should be, for messages.

    Returns
    -------
    str or None
        One line naming ``path``; None for a regular file within the limit
        (or one that cannot be looked at: the read names that).
    """
    try:
        st = check_regular(path, what)
    except FileLimitError as exc:
        return str(exc)
    except OSError:
        return None
    if st.st_size > limit(kind):
        return (f"{path}: {_size(st.st_size)} is larger than the limit of {_size(limit(kind))} "
                f"for a {what} ({_hint(kind)})")
    return None


def bounded_read_bytes(path, kind="toml", what="file", head=None, cap=None):
    """Read a regular file of at most :func:`limit` ``(kind)`` bytes.

    Parameters
    ----------
    path : str or pathlib.Path
    kind : {'toml', 'data', 'baseline', 'cache', 'total'}
        Selects the size limit (and the variable named in messages).
    what : str
        What the file should be, for messages ("scenario file", ...).
    head : int, optional
        Read only the file's first ``head`` bytes (its header lines): a
        larger file is not refused, and nothing is counted in the budget.
    cap : int, optional
        The size limit [bytes] instead of :func:`limit` ``(kind)`` (a drive
        file's, :func:`hammerstein.compensation.drive_size.drive_file_limit`).

    Returns
    -------
    bytes

    Raises
    ------
    FileNotFoundError
        Nothing at ``path``.
    FileLimitError
        Not a regular file, or larger than the limit (the message names the
        environment variable that raises it).
    OSError
        The file cannot be opened or read (permissions...).
    """
    cap = limit(kind) if cap is None else int(cap)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a FIFO must not block open()
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise FileLimitError(f"{path}: is a directory, expected a {what}")
        if not stat.S_ISREG(st.st_mode):
            raise FileLimitError(f"{path}: not a regular file (a device, FIFO or socket), "
                                 f"expected a {what}")
        if head is not None:          # the opening lines only: bounded by head, whatever the size
            chunks, total = [], 0
            while total < head:
                chunk = os.read(fd, min(1 << 20, head - total))
                if not chunk:
                    break
                chunks.append(chunk)
                total += len(chunk)
            return b"".join(chunks)
        if st.st_size > cap:
            raise FileLimitError(f"{path}: {_size(st.st_size)} is larger than the limit of "
                                 f"{_size(cap)} for a {what} ({_hint(kind)})")
        counted = kind == "data" and _BUDGET["active"] and \
            (st.st_dev, st.st_ino) not in _BUDGET["seen"]          # a file read again is free
        if counted and _BUDGET["used"] + st.st_size > limit("total"):
            raise FileLimitError(
                f"{escape(path)}: {_size(st.st_size)} more would take the data files of this "
                f"command over the total limit of {_size(limit('total'))} ({_hint('total')})")
        chunks, total = [], 0
        while True:  # the file may grow while read: never more than cap + 1 bytes
            chunk = os.read(fd, min(1 << 20, cap + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > cap:
                raise FileLimitError(f"{path}: larger than the limit of {_size(cap)} for a "
                                     f"{what} ({_hint(kind)})")
        if counted:
            _BUDGET["used"] += total
            _BUDGET["seen"].add((st.st_dev, st.st_ino))
        return b"".join(chunks)
    finally:
        os.close(fd)


def bounded_read_text(path, kind="toml", what="file", encoding="utf-8"):
    """:func:`bounded_read_bytes`, decoded.

    Parameters
    ----------
    path : str or pathlib.Path
    kind : {'toml', 'data', 'baseline', 'cache', 'total'}
        Selects the size limit.
    what : str
        What the file should be, for messages.
    encoding : str
        Text encoding. With UTF-8 (the default) a leading byte-order mark
        (``EF BB BF``, written by some Windows editors and by Excel's "CSV
        UTF-8") is dropped: it marks the encoding, it is not text.

    Returns
    -------
    str

    Raises
    ------
    FileNotFoundError, FileLimitError, OSError
        As :func:`bounded_read_bytes`.
    UnicodeDecodeError
        The bytes are not text in ``encoding``.
    """
    raw = bounded_read_bytes(path, kind, what)
    if encoding.lower().replace("_", "-") in ("utf-8", "utf8"):
        encoding = "utf-8-sig"      # the BOM, if any, is not part of the text
    return raw.decode(encoding)


class _Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived (``signum``): unwinds like Ctrl-C, removing temporaries.

    A KeyboardInterrupt (not an Exception), so that no ``except Exception``
    of a scenario run swallows it.
    """

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


_CRITICAL = {"depth": 0, "pending": None, "received": None}


def interrupt(signum):
    """Raise a KeyboardInterrupt carrying ``signum`` now, or when the current :func:`deferred_signals` block ends.

    The signal handler of the command line (:mod:`hammerstein.cli.main`) calls it.

    Parameters
    ----------
    signum : int
        The signal (SIGINT or SIGTERM); the exit status is ``128 + signum``.

    Raises
    ------
    KeyboardInterrupt
        Carrying ``signum``, unless a :func:`deferred_signals` block is open.

    Notes
    -----
    The signal is also remembered until :func:`reset_interrupt`: compiled
    code that calls back into Python may clear the exception raised in a
    callback (the handler runs wherever the interpreter happens to be), and
    the command would then go on and finish. The next
    :func:`deferred_signals` block (every file created or renamed) raises
    it again, so no report is renamed into place after a signal.
    """
    _CRITICAL["received"] = signum
    if _CRITICAL["depth"] > 0:
        _CRITICAL["pending"] = signum
        return
    raise _Interrupted(signum)


def raise_if_interrupted():
    """Raise the interruption a signal asked for, if :func:`interrupt` received one.

    A signal that lands while a module is still being imported (the first
    second of a command) can leave that module half initialised: the error
    that follows (an ``ImportError``, a missing attribute of ``scipy.linalg``)
    is the signal's doing, not the input's. Called where such an error would
    be reported, it reports the interruption instead.

    Raises
    ------
    KeyboardInterrupt
        Carrying the signal received (exit status ``128 + signum``); nothing
        when no signal arrived since :func:`reset_interrupt`.
    """
    if _CRITICAL["received"] is not None:
        raise _Interrupted(_CRITICAL["received"])


def reset_interrupt():
    """Forget a signal :func:`interrupt` received (the command that it ended is over)."""
    _CRITICAL["received"] = _CRITICAL["pending"] = None


@contextmanager
def deferred_signals():
    """Hold an interruption (:func:`interrupt`) back while creating or renaming a temporary.

    A signal that arrives meanwhile raises the interruption when the
    block ends, so the caller always knows the name of what it created (and
    removes it) and a rename of a report over an old one is never left half
    done. (A signal mask would not do: CPython may take a process signal on
    another thread and still run the handler in the main thread at once.)
    """
    if threading.current_thread() is not threading.main_thread():
        # signals are handled in the main thread only, so only its blocks defer them: a
        # figure thread's write neither holds the main thread's interruption back nor
        # receives it at the end of its own block
        yield
        return
    if _CRITICAL["depth"] == 0 and _CRITICAL["received"] is not None:
        raise _Interrupted(_CRITICAL["received"])     # its first raise was swallowed
    _CRITICAL["depth"] += 1
    try:
        yield
    finally:
        _CRITICAL["depth"] -= 1
        if _CRITICAL["depth"] == 0 and _CRITICAL["pending"] is not None:
            signum, _CRITICAL["pending"] = _CRITICAL["pending"], None
            raise _Interrupted(signum)


def umask():
    """The process umask (read without changing it for longer than one call).

    Returns
    -------
    int
        Permission bits removed from newly created files and directories.
    """
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


class _Group(threading.local):
    """The open :func:`all_or_nothing` block of one thread (a figure thread's writes are its own)."""

    def __init__(self):
        self.state = {"open": False, "pending": []}


_GROUPS = _Group()


@contextmanager
def all_or_nothing():
    """Write several files with :func:`safe_write` so that all of them or none is replaced.

    Inside the block, :func:`safe_write` writes each temporary file but does
    not rename it; when the block ends without an error every temporary is
    renamed over its target (renames in one directory do not fail for want
    of space), otherwise every temporary is removed and no target changes.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> try:
    ...     with all_or_nothing():
    ...         _ = safe_write(d / "a.txt", "a")
    ...         raise OSError("disk full")
    ... except OSError:
    ...     pass
    >>> sorted(p.name for p in d.iterdir())
    []
    """
    group = _GROUPS.state
    if group["open"]:
        yield
        return
    group["open"], group["pending"] = True, []
    try:
        yield
        group["open"] = False
        with deferred_signals():
            while group["pending"]:
                tmp, target = group["pending"].pop(0)
                os.replace(tmp, target)
    finally:
        group["open"] = False
        for tmp, _ in group["pending"]:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        group["pending"] = []


@contextmanager
def removed_if_failed(*directories):
    """Remove the directories the block creates among ``directories`` (and their parents) if it fails.

    Each directory of ``directories`` that does not exist when the block
    starts, and each of its missing parents, is removed again (when empty:
    nothing anyone wrote there is removed) if the block raises, an
    interruption included; the exception goes on.

    Parameters
    ----------
    *directories : str, pathlib.Path or None
        Output directories the block may create (None is ignored).
    """
    missing = []
    for d in directories:
        if d is None or not str(d).strip():
            continue
        p = Path(os.path.abspath(d))
        while not os.path.lexists(p) and p != p.parent:
            if p not in missing:
                missing.append(p)
            p = p.parent
    try:
        yield
    except BaseException:
        for p in sorted(missing, key=lambda q: len(q.parts), reverse=True):   # deepest first
            try:
                os.rmdir(p)
            except OSError:
                pass
        raise


def safe_write(path, data, what="file", root=None):
    """Write ``data`` to ``path`` through an exclusive temporary file and a rename.

    Parameters
    ----------
    path : str or pathlib.Path
        Target. Its parent directory is created (umask permissions) if
        missing. A symlink is followed: its final target is written; the
        directory of that target must exist (never created along a link).
    data : bytes, str or callable
        Content (str is written as UTF-8), or ``writer(fh)`` writing to a
        binary file object.
    what : str
        What the file is, for messages.
    root : str or pathlib.Path, optional
        The output directory the file must stay in (``--out DIR``): a path
        that resolves outside it (``..``, a symbolic link planted in it) is
        refused (:func:`output_problem`).

    Returns
    -------
    pathlib.Path
        The file written (the symlink's target when ``path`` is a link).

    Raises
    ------
    OutputError
        The target is an input of the running command (:func:`guard_inputs`:
        same resolved path or same inode, through a symbolic or hard link),
        resolves outside ``root``, or the write failed (a full disk, a
        directory the system refuses at the write, such as ``/sys``: the
        message names the file; the temporary is removed, the target is
        untouched).
    FileLimitError
        The target exists and is not a regular file or is read-only, or its
        directory is not a directory.
    """
    path = Path(path)
    problem = output_problem(path, root)
    if problem:
        raise OutputError(problem)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    mode = None
    try:
        st = os.stat(target)
    except FileNotFoundError:
        pass
    else:
        if not stat.S_ISREG(st.st_mode):
            kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file"
            raise FileLimitError(f"{path}: exists and is {kind}; expected a {what} to replace")
        mode = stat.S_IMODE(st.st_mode)
        if not mode & 0o222 or not os.access(target, os.W_OK):  # a rename would bypass it
            if _read_only_mount(target):       # chmod cannot help there
                raise FileLimitError(f"{path}: is on a read-only file system; choose another "
                                     f"path")
            raise FileLimitError(f"{path}: is read-only; make it writable (chmod u+w) to have "
                                 f"it replaced, or choose another path")
    parent = target.parent
    if parent.exists() and not parent.is_dir():
        raise FileLimitError(f"{path}: {parent} is not a directory")
    if target is not path and not parent.is_dir():   # never create directories along a link
        raise FileLimitError(f"{escape(path)}: is a symbolic link to {escape(target)}, whose "
                             f"directory does not exist; the directories of a link's target are "
                             f"never created")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:      # a directory the system refuses (/sys, a full disk): the file named
        raise OutputError(f"{escape(path)}: cannot write the {what} (cannot create its directory "
                          f"{escape(parent)}: {exc.strerror}); nothing was written") from None
    if mode is None:
        mode = 0o666 & ~umask()
    _remove_stale_temporaries(parent, target.name)
    tmp = None
    try:
        with deferred_signals():
            while tmp is None:
                name = parent / f".{target.name[:100]}.{secrets.token_hex(6)}{TMP_SUFFIX}"
                try:
                    fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
                    tmp = name
                except FileExistsError:
                    continue
                except OSError as exc:   # refused at the write (EPERM, EACCES under /sys)
                    raise OutputError(f"{escape(path)}: cannot write the {what} "
                                      f"({exc.strerror}); nothing was written") from None
        try:
            with os.fdopen(fd, "wb") as fh:
                if callable(data):
                    data(fh)
                else:
                    fh.write(data.encode("utf-8") if isinstance(data, str) else data)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(tmp, mode)
        except OSError as exc:
            if exc.errno not in _WRITE_ERRNOS:
                raise
            raise OutputError(f"{escape(path)}: cannot write the {what} ({exc.strerror}); "
                              f"nothing was written") from None
        if _GROUPS.state["open"]:
            _GROUPS.state["pending"].append((tmp, target))   # renamed when the group ends
        else:
            os.replace(tmp, target)
    except BaseException:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise
    return target


def append_text(path, text, what="file", root=None):
    """Add ``text`` at the end of the text file ``path`` (created if missing) through :func:`safe_write`.

    The whole file is written again through a temporary and a rename, so a
    reader sees the old or the new content, never a partial line.

    Parameters
    ----------
    path : str or pathlib.Path
    text : str
    what : str
        What the file is, for messages.
    root : str or pathlib.Path, optional
        As :func:`safe_write`.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    OutputError, FileLimitError, OSError
        As :func:`safe_write`; UnicodeDecodeError when the file is not UTF-8.
    """
    old = bounded_read_text(path, "data", what) if os.path.lexists(path) else ""
    return safe_write(path, old + text, what, root)


def replace_directory(new, target, parking=None, kept=None):
    """Rename the finished directory ``new`` to ``target`` (a report's last step).

    An existing ``target`` is first moved into ``parking`` (as
    ``parking/previous``, a temporary directory of the caller, which removes
    it), so the swap is two renames in one directory, never a copy; run it
    inside :func:`deferred_signals`.

    Parameters
    ----------
    new : str or pathlib.Path
        The directory written.
    target : str or pathlib.Path
        Its final name.
    parking : str or pathlib.Path, optional
        Where an existing ``target`` goes; None: ``target`` must not exist.
    kept : str or pathlib.Path, optional
        A new name beside ``target`` to which an existing ``target`` is renamed
        and left (what the caller must not delete); instead of ``parking``.

    Raises
    ------
    OSError
        A rename failed (``new`` is then left for the caller to remove).
    """
    if kept is not None and os.path.lexists(target):
        os.rename(target, kept)
    elif parking is not None and os.path.lexists(target):
        os.rename(target, Path(parking) / "previous")
    os.rename(new, target)


# -- the output guard: what a command may write -------------------------------------------
#: Errors of a failed write reported as :class:`OutputError` naming the file.
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS}

#: The files the running command reads: ``(as given, resolved path, (st_dev, st_ino))``.
_INPUTS = []


def reset_guard():
    """Forget the inputs of :func:`guard_inputs` (a new command starts)."""
    _INPUTS.clear()


def guard_inputs(*paths):
    """Declare files the running command reads: :func:`safe_write` never writes them.

    Each path is remembered by its resolved path (symbolic links followed)
    and, when it exists, its device and inode (a hard link names the same
    inode), so no output of the command can replace or alter one of its
    inputs, with or without ``--force``.

    Parameters
    ----------
    *paths : str, pathlib.Path or None
        Input files; None and inline values that name no file are ignored
        (a name that does not exist is still remembered by its path).
    """
    for p in paths:
        if p is None or not str(p).strip() or "\0" in str(p):
            continue
        try:
            st = os.stat(p)
            ident = (st.st_dev, st.st_ino)
        except (OSError, ValueError):
            ident = None
        try:
            real = os.path.realpath(p)
        except (OSError, ValueError):
            continue
        _INPUTS.append((str(p), real, ident))


def _input_of(path):
    """The input (as given) that ``path`` names, or None."""
    if not _INPUTS:
        return None
    try:
        real = os.path.realpath(path)
    except (OSError, ValueError):
        return None
    try:
        st = os.stat(path)
        ident = (st.st_dev, st.st_ino)
    except (OSError, ValueError):
        ident = None
    for given, r, i in _INPUTS:
        if r == real or (ident is not None and i == ident):
            return given
    return None


def _inside(real, root_real):
    return real == root_real or real.startswith(root_real.rstrip(os.sep) + os.sep)


def output_problem(path, root=None):
    """Why the output ``path`` may not be written (one line), or None.

    Refused: a final name that :func:`name_problem` refuses; a path that
    names an input of the running command (:func:`guard_inputs`; resolved
    path or same inode, so also through a symbolic or a hard link); with
    ``root``, a path that resolves (``..``, symbolic links, among them one
    planted inside ``root``) outside the directory ``root``, and any path
    when ``root`` itself is a symbolic link (a link planted at the output
    directory's name, e.g. in a shared ``/tmp``, would otherwise send the
    files, ``--force`` replacing what is there, wherever it points).

    Parameters
    ----------
    path : str or pathlib.Path
        The output file.
    root : str or pathlib.Path, optional
        The output directory (``--out DIR``).

    Returns
    -------
    str or None
        ``"<path>: ..."`` naming the problem.
    """
    p = Path(path)
    problem = name_problem(p.name, "file name", MAX_NAME_BYTES) if p.name else None
    if problem:
        return f"{escape(path)}: {problem}"
    given = _input_of(p)
    if given is not None:
        also = "" if given == str(path) else f" ({escape(given)})"
        return (f"{escape(path)} is also an input of this command{also}; "
                f"an input is never an output: choose another name")
    if root is not None:
        real, root_real = os.path.realpath(p), os.path.realpath(root)
        if os.path.islink(root):
            return (f"the output directory {escape(root)} is a symbolic link to "
                    f"{escape(root_real)}; an output directory is never followed through a link "
                    f"(one planted there would send the files elsewhere): give "
                    f"{escape(root_real)} itself")
        if not _inside(real, root_real):
            how = (f"is a symbolic link to {escape(real)}" if os.path.islink(p)
                   else f"resolves to {escape(real)}")
            return (f"{escape(path)} {how}, outside the output directory {escape(root)}; "
                    f"nothing is written outside it: remove the link or choose another directory")
    return None
