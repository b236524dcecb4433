"""Excitation signals to play on an actuator before identifying it.

Three kinds of record per input (the other inputs held at 0), each sampled at the
sampling period T of the hardware:

* :func:`decreasing_sine` — a slow sine whose amplitude steps down (100, 80,
  60, 40, 30, 20, 15, 10 % of the full amplitude, two periods each): the major loop and
  nested minor loops of the hysteresis. Each level starts and ends at a zero
  crossing, so the signal is continuous, and each level lies inside the
  previous one (wiping-out memory of a Preisach model: after its first period
  each level draws its steady minor loop).
* :func:`reversal_curves` — on request (``reversals``), played right after
  the decreasing sine, in the same record: first-order reversal curves from
  both ends of the range, which turn back at points across it (the off-centre
  reversals a raster or a drive with an offset makes, which the centred levels
  alone leave to the model's interpolation).
* :func:`multisine` — a random-phase multisine (flat amplitude spectrum on the
  grid ``j / period`` between ``f_min`` and ``f_max``, phases uniform,
  Pintelon & Schoukens [1]) for the linear dynamics; several periods of one
  realisation, so that the frequency response is estimated on exact DFT bins.
* :func:`staircase` — voltage steps held for seconds each, for creep (the
  slow drift after a step, Jung & Gweon [2]).

:func:`demagnetising_cycle` (every input at once, a sine decaying to 0 V)
is played before each of them and before every drive: it leaves the
actuator in the demagnetised state a model starts from, whatever an earlier
motion left in its hysteresis memory (the AC demagnetisation of
ferroelectrics and magnets, e.g. Bertotti [3], Section 9.3).

:func:`excitation_set` builds all of them for m inputs. Signals are arrays of
shape (m, n_samples) [V]; times (n_samples,) [s].

Length: every record kind with its own checks, and the set that plays them from the
amplifier's rest within its slew rate, belong together.

References
----------
.. [1] R. Pintelon and J. Schoukens, *System Identification: A Frequency
   Domain Approach*, 2nd ed., Wiley-IEEE, 2012, Section 2.5 (random-phase
   multisines, crest factor, periodic excitation).
.. [2] H. Jung and D.-G. Gweon, "Creep characteristics of piezoelectric
   actuators", Review of Scientific Instruments 71(4), 1896-1900, 2000.
.. [3] G. Bertotti, *Hysteresis in Magnetism*, Academic Press, 1998.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.core.numbers import MAX_MAGNITUDE, check_samples, number_problem
from hammerstein.models._lti_rate import decimation_factor
from hammerstein.models.demagnetisation import DEMAGNETISING_PERIODS

__all__ = ["LEVELS", "REVERSALS", "CURVE_SLEW", "STAIRCASE_LEVELS", "UNIPOLAR_STAIRCASE", "MIN_MULTISINE_SCALE", "ExcitationRecord", "decreasing_sine",
           "reversal_curves", "hysteresis_excitation", "multisine", "staircase", "excitation_set", "peak_slew", "around",
           "demagnetising_cycle", "demagnetising_record"]

#: Amplitude levels of the decreasing-amplitude sine (fractions of the full amplitude). The
#: 10 % level records the loops of the smallest scans (a 15 µm circle on a stage of
#: +-90 µm at the full amplitude): without it the model's loops below 20 % were extrapolated;
#: the 30 and 15 % levels record the loops of 15-30 µm scans on a +-55 µm stage, which the
#: fit otherwise draws between levels twice as far apart (``docs/identification.md``:
#: measured on two families of outside actuators). Every second level is held out. Smaller
#: levels turn back within the reversal detection's dead band
#: (:data:`hammerstein.identification._record_split.REVERSAL_BAND`, 5 % of the span) and
#: would be no level of their own.
LEVELS = (1.0, 0.8, 0.6, 0.4, 0.3, 0.2, 0.15, 0.1)
#: The standard reversal points of the first-order reversal curves (fractions of the full
#: amplitude; ``hammerstein excitation --reversals standard``): the curves from the amplitude
#: turn back up at these, their mirrors from minus the amplitude turn back down at minus these
#: (:func:`reversal_curves`). Not played by default: measured trade-offs in
#: ``docs/identification.md``.
REVERSALS = (0.8, 0.6, 0.4, 0.2, 0.0, -0.2, -0.4, -0.6, -0.8)
#: Peak slew of the reversal curves' moves, in multiples of the decreasing sine's ``2 pi f A``
#: (quasi-static still: a full-span move lasts ``1 / (6 f)``, 0.17 s at 1 Hz, against the
#: modes' milliseconds; the 18 curves and their traverses take 6 s, where the sine's own slew
#: would take 18 s and ``identify`` would read and simulate that much more).
CURVE_SLEW = 3.0
#: Voltage levels of the creep staircase (fractions of the full amplitude), after 0.
STAIRCASE_LEVELS = (0.5, 1.0, 0.5, 0.0, -0.5, -1.0, -0.5, 0.0)
#: With a slew rate, the default multisine band is narrowed rather than its amplitude scaled
#: below this fraction (:func:`excitation_set`): a multisine scaled to 3 % of 4 V left an
#: identified G with two poles the actuator does not have and a 7.7 % circle.
MIN_MULTISINE_SCALE = 0.25
#: The creep staircase of a range played around its middle (``excitation --range``), after
#: the amplifier's rest: fractions of the way from the rest to the range's far end.
UNIPOLAR_STAIRCASE = (0.25, 0.5, 0.75, 1.0, 0.75, 0.5, 0.25, 0.0)


def _check_positive(value, name, unit):
    problem = number_problem(value)
    if problem or not value > 0:
        raise ValueError(f"{name}: expected a positive number [{unit}], found {value!r}"
                         f"{f' ({problem})' if problem else ''}")
    v = float(value)
    if v > MAX_MAGNITUDE:
        raise ValueError(f"{name}: {v:g} {unit} is beyond the limit {MAX_MAGNITUDE:.0e}")
    return v


def _check_count(value, name):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name}: expected an integer >= 1, found {value!r}")
    return int(value)


def decreasing_sine(sampling_period, amplitude, frequency=1.0, levels=LEVELS, periods=2):
    """A sine whose amplitude steps down level by level.

    ``u(t) = a_k A sin(2 pi f t)`` during level k (``periods`` periods each),
    levels one after the other; ``u`` starts at 0 and each level ends at a
    zero crossing.

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float
        Full amplitude A [V].
    frequency : float
        f [Hz]; slow enough to be quasi-static (default 1 Hz).
    levels : sequence of float
        Fractions a_k of A, in (0, 1], strictly decreasing.
    periods : int
        Periods per level (>= 1; the first period of a level is its
        transient from the previous loop, the others are steady).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s]; ``n_samples = len(levels) * periods * round(1 / (f T))``.
    u : numpy.ndarray, shape (n_samples,)
        [V].
    level : numpy.ndarray, shape (n_samples,)
        Index k of the level of each sample.

    Raises
    ------
    ValueError
        On a non-positive period, amplitude or frequency, fewer than 8
        samples per period, or levels outside (0, 1] or not decreasing.

    Examples
    --------
    >>> t, u, k = decreasing_sine(1e-3, 10.0, frequency=1.0, levels=(1.0, 0.5), periods=2)
    >>> u.shape, round(float(u.max()), 6), round(float(u[k == 1].max()), 6)
    ((4000,), 10.0, 5.0)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    A = _check_positive(amplitude, "amplitude", "V")
    f = _check_positive(frequency, "frequency", "Hz")
    a = np.asarray(levels, dtype=float)
    if a.ndim != 1 or a.size == 0 or np.any(a <= 0) or np.any(a > 1) or np.any(np.diff(a) >= 0):
        raise ValueError(f"levels: expected strictly decreasing fractions in (0, 1], found {levels!r}")
    periods = _check_count(periods, "periods")
    per = 1.0 / (f * T)
    if per < 8:
        raise ValueError(f"frequency: {f:g} Hz gives {per:.3g} samples per period at T = {T:g} s; "
                         f"expected at least 8 (f <= {1 / (8 * T):g} Hz)")
    check_samples(a.size * periods * round(per), "frequency: the decreasing sine", ValueError, T)
    n_period = int(round(per))
    n_level = n_period * periods
    phase = np.sin(2 * np.pi * np.arange(n_level) / n_period)
    u = np.concatenate([A * ak * phase for ak in a])
    level = np.repeat(np.arange(a.size), n_level)
    return np.arange(u.size) * T, u, level


