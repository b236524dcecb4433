"""Reference shaping: a reference the actuator cannot follow, made one it can.

A hardware drive is computed for the reference the user asked for; where
that drive leaves what the amplifier allows (beyond the range, or stepping
faster than the slew rate, both measured on the identification records
for an identified model), clipping the *drive* afterwards leaves the
actuator somewhere the compensator never planned (and, for a hysteresis
inverse with memory, on another memory branch than the one the inverse
assumed). :func:`shape_reference` shapes the *reference* instead, and runs the
compensator again on the shaped reference:

0. **band limit**: where the reference accelerates more than a sine at
   the identified first bending mode would (:func:`faster_than_mode`: a
   raster's line steps and the turns at both ends of its lines, never a
   circle below the mode), it is
   replaced by its zero-phase Hann-window average over one period of the
   mode: the inverse of the dynamics is then not asked for content at the
   resonance, which it reproduces only as well as the mode was identified.
   A reference whose own fundamental is at or above the mode (a circle
   at the mode) is band-limited only where it accelerates more than a
   sine at that fundamental would (its corners): averaging its fundamental
   would shrink it (a 10 µm circle at a 299 Hz mode became an 8.26 µm one,
   and `learn` converged to that);
1. **transients** (a raster's line steps and corners, a circle's start):
   around every sample whose drive leaves the limits, the reference is
   replaced by its zero-phase Hann-window average (a band limit below the
   first bending mode of the identified dynamics: the window is one period
   of that mode, doubled while it helps), blended in and out by a raised
   cosine; a step becomes an S-curve, a corner a smooth turn-around.
   The window grows only while the drive's excess over the limits falls
   by at least a tenth; an excess whose peak a doubled window does not
   halve (a jump of the drive) no longer counts and is left to the slew
   limit (:mod:`hammerstein.compensation.shaping_holds`, which also names
   holds shorter than the window). The first half of the samples at rest before the
   reference starts moving stays at rest (the drive still starts at rest).
2. **range**: what still leaves the range (the reference asks for more
   displacement than the amplifier's range reaches) is replaced, around
   those samples, by the output the model predicts for the range-clipped
   drive (scaled towards rest by up to a tenth while the drive for it
   still leaves the range): the reference becomes what the actuator can
   reach, and the compensator is run again on it (its memory then
   follows the drive it actually sends).

Every change is reported (:func:`shaping_notes`): per output, the largest
change [µm], the share of samples and the time intervals. What shaping
cannot change is named beside it: a harmonic at a bending mode
(:func:`mode_note`), the ZPETC inverse's gain error at the reference's
main frequency (:func:`zpetc_note`), a drive that chatters
(:func:`chatter_warnings`).

Length: the shaping and the notes of what a drive cannot do read the same reference
spectra, mode frequencies and amplifier limits, and ``compensate`` and ``learn`` print
them together; apart, each note would copy the main-frequency and mode estimates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hammerstein.compensation._shaping_corners import faster_than_mode
from hammerstein.compensation.shaping_holds import excess_left_to_limiter, hold_note
from hammerstein.signals.fundamental import reference_fundamental

__all__ = ["ShapedReference", "RESONANT_DAMPING", "first_mode_hz", "mode_decay_s",
           "faster_than_mode", "limit_excess", "hann_average", "mode_amplification", "mode_note",
           "shape_reference", "shaping_notes", "time_intervals", "CHATTER_FRACTION",
           "chatter_warnings", "CHATTER_REFUSE_FRACTION", "main_frequency",
           "relative_response"]

#: the smoothing window grows (doubles) at most this many times
MAX_DOUBLINGS = 6
#: a doubled window is kept only when it lowers the drive's excess by at least this fraction
MIN_GAIN = 0.1
#: the range stage's reference: the reachable output scaled towards rest by these factors in turn
#: (an identified model flattens near the edge of its records, where its inverse asks much more
#: voltage for a little more displacement) until the drive is within the range
RANGE_MARGINS = (1.0, 0.995, 0.98, 0.95, 0.9)
#: a complex pole pair damped at least this much (``zeta >= 1 / sqrt(2)``) has no resonance: its
#: gain never exceeds its static gain (a second-order lag's magnitude peaks only for
#: ``zeta < 1 / sqrt(2)``). An identified pair that damped (e.g. the residual of a hysteresis
#: model the records do not fit, at 88 Hz and ``zeta = 0.998``, whose damped frequency is 6 Hz)
#: is a lag, not a bending mode: :func:`first_mode_hz` and :func:`mode_decay_s` leave it out
RESONANT_DAMPING = float(1.0 / np.sqrt(2.0))
#: :func:`mode_note` names a harmonic of the reference that the linear part passes at least this
#: many times its static gain
MODE_NOTE_GAIN = 2.0
#: the harmonics of the reference's main frequency :func:`mode_note` looks at (hysteresis makes
#: harmonics of the frequency it is driven at; the higher ones are small)
MODE_NOTE_HARMONICS = 5


@dataclass
class ShapedReference:
    """A shaped reference, the drive computed for it and what was changed.

    Parameters
    ----------
    reference : numpy.ndarray, shape (p, n_samples)
        The shaped reference [µm] (equal to the given one where nothing
        was changed).
    inputs : numpy.ndarray, shape (m, n_samples)
        The compensator's drive for ``reference`` [V], before any limit.
    window_samples : int
        The smoothing window of the transient stage [samples] (0: none).
    range_limited : bool
        True when the range stage changed the reference.
    notes : list of str
        One line per changed output (:func:`shaping_notes`).
    limited : bool
        True when the limits shaped it, not only the band limit below the first mode.
    """

    reference: np.ndarray
    inputs: np.ndarray
    window_samples: int = 0
    range_limited: bool = False
    notes: list = field(default_factory=list)
    limited: bool = False

    @property
    def changed(self) -> bool:
        """True when the reference was shaped."""
        return bool(self.notes)


def first_mode_hz(A, sampling_period, natural=False):
    """Lowest oscillatory mode of a discrete linear part [Hz], or None.

    The (damped) frequency of a discrete pole ``z`` is ``|arg z| / (2 pi T)``
    (the continuous pole ``s = log(z) / T``); real poles (creep, lags) have
    none, and a pair damped at ``zeta >= 1 / sqrt(2)``
    (:data:`RESONANT_DAMPING`: no resonance) is a lag too.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix (n may be 0).
    sampling_period : float
        T [s].
    natural : bool
        Return that mode's natural frequency ``|s| / (2 pi)`` (what
        ``identify`` reports, ``1 / sqrt(1 - zeta^2)`` times the damped one)
        instead of its damped frequency.

    Returns
    -------
    float or None
        [Hz]; None without an oscillatory pole.

    Examples
    --------
    >>> T = 1e-4
    >>> z = np.exp(T * (-50 + 2j * np.pi * 400))
    >>> A = [[z.real, -z.imag], [z.imag, z.real]]
    >>> round(first_mode_hz(A, T), 6), round(first_mode_hz(A, T, natural=True), 3)   # sqrt(400^2 + (50 / 2 pi)^2)
    (400.0, 400.079)
    """
    z = _oscillatory_poles(A, sampling_period)
    if not z.size:
        return None
    k = int(np.argmin(np.abs(np.angle(z))))
    if natural:
        return float(np.abs(np.log(z[k])) / (2 * np.pi * float(sampling_period)))
    return float(np.abs(np.angle(z[k])) / (2 * np.pi * float(sampling_period)))


def mode_decay_s(A, sampling_period):
    """Longest decay time of the oscillatory modes of a discrete linear part [s], or None.

    A mode's free response decays as ``exp(-t / tau)`` with ``tau = 1 /
    |Re s| = 1 / (zeta omega_n)``, ``s = log(z) / T`` its continuous pole
    (e.g. 14.7 ms for a 313 Hz mode damped at 0.035). Real poles (creep,
    lags) and pairs damped at ``zeta >= 1 / sqrt(2)`` (no resonance) are
    not modes and are left out.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix (n may be 0).
    sampling_period : float
        T [s].

    Returns
    -------
    float or None
        [s]; None without an oscillatory pole, ``inf`` for an undamped one.

    Examples
    --------
    >>> T = 1e-4
    >>> z = np.exp(T * (-50 + 2j * np.pi * 400))
    >>> A = [[z.real, -z.imag], [z.imag, z.real]]
    >>> round(mode_decay_s(A, T), 9)
    0.02
    """
    z = _oscillatory_poles(A, sampling_period)
    if z.size == 0:
        return None
    rate = -np.log(np.abs(z)) / float(sampling_period)        # |Re s| = -ln|z| / T
    return float(np.inf) if np.any(rate <= 0) else float(1.0 / rate.min())


def _oscillatory_poles(A, sampling_period):
    """The discrete poles ``z`` (n_modes,) of the bending modes: a frequency ``|arg z| / (2 pi T)``
    above 1e-9 Hz and a damping ``zeta = -Re s / |s|`` (``s = log(z) / T``) below
    :data:`RESONANT_DAMPING`."""
    A = np.atleast_2d(np.asarray(A, dtype=float))
    if A.size == 0:
        return np.zeros(0, dtype=complex)
    z = np.linalg.eigvals(A)
    z = z[np.abs(np.angle(z)) / (2 * np.pi * float(sampling_period)) > 1e-9]
    s = np.log(z) / float(sampling_period)
    return z[-s.real < RESONANT_DAMPING * np.abs(s)]


def _pole_frequencies(A, sampling_period):
    """Frequencies [Hz] (n_modes,) of the oscillatory discrete poles, ``|arg z| / (2 pi T)``."""
    z = _oscillatory_poles(A, sampling_period)
    return np.abs(np.angle(z)) / (2 * np.pi * float(sampling_period))


def _resonant_mode(A, sampling_period, frequency_hz):
    """Natural frequency [Hz] of the bending mode that amplifies ``frequency_hz`` the most, or None.

    Each mode's natural frequency ``f_n = |s| / (2 pi)`` and damping ``zeta =
    -Re s / |s|`` (``s = log(z) / T``, the convention of ``identify``) give
    its one-mode amplification ``1 / |1 - r^2 + 2 j zeta r|``, ``r = f / f_n``;
    a heavily damped mode next to ``f`` loses to a lightly damped one a little
    further away.
    """
    z = _oscillatory_poles(A, sampling_period)
    if z.size == 0:
        return None
    s = np.log(z) / float(sampling_period)
    fn = np.abs(s) / (2 * np.pi)
    zeta = -s.real / np.abs(s)
    r = float(frequency_hz) / fn
    return float(fn[np.argmax(1.0 / np.abs(1.0 - r * r + 2j * zeta * r))])


def mode_amplification(matrices, sampling_period, frequencies_hz):
    """How many times its static gain the linear part passes each frequency.

    ``a(f) = || G(z) G(1)^-1 ||_2`` at ``z = exp(j 2 pi f T)``, ``G(z) = C (z I
    - A)^-1 B + D`` (the largest singular value: the worst direction over the
    outputs). A hysteresis model's error at ``f`` reaches the position through
    ``G`` while the compensator, built on the model, cannot see it: where
    ``a(f)`` is large (a harmonic of the reference at a lightly damped bending
    mode, ``a = 1 / (2 zeta)`` at resonance for one mode), the error is that
    many times what it would be on a stage without resonance.

    Parameters
    ----------
    matrices : tuple of array_like
        Discrete ``(A, B, C, D)`` of the linear part, shapes (n, n), (n, m),
        (p, n), (p, m) (``HammersteinPlant.matrices``); ``G(1)`` invertible.
    sampling_period : float
        T [s].
    frequencies_hz : array_like, shape (n_freq,)
        [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_freq,)
        Dimensionless; 1 everywhere for a static plant.

    Raises
    ------
    numpy.linalg.LinAlgError
        On a static gain ``G(1)`` that is singular.

    Examples
    --------
    One mode at 400 Hz with damping 0.05 passes its resonance about
    ``1 / (2 zeta) = 10`` times its static gain:

    >>> from hammerstein.models.dynamics import sampled_bending_modes
    >>> G = sampled_bending_modes([400.0], [0.05], ["x"], 5e-5)
    >>> a = mode_amplification((G.A, G.B, G.C, G.D), 5e-5, [0.0, 100.0, 400.0])
    >>> [round(float(v), 1) for v in a]
    [1.0, 1.1, 10.0]
    """
    return np.array([np.linalg.norm(g, 2)
                     for g in relative_response(matrices, sampling_period, frequencies_hz)])


def relative_response(matrices, sampling_period, frequencies_hz):
    """``G(z) G(1)^-1`` at each frequency: the linear part relative to its static gain.

    Parameters
    ----------
    matrices : tuple of array_like
        Discrete ``(A, B, C, D)``, shapes (n, n), (n, m), (p, n), (p, m), ``G(1)``
        invertible (p = m).
    sampling_period : float
        T [s].
    frequencies_hz : array_like, shape (n_freq,)
        [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_freq, p, p), complex

    Raises
    ------
    numpy.linalg.LinAlgError
        On a static gain ``G(1)`` that is singular.

    Examples
    --------
    >>> from hammerstein.models.dynamics import sampled_bending_modes
    >>> G = sampled_bending_modes([400.0], [0.05], ["x"], 5e-5)
    >>> round(abs(complex(relative_response((G.A, G.B, G.C, G.D), 5e-5, [400.0])[0, 0, 0])), 1)
    10.0
    """
    A, B, C, D = (np.atleast_2d(np.asarray(x, dtype=float)) for x in matrices)
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    T = float(sampling_period)
    n = A.shape[0]

    def gain(fk):
        if n == 0:
            return D.astype(complex)
        z = np.exp(2j * np.pi * fk * T)
        return C @ np.linalg.solve(z * np.eye(n) - A, B) + D

    inv0 = np.linalg.inv(gain(0.0))
    return np.array([gain(fk) @ inv0 for fk in f])


def mode_note(matrices, sampling_period, reference, period_samples, limit=MODE_NOTE_GAIN):
    """A note when a harmonic of a periodic reference lies at a bending mode, or None.

    The reference's main frequency ``f0`` is the largest line of the
    spectrum of its last period (summed over the outputs, without the mean),
    refined on the Hann-windowed spectrum of its last periods (a period of a
    whole number of samples only approximates the reference's own); its
    harmonics ``n f0``, ``n = 1 ..`` :data:`MODE_NOTE_HARMONICS` (below
    the Nyquist frequency), are weighed by :func:`mode_amplification`; the
    largest, when at least ``limit``, is named, with the oscillatory mode
    nearest to it. Hysteresis turns a drive at
    ``f0`` into output harmonics of ``f0``; what the model gets wrong of them
    reaches the position that many times larger, and feedforward cannot
    correct it (iterative learning control on the measured response can).

    Parameters
    ----------
    matrices : tuple of array_like
        Discrete ``(A, B, C, D)`` of the linear part (see
        :func:`mode_amplification`).
    sampling_period : float
        T [s].
    reference : array_like, shape (p, n_samples)
        [µm].
    period_samples : int or None
        One period of the reference [samples]; None or below 2 (not
        periodic) gives None.
    limit : float
        The amplification from which a harmonic is named (default
        :data:`MODE_NOTE_GAIN`).

    Returns
    -------
    str or None
        One line, or None (a static plant, a singular static gain, no
        period, or no harmonic amplified ``limit`` times).

    Examples
    --------
    >>> from hammerstein.models.dynamics import sampled_bending_modes
    >>> T = 5e-5
    >>> G = sampled_bending_modes([300.0], [0.04], ["x"], T)
    >>> t = np.arange(2000) * T
    >>> ref = 15.0 * np.sin(2 * np.pi * 100.0 * t)[None, :]
    >>> print(mode_note((G.A, G.B, G.C, G.D), T, ref, 200))   # doctest: +NORMALIZE_WHITESPACE
    the bending mode at 300 Hz passes the reference's 3rd harmonic (300 Hz, of 100 Hz) 12.5
    times its static gain: what the hysteresis model gets wrong at 300 Hz reaches the position
    12.5 times larger, and feedforward cannot see it (`hammerstein learn` corrects it on the
    measured response)
    """
    A = np.atleast_2d(np.asarray(matrices[0], dtype=float))
    if A.size == 0:
        return None
    T = float(sampling_period)
    f0 = main_frequency(reference, period_samples, T)
    if f0 is None:
        return None
    order = np.arange(1, MODE_NOTE_HARMONICS + 1)
    order = order[order * f0 < 0.5 / T]
    if order.size == 0:
        return None
    try:
        amp = mode_amplification(matrices, T, order * f0)
    except np.linalg.LinAlgError:        # a singular static gain: no ratio to name
        return None
    k = int(np.argmax(amp))
    if amp[k] < limit:
        return None
    n, a = int(order[k]), float(amp[k])
    where = _resonant_mode(A, T, n * f0)
    where = f"the bending mode at {where:.0f} Hz" if where is not None else "the linear part"
    which = ("main frequency" if n == 1 else
             f"{n}{'nd' if n == 2 else 'rd' if n == 3 else 'th'} harmonic")
    fn = f"{n * f0:.4g} Hz" + ("" if n == 1 else f", of {f0:.4g} Hz")
    return (f"{where} passes the reference's {which} ({fn}) {a:.3g} "
            f"times its static gain: what the hysteresis model gets wrong at {n * f0:.4g} Hz "
            f"reaches the position {a:.3g} times larger, and feedforward cannot see it "
            f"(`hammerstein learn` corrects it on the measured response)")


def main_frequency(reference, period_samples, sampling_period):
    """A periodic reference's main frequency [Hz], or None.

    The largest line of the spectrum of its last period (summed over the outputs, without the
    mean), refined on the Hann-windowed spectrum of its last periods.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    period_samples : int or None
        One period [samples]; None or below 2 (not periodic) gives None.
    sampling_period : float
        T [s].

    Returns
    -------
    float or None

    Examples
    --------
    >>> t = np.arange(4000) * 5e-5
    >>> round(main_frequency(np.sin(2 * np.pi * 50.0 * t)[None, :], 400, 5e-5), 6)
    50.0
    """
    if period_samples is None or int(period_samples) < 2:
        return None
    T, P = float(sampling_period), int(period_samples)
    ref = np.atleast_2d(np.asarray(reference, dtype=float))
    if ref.shape[1] < P:
        return None
    spectrum = (np.abs(np.fft.rfft(ref[:, -P:], axis=1)) ** 2).sum(axis=0)
    if spectrum.size < 2 or not np.any(spectrum[1:] > 0):
        return None
    return _refined_frequency(ref, (1 + int(np.argmax(spectrum[1:]))) / (P * T), P, T)


def delay_search_span(reference, period_samples, sampling_period, default=50):
    """The largest delay a cross-correlation may search on a reference [samples].

    Below half a period of the reference and of its main frequency
    (:func:`main_frequency`): a delay of a whole period is no delay, and a
    circle at 50 Hz inside a record that repeats at 10 Hz (a third axis's
    sine) otherwise read its own period, 400 samples, as the delay.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    period_samples : int or None
        The record's period [samples]; None or below 3: ``default``.
    sampling_period : float
        T [s].
    default : int
        The span without a period [samples].

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> t = np.arange(8000) * 5e-5
    >>> r = np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 10 * t) / 4])
    >>> delay_search_span(r, 2000, 5e-5)
    199
    """
    P = int(period_samples) if period_samples else 0
    span = (P - 1) // 2 if P > 2 else int(default)
    f0 = main_frequency(reference, P, sampling_period) if P > 2 else None
    if f0:
        span = min(span, int((1.0 / (f0 * float(sampling_period)) - 1) // 2))
    return max(1, span)


def _refined_frequency(reference, f0, period_samples, sampling_period, periods=16, points=21):
    """The frequency near ``f0`` [Hz] where the Hann-windowed spectrum of the reference's tail peaks.

    A period of a whole number of samples only approximates the reference's
    own (150 Hz at 50 µs is 133.3 samples, read as 150.4 Hz). The tail of at
    most ``periods`` periods is scanned over ``f0 (1 +- 1 / period_samples)``
    on ``points`` frequencies, then on ``points`` more between the best one's
    neighbours: ``2 points`` sums over at most ``periods * period_samples``
    samples, O(that) memory. A period of 2000 samples or more (rounding off
    at most 0.025 %) is taken as it is.
    """
    T, P = float(sampling_period), int(period_samples)
    if P >= 2000:
        return float(f0)
    tail = reference[:, -min(reference.shape[1], periods * P):]
    tail = (tail - tail.mean(axis=1, keepdims=True)) * np.hanning(tail.shape[1])
    t = np.arange(tail.shape[1]) * T
    lo, hi = f0 * (1.0 - 1.0 / P), f0 * (1.0 + 1.0 / P)
    for _ in range(2):
        f = np.linspace(lo, hi, points)
        power = [float((np.abs(tail @ np.exp(-2j * np.pi * x * t)) ** 2).sum()) for x in f]
        k = int(np.argmax(power))
        lo, hi = f[max(k - 1, 0)], f[min(k + 1, points - 1)]
    return float(f[k])


def _limits_left(amplifier, inputs, sampling_period):
    """Which limits a drive leaves, in words: 'range', 'slew rate' or 'range and slew rate'."""
    u = np.array(inputs, dtype=float, ndmin=2)
    T, which = float(sampling_period), []
    for i, c in enumerate(amplifier.channels):
        if np.any(u[i] > c.high) or np.any(u[i] < c.low):
            which.append("range")
        steps = np.abs(np.diff(np.concatenate([[c.rest], u[i]])))
        if np.isfinite(c.slew_rate) and np.any(steps > c.slew_rate * T * (1 + 1e-9)):
            which.append("slew rate")
    return " and ".join(w for w in ("range", "slew rate") if w in which) or "range"


def limit_excess(amplifier, inputs, sampling_period):
    """Per sample, how far a drive leaves the amplifier's range and slew rate [V].

    ``e[k] = sum_i max(u_i[k] - high_i, low_i - u_i[k], 0)
    + max(|u_i[k] - u_i[k-1]| - S_i T, 0)``, the first step counted from
    the channel's rest voltage.

    Parameters
    ----------
    amplifier : hammerstein.models.amplifier.Amplifier
    inputs : array_like, shape (m, n_samples)
        [V].
    sampling_period : float
        T [s].

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        [V]; zero where the drive is within the limits.

    Examples
    --------
    >>> from hammerstein.models.amplifier import amplifier_from_table
    >>> amp = amplifier_from_table({"range": [-1.0, 1.0], "slew_rate": 1.0}, ["u"])
    >>> limit_excess(amp, [[0.5, 1.5, 1.5]], 1.0).tolist()   # beyond the range by 0.5 V twice
    [0.0, 0.5, 0.5]
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    e = np.zeros(u.shape[1])
    T = float(sampling_period)
    for i, c in enumerate(amplifier.channels):
        e += np.maximum(np.maximum(u[i] - c.high, c.low - u[i]), 0.0)
        if np.isfinite(c.slew_rate):
            steps = np.abs(np.diff(np.concatenate([[c.rest], u[i]])))
            e += np.maximum(steps - c.slew_rate * T * (1 + 1e-9), 0.0)
    return e


