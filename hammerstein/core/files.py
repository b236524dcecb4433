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
import re
import secrets
import stat
from contextlib import contextmanager
from pathlib import Path

from hammerstein.exceptions import FileLimitError, OutputError

__all__ = ["FileLimitError", "LIMITS", "limit", "check_regular", "bounded_read_bytes",
           "bounded_read_text", "safe_write", "start_budget", "umask", "TMP_SUFFIX", "deferred_signals",
           "interrupt", "all_or_nothing", "PROVENANCE", "provenance_line", "png_provenance",
           "carries_provenance", "same_file", "replace_problem", "locked", "LOCK_TIMEOUT",
           "escape", "markdown_escape", "EXCERPT", "owner_token", "release_owner",
           "parse_owner", "owner_alive", "ALLOW_ENV", "path_problem", "confined_path",
           "MAX_PATH_CHARS", "MAX_NAME_BYTES", "OutputError", "guard_inputs", "reset_guard",
           "output_problem", "name_problem", "append_text", "replace_directory", "c_name_problem", "MAX_NAME_CHARS", "C_RESERVED",
           "C_HEADERS"]

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
TMP_SUFFIX = ".hammerstein-tmp"


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


def bounded_read_bytes(path, kind="toml", what="file"):
    """Read a regular file of at most :func:`limit` ``(kind)`` bytes.

    Parameters
    ----------
    path : str or pathlib.Path
    kind : {'toml', 'data', 'baseline', 'cache', 'total'}
        Selects the size limit.
    what : str
        What the file should be, for messages ("scenario file", ...).

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
    cap = limit(kind)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a FIFO must not block open()
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise FileLimitError(f"{path}: is a directory, expected a {what}")
        if not stat.S_ISREG(st.st_mode):
            raise FileLimitError(f"{path}: not a regular file (a device, FIFO or socket), "
                                 f"expected a {what}")
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


_CRITICAL = {"depth": 0, "pending": None}


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
    """
    if _CRITICAL["depth"] > 0:
        _CRITICAL["pending"] = signum
        return
    raise _Interrupted(signum)


@contextmanager
def deferred_signals():
    """Hold an interruption (:func:`interrupt`) back while creating or renaming a temporary.

    A signal that arrives meanwhile raises the interruption when the
    block ends, so the caller always knows the name of what it created (and
    removes it) and a rename of a report over an old one is never left half
    done. (A signal mask would not do: CPython may take a process signal on
    another thread and still run the handler in the main thread at once.)
    """
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


_GROUP = {"open": False, "pending": []}


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
    if _GROUP["open"]:
        yield
        return
    _GROUP["open"], _GROUP["pending"] = True, []
    try:
        yield
        _GROUP["open"] = False
        with deferred_signals():
            while _GROUP["pending"]:
                tmp, target = _GROUP["pending"].pop(0)
                os.replace(tmp, target)
    finally:
        _GROUP["open"] = False
        for tmp, _ in _GROUP["pending"]:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        _GROUP["pending"] = []


def safe_write(path, data, what="file", root=None):
    """Write ``data`` to ``path`` through an exclusive temporary file and a rename.

    Parameters
    ----------
    path : str or pathlib.Path
        Target. Its parent directory is created (umask permissions) if
        missing. A symlink is followed: its final target is written.
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
        resolves outside ``root``, or the write failed (a full disk: the
        message names the file; the temporary is removed, the target is
        untouched).
    FileLimitError
        The target exists and is not a regular file or is read-only, or its
        directory is not a directory.
    OSError
        The directory cannot be created.
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
            raise FileLimitError(f"{path}: is read-only; make it writable (chmod u+w) to have "
                                 f"it replaced, or choose another path")
    parent = target.parent
    if parent.exists() and not parent.is_dir():
        raise FileLimitError(f"{path}: {parent} is not a directory")
    parent.mkdir(parents=True, exist_ok=True)
    if mode is None:
        mode = 0o666 & ~umask()
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
        if _GROUP["open"]:
            _GROUP["pending"].append((tmp, target))   # renamed when the group ends
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


def replace_directory(new, target, parking=None):
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

    Raises
    ------
    OSError
        A rename failed (``new`` is then left for the caller to remove).
    """
    if parking is not None and os.path.lexists(target):
        os.rename(target, Path(parking) / "previous")
    os.rename(new, target)


