"""Helpers shared by the command modules: one-line messages on stderr."""

from __future__ import annotations

import sys

__all__ = ["print_err", "one_line"]


def print_err(msg):
    """Print ``msg`` on stderr."""
    print(msg, file=sys.stderr)


def one_line(text, path=None):
    """Fold a multi-line message into one line, without a repeated ``path: `` prefix.

    Parameters
    ----------
    text : str
        Message, one problem per line (e.g. ``ScenarioOutcome.error``).
    path : str, optional
        File name that prefixes each problem; kept once, at the front.

    Returns
    -------
    str
        ``path: problem 1; problem 2; ...`` on one line.

    Examples
    --------
    >>> one_line("a.toml: x: bad\na.toml: y: worse", "a.toml")
    'a.toml: x: bad; y: worse'
    """
    lines = [" ".join(ln.split()) for ln in str(text).splitlines() if ln.strip()]
    if path is None:
        return "; ".join(lines)
    pre = f"{path}: "
    lines = [ln[len(pre):] if ln.startswith(pre) else ln for ln in lines]
    return pre + "; ".join(lines)
