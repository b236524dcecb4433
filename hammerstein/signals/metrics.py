"""Performance metrics in the field's terms, per output channel.

Open-loop characterisation (paper Fig. 5): peak-to-peak output H, hysteresis
width h (largest vertical gap between the ascending and the descending
branch of the input-output map) and h/H. Compensated tracking (Fig. 8,
10-13): RMS and maximum absolute error per axis, residual cross-coupling
peak to peak, and the Euclidean tracking error ``||Y_r - Y||`` per sample
(docs/metrics.md: the paper's ε = sgn(θ)√|θ| is not a distance and is not used).

Metrics are computed over the steady-state window that follows
``settle_periods`` periods; loop metrics over the last full period.
Rows are dicts ``{channel, metric, value, unit}``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "steady_window",
    "peak_to_peak",
    "hysteresis_branches",
    "hysteresis_width",
    "euclidean_error",
    "open_loop_metrics",
    "tracking_metrics",
    "raster_line_metrics",
    "unit_label",
]

UNITS = {
    "peak_to_peak": "µm",
    "hysteresis_width": "µm",
    "hysteresis_ratio": "%",
    "rms_error": "µm",
    "max_abs_error": "µm",
    "max_abs_error_percent": "%",      # evaluate: per output, of its own reference's half-span
    "cross_coupling_peak_to_peak": "µm",
    "max_euclidean_error": "µm",
    "rms_euclidean_error": "µm",
    "max_euclidean_error_percent": "%",
    "rms_error_percent": "%",
    "diverged_at_time": "s",
    "model_rms_error": "µm",       # plant vs model, hammerstein.scenario.identification (paper Section 5.3)
    "model_max_abs_error": "µm",
    "line_rms_error": "µm",        # raster references: per scan line (channel "line-<j>")
    "line_max_error": "µm",
}


def unit_label(unit, units=("V", "µm")):
    """A metric's unit (:data:`UNITS`, or ``V``, ``V/s`` of an input) in a model's own units.

    The metrics are computed on the values as they are, in the units of the
    files they come from: a model identified in nm and mV (``identify
    --output-unit nm --input-unit mV``) has its errors in nm and its drive's
    peaks in mV. Only the labels ``µm``, ``V``, ``V/s`` and ``µm/V`` change; ``%``,
    ``s``, ``-`` and the others stay.

    Parameters
    ----------
    unit : str
        The label in the default units (µm, V).
    units : tuple of str
        ``(input unit, output unit)`` (``HammersteinPlant.units``).

    Returns
    -------
    str

    Examples
    --------
    >>> [unit_label(u, ("mV", "nm")) for u in ("µm", "V", "V/s", "µm/V", "%", "s", "")]
    ['nm', 'mV', 'mV/s', 'nm/mV', '%', 's', '']
    """
    unit_in, unit_out = units
    return {"µm": unit_out, "V": unit_in, "V/s": f"{unit_in}/s",
            "µm/V": f"{unit_out}/{unit_in}"}.get(unit, unit)


def steady_window(n_samples, period_samples, settle_periods):
    """Slice of the samples after ``settle_periods`` periods.

    Parameters
    ----------
    n_samples : int
        Record length.
    period_samples : int
        Samples per period of the excitation (> 0).
    settle_periods : float
        Periods discarded at the start (>= 0).

    Returns
    -------
    slice

    Raises
    ------
    ValueError
        If nothing would remain after the settling periods.
    """
    start = int(round(settle_periods * period_samples))
    if start >= n_samples:
        raise ValueError(
            f"settle_periods: {settle_periods:g} periods ({float(start):.6g} samples) leave nothing of "
            f"the {n_samples}-sample record; lengthen the record or settle less")
    return slice(start, n_samples)


def peak_to_peak(y):
    """``max(y) - min(y)`` of a record.

    Parameters
    ----------
    y : array_like, shape (n_samples,)
        Record [µm].

    Returns
    -------
    float
        Peak-to-peak value [µm].
    """
    return float(np.ptp(np.asarray(y, dtype=float)))


def hysteresis_branches(u, y):
    """Ascending and descending branches of one period of a loop.

    Parameters
    ----------
    u : array_like, shape (n,)
        Abscissa over exactly one period (input [V] or reference [µm]).
    y : array_like, shape (n,)
        Output over the same period [µm].

    Returns
    -------
    ascending, descending : tuple of numpy.ndarray, each shape (2, n_branch)
        ``(u, y)`` points of each branch, sorted by increasing u.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    i0 = int(np.argmin(u))
    u, y = np.roll(u, -i0), np.roll(y, -i0)
    imax = int(np.argmax(u))
    asc = np.vstack([u[:imax + 1], y[:imax + 1]])
    desc = np.vstack([np.append(u[imax:], u[0]), np.append(y[imax:], y[0])])
    asc = asc[:, np.argsort(asc[0], kind="stable")]
    desc = desc[:, np.argsort(desc[0], kind="stable")]
    return asc, desc