# -- provenance: the mark of the files the project writes ------------------------------
#: Words that start the provenance mark of every single file the project writes.
PROVENANCE = "generated by hammerstein"


def _package_version():
    try:
        from importlib.metadata import version
        return version("hammerstein")
    except Exception:  # not installed (a source checkout on sys.path)
        return "unknown"


def provenance_line(command, style="#"):
    """The first line of a text file written by ``hammerstein <command>``.

    A file is replaced by the project only while it carries this line
    (:func:`carries_provenance`), so a hand-written file at an output path
    is never lost (the command stops with a usage error naming ``--force``).

    Parameters
    ----------
    command : str
        The command that writes the file (``"identify"``, ``"check"``).
    style : {'#', 'xml'}
        A ``#`` comment (TOML, CSV) or an XML comment.

    Returns
    -------
    str
        One line, ending with a newline.

    Raises
    ------
    ValueError
        An unknown ``style``.

    Examples
    --------
    >>> provenance_line("identify").startswith("# generated by hammerstein identify")
    True
    """
    text = (f"{PROVENANCE} {command} {_package_version()}; hammerstein replaces this file "
            f"only while this line is here")
    if style == "xml":
        return f"<!-- {text} -->\n"
    if style != "#":
        raise ValueError(f"style: expected '#' or 'xml', found {style!r}")
    return f"# {text}\n"


def png_provenance(command):
    """PNG text chunks marking a figure written by ``hammerstein <command>``.

    Pass it as ``metadata=`` to :meth:`matplotlib.figure.Figure.savefig`
    (``format="png"``); :func:`carries_provenance` finds it.

    Parameters
    ----------
    command : str

    Returns
    -------
    dict
        ``{"Comment": "generated by hammerstein <command> <version>"}``.
    """
    return {"Comment": f"{PROVENANCE} {command} {_package_version()}"}


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _png_marked(fd):
    """Whether the PNG open on ``fd`` has a text chunk with :data:`PROVENANCE` (chunks walked, bounded)."""
    import struct
    os.lseek(fd, 8, os.SEEK_SET)
    for _ in range(4096):  # a PNG has a few dozen chunks
        head = os.read(fd, 8)
        if len(head) < 8:
            return False
        length, kind = struct.unpack(">I4s", head)
        if kind in (b"tEXt", b"iTXt", b"zTXt") and length <= 1 << 16:
            data = os.read(fd, length)
            if PROVENANCE.encode() in data:
                return True
            os.lseek(fd, 4, os.SEEK_CUR)
        elif kind == b"IEND":
            return False
        else:
            os.lseek(fd, length + 4, os.SEEK_CUR)
    return False


