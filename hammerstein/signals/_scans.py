"""Triangles, AFM-style rasters and trajectory files (behind :mod:`hammerstein.signals.references`).

The references people scan with: :func:`triangle` (and :func:`triangle_drive`),
:func:`raster` (trace and retrace, a slow axis that steps or ramps, optional
rounded turn-arounds) and :func:`from_file` (a trajectory read from a CSV
file, bounded). Same conventions as :mod:`hammerstein.signals.references`.
"""

from __future__ import annotations

from __future__ import annotations


import numpy as np

from hammerstein.io.datafiles import numeric_column, signal_table
from hammerstein.core.files import FileLimitError, check_regular, confined_path, escape
from hammerstein.core.numbers import check_samples
from hammerstein.exceptions import SignalError
from hammerstein.signals._periodic import (MAX_FILE_BYTES, _at_center, _check_frequency, _finite,
                                           _positive, _sine_on, time_vector)


# -- triangles, rasters and trajectory files --------------------------------------------
def triangle_wave(cycles):
    """Unit symmetric triangle with the phase convention of the sine.

    ``tri(c) = 1 - 4 |((c + 1/4) mod 1) - 1/2|``: 0 at c = 0 rising, +1 at
    c = 1/4, 0 at 1/2, -1 at 3/4; slope ±4 per cycle.

    Parameters
    ----------
    cycles : array_like
        Phase in cycles (``f t + phase / 360``).

    Returns
    -------
    numpy.ndarray
        Same shape, in [-1, 1].

    Examples
    --------
    >>> triangle_wave([0.0, 0.25, 0.5, 0.75]).tolist()
    [0.0, 1.0, 0.0, -1.0]
    """
    c = np.mod(np.asarray(cycles, dtype=float) + 0.25, 1.0)
    return 1.0 - 4.0 * np.abs(c - 0.5)


def triangle(sampling_period, outputs, output, amplitude, frequency, phase=0.0, offset=0.0,
             periods=None, duration=None):
    """Symmetric triangle reference on one output, zero on the others.

    ``y_r(t) = offset + amplitude tri(f t + phase / 360)``
    (:func:`triangle_wave`): the sine's phase convention (0 at t = 0,
    rising), peaks ``offset ± amplitude``, slope ``±4 amplitude f`` [µm/s].

    Parameters
    ----------
    sampling_period : float
        T [s].
    outputs : sequence of str
        Names of the p outputs.
    output : str
        The output that receives the triangle.
    amplitude : float
        [µm], > 0.
    frequency : float
        [Hz]; at least 8 samples per period.
    phase : float
        [deg].
    offset : float
        [µm].
    periods, duration : float
        Length as a number of periods or in seconds (exactly one).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    reference : numpy.ndarray, shape (p, n_samples)
        [µm].

    Raises
    ------
    SignalError
        Naming the field that is out of range.

    Examples
    --------
    >>> from hammerstein import triangle
    >>> t, r = triangle(1e-3, ["x", "y"], "x", 10.0, 10.0, periods=1)
    >>> float(r[0].max()), float(r[0][25]), float(r[1].max())
    (10.0, 10.0, 0.0)
    """
    return _sine_on(sampling_period, outputs, output, amplitude, frequency, phase, offset,
                    periods, duration, "output", "µm", wave=triangle_wave)


def triangle_drive(sampling_period, inputs, input, amplitude, frequency, phase=0.0, offset=0.0,
                   periods=None, duration=None):
    """Open-loop symmetric triangle voltage on one input, zero on the others.

    ``u_k(t) = offset + amplitude tri(f t + phase / 360)`` (:func:`triangle`).

    Parameters
    ----------
    sampling_period : float
        T [s].
    inputs : sequence of str
        Names of the m inputs.
    input : str
        The driven input.
    amplitude : float
        [V], > 0.
    frequency : float
        [Hz]; at least 8 samples per period.
    phase : float
        [deg].
    offset : float
        [V].
    periods, duration : float
        Length as a number of periods or in seconds (exactly one).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    drive : numpy.ndarray, shape (m, n_samples)
        Input voltages [V].

    Raises
    ------
    SignalError
    """
    return _sine_on(sampling_period, inputs, input, amplitude, frequency, phase, offset,
                    periods, duration, "input", "V", wave=triangle_wave)


def _rounded_abs(tau, w):
    """``|tau|`` with the corner rounded over ``|tau| < w`` (raised-cosine blend).

    ``E|tau - u|`` for u of the raised-cosine density ``(1 + cos(pi u / w)) /
    (2 w)`` on [-w, w]: C^2 where it meets ``|tau|`` (value and slope agree
    at ``|tau| = w``), equal to ``|tau|`` outside.
    """
    tau = np.asarray(tau, dtype=float)
    if w <= 0:
        return np.abs(tau)
    inner = tau ** 2 / (2 * w) - (w / np.pi ** 2) * np.cos(np.pi * tau / w) + w / 2 - w / np.pi ** 2
    return np.where(np.abs(tau) < w, inner, np.abs(tau))


