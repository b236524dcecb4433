"""Output directories and file digests (behind :mod:`hammerstein.core.files`, which exports them)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from hammerstein.core._strings import escape
from hammerstein.exceptions import OutputError

__all__ = ["file_digest", "make_directory"]


def file_digest(path):
    """SHA-256 of a file's bytes, read in 1 MiB blocks (bounded memory), or None when unreadable.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    str or None
        The hexadecimal digest.
    """
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()


def make_directory(path, what="--out"):
    """Create the output directory ``path`` (and its parents; umask permissions) if missing.

    Parameters
    ----------
    path : str or pathlib.Path
    what : str
        The option or file that names it, for the message.

    Raises
    ------
    OutputError
        The system refuses it (a read-only place such as ``/sys``, a full disk, a file
        in the way): one line naming ``what``, the directory and the reason.
    """
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what}: {escape(path)}: cannot create the directory "
                          f"({exc.strerror or exc}); nothing was written") from None
