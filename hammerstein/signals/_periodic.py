"""Periodic references and drives: sine, circle, spiral, Lissajous (behind :mod:`hammerstein.signals.references`).

Every function returns ``(time, signal)`` sampled at the sampling period T:
``time`` has shape (n_samples,) [s], ``signal`` (n_channels, n_samples)
[µm] for references, [V] for drives; the trajectories are the paper's,
Section 5 (Fig. 5, 8, 10-13).
"""

from __future__ import annotations

from __future__ import annotations

from fractions import Fraction

import numpy as np

from hammerstein.core.numbers import check_samples
from hammerstein.exceptions import SignalError


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



def _at_center(xy, center, name="center"):
    """The planar signal ``xy`` (2, n) [µm] moved by ``center`` (two finite numbers [µm])."""
    if center is None:
        return xy
    c = np.asarray(center, dtype=float) if np.ndim(center) == 1 else None
    if c is None or c.shape != (2,) or not np.all(np.isfinite(c)):
        raise SignalError(f"{name}: expected two finite numbers [x, y] [µm], found {center!r}")
    return xy + c[:, None]

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


def circle(sampling_period, radius, frequency, phase=0.0, periods=None, duration=None,
           center=None):
    """Circular trajectory (paper Fig. 10).

    ``x_r = c_x + R cos(2 pi f t + phase)``, ``y_r = c_y + R sin(2 pi f t + phase)``.

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
    center : sequence of 2 floats, optional
        ``(c_x, c_y)`` [µm]; the origin by default.

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
    return t, _at_center(np.vstack([R * np.cos(arg), R * np.sin(arg)]), center)


def spiral(sampling_period, radius, frequency, tau, duration, circle_periods=1.0, phase=0.0,
           center=None):
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
    center : sequence of 2 floats, optional
        ``(c_x, c_y)`` [µm] added to both outputs; the origin by default.

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
    return t, _at_center(np.vstack([r * np.cos(arg), r * np.sin(arg)]), center)


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


def lissajous(sampling_period, amplitude, frequencies, phase=0.0, periods=None, duration=None,
              center=None):
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
    center : sequence of 2 floats, optional
        ``(c_x, c_y)`` [µm] added to both outputs; the origin by default.

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
    return t, _at_center(np.vstack([ax * np.cos(2 * np.pi * fx * t + phi),
                                    ay * np.sin(2 * np.pi * fy * t + phi)]), center)