def hann_average(signal, window):
    """Zero-phase moving average with a Hann window (edges held) per row.

    Parameters
    ----------
    signal : array_like, shape (p, n_samples)
    window : int
        Window length [samples]; below 3 the signal is returned unchanged.

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
        ``sum_j w_j x[k + j] / sum_j w_j``, ``w`` the Hann window of
        ``window`` samples centred on ``k`` (a symmetric kernel: no phase
        lag), the signal continued by its first and last values.

    Examples
    --------
    >>> np.round(hann_average([[0.0] * 4 + [1.0] * 4], 5), 3).tolist()  # weights 1, 3, 4, 3, 1 / 12
    [[0.0, 0.0, 0.083, 0.333, 0.667, 0.917, 1.0, 1.0]]
    """
    x = np.array(signal, dtype=float, ndmin=2)
    L = int(window) | 1                        # odd: centred
    if L < 3 or x.shape[1] == 0:
        return x
    w = np.hanning(L + 2)[1:-1]
    w = w / w.sum()
    h = L // 2
    pad = np.pad(x, ((0, 0), (h, h)), mode="edge")
    return np.vstack([np.convolve(row, w, mode="valid") for row in pad])


def _blend_weights(mask, window):
    """0..1 weights: 1 within ``window`` samples of a True of ``mask``, raised-cosine edges."""
    L = max(int(window), 1)
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return np.zeros(mask.size)
    near = np.zeros(mask.size)
    for k in idx:                              # dilate by L each side
        near[max(k - L, 0):k + L + 1] = 1.0
    return np.clip(hann_average(near[None, :], L)[0] * 1.0000001, 0.0, 1.0)


