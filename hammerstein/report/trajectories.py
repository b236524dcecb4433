"""Trajectory, divergence, overlay and raster error-map figures (matplotlib, Agg backend).

* :func:`trajectory_figure`: XY plot with the reference, time plots of the
  displacements and of the input voltages, tracking errors scaled on the
  settled part (the paper's Fig. 10-13).
* :func:`xy_overlay`: several XY trajectories in one plot (Fig. 10-a).
* :func:`divergence_figure`: the compensator output up to a divergence.
* :func:`raster_error_map`: a raster's tracking error as an image over the
  scanned area, line by line.

They are built on the layout helpers of :mod:`hammerstein.report.figures`
(fixed layouts, decimation, titles) and saved with its :func:`save`.
"""

from __future__ import annotations


import numpy as np

from hammerstein.report.figures import (_settled_ylim, _title_height, decimate, decimate_path,
                                        fixed_layout, legend_on_top, plt, suptitle)


def _mark_transient(ax, t_end, t_fade=0.0):
    """Shade the start-up transient [0, t_end] (time axis in ms), the fade-in [0, t_fade] darker."""
    t0 = ax.get_xlim()[0]
    if t_fade > t0:
        ax.axvspan(t0, min(t_fade, t_end), color="0.7", alpha=0.6, zorder=0, linewidth=0)
    if t_end > max(t_fade, t0):
        ax.axvspan(max(t_fade, t0), t_end, color="0.85", alpha=0.6, zorder=0, linewidth=0)


