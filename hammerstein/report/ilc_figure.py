"""The convergence figure of iterative learning control: error against trial, per axis.

Used by ``hammerstein learn --history DIR`` and the ``kind = "ilc"``
compensator of scenarios (:mod:`hammerstein.core.ilc`).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hammerstein.report.figures import fixed_layout, legend_on_top  # noqa: E402

__all__ = ["convergence_figure"]


def convergence_figure(iterations, max_error, rms_error, names, title, scale=None):
    """Max and RMS tracking error against the trial, per axis (log scale).

    Parameters
    ----------
    iterations : array_like, shape (n,)
        Trial numbers k (0 = the initial drive).
    max_error, rms_error : array_like, shape (p, n)
        ``max |e_l|`` and RMS of ``e_l`` per axis [µm].
    names : sequence of p str
        Output names.
    title : str
    scale : float, optional
        Radius or amplitude [µm]: a right axis in % of it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    k = np.asarray(iterations)
    mx, rms = np.atleast_2d(max_error), np.atleast_2d(rms_error)
    fig = plt.figure(figsize=(6.4, 4.0))
    fixed_layout(fig, left=0.9, right=0.9 if scale else 0.25, top=0.55)
    ax = fig.add_subplot(1, 1, 1)
    for l, name in enumerate(names):
        line, = ax.semilogy(k, mx[l], marker="o", label=f"{name} max")
        ax.semilogy(k, rms[l], marker="s", ls="--", color=line.get_color(), label=f"{name} RMS")
    ax.set_xlabel("trial k")
    ax.set_ylabel("tracking error [µm]")
    ax.set_xticks(k)
    ax.grid(True, which="both", alpha=0.3)
    if scale:
        sec = ax.secondary_yaxis("right", functions=(lambda v: 100 * v / scale,
                                                     lambda p: p * scale / 100))
        sec.set_ylabel("% of radius / amplitude")
    legend_on_top(ax, 2 * len(names))
    fig.suptitle(title, fontsize=11)
    return fig
