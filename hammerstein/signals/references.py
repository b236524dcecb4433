"""Reference trajectories and open-loop voltage drives.

Every function returns ``(time, signal)`` sampled at the sampling period T:
``time`` has shape (n_samples,) [s] and ``signal`` has shape
(n_channels, n_samples). References are displacements [µm] for the
compensator; drives are voltages [V] applied open loop for characterisation.
The sine, circle, spiral and Lissajous trajectories are those of the paper,
Section 5 (Fig. 5, 8, 10-13); :func:`triangle` (and :func:`triangle_drive`),
:func:`raster` (AFM-style scans) and :func:`from_file` (a trajectory read
from a CSV file) are the references people scan with.
"""

from __future__ import annotations

from fractions import Fraction
from dataclasses import dataclass
from typing import Callable

import numpy as np

from hammerstein.io.datafiles import numeric_column, signal_table
from hammerstein.core.files import FileLimitError, check_regular, confined_path, escape
from hammerstein.signals.metrics import raster_line_metrics
from hammerstein.core.numbers import check_samples
from hammerstein.core.schema import Field, Invalid, choice, integer, is_number, name_list, number, string
from hammerstein.exceptions import SignalError

__all__ = [
    "SignalError",
    "MIN_SAMPLES_PER_PERIOD",
    "time_vector",
    "sine",
    "sine_drive",
    "triangle_wave",
    "triangle",
    "triangle_drive",
    "raster",
    "raster_line_index",
    "from_file",
    "MAX_FILE_BYTES",
    "circle",
    "spiral",
    "lissajous",
    "lissajous_period",
    "ReferenceKind",
    "REFERENCE_KINDS",
    "DRIVE_KINDS",
    "words_number",
]

#: Fewest samples per period accepted for any periodic signal.
MIN_SAMPLES_PER_PERIOD = 8

#: Default most samples in one record (80 MB per signal row; 500 s at T = 50 µs);
#: ``HAMMERSTEIN_MAX_RECORD_SAMPLES`` changes the limit checked
#: (:func:`hammerstein.core.numbers.check_samples`).
MAX_SAMPLES = 10_000_000

#: Largest trajectory file :func:`from_file` reads [bytes].
MAX_FILE_BYTES = 64 * 1024 * 1024


def _positive(value, name, unit):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value) or value <= 0:
        raise SignalError(f"{name}: expected a positive number [{unit}], found {value!r}")
    return float(value)


def _finite(value, name, unit):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value):
        raise SignalError(f"{name}: expected a finite number [{unit}], found {value!r}")
    return float(value)


def _check_frequency(frequency, sampling_period, name="frequency"):
    sampling_period = _positive(sampling_period, "sampling_period", "s")
    f = _positive(frequency, name, "Hz")
    nyquist = 1.0 / (2.0 * sampling_period)
    if f >= nyquist:
        raise SignalError(f"{name}: {f:g} Hz is at or above the Nyquist frequency "
                          f"{nyquist:g} Hz of the sampling period {sampling_period:g} s")
    if 1.0 / (f * sampling_period) < MIN_SAMPLES_PER_PERIOD:
        raise SignalError(
            f"{name}: {f:g} Hz gives {1.0 / (f * sampling_period):.3g} samples per period; "
            f"expected at least {MIN_SAMPLES_PER_PERIOD} (f <= {1.0 / (MIN_SAMPLES_PER_PERIOD * sampling_period):g} Hz)")
    return f


def time_vector(sampling_period, period=None, periods=None, duration=None):
    """Sample instants ``t_k = k T`` covering a number of periods or a duration.

    Parameters
    ----------
    sampling_period : float
        T [s], > 0.
    period : float, optional
        Base period [s] that ``periods`` counts.
    periods : float, optional
        Number of periods (> 0); give either this or ``duration``.
    duration : float, optional
        Record length [s] (> 0).

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        ``n_samples = round(length / T)``, at least 1 [s].

    Raises
    ------
    SignalError
        If both or neither of ``periods`` and ``duration`` are given, a
        value is not positive, or the record exceeds :data:`MAX_SAMPLES`.
    """
    T = _positive(sampling_period, "sampling_period", "s")
    if (periods is None) == (duration is None):
        raise SignalError("periods/duration: give exactly one of periods or duration")
    if periods is not None:
        length = _positive(periods, "periods", "-") * period
    else:
        length = _positive(duration, "duration", "s")
    check_samples(length / T, "periods" if periods is not None else "duration", SignalError, T)
    n = max(int(round(length / T)), 1)
    return np.arange(n) * T


