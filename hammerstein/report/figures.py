"""Figures like the paper's (matplotlib, Agg backend).

* :func:`loop_grid`: input-output maps in a p x m grid, panel (l, k) the map
  of abscissa k against output l, lettered (a), (b), ... row by row as in the
  paper's Fig. 5 and 8 ((a) direct x, (b) cross-coupling on x, (c)
  cross-coupling on y, (d) direct y).
* :func:`trajectory_figure`: XY plot with the reference, time plot and
  tracking-error plot (Fig. 10-13).
* :func:`xy_overlay`: several XY trajectories in one plot (Fig. 10-a).
"""

from __future__ import annotations

import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["loop_grid", "trajectory_figure", "divergence_figure", "xy_overlay", "raster_error_map",
           "save"]

_STYLES = ["-", "--", "-.", ":"]
_MARKERS = [None, None, "o", "x", "s", "^"]


def _style(i):
    return dict(linestyle=_STYLES[i % len(_STYLES)], marker=_MARKERS[i % len(_MARKERS)],
                markevery=0.08, markersize=4, linewidth=1.3)


def loop_grid(curves, x_labels, y_labels, title, direct_label="direct",
              cross_label="cross-coupling"):
    """Input-output maps of direct transfers and cross-couplings.

    Parameters
    ----------
    curves : list of dict
        Each with ``label`` (str), ``column`` (int k), ``x`` (array, shape
        (n,)) the abscissa [V or µm], and ``outputs`` (array, shape (p, n))
        [µm].
    x_labels : sequence of str, length m
        Axis labels of the abscissae, e.g. ``'u_x [V]'``.
    y_labels : sequence of str, length p
        Axis labels of the outputs, e.g. ``'x [µm]'``.
    title : str
    direct_label, cross_label : str
        Panel captions.

    Returns
    -------
    matplotlib.figure.Figure
    """
    p, m = len(y_labels), len(x_labels)
    fig, axes = plt.subplots(p, m, figsize=(5.2 * m, 4.2 * p), squeeze=False)
    counts = [0] * m
    for c in curves:
        k = c["column"]
        for l in range(p):
            axes[l][k].plot(c["x"], c["outputs"][l], label=c["label"], **_style(counts[k]))
        counts[k] += 1
    return decorate_grid(fig, axes, counts, x_labels, y_labels, title,
                         direct_label, cross_label, legend_size=8)


def decorate_grid(fig, axes, counts, x_labels, y_labels, title, direct_label="direct",
                  cross_label="cross-coupling", legend_size=8):
    """Titles, labels and legends of a p x m grid of input-output maps.

    Panel (l, k) is output l against abscissa k, lettered row by row as in the
    paper's Fig. 5/6/8: (a) (u_x, x) direct, (b) (u_y, x) cross-coupling, ...

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    axes : array of Axes, shape (p, m)
    counts : sequence of int, length m
        Curves drawn in each column (a column without curves says so).
    x_labels, y_labels : sequence of str
        Abscissa labels (m) and output labels (p), e.g. ``'u_x [V]'``, ``'x [µm]'``.
    title : str
    direct_label, cross_label : str
        Captions of diagonal and off-diagonal panels.
    legend_size : float

    Returns
    -------
    matplotlib.figure.Figure
        ``fig``, laid out.
    """
    p, m = len(y_labels), len(x_labels)
    letters = "abcdefghijklmnopqrstuvwxyz"
    for l in range(p):
        for k in range(m):
            ax = axes[l][k]
            kind = direct_label if l == k else cross_label
            ax.set_title(f"({letters[(l * m + k) % 26]}) {kind}: {y_labels[l].split(' ')[0]} vs "
                         f"{x_labels[k].split(' ')[0]}", fontsize=10)
            ax.set_xlabel(x_labels[k])
            ax.set_ylabel(y_labels[l])
            ax.grid(True, alpha=0.3)
            if counts[k]:
                ax.legend(fontsize=legend_size, loc="best")
            else:
                ax.text(0.5, 0.5, "no case drives this input", ha="center", va="center",
                        transform=ax.transAxes, color="0.5")
    fig.suptitle(textwrap.fill(title, width=int(48 * m)))
    fig.tight_layout()
    return fig


