"""A byte-for-byte snapshot of a directory tree, for the no-harm tests of the CLI.

Tests take one before and one after a command and compare them: any file whose
bytes, permission bits or type changed, any link whose target changed, any entry
that appeared or vanished shows up as a difference.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path


def tree_snapshot(root):
    """Everything under ``root``: path -> (file type, permission bits, content).

    Parameters
    ----------
    root : str or pathlib.Path
        Directory to walk (symbolic links are recorded, not followed).

    Returns
    -------
    dict
        ``pathlib.Path`` -> ``(stat.S_IFMT, stat.S_IMODE, content)``, content the
        bytes of a regular file, the target of a link, None otherwise.
    """
    snap = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                content = os.readlink(p)
            elif stat.S_ISREG(st.st_mode):
                content = p.read_bytes()
            else:
                content = None
            snap[p] = (stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode), content)
    return snap
