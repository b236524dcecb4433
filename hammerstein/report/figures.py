"""Figures like the paper's (matplotlib, Agg backend).

* :func:`loop_grid`: input-output maps in a p x m grid, panel (l, k) the map
  of abscissa k against output l, lettered (a), (b), ... row by row as in the
  paper's Fig. 5 and 8 ((a) direct x, (b) cross-coupling on x, (c)
  cross-coupling on y, (d) direct y); columns that no curve drives are left
  out (the panels drawn are lettered in turn, no letter missing).
The trajectory, divergence, overlay and raster error-map figures are in
:mod:`hammerstein.report.trajectories`, built on this module's layout helpers.

Speed: every figure has a fixed layout computed once from its size (margins
in inches, :func:`fixed_layout`), no ``tight_layout``/``bbox_inches="tight"``
(each of which draws the figure once more), and long lines are reduced to the
points a figure can show (:func:`decimate`, min/max per pixel bin, turning
points kept). ``benchmarks/figures.py`` times every figure function.

Length: the lazy matplotlib loader and the classes it defines, the layout helpers
and the text/tick caches that make :func:`save` fast share this module's globals
(PEP 562 lazy names), so they stay together; the figures themselves live elsewhere.
"""

from __future__ import annotations

import contextlib
import math
import re
import textwrap
import threading

import numpy as np


# -- matplotlib, loaded when the first figure is drawn --------------------------------------
# Importing matplotlib (pyplot, the Agg backend, fonts) costs about as much CPU as a warm
# default run simulates; a run whose figures are all drawn by workers, or none at all, never
# needs it in its main process. `plt` (also exported as `pyplot`) is a stand-in: its first
# attribute access imports matplotlib with the Agg backend, defines the classes below that
# derive from matplotlib's and puts every matplotlib name this module uses in its globals.
_MPL_LOCK = threading.RLock()


def _load_matplotlib():
    """Import matplotlib (Agg) and define this module's matplotlib-derived classes, once."""
    g = globals()
    if "Axis" in g:
        return
    with _MPL_LOCK:
        if "Axis" in g:
            return
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot
        from matplotlib.axis import Axis
        from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg, get_hinting_flag
        from matplotlib.font_manager import fontManager, get_font
        from matplotlib.ft2font import RenderMode
        from matplotlib.ticker import Locator, LogFormatterSciNotation, NullLocator
        from PIL import Image
        from PIL.PngImagePlugin import PngInfo

        names = dict(matplotlib=matplotlib, fontManager=fontManager, get_font=get_font,
                     FigureCanvasAgg=FigureCanvasAgg, RendererAgg=RendererAgg,
                     get_hinting_flag=get_hinting_flag, RenderMode=RenderMode, Locator=Locator,
                     LogFormatterSciNotation=LogFormatterSciNotation, NullLocator=NullLocator,
                     Image=Image, PngInfo=PngInfo, _pyplot_module=matplotlib.pyplot)
        g.update(names)
        g.update(_define_classes())
        g["Axis"] = Axis                     # last: marks the module as loaded


class _LazyPyplot:
    """``matplotlib.pyplot``, imported on the first attribute access (:func:`_load_matplotlib`)."""

    def __getattr__(self, name):
        _load_matplotlib()
        return getattr(_pyplot_module, name)  # noqa: F821 - defined by _load_matplotlib

    def __repr__(self):
        return "<matplotlib.pyplot, imported on first use>"


plt = pyplot = _LazyPyplot()

#: Names defined by :func:`_load_matplotlib` (module attributes on first access, PEP 562).
_LAZY_NAMES = ("matplotlib", "Axis", "fontManager", "get_font", "FigureCanvasAgg", "RendererAgg",
               "get_hinting_flag", "RenderMode", "Locator", "LogFormatterSciNotation",
               "NullLocator", "Image", "PngInfo", "_PlainLogFormatter", "_TicksInView",
               "_TextCachingRenderer", "_Canvas")


def __getattr__(name):
    if name in _LAZY_NAMES:
        _load_matplotlib()
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["plain_log_labels", "loop_grid", "decorate_grid", "save", "scenario_prefix", "grid_figure", "decimate",
           "decimate_path", "fixed_layout", "legend_on_top", "headroom", "log_ticks", "suptitle",
           "grid_width", "legend_columns", "MAX_LOG_LABELS", "MAX_POINTS", "DPI", "pyplot"]

#: Largest number of points drawn per line: a 15-inch figure at :data:`DPI` is
#: 1800 pixels wide, so 2 points (min and max) per pixel column of a panel.
MAX_POINTS = 2000
#: Resolution of the PNG files [dots per inch].
DPI = 120
_LETTERS = "abcdefghijklmnopqrstuvwxyz"
_STYLES = ["-", "--", "-.", ":"]
_MARKERS = [None, None, "o", "x", "s", "^"]