def _half_cosine_samples(distance, speed, T):
    """Samples of a half-cosine move over ``distance`` [V] whose peak slew is at most
    ``speed`` [V/s] (at least 2)."""
    return max(2, int(np.ceil(np.pi * distance / (2.0 * speed * T) - 1e-9)))    # never faster


def _half_cosine_weights(n):
    """The ``n`` weights of a half-cosine move after its start, up to 1."""
    return 0.5 - 0.5 * np.cos(np.pi * np.arange(1, n + 1) / n)


def _half_cosine(a, b, speed, T):
    """Samples after ``a`` up to ``b``: a half-cosine of peak slew at most ``speed`` [V/s]."""
    return a + (b - a) * _half_cosine_weights(_half_cosine_samples(abs(b - a), speed, T))


def reversal_curves(sampling_period, amplitude, frequency=1.0, reversals=REVERSALS):
    """First-order reversal curves from both ends of the range, starting and ending at 0 V.

    From 0 up to ``A``; then for each reversal point ``b_j``: down from ``A``
    to ``b_j A`` and back up to ``A`` (the ascending first-order reversal curve
    from ``b_j A``), down to ``-A``, up to ``-b_j A`` and back down to ``-A``
    (the mirrored curve), and up to ``A`` again (to 0 after the last point).
    Each move is a half-cosine whose peak slew is :data:`CURVE_SLEW` times the
    decreasing sine's, ``2 pi f A``. The two families alternate, so that the
    input's mean over each pair is 0: the creep is not driven to one side for
    seconds, as it is by one family after the other (2.5 s near ``+A``, then
    2.5 s near ``-A`` with the standard points).

    A decreasing-amplitude sine (:func:`decreasing_sine`) only turns back at
    its own centred levels: the Preisach plane is seen along those few lines,
    and the density between them (an off-centre loop, e.g. a raster between
    0 and 8 V) is interpolated. The reversal curves see it along a line per
    reversal point, from either end: the first-order reversal curves from
    which a Preisach density is identified (Mayergoyz [4], ch. 1; Hu & Ben
    Mrad [5]).

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float
        Full amplitude A [V].
    frequency : float
        f [Hz] of the decreasing sine (the moves' peak slew is :data:`CURVE_SLEW`
        ``* 2 pi f A`` [V/s]).
    reversals : sequence of float
        Reversal points b_j, fractions of A in (-1, 1), distinct.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    u : numpy.ndarray, shape (n_samples,)
        [V]; ``u[0] = 0``, and the next sample after the last would be 0 again
        (as :func:`decreasing_sine`, so that either can follow the other).
    curve : numpy.ndarray, shape (n_samples,)
        Index of the reversal curve of each sample: j for the curve from ``A``
        turning at ``b_j A``, ``n + j`` for its mirror from ``-A``; -1 on the
        moves between them.

    Raises
    ------
    ValueError
        On a non-positive period, amplitude or frequency, or reversal points
        outside (-1, 1) or repeated.

    References
    ----------
    .. [4] I. D. Mayergoyz, *Mathematical Models of Hysteresis and Their
       Applications*, Elsevier, 2003.
    .. [5] H. Hu and R. Ben Mrad, "On the classical Preisach model for
       hysteresis in piezoceramic actuators", Mechatronics 13(2), 85-94, 2003.

    Examples
    --------
    >>> t, u, j = reversal_curves(1e-3, 10.0, reversals=(0.5, -0.5))
    >>> float(u[0]), float(u.max()), float(u.min()), bool(-1e-2 < u[-1] < 0)
    (0.0, 10.0, -10.0, True)
    >>> sorted(round(float(u[j == k].min()), 6) for k in (0, 1))   # turning back up
    [-5.0, 5.0]
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    A = _check_positive(amplitude, "amplitude", "V")
    f = _check_positive(frequency, "frequency", "Hz")
    b = np.asarray(reversals, dtype=float)
    if b.ndim != 1 or np.any(~np.isfinite(b)) or np.any(np.abs(b) >= 1) \
            or np.unique(b).size != b.size:
        raise ValueError(f"reversals: expected distinct fractions in (-1, 1), found {reversals!r}")
    speed = CURVE_SLEW * 2 * np.pi * f * A
    travel = A * (4.0 * np.sum(1.0 - b) + 4.0 * b.size)   # per point: two curves, two traverses
    check_samples(np.pi * travel / (2.0 * speed * T) + 8 * b.size + 8,
                  "reversals: the first-order reversal curves", ValueError, T)
    parts, tags = [np.zeros(1)], [np.full(1, -1)]

    def move(a, c, tag):
        parts.append(_half_cosine(a, c, speed, T))
        tags.append(np.full(parts[-1].size, tag))
    move(0.0, A, -1)
    for j, bj in enumerate(b):
        move(A, bj * A, j)
        move(bj * A, A, j)
        move(A, -A, -1)
        move(-A, -bj * A, b.size + j)
        move(-bj * A, -A, b.size + j)
        move(-A, A if j < b.size - 1 else 0.0, -1)
    u, tag = np.concatenate(parts)[:-1], np.concatenate(tags)[:-1]
    return np.arange(u.size) * T, u, tag


def hysteresis_excitation(sampling_period, amplitude, frequency=1.0, levels=LEVELS,
                          reversals=(), periods=2):
    """The hysteresis record of one input: the decreasing sine, then the reversal curves.

    :func:`decreasing_sine` followed by :func:`reversal_curves` (none when
    ``reversals`` is empty), one continuous signal from 0 V: what
    ``hammerstein excitation`` writes as ``hysteresis-<input>.csv`` and what
    scenario identification tables play through their plant.

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float
        Full amplitude A [V].
    frequency : float
        f [Hz] of the sine (the curves' peak slew is :data:`CURVE_SLEW` times its
        ``2 pi f A``).
    levels : sequence of float
        The sine's amplitude levels (fractions of A, strictly decreasing).
    reversals : sequence of float
        Reversal points of the curves (fractions of A in (-1, 1), e.g.
        :data:`REVERSALS`); empty (the default): the sine alone.
    periods : int
        Periods per level of the sine.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    u : numpy.ndarray, shape (n_samples,)
        [V].

    Raises
    ------
    ValueError
        As :func:`decreasing_sine` and :func:`reversal_curves`.

    Examples
    --------
    >>> t, u = hysteresis_excitation(1e-3, 10.0, levels=(1.0, 0.5), reversals=(0.0,))
    >>> u.size > 4000, float(u[:4000].max()), float(u[4000:].min())
    (True, 10.0, -10.0)
    """
    _, u, _ = decreasing_sine(sampling_period, amplitude, frequency, levels, periods)
    if len(reversals):
        _, curves, _ = reversal_curves(sampling_period, amplitude, frequency, reversals)
        u = np.concatenate([u, curves])
    return np.arange(u.size) * float(sampling_period), u


def demagnetising_cycle(sampling_period, amplitude, frequency=2.0, periods=DEMAGNETISING_PERIODS,
                        rest=1.0):
    """Every input at once: a sine decaying linearly to 0 V, then a rest at 0 V.

    ``u_k(t) = A_k (1 - t / D) sin(2 pi f t)`` for ``0 <= t < D = periods / f``,
    then ``u = 0`` for ``rest`` seconds. Each period turns back a little inside
    the previous one, so the hysteresis memory of every input path is wiped
    from the full amplitude down to 0 (wiping-out property of Preisach
    hysteresis; the AC demagnetisation of ferroelectrics and magnets,
    Bertotti [3], Section 9.3): the state it leaves is the demagnetised state
    every model of :mod:`hammerstein.models` starts from, whatever the
    actuator did before. It starts and ends at 0 V; its largest slew is
    ``2 pi f A_k`` [V/s].

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : array_like, shape (m,)
        Starting amplitude per input [V] (the records' full amplitude).
    frequency : float
        f [Hz] (default 2 Hz).
    periods : int
        Periods of the decay (default 20: the amplitude falls by 5 % of A
        per period).
    rest : float
        Seconds at 0 V after the decay (the modes and the fast creep settle;
        default 1 s).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    u : numpy.ndarray, shape (m, n_samples)
        [V].

    Raises
    ------
    ValueError
        On a non-positive period, amplitude or frequency, fewer than 8
        samples per period or a negative rest (the message names the
        parameter).

    Examples
    --------
    >>> t, u = demagnetising_cycle(1e-3, [10.0, 5.0], frequency=2.0, periods=4, rest=0.5)
    >>> u.shape, float(u[:, 0].max()), float(abs(u[:, -500:]).max())
    ((2, 2500), 0.0, 0.0)
    >>> round(float(u[0].max()), 2), round(float(u[1].max()), 2)   # the first crest
    (9.38, 4.69)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    amp = np.atleast_1d(np.asarray(amplitude, dtype=float))
    if amp.ndim != 1 or amp.size == 0:
        raise ValueError(f"amplitude: expected one amplitude per input [V], found {amplitude!r}")
    amp = np.array([_check_positive(a, "amplitude", "V") for a in amp])
    f = _check_positive(frequency, "frequency", "Hz")
    periods = _check_count(periods, "periods")
    problem = number_problem(rest)
    if problem or not rest >= 0:
        raise ValueError(f"rest: expected a duration >= 0 [s], found {rest!r}")
    per = 1.0 / (f * T)
    if per < 8:
        raise ValueError(f"frequency: {f:g} Hz gives {per:.3g} samples per period at T = {T:g} s; "
                         f"expected at least 8 (f <= {1 / (8 * T):g} Hz)")
    n_decay = int(round(periods * per))
    n_rest = int(round(float(rest) / T))
    check_samples(n_decay + n_rest, "frequency: the demagnetising cycle", ValueError, T)
    k = np.arange(n_decay)
    one = (1.0 - k / n_decay) * np.sin(2 * np.pi * f * T * k)
    u = np.zeros((amp.size, n_decay + n_rest))
    u[:, :n_decay] = amp[:, None] * one
    return np.arange(u.shape[1]) * T, u


def demagnetising_record(sampling_period, amplitude, sine_frequency=1.0, centre=0.0,
                         slew_rate=None):
    """The ``demagnetise.csv`` of ``hammerstein excitation``: played before every record.

    :func:`demagnetising_cycle` at twice the decreasing sine's frequency (at most the 8
    samples per period it needs) from each input's full amplitude, then 1 s at rest. An
    input range centred elsewhere than 0 V (a unipolar amplifier) is cycled around its
    centre, reached from and left back to its rest value (the range's value nearest 0 V)
    by :func:`around`'s half-cosines. The state it leaves is the models' demagnetised
    initial state
    (:func:`hammerstein.models.demagnetisation.demagnetising_turning_points`).

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : array_like, shape (m,)
        Full amplitude per input [V].
    sine_frequency : float
        The decreasing sine's frequency [Hz] (default 1 Hz).
    centre : float or array_like, shape (m,)
        Centre of each input's range [V] (default 0).
    slew_rate : float, optional
        The amplifier's slew rate [V/s]; None: unlimited.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s].
    u : numpy.ndarray, shape (m, n_samples)
        [V], from the rest value back to it.

    Raises
    ------
    ValueError
        As :func:`demagnetising_cycle`, or a cycle steeper than ``slew_rate`` ("frequency:
        ...").

    Examples
    --------
    >>> t, u = demagnetising_record(1e-3, [10.0, 5.0])
    >>> u.shape, float(abs(u[:, -1000:]).max())          # 20 periods at 2 Hz, 1 s at rest
    ((2, 11000), 0.0)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    amp = np.atleast_1d(np.asarray(amplitude, dtype=float))
    centre = np.broadcast_to(np.asarray(centre, dtype=float), amp.shape)
    f_demag = min(2.0 * _check_positive(sine_frequency, "sine_frequency", "Hz"), 1 / (8 * T))
    if np.any(centre):          # around the middle of the range, from its rest and back
        rest = np.clip(0.0, centre - amp, centre + amp)
        _, u = demagnetising_cycle(T, amp, f_demag, rest=0.0)
        speed = 2 * np.pi * sine_frequency * float(np.max(amp))
        u = around(u, centre, rest, T, speed if slew_rate is None else min(speed, slew_rate))
        u = np.concatenate([u, np.repeat(rest[:, None], int(round(1.0 / T)), axis=1)], axis=1)
        t = np.arange(u.shape[1]) * T
    else:
        t, u = demagnetising_cycle(T, amp, f_demag)
    fast = max(peak_slew(row, T) for row in u)
    if slew_rate is not None and fast > slew_rate:
        raise ValueError(f"frequency: the demagnetising cycle steps at up to {fast:.4g} "
                         f"V/s, beyond the slew rate {slew_rate:g} V/s; expected a "
                         f"lower sine frequency")
    return t, u


def multisine(sampling_period, amplitude, f_min=10.0, f_max=None, period=None, periods=4, seed=0):
    """A random-phase multisine with a flat amplitude spectrum.

    ``u(t) = c sum_j cos(2 pi f_j t + phi_j)``, ``f_j = j / P`` for every
    multiple of ``1 / P`` in ``[f_min, f_max]``, phases ``phi_j`` uniform in
    [0, 2 pi) (seeded), scaled so that ``max |u| = amplitude``
    (Pintelon & Schoukens [1]).

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float
        Peak |u| [V].
    f_min : float
        Lowest excited frequency [Hz] (default 10 Hz).
    f_max : float, optional
        Highest excited frequency [Hz]; default half the Nyquist frequency
        ``1 / (4 T)``.
    period : float, optional
        Period P [s] (frequency resolution ``1 / P``); default ``1 / f_min``.
    periods : int
        Number of periods (>= 1).
    seed : int
        Seed of the phases (numpy ``default_rng``).

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s]; ``n_samples = periods * round(P / T)``.
    u : numpy.ndarray, shape (n_samples,)
        [V].
    frequencies : numpy.ndarray, shape (n_lines,)
        The excited frequencies f_j [Hz].

    Raises
    ------
    ValueError
        On a non-positive parameter, ``f_max`` at or above the Nyquist
        frequency, or no multiple of ``1 / P`` in the band.

    Examples
    --------
    >>> t, u, f = multisine(5e-5, 8.0, f_min=10.0, periods=2)
    >>> u.shape, round(float(abs(u).max()), 9), float(f[0]), float(f[-1])
    ((4000,), 8.0, 10.0, 5000.0)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    A = _check_positive(amplitude, "amplitude", "V")
    f_lo = _check_positive(f_min, "f_min", "Hz")
    f_hi = 0.25 / T if f_max is None else _check_positive(f_max, "f_max", "Hz")
    if f_hi >= 0.5 / T:
        raise ValueError(f"f_max: expected below the Nyquist frequency {0.5 / T:g} Hz, found {f_hi:g}")
    P = 1.0 / f_lo if period is None else _check_positive(period, "period", "s")
    periods = _check_count(periods, "periods")
    if P / T < 8:
        raise ValueError(f"f_min: a period of {P:g} s is {P / T:.3g} samples at T = {T:g} s; "
                         f"expected at least 8 (f_min <= {1 / (8 * T):g} Hz)")
    check_samples(periods * round(P / T), f"f_min, periods: {periods} periods of {P:g} s",
                  ValueError, T)
    n_period = int(round(P / T))
    df = 1.0 / (n_period * T)
    j = np.arange(max(1, int(np.ceil(f_lo / df - 1e-9))), int(np.floor(f_hi / df + 1e-9)) + 1)
    if j.size == 0:
        raise ValueError(f"f_min, f_max: no multiple of 1/period = {df:g} Hz in [{f_lo:g}, {f_hi:g}] Hz")
    phases = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, j.size)
    # sum_j cos(2 pi j k / N + phi_j) as one inverse real FFT: O(N log N), not O(N lines)
    spectrum = np.zeros(n_period // 2 + 1, dtype=complex)
    spectrum[j] = 0.5 * n_period * np.exp(1j * phases)
    one = np.fft.irfft(spectrum, n_period)
    one *= A / np.max(np.abs(one))
    u = np.tile(one, int(periods))
    return np.arange(u.size) * T, u, j * df


def staircase(sampling_period, amplitude, hold=2.0, levels=STAIRCASE_LEVELS):
    """Voltage steps held ``hold`` seconds each, starting from 0.

    Parameters
    ----------
    sampling_period : float
        T [s].
    amplitude : float
        Full amplitude A [V]; the steps go to ``a_k A``.
    hold : float
        Duration of each step [s] (default 2 s), the first one at 0 V.
    levels : sequence of float
        Fractions a_k of A in [-1, 1], after the initial 0.

    Returns
    -------
    time : numpy.ndarray, shape (n_samples,)
        [s]; ``n_samples = (len(levels) + 1) * round(hold / T)``.
    u : numpy.ndarray, shape (n_samples,)
        [V].
    step : numpy.ndarray, shape (n_samples,)
        Index of the step of each sample (0 = the initial 0 V).

    Raises
    ------
    ValueError
        On a non-positive parameter or a level outside [-1, 1].

    Examples
    --------
    >>> t, u, s = staircase(0.01, 10.0, hold=1.0, levels=(1.0, -1.0))
    >>> u.shape, float(u[0]), float(u[150]), float(u[-1])
    ((300,), 0.0, 10.0, -10.0)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    A = _check_positive(amplitude, "amplitude", "V")
    H = _check_positive(hold, "hold", "s")
    a = np.concatenate([[0.0], np.asarray(levels, dtype=float)])
    if a.ndim != 1 or np.any(np.abs(a) > 1):
        raise ValueError(f"levels: expected fractions in [-1, 1], found {levels!r}")
    check_samples(a.size * max(1.0, H / T), f"hold: {a.size} steps of {H:g} s", ValueError, T)
    n_hold = max(1, int(round(H / T)))
    step = np.repeat(np.arange(a.size), n_hold)
    return np.arange(step.size) * T, A * a[step], step


@dataclass(frozen=True)
class ExcitationRecord:
    """One excitation file: a time column and every input column.

    Parameters
    ----------
    name : str
        File stem, e.g. ``"hysteresis-ux"``.
    kind : str
        ``"hysteresis"``, ``"multisine"``, ``"multisine-validation"``, ``"creep"``
        or ``"demagnetise"`` (:func:`demagnetising_cycle`, every input).
    excited : int
        Index of the excited input (the others are 0); -1 when every input
        moves.
    time : numpy.ndarray, shape (n_samples,)
        [s].
    u : numpy.ndarray, shape (m, n_samples)
        [V].
    scale : float
        What a slew rate scaled the record down by (1: not scaled).
    f_max : float or None
        A multisine's highest line [Hz] (None for the other kinds).
    """

    name: str
    kind: str
    excited: int
    time: np.ndarray
    u: np.ndarray
    scale: float = 1.0
    f_max: float | None = None


def _ramp(a, b, speed, T):
    """Every input from ``a`` to ``b`` (arrays (m,)) by half-cosines over the same samples,
    the farthest move's peak slew ``speed`` [V/s]: (m, n), ``a`` not included."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    w = _half_cosine_weights(_half_cosine_samples(float(np.max(np.abs(b - a))), speed, T))
    return a[:, None] + np.outer(b - a, w)


def around(u, centre, rest, sampling_period, speed):
    """A record played around ``centre`` by an amplifier that rests at ``rest``.

    ``centre + u``, preceded by a half-cosine from ``rest`` to its first sample and followed
    by one back to ``rest``, each of peak slew ``speed`` (the ramps of the input with the
    farthest move; every input ramps over the same samples). With ``centre = rest = 0`` the
    record is returned as it is.

    Parameters
    ----------
    u : array_like, shape (m, n_samples)
        The record around 0 [V].
    centre, rest : array_like, shape (m,)
        The centre of each input's range, and where its amplifier rests [V] (the range's value
        nearest 0 V).
    sampling_period : float
        T [s].
    speed : float
        Peak slew of the ramps [V/s].

    Returns
    -------
    numpy.ndarray, shape (m, n_lead + n_samples + n_tail)
        [V], from ``rest`` (not included) back to ``rest`` (the last sample).

    Examples
    --------
    >>> v = around(np.zeros((1, 4)), [75.0], [0.0], 1e-3, 1000.0)
    >>> float(v[0, 0]) > 0, float(v[0].max()), float(v[0, -1])
    (True, 75.0, 0.0)
    """
    u = np.atleast_2d(np.asarray(u, dtype=float))
    c = np.broadcast_to(np.asarray(centre, dtype=float), (u.shape[0],))
    r = np.broadcast_to(np.asarray(rest, dtype=float), (u.shape[0],))
    if not np.any(c) and not np.any(r):
        return u
    first, last = c + u[:, 0], c + u[:, -1]
    T = float(sampling_period)

    return np.concatenate([_ramp(r, first, speed, T), c[:, None] + u,
                           _ramp(last, r, speed, T)], axis=1)


def peak_slew(u, sampling_period, periodic=False):
    """Largest ``|u[k] - u[k-1]| / T`` [V/s] of a record played from rest at 0 V.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        [V].
    sampling_period : float
        T [s].
    periodic : bool
        Also count the step from the last sample back to the first (one period of a
        periodic signal played again).

    Returns
    -------
    float

    Examples
    --------
    >>> peak_slew([0.0, 1.0, 3.0, 2.0], 0.5)
    4.0
    """
    u = np.asarray(u, dtype=float)
    steps = np.abs(np.diff(np.concatenate([[0.0], u, u[:1] if periodic else []])))
    return float(steps.max() / sampling_period) if steps.size else 0.0


def _from_rest(one, n_period):
    """The multisine's periods started at its sample nearest 0 V (a cyclic shift: the same
    spectrum, no step from rest)."""
    return np.tile(np.roll(one[:n_period], -int(np.argmin(np.abs(one[:n_period])))),
                   one.size // n_period)


def _slew_limited_multisine(one, n_period, T, slew_rate):
    """A multisine period started at its sample nearest 0 V (:func:`_from_rest`) and scaled
    down until it steps no faster than ``slew_rate`` [V/s]; (periods, scale)."""
    period = _from_rest(one[:n_period], n_period)
    scale = min(1.0, slew_rate / peak_slew(period, T, periodic=True))
    return np.tile(scale * period, one.size // n_period), scale


def _ramped_staircase(u, T, slew_rate):
    """A staircase whose steps are linear ramps at ``slew_rate`` [V/s] from each step's
    first sample (the hold shortened by the ramp)."""
    out = u.copy()
    edges = np.flatnonzero(np.diff(u)) + 1
    for e in edges:
        a, b = out[e - 1], u[e]
        n = int(np.ceil(abs(b - a) / (slew_rate * T)))
        end = min(u.size, e + n)
        out[e:end] = a + (b - a) * np.arange(1, end - e + 1) / n
    return out


def default_f_max(sampling_period):
    """The multisines' default highest frequency [Hz]: a quarter of the dynamics' rate.

    ``identify --dynamics`` fits the bending modes at the records' rate up to
    20 kHz, and decimates faster records near 10 kHz
    (:func:`hammerstein.models._lti_rate.decimation_factor`). The band
    ends at a quarter of that rate, ``1 / (4 q T)``: half the Nyquist
    frequency at 20 kHz and below, about 2.5 kHz above. Power beyond it is
    filtered out before the fit, and the signal-to-noise ratio at the
    modes falls with it (measured: 50 kHz records whose band reached
    12.5 kHz gave a held-out fit of 78.7 % against 96.1 % from the same
    actuator's 10 kHz records).

    Parameters
    ----------
    sampling_period : float
        T of the records [s].

    Returns
    -------
    float
        The band's top [Hz].

    Examples
    --------
    >>> default_f_max(5e-5), default_f_max(2e-5), default_f_max(1e-5)
    (5000.0, 2500.0, 2777.777777777778)
    """
    T = _check_positive(sampling_period, "sampling_period", "s")
    return 0.25 / (decimation_factor(T) * T)


def excitation_set(input_names, amplitude, sampling_period, sine_frequency=1.0, levels=LEVELS,
                   f_min=10.0, f_max=None, multisine_fraction=0.8, multisine_periods=4,
                   hold=2.0, seed=0, reversals=(), slew_rate=None, centre=0.0):
    """Every excitation record for m inputs, one input at a time.

    Per input k (the others at 0): the decreasing-amplitude sine
    (:func:`decreasing_sine`), followed by the first-order reversal curves
    (:func:`reversal_curves`) when ``reversals`` are given, in record
    ``hysteresis-<k>``, two multisines of
    independent phases at ``multisine_fraction`` of the amplitude
    (:func:`multisine`; ``multisine-<k>`` for estimation and
    ``multisine-<k>-validation``, held out to choose the order of the
    dynamics) and the staircase (:func:`staircase`, ``creep-<k>``).

    Parameters
    ----------
    input_names : sequence of str
        Names of the m inputs (column names).
    amplitude : float or array_like, shape (m,)
        Full amplitude per input [V].
    sampling_period : float
        T [s].
    sine_frequency : float
        Frequency of the decreasing-amplitude sine [Hz].
    levels : sequence of float
        Its amplitude levels (fractions).
    f_min, f_max : float
        Band of the multisines [Hz] (``f_max`` default: :func:`default_f_max`,
        ``1 / (4 T)`` at 20 kHz and below, about 2.5 kHz above).
    multisine_fraction : float
        Peak of the multisines as a fraction of the amplitude, in (0, 1].
    multisine_periods : int
        Periods per multisine record.
    hold : float
        Duration of a creep step [s].
    seed : int
        Seed of the multisine phases (input k, record r uses ``seed + 2 k + r``).
    reversals : sequence of float
        Reversal points of the first-order reversal curves (fractions of the
        amplitude, :func:`reversal_curves`, e.g. :data:`REVERSALS`); empty
        (the default): the decreasing sine alone.
    slew_rate : float, optional
        The amplifier's slew rate [V/s]. Every record then steps no faster,
        from rest: each multisine period starts at its sample nearest 0 V (a
        cyclic shift) and is scaled down as far as needed (the record's
        ``scale`` says by how much); with the default ``f_max`` the band is
        first narrowed, down to 4 ``f_min``, until the scale reaches
        :data:`MIN_MULTISINE_SCALE` (each multisine record's ``f_max``
        gives the band kept); the staircase's steps become ramps at
        that rate. A hysteresis record that would step faster is refused
        (lower ``sine_frequency``). Default None: no limit (the staircase
        steps in one sample; the multisines still start at their sample
        nearest 0 V, as every record starts from rest).
    centre : float or array_like, shape (m,)
        The middle of each input's range [V] (default 0: ``[-A, A]``); e.g. 75 V for a
        unipolar 0-150 V amplifier with ``amplitude`` 75. Every record is then played
        around it (:func:`around`): from the amplifier's rest, the range's value nearest
        0 V, to the record's first sample and back, at the decreasing sine's largest
        slew; the idle inputs stay at their rest.

    Returns
    -------
    list of ExcitationRecord
        Four records per input, in input order.

    Raises
    ------
    ValueError
        On bad parameters (the message names the parameter).

    Examples
    --------
    >>> recs = excitation_set(["ux", "uy"], 10.0, 5e-4, multisine_periods=1, hold=0.1)
    >>> [r.name for r in recs][:4]
    ['hysteresis-ux', 'multisine-ux', 'multisine-ux-validation', 'creep-ux']
    >>> recs[5].u.shape[0], float(abs(recs[5].u[0]).max()), float(abs(recs[5].u[1]).max())
    (2, 0.0, 8.0)
    """
    names = [str(n) for n in input_names]
    m = len(names)
    if m == 0 or len(set(names)) != m:
        raise ValueError(f"inputs: expected distinct names, found {names!r}")
    amp = np.broadcast_to(np.asarray(amplitude, dtype=float), (m,))
    if not (0 < float(multisine_fraction) <= 1):
        raise ValueError(f"multisine_fraction: expected in (0, 1], found {multisine_fraction!r}")
    S = None if slew_rate is None else _check_positive(slew_rate, "slew_rate", "V/s")
    mid = np.broadcast_to(np.asarray(centre, dtype=float), (m,))
    if not np.all(np.isfinite(mid)) or np.any(np.abs(mid) > MAX_MAGNITUDE):
        raise ValueError(f"centre: expected finite voltages [V], found {centre!r}")
    rest = np.clip(0.0, mid - amp, mid + amp)          # where each amplifier rests
    S_scaled = S
    if S is not None:
        # the files print 9 significant digits: two roundings of up to half a unit of the
        # largest voltage's decade may lengthen a multisine scaled onto the slew rate (its
        # steps 3.7e-9 V over 1 V per sample at 10 V): it is scaled onto the slew rate less that
        decade = 10.0 ** np.ceil(np.log10(max(float(np.max(np.abs(mid) + amp)), 1e-300)))
        S_scaled = max(S - 1e-8 * decade / float(sampling_period), 0.999 * S)
    out = []
    for k, name in enumerate(names):
        def full(t, one, kind, stem, k=k, scale=1.0, f_max=None):
            u = np.zeros((m, t.size))
            u[k] = one
            if np.any(mid) or np.any(rest):
                speed = 2 * np.pi * float(sine_frequency) * float(np.max(amp))
                if S is not None:
                    speed = min(speed, S)
                u = around(u, np.where(np.arange(m) == k, mid, rest), rest, sampling_period,
                           speed)
                t = np.arange(u.shape[1]) * float(sampling_period)
            out.append(ExcitationRecord(stem, kind, k, t, u, scale, f_max))
        t, one = hysteresis_excitation(sampling_period, amp[k], sine_frequency, levels, reversals)
        if S is not None and peak_slew(one, sampling_period) > S:
            raise ValueError(f"frequency: the hysteresis record of {name} steps at up to "
                             f"{peak_slew(one, sampling_period):.4g} V/s, beyond the slew rate "
                             f"{S:g} V/s; expected a lower sine frequency")
        full(t, one, "hysteresis", f"hysteresis-{name}")
        band = default_f_max(sampling_period) if f_max is None else f_max
        for r, suffix in enumerate(("", "-validation")):
            while True:
                t, one, lines = multisine(sampling_period, multisine_fraction * amp[k], f_min,
                                          band, periods=multisine_periods, seed=seed + 2 * k + r)
                scale = 1.0
                if S is None:       # from rest: a 3 V step at t = 0 otherwise (80 % of 10 V)
                    one = _from_rest(one, one.size // int(multisine_periods))
                    break
                one, scale = _slew_limited_multisine(one, one.size // int(multisine_periods),
                                                     float(sampling_period), S_scaled)
                top = float(lines[-1])
                # the default band narrowed (its slew falls with it) rather than the amplitude
                # below MIN_MULTISINE_SCALE, down to 4 f_min at most; a given f_max is kept
                if f_max is not None or r or scale >= MIN_MULTISINE_SCALE or top <= 4 * f_min:
                    break
                band = max(4.0 * f_min, top * max(0.5, scale / MIN_MULTISINE_SCALE))
            full(t, one, "multisine" + suffix, f"multisine-{name}{suffix}", scale=scale,
                 f_max=float(lines[-1]))
        if np.any(mid) or np.any(rest):
            # from the amplifier's rest to the range's far end and back, by quarters (steps
            # from rest, not ramps to the middle: the creep fit reads held steps)
            far = mid[k] + amp[k] if abs(mid[k] + amp[k] - rest[k]) >= abs(mid[k] - amp[k] - rest[k]) \
                else mid[k] - amp[k]
            t, one, _ = staircase(sampling_period, 1.0, hold, UNIPOLAR_STAIRCASE)
            one = rest[k] + (far - rest[k]) * one
            u = np.repeat(rest[:, None], t.size, axis=1)      # the idle inputs at rest
            u[k] = _ramped_staircase(one, float(sampling_period), S) if S is not None else one
            out.append(ExcitationRecord(f"creep-{name}", "creep", k, t, u))
            continue
        t, one, _ = staircase(sampling_period, amp[k], hold)
        if S is not None:
            one = _ramped_staircase(one, float(sampling_period), S)
        full(t, one, "creep", f"creep-{name}")
    return out
