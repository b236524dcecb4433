"""Paths named in scenario files: confined to the scenario's directory (behind :mod:`hammerstein.core.files`).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from hammerstein.exceptions import FileLimitError
from hammerstein.core._strings import escape


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
        return _named(path)
    path = path if path.is_absolute() else Path(base_dir) / path
    real = Path(os.path.realpath(path))
    roots = [Path(os.path.realpath(base_dir))]
    roots += [Path(os.path.realpath(d)) for d in os.environ.get(ALLOW_ENV, "").split(os.pathsep)
              if d.strip() and "\0" not in d]
    if any(real == r or r in real.parents for r in roots):
        return _named(path)
    raise error(f"{escape(text)}: outside the scenario's directory ({escape(base_dir)}); "
                f"name a file under it, or allow its directory with {ALLOW_ENV}=DIR")


#: The open :func:`recorded_paths` lists (each receives every path :func:`confined_path` returns).
_RECORDERS = []


def _named(path):
    for names in _RECORDERS:
        names.append(path)
    return path


@contextmanager
def recorded_paths():
    """Collect the files named in scenario files (every :func:`confined_path`) while the block runs.

    The runner uses it to know the files a scenario reads, so that no report
    directory it replaces holds one of them.

    Yields
    ------
    list of pathlib.Path
        Filled as the paths are named (a path named twice appears twice).
    """
    names = []
    _RECORDERS.append(names)
    try:
        yield names
    finally:
        _RECORDERS.remove(names)
