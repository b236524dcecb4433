"""How ``hammerstein learn --history`` judges a trial against the best one (behind :mod:`hammerstein.cli.learn`).

One trial is one of:

* **out of step**: its lag behind the model's prediction of the drive
  (cross-correlation, :func:`trial_lag`, as ``evaluate`` estimates it) is not
  the delay the errors are aligned on: a trigger that fired early or late,
  or an acquisition whose latency changed. Its error says nothing about the
  drive; it is not learnt from, and it does not count as the actuator
  getting worse (the gain is left as it was);
* **a re-measurement of the best drive** (``--drive`` the best trial's
  drive, e.g. ``best-trial.csv`` when learning resumes the next day): its
  error replaces the best's; when it is worse beyond the noise the best
  was stale (the actuator changed since: drift, temperature): the trial is
  learnt from at full gain;
* **worse than the best** beyond the noise: not learnt from; the next drive
  is learnt again from the best one with half the gain. When that drive,
  the best plus a small correction, is itself worse beyond the noise,
  either the best is stale (the actuator drifted since) or the learning
  diverges at this gain (a mode above Q's reach, a gain too high): only the
  best drive measured again tells them apart, so the next drive is the best
  trial's drive itself, unchanged (``remeasure``). Measured again, worse
  beyond the noise: the best was stale (above: the trial replaces it, full
  gain; a drifting actuator otherwise locked the learning on a best it
  could no longer reach). Within the noise: the best stands and the
  learning diverges at this gain: it goes on from that measurement with
  the gain halved for good (``diverges``). Declaring the best stale at once
  locked in a divergence on an unchanged stage whose modes Q passed: 5.3 %
  of the radius to 71 % in four trials;
* **accepted** (learnt from): the halvings of the worse trials before it
  are undone; a trial of a repeating reference not below the best, within
  the noise, has reached the noise, and its gain is halved (a decreasing
  gain at the noise floor).

The gain never falls below ``0.5 ** MAX_HALVINGS`` times ``--learning-gain``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hammerstein.compensation.ilc import estimate_delay
from hammerstein.compensation.shaping import delay_search_span

__all__ = ["MAX_HALVINGS", "NOISE_FLOOR_RATIO", "REMEASURE_AFTER", "LAG_TOLERANCE", "LAG_PHASE_DEG", "Verdict", "gain_factor",
           "trial_lag", "lag_tolerance", "lag_problem", "lag_advice", "judge_trial"]

#: the gain is halved at most this many times in all (a floor of 1/16 of --learning-gain)
MAX_HALVINGS = 4
#: a trial not below the best within the noise has reached the noise only when its judged
#: error is within this many noise margins; above, it stalls (either way its gain is halved): a
#: warm stage's 20 Hz circle judged 0.7386 against the best's 0.7382 um, 7.7 margins of
#: 0.096 um, was said to have "reached the noise" while its true error still fell
NOISE_FLOOR_RATIO = 3.0
#: this many worse trials in a row: the next drive is the best's own, to measure it again
REMEASURE_AFTER = 2
#: a trial whose lag differs from the one expected by more than this many samples is out of step
LAG_TOLERANCE = 1
#: ... on a first trial (no earlier lag known), a model's phase error at the reference's
#: fundamental up to this many degrees is no change of lag (realistic-2dof: 3.6 deg at 10 Hz)
LAG_PHASE_DEG = 4.0


def gain_factor(halvings, rejections=0):
    """The factor of ``--learning-gain`` after ``halvings + rejections`` halvings, floored.

    Parameters
    ----------
    halvings : int
        Halvings at the noise floor.
    rejections : int
        Trials rejected in a row since the last one learnt from.

    Returns
    -------
    float
        ``0.5 ** min(halvings + rejections, MAX_HALVINGS)``.

    Examples
    --------
    >>> gain_factor(1, 1), gain_factor(9, 3)
    (0.25, 0.0625)
    """
    return 0.5 ** min(int(halvings) + int(rejections), MAX_HALVINGS)


def trial_lag(predicted, measured, reference, period_samples, sampling_period):
    """Samples the measurement lags the model's prediction of the drive (may be negative).

    The cross-correlation of :func:`hammerstein.compensation.ilc.estimate_delay`
    searched within :func:`hammerstein.compensation.shaping.delay_search_span`
    of the reference, as ``learn --delay auto`` and ``evaluate`` estimate it.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        The model's response to the drive and the measurement [µm].
    reference : numpy.ndarray, shape (p, N)
        The faded reference [µm] (sets the search span).
    period_samples : int
        The reference's period [samples] (1 or 0: none).
    sampling_period : float
        T [s].

    Returns
    -------
    int
    """
    return int(estimate_delay(predicted, measured, delay_search_span(
        reference, period_samples, sampling_period)))


def lag_tolerance(expected_offset, period_samples):
    """Samples a trial's lag may differ from the one expected (:func:`lag_problem`).

    Parameters
    ----------
    expected_offset : int or None
        ``lag - delay`` of the last trial learnt from, None on a first trial.
    period_samples : float
        The period of the reference's fundamental [samples] (given by
        ``--period``, or found from the reference itself,
        :func:`hammerstein.signals.fundamental.reference_fundamental`);
        0 or 1: none known.

    Returns
    -------
    int
        ``LAG_TOLERANCE`` against an earlier trial; on a first trial
        ``LAG_PHASE_DEG`` of the fundamental, rounded up, at least that.
    """
    if expected_offset is not None or not period_samples or period_samples <= 1:
        return LAG_TOLERANCE
    return max(LAG_TOLERANCE, math.ceil(float(period_samples) * LAG_PHASE_DEG / 360.0))


def lag_problem(lag, delay, expected_offset, period_samples, source, sampling_period=None):
    """The line saying a trial is out of step, or None.

    Parameters
    ----------
    lag : int
        The trial's lag (:func:`trial_lag`) [samples].
    delay : int
        The delay the errors are aligned on [samples].
    expected_offset : int or None
        ``lag - delay`` of the last trial learnt from (the model's phase
        error at the reference, the same from trial to trial), None when
        no earlier trial is known (then a tolerance of ``LAG_PHASE_DEG`` of
        the reference's fundamental, :func:`lag_tolerance`).
    period_samples : float
        The period of the reference's fundamental [samples] (0 or 1: none).
    source : str
        Where ``delay`` comes from (``"the model's delay"``, ``"--delay"``).
    sampling_period : float, optional
        T [s]: the line names the fundamental in Hz.

    Returns
    -------
    str or None
        A measurement that leads the prediction (``lag < 0``) is not called a
        latency: no acquisition answers before it is driven.
    """
    offset = int(lag) - int(delay)
    first = expected_offset is None
    off = offset if first else offset - int(expected_offset)
    tol = lag_tolerance(expected_offset, period_samples)
    if abs(off) <= tol:
        return None
    since = ("" if first or expected_offset == 0 else
             f" (the trials learnt from lagged {int(delay) + int(expected_offset)})")
    if first and period_samples and period_samples > 1:
        fund = (f"{1.0 / (float(period_samples) * float(sampling_period)):.4g} Hz "
                if sampling_period else "")
        within = (f"; a first trial may be off by {tol} samples, {LAG_PHASE_DEG:g} deg of the "
                  f"reference's {fund}fundamental (a model's phase error)")
    elif first:
        within = (f"; a first trial may be off by {tol} sample(s): no period of the reference "
                  f"is known (--period)")
    else:
        within = ""
    if lag < 0:
        return (f"leads the model's prediction by {-int(lag)} samples, {source} is {delay}{since}: "
                f"no latency (an acquisition does not answer before it is driven): a record "
                f"triggered after the drive started, or a phase lead of the model's error at "
                f"the reference{within}")
    # a record that starts S samples late reads S samples ahead: its lag is S less
    when = "early" if off > 0 else "late"
    return (f"lags {lag} samples, {source} is {delay}{since}: a trigger or latency change "
            f"(the record starts {abs(off)} samples {when}, or the acquisition's latency "
            f"changed){within}")


def lag_advice(lag, expected_offset, period_given):
    """What helps a trial :func:`lag_problem` refused (the end of its line).

    Parameters
    ----------
    lag : int
        The trial's lag [samples].
    expected_offset : int or None
        As for :func:`lag_problem`.
    period_given : bool
        ``--period`` was given.

    Returns
    -------
    str
        ``--delay N`` only with the N that aligns the trial (a latency,
        ``>= 0``); for a lead on a first trial, ``--period`` (the
        tolerance is a share of the fundamental) or the dynamics.
    """
    new = int(lag) - int(expected_offset or 0)
    text = "check that the record starts with the drive and measure it again"
    if new >= 0:
        return text + f"; when the acquisition's latency really changed, give --delay {new}"
    text += " (--delay cannot align a lead: it is a latency, an integer >= 0)"
    if expected_offset is None:
        text += ("; when the record does start with the drive, the model's phase error at the "
                 "reference is beyond a first trial's tolerance: "
                 + ("" if period_given else "give --period S when the reference's period is "
                    "longer than that of the fundamental above, or ")
                 + "identify the dynamics again (identify --dynamics)")
    return text


@dataclass
class Verdict:
    """What ``learn`` does with a trial (:func:`judge_trial`).

    Attributes
    ----------
    from_best : bool
        The next drive is learnt from the best trial's files, not this trial's.
    best : bool
        This trial becomes the best (its files replace ``best-trial.csv``).
    halvings, rejections : int
        The state after this trial (noise-floor halvings; worse trials in a row).
    note : str or None
        The line when this trial is not learnt from.
    stall : str or None
        The line when the gain is halved at the noise floor.
    info : str or None
        The line when the best is replaced by a re-measurement or found stale.
    reset : bool
        The per-harmonic gains start afresh (the actuator changed).
    restored : int
        Halvings of the per-harmonic gains undone (a trial accepted after rejections).
    halve : bool
        The per-harmonic gains are halved (a worse trial, or the noise reached).
    remeasure : bool
        The next drive is the best trial's drive itself, unchanged (not
        learnt): the next trial measures it again.
    diverges : bool
        The best drive measured again is within the noise of its stored
        error: the best stands, and the learning diverges at the gain it had.
    """

    from_best: bool = False
    best: bool = True
    halvings: int = 0
    rejections: int = 0
    note: str | None = None
    stall: str | None = None
    info: str | None = None
    reset: bool = False
    restored: int = 0
    halve: bool = False
    remeasure: bool = False
    diverges: bool = False


def judge_trial(state, k, score, best_score, margin, worse, better, remeasured, repeating,
                what, judged_text, out_of_step=None, advice=None, q_cutoff_hz=None,
                first_mode_hz=None, unit="µm", held=None):
    """The verdict on trial ``k`` against the history's best (module docstring).

    Parameters
    ----------
    state : dict
        The history's state (``trial``, ``halvings``, ``rejections``).
    k : int
        This trial's number.
    score, best_score, margin : float
        This trial's and the best's judged errors, the noise margin [``unit``].
    worse, better : bool
        Worse than the best beyond the noise; below the best.
    remeasured : bool or str
        ``--drive`` is the best trial's drive (``"replayed"``: and not the
        drive written last).
    repeating : bool
        A repeating reference (judged on its periods' average).
    what : str
        How the best's error was judged (in the lines).
    judged_text : str
        What the judged error is (in the lines).
    out_of_step : str or None
        :func:`lag_problem`'s text.
    advice : str, optional
        :func:`lag_advice`'s text, ending an out-of-step trial's note.
    q_cutoff_hz : float, optional
        Q's cutoff [Hz], named when the learning is found to diverge.
    first_mode_hz : float, optional
        The model's first bending mode [Hz] (identified dynamics): a divergence is then
        not blamed on a mode the model lacks.
    unit : str
        The model's output unit (``HammersteinPlant.units[1]``), the errors' in the lines.
    held : str, optional
        The inputs this trial's drive holds on their range's edge after the fade-in
        (:func:`hammerstein.cli._learn_notes.held_inputs`): a stall far above the noise
        names them first.

    Returns
    -------
    Verdict
    """
    b = state["trial"]
    halvings = min(int(state["halvings"]), MAX_HALVINGS)
    rejections = int(state.get("rejections") or 0)
    ratio = f"{score / best_score:.4g} times" if best_score > 0 else "more than"
    if out_of_step is not None:
        return Verdict(from_best=True, best=False, halvings=halvings, rejections=rejections,
                       note=(f"trial {k} {out_of_step}: not learnt from (its error says nothing "
                             f"about the drive) and not counted as the actuator getting worse; "
                             f"learning again from trial {b}'s drive with gain "
                             f"x{gain_factor(halvings, rejections):g}; "
                             + (advice or "check the trigger and measure again")))
    if remeasured and worse:
        info = (f"trial {k} re-measures the best trial {b}'s drive: {ratio} its stored "
                f"error ({score:.4g} against {best_score:.4g} {unit} {what}): the best was stale "
                f"(the actuator changed since: drift, temperature); trial {k} replaces it "
                f"and is learnt from at full gain")
        return Verdict(info=info, reset=True)
    if remeasured and rejections >= REMEASURE_AFTER:
        # the best drive measured again after worse trials, within the noise of its error: the
        # actuator did not change; the learning steps away from the best diverge at this gain
        halvings = min(halvings + rejections, MAX_HALVINGS)
        cut = "" if q_cutoff_hz is None else f" {q_cutoff_hz:.4g} Hz"
        # with identified modes, none is missing: a stage whose model held its 420 and 610 Hz
        # modes was told to lower the cutoff below them, and learnt worse (0.94 % against 0.81)
        why = (f"likely a bending mode at or below Q's cutoff{cut} that the model does not "
               f"hold: identify --dynamics, or give --q-cutoff-hz below the first mode"
               if first_mode_hz is None else
               f"the model holds the bending modes from {first_mode_hz:.4g} Hz: likely what "
               f"the hysteresis model gets wrong where an input reverses, which a learning step "
               f"built on it misjudges; the lower gain learns it more slowly")
        floor = (" (its floor: lower --q-cutoff-hz below the actuator's first bending mode, or "
                 "stop here)" if halvings == MAX_HALVINGS else "")
        info = (f"trial {k} measures the best trial {b}'s drive again: its judged error "
                f"{score:.4g} {unit} is within the {margin:.2g} {unit} of noise of the stored "
                f"{best_score:.4g} {unit}, so the actuator did not change and trial {b}'s drive stays "
                f"the best (this measurement of it replaces the stored one): the learning "
                f"diverges at the gain it had ({why}); the next drive is "
                f"learnt from this measurement with gain x{gain_factor(halvings):g}{floor}")
        return Verdict(halvings=halvings, info=info, diverges=True)
    if worse and rejections > 0:
        # the best learnt again at a lower gain is worse too: the best stale (a drift) or the
        # learning diverging (a mode above Q's reach); measuring the best drive tells them apart
        rejections += 1
        note = (f"trial {k} is {ratio} the error of trial {b} (the best so far, "
                f"{best_score:.4g} {unit} {what}; {margin:.2g} {unit} of noise margin) and its drive is "
                f"trial {b}'s learnt again: either the actuator changed since trial {b} (drift, "
                f"temperature) or the learning diverges at this gain; to tell them apart the "
                f"next drive is trial {b}'s own drive, unchanged: measure it again")
        return Verdict(from_best=True, best=False, halvings=halvings, rejections=rejections,
                       note=note, halve=True, remeasure=True)
    if worse:
        rejections += 1
        note = (f"trial {k} is {ratio} the error of trial {b} (the best so far, "
                f"{best_score:.4g} {unit} {what}; {margin:.2g} {unit} of noise margin): not learnt "
                f"from; learning again from trial {b}'s drive with gain "
                f"x{gain_factor(halvings, rejections):g} (restored once a trial is learnt from)")
        return Verdict(from_best=True, best=False, halvings=halvings, rejections=rejections,
                       note=note, halve=True)
    stall = None
    if repeating and score >= best_score:
        # not better than the best, and not worse beyond the noise: the learning has reached
        # the noise, and full steps now mostly move noise into the drive (a decreasing gain,
        # as in S. S. Saab, "A discrete-time stochastic learning control algorithm", IEEE
        # Trans. Automatic Control 46(6), 877-887, 2001), down to the floor; far above the
        # noise it stalls, and the smaller steps are no noise's but a caution
        halvings = min(halvings + 1, MAX_HALVINGS)
        if score <= NOISE_FLOOR_RATIO * margin:
            why = "the learning has reached the noise"
        else:
            pinned = ("" if not held else
                      f"{held}: no drive within the range follows the reference there, and no "
                      f"gain reduces that error (centre or shrink the reference); else ")
            why = (f"the learning stalls {score / margin:.3g} times above the noise (not the "
                   f"noise floor: {pinned}the error left is one the learning does not reduce at "
                   f"this gain, or a change the judged average does not show)")
        stall = (f"trial {k}'s judged error {score:.4g} {unit} ({judged_text}) is not below the "
                 f"best, trial {b}'s {best_score:.4g} {unit}, and within the {margin:.2g} {unit} of "
                 f"noise of it: {why}; the next drive is learnt from this trial with gain "
                 f"x{gain_factor(halvings):g}")
    elif repeating and score <= margin:
        # better than the best, but within the noise margin of no error at all: the
        # measurement no longer resolves the peak the trials are judged by, and a full step on
        # harmonics still above their own noise can raise it unseen; the same decreasing gain
        halvings = min(halvings + 1, MAX_HALVINGS)
        stall = (f"trial {k}'s judged error {score:.4g} {unit} ({judged_text}) is within the "
                 f"{margin:.2g} {unit} noise margin of no error: the measurement no longer resolves "
                 f"the error's peak; the next drive is learnt from this trial with gain "
                 f"x{gain_factor(halvings):g}")
    info = None
    if remeasured == "replayed" and not better:
        # the best drive played again, not the one written last (a resumed learning): its
        # error is the best's now
        info = (f"trial {k} re-measures the best trial {b}'s drive: its judged error "
                f"{score:.4g} {unit} replaces the stored {best_score:.4g} {unit} (within the noise)")
    return Verdict(best=bool(better) or info is not None, halvings=halvings, stall=stall,
                   restored=rejections, halve=stall is not None, info=info)