def _channel_index(names, channel, field):
    names = [str(n) for n in names]
    if channel not in names:
        raise SignalError(f"{field}: expected one of {names}, found {channel!r}")
    return names.index(channel)


def _sine_on(sampling_period, names, channel, amplitude, frequency, phase, offset,
             periods, duration, field, unit, wave=None):
    k = _channel_index(names, channel, field)
    a = _positive(amplitude, "amplitude", unit)
    f = _check_frequency(frequency, sampling_period)
    phi = np.deg2rad(_finite(phase, "phase", "deg"))
    off = _finite(offset, "offset", unit)
    t = time_vector(sampling_period, 1.0 / f, periods, duration)
    sig = np.zeros((len(names), t.size))
    if wave is None:
        sig[k] = off + a * np.sin(2 * np.pi * f * t + phi)
    else:
        sig[k] = off + a * wave(f * t + phi / (2 * np.pi))
    return t, sig


def sine(sampling_period, outputs, output, amplitude, frequency, phase=0.0, offset=0.0,
         periods=None, duration=None):
    """Sine reference on one output, zero on the others (paper Fig. 8).

    ``y_r(t) = offset + amplitude sin(2 pi f t + phase)`` on ``output``.

    Parameters
    ----------
    sampling_period : float
        T [s].
    outputs : sequence of str
        Names of the p outputs (rows of the returned reference).
    output : str
        The output that receives the sine.
    amplitude : float
        [µm], > 0.
    frequency : float
        [Hz]; at least 8 samples per period (below Nyquist).
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
    """
    return _sine_on(sampling_period, outputs, output, amplitude, frequency, phase, offset,
                    periods, duration, "output", "µm")