def carries_provenance(path):
    """Whether the file at ``path`` carries the project's provenance mark.

    A text file's first line (after a byte-order mark; for XML the line
    after the declaration may hold it) starts with the comment of
    :func:`provenance_line`; a PNG holds a text chunk of
    :func:`png_provenance`. At most 4 KiB of a text file is read.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    bool
        False also when the file cannot be read or is not a regular file.
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return False
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return False
        head = os.read(fd, 4096)
        if head.startswith(_PNG_SIGNATURE):
            return _png_marked(fd)
        lines = head.removeprefix(b"\xef\xbb\xbf").split(b"\n")[:2]
        first = lines[0].strip()
        if first.startswith(b"# " + PROVENANCE.encode()):
            return True
        if first.startswith(b"<?xml") and len(lines) > 1:
            first = lines[1].strip()
        return first.startswith(b"<!-- " + PROVENANCE.encode())
    except OSError:
        return False
    finally:
        os.close(fd)


def same_file(a, b):
    """Whether two paths name the same file (same inode, or the same resolved path).

    Parameters
    ----------
    a, b : str or pathlib.Path

    Returns
    -------
    bool
    """
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        try:
            return Path(os.path.realpath(a)) == Path(os.path.realpath(b))
        except (OSError, ValueError):
            return False


def replace_problem(path, inputs=(), force=False, command="hammerstein",
                    inputs_are="an input of this command"):
    """Why the output ``path`` may not be written (one line), or None.

    An output may not be one of the command's ``inputs`` (even with
    ``force``), and an existing file is replaced only when it carries the
    provenance mark (:func:`carries_provenance`) or ``force`` is set.

    Parameters
    ----------
    path : str or pathlib.Path
        The output file.
    inputs : iterable of str or pathlib.Path
        The files the command reads.
    force : bool
        Replace a file without the mark.
    command : str
        Named in the message (``"hammerstein identify"``).
    inputs_are : str
        What the inputs are, for the message (``"one of the data files"``).

    Returns
    -------
    str or None
        ``"<path> is also an input of this command (<input>)"`` or
        ``"<path> exists and was not written by <command> (...); ... --force"``.
    """
    for i in inputs:
        if i is not None and os.path.lexists(path) and same_file(path, i):
            also = "" if str(i) == str(path) else f" ({escape(i)})"
            return f"{escape(path)} is also {inputs_are}{also}; choose another name"
        if i is not None and Path(os.path.abspath(path)) == Path(os.path.abspath(i)):
            return f"{escape(path)} is also {inputs_are}; choose another name"
    if force or not os.path.lexists(path) or not os.path.exists(path):
        return None
    if carries_provenance(path):
        return None
    return (f"{escape(path)} exists and was not written by {command} (no '{PROVENANCE}' mark); "
            f"choose another name, or add --force to replace it")


# -- advisory locks for read-modify-write ------------------------------------------------
#: Longest wait [s] for the lock of another process updating the same file.
LOCK_TIMEOUT = 120.0


@contextmanager
def locked(path, timeout=None):
    """Hold an exclusive advisory lock (``fcntl.flock``) for a read-modify-write of ``path``.

    The lock is taken on the directory of ``path`` (the file itself is
    replaced by a rename, so a lock on it would not be seen by the next
    writer); no lock file is left behind. Read the file again once the lock
    is held.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to be read and rewritten.
    timeout : float, optional
        Longest wait [s] for another holder (default :data:`LOCK_TIMEOUT`).

    Raises
    ------
    FileLimitError
        The lock was not obtained within ``timeout`` (another process holds it).
    OSError
        The directory cannot be opened.
    """
    import time
    try:
        import fcntl
    except ImportError:  # not POSIX: no advisory locks
        yield
        return
    parent = os.path.dirname(os.path.abspath(path))
    fd = os.open(parent, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        limit_at = time.monotonic() + (LOCK_TIMEOUT if timeout is None else timeout)
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > limit_at:
                    raise FileLimitError(f"{escape(path)}: another process has been updating it "
                                         f"for more than {timeout or LOCK_TIMEOUT:g} s; "
                                         f"try again later") from None
                time.sleep(0.05)
            except OSError:  # a file system without locks: go on unlocked
                break
        yield
    finally:
        os.close(fd)  # releases the lock


# -- user strings in messages and reports -------------------------------------------------
#: Longest excerpt of a user string quoted in a message (characters).
EXCERPT = 200


def escape(text, limit=EXCERPT):
    """A user string made safe to print on one terminal line.

    Control characters (escape sequences, NUL, newlines, DEL, C1 controls,
    bidirectional overrides) become Python-style escapes (``\\x1b``,
    ``\\n``) and a long string is cut to ``limit`` characters with the
    number left out, so a file name or a value can neither forge a line
    nor drive the terminal.

    Parameters
    ----------
    text : object
        Converted with ``str``.
    limit : int or None
        Longest excerpt (characters); None: no cut.

    Returns
    -------
    str

    Examples
    --------
    >>> escape("a\\x1b]0;owned\\x07b\\nerror: x")
    'a\\\\x1b]0;owned\\\\x07b\\\\nerror: x'
    >>> escape("x" * 300, limit=5)
    'xxxxx... (295 more characters)'
    """
    s = str(text)
    cut = ""
    if limit is not None and len(s) > limit:
        cut, s = f"... ({len(s) - limit} more characters)", s[:limit]
    if s.isprintable():
        return s + cut
    out = []
    for ch in s:
        if ch.isprintable() or ch == " ":
            out.append(ch)
        else:
            code = ord(ch)
            out.append({"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(ch) or
                       (f"\\x{code:02x}" if code < 0x100 else
                        f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"))
    return "".join(out) + cut


def markdown_escape(text, limit=None):
    """A user string made safe for one line of Markdown (report.md).

    :func:`escape` first (no control characters or newlines), then the
    characters Markdown or HTML would interpret (``\\ ` * _ { } [ ] < > ( )
    # + - ! | ~``) are backslash-escaped.

    Parameters
    ----------
    text : object
    limit : int or None
        As :func:`escape`.

    Returns
    -------
    str

    Examples
    --------
    >>> markdown_escape("<script>*x*</script>")
    '\\\\<script\\\\>\\\\*x\\\\*\\\\</script\\\\>'
    """
    s = escape(text, limit)
    return "".join("\\" + ch if ch in "\\`*_{}[]<>()#+-!|~" else ch for ch in s)


# -- owners of temporaries: host, PID namespace, process start, call ----------------------
_LIVE = set()          # nonces of the temporaries this process is working on


def _pid_namespace():
    try:
        return str(os.stat("/proc/self/ns/pid").st_ino)
    except OSError:
        return "-"


def _start_time(pid):
    """Start time of process ``pid`` (clock ticks since boot, /proc), None if gone, '-' if unknown."""
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as fh:
            data = fh.read(4096)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, OverflowError):
        return "-"
    try:
        return data.rsplit(b")", 1)[1].split()[19].decode()
    except (IndexError, UnicodeDecodeError):
        return "-"


