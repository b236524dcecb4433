"""The convergence figure of iterative learning control: error against trial, per axis.

Used by ``hammerstein learn --history DIR`` and the ``kind = "ilc"``
compensator of scenarios (:mod:`hammerstein.compensation.ilc`).
"""

from __future__ import annotations

import numpy as np

from hammerstein.report.figures import pyplot as plt  # matplotlib on first use

from hammerstein.report.figures import _title_height, fixed_layout, log_ticks, suptitle

__all__ = ["convergence_figure", "iteration_history"]


def convergence_figure(iterations, max_error, rms_error, names, title, scale=None,
                       scale_name="radius / amplitude", euclidean=None, judged=None, unit="µm"):
    """Max and RMS tracking error against the trial, per axis (log scale).

    With ``euclidean`` (and ``judged``), the settled max Euclidean error
    ``learn`` prints (over two outputs or more; one output's is its max) and
    the error it judges the trials on (the noise averaged down) are drawn
    too, as open black and grey markers under the per-axis points. Each
    series sits a little to the side of its trial, so that equal values stay
    visible; the legend is under the axes.

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
    unit : str
        The errors' unit (the model's output unit, ``HammersteinPlant.units[1]``),
        the axis label's.

    Returns
    -------
    matplotlib.figure.Figure
    """
    k = np.asarray(iterations)
    mx, rms = np.atleast_2d(max_error), np.atleast_2d(rms_error)
    series = []             # (values, style): the aggregates first, under the per-axis points
    for values, style in ((euclidean if len(names) > 1 else None,   # one axis: its own max
                           dict(color="k", marker="D", ms=9, mfc="none", mew=1.4, ls="-", lw=1.0,
                                label="max Euclidean error ||Y_r - Y|| (settled)")),
                          (judged, dict(color="0.45", marker="v", ms=8, mfc="none", mew=1.3,
                                        ls=":", label="judged error (what learn compares: "
                                                      "noise averaged out)"))):
        v = None if values is None else np.asarray(values, dtype=float)
        if v is not None and v.shape == k.shape and np.any(np.isfinite(v) & (v > 0)):
            series.append((np.where(v > 0, v, np.nan), style))
    for l, name in enumerate(names):
        series.append((mx[l], dict(color=f"C{l}", marker="o", ms=6, ls="-",
                                   label=f"{name}: max |{name}_r - {name}|")))
        series.append((rms[l], dict(color=f"C{l}", marker="s", ms=6, ls="--",
                                    label=f"{name}: RMS of {name}_r - {name}")))
    # each series a little to the side of its trial: equal values stay visible side by side
    width = 0.5 if k.size < 2 else 0.5 * float(np.min(np.diff(np.sort(k))))
    dx = (np.arange(len(series)) - (len(series) - 1) / 2) * width / max(len(series), 1)
    ncol = 2
    rows = -(-len(series) // ncol)
    legend_h = 0.22 * rows + 0.15
    W, axes_h = 7.0, 3.0
    top = _title_height(title, W, fontsize=11) + 0.1
    bottom = 0.6 + legend_h
    fig = plt.figure(figsize=(W, top + axes_h + bottom))
    fixed_layout(fig, left=0.9, right=0.9 if scale else 0.25, top=top, bottom=bottom)
    ax = fig.add_subplot(1, 1, 1)
    for (values, style), d in zip(series, dx):
        ax.semilogy(k + d, values, **style)
    ax.set_xlabel("trial k")
    ax.set_ylabel(f"tracking error [{unit}]")
    ax.set_xticks(k)
    ax.set_xlim(float(k.min()) - 1.2 * width, float(k.max()) + 1.2 * width)
    ax.grid(True, which="major", alpha=0.3)
    log_ticks(ax)                       # 0.2, 0.5, 1 µm, not 2 x 10^-1
    if scale:
        sec = ax.secondary_yaxis("right", functions=(lambda v: 100 * v / scale,
                                                     lambda p: p * scale / 100))
        sec.set_ylabel(f"% of {scale_name}")
        log_ticks(sec)
    # the legend under the axes, on no data
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=ncol, fontsize=8,
               bbox_to_anchor=(0.5, 0.05 / fig.get_size_inches()[1]), frameon=False)
    suptitle(fig, title, fontsize=11)
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