def _rounded_step(tau, w):
    """Heaviside step at 0 blended over ``|tau| < w`` by the raised-cosine CDF."""
    tau = np.asarray(tau, dtype=float)
    if w <= 0:
        return (tau >= 0).astype(float)
    inner = (tau + w) / (2 * w) + np.sin(np.pi * tau / w) / (2 * np.pi)
    return np.where(tau <= -w, 0.0, np.where(tau >= w, 1.0, inner))


def _unit_scan(cycles, smoothing):
    """Fast-axis scan in [0, 1]: 0 at integer cycles, 1 at half cycles, turns rounded.

    With ``smoothing`` s > 0 each turning point is rounded over s of a
    period (:func:`_rounded_abs`), then the wave is rescaled so that it still
    spans exactly [0, 1]; the linear parts stay linear.
    """
    c = np.asarray(cycles, dtype=float)
    w = smoothing / 2.0
    t0 = np.mod(c + 0.5, 1.0) - 0.5          # signed distance to the nearest 0-turn [cycles]
    t1 = np.mod(c, 1.0) - 0.5                # signed distance to the nearest 1-turn
    low = np.abs(t0) <= np.abs(t1)
    v = np.where(low, 2 * _rounded_abs(t0, w), 1 - 2 * _rounded_abs(t1, w))
    lo = 2 * float(_rounded_abs(0.0, w))
    return (v - lo) / (1 - 2 * lo)


def raster(sampling_period, size, lines, frequency, slow="step", smoothing=0.0, center=None):
    """AFM-style raster scan: triangle on the fast axis, one line per fast period.

    The scan starts at rest at the origin and covers ``[0, W] x [0, H]``
    (``size = [W, H]``). The fast axis goes 0 -> W (trace, first half of a
    period) and back to 0 (retrace), ``lines`` times at ``frequency``; the
    slow axis moves by one line per fast period, at the fast axis' return
    to 0:

    - ``slow = "step"``: line j (0-based) is held at ``j H / (lines - 1)``,
      a step at each return;
    - ``slow = "ramp"``: ``y = H f t / lines``, rising continuously to H at
      the end of the last line.

    ``smoothing`` s in [0, 0.5] rounds every turning point of the fast axis
    over a fraction s of the period (a raised-cosine blend of the velocity
    reversal; the wave is rescaled to still span exactly [0, W], the
    linear parts keep a constant speed) and spreads each slow-axis step
    over the same window (raised-cosine). ``s = 0``: sharp turns and steps.

    Parameters
    ----------
    sampling_period : float
        T [s].
    size : sequence of 2 floats
        ``W, H``: fast- and slow-axis extent [µm], > 0.
    lines : int
        Number of scan lines (>= 2).
    frequency : float
        Fast-axis (line) frequency [Hz]; at least 8 samples per period.
    slow : {'step', 'ramp'}
    smoothing : float
        Fraction of a period over which turns are rounded, 0 <= s <= 0.5.
    center : sequence of 2 floats, optional
        Centre of the scanned rectangle ``(c_fast, c_slow)`` [µm]: the scan
        covers ``[c_fast - W/2, c_fast + W/2] x [c_slow - H/2, c_slow + H/2]``
        and starts at its corner ``(c_fast - W/2, c_slow - H/2)``. By default
        ``[0, W] x [0, H]`` from the origin.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        ``lines / frequency`` seconds [s].
    reference : numpy.ndarray, shape (2, n_samples)
        ``(fast, slow)`` [µm].

    Raises
    ------
    SignalError
        Naming the field that is out of range.

    Examples
    --------
    >>> from hammerstein import raster
    >>> t, r = raster(1e-4, [20.0, 10.0], 5, 100.0)
    >>> r.shape, float(r[0].max()), sorted(set(r[1].round(6).tolist()))
    ((2, 500), 20.0, [0.0, 2.5, 5.0, 7.5, 10.0])
    """
    if np.isscalar(size) or len(size) != 2:
        raise SignalError(f"size: expected two extents [fast, slow] [µm], found {size!r}")
    W = _positive(size[0], "size[0]", "µm")
    H = _positive(size[1], "size[1]", "µm")
    if isinstance(lines, bool) or not isinstance(lines, (int, np.integer)) or lines < 2:
        raise SignalError(f"lines: expected an integer >= 2, found {lines!r}")
    f = _check_frequency(frequency, sampling_period)
    if slow not in ("step", "ramp"):
        raise SignalError(f"slow: expected 'step' or 'ramp', found {slow!r}")
    s = _finite(smoothing, "smoothing", "-")
    if not 0 <= s <= 0.5:
        raise SignalError(f"smoothing: expected a fraction of the period in [0, 0.5], found {smoothing!r}")
    t = time_vector(sampling_period, 1.0 / f, periods=int(lines))
    c = f * t
    fast = W * _unit_scan(c, s)
    if slow == "ramp":
        slow_axis = H * c / lines
    else:
        dy = H / (lines - 1)
        steps = sum(_rounded_step(c - j, s / 2.0) for j in range(1, int(lines)))
        slow_axis = dy * np.asarray(steps, dtype=float)
    corner = None if center is None else _at_center(np.array([[-0.5 * W], [-0.5 * H]]), center)[:, 0]
    return t, _at_center(np.vstack([fast, slow_axis]), corner)