def owner_token():
    """A new owner token for a temporary: this host, PID namespace, process and call.

    Registered as live in this process until :func:`release_owner`; a
    temporary is judged stale by :func:`owner_alive` from its token, never
    from its PID alone (two PID namespaces share PIDs, two threads share one).

    Returns
    -------
    str
        ``host=<hostname> pidns=<inode> pid=<pid> start=<ticks> nonce=<hex>``.
    """
    nonce = secrets.token_hex(8)
    _LIVE.add(nonce)
    host = escape(os.uname().nodename if hasattr(os, "uname") else "-", 100).replace(" ", "_")
    return (f"host={host} pidns={_pid_namespace()} pid={os.getpid()} "
            f"start={_start_time(os.getpid())} nonce={nonce}")


def release_owner(token):
    """Forget a token of :func:`owner_token` (its temporary is gone or renamed).

    Parameters
    ----------
    token : str
    """
    _LIVE.discard(parse_owner(token).get("nonce"))


def parse_owner(token):
    """The fields of a token of :func:`owner_token` (``{}`` when it is not one).

    Parameters
    ----------
    token : str

    Returns
    -------
    dict of str to str
    """
    fields = dict(p.split("=", 1) for p in str(token).split() if "=" in p)
    return fields if {"host", "pidns", "pid", "start", "nonce"} <= fields.keys() else {}


def owner_alive(token):
    """Whether the owner of a temporary may still be working on it.

    Parameters
    ----------
    token : str
        From :func:`owner_token`.

    Returns
    -------
    bool or None
        False when the owner is certainly gone (same host and PID
        namespace, and its process has exited or its PID now belongs to a
        process started at another time, or it is this process and the call
        is over); True when it is alive; None when it cannot be told
        (another host or PID namespace, no /proc): keep the temporary.
    """
    f = parse_owner(token)
    if not f:
        return None
    host = escape(os.uname().nodename if hasattr(os, "uname") else "-", 100).replace(" ", "_")
    if f["host"] != host or f["pidns"] != _pid_namespace() or f["pidns"] == "-":
        return None
    if not (f["pid"].isascii() and f["pid"].isdigit()):
        return None
    start = _start_time(f["pid"])
    if start is None:
        return False
    if start == "-" or f["start"] == "-":
        return None
    if start != f["start"]:
        return False           # the PID was reused by a later process
    if int(f["pid"]) == os.getpid():
        return f["nonce"] in _LIVE
    return True


