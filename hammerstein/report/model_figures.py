"""Figures of model validation (matplotlib, Agg backend).

* :func:`model_loop_grid`: plant vs model input-output maps in a p x m grid
  (direct transfers and cross-couplings), like the paper's Fig. 6;
* :func:`rms_vs_frequency_figure`: the model's RMS error against the drive
  frequency, one panel per transfer, like Fig. 7;
* :func:`record_fit_figure`: a measured record against its identified model
  (loops, time plot, error).
"""

from __future__ import annotations

import numpy as np

from hammerstein.report.figures import pyplot as plt  # matplotlib on first use
from hammerstein.report.figures import (
    _active_columns, _title_height, decimate, decimate_path, decorate_grid, fixed_layout,
    grid_figure, legend_on_top, suptitle)

__all__ = ["model_loop_grid", "rms_vs_frequency_figure", "record_fit_figure"]

_LETTERS = "abcdefghijklmnopqrstuvwxyz"


def _panel_title(l, k, m, y_labels, x_labels):
    kind = "direct" if l == k else "cross-coupling"
    return (f"({_LETTERS[l * m + k]}) {kind}: {y_labels[l].split(' ')[0]} vs "
            f"{x_labels[k].split(' ')[0]}")


def model_loop_grid(curves, x_labels, y_labels, title):
    """Plant (solid) vs model (dashed) input-output maps, panel (l, k) output l vs input k.

    Parameters
    ----------
    curves : list of dict
        Each with ``label`` (str), ``column`` (int k, the driven input),
        ``x`` (array, shape (n,)) the drive [V], ``plant`` and ``model``
        (arrays, shape (p, n)) the displacements [µm]. A case's plant and
        model share a colour.
    x_labels : sequence of str, length m
        E.g. ``'ux [V]'``.
    y_labels : sequence of str, length p
        E.g. ``'x [µm]'``.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    p, m = len(y_labels), len(x_labels)
    cols = _active_columns(curves, m)
    fig, axes = grid_figure(p, len(cols), title)
    counts = [0] * m
    for c in curves:
        k = c["column"]
        j = cols.index(k)
        color = f"C{counts[k] % 10}"
        for l in range(p):
            ax = axes[l][j]
            ax.plot(*decimate_path(c["x"], c["plant"][l]), "-", color=color, linewidth=1.3,
                    label=f"{c['label']}: plant")
            ax.plot(*decimate_path(c["x"], c["model"][l]), "--", color=color, linewidth=1.1,
                    label=f"{c['label']}: model")
        counts[k] += 1
    return decorate_grid(fig, axes, counts, x_labels, y_labels, title, legend_size=7,
                         columns=cols)


def rms_vs_frequency_figure(table, input_names, output_names, title, identification_hz=None):
    """Model RMS error against drive frequency, one panel per transfer (Fig. 7).

    Parameters
    ----------
    table : pandas.DataFrame
        Columns ``input`` (driven input name), ``output``, ``frequency_hz``
        [Hz] and ``model_rms_error`` [µm].
    input_names, output_names : sequence of str
        The m inputs and p outputs; panel (l, k) shows output l for drives
        of input k.
    title : str
    identification_hz : float, optional
        Identification frequency [Hz], marked by a vertical line.

    Returns
    -------
    matplotlib.figure.Figure
    """
    p, m = len(output_names), len(input_names)
    fig, axes = grid_figure(p, m, title, panel_h=3.3)
    for l, out in enumerate(output_names):
        for k, inp in enumerate(input_names):
            ax = axes[l][k]
            sel = table[(table["input"] == inp) & (table["output"] == out)].sort_values("frequency_hz")
            ax.plot(sel["frequency_hz"], sel["model_rms_error"], "o-", markersize=4, linewidth=1.2,
                    label="model RMS error")
            if identification_hz is not None:
                ax.axvline(identification_hz, color="0.5", linestyle=":", linewidth=1.0,
                           label=f"identified at {identification_hz:g} Hz")
            ax.set_title(_panel_title(l, k, m, [f"{o} " for o in output_names],
                                      [f"{i} " for i in input_names]), fontsize=10, y=1.0)
            ax.set_xlabel(f"{inp} drive frequency [Hz]")
            ax.set_ylabel(f"model RMS error, {out} [µm]")
            ax.grid(True, alpha=0.3)
            if identification_hz is not None:
                legend_on_top(ax, 2, ncol=2)
    suptitle(fig, title)
    return fig


def record_fit_figure(time, u, y, y_model, train_start, split, x_label, y_label, title):
    """A measured record against its identified model.

    Parameters
    ----------
    time : array_like, shape (n,)
        [s].
    u : array_like, shape (n,)
        Input [V].
    y, y_model : array_like, shape (n,)
        Measured and model output [µm] (model with its offset).
    train_start : int
        First training sample (after the start-up / virgin curve).
    split : int
        First held-out sample.
    x_label, y_label : str
        E.g. ``'u [V]'``, ``'y [µm]'``.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        (a) held-out loops, measured vs model; (b) time plot of the whole
        record with the training and held-out windows; (c) error.
    """
    t, u, y, ym = (np.asarray(a, dtype=float) for a in (time, u, y, y_model))
    W = 14.0
    top = _title_height(title, W) + 0.3
    fig = plt.figure(figsize=(W, top + 3.6 + 0.6))
    gs = fig.add_gridspec(1, 3, width_ratios=[1.0, 1.5, 1.5])
    fixed_layout(fig, 1, 3, left=0.75, right=0.2, bottom=0.6, top=top, wspace=0.85)
    ax = fig.add_subplot(gs[0])
    ax.plot(*decimate_path(u[split:], y[split:]), "-", color="0.3", linewidth=1.2, label="measured")
    ax.plot(*decimate_path(u[split:], ym[split:]), "--", color="C1", linewidth=1.1, label="model")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.set_title("(a) held-out loops", fontsize=10, y=1.0)
    ax.grid(True, alpha=0.3)
    axt = fig.add_subplot(gs[1])
    axt.plot(*decimate(t, y), "-", color="0.3", linewidth=1.0, label="measured")
    axt.plot(*decimate(t, ym), "--", color="C1", linewidth=1.0, label="model")
    axe = fig.add_subplot(gs[2])
    axe.plot(*decimate(t[train_start:], (y - ym)[train_start:]), "-", color="C3", linewidth=0.8)
    for a in (axt, axe):
        a.axvspan(t[train_start], t[split], color="C0", alpha=0.08, label="training")
        a.axvline(t[split], color="0.5", linestyle=":", linewidth=1.0)
        a.set_xlabel("time [s]")
        a.grid(True, alpha=0.3)
    axt.set_ylabel(y_label)
    axt.set_title("(b) time domain (shaded: training; right of the line: held out)", fontsize=10, y=1.0)
    axe.set_ylabel(f"measured - model [{y_label.split('[')[-1].rstrip(']') or 'µm'}]")
    axe.set_title("(c) model error", fontsize=10, y=1.0)
    legend_on_top(ax, 2)
    legend_on_top(axt, 3)
    suptitle(fig, title)
    return fig