def _style(i):
    return dict(linestyle=_STYLES[i % len(_STYLES)], marker=_MARKERS[i % len(_MARKERS)],
                markevery=0.08, markersize=4, linewidth=1.3)


# -- speed: fewer points, fixed layouts ---------------------------------------------------
def _minmax_indices(arrays, max_points):
    """Indices of the first/last sample and of the min and max of every array
    in each of ``max_points // (2 * len(arrays))`` equal bins (sorted, unique)."""
    n = arrays[0].shape[-1]
    n_bins = max(1, max_points // (2 * len(arrays)))
    if n <= max_points or n_bins >= n:
        return None
    edges = np.linspace(0, n, n_bins + 1).astype(int)
    width = int(np.diff(edges).max())
    # pad every bin to the same width so one argmin/argmax per row does it
    idx = edges[:-1, None] + np.arange(width)[None, :]
    valid = idx < edges[1:, None]
    idx = np.minimum(idx, n - 1)
    keep = [np.array([0, n - 1])]
    for a in arrays:
        v = a[idx]
        lo = np.where(valid & ~np.isnan(v), v, np.inf)
        hi = np.where(valid & ~np.isnan(v), v, -np.inf)
        rows = np.arange(n_bins)
        keep += [idx[rows, lo.argmin(axis=1)], idx[rows, hi.argmax(axis=1)]]
        nan = np.flatnonzero(np.isnan(a))
        if nan.size:  # keep where a line is broken (NaN after a divergence)
            keep.append(nan[np.r_[True, np.diff(nan) > 1]])
    return np.unique(np.concatenate(keep))


def decimate(x, y, max_points=MAX_POINTS):
    """Reduce a time series to what a figure can show, keeping its turning points.

    The samples are split into ``max_points // 2`` bins of consecutive
    samples; in each bin the minimum and the maximum of ``y`` are kept (in
    time order), plus the first and last sample. A line drawn through the
    result covers the same pixels as the full line when there are at least as
    many bins as pixel columns (min/max decimation, as oscilloscopes do).

    Parameters
    ----------
    x : array_like, shape (n,)
        Abscissa (time [s] or [ms]), increasing.
    y : array_like, shape (n,)
        Ordinate; NaN (after a divergence) breaks the line and is kept.
    max_points : int
        At most about this many points are returned.

    Returns
    -------
    x, y : numpy.ndarray, shape (k,), k <= max_points + 2
        The input unchanged when ``n <= max_points``.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 100001)
    >>> td, yd = decimate(t, np.sin(2 * np.pi * 5 * t))
    >>> td.size <= 2002, float(yd.max()), float(yd.min())
    (True, 1.0, -1.0)
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = _minmax_indices([y], max_points)
    return (x, y) if keep is None else (x[keep], y[keep])


def decimate_path(x, y, max_points=MAX_POINTS):
    """Reduce a parametric XY curve (x(t), y(t)) keeping the turning points of both.

    As :func:`decimate`, but the minimum and maximum of ``x`` and of ``y`` are
    kept in every bin, so the extreme points of loops and orbits stay exact.

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Coordinates in sample order.
    max_points : int

    Returns
    -------
    x, y : numpy.ndarray, shape (k,), k <= max_points + 2
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = _minmax_indices([x, y], max_points)
    return (x, y) if keep is None else (x[keep], y[keep])


def fixed_layout(fig, nrows=1, ncols=1, left=0.8, right=0.25, bottom=0.6, top=0.8,
                 wspace=0.75, hspace=0.8):
    """Place the subplots of ``fig`` with margins given in inches.

    Computed once from the figure size, so the figure is drawn once when it is
    saved (``tight_layout``, constrained layout and ``bbox_inches="tight"``
    each need an extra draw to measure the text).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    nrows, ncols : int
        Grid of the subplots (to turn the gaps into fractions of an axis).
    left, right, bottom, top : float
        Margins [in].
    wspace, hspace : float
        Gaps between columns / rows [in].
    """
    W, H = fig.get_size_inches()
    aw = (W - left - right - (ncols - 1) * wspace) / ncols
    ah = (H - top - bottom - (nrows - 1) * hspace) / nrows
    fig.subplots_adjust(left=left / W, right=1 - right / W, bottom=bottom / H, top=1 - top / H,
                        wspace=wspace / aw if ncols > 1 else 0.2,
                        hspace=hspace / ah if nrows > 1 else 0.2)


def _title_lines(title, width_in, fontsize=12):
    return textwrap.wrap(title, width=max(20, int(width_in * 72 / (0.56 * fontsize))))


def suptitle(fig, title, fontsize=12):
    """Figure title wrapped to the figure width, at the top of the figure.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    title : str
    fontsize : float
        [pt].

    Returns
    -------
    int
        Number of lines of the wrapped title.
    """
    lines = _title_lines(title, fig.get_size_inches()[0] - 0.3, fontsize)
    fig.suptitle("\n".join(lines), fontsize=fontsize, y=1 - 0.12 / fig.get_size_inches()[1],
                 va="top")
    return len(lines)


def _title_height(title, width_in, fontsize=12):
    """Height [in] of a wrapped figure title and the space under it."""
    return 0.12 + len(_title_lines(title, width_in - 0.3, fontsize)) * fontsize * 1.3 / 72 + 0.1


def headroom(ax, rows, fontsize=8):
    """Extend the y-limits of ``ax`` upwards so that a band at the top stays free of data.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        With its final position (layout fixed) and its curves drawn; linear
        or log y-scale.
    rows : int
        Text lines the band must hold.
    fontsize : float
        Font size of those lines [pt].
    """
    fig_h = ax.figure.get_size_inches()[1]
    ax_h = ax.get_position().height * fig_h
    frac = min(0.6, (rows * fontsize * 1.45 / 72 + 0.12) / ax_h)
    lo, hi = ax.get_ylim()
    if ax.get_yscale() == "log":
        llo, lhi = np.log10(lo), np.log10(hi)
        ax.set_ylim(lo, 10 ** (llo + (lhi - llo) / (1 - frac)))
    else:
        ax.set_ylim(lo, lo + (hi - lo) / (1 - frac))


def legend_on_top(ax, n_entries, ncol=None, fontsize=8, loc="upper center", **kwargs):
    """A legend in a band at the top of ``ax`` that no data enters.

    The y-limits are extended upwards (linear or log scale) by the height of
    the legend so that the legend never covers a curve. Call it after the
    curves are drawn and the layout is fixed.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    n_entries : int
        Number of legend entries.
    ncol : int, optional
        Columns of the legend (default: all entries in one row up to 4).
    fontsize : float
    loc : str
        ``'upper center'``, ``'upper left'`` or ``'upper right'``.
    **kwargs
        Passed to ``ax.legend`` (e.g. ``handles``, ``labels``).

    Returns
    -------
    matplotlib.legend.Legend
    """
    ncol = ncol or min(n_entries, 4)
    headroom(ax, math.ceil(n_entries / ncol), fontsize)
    return ax.legend(loc=loc, ncol=ncol, fontsize=fontsize, framealpha=0.9,
                     borderaxespad=0.3, handlelength=2.2, columnspacing=1.2, **kwargs)


def log_ticks(ax):
    """Plain labels 1, 2, 5 x 10^k on a log y-axis (no crowded minor labels).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        With a log y-scale.
    """
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # lazy: only the sweep figures' log axes
    ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


#: Labels at most on a log axis of :func:`readable_log_ticks`: beyond, decades only.
MAX_LOG_LABELS = 12

#: Mantissas of the labelled ticks of :func:`readable_log_ticks`, coarsest first.
LOG_TICK_SETS = ((1.0, 2.0, 5.0), (1.0, 1.5, 2.0, 3.0, 5.0, 7.0),
                 (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0))


def _log_tick_values(lo, hi, subs):
    """Ticks ``m 10^k`` (m in ``subs``) from the last at or below ``lo`` to the first at or above ``hi``."""
    k0, k1 = int(np.floor(np.log10(lo))) - 1, int(np.ceil(np.log10(hi))) + 1
    ticks = np.array(sorted(m * 10.0 ** k for k in range(k0, k1 + 1) for m in subs))
    ticks = np.array([float(f"{t:.12g}") for t in ticks])
    below, above = ticks[ticks <= lo * (1 + 1e-12)], ticks[ticks >= hi * (1 - 1e-12)]
    return ticks[(ticks >= below[-1]) & (ticks <= above[0])]


def _positive_span(values):
    """(lo, hi) of the positive finite ``values`` (widened when equal), or None."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return None
    lo, hi = float(v.min()), float(v.max())
    return (lo / 1.5, hi * 1.5) if hi <= lo * (1 + 1e-9) else (lo, hi)


def log_tick_set(values, max_span=1.8):
    """Index in :data:`LOG_TICK_SETS` of the coarsest mantissas that label ``values`` well.

    Well: three labelled ticks or more between the tick at or below the
    smallest value and the one at or above the largest, and that range at most
    ``max_span`` times the values' own (on the log scale); the finest set
    when none is.

    Parameters
    ----------
    values : array_like
        Positive finite ones are used.
    max_span : float
        Largest ratio of the axis' log range to the values'.

    Returns
    -------
    int
    """
    span = _positive_span(values)
    if span is None:
        return 0
    lo, hi = span
    own = np.log10(hi / lo)
    for i, subs in enumerate(LOG_TICK_SETS):
        t = _log_tick_values(lo, hi, subs)
        if len(t) >= 3 and np.log10(t[-1] / t[0]) <= max_span * own:
            return i
    return len(LOG_TICK_SETS) - 1


def readable_log_ticks(ax, values, tick_set=None):
    """A log y-axis whose data lie between labelled ticks, labelled in plain numbers.

    The y-limits run from the labelled tick at or below the smallest value to
    the one at or above the largest, so that no point lies beyond the last
    label; the labels are plain numbers (0.02, 0.05, 0.1) at ``m x 10^k``,
    ``m`` from ``LOG_TICK_SETS[tick_set]`` (1, 2, 5 when the values span
    enough for three of them, finer otherwise, :func:`log_tick_set`); the
    minor ticks are unlabelled. Give the panels of one figure the same
    ``tick_set`` (the largest of theirs) for the same kind of labels.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        With a log y-scale.
    values : array_like
        The values drawn; positive finite ones are used.
    tick_set : int, optional
        Index in :data:`LOG_TICK_SETS`; default :func:`log_tick_set` of ``values``.

    Returns
    -------
    numpy.ndarray
        The labelled ticks (empty when no value is positive: then
        :func:`log_ticks` labels the axis).
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter
    span = _positive_span(values)
    if span is None:
        log_ticks(ax)
        return np.array([])
    subs = LOG_TICK_SETS[log_tick_set(values) if tick_set is None else tick_set]
    ticks = _log_tick_values(*span, subs)
    ax.set_ylim(ticks[0], ticks[-1])
    if len(ticks) > MAX_LOG_LABELS:
        # values over many decades (a compensator following its own model to 1e-12 beside
        # others at 1-20): 1, 2, 5 in every decade overlapped; decades, every k-th
        decades = _log_tick_values(*span, (1.0,))
        step = -(-len(decades) // MAX_LOG_LABELS)
        ticks = decades[::step]
        ax.set_ylim(decades[0], decades[-1])
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.yaxis.set_minor_locator(LogLocator(base=10.0, subs=np.arange(1.0, 10.0)))
    ax.yaxis.set_minor_formatter(NullFormatter())
    return ticks


def _settled_ylim(ax, values, pad=0.08):
    """Scale ``ax`` on ``values`` (the settled part of its curves)."""
    v = np.concatenate([np.ravel(a) for a in values])
    v = v[np.isfinite(v)]
    if v.size == 0:
        return
    lo, hi = float(v.min()), float(v.max())
    span = hi - lo if hi > lo else max(abs(hi), 1e-9)
    ax.set_ylim(lo - pad * span, hi + pad * span)


def scenario_prefix(scenario):
    """Short name of a scenario for figure titles.

    Parameters
    ----------
    scenario : object
        With ``title`` and ``name`` (a loaded scenario).

    Returns
    -------
    str
        ``"Fig. 8"`` for a title that starts with a paper figure number
        (``"Fig. 8: ..."``), else the whole title when it is at most
        :data:`PREFIX_CHARS` characters (a ':' in it kept: ``"Stage B: slow
        scans"`` stays whole), else the scenario name.
    """
    title = " ".join(str(getattr(scenario, "title", "") or "").split())
    figure = _FIGURE_NUMBER.match(title)
    if figure:
        return figure.group(1)
    return title if 0 < len(title) <= PREFIX_CHARS else scenario.name


#: Longest scenario title used whole as the prefix of its figures' titles.
PREFIX_CHARS = 60
_FIGURE_NUMBER = re.compile(r"^((?:Fig\.|Figure)\s*\d+[a-z]?)\s*:")


def plain_log_labels(axis):
    """Label a log-scaled axis with plain numbers instead of powers of ten.

    On a log axis spanning less than about a decade matplotlib labels minor
    ticks too, as ``3×10⁻¹``: text twice as wide as ``0.3``, which pushes the
    axis label off a fixed layout's margin onto the tick labels. The same
    ticks keep a label; only its text changes (``f"{x:g}"``).

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        ``ax.yaxis`` or ``ax.xaxis`` of a log-scaled axes.
    """
    _load_matplotlib()
    axis.set_major_formatter(_PlainLogFormatter(labelOnlyBase=False))
    axis.set_minor_formatter(_PlainLogFormatter(labelOnlyBase=False))


def grid_width(m, panel_w=5.0):
    """Width of :func:`grid_figure`'s figure.

    Parameters
    ----------
    m : int
        Columns of panels.
    panel_w : float
        Width of one panel [in].

    Returns
    -------
    float
        [in].
    """
    return 0.85 + 0.25 + m * panel_w + (m - 1) * 0.85


def legend_columns(labels, width, fontsize=8, most=3):
    """Columns of a figure legend whose entries fit side by side within ``width``.

    Each entry is taken as its handle (2.2 font sizes), the gap between
    columns and its label at 0.6 font sizes per character (DejaVu Sans'
    mean advance); a legend wider than the figure was cut on both sides
    (a sweep of eight compensators with names of 60 characters, three
    columns in a 5.9 in figure).

    Parameters
    ----------
    labels : sequence of str
        The legend's labels.
    width : float
        The figure's width [in].
    fontsize : float
        The legend's font size [pt].
    most : int
        Columns at most.

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> legend_columns(["a", "b", "c"], 6.0), legend_columns(["x" * 60] * 8, 5.9)
    (3, 1)
    """
    pt = fontsize / 72.0
    entry = max((len(str(t)) for t in labels), default=1) * 0.6 * pt + 4.0 * pt
    fit = int((float(width) - 0.2) // entry)
    return max(1, min(len(labels), int(most), fit))


def grid_figure(p, m, title, panel_w=5.0, panel_h=3.6, extra_top=0.0):
    """A p x m grid of panels with a fixed layout and room for ``title``.

    Parameters
    ----------
    p, m : int
        Rows and columns of panels.
    title : str
        Figure title (wrapped; the top margin grows with its lines).
    panel_w, panel_h : float
        Size of one panel [in].
    extra_top : float
        Height [in] of a band reserved under the title (a figure legend).

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : numpy.ndarray of Axes, shape (p, m)
    """
    W = grid_width(m, panel_w)
    top = _title_height(title, W) + 0.3 + extra_top
    H = top + 0.6 + p * panel_h + (p - 1) * 0.8
    fig, axes = plt.subplots(p, m, figsize=(W, H), squeeze=False)
    fixed_layout(fig, p, m, left=0.85, right=0.25, bottom=0.6, top=top, wspace=0.85, hspace=0.8)
    return fig, axes


def _active_columns(curves, m):
    """Columns (abscissae) that at least one curve uses, in order."""
    used = {c["column"] for c in curves}
    cols = [k for k in range(m) if k in used]
    return cols or list(range(m))


def loop_grid(curves, x_labels, y_labels, title, direct_label="direct",
              cross_label="cross-coupling"):
    """Input-output maps of direct transfers and cross-couplings.

    Panel (l, k) is output l against abscissa k; only the abscissae that some
    curve uses get a column (a compensated sine on x alone gives panels (a)
    and (c)). Each case keeps its colour and line style in every row; the
    legend sits above the curves of the top panel of each column.

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
        Figure title (what this file shows).
    direct_label, cross_label : str
        Panel captions.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> u = 10 * np.sin(np.linspace(0, 2 * np.pi, 401))
    >>> fig = loop_grid([{"label": "ux 50 Hz", "column": 0, "x": u,
    ...                   "outputs": np.vstack([5.8 * u, 0.2 * u])}],
    ...                 ["ux [V]", "uy [V]"], ["x [µm]", "y [µm]"], "open-loop maps")
    >>> len(fig.axes)   # (a) and (b): no curve drives uy
    2
    >>> plt.close(fig)
    """
    p, m = len(y_labels), len(x_labels)
    cols = _active_columns(curves, m)
    fig, axes = grid_figure(p, len(cols), title)
    counts = [0] * m
    for c in curves:
        k = c["column"]
        j = cols.index(k)
        for l in range(p):
            xd, yd = decimate_path(c["x"], c["outputs"][l])
            axes[l][j].plot(xd, yd, label=c["label"], **_style(counts[k]))
        counts[k] += 1
    return decorate_grid(fig, axes, counts, x_labels, y_labels, title,
                         direct_label, cross_label, legend_size=8, columns=cols)


def decorate_grid(fig, axes, counts, x_labels, y_labels, title, direct_label="direct",
                  cross_label="cross-coupling", legend_size=8, columns=None):
    """Titles, labels and legends of a grid of input-output maps.

    Panel (l, k) is output l against abscissa k, lettered row by row as in the
    paper's Fig. 5/6/8: (a) (u_x, x) direct, (b) (u_y, x) cross-coupling, ...
    With columns left out, the panels drawn are lettered (a), (b), ... in turn,
    so no letter is missing.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        With a fixed layout (:func:`grid_figure`).
    axes : array of Axes, shape (p, len(columns))
    counts : sequence of int, length m
        Curves drawn against each abscissa.
    x_labels, y_labels : sequence of str
        Abscissa labels (m) and output labels (p), e.g. ``'u_x [V]'``, ``'x [µm]'``.
    title : str
    direct_label, cross_label : str
        Captions of diagonal and off-diagonal panels.
    legend_size : float
    columns : sequence of int, optional
        The abscissa index of each column of ``axes`` (default: all m).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig``.
    """
    p, m = len(y_labels), len(x_labels)
    columns = list(range(m)) if columns is None else list(columns)
    for l in range(p):
        for j, k in enumerate(columns):
            ax = axes[l][j]
            kind = direct_label if l == k else cross_label
            ax.set_title(f"({_LETTERS[(l * len(columns) + j) % 26]}) {kind}: "
                         f"{y_labels[l].split(' ')[0]} vs "
                         f"{x_labels[k].split(' ')[0]}", fontsize=10, y=1.0)
            ax.set_xlabel(x_labels[k])
            ax.set_ylabel(y_labels[l])
            ax.grid(True, alpha=0.3)
            if not counts[k]:
                ax.text(0.5, 0.5, "no case drives this input", ha="center", va="center",
                        transform=ax.transAxes, color="0.5")
            elif l == 0:
                n = len(ax.get_legend_handles_labels()[0])
                legend_on_top(ax, n, ncol=1 if n == 1 else 2, fontsize=legend_size)
    suptitle(fig, title)
    return fig


def _ticks_in_view(fig):
    """Wrap the tick locators of every axis of ``fig`` in :class:`_TicksInView`
    (not the colorbars', whose locators their colorbar manages)."""
    _load_matplotlib()
    for ax in fig.axes:
        if getattr(ax, "_colorbar", None) is not None:
            continue
        for axis in (ax.xaxis, ax.yaxis):
            for ticker in (axis.major, axis.minor):        # shared axes share a ticker
                if not isinstance(ticker.locator, (_TicksInView, NullLocator)):
                    ticker.locator = _TicksInView(ticker.locator)
                    ticker.locator.set_axis(axis)


def _unlabelled_axes_not_placed(fig):
    """Skip the label placement of every axis of ``fig`` whose label is empty.

    Before drawing an axis, matplotlib places its label clear of the tick
    labels of the axis and of every axis sharing it (one more tick update
    per sibling, quadratic in the panels of a column sharing x): 9 % of the
    figures' CPU. An empty label draws nothing wherever it is, so it gets
    a fixed place instead (``set_label_coords``, which turns the automatic
    placement off); the pixels do not change.
    """
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.label.get_text() == "":
                axis.set_label_coords(0.5, 0.5)


_DRAW_LOCK = threading.RLock()


@contextlib.contextmanager
def _ticks_updated_once():
    """While drawing one figure, update each axis' ticks once (not three times).

    Drawing a labelled axis, matplotlib updates its ticks (locator,
    formatter, positions of every tick) and measures its tick labels when
    drawing them, again to place the axis label clear of them, and a third
    time for the spine's extent that placement reads
    (``Axis._update_ticks``, ``Axis._get_ticklabel_bboxes``). Within one
    draw nothing changes in between, so the first result is reused while the
    view interval of the axis is the one it was computed for (anything that
    moves the view limits computes it again); the ticks and the pixels are
    the same (``tests/report/test_tick_memo.py``). Measured on the paper
    run's 27 figures drawn in one process: 6.0-7.6 s of CPU against
    7.2-7.9 s without it (3 alternated rounds, load 0.6-1.0), byte-identical
    PNGs.

    The methods are replaced on matplotlib's ``Axis`` class for the draw,
    so :func:`save` draws one figure at a time in a process
    (:data:`_DRAW_LOCK`; matplotlib is not thread-safe anyway).
    """
    _load_matplotlib()
    update = getattr(Axis, "_update_ticks", None)
    bboxes = getattr(Axis, "_get_ticklabel_bboxes", None)
    if update is None or bboxes is None:                 # another matplotlib: draw as it does
        yield
        return
    ticks_of, boxes_of = {}, {}

    def view(axis):
        return tuple(float(v) for v in axis.get_view_interval())

    def update_once(axis):
        key = view(axis)
        hit = ticks_of.get(id(axis))
        if hit is None or hit[0] != key or hit[1] is not axis:
            hit = ticks_of[id(axis)] = (key, axis, update(axis))
        return list(hit[2])

    def bboxes_once(axis, ticks, renderer):
        key = (view(axis), tuple(id(t) for t in ticks), id(renderer))
        hit = boxes_of.get(id(axis))
        if hit is None or hit[0] != key or hit[1] is not axis:
            hit = boxes_of[id(axis)] = (key, axis, bboxes(axis, ticks, renderer))
        return [b.frozen() for b in hit[2][0]], [b.frozen() for b in hit[2][1]]

    Axis._update_ticks, Axis._get_ticklabel_bboxes = update_once, bboxes_once
    try:
        yield
    finally:
        Axis._update_ticks, Axis._get_ticklabel_bboxes = update, bboxes


_TEXT_CACHE_ENTRIES = 50_000                # per cache; about 10 MB of glyph bitmaps at most
_layouts, _extents, _glyphs, _rotations, _heights = {}, {}, {}, {}, {}


def _cached(cache, key, compute):
    value = cache.get(key)
    if value is None:
        if len(cache) >= _TEXT_CACHE_ENTRIES:
            cache.clear()
        value = cache[key] = compute()
    return value


def _hashable(value):
    """``value`` as a dictionary key (lists of features or language tags as tuples)."""
    if isinstance(value, (list, tuple)):
        return tuple(_hashable(v) for v in value)
    return value


def _define_classes():
    """The classes deriving from matplotlib's (called once, by :func:`_load_matplotlib`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg, get_hinting_flag
    from matplotlib.font_manager import fontManager, get_font
    from matplotlib.ft2font import RenderMode
    from matplotlib.ticker import Locator, LogFormatterSciNotation

    class _PlainLogFormatter(LogFormatterSciNotation):
        """Label the ticks matplotlib's log formatter labels, as plain numbers (``0.3``, ``20``)."""

        def __call__(self, x, pos=None):
            return f"{x:g}" if super().__call__(x, pos) else ""

    class _TicksInView(Locator):
        """A tick locator returning only the ticks of ``base`` that the axis draws.

        Locators return ticks beyond the view limits too (a linear axis one or two
        per side, a log axis whole decades); matplotlib creates a tick object
        (lines and labels) for each of them and then draws only those inside the
        view interval. Dropping them first gives the same picture with fewer tick
        objects (a third of the ticks of a Bode plot's log axes). The interval
        test is matplotlib's (``Axis._update_ticks``), with a looser tolerance:
        every tick it draws is kept.

        Parameters
        ----------
        base : matplotlib.ticker.Locator
            The axis' locator (limits, ``nonsingular`` and ``view_limits`` are its own).
        """

        def __init__(self, base):
            self.base = base

        def set_axis(self, axis):
            super().set_axis(axis)
            self.base.set_axis(axis)

        def __call__(self):
            locs = np.asarray(self.base(), dtype=float)
            if locs.size == 0 or self.axis is None:
                return locs
            lo, hi = sorted(self.axis.get_view_interval())
            transform = self.axis.get_transform()
            with np.errstate(all="ignore"):
                a, b = sorted(np.ravel(transform.transform(np.array([lo, hi], dtype=float))))
                t = np.ravel(transform.transform(locs))
            tol = 1e-9 * (b - a)
            if not (np.isfinite(a) and np.isfinite(b)):
                return locs
            return locs[~(t < a - tol) & ~(t > b + tol)]          # NaN (masked) kept, as before

        def tick_values(self, vmin, vmax):
            return self.base.tick_values(vmin, vmax)

        def nonsingular(self, v0, v1):
            return self.base.nonsingular(v0, v1)

        def view_limits(self, vmin, vmax):
            return self.base.view_limits(vmin, vmax)

    class _TextCachingRenderer(RendererAgg):
        """Matplotlib's Agg renderer, laying out each string and rasterising each glyph once.

        The paper run's figures draw about 1500 strings made of about 13 000
        glyphs, of which about 270 strings and 2900 glyph images are distinct
        (the same tick labels, axis labels and legends on every panel and
        figure). Matplotlib lays out every string (``FT2Font._layout``),
        measures it (``set_text``) and renders every glyph (FreeType) at each
        draw; this renderer keeps the results, keyed by everything they depend
        on: the font object, its size and the resolution, the hinting flags, the
        string (and its font features and language) or the glyph, its transform
        and the sub-pixel part of its position (FreeType renders a glyph moved by
        whole pixels into the same bitmap, moved). The drawing calls are
        matplotlib's (``RendererAgg._draw_text_glyphs_and_boxes``,
        ``draw_text``, ``get_text_width_height_descent``) with the cache in
        front; the pixels are the same (``tests/report/test_text_cache.py``).
        """

        def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
            if ismath:
                return self.draw_mathtext(gc, x, y, s, prop, angle)
            font = self._prepare_font(prop)
            features = mtext.get_fontfeatures() if mtext is not None else None
            language = mtext.get_language() if mtext is not None else None
            flags = get_hinting_flag()
            key = (font, prop.get_size_in_points(), self.dpi, flags, s, _hashable(features),
                   _hashable(language))
            items = _cached(_layouts, key, lambda: [
                (item.ft_object, item.glyph_index, item.x, item.y)
                for item in font._layout(s, flags=flags, features=features, language=language)])
            size = prop.get_size_in_points()
            self._draw_text_glyphs_and_boxes(
                gc, x, y, angle, ((ft, size, index, 0, 1, dx, dy) for ft, index, dx, dy in items), [])

        def _get_font_height_metrics(self, prop):
            """Line metrics of ``prop``'s font, as ``Text._get_layout`` computes them, once per font.

            Matplotlib asks a renderer with this method instead of looking up
            the font and reading its ``OS/2`` or ``hhea`` table for every text
            it lays out; the values are those of its own code (matplotlib
            3.10's ``Text._get_layout``), scaled to the font size and this
            renderer's resolution (the figure's in :func:`save`).
            """
            def metrics():
                font = get_font(fontManager._find_fonts_by_props(prop))
                for table_name, gap, ascent, descent in (
                        ("OS/2", "sTypoLineGap", "sTypoAscender", "sTypoDescender"),
                        ("hhea", "lineGap", "ascent", "descent")):
                    table = font.get_sfnt_table(table_name)
                    if table is None:
                        continue
                    scale = (1 / font.get_sfnt_table("head")["unitsPerEm"]
                             * prop.get_size_in_points() * self.dpi / 72)
                    return table[ascent] * scale, -table[descent] * scale, table[gap] * scale
                return None, None, None                     # matplotlib measures "lp" itself

            return _cached(_heights, (_hashable(tuple(vars(prop).values())), self.dpi), metrics)

        def get_text_width_height_descent(self, s, prop, ismath):
            if ismath:
                return super().get_text_width_height_descent(s, prop, ismath)
            font = self._prepare_font(prop)
            flags = get_hinting_flag()

            def measure():
                font.set_text(s, 0.0, flags=flags)
                w, h = font.get_width_height()
                return w / 64.0, h / 64.0, font.get_descent() / 64.0

            return _cached(_extents, (font, prop.get_size_in_points(), self.dpi, flags, s), measure)

        def _draw_text_glyphs_and_boxes(self, gc, x, y, angle, glyphs, boxes):
            cos, sin = math.cos(math.radians(angle)), math.sin(math.radians(angle))
            flags = get_hinting_flag()
            antialiased = bool(gc.get_antialiased())
            height = self.height
            for font, size, glyph_index, slant, extend, dx, dy in glyphs:   # dy is upwards
                matrix = _cached(_rotations, (angle, slant, extend), lambda: (
                    0x10000 * np.array([[cos, -sin], [sin, cos]])
                    @ [[extend, extend * slant], [0, 1]]).round().astype(int))
                px = round(0x40 * (x + dx * cos - dy * sin))
                py = round(0x40 * (height - y + dx * sin + dy * cos))   # FreeType's y is upwards

                def render(font=font, size=size, glyph_index=glyph_index, matrix=matrix, px=px, py=py):
                    font.set_size(size, self.dpi)
                    font._set_transform(matrix, [px & 0x3F, py & 0x3F])
                    bitmap = font._render_glyph(
                        glyph_index, flags, RenderMode.NORMAL if antialiased else RenderMode.MONO)
                    buffer = np.array(bitmap.buffer)
                    if not antialiased:
                        buffer *= 0xff
                    return buffer, bitmap.left, bitmap.top

                buffer, left, top = _cached(
                    _glyphs, (font, size, self.dpi, glyph_index, matrix.tobytes(), px & 0x3F, py & 0x3F,
                              flags, antialiased), render)
                # draw_text_image's y is downwards & the bitmap bottom side.
                self._renderer.draw_text_image(
                    buffer, left + (px >> 6), int(height) - (top + (py >> 6)) + buffer.shape[0], 0, gc)
            if boxes:
                super()._draw_text_glyphs_and_boxes(gc, x, y, angle, (), boxes)


    class _Canvas(FigureCanvasAgg):
        """An Agg canvas drawing with :class:`_TextCachingRenderer`."""

        def get_renderer(self):
            w, h = self.get_width_height(physical=True)
            key = w, h, self.figure.dpi
            if self._lastKey != key:
                self.renderer = _TextCachingRenderer(w, h, self.figure.dpi)
                self._lastKey = key
            return self.renderer

    return {"_PlainLogFormatter": _PlainLogFormatter, "_TicksInView": _TicksInView,
            "_TextCachingRenderer": _TextCachingRenderer, "_Canvas": _Canvas}


def save(fig, path):
    """Write a figure as PNG (:data:`DPI`, RGB, zlib level 1) and close it.

    One draw (no tight bounding box), tick objects only for the ticks drawn
    (:class:`_TicksInView`), no label placement for axes without a label
    (:func:`_unlabelled_axes_not_placed`). The Agg canvas is opaque (a white figure), so
    its alpha channel is dropped: RGB at zlib level 1 encodes in about 65 %
    of the time of RGBA at level 3, in files about 8 % smaller (measured on
    the figures of the paper run, ``benchmarks/figures.py``). A figure with
    transparent pixels keeps its alpha channel.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed afterwards (pyplot releases it).
    path : str, pathlib.Path or binary file object
        Where to write (a file is overwritten).
    """
    _load_matplotlib()
    _ticks_in_view(fig)
    _unlabelled_axes_not_placed(fig)
    fig.set_dpi(DPI)
    canvas = _Canvas(fig)
    with _DRAW_LOCK, _ticks_updated_once():
        canvas.draw()
    image = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw",
                             "RGBA", 0, 1)
    if image.getextrema()[3][0] == 255:
        image = image.convert("RGB")
    info = PngInfo()
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/")
    image.save(path, format="png", compress_level=1, pnginfo=info)
    plt.close(fig)