# -- paths named in scenario files ----------------------------------------------------------
#: Environment variable: directories (``os.pathsep``-separated) whose files a scenario may
#: name besides those under its own directory (``/`` allows every file).
ALLOW_ENV = "HAMMERSTEIN_ALLOW_PATHS"
#: Longest path accepted in a file [characters], and longest name in it [bytes].
MAX_PATH_CHARS, MAX_NAME_BYTES = 1000, 255


def path_problem(text):
    """Why ``text`` cannot be a file path (one line), or None: NUL character, too long.

    Parameters
    ----------
    text : str

    Returns
    -------
    str or None
    """
    s = str(text)
    if "\0" in s:
        return f"{escape(s)}: a path cannot contain a NUL character"
    if len(s) > MAX_PATH_CHARS:
        return f"{escape(s, 60)}: a path of {len(s)} characters; expected at most {MAX_PATH_CHARS}"
    for part in Path(s).parts:
        if len(part.encode("utf-8", "surrogateescape")) > MAX_NAME_BYTES:
            return (f"{escape(s, 60)}: a name of {len(part.encode('utf-8', 'surrogateescape'))} "
                    f"bytes in the path; expected at most {MAX_NAME_BYTES}")
    return None


def confined_path(text, base_dir, error=FileLimitError):
    """The path of a file named in a scenario, confined to the scenario's directory.

    A relative path is resolved against ``base_dir`` (the scenario's
    directory); the file (symbolic links followed) must lie under
    ``base_dir`` or under a directory of ``$HAMMERSTEIN_ALLOW_PATHS``
    (:data:`ALLOW_ENV`, ``os.pathsep``-separated; ``/`` allows every file),
    so a scenario received from elsewhere cannot read ``/etc/shadow`` or
    ``../../secret`` and echo it in a message.

    Parameters
    ----------
    text : str
        The path as written in the scenario.
    base_dir : str or pathlib.Path or None
        The scenario's directory; None (a call from the Python API): no
        confinement, only :func:`path_problem`.
    error : type
        Exception class raised (the caller's: PresetError, DataFileError...).

    Returns
    -------
    pathlib.Path
        ``base_dir / text`` (or ``text`` when absolute), not resolved.

    Raises
    ------
    error
        A NUL character, a path too long, or a file outside the allowed
        directories (the message names :data:`ALLOW_ENV`).
    """
    problem = path_problem(text)
    if problem:
        raise error(problem)
    path = Path(text)
    if base_dir is None:
        return path
    path = path if path.is_absolute() else Path(base_dir) / path
    real = Path(os.path.realpath(path))
    roots = [Path(os.path.realpath(base_dir))]
    roots += [Path(os.path.realpath(d)) for d in os.environ.get(ALLOW_ENV, "").split(os.pathsep)
              if d.strip() and "\0" not in d]
    if any(real == r or r in real.parents for r in roots):
        return path
    raise error(f"{escape(text)}: outside the scenario's directory ({escape(base_dir)}); "
                f"name a file under it, or allow its directory with {ALLOW_ENV}=DIR")


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
    planted inside ``root``) outside the directory ``root``.

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
        if not _inside(real, root_real):
            how = (f"is a symbolic link to {escape(real)}" if os.path.islink(p)
                   else f"resolves to {escape(real)}")
            return (f"{escape(path)} {how}, outside the output directory {escape(root)}; "
                    f"nothing is written outside it: remove the link or choose another directory")
    return None


#: Longest name of a signal, model or C prefix turned into a file name [characters].
MAX_NAME_CHARS = 100