def hysteresis_width(u, y, period_samples, n_grid=1000):
    """Largest vertical gap between the branches of the last full period.

    Both branches of the ``(u, y)`` map over the last ``period_samples``
    samples are interpolated (linearly) on a common grid of u spanning
    their overlap; h is the largest ``|y_asc - y_desc|`` (paper Section 5.1).

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Abscissa: input voltage [V] or reference [µm].
    y : array_like, shape (n_samples,)
        Output [µm].
    period_samples : int
        Samples per period.
    n_grid : int
        Points of the common grid.

    Returns
    -------
    float
        h [µm]; 0 when u does not move.

    Raises
    ------
    ValueError
        If the record is shorter than one period.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    P = int(period_samples)
    if P < 2 or u.size < P:
        raise ValueError(f"period_samples: the record ({u.size} samples) is shorter than one "
                         f"period ({P} samples)")
    u, y = u[-P:], y[-P:]
    if np.ptp(u) == 0:
        return 0.0
    asc, desc = hysteresis_branches(u, y)
    lo = max(asc[0, 0], desc[0, 0])
    hi = min(asc[0, -1], desc[0, -1])
    grid = np.linspace(lo, hi, n_grid)
    gap = np.interp(grid, asc[0], asc[1]) - np.interp(grid, desc[0], desc[1])
    return float(np.max(np.abs(gap)))


def euclidean_error(reference, outputs):
    """Euclidean tracking error ``||Y_r(t) - Y(t)||`` per sample (docs/metrics.md).

    Parameters
    ----------
    reference, outputs : array_like, shape (p, n_samples)
        [µm].

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        [µm].
    """
    e = np.asarray(reference, dtype=float) - np.asarray(outputs, dtype=float)
    return np.sqrt(np.sum(e * e, axis=0))


def _row(channel, metric, value):
    return {"channel": channel, "metric": metric, "value": float(value), "unit": UNITS[metric]}


def open_loop_metrics(drive, outputs, driven_input, output_names, period_samples, settle_periods=1):
    """Characterisation metrics of an open-loop sine drive (paper Fig. 5).

    For every output: ``peak_to_peak`` H and ``hysteresis_width`` h of the
    ``(u_k, y_l)`` map over the last full period and ``hysteresis_ratio``
    100 h/H; for the outputs other than the direct one (output index ==
    driven input index) also ``cross_coupling_peak_to_peak``.

    Parameters
    ----------
    drive : array_like, shape (m, n_samples)
        Input voltages [V].
    outputs : array_like, shape (p, n_samples)
        Displacements [µm].
    driven_input : int
        Index k of the driven input.
    output_names : sequence of str
        p names.
    period_samples : int
        Samples per drive period.
    settle_periods : float
        Periods discarded before the steady-state window.

    Returns
    -------
    list of dict
        Rows ``{channel, metric, value, unit}``.
    """
    u = np.asarray(drive, dtype=float)[driven_input]
    y = np.asarray(outputs, dtype=float)
    win = steady_window(y.shape[1], period_samples, settle_periods)
    rows = []
    for l, name in enumerate(output_names):
        last = y[l, -int(period_samples):]
        H = peak_to_peak(last)
        h = hysteresis_width(u[win], y[l, win], period_samples)
        rows.append(_row(name, "peak_to_peak", H))
        rows.append(_row(name, "hysteresis_width", h))
        rows.append(_row(name, "hysteresis_ratio", 100.0 * h / H if H > 0 else 0.0))
        if l != driven_input:
            rows.append(_row(name, "cross_coupling_peak_to_peak", peak_to_peak(y[l, win])))
    return rows


def tracking_metrics(reference, outputs, output_names, period_samples, settle_periods=1,
                     scale=None, loop_channel=None):
    """Tracking metrics of a compensated run (paper Fig. 8, 10-13).

    Per output: ``rms_error`` and ``max_abs_error``; for outputs whose
    reference is identically zero, ``cross_coupling_peak_to_peak``; for the
    ``loop_channel`` (a sine reference on one axis), the ``(y_r, y)`` loop's
    ``peak_to_peak``, ``hysteresis_width`` and ``hysteresis_ratio``, and
    ``rms_error_percent`` of the amplitude. For all outputs together (channel
    ``'+'.join(output_names)``): ``max_euclidean_error``,
    ``rms_euclidean_error`` and, with ``scale``, ``max_euclidean_error_percent``.

    Parameters
    ----------
    reference, outputs : array_like, shape (p, n_samples)
        [µm].
    output_names : sequence of str
        p names.
    period_samples : int
        Samples per period of the reference.
    settle_periods : float
        Periods discarded before the steady-state window.
    scale : float, optional
        Radius or amplitude [µm] for the percent metrics.
    loop_channel : int, optional
        Index of the output carrying a single-axis sine reference.

    Returns
    -------
    list of dict
        Rows ``{channel, metric, value, unit}``.
    """
    r = np.asarray(reference, dtype=float)
    y = np.asarray(outputs, dtype=float)
    win = steady_window(y.shape[1], period_samples, settle_periods)
    e = r[:, win] - y[:, win]
    rows = []
    for l, name in enumerate(output_names):
        rows.append(_row(name, "rms_error", np.sqrt(np.mean(e[l] ** 2))))
        rows.append(_row(name, "max_abs_error", np.max(np.abs(e[l]))))
        if not np.any(r[l]):
            rows.append(_row(name, "cross_coupling_peak_to_peak", peak_to_peak(y[l, win])))
    if loop_channel is not None:
        name = output_names[loop_channel]
        H = peak_to_peak(y[loop_channel, -int(period_samples):])
        h = hysteresis_width(r[loop_channel, win], y[loop_channel, win], period_samples)
        rows.append(_row(name, "peak_to_peak", H))
        rows.append(_row(name, "hysteresis_width", h))
        rows.append(_row(name, "hysteresis_ratio", 100.0 * h / H if H > 0 else 0.0))
        if scale:
            rms = np.sqrt(np.mean(e[loop_channel] ** 2))
            rows.append(_row(name, "rms_error_percent", 100.0 * rms / scale))
    ee = euclidean_error(r[:, win], y[:, win])
    allch = "+".join(output_names)
    rows.append(_row(allch, "max_euclidean_error", ee.max()))
    rows.append(_row(allch, "rms_euclidean_error", np.sqrt(np.mean(ee ** 2))))
    if scale:
        rows.append(_row(allch, "max_euclidean_error_percent", 100.0 * ee.max() / scale))
    return rows


def raster_line_metrics(reference, outputs, line_index):
    """Euclidean tracking error per scan line of a raster reference.

    Parameters
    ----------
    reference, outputs : array_like, shape (p, n_samples)
        [µm].
    line_index : array_like of int, shape (n_samples,)
        Scan line (0-based) of each sample
        (:func:`hammerstein.signals.references.raster_line_index`); every
        line is measured whole (trace and retrace, the first one with the
        start-up transient: no settling window).

    Returns
    -------
    list of dict
        Per line, channel ``line-<j>`` (1-based, zero-padded):
        ``line_rms_error`` and ``line_max_error`` of ``||Y_r - Y||`` [µm].
    """
    ee = euclidean_error(reference, outputs)
    line = np.asarray(line_index, dtype=int)
    lines = np.unique(line)
    width = len(str(int(lines.max()) + 1)) if lines.size else 1
    rows = []
    for j in lines:
        e = ee[line == j]
        ch = f"line-{int(j) + 1:0{width}d}"
        rows.append(_row(ch, "line_rms_error", np.sqrt(np.mean(e ** 2))))
        rows.append(_row(ch, "line_max_error", np.max(e)))
    return rows
