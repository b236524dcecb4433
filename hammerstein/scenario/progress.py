"""Progress bars for long sweeps (tqdm), quiet when stderr is not a terminal."""

from __future__ import annotations

from tqdm import tqdm

__all__ = ["progress"]


def progress(iterable=None, total=None, desc=None, **kwargs):
    """Wrap an iterable in a progress bar shown only on a terminal.

    ``tqdm(disable=None)`` disables the bar when stderr is not a TTY (pipes,
    CI logs, report generation), so sweeps print nothing there.

    Parameters
    ----------
    iterable : iterable, optional
        Items to iterate over (None: update the bar by hand with ``.update``).
    total : int, optional
        Number of items, when ``len(iterable)`` is unknown.
    desc : str, optional
        Label in front of the bar (e.g. ``"Fig. 9 sweep"``).
    **kwargs
        Further :class:`tqdm.tqdm` options (``unit``, ``leave``...).

    Returns
    -------
    tqdm.tqdm
        Iterates like ``iterable``.
    """
    kwargs.setdefault("disable", None)
    kwargs.setdefault("dynamic_ncols", True)
    return tqdm(iterable, total=total, desc=desc, **kwargs)