def name_problem(name, what="name", limit=MAX_NAME_CHARS):
    """Why ``name`` cannot become (part of) a file name (one line), or None.

    Refused: an empty name, ``.`` or ``..``, a path separator (``/``,
    ``\\``), a control character (newline, escape, NUL, DEL, C1, and the
    bidirectional overrides), or more than ``limit`` characters.

    Parameters
    ----------
    name : str
    what : str
        What the name is, for the message (``"--inputs name"``).
    limit : int
        Longest name [characters].

    Returns
    -------
    str or None

    Examples
    --------
    >>> name_problem("x") is None
    True
    >>> name_problem("../evil", "--inputs name")
    "--inputs name '../evil': a path separator ('/'); expected a plain name"
    """
    s = str(name)
    if not s.strip() or s in (".", ".."):
        return f"{what} '{escape(s)}': expected a non-empty name (not '.' or '..')"
    if len(s) > limit:
        return f"{what} '{escape(s, 40)}': {len(s)} characters; expected at most {limit}"
    for sep in ("/", "\\"):
        if sep in s:
            return f"{what} '{escape(s)}': a path separator ({sep!r}); expected a plain name"
    if not s.isprintable():
        bad = next(c for c in s if not c.isprintable())
        return (f"{what} '{escape(s)}': a control character ({escape(bad)}); "
                f"expected printable characters")
    return None


#: Identifiers a C prefix may not be: the C keywords and the names the standard library owns.
C_RESERVED = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while", "bool", "true", "false", "alignas",
    "alignof", "static_assert", "thread_local", "noreturn", "complex", "imaginary", "main",
    "errno", "assert", "setjmp", "longjmp", "offsetof", "va_arg", "va_start", "va_end",
    "va_copy", "va_list", "NULL", "EOF", "FILE", "stdin", "stdout", "stderr", "size_t",
    "ptrdiff_t", "math_errhandling", "INFINITY", "NAN", "HUGE_VAL", "signal", "raise", "exit",
    "abort", "malloc", "free", "memcpy", "memset", "printf", "sin", "cos", "exp", "log", "pow",
    "sqrt", "fabs", "floor", "ceil", "round", "fmin", "fmax", "tanh"}
#: Base names of the C standard headers (and of the FMI headers an FMU includes).
C_HEADERS = {
    "assert", "complex", "ctype", "errno", "fenv", "float", "inttypes", "iso646", "limits",
    "locale", "math", "setjmp", "signal", "stdalign", "stdarg", "stdatomic", "stdbit",
    "stdbool", "stdckdint", "stddef", "stdint", "stdio", "stdlib", "stdnoreturn", "string",
    "tgmath", "threads", "time", "uchar", "wchar", "wctype", "unistd", "fcntl", "strings",
    "fmi2Functions", "fmi2FunctionTypes", "fmi2TypesPlatform", "fmi3Functions"}
_C_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,39}")


def c_name_problem(name, what="--name"):
    """Why ``name`` cannot be the prefix and file stem of exported C code (one line), or None.

    It must be a C identifier of 1-40 letters, digits or ``_`` not starting
    with a digit; not a keyword or a name the C library owns
    (:data:`C_RESERVED`: ``main``, ``errno``, ...); not reserved to the
    implementation (starting with ``__`` or ``_`` and a capital letter);
    and not the base name of a standard header (:data:`C_HEADERS`, compared
    without case: ``math.h`` would shadow ``<math.h>``).

    Parameters
    ----------
    name : str
    what : str
        The option, for the message.

    Returns
    -------
    str or None

    Examples
    --------
    >>> c_name_problem("piezo_x") is None
    True
    >>> c_name_problem("math").startswith("--name: 'math' is the name of the C standard header")
    True
    """
    if not isinstance(name, str) or not _C_IDENT.fullmatch(name):
        return (f"{what}: expected a C identifier of 1-40 letters, digits "
                f"or '_' not starting with a digit, found '{escape(name, 60)}'")
    if name in C_RESERVED:
        return (f"{what}: {name!r} is a C keyword or a name the C library owns; "
                f"choose another prefix (e.g. {name}_comp)")
    if name.startswith("__") or re.match(r"_[A-Z]", name):
        return (f"{what}: {name!r} is reserved to the C implementation (it starts with '__' or "
                f"'_' and a capital letter); choose another prefix")
    if name.lower() in {h.lower() for h in C_HEADERS}:
        return (f"{what}: {name!r} is the name of the C standard header <{name.lower()}.h>, which "
                f"{name}.h would shadow; choose another prefix (e.g. {name}_comp)")
    return None
