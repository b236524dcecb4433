"""The convergence figure of iterative learning control: error against trial, per axis.

Used by ``hammerstein learn --history DIR`` and the ``kind = "ilc"``
compensator of scenarios (:mod:`hammerstein.compensation.ilc`).
"""

from __future__ import annotations

import numpy as np

from hammerstein.report.figures import pyplot as plt  # matplotlib on first use

from hammerstein.report.figures import fixed_layout, legend_on_top, log_ticks

__all__ = ["convergence_figure", "iteration_history"]


def convergence_figure(iterations, max_error, rms_error, names, title, scale=None,
                       scale_name="radius / amplitude", euclidean=None, judged=None):
    """Max and RMS tracking error against the trial, per axis (log scale).

    With ``euclidean`` (and ``judged``), the settled max Euclidean error
    ``learn`` prints (over two outputs or more; one output's is its max) and
    the error it judges the trials on (the noise averaged down) are drawn
    too, in black and grey.

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
    scale_name : str
        What ``scale`` is, for the right axis' label (a raster's: its size).
    euclidean, judged : array_like, shape (n,), optional
        Settled max Euclidean error and judged error per trial [µm] (NaN
        where a trial has none).

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
    entries = 2 * len(names)
    for values, style in ((euclidean if len(names) > 1 else None,   # one axis: its own max
                           dict(color="k", marker="D", label="Euclidean max")),
                          (judged, dict(color="0.5", marker="v", ls=":",
                                        label="judged (noise removed)"))):
        v = None if values is None else np.asarray(values, dtype=float)
        if v is not None and v.shape == k.shape and np.any(np.isfinite(v) & (v > 0)):
            ax.semilogy(k, np.where(v > 0, v, np.nan), **style)
            entries += 1
    ax.set_xlabel("trial k")
    ax.set_ylabel("tracking error [µm]")
    ax.set_xticks(k)
    ax.grid(True, which="both", alpha=0.3)
    log_ticks(ax)                       # 0.2, 0.5, 1 µm, not 2 x 10^-1
    if scale:
        sec = ax.secondary_yaxis("right", functions=(lambda v: 100 * v / scale,
                                                     lambda p: p * scale / 100))
        sec.set_ylabel(f"% of {scale_name}")
        log_ticks(sec)
    legend_on_top(ax, entries)
    fig.suptitle(title, fontsize=11)
    return fig


def iteration_history(rows, names):
    """The per-trial errors of a case from its ``iteration-<k>`` metric rows.

    Parameters
    ----------
    rows : iterable of dict
        Metric rows (``channel``, ``metric``, ``value``), as
        :meth:`hammerstein.compensation.ilc.LearningCompensator.history_rows` writes
        them: channel ``iteration-<k>``, metrics ``max_abs_error_<output>``
        and ``rms_error_<output>`` [µm].
    names : sequence of p str
        Output names.

    Returns
    -------
    iterations : numpy.ndarray, shape (n,)
        The trials k found, ascending (empty when there are none).
    max_error, rms_error : numpy.ndarray, shape (p, n)
        [µm]; NaN where a row is missing.

    Examples
    --------
    >>> rows = [{"channel": "iteration-1", "metric": "max_abs_error_x", "value": 2.0},
    ...         {"channel": "iteration-0", "metric": "max_abs_error_x", "value": 4.0},
    ...         {"channel": "x", "metric": "max_abs_error_x", "value": 9.0}]
    >>> k, mx, rms = iteration_history(rows, ["x"])
    >>> k.tolist(), mx.tolist()
    ([0, 1], [[4.0, 2.0]])
    """
    table = {}
    for r in rows:
        ch = str(r.get("channel", ""))
        if not ch.startswith("iteration-") or not ch[10:].isdigit():
            continue
        table[(int(ch[10:]), r["metric"])] = float(r["value"])
    its = np.array(sorted({k for k, _ in table}), dtype=int)
    mx = np.array([[table.get((k, f"max_abs_error_{n}"), np.nan) for k in its] for n in names])
    rms = np.array([[table.get((k, f"rms_error_{n}"), np.nan) for k in its] for n in names])
    return its, mx.reshape(len(names), its.size), rms.reshape(len(names), its.size)