def _peak_off_scale(ax, values):
    """Largest |value| of ``values`` when some of them lie outside the y-limits."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    lo, hi = ax.get_ylim()
    return float(np.max(np.abs(v))) if v.size and (v.min() < lo or v.max() > hi) else None


def _error_unit(errors):
    """Scale and unit of an error axis [µm], so that its tick labels stay short.

    Below 0.1 µm the ticks in µm read 0.0004 and the like, wider than the
    space the fixed layout leaves between the panels: nm down to 1e-4 µm,
    below that (round-off) a power of ten of µm written in the unit.
    """
    e = np.asarray(errors, dtype=float)
    e = e[np.isfinite(e)]
    peak = float(np.max(np.abs(e))) if e.size else 0.0
    if peak >= 0.1 or peak == 0.0:
        return 1.0, "µm"
    if peak >= 1e-4:
        return 1e3, "nm"
    k = int(np.floor(np.log10(peak)))
    return 10.0 ** -k, f"1e{k} µm"


def _length(value, unit="µm"):
    """A length given in ``unit``; one in µm is written in nm below 0.1 µm."""
    if unit != "µm":
        return f"{value:.3g} {unit}"
    return f"{value:.3g} µm" if abs(value) >= 0.1 else f"{value * 1e3:.3g} nm"


def trajectory_figure(time, reference, outputs, names, title, settle_time=0.0,
                      inputs=None, input_names=None, fade_time=0.0, units=("V", "µm")):
    """XY plot, time plots (displacements, input voltages) and tracking errors.

    Layout: (a) the XY plot of the reference (a wide grey band, which
    reads where many periods overlap) and the output (a thin line) after
    settling, over the first two outputs (one output: the output against
    its reference, the diagonal dashed); (b) every output's
    displacement against time; (c) every output's tracking error y_r - y
    and (e) the Euclidean error ||Y_r - Y|| over all outputs, both scaled
    on the settled part (the start-up transient is shaded, the fade-in
    darker than the settling after it, and its peak is printed when it is
    off scale) and in nm when the settled errors stay
    below 0.1 µm; (d) the input voltages when ``inputs``
    is given. Every axis is labelled in ``units`` (a model identified in nm
    and mV); errors in another output unit than µm are not rescaled.

    Parameters
    ----------
    time : array_like, shape (n,)
        [s].
    reference, outputs : array_like, shape (p, n)
        ``(x_r[, y_r, z_r ...])`` and ``(x[, y, z ...])`` [µm], p >= 1
        (outputs may hold NaN after a divergence); the reference the
        output tracked (faded in from rest where the drive fades in).
    names : sequence of p str
        Output names.
    title : str
    settle_time : float
        End of the settling transient [s], excluded from the metrics.
    inputs : array_like, shape (m, n), optional
        Input voltages [V] (the compensator output).
    input_names : sequence of m str, optional
    fade_time : float
        End of the reference's fade-in from rest [s] (0: none), at most
        ``settle_time``: shaded darker than the settling after it.
    units : tuple of str
        ``(input unit, output unit)`` of ``inputs`` and of ``reference`` and
        ``outputs`` (``HammersteinPlant.units``; a drive file's,
        :func:`hammerstein.compensation.drive_files.drive_units`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    unit_in, unit_out = units
    t = np.asarray(time, dtype=float) * 1e3
    r = np.asarray(reference, dtype=float)
    y = np.asarray(outputs, dtype=float)
    e = r - y
    eu = np.sqrt(np.sum(e * e, axis=0))             # over all p outputs, as the metrics
    names = list(names)
    steady = t >= settle_time * 1e3
    transient = settle_time > 0 and steady.any() and not steady.all()
    W = 15.0
    top = _title_height(title, W) + 0.45
    H = top + 2 * 2.7 + 0.9 + 0.55
    fig = plt.figure(figsize=(W, H))
    gs = fig.add_gridspec(2, 3, width_ratios=[1.15, 1.4, 1.4])
    # room for the XY panel's tick labels: '-2000' of a circle in nm is two digits wider than
    # '-20' in µm, and its y label was cut at the figure's edge
    side = np.abs(np.concatenate([r[-1], y[-1]])) if r.size else np.zeros(1)
    wide = max(0, len(f"{float(np.max(side[np.isfinite(side)], initial=0.0)):.0f}") - 2)
    fixed_layout(fig, 2, 3, left=0.7 + 0.07 * wide, right=0.2, bottom=0.55, top=top, wspace=0.8,
                 hspace=0.9)
    ax = fig.add_subplot(gs[:, 0])
    if len(names) >= 2:        # the reference as a band: dashes of overlapping periods fill in
        ax.plot(*decimate_path(r[0, steady], r[1, steady]), "-", color="0.75", linewidth=5.0,
                solid_capstyle="round", solid_joinstyle="round", label="reference")
        ax.plot(*decimate_path(y[0, steady], y[1, steady]), "-", color="C0", linewidth=1.0,
                label="output")
        ax.set_xlabel(f"{names[0]} [{unit_out}]")
        ax.set_ylabel(f"{names[1]} [{unit_out}]")
        ax.set_title("(a) spatial domain after settling\n(grey band: reference, blue: output)",
                     fontsize=10, y=1.0)
    else:                          # one axis: the output against its reference
        span = [float(np.nanmin(r[0, steady])), float(np.nanmax(r[0, steady]))]
        ax.plot(span, span, "--", color="0.35", linewidth=1.2)
        ax.plot(*decimate_path(r[0, steady], y[0, steady]), "-", color="C0", linewidth=1.0)
        ax.set_xlabel(f"{names[0]}_r [{unit_out}]")
        ax.set_ylabel(f"{names[0]} [{unit_out}]")
        ax.set_title("(a) output against reference after settling\n(dashed: y = reference)",
                     fontsize=10, y=1.0)
    _equal_aspect(ax)
    ax.grid(True, alpha=0.3)

    axt = fig.add_subplot(gs[0, 1])
    for i, n in enumerate(names):
        axt.plot(*decimate(t, r[i]), "--", color=f"C{i}", linewidth=1.0, label=f"{n}_r")
        axt.plot(*decimate(t, y[i]), "-", color=f"C{i}", linewidth=1.0, alpha=0.8, label=n)
    axt.set_ylabel(f"displacement [{unit_out}]")
    axt.set_title("(b) time domain", fontsize=10, y=1.0)
    axu = fig.add_subplot(gs[1, 1], sharex=axt)
    if inputs is not None:
        u = np.asarray(inputs, dtype=float)
        un = list(input_names) if input_names is not None else [f"u{k}" for k in range(len(u))]
        for k, n in enumerate(un):
            axu.plot(*decimate(t, u[k]), "-", color=f"C{k + 2}", linewidth=1.0, label=f"{n}")
        axu.set_title("(d) input voltages (compensator output)", fontsize=10, y=1.0)
    else:
        axu.text(0.5, 0.5, "no input voltages given", ha="center", va="center",
                 transform=axu.transAxes, color="0.5")
        axu.set_title("(d) input voltages", fontsize=10, y=1.0)
    axu.set_ylabel(f"voltage [{unit_in}]")
    axu.set_xlabel("time [ms]")

    # in µm, rescaled to nm when small; in a model's own unit as it is
    scale, unit = _error_unit(e[:, steady] if steady.any() else e) if unit_out == "µm" \
        else (1.0, unit_out)
    e, eu = e * scale, eu * scale
    axe = fig.add_subplot(gs[0, 2], sharex=axt)
    for i, n in enumerate(names):
        axe.plot(*decimate(t, e[i]), "-", color=f"C{i}", linewidth=1.0, label=f"{n}_r - {n}")
    axe.set_ylabel(f"tracking error [{unit}]")
    axn = fig.add_subplot(gs[1, 2], sharex=axt)
    axn.plot(*decimate(t, eu), "-", color="k", linewidth=0.9)
    axn.set_ylabel(f"||Y_r - Y|| over {', '.join(names)} [{unit}]")
    axn.set_xlabel("time [ms]")
    for a in (axt, axu, axe, axn):
        a.grid(True, alpha=0.3)
        a.set_xlim(t[0], t[-1])
    for a in (axt, axe):       # x labels under (d) and (e) only; not get_xticklabels (ticks now)
        a.tick_params(labelbottom=False)
    notes = {axe: "", axn: ""}
    if transient:
        _settled_ylim(axe, [e[:, steady]])
        _settled_ylim(axn, [np.r_[0.0, eu[steady]]])
        for a, vals in ((axe, e[:, ~steady]), (axn, eu[~steady])):
            peak = _peak_off_scale(a, vals)
            notes[a] = "\nscaled after settling" + (
                "" if peak is None else f"; start-up (shaded) peaks at {_length(peak / scale, unit_out)}")
        for a in (axt, axu, axe, axn):
            _mark_transient(a, settle_time * 1e3, min(fade_time, settle_time) * 1e3)
    if transient and fade_time > 0:
        axt.set_title("(b) time domain\nshaded: fade-in from rest (dark), settling (light)",
                      fontsize=10, y=1.0)
    axe.set_title("(c) tracking error per axis" + notes[axe], fontsize=10, y=1.0)
    axn.set_title("(e) Euclidean error" + notes[axn], fontsize=10, y=1.0)
    legend_on_top(axt, 2 * len(names), loc="upper right")
    if inputs is not None:
        legend_on_top(axu, len(un), loc="upper right")
    legend_on_top(axe, len(names), loc="upper right")
    suptitle(fig, title)
    return fig


def divergence_figure(inputs, names, sample, reason, title):
    """Input voltages of a diverging compensator, |U| on a log scale.

    Parameters
    ----------
    inputs : array_like, shape (m, n)
        Compensator output [V] (valid before ``sample``); drawn up to and
        including ``sample`` where finite.
    names : sequence of str
        Input names.
    sample : int
        First sample where the divergence was detected (marked by a dotted
        line).
    reason : str
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    # up to and including the detected sample, whose value the reason cites; the runner
    # records no output from that sample on (NaN): the title says so then
    u = np.asarray(inputs, dtype=float)[:, :sample + 1]
    k = np.arange(u.shape[1])
    W = 8.0
    drawn = sample < u.shape[1] and np.isfinite(u[:, sample]).all()
    full = f"{title}; detected at sample {sample}{'' if drawn else ' (not recorded)'}: {reason}"
    top = _title_height(full, W, fontsize=10) + 0.1
    fig, ax = plt.subplots(figsize=(W, top + 3.6 + 0.6))
    fixed_layout(fig, left=0.85, right=0.25, bottom=0.6, top=top)
    for i, n in enumerate(names):
        mag = np.abs(u[i])
        ax.semilogy(k, np.where((mag > 0) & np.isfinite(mag), mag, np.nan), "o-",
                    label=f"|{n}| [V]", markersize=4)
    ax.axvline(sample, color="r", linestyle=":", label=f"divergence detected (sample {sample})")
    ax.axhline(10.0, color="0.5", linestyle="--", linewidth=0.8, label="10 V drive range")
    ax.set_xlabel("sample")
    ax.set_ylabel("|compensator output| [V]")
    ax.grid(True, which="major", alpha=0.3)
    legend_on_top(ax, len(names) + 2, ncol=2)
    suptitle(fig, full, fontsize=10)
    return fig


#: an XY panel shrinks its box to the data's aspect (equal scales) when the data's height over
#: width lies within these bounds; beyond, the data limits grow instead (a line scan would leave
#: a sliver of a box)
BOX_ASPECT_RANGE = (0.4, 2.5)


def _equal_aspect(ax):
    """Equal scales on an XY panel, without a box mostly empty around a square-ish trajectory.

    ``adjustable="datalim"`` kept the box and stretched the limits: a 40 x 30 µm raster in a
    tall box showed y from -22 to 55 µm. The box follows the data's aspect instead, within
    :data:`BOX_ASPECT_RANGE`.
    """
    ax.relim()
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    ratio = (y1 - y0) / (x1 - x0) if x1 > x0 else 0.0
    lo, hi = BOX_ASPECT_RANGE
    ax.set_aspect("equal", adjustable="box" if lo <= ratio <= hi else "datalim")


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
        The legend is outside the axes, on the right.
    """
    W, legend_w = 9.0, 2.4
    top = _title_height(title, W) + 0.1
    fig, ax = plt.subplots(figsize=(W, top + 6.0 + 0.6))
    fixed_layout(fig, left=0.8, right=legend_w, bottom=0.6, top=top)
    for i, c in enumerate(curves):
        ax.plot(*decimate_path(*c["reference"][:2]), "--", color="0.4", linewidth=1.0,
                label="references" if i == 0 else "_reference")   # one entry for all
        ax.plot(*decimate_path(*c["outputs"][:2]), "-", color=f"C{i}", linewidth=1.1,
                label=c["label"])
    _equal_aspect(ax)
    ax.set_xlabel(f"{names[0]} [µm]")
    ax.set_ylabel(f"{names[1]} [µm]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0)
    suptitle(fig, title)
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
                     n_bins=200, start=0.0):
    """Image-style error map of a raster scan: error against fast-axis position, one row per line.

    One row of panels per error signal (e.g. the fast- and the slow-axis
    tracking error), the trace (fast axis rising) on the left and the
    retrace on the right; each image row is a scan line, its colour the
    error at each fast-axis reference position (linear interpolation onto
    ``n_bins`` positions). Colours are symmetric about 0 (red: output below
    the reference), shared by the trace and retrace of a signal, and scaled
    on the lines after the first (which holds the fade-in's start-up) when
    there are three or more: the first saturates, and the colour bar says so.

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
        Fast-axis scan size W [µm] (the abscissa spans [start, start + W]).
    fast_name : str
        Fast-axis output name.
    title : str
    n_bins : int
        Positions per image row.
    start : float
        Where the fast axis starts [µm] (0; ``center - W / 2`` for a centred raster).

    Returns
    -------
    matplotlib.figure.Figure
    """
    x = np.asarray(fast_reference, dtype=float)
    e = np.atleast_2d(np.asarray(errors, dtype=float))
    line = np.asarray(line_index, dtype=int)
    trace = np.asarray(trace, dtype=bool)
    n_lines = int(line.max()) + 1
    grid = np.linspace(float(start), float(start) + float(extent), int(n_bins))
    k = e.shape[0]
    W = 11.0
    top = _title_height(title, W) + 0.35                # the title wrapped to the width
    H = top + 2.6 * k + 0.7
    fig, axes = plt.subplots(k, 2, figsize=(W, H), squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.9, bottom=0.7 / H, top=1 - top / H, wspace=0.12,
                        hspace=0.45)
    for i in range(k):
        imgs = [_line_image(x, e[i], line, trace, n_lines, grid),
                _line_image(x, e[i], line, ~trace, n_lines, grid)]
        finite = np.abs(np.concatenate([m[np.isfinite(m)] for m in imgs]))
        # from the second line on when there are three or more: the first holds the fade-in's
        # start-up (16 µm against +-0.1 µm on the others), which would leave every other line
        # white; its colours saturate, and the colour bar says so
        later = np.abs(np.concatenate([m[1:][np.isfinite(m[1:])] for m in imgs])) \
            if n_lines >= 3 else finite
        lim = float(later.max()) if later.size else (float(finite.max()) if finite.size else 1.0)
        lim = lim if lim > 0 else 1.0
        saturated = bool(finite.size and finite.max() > lim * (1 + 1e-9))
        for d, (img, name) in enumerate(zip(imgs, ("trace", "retrace"))):
            ax = axes[i][d]
            im = ax.imshow(img, aspect="auto", cmap="RdBu_r", vmin=-lim, vmax=lim,
                           extent=(float(start), float(start) + float(extent), n_lines + 0.5, 0.5),
                           interpolation="nearest")
            ax.set_title(f"({chr(97 + 2 * i + d)}) {labels[i]}, {name}", fontsize=10, y=1.0)
            ax.set_xlabel(f"{fast_name}_r (fast axis) [µm]")
            if d == 0:
                ax.set_ylabel("scan line")
        fig.colorbar(im, ax=list(axes[i]), fraction=0.03, pad=0.02,
                     label="error [µm]" + (f", capped (max {float(finite.max()):.3g})"
                                           if saturated else ""))
    suptitle(fig, title)
    return fig
