"""The notes ``hammerstein learn`` prints on how it learns (behind :mod:`hammerstein.cli.learn`).

The Q filter's default cut-off and why, the harmonics left unlearnt at an
anti-resonance, a ``--period`` learnt sample by sample, a noise margin that
is mostly a drift over the periods, and the inputs a trial's drive holds on
their range's edge: each one line, from the plant, the reference's period
and the trial's error.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.edge_holds import edge_holds, reference_at_rest
from hammerstein.compensation.ilc import INVERSE_GAIN_LIMIT, inverse_gain_ratio, period_drift
from hammerstein.compensation.shaping import first_mode_hz

__all__ = ["Q_CUTOFF_MIN_HZ", "Q_CUTOFF_PER_MODE", "Q_CUTOFF_NO_DYNAMICS_HZ", "DRIFT_RATIO",
           "default_q_cutoff", "held_inputs"]


#: Lowest default cutoff of the learning's Q [Hz] and its multiple of the first bending mode.
Q_CUTOFF_MIN_HZ, Q_CUTOFF_PER_MODE = 1000.0, 2.5
#: The default cutoff [Hz] when the model has no identified dynamics (its modes unknown): half
#: of 200 Hz, below which piezo stages' first bending modes rarely lie (commonly 250-600 Hz)
Q_CUTOFF_NO_DYNAMICS_HZ = 100.0


def default_q_cutoff(plant):
    """The default cutoff of the learning filter Q [Hz] and the note that says why.

    Q must pass the harmonics of the reference that the bending modes
    amplify: a circle's hysteresis residual has harmonics at every multiple
    of its frequency, and the ones near the first two modes (up to 1.2 times
    the first in the outside family) are what is left after the feedforward.
    ``max(1000 Hz, 2.5 f_1)`` with ``f_1`` the lowest oscillatory mode of
    the actuator's linear part (:func:`~hammerstein.compensation.shaping.first_mode_hz`),
    at most 0.45 times the sampling rate. Measured on four outside
    actuators (30 µm at 100 Hz, 10 trials, first modes 313-580 Hz): 500 Hz
    left 0.25-0.98 % of the radius (the 6th-7th harmonics at a 580/659 Hz
    pair of modes never learnt), this rule 0.13-0.31 %.

    A model without identified dynamics (``identify`` without ``--dynamics``,
    ``plant.dynamics`` None) does not know the actuator's modes: the
    learning cannot tell them from the hysteresis, and a harmonic learnt at
    or above the first mode (whose phase turns the correction the wrong
    way) grows from trial to trial. The default is then
    :data:`Q_CUTOFF_NO_DYNAMICS_HZ` (100 Hz, half the lowest first mode
    piezo stages commonly have), and the line is a ``warning:``. Per
    harmonic at gain 0.5, with the order-2 Q, a harmonic on a mode of
    damping 0.03 grows at most 1.11 times per trial on a 200 Hz mode, 1.02 on a
    250 Hz one and 1.01 on a 380 Hz one (8.4, 8.4 and 4.8 times with a
    1000 Hz cutoff). Measured on a two-axis stage with modes at 380/450 Hz
    (20 µm circle at 50 Hz): 1000 Hz diverged to 71 % of the radius by trial
    4; at 100 Hz (``--delay 0``) it ended at 1.02 % in nine trials.

    Parameters
    ----------
    plant : HammersteinPlant
        With ``matrices`` (the discrete linear part), ``sampling_period``
        [s] and ``dynamics`` (None: none identified; an object without the
        attribute counts as identified).

    Returns
    -------
    cutoff : float
        [Hz].
    note : str
        One line, ``note: Q cutoff ... because ...``, or without identified
        dynamics ``warning: Q cutoff ...`` naming the remedies.
    """
    T = plant.sampling_period
    if getattr(plant, "dynamics", True) is None:
        cutoff = min(Q_CUTOFF_NO_DYNAMICS_HZ, 0.45 / T)
        return cutoff, (f"warning: Q cutoff {cutoff:.4g} Hz: the model has no identified "
                        f"dynamics, so it does not know the actuator's bending modes, and "
                        f"learning at or above the first one can diverge (piezo stages' first "
                        f"modes lie commonly at 250-600 Hz, rarely below 200 Hz); identify "
                        f"--dynamics to learn up to {Q_CUTOFF_PER_MODE:g} x the first mode, or "
                        f"give --q-cutoff-hz below your actuator's first mode")
    matrices = getattr(plant, "matrices", None)
    f1 = first_mode_hz(matrices[0], T) if matrices else None
    cutoff = Q_CUTOFF_MIN_HZ if f1 is None else max(Q_CUTOFF_MIN_HZ, Q_CUTOFF_PER_MODE * f1)
    wanted = cutoff
    cutoff = min(cutoff, 0.45 / T)
    why = ("the actuator has no oscillatory mode" if f1 is None else
           f"the harmonics the modes amplify are learnt up to {Q_CUTOFF_PER_MODE:g} x the first "
           f"bending mode's damped frequency {f1:.4g} Hz (natural frequency "
           f"{first_mode_hz(matrices[0], T, natural=True):.4g} Hz, as identify and compensate "
           f"name it), and never below {Q_CUTOFF_MIN_HZ:g} Hz")
    if cutoff < wanted:
        why += (f", capped at 0.45 x the sampling rate {1 / T:.4g} Hz (that rule asked "
                f"{wanted:.4g} Hz, beyond what the samples hold)")
    return cutoff, f"note: Q cutoff {cutoff:.4g} Hz because {why} (--q-cutoff-hz sets it)"


def _anti_resonance_note(ilc, period_samples, sampling_period, q_cutoff_hz, unit="µm"):
    """The note naming the harmonics below the Q cutoff left unlearnt at an anti-resonance;
    ``unit``: the model's output unit (``HammersteinPlant.units[1]``), the note's."""
    P = int(period_samples)
    fh = np.arange(1, P // 2 + 1) / (P * sampling_period)
    fh = fh[fh <= q_cutoff_hz]
    if not fh.size:
        return None
    ratio = inverse_gain_ratio(ilc.dynamics, fh, sampling_period)
    out = fh[ratio > INVERSE_GAIN_LIMIT]
    if not out.size:
        return None
    return (f"note: {out.size} harmonic(s) at {out.min():.4g}-{out.max():.4g} Hz not learnt: "
            f"the identified dynamics pass them at less than 1/{INVERSE_GAIN_LIMIT:g} of their "
            f"static gain (an anti-resonance: up to {ratio.max():.3g} times the drive per {unit}), "
            f"where a correction would make the drive chatter")


#: Inline reference kinds whose period is ``1 / frequency``.
PERIODIC_KINDS = ("circle", "sine", "triangle")


def _period_note(period, period_samples, sampling_period, steady, n_samples=None, fade=0,
                 frequency=None):
    """The note saying why a periodic reference is learnt in the time domain, or None.

    Which of the reasons :func:`~hammerstein.compensation.ilc.repeating_from`
    has it is: a period of no whole number of samples, fewer than five
    periods after the fade-in (``n_samples`` and ``fade`` [samples] given),
    or a file that does not repeat. ``period`` [s] is a CSV reference's
    ``--period``; ``frequency`` [Hz] an inline reference's (a 150 Hz circle
    at 20 kHz, 133.33 samples a period, was learnt sample by sample with
    only a header line to say so, its true error rising on trials 3, 6 and
    10 while each trial printed "monotonic").
    """
    inline = period is None and frequency is not None and frequency > 0
    if inline:
        period = 1.0 / float(frequency)
    if period is None or period_samples is None or steady is not None:
        return None
    exact = float(period) / sampling_period
    start = max(int(fade), int(period_samples))    # where repeating_from looks from
    left = None if n_samples is None else (int(n_samples) - start) / period_samples
    what = "the reference" if inline else "the file"
    if abs(exact - round(exact)) > 1e-6:
        whole = max(round(exact), 2)
        given = (f"{frequency:g} Hz is a period of {exact:.6g} sampling periods" if inline else
                 f"--period {period:g} s is {exact:.6g} sampling periods")
        like = (f"{1.0 / (whole * sampling_period):.6g} Hz ({whole} samples)" if inline else
                f"{whole * sampling_period:g} s")
        return (f"note: learnt sample by sample, not per harmonic of the period: {given}, not "
                f"a whole number: {what} does not repeat every {period_samples} samples (a "
                f"period of a whole number of samples, e.g. {like}, repeats exactly); the "
                f"settled error of such a learning can rise from one trial to the next")
    if left is not None and left < 5:
        return (f"note: learnt sample by sample, not per harmonic of the period: {what} holds "
                f"{max(left, 0):.3g} periods after the {start * sampling_period:.4g} s fade-in, "
                f"fewer than the five the harmonics need (a fade-in compensate lengthened is in "
                f"the drive file's header): give more periods, or a shorter --fade-in")
    return (f"note: learnt sample by sample, not per harmonic of the period: {what} does not "
            f"repeat every {period_samples} samples after the fade-in")


#: periods spread by more than this times what a slow trend leaves: the margin's "noise" is drift
DRIFT_RATIO = 2.0


def _drift_note(error, period, steady, unit="µm"):
    """The note when the noise margin is mostly a slow drift over the periods (0 or 1 line).

    ``error`` (p, n) [µm] aligned on the measurement delay; the spread of its
    periods from ``steady`` on is what the margin takes for noise
    (:func:`_judged_error`); :func:`hammerstein.compensation.ilc.period_drift`
    tells a drift (creep, a transient still settling) from noise. ``unit``: the model's
    output unit (``HammersteinPlant.units[1]``), the note's.
    """
    drift = period_drift(error, period, steady)
    if drift is None or drift[0] <= DRIFT_RATIO * drift[1]:
        return []
    return [f"note: the noise margin is mostly drift: the settled periods spread "
            f"{drift[0]:.2g} {unit} RMS about their average, {drift[1]:.2g} {unit} once a slow trend "
            f"over the periods is taken out; that trend (creep or a transient still settling, "
            f"the same in every trial) does not repeat from period to period, so learning per "
            f"period cannot remove it"]


def held_inputs(inputs, amplifier, fade, reference, rest_output, names, unit="V"):
    """The inputs a drive holds on their range's edge after the fade-in, in words, or None.

    A rest edge (a unipolar stage's 0 V) counts where the reference is away from the rest
    output (:func:`hammerstein.compensation.edge_holds.reference_at_rest`).

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        The drive [``unit``].
    amplifier : hammerstein.models.amplifier.Amplifier or None
    fade : int
        The fade-in [samples].
    reference : array_like, shape (p, n_samples)
        The faded reference the drive aims at [µm].
    rest_output : array_like, shape (p,)
        [µm].
    names : sequence of str
        The input names.
    unit : str

    Returns
    -------
    str or None
        E.g. ``"vy holds 0 V (its rest) on 8.2 % of the samples after the fade-in"``.

    Examples
    --------
    >>> from hammerstein.models.amplifier import Amplifier, AmplifierChannel
    >>> amp = Amplifier([AmplifierChannel(0.0, 100.0)], ["vy"])
    >>> held_inputs([[0.0, 0.0, 40.0, 0.0, 0.0]], amp, 1, [[0.0, 5.0, 9.0, 5.0, 0.0]], [0.0],
    ...             ["vy"])
    'vy holds 0 V (its rest) on 50 % of the samples after the fade-in'
    """
    if amplifier is None:
        return None
    n = np.asarray(inputs).shape[1]
    at_rest = reference_at_rest(np.asarray(reference, dtype=float)[:, :n], rest_output)
    rest = amplifier.rest_voltages()
    held = edge_holds(inputs, amplifier, fade, rest, at_rest)
    return "; ".join(f"{names[i]} holds {edge:g} {unit}"
                     f"{' (its rest)' if edge == rest[i] else ''} on {100 * on.mean():.3g} % of "
                     f"the samples after the fade-in" for i, edge, on in held) or None