def trajectory_figure(time, reference, outputs, names, title, settle_time=0.0):
    """XY plot, time plot and tracking-error plot of a 2-D trajectory.

    Parameters
    ----------
    time : array_like, shape (n,)
        [s].
    reference, outputs : array_like, shape (2, n)
        ``(x_r, y_r)`` and ``(x, y)`` [µm] (outputs may hold NaN after a
        divergence).
    names : sequence of 2 str
        Output names.
    title : str
    settle_time : float
        End of the settling transient [s]: the XY plot shows the record
        after it, the time plots mark it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(time) * 1e3
    r = np.asarray(reference)
    y = np.asarray(outputs)
    e = r - y
    fig = plt.figure(figsize=(13, 4.6))
    gs = fig.add_gridspec(2, 3, width_ratios=[1.0, 1.4, 1.4])
    ax = fig.add_subplot(gs[:, 0])
    steady = np.asarray(time) >= settle_time
    ax.plot(r[0, steady], r[1, steady], "--", color="0.35", label="reference", linewidth=1.2)
    ax.plot(y[0, steady], y[1, steady], "-", color="C0", label="output", linewidth=1.0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{names[0]} [µm]")
    ax.set_ylabel(f"{names[1]} [µm]")
    ax.set_title("(a) spatial domain (after settling)", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, alpha=0.3)
    axt = fig.add_subplot(gs[:, 1])
    for i, n in enumerate(names):
        axt.plot(t, r[i], "--", color=f"C{i}", linewidth=1.0, label=f"{n}_r")
        axt.plot(t, y[i], "-", color=f"C{i}", linewidth=1.0, alpha=0.8, label=n)
    axt.set_xlabel("time [ms]")
    axt.set_ylabel("displacement [µm]")
    axt.set_title("(b) time domain", fontsize=10)
    axt.legend(fontsize=8, ncol=2, loc="upper right")
    axt.grid(True, alpha=0.3)
    axe = fig.add_subplot(gs[:, 2])
    axe.plot(t, e[0], "-", color="C0", linewidth=1.0, label=f"{names[0]}_r - {names[0]}")
    axe.plot(t, e[1], "-", color="C1", linewidth=1.0, label=f"{names[1]}_r - {names[1]}")
    axe.plot(t, np.sqrt(e[0] ** 2 + e[1] ** 2), "-", color="k", linewidth=0.8,
             label="Euclidean ||Y_r - Y||")
    axe.set_xlabel("time [ms]")
    axe.set_ylabel("tracking error [µm]")
    axe.set_title("(c) tracking error", fontsize=10)
    axe.legend(fontsize=8, loc="upper right")
    axe.grid(True, alpha=0.3)
    if settle_time > 0:
        for a in (axt, axe):
            a.axvline(settle_time * 1e3, color="0.5", linestyle=":", linewidth=1.0)
            a.text(settle_time * 1e3, 1.0, " settled", transform=a.get_xaxis_transform(),
                   va="top", ha="left", fontsize=8, color="0.4")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def divergence_figure(inputs, names, sample, reason, title):
    """Input voltages of a diverging compensator, |U| on a log scale.

    Parameters
    ----------
    inputs : array_like, shape (m, n)
        Compensator output [V] (valid before ``sample``).
    names : sequence of str
        Input names.
    sample : int
        First sample where the divergence was detected.
    reason : str
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    u = np.asarray(inputs)[:, :sample]
    k = np.arange(u.shape[1])
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for i, n in enumerate(names):
        mag = np.abs(u[i])
        ax.semilogy(k, np.where(mag > 0, mag, np.nan), "o-", label=f"|{n}| [V]", markersize=4)
    ax.axvline(sample, color="r", linestyle=":", label=f"divergence detected (sample {sample})")
    ax.axhline(10.0, color="0.5", linestyle="--", linewidth=0.8, label="10 V drive range")
    ax.set_xlabel("sample")
    ax.set_ylabel("|compensator output| [V]")
    ax.set_title(f"{title}\n{reason}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def xy_overlay(curves, names, title):
    """Several XY trajectories with their references (paper Fig. 10-a).

    Parameters
    ----------
    curves : list of dict
        Each with ``label``, ``reference`` and ``outputs`` (arrays, shape
        (2, n)) [µm].
    names : sequence of 2 str
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = plt.subplots(figsize=(6, 6))
    for i, c in enumerate(curves):
        ax.plot(c["reference"][0], c["reference"][1], "--", color="0.4", linewidth=1.0)
        ax.plot(c["outputs"][0], c["outputs"][1], "-", color=f"C{i}", linewidth=1.1,
                label=c["label"])
    ax.plot([], [], "--", color="0.4", label="references")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{names[0]} [µm]")
    ax.set_ylabel(f"{names[1]} [µm]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    return fig


def _line_image(x, e, line, mask, n_lines, grid):
    """Rows of ``e`` against ``x`` on ``grid``, one row per line, samples where ``mask``."""
    img = np.full((n_lines, grid.size), np.nan)
    for j in range(n_lines):
        sel = (line == j) & mask
        if np.count_nonzero(sel) < 2:
            continue
        order = np.argsort(x[sel], kind="stable")
        img[j] = np.interp(grid, x[sel][order], e[sel][order], left=np.nan, right=np.nan)
    return img


def raster_error_map(fast_reference, errors, labels, line_index, trace, extent, fast_name, title,
                     n_bins=200):
    """Image-style error map of a raster scan: error against fast-axis position, one row per line.

    One row of panels per error signal (e.g. the fast- and the slow-axis
    tracking error), the trace (fast axis rising) on the left and the
    retrace on the right; each image row is a scan line, its colour the
    error at each fast-axis reference position (linear interpolation onto
    ``n_bins`` positions). Colours are symmetric about 0 (red: output below
    the reference), shared by the trace and retrace of a signal.

    Parameters
    ----------
    fast_reference : array_like, shape (n,)
        Fast-axis reference [µm].
    errors : array_like, shape (k, n)
        Errors ``y_r - y`` [µm] (NaN after a divergence).
    labels : sequence of k str
        Name of each error signal, e.g. ``'x_r - x'``.
    line_index : array_like of int, shape (n,)
        Scan line of each sample, 0-based.
    trace : array_like of bool, shape (n,)
        True on the trace half of each line.
    extent : float
        Fast-axis scan size W [µm] (the abscissa spans [0, W]).
    fast_name : str
        Fast-axis output name.
    title : str
    n_bins : int
        Positions per image row.

    Returns
    -------
    matplotlib.figure.Figure
    """
    x = np.asarray(fast_reference, dtype=float)
    e = np.atleast_2d(np.asarray(errors, dtype=float))
    line = np.asarray(line_index, dtype=int)
    trace = np.asarray(trace, dtype=bool)
    n_lines = int(line.max()) + 1
    grid = np.linspace(0.0, float(extent), int(n_bins))
    k = e.shape[0]
    fig, axes = plt.subplots(k, 2, figsize=(11, 2.0 + 2.6 * k), squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.9, bottom=0.1, top=0.86, wspace=0.12, hspace=0.45)
    for i in range(k):
        imgs = [_line_image(x, e[i], line, trace, n_lines, grid),
                _line_image(x, e[i], line, ~trace, n_lines, grid)]
        finite = np.concatenate([m[np.isfinite(m)] for m in imgs])
        lim = float(np.max(np.abs(finite))) if finite.size else 1.0
        lim = lim if lim > 0 else 1.0
        for d, (img, name) in enumerate(zip(imgs, ("trace", "retrace"))):
            ax = axes[i][d]
            im = ax.imshow(img, aspect="auto", cmap="RdBu_r", vmin=-lim, vmax=lim,
                           extent=(0.0, float(extent), n_lines + 0.5, 0.5), interpolation="nearest")
            ax.set_title(f"({chr(97 + 2 * i + d)}) {labels[i]}, {name}", fontsize=10)
            ax.set_xlabel(f"{fast_name}_r (fast axis) [µm]")
            if d == 0:
                ax.set_ylabel("scan line")
        fig.colorbar(im, ax=list(axes[i]), fraction=0.03, pad=0.02, label="error [µm]")
    fig.suptitle(title)
    return fig


def save(fig, path):
    """Write a figure as PNG (120 dpi) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed afterwards (pyplot releases it).
    path : str or pathlib.Path
        File to write (overwritten).
    """
    fig.savefig(path, dpi=120)
    plt.close(fig)
