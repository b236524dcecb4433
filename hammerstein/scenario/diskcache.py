"""On-disk cache of identifications, so that running a scenario again does not identify again.

Identifying a model (characterisation records simulated on the plant, least
squares; for ``kind = "hammerstein"`` two PI stages and two subspace fits of
G) takes seconds and gives the same result every time: the records are
simulated, and the sensor noise is drawn with the table's ``seed``. The
results are therefore kept on disk, one JSON file per identification,
under a name that is a hash of

* what is identified: the plant's content (PI model, sampling period,
  dynamics matrices) and the ``identify`` / ``identify_dynamics`` tables;
* the code that identifies: the hammerstein version, a digest of every
  ``.py`` file of the package, and the numpy, scipy, numba and nfoursid
  versions, so that an entry is never used by other code than the code that
  wrote it.

Where: ``$HAMMERSTEIN_CACHE_DIR``, else ``$XDG_CACHE_HOME/hammerstein``,
else ``~/.cache/hammerstein``, in a subdirectory ``identified/``.
``HAMMERSTEIN_CACHE_DIR=off`` (or empty) turns the cache off. Removing the
directory is always safe (the next run identifies again); entries written by
older versions are never read again and not removed either (an entry is a
few kB: the paper's 8 identifications take 32 kB).

Safety: an entry is written once, through a temporary file and a rename
(:func:`hammerstein.core.files.safe_write`, the user's umask), and never
over an existing file; a read is bounded (``HAMMERSTEIN_MAX_CACHE_BYTES``,
default 64 MiB). Trust, as ssh does for its files: the cache is used only
when its directories belong to the user (or root) and are not writable by
group or others (else one note and no cache), and an entry is used only
when it is a regular file owned by the user, not writable by group or
others, written for this user (its ``uid``), for this key (the key text is
stored and compared) and with its content digest intact. An entry that
cannot be read or parsed (not JSON, nested too deeply, a ``meta`` that is
not a table...), or fails these checks, is ignored - one note with ``-v``
(:func:`set_reporter`) - and the identification runs as if there were no
cache. Nothing is deleted. A cache that cannot be written (read-only home,
full disk) only costs the time of identifying again.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
from importlib import metadata
from pathlib import Path

from hammerstein.core.files import FileLimitError, bounded_read_bytes, escape, safe_write

__all__ = ["cache_dir", "code_digest", "entry_path", "load", "store", "ENV", "set_reporter",
           "trust_problem", "note", "same_data"]

#: Environment variable naming the cache directory (``off`` or empty: no cache).
ENV = "HAMMERSTEIN_CACHE_DIR"
#: Format of the entries (part of every key).
FORMAT = 2

_DIGEST = {}
_REPORT = {"to": None, "said": set()}


def set_reporter(report):
    """Where the notes on ignored entries and untrusted directories go.

    Parameters
    ----------
    report : callable or None
        ``report(line)``; the command line passes its stderr printer with
        ``-v``. None (default): the logger named "hammerstein.cache" (INFO).
    """
    _REPORT["to"] = report


def note(text):
    """Report ``text`` once per process (the ``-v`` note of an ignored entry or directory).

    Parameters
    ----------
    text : str
        One line, without the ``note: `` prefix; control characters escaped.
    """
    _note(escape(text, 1000))


def _note(text):
    if text in _REPORT["said"]:
        return
    _REPORT["said"].add(text)
    if _REPORT["to"] is not None:
        _REPORT["to"](f"note: {text}")
    else:
        import logging
        logging.getLogger("hammerstein.cache").info(text)


def trust_problem(path, directory=False):
    """Why the cache file or directory ``path`` is not trusted (one line), or None.

    Parameters
    ----------
    path : pathlib.Path
    directory : bool
        Judge a directory (owner the user or root, not writable by group or
        others unless sticky) instead of an entry (a regular file owned by
        the user, not writable by group or others).

    Returns
    -------
    str or None
    """
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return f"{escape(path)}: cannot be examined ({exc.strerror})"
    uid = os.getuid() if hasattr(os, "getuid") else None
    if uid is None:
        return None
    if directory:
        if not stat.S_ISDIR(st.st_mode):
            return f"{escape(path)}: not a directory"
        if st.st_uid not in (uid, 0):
            return f"{escape(path)}: belongs to another user (uid {st.st_uid})"
        if st.st_mode & 0o022 and not st.st_mode & stat.S_ISVTX:
            return f"{escape(path)}: writable by group or others (chmod go-w it)"
        return None
    if not stat.S_ISREG(st.st_mode):
        return f"{escape(path)}: not a regular file"
    if st.st_uid != uid:
        return f"{escape(path)}: written by another user (uid {st.st_uid})"
    if st.st_mode & 0o022:
        return f"{escape(path)}: writable by group or others"
    return None


def _directory_problem(d):
    """The first untrusted directory from ``d`` up to its cache root, or None."""
    for p in (d, d.parent):
        problem = trust_problem(p, directory=True)
        if problem:
            return problem
    return None


def cache_dir():
    """The directory of the identification cache, or None when it is turned off.

    Returns
    -------
    pathlib.Path or None
        ``<root>/identified`` with root ``$HAMMERSTEIN_CACHE_DIR``, else
        ``$XDG_CACHE_HOME/hammerstein``, else ``~/.cache/hammerstein``;
        None when turned off or when there is no home directory.
    """
    root = os.environ.get(ENV)
    if root is not None:
        if root.strip() in ("", "off", "0", "false", "no"):
            return None
        return Path(root).expanduser() / "identified"
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    if xdg:
        return Path(xdg) / "hammerstein" / "identified"
    try:
        home = Path.home()
    except (RuntimeError, KeyError):      # no HOME and no passwd entry: no cache
        return None
    return home / ".cache" / "hammerstein" / "identified"


def _version(dist):
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "-"


def code_digest():
    """Digest of the code an entry depends on (computed once per process).

    Returns
    -------
    str
        SHA-256 (hex) of the package's ``.py`` files (paths and contents)
        and of the hammerstein-piezo, numpy, scipy, numba and nfoursid versions.
    """
    if "value" not in _DIGEST:
        package = Path(__file__).resolve().parents[1]
        h = hashlib.sha256()
        for dist in ("hammerstein-piezo", "numpy", "scipy", "numba", "nfoursid"):
            h.update(f"{dist}={_version(dist)};".encode())
        for path in sorted(package.rglob("*.py")):
            h.update(path.relative_to(package).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
        _DIGEST["value"] = h.hexdigest()
    return _DIGEST["value"]


def _key_text(kind, key):
    return repr((FORMAT, kind, code_digest(), key))


def entry_path(kind, key):
    """The file of one entry (whether it exists or not).

    Parameters
    ----------
    kind : str
        What is cached (``"pi"``, ``"hammerstein"``).
    key : tuple
        Content key of the identification (strings, numbers, tuples: its
        ``repr`` is hashed).

    Returns
    -------
    pathlib.Path or None
        ``<cache_dir>/<kind>-<sha256>.json``; None when the cache is off.
    """
    d = cache_dir()
    if d is None:
        return None
    return d / f"{kind}-{hashlib.sha256(_key_text(kind, key).encode()).hexdigest()}.json"


def load(kind, key):
    """The value stored for ``(kind, key)``, or None.

    Parameters
    ----------
    kind : str
    key : tuple
        See :func:`entry_path`.

    Returns
    -------
    dict or None
        The stored value; None when the cache is off, the entry is missing,
        too large, unreadable, not JSON, or written for another key.
    """
    path = entry_path(kind, key)
    if path is None or not os.path.lexists(path):
        return None
    problem = _directory_problem(path.parent)
    if problem:
        _note(f"identification cache not used: {problem}")
        return None
    problem = trust_problem(path)
    if problem:
        _note(f"identification cache entry ignored: {problem}")
        return None
    try:
        entry = json.loads(bounded_read_bytes(path, "cache", "identification cache entry"))
    except (OSError, FileLimitError, ValueError, RecursionError) as exc:
        _note(f"identification cache entry ignored: {escape(path)}: not readable JSON "
              f"({escape(type(exc).__name__)})")
        return None
    why = _entry_problem(entry, kind, key)
    if why:
        _note(f"identification cache entry ignored: {escape(path)}: {why}")
        return None
    return entry["value"]


def _value_digest(value):
    return hashlib.sha256(json.dumps(value, sort_keys=True, allow_nan=True).encode()).hexdigest()


def _entry_problem(entry, kind, key):
    """Why a parsed entry is not the one of ``(kind, key)`` for this user (or None)."""
    if not isinstance(entry, dict) or entry.get("key") != _key_text(kind, key):
        return "written for another key"
    if hasattr(os, "getuid") and entry.get("uid") != os.getuid():
        return "written for another user"
    value = entry.get("value")
    if not isinstance(value, dict):
        return "its value is not a table"
    if "meta" in value and not isinstance(value["meta"], dict):
        return "its meta is not a table"
    if "model" in value and not isinstance(value["model"], dict):
        return "its model is not a table"
    try:
        if entry.get("digest") != _value_digest(value):
            return "its content does not match its digest (edited)"
    except (TypeError, ValueError, RecursionError):
        return "its content cannot be digested"
    return None


def same_data(a, b):
    """Equal JSON data, NaN equal to NaN, and of the same types (no tuple for a list).

    Parameters
    ----------
    a, b : object
        JSON data (dicts, lists, str, int, float, bool, None).

    Returns
    -------
    bool
    """
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same_data(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same_data(x, y) for x, y in zip(a, b))
    if isinstance(a, float):
        return a == b or (a != a and b != b)
    return a == b


def store(kind, key, value):
    """Store ``value`` for ``(kind, key)`` unless an entry file exists already.

    Parameters
    ----------
    kind : str
    key : tuple
        See :func:`entry_path`.
    value : dict
        JSON data (dicts, lists, str, int, float, bool, None). Floats are
        written with all their digits (``repr``), so they read back equal.

    Returns
    -------
    bool
        True when the entry was written; False when the cache is off, an
        entry exists, the value is not JSON data that reads back equal, or
        the file cannot be written.
    """
    path = entry_path(kind, key)
    if path is None or os.path.lexists(path):
        return False
    try:   # private directories: an entry is trusted only where others cannot write
        path.parent.parent.parent.mkdir(parents=True, exist_ok=True)
        for d in (path.parent.parent, path.parent):
            d.mkdir(mode=0o700, exist_ok=True)
    except OSError:
        return False
    if _directory_problem(path.parent):   # never write into a directory others may write
        return False
    try:
        text = json.dumps({"key": _key_text(kind, key),
                           "uid": os.getuid() if hasattr(os, "getuid") else None,
                           "digest": _value_digest(value), "value": value}, allow_nan=True)
    except (TypeError, ValueError, RecursionError):
        return False
    if not same_data(json.loads(text)["value"], value):   # tuples or numpy scalars do not round-trip
        return False
    try:
        safe_write(path, text, "identification cache entry", root=os.path.realpath(path.parent))
    except (OSError, FileLimitError):
        return False
    return True
