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

import os
import secrets
import stat
from contextlib import contextmanager
from pathlib import Path

from hammerstein.exceptions import FileLimitError

__all__ = ["FileLimitError", "LIMITS", "limit", "check_regular", "bounded_read_bytes",
           "bounded_read_text", "safe_write", "umask", "TMP_SUFFIX", "deferred_signals",
           "interrupt"]

#: Default size limits [bytes] and the environment variables overriding them.
LIMITS = {
    "toml": ("HAMMERSTEIN_MAX_TOML_BYTES", 4 * 2**20),
    "data": ("HAMMERSTEIN_MAX_DATA_BYTES", 256 * 2**20),
    "baseline": ("HAMMERSTEIN_MAX_BASELINE_BYTES", 64 * 2**20),
    "cache": ("HAMMERSTEIN_MAX_CACHE_BYTES", 64 * 2**20),
}

#: Suffix of the temporary files of :func:`safe_write`.
TMP_SUFFIX = ".hammerstein-tmp"


def _size(n):
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= scale:
            return f"{n / scale:.4g} {unit}"
    return f"{n} bytes"


def _hint(kind):
    """``raise it with VAR=BYTES``, noting an override that is not a positive integer."""
    var = LIMITS[kind][0]
    text = os.environ.get(var)
    bad = "" if text is None or (text.strip().isdigit() and int(text) > 0) else \
        f"; its value {text!r} is not a positive integer, the default applies"
    return f"raise it with {var}=BYTES{bad}"


def limit(kind):
    """The size limit [bytes] of a kind of file.

    The environment variable of :data:`LIMITS` overrides the default; a
    value that is not a positive integer is ignored.

    Parameters
    ----------
    kind : {'toml', 'data', 'baseline', 'cache'}
        Key of :data:`LIMITS`.

    Returns
    -------
    int
        Largest accepted size [bytes].
    """
    var, default = LIMITS[kind]
    text = os.environ.get(var, "").strip()
    if text.isdigit() and int(text) > 0:
        return int(text)
    return default


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
    kind : {'toml', 'data', 'baseline', 'cache'}
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
        return b"".join(chunks)
    finally:
        os.close(fd)


def bounded_read_text(path, kind="toml", what="file", encoding="utf-8"):
    """:func:`bounded_read_bytes`, decoded.

    Parameters
    ----------
    path : str or pathlib.Path
    kind : {'toml', 'data', 'baseline', 'cache'}
        Selects the size limit.
    what : str
        What the file should be, for messages.
    encoding : str
        Text encoding.

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
    return bounded_read_bytes(path, kind, what).decode(encoding)


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


def safe_write(path, data, what="file"):
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

    Returns
    -------
    pathlib.Path
        The file written (the symlink's target when ``path`` is a link).

    Raises
    ------
    FileLimitError
        The target exists and is not a regular file or is read-only, or its
        directory is not a directory.
    OSError
        The directory cannot be created or written.
    """
    path = Path(path)
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
        with os.fdopen(fd, "wb") as fh:
            if callable(data):
                data(fh)
            else:
                fh.write(data.encode("utf-8") if isinstance(data, str) else data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise
    return target
