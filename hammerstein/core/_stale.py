"""What a killed writer leaves, and file systems a chmod cannot help (behind :mod:`hammerstein.core.files`)."""

from __future__ import annotations

import os
import re
import stat
import time
from glob import escape as glob_escape

#: the suffix of :func:`hammerstein.core.files.safe_write`'s temporaries (files.TMP_SUFFIX)
TMP_SUFFIX = ".hammerstein-tmp"

#: a temporary of :func:`safe_write` older than this [s] is a killed writer's (a live one
#: renames or removes its temporary within the seconds its write takes)
STALE_TMP_S = 3600.0


def _remove_stale_temporaries(parent, name):
    """Remove this user's temporaries of target ``name`` in ``parent`` older than STALE_TMP_S.

    A writer killed by SIGKILL (or a power cut) between writing its temporary and the rename
    left ``.NAME.<hex>.hammerstein-tmp`` files, megabytes each, that nothing removed; the next
    write of the same target removes them. Never another user's, never a recent one.
    """
    now = time.time()
    try:
        found = list(parent.glob(f".{glob_escape(name[:100])}.*{TMP_SUFFIX}"))
    except OSError:
        return
    for p in found:
        try:
            st = os.lstat(p)
            if (stat.S_ISREG(st.st_mode) and st.st_uid == os.getuid()
                    and now - st.st_mtime > STALE_TMP_S
                    and re.fullmatch(r"[0-9a-f]{12}", p.name[len(name[:100]) + 2:-len(TMP_SUFFIX)])):
                os.unlink(p)
        except OSError:
            continue


def _read_only_mount(path):
    """True when ``path`` lies on a file system mounted read-only."""
    try:
        return bool(os.statvfs(path).f_flag & getattr(os, "ST_RDONLY", 1))
    except (OSError, AttributeError):
        return False