def sine_drive(sampling_period, inputs, input, amplitude, frequency, phase=0.0, offset=0.0,
               periods=None, duration=None):
    """Open-loop sine voltage on one input, zero on the others (paper Fig. 5).

    ``u_k(t) = offset + amplitude sin(2 pi f t + phase)``.

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
                    periods, duration, "input", "V")


def circle(sampling_period, radius, frequency, phase=0.0, periods=None, duration=None):
    """Circular trajectory (paper Fig. 10).

    ``x_r = R cos(2 pi f t + phase)``, ``y_r = R sin(2 pi f t + phase)``.

    Parameters
    ----------
    sampling_period : float
        T [s].
    radius : float
        R [µm], > 0.
    frequency : float
        [Hz]; at least 8 samples per period.
    phase : float
        [deg].
    periods, duration : float
        Length in turns or seconds (exactly one).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    reference : numpy.ndarray, shape (2, n_samples)
        ``(x_r, y_r)`` [µm].

    Raises
    ------
    SignalError
    """
    R = _positive(radius, "radius", "µm")
    f = _check_frequency(frequency, sampling_period)
    phi = np.deg2rad(_finite(phase, "phase", "deg"))
    t = time_vector(sampling_period, 1.0 / f, periods, duration)
    arg = 2 * np.pi * f * t + phi
    return t, np.vstack([R * np.cos(arg), R * np.sin(arg)])


def spiral(sampling_period, radius, frequency, tau, duration, circle_periods=1.0, phase=0.0):
    """Spiral trajectory (paper Fig. 11): circles, then a decaying radius.

    The radius is R for ``circle_periods`` full turns (``t0 = circle_periods
    / f``), then ``R exp(-(t - t0) / tau)``; the angle is ``2 pi f t + phase``.
    (The paper starts the decay by a manual trigger after a circular run.)

    Parameters
    ----------
    sampling_period : float
        T [s].
    radius : float
        Initial radius R [µm], > 0.
    frequency : float
        [Hz]; at least 8 samples per period.
    tau : float
        Decay time constant [s], > 0.
    duration : float
        Record length [s], > 0.
    circle_periods : float
        Full circles before the decay starts, >= 0.
    phase : float
        [deg].

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    reference : numpy.ndarray, shape (2, n_samples)
        ``(x_r, y_r)`` [µm].

    Raises
    ------
    SignalError
    """
    R = _positive(radius, "radius", "µm")
    f = _check_frequency(frequency, sampling_period)
    tau = _positive(tau, "tau", "s")
    cp = _finite(circle_periods, "circle_periods", "-")
    if cp < 0:
        raise SignalError(f"circle_periods: expected a number >= 0, found {circle_periods!r}")
    phi = np.deg2rad(_finite(phase, "phase", "deg"))
    t = time_vector(sampling_period, duration=duration)
    t0 = cp / f
    r = R * np.exp(-np.clip(t - t0, 0.0, None) / tau)
    arg = 2 * np.pi * f * t + phi
    return t, np.vstack([r * np.cos(arg), r * np.sin(arg)])


def lissajous_period(frequency_x, frequency_y, max_denominator=100):
    """Common period of a Lissajous curve [s].

    The ratio ``f_x / f_y`` is approximated by a fraction p/q with q <=
    ``max_denominator``; the common period is ``p / f_x = q / f_y``.

    Parameters
    ----------
    frequency_x : float
        Frequency of the x signal [Hz], > 0.
    frequency_y : float
        Frequency of the y signal [Hz], > 0.
    max_denominator : int
        Largest q tried.

    Returns
    -------
    float
        The common period [s].

    Raises
    ------
    SignalError
        If the ratio is not within 1e-6 (relative) of such a fraction; write
        e.g. 100/3 Hz as 33.333333333333336, not 33.33.
    """
    fx = _positive(frequency_x, "frequencies[0]", "Hz")
    fy = _positive(frequency_y, "frequencies[1]", "Hz")
    ratio = Fraction(fx / fy).limit_denominator(max_denominator)
    if abs(float(ratio) - fx / fy) > 1e-6 * fx / fy:
        raise SignalError(f"frequencies: the ratio {fx!r}/{fy!r} is not a simple fraction "
                          f"(denominator <= {max_denominator}) to 1e-6; give the frequencies in "
                          f"full precision (100/3 Hz = 33.333333333333336) or a duration")
    return ratio.numerator / fx


def lissajous(sampling_period, amplitude, frequencies, phase=0.0, periods=None, duration=None):
    """Lissajous trajectory (paper Fig. 12 and 13).

    ``x_r = A_x cos(2 pi f_x t + phase)``, ``y_r = A_y sin(2 pi f_y t + phase)``;
    the Lissajous ratio is ``f_x / f_y``.

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float or sequence of 2 floats
        ``A_x, A_y`` [µm], > 0.
    frequencies : sequence of 2 floats
        ``f_x, f_y`` [Hz]; each at least 8 samples per period.
    phase : float
        [deg].
    periods : float, optional
        Number of common periods (see :func:`lissajous_period`).
    duration : float, optional
        Record length [s].

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    reference : numpy.ndarray, shape (2, n_samples)
        ``(x_r, y_r)`` [µm].

    Raises
    ------
    SignalError
    """
    amp = [amplitude, amplitude] if np.isscalar(amplitude) else list(amplitude)
    freqs = list(frequencies) if not np.isscalar(frequencies) else None
    if len(amp) != 2:
        raise SignalError(f"amplitude: expected one number or two [µm], found {amplitude!r}")
    if freqs is None or len(freqs) != 2:
        raise SignalError(f"frequencies: expected two frequencies [f_x, f_y] [Hz], found {frequencies!r}")
    ax = _positive(amp[0], "amplitude[0]", "µm")
    ay = _positive(amp[1], "amplitude[1]", "µm")
    fx = _check_frequency(freqs[0], sampling_period, "frequencies[0]")
    fy = _check_frequency(freqs[1], sampling_period, "frequencies[1]")
    phi = np.deg2rad(_finite(phase, "phase", "deg"))
    period = lissajous_period(fx, fy) if periods is not None else None
    t = time_vector(sampling_period, period, periods, duration)
    return t, np.vstack([ax * np.cos(2 * np.pi * fx * t + phi),
                         ay * np.sin(2 * np.pi * fy * t + phi)])


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


def raster(sampling_period, size, lines, frequency, slow="step", smoothing=0.0):
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
    return t, np.vstack([fast, slow_axis])


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


# -- the registry of signal kinds: ``reference = { kind = ... }`` / ``drive = { kind = ... }`` --
def _pair(what):
    def check(v):
        if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
            return [float(a) for a in v]
        raise Invalid(f"expected {what}, found {v!r}")
    return check


def _amplitudes(v):
    if is_number(v) and v > 0:
        return float(v)
    if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a positive number or two [µm], found {v!r}")


def _fraction(upper):
    def check(v):
        if not is_number(v) or not 0 <= v <= upper:
            raise Invalid(f"expected a fraction of the period in [0, {upper:g}], found {v!r}")
        return float(v)
    return check


def _column_map(v):
    if isinstance(v, dict) and v and all(isinstance(c, str) and c for c in v.values()):
        return dict(v)
    raise Invalid(f"expected a table {{ <output> = \"<column>\" }} of column names, found {v!r}")


def words_number(v, unit=""):
    """A number for people: ``50 µm``, ``0.25 s``, ``33.3333 Hz``.

    Parameters
    ----------
    v : float
    unit : str
        Appended after a space when given.

    Returns
    -------
    str
        ``v`` with 6 significant digits.
    """
    return f"{float(v):.6g}{' ' + unit if unit else ''}"


def _length(s):
    if "periods" in s:
        return f"{words_number(s['periods'])} period{'' if s['periods'] == 1 else 's'}"
    return words_number(s["duration"], "s") if "duration" in s else ""


def _common_words(s, unit):
    """Phase and offset when not zero, then the record length."""
    parts = [f"phase {words_number(s['phase'], '°')}"] if s.get("phase") else []
    if s.get("offset"):
        parts.append(f"offset {words_number(s['offset'], unit)}")
    return parts + [_length(s)]


@dataclass
class ReferenceKind:
    """An entry of a signal registry (:data:`REFERENCE_KINDS`, :data:`DRIVE_KINDS`).

    Adding a kind is one entry: its keys are checked by ``hammerstein
    validate``, its generator runs there (so a signal beyond Nyquist is
    reported before any run), its summary is the "signal" column of
    ``report.md``, its metrics and scan geometry (raster-style extras) are
    added by the execution and the report.

    Parameters
    ----------
    fields : dict of str to hammerstein.core.schema.Field
        The keys of the table besides ``kind``.
    generate : callable
        ``generate(table, T, names, base_dir) -> (time, signal, period, extras)``:
        ``table`` the checked table (defaults filled, no ``kind``), ``T`` the
        sampling period [s], ``names`` the plant's outputs (references) or
        inputs (drives); ``time`` shape (n_samples,) [s], ``signal`` shape
        (len(names), n_samples) [µm or V], ``period`` [s] (what
        ``settle_periods`` counts), ``extras`` a dict of ``loop_channel``
        (index of a single-axis loop), ``driven_input`` (drives) and
        ``scale`` [µm] (percent metrics). Raises SignalError naming the key.
    summary : callable
        ``summary(table, unit) -> list of str``: the table in words for the
        report (``["circle", "radius 50 µm", "50 Hz", "3 periods"]``).
    description : str
        One line for ``hammerstein list`` and the README.
    period : callable, optional
        ``period(table) -> float or None`` [s] before generating (the sample
        budget); default ``1 / frequency`` when the table has one.
    metrics : callable, optional
        ``metrics(time, table, reference, outputs) -> list of dict``: rows
        added to the tracking metrics (e.g. per scan line).
    scan : callable, optional
        ``scan(time, table, names) -> dict`` of a scanned (raster-style)
        reference: ``line`` (scan line per sample), ``trace`` (bool per
        sample), ``fast``, ``slow`` (output names), ``extent`` (fast-axis
        length [µm]); the report draws the error per scan line from it.
    """

    fields: dict
    generate: Callable
    summary: Callable
    description: str = ""
    period: Callable | None = None
    metrics: Callable | None = None
    scan: Callable | None = None

    def period_of(self, table):
        """The period [s] of a checked table before generating it, or None.

        Parameters
        ----------
        table : dict

        Returns
        -------
        float or None
        """
        if self.period is not None:
            return self.period(table)
        return 1.0 / table["frequency"] if "frequency" in table else None


def _placed(xy, outs, names):
    """A (2, N) planar trajectory on outputs ``outs`` of ``names``: (p, N)."""
    sig = np.zeros((len(names), xy.shape[1]))
    for row, o in zip(xy, outs):
        sig[list(names).index(o)] = row
    return sig


def _planar_outputs(table, names):
    outs = table.pop("outputs", None) or list(names[:2])
    missing = [o for o in outs if o not in names]
    if not missing and len(set(outs)) < len(outs):
        raise SignalError(f"outputs: expected two different outputs of the plant {list(names)}, "
                          f"found {outs}")
    if missing or len(names) < 2:
        raise SignalError(f"outputs: expected two of the plant's outputs {list(names)}, found {outs}")
    return outs


def _single_axis(fn):
    def generate(c, T, names, base_dir):
        t, sig = fn(T, names, **c)
        return t, sig, 1.0 / c["frequency"], {"loop_channel": list(names).index(c["output"]),
                                              "scale": c["amplitude"]}
    return generate


def _single_axis_words(kind):
    def summary(s, unit):
        return [f"{kind} on {s.get('output', s.get('input'))}", words_number(s["amplitude"], unit),
                words_number(s["frequency"], "Hz")] + _common_words(s, unit)
    return summary


def _drive(fn):
    def generate(c, T, names, base_dir):
        t, sig = fn(T, names, **c)
        return t, sig, 1.0 / c["frequency"], {"driven_input": list(names).index(c["input"])}
    return generate


def _circle(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    t, xy = circle(T, **c)
    return t, _placed(xy, outs, names), 1.0 / c["frequency"], {"scale": c["radius"]}


def _spiral(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    t, xy = spiral(T, **c)
    return t, _placed(xy, outs, names), 1.0 / c["frequency"], {"scale": c["radius"]}


def _lissajous_period(c):
    try:
        return lissajous_period(*c["frequencies"])
    except SignalError:
        return 1.0 / min(c["frequencies"])


def _lissajous(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    t, xy = lissajous(T, **c)
    return t, _placed(xy, outs, names), _lissajous_period(c), {"scale": float(np.max(c["amplitude"]))}


def _lissajous_words(s, unit):
    a = s["amplitude"]
    amp = (" × ".join(words_number(x) for x in a) + " µm") if isinstance(a, list) \
        else words_number(a, "µm")
    return (["Lissajous", amp, " / ".join(words_number(f) for f in s["frequencies"]) + " Hz"]
            + _common_words(s, unit))


def _raster(c, T, names, base_dir):
    outs = c.pop("outputs")
    if len(set(outs)) != 2 or any(o not in names for o in outs):
        raise SignalError(f"outputs: expected two different outputs [fast, slow] of the plant "
                          f"{list(names)}, found {outs}")
    t, xy = raster(T, **c)
    return t, _placed(xy, outs, names), 1.0 / c["frequency"], {"scale": float(max(c["size"]))}


def _raster_words(s, unit):
    fast, slow = s["outputs"]
    size = s["size"]
    parts = [f"raster, fast {fast}, slow {slow}",
             f"{words_number(size[0])} × {words_number(size[1])} µm", f"{s['lines']} lines",
             f"{words_number(s['frequency'], 'Hz')} line rate", f"slow axis {s.get('slow', 'step')}"]
    if s.get("smoothing"):
        parts.append(f"turns rounded over {words_number(100 * s['smoothing'])} % of a period")
    return parts + _common_words(s, unit)


def _raster_metrics(time, s, reference, outputs):
    return raster_line_metrics(reference, outputs, raster_line_index(time, s["frequency"]))


def _raster_scan(time, s, names):
    return {"line": raster_line_index(time, s["frequency"]),
            "trace": np.mod(np.asarray(time) * float(s["frequency"]), 1.0) < 0.5,
            "fast": s["outputs"][0], "slow": s["outputs"][1], "extent": float(s["size"][0])}


def _file(c, T, names, base_dir):
    period = c.pop("period", None) or T
    t, sig = from_file(T, names, base_dir=base_dir, **c)
    return t, sig, period, {}


def _file_words(s, unit):
    cols = ", ".join(f"{o} = {c!r}" for o, c in s.get("columns", {}).items())
    return [f"file {s.get('file')}", f"time {s.get('time', 'time')!r}", cols]


_PHASE = Field(number("deg"), default=0.0)
_LENGTH = {"periods": Field(number("periods", 0)), "duration": Field(number("s", 0))}
_SINE_REFERENCE = {"output": Field(string(), required=True),
                   "amplitude": Field(number("µm", 0), required=True),
                   "frequency": Field(number("Hz", 0), required=True),
                   "phase": _PHASE, "offset": Field(number("µm"), default=0.0), **_LENGTH}
_SINE_DRIVE = {"input": Field(string(), required=True),
               "amplitude": Field(number("V", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "phase": _PHASE, "offset": Field(number("V"), default=0.0), **_LENGTH}

#: Reference kinds (``[[cases]] reference = { kind = ... }``): name -> :class:`ReferenceKind`.
#: Add a kind by adding an entry (see docs/python-api.md, "Where things go").
REFERENCE_KINDS: dict[str, ReferenceKind] = {
    "sine": ReferenceKind(_SINE_REFERENCE, _single_axis(sine), _single_axis_words("sine"),
                          "sine on one output (paper Fig. 8)"),
    "triangle": ReferenceKind(dict(_SINE_REFERENCE), _single_axis(triangle),
                              _single_axis_words("triangle"), "triangle on one output"),
    "circle": ReferenceKind(
        {"radius": Field(number("µm", 0), required=True),
         "frequency": Field(number("Hz", 0), required=True),
         "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
        _circle, lambda s, unit: ["circle", f"radius {words_number(s['radius'], 'µm')}",
                                  words_number(s["frequency"], "Hz")] + _common_words(s, unit),
        "circle on two outputs (paper Fig. 10)"),
    "spiral": ReferenceKind(
        {"radius": Field(number("µm", 0), required=True),
         "frequency": Field(number("Hz", 0), required=True),
         "tau": Field(number("s", 0), required=True),
         "duration": Field(number("s", 0), required=True),
         "circle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
         "phase": _PHASE, "outputs": Field(name_list(2))},
        _spiral, lambda s, unit: ["spiral", f"radius {words_number(s['radius'], 'µm')}",
                                  words_number(s["frequency"], "Hz"),
                                  f"decay τ {words_number(s['tau'], 's')} after "
                                  f"{words_number(s.get('circle_periods', 1.0))} circle(s)"]
        + _common_words(s, unit),
        "circle whose radius decays (paper Fig. 11)"),
    "lissajous": ReferenceKind(
        {"amplitude": Field(_amplitudes, required=True),
         "frequencies": Field(_pair("two positive frequencies [f_x, f_y] [Hz]"), required=True),
         "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
        _lissajous, _lissajous_words, "Lissajous figure on two outputs (paper Fig. 12-13)",
        period=_lissajous_period),
    "raster": ReferenceKind(
        {"outputs": Field(name_list(2), required=True),     # [fast, slow]
         "size": Field(_pair("two positive extents [fast, slow] [µm]"), required=True),
         "lines": Field(integer(2), required=True),
         "frequency": Field(number("Hz", 0), required=True),  # fast axis (line rate)
         "slow": Field(choice("step", "ramp"), default="step"),
         "smoothing": Field(_fraction(0.5), default=0.0)},
        _raster, _raster_words, "AFM-style raster scan (trace and retrace, per-line metrics)",
        metrics=_raster_metrics, scan=_raster_scan),
    "file": ReferenceKind(
        {"file": Field(string(), required=True),
         "time": Field(string(), default="time"),
         "columns": Field(_column_map, required=True),
         "duration": Field(number("s", 0)),
         "period": Field(number("s", 0))},   # what settle_periods counts (default: T)
        _file, _file_words, "trajectory read from a CSV file",
        period=lambda c: None),
}

#: Drive kinds (``[[cases]] drive = { kind = ... }``, open-loop voltages): name -> :class:`ReferenceKind`.
DRIVE_KINDS: dict[str, ReferenceKind] = {
    "sine": ReferenceKind(_SINE_DRIVE, _drive(sine_drive), _single_axis_words("sine"),
                          "sine voltage on one input (paper Fig. 5)"),
    "triangle": ReferenceKind(dict(_SINE_DRIVE), _drive(triangle_drive),
                              _single_axis_words("triangle"), "triangle voltage on one input"),
}