def raster_line_index(time, frequency):
    """Scan line of each sample of a raster (0-based): ``floor(f t)``.

    Parameters
    ----------
    time : array_like, shape (n_samples,)
        [s].
    frequency : float
        Fast-axis frequency [Hz].

    Returns
    -------
    numpy.ndarray of int, shape (n_samples,)
    """
    return np.floor(np.asarray(time, dtype=float) * float(frequency) + 1e-9).astype(int)


def _read_bounded(path, limit):
    try:
        check_regular(path, "CSV file")  # a FIFO or device is refused before it is opened
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except FileNotFoundError:
        raise SignalError(f"file: {path} not found") from None
    except IsADirectoryError:
        raise SignalError(f"file: {path} is a directory, expected a CSV file") from None
    except FileLimitError as exc:
        raise SignalError(f"file: {exc}") from None
    except OSError as exc:
        raise SignalError(f"file: {path} cannot be read ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise SignalError(f"file: {path} is larger than {limit / 2 ** 20:g} MB; "
                          f"give a shorter trajectory")
    return data


def from_file(sampling_period, outputs, file, columns, time="time", duration=None,
              base_dir=None, max_bytes=None):
    """Reference read from a CSV file and resampled to the sampling period.

    The file has a header row; ``time`` names its time column [s] (strictly
    increasing) and ``columns`` maps outputs to columns [µm]. The samples
    ``t_k = k T`` from 0 to the last time of the file (or to ``duration``)
    are interpolated linearly (:func:`numpy.interp`); outputs not in
    ``columns`` get 0. A file that starts after t = 0 or ends before
    ``duration`` would need extrapolation and is refused.

    Parameters
    ----------
    sampling_period : float
        T [s] of the plant.
    outputs : sequence of str
        Names of the p outputs.
    file : str or pathlib.Path
        CSV file, relative to ``base_dir``.
    columns : dict of str to str
        ``{output: column}``.
    time : str
        Name of the time column.
    duration : float, optional
        Record length [s] (default: up to the file's last time).
    base_dir : str or pathlib.Path, optional
        Directory of relative file names (the scenario's).
    max_bytes : int, optional
        Largest file read (default :data:`MAX_FILE_BYTES`).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    reference : numpy.ndarray, shape (p, n_samples)
        [µm].

    Raises
    ------
    SignalError
        Naming the key: ``file`` (missing, too large, not CSV), ``time``
        (missing column, not increasing, starting after 0), ``columns``
        (unknown output, missing column, non-numeric values), ``duration``
        (beyond the file's last time).
    """
    T = _positive(sampling_period, "sampling_period", "s")
    path = confined_path(str(file), base_dir, lambda m: SignalError(f"file: {m}"))
    if not isinstance(columns, dict) or not columns:
        raise SignalError(f"columns: expected a table {{ <output> = \"<column>\" }}, found {columns!r}")
    names = [str(n) for n in outputs]
    for out in columns:
        if out not in names:
            raise SignalError(f"columns.{out}: expected one of the plant's outputs {names}")
    data = _read_bounded(path, MAX_FILE_BYTES if max_bytes is None else int(max_bytes))
    table = signal_table(data, path, "", lambda m: SignalError(f"file: {m}"))
    header = list(table.frame.columns)

    def numeric(col, key):
        if col not in header:
            raise SignalError(f"{key}: column {escape(repr(col), 60)} not in {escape(path)} "
                              f"(columns: {', '.join(escape(h, 60) for h in header[:20])})")
        return numeric_column(table, col)

    tf = numeric(time, "time")
    if tf.size < 2 or np.any(np.diff(tf) <= 0):
        raise SignalError(f"time: column {time!r} of {path} must hold at least two strictly "
                          f"increasing times [s]")
    if tf[0] > 1e-12 * max(1.0, abs(tf[-1])):
        raise SignalError(f"time: {path} starts at {tf[0]:g} s; the reference is sampled from "
                          f"t = 0 and would need extrapolation before {tf[0]:g} s (start the "
                          f"time column at 0)")
    end = tf[-1]
    if duration is not None:
        d = _positive(duration, "duration", "s")
        if d > end + 1e-9 * max(1.0, end):
            raise SignalError(f"duration: {d:g} s is beyond the last time {end:g} s of {path}; "
                              f"the reference would need extrapolation")
        end = d
    n = check_samples(np.floor(end / T + 1e-9) + 1, f"file: {escape(path)}: {end:g} s",
                      SignalError, T)
    t = np.arange(n) * T
    ref = np.zeros((len(names), n))
    for out, col in columns.items():
        ref[names.index(out)] = np.interp(t, tf, numeric(str(col), f"columns.{out}"))
    return t, ref
