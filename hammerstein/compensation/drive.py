"""Drive signals: the voltages to apply for a reference, within the amplifier's limits.

Length: about 980 lines: the drive of the scenarios (:func:`drive_signal`;
:class:`DriveStream` lives in :mod:`hammerstein.compensation.drive_stream`) and
of the hardware commands (:func:`hardware_drive`: fade-in, shaping, limits)
share the fade and start-up rules, kept in one place; the drive files and the
reference shaping are modules of their own.

:func:`drive_signal` is the one call from a reference to the input
voltages of any compensator (rate-independent kinds and the Hammerstein
compensator alike), as the scenarios compute them:

1. **fade-in from rest.** The reference is faded in from the rest output
   (0 µm) by the raised cosine ``w(t) = (1 - cos(pi t / t_f)) / 2`` over
   ``fade_samples`` samples (:func:`hammerstein.compensation.hammerstein_compensator.fade_in`;
   value and slope continuous at both ends). ``fade_samples = 0`` keeps a
   reference that already starts at rest as it is; the default
   (:func:`default_fade_samples`) is one period of the reference for a
   reference that does not start at rest (a circle starts at x = R, which
   a compensator would otherwise ask for in one sample) when the
   compensator inverts the dynamics or the amplifier has a slew rate.
2. **the compensator**, from rest. The Hammerstein compensator's ZPETC
   inverse reads the reference ``preview_samples`` ahead and is continued
   past the record's end (periodically for a periodic reference,
   :func:`hammerstein.compensation.hammerstein_compensator.continuation`), exactly
   as :meth:`HammersteinCompensator.run_reference` does.
3. **the amplifier's limits**
   (:class:`hammerstein.models.amplifier.Amplifier`): ``peak_input`` and
   ``peak_slew`` per input are measured on the commanded voltages; beyond the
   range or slew rate ``limits = "error"`` refuses, ``"warn"`` warns and
   ``"clip"`` does not, and both then clip and slew-limit the drive.

:class:`DriveStream` computes the same voltages chunk by chunk (a reference
read or generated in pieces): every chunk size gives the same numbers as
the whole record (``'stable'`` inversion excepted: it inverts the whole
record at once and is only run by :func:`drive_signal`).

The drive files themselves (:func:`read_signals`, :func:`signals_csv`,
:data:`DRIVE_MARK`, :func:`drive_fade_samples`) live in
:mod:`hammerstein.compensation.drive_files` and are re-exported here; the
reference shaping of :func:`hardware_drive` in
:mod:`hammerstein.compensation.shaping`.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from hammerstein.models.amplifier import Amplifier, drive_metrics, slew_limit
from hammerstein.compensation._repeat import REPEAT_SAMPLES, record_period, repeat_lag
from hammerstein.compensation.drive_result import DriveResult
from hammerstein.compensation.drive_stream import DriveStream, _fade_weights
from hammerstein.compensation.lookahead import rest_output
from hammerstein.compensation.lookahead import preactuation_samples, taper_preactuation
from hammerstein.compensation.drive_splice import keep_end, keep_start, learning_onset
from hammerstein.compensation.edge_holds import edge_hold_note, reference_at_rest
from hammerstein.compensation.shaping import shape_reference, time_intervals
from hammerstein.compensation.start_up import (at_rest_while_previewing, export_slew_words, settled_bound,
                                               start_up_in_reference)
from hammerstein.exceptions import CompensatorError, RangeWarning
from hammerstein.compensation.drive_files import (DRIVE_MARK, fade_weight, drive_fade_samples, read_signals,
                                                  signals_csv)

__all__ = ["DriveResult", "DriveStream", "drive_signal", "default_fade_samples",
           "starts_at_rest", "apply_amplifier", "hardware_drive", "shape_drive", "MIN_FADE_S",
           "FADE_DECAYS", "settled_step", "keep_start", "keep_end", "learning_onset",
           "drive_fade_samples", "limit_start_up", "ROUNDING_WORDS",
           "rest_output", "compensator_rest", "hardware_fade", "fade_weight", "read_signals", "signals_csv", "DRIVE_MARK"]

DriveStream.__module__ = __name__       # documented (and pickled) as this module's
DriveResult.__module__ = __name__


def starts_at_rest(reference, rest=None, atol=1e-9):
    """True when a reference starts at the rest output (its first sample at rest).

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    rest : array_like, shape (p,), optional
        Rest output [µm]; zeros by default.
    atol : float
        Tolerance [µm].

    Returns
    -------
    bool

    Examples
    --------
    >>> starts_at_rest([[0.0, 1.0], [0.0, 0.5]]), starts_at_rest([[2.0, 1.0]])
    (True, False)
    """
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    if r.shape[1] == 0:
        return True
    r0 = np.zeros(r.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    return bool(np.all(np.abs(r[:, 0] - r0) <= atol))


def default_fade_samples(reference, period_samples, settle_samples=None, compensator=None,
                         amplifier=None, sampling_period=None):
    """The default fade-in [samples]: one period for a reference that does not start at rest.

    The rule, for every compensator kind: 0 for a reference that starts at
    rest (0 µm); otherwise one period (at most ``settle_samples``) for a
    compensator that inverts the dynamics (the inverse would otherwise ask
    for a step of velocity, a spike of V) or when the amplifier has a
    finite slew rate (a rate-independent compensator would otherwise step
    its input from rest to the first sample's voltage, e.g. 9 V in one
    sample for a circle). A rate-independent compensator on a plant
    without a declared slew rate keeps its abrupt start (its ``peak_slew``
    metric shows the step), so results of existing scenarios do not change.
    With a slew rate, the ``sampling_period`` and a rate-independent
    compensator, the fade is doubled (beyond ``settle_samples`` if need
    be, up to the record's length) until the compensator's voltages during
    the fade-in never step faster than the slew rate, or than the period
    after the fade where the reference itself needs more (measured by
    running the compensator over the fade and one period, from rest).

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    period_samples : int
        One period of the reference [samples] (1 for a non-periodic record).
    settle_samples : int, optional
        At most this many (the samples the metrics skip).
    compensator : object, optional
        The compensator (one with ``run_reference`` inverts the dynamics);
        None: treated as inverting the dynamics.
    amplifier : hammerstein.models.amplifier.Amplifier, optional
    sampling_period : float, optional
        T [s], needed to hold the fade-in within the slew rate.

    Returns
    -------
    int

    Examples
    --------
    >>> import numpy as np
    >>> circle = np.vstack([np.cos(np.linspace(0, 6.28, 100)), np.sin(np.linspace(0, 6.28, 100))])
    >>> default_fade_samples(circle, 50), default_fade_samples(np.roll(circle, 25, axis=0), 50)
    (50, 50)
    >>> default_fade_samples(circle[::-1] * [[1], [0]], 50)         # starts at 0: no fade
    0
    """
    if starts_at_rest(reference):
        return 0
    inverts = compensator is None or hasattr(compensator, "run_reference")
    slew = amplifier is not None and any(np.isfinite(c.slew_rate) for c in amplifier.channels)
    if not (inverts or slew):
        return 0
    n = int(period_samples)
    n = n if settle_samples is None else int(min(n, settle_samples))
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    if not (slew and sampling_period and not inverts and hasattr(compensator, "simulate")):
        return n
    limit = np.array([c.slew_rate for c in amplifier.channels]) * float(sampling_period)
    rest = amplifier.rest_voltages()
    n = max(n, 1)
    while n < r.shape[1]:
        m = min(n + 1 + int(period_samples), r.shape[1])
        with warnings.catch_warnings():          # a probe: the case's own run warns
            warnings.simplefilter("ignore")
            u, _ = compensator.simulate(r[:, :m] * _fade_weights(0, m, n))
        if _fade_within_slew(u, n, rest, limit):
            break
        n = int(min(2 * n, r.shape[1]))
    return n


def _fade_within_slew(u, fade, rest, limit):
    """True when no step of the first ``fade + 1`` voltages (from rest) exceeds the slew limit
    [V per sample] or, where the reference itself needs more, the steps after the fade."""
    steps = np.abs(np.diff(np.concatenate([rest[:, None], u], axis=1), axis=1))
    after = np.max(steps[:, fade + 1:], axis=1) if steps.shape[1] > fade + 1 else 0.0
    return bool(np.all(np.max(steps[:, :fade + 1], axis=1) <= np.maximum(limit, after) * (1 + 1e-9)))


def drive_signal(compensator, reference, sampling_period, period_samples=None, fade_samples=None,
                 amplifier=None, limits="error", settle_samples=None, where=""):
    """The input voltages of a compensator for a reference, from rest, within the amplifier's limits.

    The voltages equal those of the scenario route (``hammerstein run``,
    timeseries ``<input>_V``) for the same compensator, reference and
    fade-in; the steps are listed in the module docstring.

    Parameters
    ----------
    compensator : object
        Any compensator of :mod:`hammerstein.compensation.compensators` or a
        :class:`~hammerstein.compensation.hammerstein_compensator.HammersteinCompensator`.
    reference : array_like, shape (p, n_samples)
        ``yr(t)`` [µm] at the sampling period, from t = 0.
    sampling_period : float
        T [s].
    period_samples : int, optional
        One period of a periodic reference [samples] (default fade length,
        continuation of the ZPETC preview).
    fade_samples : int, optional
        Fade-in from rest [samples]; default :func:`default_fade_samples`,
        doubled (up to the record's length) while the fade-in would step an
        input faster than the amplifier's slew rate.
    amplifier : Amplifier, optional
        The limits (e.g. ``plant.amplifier`` of a preset with an
        ``[amplifier]`` table); None: none.
    limits : {'error', 'warn', 'clip'}
        Reaction to a drive beyond the amplifier
        (:meth:`~hammerstein.models.amplifier.Amplifier.check`).
    settle_samples : int, optional
        Upper bound of the default fade.
    where : str
        Prefix of the limit messages (e.g. a case name).

    Returns
    -------
    DriveResult

    Raises
    ------
    AmplifierError
        ``limits = "error"`` and the drive exceeds the amplifier.
    CompensatorError
        A sampling period that is not a positive time, or a reference that
        is not (p, n_samples) with the compensator model's p outputs.
    CompensatorDivergence
        When the compensator diverges.

    Examples
    --------
    >>> from hammerstein import drive_signal
    >>> import numpy as np
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    >>> plant = load_plant("rakotondrabe-2dof", dynamics=False)
    >>> comp = InverseMultiplicativeCompensator(plant.hysteresis)
    >>> t = np.arange(2000) * plant.sampling_period
    >>> yr = 30 * np.vstack([np.cos(2 * np.pi * 10 * t), np.sin(2 * np.pi * 10 * t)])
    >>> d = drive_signal(comp, yr, plant.sampling_period, period_samples=2000, fade_samples=2000)
    >>> d.inputs.shape, bool(d.peak_slew.max() < 1e3)    # V/s: faded in, no step from rest
    ((2, 2000), True)
    >>> abrupt = drive_signal(comp, yr, plant.sampling_period, period_samples=2000, fade_samples=0)
    >>> bool(abrupt.peak_slew.max() > 1e5)               # V/s: 0 -> 6 V in one 50 µs sample
    True
    """
    r = _checked(compensator, reference, sampling_period)
    default = fade_samples is None
    if default:
        fade_samples = default_fade_samples(r, period_samples or 1, settle_samples, compensator,
                                            amplifier, sampling_period)
    fade_samples = int(min(max(int(fade_samples), 0), r.shape[1]))
    u, faded = _compensate(compensator, r, period_samples, fade_samples)
    if default and fade_samples and amplifier is not None:
        # the default never steps an input faster than the slew limit while fading in (or, where
        # the reference itself needs more, than after the fade): a fade too short for the first
        # voltages is doubled until it is not (or covers the record)
        limit = np.array([c.slew_rate for c in amplifier.channels]) * float(sampling_period)
        rest = amplifier.rest_voltages()
        while fade_samples < r.shape[1]:
            if _fade_within_slew(u, fade_samples, rest, limit):
                break
            fade_samples = int(min(2 * fade_samples, r.shape[1]))
            u, faded = _compensate(compensator, r, period_samples, fade_samples)
    peak, slew = drive_metrics(u, sampling_period)
    problems, out = [], u
    if amplifier is not None:
        problems = amplifier.check(u, sampling_period, limits, where)
        if problems:
            out, _ = amplifier.limit(u, sampling_period)
    return DriveResult(out, u, faded, peak, slew, fade_samples, problems)


def _checked(compensator, reference, sampling_period):
    """The reference as a (p, n) float array, after checking it and the sampling period."""
    T = sampling_period
    if isinstance(T, bool) or not isinstance(T, (int, float, np.number)) or not (
            np.isfinite(T) and T > 0):
        raise CompensatorError(f"sampling_period: expected a positive time [s], found {T!r}")
    r = np.asarray(reference, dtype=float)
    p = getattr(getattr(compensator, "model", None), "n_outputs", None)
    if r.ndim != 2 or r.shape[1] < 1 or (p is not None and r.shape[0] != p):
        raise CompensatorError(f"reference: expected shape ({p if p is not None else 'p'}, "
                               f"n_samples), one row per output [µm], found {r.shape}")
    return r


def _compensate(compensator, r, period_samples, fade_samples):
    """The compensator's voltages (m, N) and the faded reference (p, N) [µm], from rest."""
    if hasattr(compensator, "run_reference") and getattr(compensator, "inverse", 1) is None:
        lead, state, faded = compensator.start(r, period_samples, fade_samples)   # 'stable'
        u, _ = compensator.simulate(lead, state)
    else:
        stream = DriveStream(compensator, fade_samples, period_samples)
        u = np.concatenate([stream.push(r), stream.finish()], axis=1)
        faded = r * _fade_weights(0, r.shape[1], fade_samples) if fade_samples else r
    return u, faded


def apply_amplifier(amplifier: Amplifier | None, inputs, sampling_period):
    """What reaches the actuator from a drive: the amplifier's clip, slew limit and bandwidth.

    Parameters
    ----------
    amplifier : Amplifier or None
        None: the drive itself.
    inputs : array_like, shape (m, n_samples)
        [V].
    sampling_period : float
        T [s].

    Returns
    -------
    numpy.ndarray, shape (m, n_samples)
        [V].
    """
    if amplifier is None:
        return np.asarray(inputs, dtype=float)
    return amplifier.apply(inputs, sampling_period)[0]


#: Shortest default fade-in of the hardware commands [s]: 20 ms, ten periods of a 500 Hz first
#: mode (a fade is a duration, never a sample: a file reference has no period to fade over)
MIN_FADE_S = 0.02
#: the default fade-in of the hardware commands lasts at least this many decay times of the slowest
#: identified bending mode (:func:`hammerstein.compensation.shaping.mode_decay_s`), at most half
#: the record: the modes then follow the fade's envelope more closely and ring less at its end
#: (measured on outside actuators whose slowest mode decays in 15-19 ms: fades of 20-50 ms left
#: the mode ringing into the first periods after them, 0.13-0.17 % of a 30 µm circle at 100 Hz
#: once learnt, three times the settled error; with 59-78 ms, 0.085-0.145 %)
FADE_DECAYS = 4.0
#: relative tolerance of the step comparisons of :func:`hardware_drive`: a start-up stepping
#: faster than the settled drive by less does not grow the fade-in and is slew-limited without a
#: note (at 50 kHz a circle's start-up stepped 3e-6 more: its fade-in grew to a quarter of the
#: record, with advice for a longer record); no drive steps beyond the settled drive's largest
_STEP_TOL = 1e-3

#: ... and the relative excess of a start-up step over the settled drive's largest that is
#: slew-limited at all (below it, the drive is the compensator's own, bit for bit)
_LIMIT_TOL = 1e-6

#: A slew-limited start-up that moves the drive by more than this share of its peak, after
#: the fade-in, gets the advice of a longer fade (below it: a few nm, said in the header only).
START_UP_MOVE = 1e-4
#: The words of a start-up limit within :data:`_STEP_TOL`: said in the drive file's header,
#: for whoever compares it with an exported compensator, not on the console (half of the
#: family's 400 drives had one, moving the drive by 4e-8 to 2e-4 V). Not "rounding": up to
#: 1e-3 of the step, an outside stage's was 8.7e-4 (1.2e-5 of the drive)
ROUNDING_WORDS = "within 0.1 % of the settled step"


def settled_step(inputs, start):
    """The largest sample-to-sample step of a drive from ``start`` on, per input [V].

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        [V].
    start : int
        First sample of the settled part.

    Returns
    -------
    numpy.ndarray, shape (m,)
        ``max_k |u[k] - u[k-1]|`` over ``k > start``; ``inf`` when fewer
        than two samples remain (nothing to compare with).

    Examples
    --------
    >>> settled_step([[0.0, 5.0, 5.5, 6.5]], 1)
    array([1.])
    """
    u = np.atleast_2d(np.asarray(inputs, dtype=float))
    if u.shape[1] - int(start) < 2:
        return np.full(u.shape[0], np.inf)
    return np.max(np.abs(np.diff(u[:, int(start):], axis=1)), axis=1)


def _initial_hold(reference):
    """The number of first samples at which every output equals its first [samples]."""
    r = np.atleast_2d(reference)
    still = np.all(np.abs(r - r[:, :1]) <= 1e-9 * max(1.0, float(np.max(np.abs(r)))), axis=0)
    return int(np.argmin(still)) if not still.all() else r.shape[1]


def _start_steps(u, end, rest):
    """Largest step per input of samples ``0 .. end - 1``, the first counted from ``rest``."""
    head = np.concatenate([rest[:, None], u[:, :max(int(end), 1)]], axis=1)
    return np.max(np.abs(np.diff(head, axis=1)), axis=1)


def shape_drive(amplifier, inputs, sampling_period, unit="V"):
    """A drive shaped into the amplifier's range and slew rate, and where and by how much.

    The shaping is the amplifier's own range clip then slew limit
    (:meth:`~hammerstein.models.amplifier.Amplifier.limit`, from rest): a
    clipped sample steps less than the commanded one
    (``|clip(a) - clip(b)| <= |a - b|``) and the slew limit bounds every
    step by ``S T``, so the shaped drive is within the range, starts from
    rest and never steps faster than the slew rate.

    Parameters
    ----------
    amplifier : Amplifier
        The limits (e.g. measured on the identification records).
    inputs : array_like, shape (m, n_samples)
        The commanded drive [V].
    sampling_period : float
        T [s].
    unit : str
        The drive's unit, the model's input unit (``HammersteinPlant.units[0]``): the notes'.

    Returns
    -------
    shaped : numpy.ndarray, shape (m, n_samples)
        [V].
    notes : list of str
        One per input that was changed: the largest change [``unit``], the share
        of samples changed and the time intervals, e.g. ``"ux: beyond the
        range [-10, 10] V by up to 1.93 V, 3.1 % of the samples
        (0.0210-0.0233 s, ...)"``.
    """
    u = np.atleast_2d(np.asarray(inputs, dtype=float))
    out, _ = amplifier.limit(u, sampling_period)
    notes = []
    for i, c in enumerate(amplifier.channels):
        diff = np.abs(out[i] - u[i])
        changed = diff > 1e-9 * max(1.0, float(np.max(np.abs(u[i]))) if u.shape[1] else 1.0)
        if not np.any(changed):
            continue
        beyond = (u[i] > c.high) | (u[i] < c.low)
        what = []
        if np.any(beyond):
            what.append(f"beyond the range [{c.low:.4g}, {c.high:.4g}] {unit} by up to "
                        f"{float(np.max(np.maximum(u[i] - c.high, c.low - u[i]))):.3g} {unit}")
        if np.any(changed & ~beyond):
            what.append(f"faster than {c.slew_rate:.4g} {unit}/s")
        notes.append(f"{amplifier.inputs[i]}: {' and '.join(what)}, changed by up to "
                     f"{float(diff.max()):.3g} {unit} on {100 * np.mean(changed):.3g} % of the samples "
                     f"({time_intervals(changed, sampling_period)})")
    return out, notes


def hardware_fade(reference, fade_samples, rest=None, lead=None):
    """The hardware commands' fade-in: a tenth of it at rest, then :func:`fade_weight`.

    ``yr_f[k] = rest + w[k] (yr[k] - rest)`` with ``w = 0`` for ``k < L =
    fade // 10``, ``w = fade_weight((k - L) / (fade - L))`` up to ``fade``,
    1 after; the first ``L`` samples exactly at rest, so a compensator that
    reads the reference ahead (the ZPETC preview, shorter than ``L``) also
    starts exactly at rest.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    fade_samples : int
        The fade-in, rest lead included [samples] (0: none).
    rest : array_like, shape (p,), optional
        The output at rest [µm]; zeros by default.
    lead : int, optional
        The samples at rest [samples], less than ``fade_samples``; ``fade_samples // 10``
        by default (longer for a stable inversion's pre-actuation, :func:`hardware_drive`).

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)

    Examples
    --------
    >>> np.round(hardware_fade([[2.0] * 12], 10)[0], 3).tolist()
    [0.0, 0.0, 0.008, 0.095, 0.347, 0.76, 1.24, 1.653, 1.905, 1.992, 2.0, 2.0]
    """
    r = np.array(reference, dtype=float, ndmin=2)
    n = int(min(max(int(fade_samples), 0), r.shape[1]))
    if n == 0:
        return r
    r0 = np.zeros(r.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    lead = n // 10 if lead is None else int(min(max(int(lead), 0), n - 1))
    k = np.arange(n) - lead
    w = fade_weight(k / (n - lead))
    r[:, :n] = r0[:, None] + w * (r[:, :n] - r0[:, None])
    return r


def compensator_rest(model, compensator):
    """The output a compensator maps to 0 V [µm]: where its reference fades in from.

    A compensator that inverts the actuator's creep (the Hammerstein compensator built
    with it, its ``creep``) starts its creep inverse settled: the hysteresis model's
    output at 0 V times the creep's static gain (:func:`rest_output`). A static gain
    ``U = K^-1 (Yr - c)`` (its ``centre``) maps its centre to 0 V. The other kinds invert
    the hysteresis alone: the hysteresis model's output at 0 V. Faded in from another
    point (the creep's settled output for a kind that does not invert creep), the drive
    would start away from 0 V; ``compensate``, the exported C and the FMU start there.

    Parameters
    ----------
    model : object
        The hysteresis model (as :func:`rest_output`).
    compensator : object

    Returns
    -------
    numpy.ndarray, shape (p,)
        [µm].

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from hammerstein.io.presets import load_plant
    >>> model = load_plant("rakotondrabe-2dof", dynamics=False).hysteresis
    >>> compensator_rest(model, SimpleNamespace(centre=np.array([1.0, 2.0]))).tolist()
    [1.0, 2.0]
    """
    creep = getattr(compensator, "creep", None)
    centre = getattr(compensator, "centre", None)
    if creep is None and centre is not None:
        return np.array(centre, dtype=float)
    return rest_output(model, creep)


def hardware_drive(compensator, reference, sampling_period, period_samples=None,
                   fade_samples=None, amplifier=None, limits="error", where="", rest=None,
                   first_mode=None, predict=None, names=None, mode_decay=None, rest_lead=None,
                   shape=True, input_names=None, progress=None, input_unit="V",
                   output_unit="µm"):
    """The drive a hardware command writes: faded in over a duration, shaped into the limits.

    Every compensator kind and every reference (inline or file) gets the
    same rules, on top of :func:`drive_signal`:

    1. **the fade-in is a duration.** The default starts at
       ``max(one period, MIN_FADE_S, FADE_DECAYS mode_decay)`` (a file
       reference without ``--period`` has no period: the other two; the
       modes' term at most half the record), also for a
       reference that starts at rest (its first velocity is faded in too),
       and is doubled (up to the record's length) until no step of the
       drive before the end of the fade plus one period (from rest)
       exceeds the settled drive's own largest step after it
       (:func:`settled_step`; steps beyond the slew rate that the settled
       drive takes too are the reference's, shaped in 2.);
       the reference is faded in from the model's output at rest
       (``rest``) by :func:`hardware_fade`, whose first tenth is at rest, so
       the drive starts at rest. The doubling stops at a
       quarter of the record. A start-up that still steps faster than the
       settled drive (an axis held away from rest beside a moving one) is
       corrected in the reference when ``predict`` is given
       (:func:`hammerstein.compensation.start_up.start_up_in_reference`:
       the drive stays the compensator's for the reference returned, which
       the exported C reproduces); after the limits (2.), what is left is
       slew-limited to the settled drive's largest step over the whole
       record (which the settled drive never needs; ``shaped`` says so). With limits measured on the
       records, such a start-up is first shaped in the reference instead
       (a raster's first line step, which the fade ends on: the settled
       drive's largest step taken as the slew rate), so the slew limit
       has nothing left to change.
    2. **the limits.** An amplifier whose limits were measured on the
       identification records (``source = "records"``) first shapes the
       reference where the drive would leave them
       (:func:`hammerstein.compensation.shaping.shape_reference`; the
       compensator is run again on the shaped reference), then the drive
       (:func:`shape_drive`: range clip, slew limit, the notes say where
       and by how much); the amplifier's own limits react as ``limits``
       says (:meth:`~hammerstein.models.amplifier.Amplifier.check`).

    Parameters
    ----------
    compensator : object
        Any compensator (see :func:`drive_signal`).
    reference : array_like, shape (p, n_samples)
        [µm], from t = 0.
    sampling_period : float
        T [s].
    period_samples : int, optional
        One period of a periodic reference [samples]; None or 1 for none.
    fade_samples : int, optional
        A given fade-in [samples] (used as it is); None for the default above.
    amplifier : Amplifier, optional
    limits : {'error', 'warn', 'clip'}
        For an amplifier's own limits.
    where : str
        Prefix of the limit messages.
    rest : array_like, shape (p,), optional
        The fade's start [µm] (:func:`compensator_rest`); zeros by default.
    first_mode : float, optional
        The identified dynamics' first bending mode [Hz] (for the reference
        shaping: :func:`hammerstein.compensation.shaping.first_mode_hz`).
    predict : callable, optional
        ``predict(inputs) -> outputs (p, n_samples)`` [µm], the model from
        rest, for the reference shaping's range stage.
    names : sequence of str, optional
        Output names for the shaping notes.
    input_names : sequence of str, optional
        Input names for the start-up notes (default the amplifier's).
    mode_decay : float, optional
        The identified bending modes' longest decay time [s]
        (:func:`hammerstein.compensation.shaping.mode_decay_s`), for the
        default fade-in; None (no modes) leaves it out.
    rest_lead : int, optional
        With a given ``fade_samples``: its first samples at rest (a drive file's
        ``rest_lead``, so that ``learn`` fades as ``compensate`` did); a tenth by default.
        The default fade-in lengthens its rest lead, by :func:`preactuation_samples`, until
        a stable inversion's drive starts within ``FIRST_SAMPLE_TOLERANCE`` of rest.
    shape : bool
        Shape the reference into limits measured on the records (stage 2., default);
        False keeps the reference and only shapes the drive into them
        (:func:`shape_drive`): ``learn``'s reference, already shaped, plus a learnt
        correction that may step a little beyond the slew rate.
    progress : callable, optional
        ``progress(line)``, called with a short description as each pass of the
        compensator over the whole reference starts (the fade-in's doubling and the
        shaping each run it again): a long reference's wait, said.
    input_unit : str
        The drive's unit, the model's (a preset's ``input_unit``), in every note and problem
        that gives voltages (the edges held, the shaping, the start-up, the limits).
    output_unit : str
        The reference's unit, the model's (a preset's ``output_unit``), in the notes that
        give outputs (the reference shaped or corrected).

    Returns
    -------
    DriveResult
        ``shaped`` lists the shaping notes; ``reference`` the faded
        reference the drive was computed for, itself shaped where the
        drive would leave limits measured on the records
        (:func:`hammerstein.compensation.shaping.shape_reference`: a
        raster's line steps and corners smoothed below the first mode, a
        range the amplifier does not reach limited to what it reaches).

    Raises
    ------
    AmplifierError
        ``limits = "error"``, an amplifier's own limits exceeded.
    CompensatorDivergence
        When the compensator diverges.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    >>> plant = load_plant("rakotondrabe-2dof", dynamics=False)
    >>> comp = InverseMultiplicativeCompensator(plant.hysteresis)
    >>> t = np.arange(4000) * plant.sampling_period
    >>> yr = 30 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    >>> d = drive_signal(comp, yr, plant.sampling_period, 200, fade_samples=0)
    >>> h = hardware_drive(comp, yr, plant.sampling_period, 200)
    >>> h.fade_samples * plant.sampling_period >= MIN_FADE_S, float(h.inputs[0, 0])
    (True, 0.0)
    >>> bool(np.max(np.abs(np.diff(h.inputs))) <= np.max(np.abs(np.diff(d.inputs[:, 400:]))) * 1.001)
    True
    """
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    N = r.shape[1]
    T = float(sampling_period)
    P = int(period_samples) if period_samples and int(period_samples) > 1 else 0
    u_rest = amplifier.rest_voltages() if amplifier is not None else None
    y_rest = np.zeros(r.shape[0]) if rest is None else np.asarray(rest, dtype=float)

    passes = []
    preview = int(getattr(compensator, "preview_samples", 0) or 0)
    # the compensator's look-ahead past the end: the given period, else the record's own
    # (a file holding a pattern several times over), else an extrapolation
    repeat = P or record_period(r) or 0

    def pass_over(ref, why):
        passes.append(why)
        if progress is not None:
            progress(f"pass {len(passes)} over the {N} samples ({why})")
        ext = _periodic_tail(ref, r, repeat, preview or 1)
        if at_rest_while_previewing(ref, preview):   # as the exported C: its law starts there
            u = _compensate(compensator, ext[:, preview:], repeat or None, 0)[0][:, :N - preview]
            rest0 = np.zeros(u.shape[0]) if u_rest is None else u_rest
            return np.concatenate([np.repeat(rest0[:, None], preview, axis=1), u], axis=1)
        return _compensate(compensator, ext, repeat or None, 0)[0][:, :N]

    def run(fade, lead=None):
        faded = hardware_fade(r, fade, y_rest, lead)
        return pass_over(faded, f"fade-in {fade * T:.4g} s"), faded

    grown = None
    if fade_samples is None:
        n = int(min(max(P, int(np.ceil(MIN_FADE_S / T - 1e-9)), 1), N))
        if mode_decay is not None:
            n = max(n, int(min(np.ceil(FADE_DECAYS * mode_decay / T - 1e-9), N // 2)))
        hold = _initial_hold(r)
        if not P and hold * T >= MIN_FADE_S:
            # a reference that does not repeat and first holds still (a move, then a hold): the
            # fade ends with the hold, so that the move is judged and bounds the start-up (faded
            # over it, the move was slew-limited to the later hold's steps, 17 V/s, and the drive
            # never reached the target)
            n = min(n, hold)
        # grown past the hold, the fade would take the move in again: the start-up is then
        # slew-limited to the move's steps instead (limit_start_up below)
        cap, n0 = (n if not P and hold * T >= MIN_FADE_S else max(n, N // 4)), n
        while True:
            u, faded = run(n)
            end = min(n + max(P, 1), N)
            # not the slew rate: steps beyond it that the settled drive takes too are the reference's
            # (a raster's corners), shaped in 2.; no fade shortens them (one grew to 25 % of a scan)
            bound = settled_bound(u, end)
            r0 = np.zeros(u.shape[0]) if u_rest is None else u_rest
            if n >= cap or np.all(_start_steps(u, end, r0) <= bound * (1 + _STEP_TOL)):
                break
            n = int(min(2 * n, cap))
        grown = (n0, n, n >= cap) if n > n0 else None
        extra = preactuation_samples(compensator, u, u_rest, n, N)
        if extra:       # a stable inversion acting before the reference moves: a longer rest
            rest_lead, n = n // 10 + extra, n + extra
            u, faded = run(n, rest_lead)
    else:
        n = int(min(max(int(fade_samples), 0), N))
        u, faded = run(n, rest_lead)
    notes, limited, range_limited = [], False, False
    if amplifier is not None and amplifier.from_records and shape:
        def drive_for(ref):
            # a trial of the shaping, not the user's reference: blended towards what a clipped
            # drive reaches, it leaves the model's range where the law does not converge, and
            # each trial repeated the range warning of values the reference never had (five
            # lines of 76-85 µm for a +-10 µm sine); the user's reference was checked above
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RangeWarning)
                return pass_over(ref, "the reference shaped into the records' limits")

        sr = shape_reference(drive_for, faded, amplifier, T, first_mode, predict, P or None, names,
                             fade_samples=n, units=(input_unit, output_unit))
        u, faded, notes = sr.inputs, sr.reference, sr.notes
        limited, range_limited = sr.limited, sr.range_limited
        if fade_samples is None:     # a start-up stepping faster than the settled drive: shaped too
            u, faded, more = _shape_start_up(drive_for, u, faded, amplifier, T, n, P,
                                             first_mode, predict, names, (input_unit, output_unit))
            notes += more
    if fade_samples is None and predict is not None:
        # a start-up still stepping faster than the settled drive (a held axis's fade to
        # mid-range): corrected in the reference, so that the drive stays the compensator's for
        # the reference written (the exported C fed it reproduces it); limit_start_up below
        # slew-limits only what the correction leaves
        u, faded, more, corrected = _start_up_reference(
            pass_over, u, faded, n, P, u_rest, predict, T, names,
            input_names or (amplifier.inputs if amplifier is not None else None),
            (input_unit, output_unit))
        notes += more
    else:
        corrected = 0
    untapered = u                # the taper moves the first samples: what they were, kept
    u, _ = taper_preactuation(u, u_rest, n // 10 if rest_lead is None else rest_lead)
    peak, top = drive_metrics(u, T)
    res = DriveResult(u, u, faded, peak, top, n, shaped=notes,
                      rest_lead=None if rest_lead is None or rest_lead == n // 10 else rest_lead,
                      limited=limited, range_limited=range_limited)
    if u is not untapered:
        res.start_offset = untapered[:, 0] - (np.zeros(u.shape[0]) if u_rest is None else u_rest)
        res.taper_change = float(np.max(np.abs(u - untapered)))
    if fade_samples is None and grown:    # what the metrics leave out, said (a raster's lines)
        res.notes.append(f"the fade-in was lengthened from {grown[0] * T:.4g} s to "
                         f"{grown[1] * T:.4g} s, {100 * grown[1] / N:.3g} % of the record, "
                         f"excluded from the metrics, for a start-up no faster than the settled "
                         f"drive" + (" (a quarter of the record at most)" if grown[2] else ""))
    r0 = np.zeros(u.shape[0]) if u_rest is None else u_rest
    out = u
    if amplifier is not None and amplifier.from_records:
        out, more = shape_drive(amplifier, u, T, input_unit)
        res.shaped += more
    elif amplifier is not None:
        res.problems = amplifier.check(u, T, limits, where, input_unit)
        if res.problems:
            out, _ = amplifier.limit(u, T)
    if fade_samples is None:        # a start-up no fade removes: slew-limited to the settled bound
        before = out
        out, notes = limit_start_up(out, n, P, r0, input_names or (
            amplifier.inputs if amplifier is not None else None), T, input_unit)
        if notes:       # the limit the exported C needs to give this drive too
            notes[-1] += export_slew_words(before, out, min(n + max(P, 1), N), T, amplifier)
        res.shaped += notes
        # moved by more than START_UP_MOVE of the drive's peak: the start-ups limited by a
        # hair (0.1-0.2 % of the settled step asked beyond it) moved circles' drives by
        # 1e-5 to 4e-4 V of 3.5-6 V, a few nm, and were advised a fade three times as long
        # or a longer record; a held axis's start-up moves volts
        moved = max(1e-12, START_UP_MOVE * float(np.max(np.abs(before), initial=0.0)))
        changed = np.flatnonzero(np.any(np.abs(out - before) > moved, axis=0))
        last = int(changed[-1]) + 1 if changed.size else 0
        if max(last, corrected) > n:
            # a large move the settled drive never makes (an axis held away from rest under a
            # raster): its start-up, slew-limited or corrected in the reference, goes on after
            # the fade, into what is judged
            late = max(last, corrected) * T
            how = ("slew-limited start-up" if last >= corrected else
                   "start-up corrected in the reference")
            advice = np.ceil(2.5 * late / 0.01) * 0.01
            why = "a fade whose steepest step, 2.4 times its mean, stays within the settled drive's"
            fix = (f"give --fade-in {advice:.2g} or more (fade_in={advice:.2g} from Python; "
                   f"{why})" if advice <= 0.5 * N * T else
                   f"a fade-in that long ({advice:.2g} s, {why}) would take "
                   f"{100 * advice / (N * T):.3g} % of the {N * T:.4g} s record: give a longer "
                   f"record (more periods) with --fade-in {advice:.2g}, or a reference that "
                   f"starts at rest")
            res.notes.append(
                f"the {how} reaches the drive {late:.4g} s after the start, "
                f"{late - n * T:.3g} s after the {n * T:.4g} s fade-in: the metrics from the "
                f"fade's end include it; {fix}")
    # no limit left, output short; on the rest edge too where the reference is away from rest
    edge = edge_hold_note(out, amplifier, n, T, r0, input_unit, reference_at_rest(faded, y_rest))
    if edge:
        res.notes.append(edge)
    res.inputs = out
    return res


def _periodic_tail(ref, original, period_samples, preview):
    """``ref`` (p, N) followed by the periods of ``original`` (p, N) that follow its end, where
    a correction of ``ref`` early in the record (a start-up corrected, shaped) hid its repeat.

    The compensator continues a periodic record past its end from the record itself
    (:func:`~hammerstein.compensation._repeat.repeat_lag`: the last 8 samples one or more
    periods earlier). When ``ref`` ends as ``original`` does but repeats nowhere
    (the correction reaches back to every lag tested: a 340 Hz circle at 10 kHz, whose
    samples repeat every 500, corrected over its first 1305 of 1765), the continuation
    fell back on a quadratic extrapolation and the drive's last sample stepped 2.43 V where
    the settled drive steps 0.07 V. Returned as it is otherwise.
    """
    if not period_samples or ref is original:
        return ref
    K = REPEAT_SAMPLES
    N = ref.shape[1]
    if N < K or not np.array_equal(ref[:, N - K:], original[:, N - K:]) \
            or repeat_lag(ref, period_samples, preview) is not None:
        return ref
    lag = repeat_lag(original, period_samples, 1)
    if lag is None:
        return ref
    reps = -(-max(preview, 1) // lag)          # whole repeats covering the look-ahead
    tail = original[:, N - lag + np.arange(reps * lag) % lag]
    return np.concatenate([ref, tail], axis=1)


#: Relative change of the reference below which :func:`_shape_start_up` counts a sample as unshaped.
_SHAPE_TOL = 1e-9


def _shape_start_up(run, u, faded, amplifier, T, fade, P, first_mode, predict, names,
                    units=("V", "µm")):
    """Reference shaping against the settled drive's own largest step (the start-up's bound).

    The settled part (one period after the fade on) never steps more than
    ``S`` per sample, so shaping with the slew rate ``S / T`` changes only
    what steps more: the start-up (e.g. a raster's first line step, which
    the default fade-in ends on). Returns ``(u, faded, notes)``, unchanged
    when the start-up is within the bound, and unchanged as well when the
    shaping would change the reference after the start-up (the settled
    part, which is judged): the start-up is then slew-limited by
    :func:`limit_start_up` instead (measured on an outside
    generalised-PI actuator: a 15 µm circle at 20 Hz was shaped by up to
    2.9 µm on 95 % of its samples, 21 % of the radius left). ``units``: the model's
    (input, output) units, the notes'.
    """
    N = u.shape[1]
    end = min(fade + max(P, 1), N)
    bound = settled_bound(u, end)
    rest = amplifier.rest_voltages()
    start = _start_steps(u, end, rest)
    if not np.any(start > bound * (1 + _STEP_TOL)) or not np.all(np.isfinite(bound) & (bound > 0)):
        return u, faded, []
    tight = Amplifier([replace(c, slew_rate=min(c.slew_rate, b / T))
                       for c, b in zip(amplifier.channels, bound)], amplifier.inputs,
                      amplifier.source)
    sr = shape_reference(run, faded, tight, T, first_mode, predict, P or None, names,
                         fade_samples=fade, units=units)
    if not sr.changed:
        return u, faded, []
    moved = np.abs(np.asarray(sr.reference) - faded) > _SHAPE_TOL * max(1.0, float(np.max(np.abs(faded))))
    if np.any(moved[:, end:]):
        # the shaping reached into the settled part (a drive whose settled steps are small, e.g. a
        # slow circle, shaped over most of the record): what is judged is not changed for the
        # start-up's sake; limit_start_up slew-limits the start-up of the drive instead
        return u, faded, []
    why = "the drive left the limits measured on the records"
    notes = [n.replace(why, "the start-up stepped faster than the settled drive") for n in sr.notes]
    return sr.inputs, sr.reference, notes


def _start_up_reference(pass_over, u, faded, n, P, u_rest, predict, T, names, input_names,
                        units=("V", "µm")):
    """:func:`~hammerstein.compensation.start_up.start_up_in_reference` for :func:`hardware_drive`:
    ``(u, faded, notes, end)``, ``end`` the first sample of the reference left as it was;
    unchanged (no notes, ``end`` 0) when the start-up keeps within the settled steps.
    ``units``: the model's (input, output) units, the note's."""
    iu, ou = units
    end = min(n + max(P, 1), u.shape[1])
    r0 = np.zeros(u.shape[0]) if u_rest is None else np.asarray(u_rest, dtype=float)
    u2, ref, asked, bound, _, changed = start_up_in_reference(
        lambda x: pass_over(x, "the start-up corrected in the reference"), u, faded, n, end,
        r0, predict, _LIMIT_TOL)
    if not changed:
        return u, faded, [], 0
    left = np.max(np.abs(np.diff(np.concatenate([r0[:, None], u2[:, :end]], axis=1), axis=1)),
                  axis=1)
    by = np.max(np.abs(ref - faded), axis=1)
    outs = ", ".join(f"{names[j] if names is not None else f'output {j + 1}'} by up to "
                     f"{by[j]:.3g} {ou}" for j in range(ref.shape[0]) if by[j] > 0)
    ins = ", ".join(f"{input_names[i] if input_names is not None else f'input {i + 1}'} "
                    f"{asked[i]:.3g} {iu} per sample asked, {left[i]:.3g} {iu} left"
                    for i in range(u.shape[0]) if asked[i] > bound[i] * (1 + _LIMIT_TOL))
    moved = np.flatnonzero(np.any(ref != faded, axis=0))
    late = int(moved[-1]) + 1
    return u2, ref, [f"the start-up corrected in the reference ({outs}, until {late * T:.4g} s) "
                     f"for a drive that steps no faster than the "
                     f"settled drive ({ins + '; ' if ins else ''}the settled drive's largest step "
                     + ", ".join(f"{b:.3g}" for b in bound) + f" {iu}), the drive the compensator's "
                     "for the reference written"], late


def limit_start_up(inputs, fade_samples, period_samples=None, rest=None, names=None,
                   sampling_period=None, unit="V"):
    """A drive whose start-up never steps faster than its settled part, and what was changed.

    The settled part starts one period (one sample without a period) after
    the fade-in. Per input whose start-up (the first step counted from
    ``rest``) has a step larger than the settled part's largest, ``S``, the
    whole record is slew-limited to ``S`` per sample
    (:func:`hammerstein.models.amplifier.slew_limit`): the settled part,
    whose steps are at most ``S``, is changed only while the limiter
    catches up.

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        [V].
    fade_samples : int
    period_samples : int, optional
    rest : array_like, shape (m,), optional
        The voltages before the first sample [V]; zeros by default.
    names : list of str, optional
        Input names for the notes.
    sampling_period : float, optional
        T [s], for the notes.
    unit : str
        The drive's unit, the model's input unit (``HammersteinPlant.units[0]``): the notes'.

    Returns
    -------
    limited : numpy.ndarray, shape (m, n_samples)
    notes : list of str

    Examples
    --------
    >>> u, notes = limit_start_up([[0.0, 3.0, 3.5, 3.0, 2.5, 3.0]], 1)
    >>> u.tolist()
    [[0.0, 0.5, 1.0, 1.5, 2.0, 2.5]]
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    N = u.shape[1]
    P = int(period_samples) if period_samples and int(period_samples) > 1 else 1
    r0 = np.zeros(u.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    end = min(int(fade_samples) + P, N)
    bound = settled_bound(u, end)
    start = _start_steps(u, end, r0)
    notes = []
    for i in np.flatnonzero((start > bound * (1 + _LIMIT_TOL)) & (bound > 0)):
        # an excess is limited (no step of the drive beyond the settled drive's largest), and
        # said even when within _STEP_TOL (rounding: 3e-6 at 50 kHz): the drive then departs
        # from the compensator's voltages, which an exported compensator fed the reference
        # gives (a bender's 50 Hz sine: 1.1e-5 V at one sample, 6e-6 over, said nowhere)
        before = u[i].copy()
        u[i] = slew_limit(u[i], r0[i], bound[i])
        name = names[i] if names is not None else f"input {i + 1}"
        when = f" {int(fade_samples) * sampling_period:g} s" if sampling_period else ""
        over = start[i] / bound[i] - 1
        moved = np.abs(u[i] - before)
        # the samples that moved beyond rounding (1e-16 V counted: '9 sample(s)' where one moved),
        # and where: the limit acts over the fade-in and the period after it
        hit = np.flatnonzero(moved > 1e-12 * max(1.0, float(np.max(np.abs(before)))))
        at = (f"{hit.size} sample(s)" + (f", from sample {hit[0]}" + (
            f" (t = {hit[0] * sampling_period:.4g} s)" if sampling_period else "") if hit.size else ""))
        if over > _STEP_TOL:
            # what the exported C (fed the reference, not limited) differs by: said with the
            # limit (a user compared them and found 1e-4 V at three samples, said nowhere)
            notes.append(f"{name}: the start-up (the{when} fade-in and one period) slew-limited to the "
                         f"settled drive's largest step, {bound[i]:.3g} {unit} per sample "
                         f"({start[i]:.3g} {unit} asked, {100 * over:.3g} % more): the drive "
                         f"differs from the compensator's by up to {moved.max():.2g} {unit} at {at}")
            continue
        notes.append(f"{name}: the start-up (the{when} fade-in and one period) slew-limited to the settled "
                     f"drive's largest step, {bound[i]:.6g} {unit} per sample ({over:.2g} of it more "
                     f"asked, {ROUNDING_WORDS}): the drive differs from the compensator's by up to "
                     f"{moved.max():.2g} {unit} at {at}")
    return u, notes