def _after(start, n, size):
    """0 before ``start``, a raised cosine up to 1 over the next ``n`` samples, 1 after."""
    k = np.clip((np.arange(size) - start) / max(n, 1), 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * k))


#: :func:`chatter_warnings` names an input that reverses by more than this fraction of its range
#: (or of its own span without one) on two consecutive samples
CHATTER_FRACTION = 0.02
#: ``compensate`` and ``learn`` refuse a drive (under ``--limits error``) that reverses by more
#: than this fraction of the range on two consecutive samples: 22-50 % on the drives two new
#: users' checks and a Bouc-Wen actuator met; a 400 Hz circle's one glitch at the end of its
#: fade on the paper's actuator, 8 %, is only named.
CHATTER_REFUSE_FRACTION = 0.1


def chatter_warnings(inputs, sampling_period, span=None, names=None, fraction=CHATTER_FRACTION,
                     unit="V"):
    """Where a drive chatters: steps up and down (or down and up) by a large voltage on
    consecutive samples.

    A drive that follows a reference through a smooth model reverses only where its voltage
    turns, with steps near zero there; two consecutive steps of opposite sign, each larger
    than :data:`CHATTER_FRACTION` of the range, are the exact inverse alternating between two
    inputs that give the model the same output (a model flat over a few volts near the edge of
    its records: on an outside actuator, 16.4 / 19.8 V sample to sample). Such a drive excites
    the actuator at half the sampling rate and is no command for hardware.

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        The drive [V].
    sampling_period : float
        T [s].
    span : array_like, shape (m,), optional
        Each input's range width [V] (the amplifier's); its own peak to peak otherwise.
    names : list of str, optional
    fraction : float
        Of the range: the smallest step of a reversal that counts (default
        :data:`CHATTER_FRACTION`; :data:`CHATTER_REFUSE_FRACTION` for those a command refuses).
    unit : str
        The drive's unit, the model's input unit (``HammersteinPlant.units[0]``): the lines'.

    Returns
    -------
    list of str
        One line per input that chatters (count, where, the largest step); empty otherwise.

    Examples
    --------
    >>> u = np.array([[0.0, 1.0, 2.0, 3.0, 2.0, 3.2, 2.1, 3.3]])
    >>> chatter_warnings(u, 0.5, span=[10.0])[0].split(":")[0]
    'input 1'
    >>> chatter_warnings(np.sin(np.linspace(0, 6, 400))[None, :], 1e-3)
    []
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    if u.shape[1] < 3:
        return []
    d = np.diff(u, axis=1)
    width = np.ptp(u, axis=1) if span is None else np.asarray(span, dtype=float)
    out = []
    for i in range(u.shape[0]):
        big = fraction * width[i]
        hit = (d[i, :-1] * d[i, 1:] < 0) & (np.minimum(np.abs(d[i, :-1]), np.abs(d[i, 1:])) > big)
        if big > 0 and hit.any():
            name = names[i] if names is not None else f"input {i + 1}"
            near = np.convolve(hit, np.ones(5), "same") > 0        # one run per episode
            out.append(f"{name}: the drive reverses by more than {big:.3g} {unit} from one sample to the "
                       f"next at {int(hit.sum())} samples ({time_intervals(near, sampling_period)}; "
                       f"steps up to {np.abs(d[i]).max():.3g} {unit}): " + (
                           "the inverse alternates between inputs that give the model the same "
                           "output (a model flat there, e.g. near the edge of its records), or the "
                           "inverse of the dynamics rings on a step of the reference (a raster's "
                           "line step, without an [amplifier] to shape it); do not play it as it "
                           "is: keep the reference away from there, smooth it, or look at it with "
                           "--predicted" if fraction >= CHATTER_REFUSE_FRACTION else
                           "a corner of the reference through the inverse of the dynamics, or the "
                           "start of an inverse alternating between inputs; look at it with "
                           "--predicted before playing it"))
    return out


def time_intervals(mask, sampling_period, limit=4):
    """``"0.1200-0.1250 s, ..."``: the runs of True in ``mask`` (at most ``limit``, then a count).

    Parameters
    ----------
    mask : array_like of bool, shape (n_samples,)
    sampling_period : float
        T [s].
    limit : int
        Runs listed before ``and N more``.

    Returns
    -------
    str
        Empty when ``mask`` has no True.

    Examples
    --------
    >>> time_intervals([False, True, True, False, True], 0.5)
    '0.5000-1.0000 s, 2.0000-2.0000 s'
    """
    idx = np.flatnonzero(np.asarray(mask, dtype=bool))
    if idx.size == 0:
        return ""
    cuts = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[idx[0]], idx[cuts + 1]])
    ends = np.concatenate([idx[cuts], [idx[-1]]])
    T = float(sampling_period)
    text = ", ".join(f"{a * T:.4f}-{b * T:.4f} s" for a, b in zip(starts[:limit], ends[:limit]))
    more = starts.size - limit
    return text + (f" and {more} more" if more > 0 else "")


def shaping_notes(raw, shaped, sampling_period, names=None, why="", unit="µm"):
    """One line per output the shaping changed: by how much, how often, where.

    Parameters
    ----------
    raw, shaped : array_like, shape (p, n_samples)
        The reference before and after [µm].
    sampling_period : float
        T [s].
    names : sequence of str, optional
        Output names (default ``output 1``, ...).
    why : str
        Appended to every line (e.g. the limits the drive left).
    unit : str
        The reference's unit, the model's output unit (``HammersteinPlant.units[1]``): the
        lines'.

    Returns
    -------
    list of str

    Examples
    --------
    >>> shaping_notes([[0.0, 1.0, 1.0]], [[0.0, 0.5, 1.0]], 0.5, ["x"])
    ['x: reference shaped by up to 0.5 µm on 33.3 % of the samples (0.5000-0.5000 s)']
    """
    r = np.array(raw, dtype=float, ndmin=2)
    s = np.array(shaped, dtype=float, ndmin=2)
    notes = []
    for i in range(r.shape[0]):
        d = np.abs(s[i] - r[i])
        scale = max(1.0, float(np.max(np.abs(r[i])))) if r.shape[1] else 1.0
        changed = d > 1e-9 * scale
        if not np.any(changed):
            continue
        name = names[i] if names is not None else f"output {i + 1}"
        notes.append(f"{name}: reference shaped by up to {float(d.max()):.3g} {unit} on "
                     f"{100 * np.mean(changed):.3g} % of the samples "
                     f"({time_intervals(changed, sampling_period)}){why}")
    return notes


def shape_reference(run, reference, amplifier, sampling_period, first_mode=None, predict=None,
                    period_samples=None, names=None, fade_samples=0, units=("V", "µm")):
    """A reference shaped to what the amplifier and the identified dynamics allow.

    See the module docstring for the two stages. Nothing is changed when
    the drive ``run(reference)`` is within the limits.

    Parameters
    ----------
    run : callable
        ``run(reference) -> inputs (m, n_samples)``: the compensator's drive
        from rest for a reference [V].
    reference : array_like, shape (p, n_samples)
        The reference, already faded in from rest [µm].
    amplifier : hammerstein.models.amplifier.Amplifier
        The limits (e.g. measured on the identification records).
    sampling_period : float
        T [s].
    first_mode : float, optional
        The identified dynamics' first bending mode [Hz]
        (:func:`first_mode_hz`): the first smoothing window is one of its
        periods; without one (a static model) 8 samples.
    predict : callable, optional
        ``predict(inputs) -> outputs (p, n_samples)``, the model's output
        for a drive from rest [µm]; without it there is no range stage.
    period_samples : int, optional
        One period of a periodic reference: the window never exceeds half
        of it.
    names : sequence of str, optional
        Output names for the notes.
    fade_samples : int
        The fade-in's samples: no hold is judged before its end (the fade's flat
        tail before a step is no hold of the reference: "holds of 0.15 ms" at the
        end of a staircase's 50 ms fade, every hold 50 ms long).
    units : tuple of str
        The model's (input, output) units (``HammersteinPlant.units``), in which the notes
        give the drive's excess and the reference's change.

    Returns
    -------
    ShapedReference

    Examples
    --------
    A static gain of 1 V/µm behind a slew limit of 1 V per sample: a 4 µm
    step becomes an S-curve the drive can follow.

    >>> from hammerstein.models.amplifier import amplifier_from_table
    >>> amp = amplifier_from_table({"range": [-10.0, 10.0], "slew_rate": 1.0}, ["u"])
    >>> r = np.array([[0.0] * 20 + [4.0] * 20])
    >>> s = shape_reference(lambda x: x, r, amp, 1.0)
    >>> float(limit_excess(amp, s.inputs, 1.0).max()), s.window_samples
    (0.0, 8)
    """
    r = np.array(reference, dtype=float, ndmin=2)
    T = float(sampling_period)
    N = r.shape[1]
    L0 = int(np.ceil(1.0 / (first_mode * T))) if first_mode else 8
    if not period_samples or period_samples < 2:
        # a file given without --period: the window stops at half of the fundamental found
        # from its samples, as for a period given (a 30 µm circle at 100 Hz beyond a 5 V
        # range's reach was averaged over 14 ms, 1.4 of its periods: shaped to 21 % of its size
        # where the range allowed 83 %)
        found = reference_fundamental(r, T)
        cap = N // 2 if found is None else max(min(int(found.samples(T)) // 2, N // 2), 3)
    else:
        found = None
        cap = max(int(period_samples) // 2, 3)
    one_period = L0                 # one period of the mode [samples], before the cap
    L0 = max(min(L0, cap), 3)
    at_rest = np.all(np.abs(r - r[:, :1]) <= 1e-12 * max(1.0, float(np.max(np.abs(r)))), axis=0)
    lead = int(np.argmin(at_rest)) if not np.all(at_rest) else N    # samples at rest first
    guard = _after(lead // 2, lead - lead // 2, N)     # the first half of them stays at rest
    repeat = period_samples if _repeats(r, period_samples, lead) else None
    base, band = r, False
    if first_mode and N >= 3:                          # stage 0: band limit below the first mode
        # (or, for a reference whose fundamental is faster, above that fundamental)
        fundamental = (1.0 / (period_samples * T) if period_samples and period_samples >= 2
                       else found.frequency_hz if found is not None else 0.0)
        fast = faster_than_mode(r, max(first_mode, fundamental), T)
        if np.any(fast):
            base = _periodic_end(r + _blend_weights(fast, L0) * guard * (hann_average(r, L0) - r),
                                 repeat, lead)
            band = True
    u = np.asarray(run(base), dtype=float)
    excess = limit_excess(amplifier, u, T) if amplifier is not None else np.zeros(N)
    best = ShapedReference(base, u, L0 if band else 0)
    reasons = ([f"it moves faster than the first mode of the identified dynamics (damped "
                f"frequency {first_mode:.4g} Hz) follows: smoothed there over {L0 * T * 1e3:.3g} ms ("
                + ("one period of the mode)" if L0 >= one_period else
                   "half the reference's period, less than one period of the mode)")]
               if band else [])
    if not np.any(excess > 0) or N < 3:
        best.notes = shaping_notes(r, best.reference, T, names,
                                   f": {'; '.join(reasons)}" if reasons else "", units[1])
        best.notes += hold_note(r, best.reference, best.window_samples, T, names,
                                max(lead, int(fade_samples)), units[1])
        return best
    mask = excess > 0
    e_best = excess
    left = np.zeros(N, dtype=bool)      # excess no longer window removes: the slew limit's
    L = L0
    limited_window, doublings = 0, 0
    for _ in range(MAX_DOUBLINGS + 1):
        w = _blend_weights(mask, L) * guard
        trial = _periodic_end(base + w * (hann_average(base, L) - base), repeat, lead)
        u_t = np.asarray(run(trial), dtype=float)
        e_t = limit_excess(amplifier, u_t, T)
        if limited_window:              # a doubling: what it does not lower is not its to remove
            left |= excess_left_to_limiter(e_best, e_t, L)
        total, best_total = float(e_t[~left].sum()), float(e_best[~left].sum())
        if total > (1 - MIN_GAIN) * best_total or (limited_window and best_total == 0):
            break
        best, e_best, limited_window = ShapedReference(trial, u_t, L), e_t, L
        doublings += L > L0
        mask = mask | (e_t > 0)
        if total == 0 or 2 * L > cap:
            break
        L *= 2
    notes_why = []
    if limited_window:
        notes_why.append(f"smoothed over {limited_window * T * 1e3:.3g} ms" + _window_words(
            limited_window, one_period, first_mode, doublings))
        stuck = left & (e_best > 0)
        if np.any(stuck):
            notes_why.append(f"{float(e_best[stuck].sum()):.3g} {units[0]} of it at "
                             f"{time_intervals(stuck, T)} left to the slew limit (a window "
                             f"twice as long did not halve it)")
    e_now = limit_excess(amplifier, best.inputs, T)
    if predict is not None and np.any(e_now > 0):
        left = _limits_left(amplifier, best.inputs, T)
        clipped, _ = amplifier.limit(best.inputs, T)
        reach = np.asarray(predict(clipped), dtype=float)
        rest = r[:, :1]                          # the faded reference starts at rest
        w = _blend_weights(e_now > 0, L0) * guard
        total, limited = float(e_now.sum()), None
        for f in RANGE_MARGINS:                  # the range's edge, then a little inside it
            trial = _periodic_end(best.reference + w * (rest + f * (reach - rest) - best.reference),
                                  repeat, lead)
            u_t = np.asarray(run(trial), dtype=float)
            e_t = float(limit_excess(amplifier, u_t, T).sum())
            if e_t < total:
                total, limited = e_t, (ShapedReference(trial, u_t, best.window_samples, True), f)
            if e_t == 0:
                break
        if limited is not None:
            best, f = limited
            notes_why.append(f"limited to the output the drive reaches within the "
                             f"{left} (the model's prediction for the drive "
                             f"{'clipped' if left == 'range' else 'limited'} to it"
                             + (f", {100 * (1 - f):.3g} % inside it" if f < 1 else "") + ")")
    best.limited = True           # the drive left the limits after the band limit
    if notes_why:
        reasons.append(f"the drive left the limits measured on the records ({'; '.join(notes_why)})")
    best.notes = shaping_notes(r, best.reference, T, names,
                               f": {'; '.join(reasons)}" if reasons else "", units[1])
    best.notes += hold_note(r, best.reference, max(best.window_samples, L0 if band else 0), T,
                            names, max(lead, int(fade_samples)), units[1])
    return best


def _window_words(window, one_period, first_mode, doublings):
    """`` (4 periods of the first mode, damped frequency 258.5 Hz: one period, ...)``: how a
    smoothing window of ``window`` samples came about, or empty without a first mode."""
    if not first_mode or window < one_period:
        return ""
    if not doublings:
        return f" (one period of the first mode, damped frequency {first_mode:.4g} Hz)"
    times = {1: "once", 2: "twice"}.get(doublings, f"{doublings} times")
    return (f" ({window / one_period:.3g} periods of the first mode, damped frequency "
            f"{first_mode:.4g} Hz: one "
            f"period, doubled {times} while that lowered the drive's excess over the limits by "
            f"at least a tenth)")


def _repeats(r, period_samples, lead):
    """True when the reference's last period repeats the one before (a circle; not a raster,
    whose lines step), with at least three periods after the rest ``lead``."""
    P, n = int(period_samples or 0), r.shape[1]
    if P < 2 or n - lead < 3 * P:
        return False
    scale = max(float(np.max(np.abs(r))), 1.0)
    return bool(np.max(np.abs(r[:, n - P:] - r[:, n - 2 * P:n - P])) <= 1e-9 * scale)


def _periodic_end(x, period_samples, lead):
    """``x`` with its last period a copy of the one before (a periodic reference's shaping
    is that of its earlier periods: the record's end neither smoothed against a held edge
    nor left unshaped); ``period_samples`` None (not a repeating reference): unchanged."""
    P, n = int(period_samples or 0), x.shape[1]
    if P < 2:
        return x
    x = x.copy()
    x[:, n - P:] = x[:, n - 2 * P:n - P]
    return x
