"""Where numba keeps the compiled simulation kernels: the user's cache directory.

numba's default is a ``__pycache__`` directory next to the package's sources,
which writes into a source tree (or a site-packages directory) the user does
not expect to change. Unless the user sets ``NUMBA_CACHE_DIR`` themselves,
the kernels are cached under ``$XDG_CACHE_HOME/hammerstein/numba`` (by default
``~/.cache/hammerstein/numba``), next to the identification cache. This module
imports nothing, so the CLI can consult it before numba is loaded.
"""

from __future__ import annotations

import os

__all__ = ["numba_cache_dir", "use_user_numba_cache"]


def numba_cache_dir():
    """The directory numba caches the kernels in.

    Returns
    -------
    str or None
        ``NUMBA_CACHE_DIR`` when the user set it, else
        ``$XDG_CACHE_HOME/hammerstein/numba`` (``~/.cache/hammerstein/numba``);
        None when no home directory can be found.
    """
    own = os.environ.get("NUMBA_CACHE_DIR", "").strip()
    if own:
        return own
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    base = xdg if xdg and os.path.isabs(xdg) else os.path.join(os.path.expanduser("~"), ".cache")
    if base.startswith("~"):
        return None
    return os.path.join(base, "hammerstein", "numba")


def use_user_numba_cache():
    """Point ``NUMBA_CACHE_DIR`` at :func:`numba_cache_dir` unless the user set it.

    Called before numba is imported (numba reads the variable once, on import).

    Returns
    -------
    str or None
        The cache directory now in effect, None when numba's own default applies.
    """
    where = numba_cache_dir()
    if where is not None and not os.environ.get("NUMBA_CACHE_DIR", "").strip():
        os.environ["NUMBA_CACHE_DIR"] = where
    return where
