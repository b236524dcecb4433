"""``hammerstein learn``: one iterative-learning trial from a drive file and its measured response.

Reads the drive ``u_k`` that was applied (a file of ``hammerstein compensate``
or of an earlier ``learn``), the measured response ``y_k`` and the
reference; prints the trial's error and, once, the monotonic-convergence
condition; writes ``u_{k+1}`` (:class:`hammerstein.compensation.ilc.IterativeLearning`)
within the amplifier's limits. ``--history DIR`` appends the trial's error
to ``DIR/history.csv`` and redraws ``DIR/convergence.png``.

The reference is faded in as the first drive was: the drive file's header
records the fade-in (``fade-in N samples``), which is used unless
``--fade-in`` is given. The measured record's delay behind the model's
prediction is estimated by cross-correlation (``--delay auto``, printed) and
the error is advanced by it before learning; when one sample is less than
2 degrees of the reference's fundamental, a line says the estimate cannot
tell the delay from the model's phase error (give ``--delay N``). A reference that repeats after
its fade-in is learnt per harmonic of its period from two periods after the
fade-in on (:func:`hammerstein.compensation.ilc.repeating_from`, gains
``gamma |Q|`` per harmonic, not learnt at the noise floor); with
``--history DIR`` the per-harmonic gains carry over from trial to trial in
``DIR/harmonics.csv`` (halved where a harmonic's error keeps growing).
What is learnt for it is the reference the compensator follows
(:func:`hammerstein.compensation.ilc.reference_correction`): the next drive
is ``compensate``'s drive (the same kind, from rest, faded in) for the
reference plus the learnt periodic correction, and the drive file keeps
that reference in its ``<output>_learnt`` columns, from which the next
trial goes on. Every drive's start-up is then the compensator's own,
consistent with the model's dynamics. A drive that neither ``compensate``
nor ``learn`` wrote (no compensator reference) is learnt through the drive
(the time-domain law below).

Where ``compensate`` shaped the reference to what the amplifier and the
identified dynamics allow (the drive file's ``<output>_shaped`` columns),
that shaped reference is what is learnt and judged (the error against the
reference as asked is printed as well): the reference as asked cannot be
followed there, and learning towards it winds the correction up against
the limits. Each learnt drive carries it over in its own ``<output>_shaped``
columns, and its reference is not shaped again (only the drive is shaped
into the limits, :func:`hammerstein.compensation.drive.hardware_drive`
with ``shape=False``).

Everything is judged on the settled part: the printed max and RMS
Euclidean errors start after the fade-in and ``--settle-periods`` (the
start-up no drive removes), for a repeating reference not before its
repeating part (two periods after the fade-in; so too for a CSV reference
without ``--period`` that repeats, a raster's lines: its period and, for a
first trial's lag, its fundamental are found from it,
:mod:`hammerstein.signals.fundamental`), and the fade-in itself is not judged (the next
drive starts as the base drive and is faded into the learning over the
fade-in and the next period, as the reference is,
:func:`hammerstein.compensation.drive.keep_start`), so every drive starts at
rest as the first one did; without a period the learnt change enters the
drive over the tenth of the record after the fade-in, and the error is
judged from there on, not where no trial learns it away
(:func:`hammerstein.compensation.drive.learning_onset`). An amplifier table measured on the
identification records (``source = "records"``) shapes the next drive into
it (:func:`hammerstein.compensation.drive.shape_drive`).

With ``--history DIR`` the best trial so far is kept in ``DIR/best-trial.csv``
(its drive and measured response; ``DIR/learning.csv`` its error and the
gain halvings; ``DIR/settled.csv`` every trial's settled max and RMS
Euclidean error and judged error). A history belongs to one learning: its
state records a fingerprint of the faded reference and samples of the last
drive written, and a trial whose reference differs, or whose ``--drive`` is
neither the last drive written nor the best trial's, is refused (exit 1,
nothing written: a history left from another reference, actuator or
identification would otherwise be learnt from). A trial whose error is above the best
one, beyond what the sensor noise can explain, is not learnt from; the next
drive is learnt from the best trial's drive and response with half the
gain (halved again at each such trial, never below 1/16 of
``--learning-gain``, restored once a trial is learnt from), and one line
says so, as the scenarios' ``kind = "ilc"`` does. When that drive is itself
worse beyond the noise, the next drive is the best trial's drive itself, to
measure it again. The best drive measured again (so, or ``best-trial.csv``
replayed as ``--drive`` to resume) worse beyond the noise: the best is
stale (the actuator changed), the trial becomes the best and is learnt from
at full gain; asked for and within the noise: the learning diverges at that
gain, which is halved for good (the line names Q's cutoff and
``--dynamics``); a
trial whose lag behind the model's prediction is not the delay (a trigger
or latency change) is not learnt from and changes no gain
(:mod:`hammerstein.cli._learn_rules`). A measured response that is not the
drive's (its error against the model's prediction of the drive far beyond a
model's, or an output flat where the prediction moves: channels swapped,
another drive's record, a saturated sensor) is refused before anything is
learnt (:mod:`hammerstein.cli._learn_checks`). A trial of a repeating reference judged
not better than the best, and not worse beyond the noise, has reached the
noise: it is learnt from, with the gain halved (again at each such trial),
so that the last steps stop moving the sensor's noise into the drive; one
line says so.
When the judged error rose since the
previous trial, the printed condition ``||I - gamma Q L G||`` is said to
hold on the model only, and a line says the learning was not monotonic on
the actuator. The error judged: for a repeating
reference, the max Euclidean error averaged over the periods, with a
margin of 3 standard deviations of the periods' spread
(:func:`_judged_error`); for one that does not repeat (a raster), the RMS
Euclidean error less the noise's power, over the window the printed error
covers (after the fade-in and ``--settle-periods``), the noise estimated
from each record's content above the learning's band and the margin 3
standard deviations of the difference
(:func:`hammerstein.signals.trial_noise.compare_trials`).

Exit status: 0 written; 1 bad files, shapes or a drive beyond the amplifier
with ``--limits error`` (one line, nothing written); 2 a usage error.

Length: one trial is one pass (read, align, judge against the history, learn,
write with its header); the rules, the history and the notes live apart
(``_learn_rules``, ``_learn_history``, ``_learn_notes``).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from hammerstein.cli._common import out_dir_problem, out_file_problem, print_err
from hammerstein.cli._hardware import (START_NOTE, add_actuator_arguments, catch, end_note,
                                       check_reference_first,
                                       load_actuator,
                                       fraction, load_reference, mapping, nonnegative_float,
                                       owned_problem, positive_float, settle_periods)
from hammerstein.cli._hardware import Reference
from hammerstein.cli._learn_history import (BEST_FILE, HISTORY_MARK, _check_history, _drive_samples,
                                            foreign_history_problem, history_file_problem,
                                            history_unit_problem,
                                            _fingerprint, _read_best, _read_state, _restore_gains,
                                            _save_gains, _settled_rows, _write_history,
                                            _write_state, history_rows,
                                            write_history_manifest)
from hammerstein.cli.compensate import LAW_HINT, compensate
from hammerstein.scenario.hardware_route import LAW_KINDS
from hammerstein.models.amplifier import LIMITS
from hammerstein.compensation.drive import (MIN_FADE_S, drive_fade_samples, hardware_fade,
                                            keep_end, keep_start, learning_onset,
                                            limit_start_up,
                                            read_signals, settled_step,
                                            rest_output, shape_drive, signals_csv)
from hammerstein.compensation.edge_holds import edge_hold_note, reference_at_rest
from hammerstein.compensation.start_up import export_slew_words
from hammerstein.compensation.drive_files import (drive_rest_lead, drive_rest_output,
                                                  followed_reference, head_lines, learnt_names,
                                                  rest_lead_text, shaped_target)
from hammerstein.core.files import (FileLimitError, all_or_nothing, guard_inputs, locked,
                                    output_problem, removed_if_failed, safe_write)
from hammerstein.compensation.ilc import (INVERSE_GAIN_LIMIT, HarmonicGains, IterativeLearning,
                                          error_summary, harmonic_base_gains,
                                          periodic_average, reference_correction, repeating_from)
from hammerstein.compensation.model_classes import model_class
from hammerstein.compensation.reach import output_reach, reach_note
from hammerstein.compensation.kind_choice import law_check
from hammerstein.compensation.shaping import (CHATTER_REFUSE_FRACTION, chatter_warnings,
                                              delay_search_span)
from hammerstein.cli._learn_rules import (MAX_HALVINGS, Verdict, gain_factor, judge_trial,
                                          lag_advice, lag_problem, trial_lag)
from hammerstein.cli._learn_checks import (gain_band, measurement_problem,
                                           model_gain_note, model_gains, plant_first_mode,
                                           stepping_outputs)
from hammerstein.cli._learn_notes import (_anti_resonance_note, _drift_note,  # noqa: F401
                                          _period_note, default_q_cutoff, held_inputs,
                                          PERIODIC_KINDS)
from hammerstein.signals.fundamental import reference_fundamental
from hammerstein.signals.trial_noise import SEGMENT, compare_trials, trial_error
from hammerstein.exceptions import CompensatorError, DataFileError

__all__ = ["add_parser", "history_rows"]


def _read_drive(args, inputs):
    """The drive file's inputs at its own time column, as ``evaluate`` reads it.

    ``compensate`` and ``learn`` write the drive's time as ``t``; ``--time`` names
    the measured file's (and a CSV reference's) time column, so the drive is read
    at ``t``, and at ``--time`` only when the drive has no ``t`` (a drive written
    by other software with the measured file's column names).

    Returns
    -------
    t : numpy.ndarray, shape (n,)
        Drive time [s].
    u : numpy.ndarray, shape (len(inputs), n)
        Drive inputs [V].
    period : float
        Its sampling period [s].

    Raises
    ------
    DataFileError
        Unreadable drive, or none of its columns named as asked.
    """
    columns = mapping(args.inputs, inputs, "--input-columns")
    try:
        return read_signals(args.drive, inputs, "t", columns, None, "--drive")
    except DataFileError:
        if args.time == "t":
            raise
        first = sys.exc_info()[1]
    try:
        return read_signals(args.drive, inputs, args.time, columns, None, "--drive")
    except DataFileError:
        raise first from None


def add_parser(subparsers):
    """Register the ``learn`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "learn", help="one iterative-learning step from drive and measured files",
        description="Iterative learning control, one trial: from the drive applied (u_k), its "
                    "measured response (y_k) and the reference, write the next drive u_k+1.")
    add_actuator_arguments(p, time_help="time column of --measured and of a CSV reference "
                                        "(default t); the --drive file's own is t")
    p.add_argument("--drive", required=True, metavar="U_K.csv", help="the drive that was applied")
    p.add_argument("--measured", required=True, metavar="Y_K.csv",
                   help="its measured response: t [s] from the drive's start, one column per "
                        "output in the model's output unit (µm by default; resampled onto the "
                        "drive's period)")
    p.add_argument("--out", required=True, metavar="U_K+1.csv", help="the next drive")
    p.add_argument("--history", metavar="DIR",
                   help="append this trial's error to DIR/history.csv, draw DIR/convergence.png, keep the "
                        "best trial: a trial 10 %% worse than it beyond the sensor noise is not "
                        "learnt from (the next drive is learnt from the best one with half the gain, "
                        "at least 1/16 of --learning-gain; after a second, the best drive itself, "
                        "to measure it again); replay DIR/best-trial.csv as --drive "
                        "to resume a learning")
    p.add_argument("--learning-gain", type=positive_float, default=0.5, metavar="G",
                   help="gamma in (0, 2) (default 0.5: half the error per trial, half the noise)")
    p.add_argument("--q-cutoff-hz", type=positive_float, default=None, metavar="HZ",
                   help="zero-phase low-pass Q of the update (default: 2.5 times the first "
                        "bending mode of the actuator's dynamics, at least 1000 Hz, printed; "
                        "1000 Hz without an oscillatory mode; 100 Hz, with a warning, for a "
                        "model identified without --dynamics)")
    p.add_argument("--inversion", choices=["zpetc", "stable"], default="zpetc",
                   help="inverse of the dynamics, in the learning and in the compensator that "
                        "computes a repeating reference's drive (default zpetc)")
    p.add_argument("--slope-floor", type=fraction, metavar="F",
                   help="in [0, 1]: no local gain of the model below F x its loop's mean slope is "
                        "inverted (a trust region after input reversals; default 0.7 for a Preisach "
                        "or generalised-PI model, 0 for a classical PI; the learning through the "
                        "drive: a reference that does not repeat, or a drive no command wrote)")
    p.add_argument("--gain", choices=["secant", "midpoint", "identity"], default=None,
                   help="K of the inverse multiplicative law that inverts a classical PI in the "
                        "learning (default: the convergent gain, printed with why; a Preisach or "
                        "generalised-PI model is inverted exactly)")
    p.add_argument("--check", choices=["error", "warn", "ignore"], default=None,
                   help="when that law may not converge, rho(I - K^-1 J) >= 1: error, warn or "
                        "ignore (default: ignore with a note, as its 50 iterations per sample "
                        "are checked on the model's own prediction)")
    p.add_argument("--delay", default="auto", metavar="auto|N",
                   help="samples the measurement lags the model (default auto: the model file's "
                        "measurement delay when `identify --delay` wrote one, else "
                        "cross-correlation with the model's prediction)")
    p.add_argument("--fade-in", type=nonnegative_float, metavar="S",
                   help="fade-in of the reference [s] (default: the drive file's)")
    p.add_argument("--settle-periods", type=settle_periods, default=1.0, metavar="N",
                   help="periods excluded from the printed error after the fade-in (default "
                        "1; a repeating reference is judged from its repeating part on, two "
                        "periods after the fade-in, when that is later)")
    p.add_argument("--limits", choices=list(LIMITS), default="error",
                   help="beyond the amplifier, or a next drive that chatters (large steps of "
                        "alternating sign on consecutive samples): error (default, nothing "
                        "written), warn or clip (a chattering drive is written with a warning)")
    p.add_argument("--force", action="store_true",
                   help="replace an --out file that hammerstein did not write, or a drive "
                        "changed since it wrote it (a measured column added)")
    p.set_defaults(handler=_handle)


def _inverse_gain(model, gain, check, units=("V", "µm")):
    """(K of the law inverting a classical PI in the learning, its check, the notes to print).

    The gain and check are :func:`hammerstein.compensation.kind_choice.law_check`'s,
    the decision ``compensate`` and ``export`` make with the same options: with
    neither given, a law no gain makes provably converge runs with ``check =
    warn`` when it follows the model's own outputs and is refused when not.
    The notes: one line on the choice (``note: kind = ilc because ...``); a
    warning when ``rho(I - K^-1 J) >= 1`` and the check is warn. ``units``: the model's
    (input, output) units (``HammersteinPlant.units``), K's in the lines.
    """
    entry = model_class(model)
    notes = []
    if entry.exact_inverse_kind is not None:
        if gain is not None or check is not None:
            raise CompensatorError(f"--gain/--check: the {entry.label} model is inverted exactly "
                                   f"in the learning (no inverse multiplicative law)")
        return "secant", check, [f"note: kind = ilc because learning runs on the hardware; the "
                                 f"{entry.label} model is inverted exactly in L"]   # gain unused
    law = law_check(model, gain, check, entry.label)
    gain, radius = law.gain, law.radius
    name = gain if isinstance(gain, str) else "scaled midpoint K = [" + ", ".join(
        f"{v:.4g}" for v in np.diag(gain)) + f"] {units[1]}/{units[0]}"
    if radius >= 1.0 and (law.check or "error") in ("error", "warn"):
        # where no gain converges the reason says so (the hint's "a gain that converges"
        # beside it contradicted it)
        text = (f"gain {name}: rho(I - K^-1 J) reaches {radius:.3g} >= 1, the law inverting "
                f"the model in the learning may not converge ({law.reason or LAW_HINT})")
        if (law.check or "error") == "error":
            raise CompensatorError(text)
        notes.append(f"warning: {text}")
    notes.append(f"note: kind = ilc because learning runs on the hardware; the classical PI is "
                 f"inverted in L by the multivariable law, gain {name}, rho(I - K^-1 J) "
                 f"{radius:.3g}" + (f"; {law.reason}" if law.reason and radius < 1.0 else ""))
    return gain, law.check, notes


#: a trial worse than the best one so far by more than this factor is not learnt from
WORSE = 1.1
#: ... and by more than this many standard deviations of the difference of two judged errors
#: (noise of the period-averaged measurement, :func:`_judged_error`): on realistic-2dof with
#: 40 nm of noise, trials judged 1.15-1.38 times worse on the averaged measurement (0.05-0.07
#: µm, averaged noise ~14 nm) were as good or better in truth, and learning again from the
#: older drive made the next trial 1.29 times worse. A non-repeating reference (a raster) uses
#: it as the z of :func:`hammerstein.signals.trial_noise.compare_trials` (standard deviations of
#: the difference of two mean squares less the noise)
NOISE_MARGIN = 3.0
#: below this phase of one sample at the reference's fundamental [deg] (a period longer than
#: 360 / DELAY_PHASE_DEG samples), ``--delay auto`` says the delay is not observable. The
#: estimate (normalised cross-correlation with the model's prediction) carries the model's
#: phase error at the fundamental. Measured, inserted delays 0, 3, 10, 20 samples, 40 nm noise,
#: T = 50 us, drives of ``compensate rakotondrabe-2dof``: on that actuator 4 % stronger, 0
#: samples off for 20 um circles at 10, 50, 200 Hz and a 40 Hz raster, 1 on a 10 Hz raster; on
#: realistic-2dof (outside the model's class) +20, +1, -4 samples for the circles and +10, +1
#: for the rasters (a 3.6 deg phase error at 10 Hz is 20 samples)
DELAY_PHASE_DEG = 2.0


def _window_error(target, y, delay, start, sampling_period, q_cutoff_hz):
    """The measured error of a non-repeating reference over the judged window, or None.

    Parameters
    ----------
    target, y : numpy.ndarray, shape (p, N)
        The faded reference and the measured response [µm].
    delay : int
        Samples the measurement lags [samples].
    start : int
        First sample judged (after the fade-in and the settling) [samples].
    sampling_period : float
        T [s].
    q_cutoff_hz : float
        Q's cut-off [Hz]: the noise is estimated from the error's content
        above ``min(2 q_cutoff_hz, fs / 4)`` (what the learning puts into
        the drive stays below Q; the actuator's modes and the reference's
        harmonics there are lines the median leaves out).

    Returns
    -------
    hammerstein.signals.trial_noise.TrialError or None
        None when the window holds fewer than ``2 SEGMENT`` samples (too
        short a record to estimate the noise from).
    """
    N = target.shape[1]
    e = target[:, start:N - delay] - y[:, start + delay:N]
    if e.shape[1] < 2 * SEGMENT:
        return None
    return trial_error(e, sampling_period, min(2.0 * q_cutoff_hz, 0.25 / sampling_period))


#: the shaped reference differs from the one asked within the judged window by more than this [µm]
SHAPED_WITHIN_UM = 1e-6

#: what the notes call a trial's judged error, beside the printed max (which carries the noise)
JUDGED = ("its noise averaged down: the max Euclidean error of the settled periods' average "
          "for a repeating reference, else the RMS less the noise; the max printed above "
          "carries the noise")


def _judged_error(target, y, delay, period, steady):
    """The error a trial is judged by, and the noise of that judgement [µm].

    Used for a repeating reference; a reference that does not repeat is
    judged on its RMS error less the noise (:func:`_window_error`), unless
    its record is too short for the noise estimate.

    The score is the max Euclidean error of the measurement, averaged over the
    periods from ``steady`` on for a repeating reference (its noise divided by
    the square root of their number), else over the whole record after the
    delay. The noise is the standard deviation, per axis (the largest), of
    the averaged error's noise: the spread of the periods about their mean,
    ``sqrt(sum r^2 / (n - P)) / sqrt(n / P)`` over the ``n`` samples from
    ``steady`` on (0 when nothing is averaged).
    """
    N = target.shape[1]
    e = target[:, :N - delay] - y[:, delay:N]
    if steady is not None and period and e.shape[1] - steady >= 2 * period:
        averaged = periodic_average(e, period, steady)[:, steady:]
        n = averaged.shape[1]
        spread = np.sum((e[:, steady:] - averaged) ** 2, axis=1) / (n - period)
        return float(np.max(np.linalg.norm(averaged, axis=0))), float(np.sqrt(np.max(spread) * period / n))
    return float(np.max(np.linalg.norm(e, axis=0))), 0.0


def _judged_rms(target, y, delay, period, steady):
    """RMS Euclidean error of the settled periods' average [µm] (None: nothing is averaged)."""
    N = target.shape[1]
    e = target[:, :N - delay] - y[:, delay:N]
    if steady is None or not period or e.shape[1] - steady < 2 * period:
        return None
    averaged = periodic_average(e, period, steady)[:, steady:]
    return float(np.sqrt(np.mean(np.sum(averaged ** 2, axis=0))))


def _judged_line(k, score, judged, rms, scale, unit="µm"):
    """The short line of a trial's judged (noise-averaged) settled errors, in ``unit`` (the
    model's output unit)."""
    pct = (lambda v: f" ({100 * v / scale:.3g} %)") if scale else (lambda v: "")
    trial = "" if k is None else f"trial {k} "
    if judged is not None:
        return f"{trial}judged (RMS less the sensor noise): RMS {score:.4g} {unit}{pct(score)}"
    if rms is None:
        return f"{trial}judged (nothing to average): max {score:.4g} {unit}{pct(score)}"
    return (f"{trial}judged (settled periods averaged, noise averaged down): max "
            f"{score:.4g} {unit}{pct(score)}, RMS {rms:.4g} {unit}{pct(rms)}")


def _handle(args):
    """One trial; with ``--history``, under an advisory lock on the history's parent directory.

    Two ``learn --history DIR`` at once both read the same last trial and both appended trial
    k + 1: one was lost without a word. The second now waits for the first, reads the history
    it left, and is refused (its drive is no longer the last one written).
    """
    parent = Path(args.history).absolute().parent if args.history else None
    if parent is None or not parent.is_dir():
        return _learn(args)
    try:
        with locked(Path(args.history).absolute()):
            return _learn(args)
    except FileLimitError as exc:          # the lock not obtained within its timeout
        print_err(f"hammerstein learn: error: --history: {exc}")
        return 1


def _learn(args):
    problem = out_file_problem(args.out, "drive file",
                               (args.actuator, args.reference, args.drive, args.measured))
    if not problem:
        # the history's best-trial.csv replayed as --drive (a resumed learning): read whole
        # before anything is written, and the history's own file to replace
        best_file = Path(args.history) / BEST_FILE if args.history else None
        try:
            replay = (best_file is not None and best_file.is_file()
                      and Path(args.drive).is_file() and os.path.samefile(best_file, args.drive))
        except (OSError, ValueError):      # a name too long: --history's own check says so
            replay = False
        guard_inputs(args.actuator, args.reference, None if replay else args.drive, args.measured)
        problem = output_problem(args.out)         # an input is never an output, even with --force
        problem = f"--out: {problem}" if problem else None
    if not problem and args.history:
        problem = out_dir_problem(args.history)
        problem = problem.replace("--out", "--history") if problem else None
    if not problem and args.history:
        problem = history_file_problem(args.out, args.history)   # never two writes to one file
    if not problem and args.history:
        problem = foreign_history_problem(args.history, args.out)   # before the learning runs
    if not problem:
        try:
            same = os.path.samefile(args.drive, args.measured)
        except (OSError, ValueError):      # a missing file: its reading says so
            same = False
        if same:          # its <output>_shaped columns read as the measurement: "RMS 0 µm"
            problem = (f"--measured: {args.measured} is the --drive file itself; expected the "
                       f"response measured while the drive was played")
    if problem:
        print_err(f"hammerstein learn: error: {problem}")
        return 2
    try:
        check_reference_first(args.actuator, args.sampling_period, args.reference, args.time,
                              args.outputs, args.period)     # the budget before re-sampling
        plant = load_actuator(args.actuator, args.sampling_period)
        unit_problem = history_unit_problem(args.history, plant.units[1]) if args.history else None
        if unit_problem:
            raise DataFileError(unit_problem)
        model = plant.hysteresis
        ref = load_reference(args.reference, plant, args.time, args.outputs, args.period)
        T = plant.sampling_period
        q_note = None
        if args.q_cutoff_hz is None:
            args.q_cutoff_hz, q_note = default_q_cutoff(plant)
        _, u, Tu = _read_drive(args, list(model.input_names))
        if not np.isclose(Tu, T, rtol=1e-6):
            raise DataFileError(f"--drive: sampled every {Tu:g} s; expected the actuator's {T:g} s "
                                f"(give --sampling-period)")
        N = ref.signal.shape[1]
        if u.shape[1] != N:
            raise DataFileError(f"--drive: {u.shape[1]} samples; expected the reference's {N}")
        rate_notes = list(ref.notes)   # a reference or measurement at another rate: resampled
        _, y, _ = read_signals(args.measured, list(model.output_names), args.time,
                               mapping(args.outputs, list(model.output_names), "--output-columns"), T,
                               "--measured", upsample=False, notes=rate_notes, units=plant.units)
        if y.shape[1] < N:
            raise DataFileError(f"--measured: {y.shape[1]} samples at {T:g} s; expected at least "
                                f"the drive's {N} (the measurement must cover the whole drive)")
        y = y[:, :N]
        # after the files are read: a bad input is one line on stderr, not a warning and it
        if getattr(plant, "dynamics_problem", None):
            print_err(f"warning: {plant.dynamics_problem}")
        if args.fade_in is not None and args.fade_in / T > ref.signal.shape[1]:
            raise DataFileError(f"--fade-in: {args.fade_in:g} s is longer than the reference "
                                f"({ref.signal.shape[1]} samples, {ref.signal.shape[1] * T:g} s); "
                                f"expected at most {ref.signal.shape[1] * T:g} s")
        fade = (int(round(args.fade_in / T)) if args.fade_in is not None else drive_fade_samples(args.drive))
        if fade is None:              # as compensate's shortest default: a duration
            fade = min(max(ref.period_samples if ref.period_samples > 1 else 0,
                           int(np.ceil(MIN_FADE_S / T - 1e-9))), N)
        # as compensate faded it: a stable inversion's longer rest lead too (the drive's header)
        lead = None if args.fade_in is not None else drive_rest_lead(args.drive)
        # from the rest compensate faded from (its header: a kind that does not invert creep
        # fades from the hysteresis' output at 0 V), else the settled one
        rest = drive_rest_output(args.drive, list(model.output_names))
        rest = rest_output(model, plant.creep) if rest is None else rest
        target = hardware_fade(ref.signal, fade, rest, lead)
        # where compensate shaped the reference to what the amplifier and the dynamics allow
        # (its <output>_shaped columns, carried over by learn), that is the position learnt and
        # judged: the reference as asked cannot be followed there, and learning towards it
        # winds the correction up against the limits trial after trial
        shaped_ref = shaped_target(args.drive, list(model.output_names), target, T)
        aim = target if shaped_ref is None else shaped_ref
        predicted, _ = plant.simulate(u, plant.rest_state())     # from rest, as the actuator
        delay_note = None
        if args.delay == "auto" and plant.measurement_delay is not None:
            delay = plant.measurement_delay          # identify --delay: the acquisition's
            print(f"delay {delay} samples: the model file's measurement delay (identify's --delay, "
                  f"given or estimated)")
        elif args.delay == "auto":
            delay = max(trial_lag(predicted, y, target, ref.period_samples, T), 0)
            per_sample = 360.0 / ref.period_samples if ref.period_samples > 1 else None
            if per_sample is not None and per_sample < DELAY_PHASE_DEG:
                advice = ("identify with --dynamics (the delay found from the multisines)"
                          if getattr(plant, "delay_problem", None) is None else
                          "identify --delay N, which fits the dynamics with it (identify's own "
                          "estimate was refused: its model file's measurement_delay_estimate "
                          "says why)")
                delay_note = (f"note: --delay auto: {delay} samples from the model's prediction, but one "
                              f"sample is only {per_sample:.2g} deg of the reference's fundamental "
                              f"({1 / (ref.period_samples * T):.4g} Hz), less than a model's phase "
                              f"error: give --delay N when you know your acquisition's delay, or "
                              f"{advice}")
        else:
            try:
                delay = int(args.delay)
            except ValueError:
                raise DataFileError(f"--delay: expected auto or an integer >= 0, found "
                                    f"{args.delay!r}") from None
            if delay < 0:
                raise DataFileError(f"--delay: expected auto or an integer >= 0 (the "
                                    f"acquisition's latency; a measurement that leads the drive "
                                    f"has none), found {delay}")
        if delay >= N - 1:
            raise DataFileError(f"--delay: {delay} samples; expected fewer than the record's {N - 1}")
        # a delay not measured on this trial (the model file's, or --delay N): the trial's own
        # lag is, as evaluate measures it; a trigger or latency change shows there
        lag = None if args.delay == "auto" and plant.measurement_delay is None else \
            trial_lag(predicted, y, target, ref.period_samples, T)
        # the settled window: after the fade-in and --settle-periods (the start-up no drive removes)
        P = ref.period_samples if ref.period_samples > 1 else None
        steady = repeating_from(target, P, fade)
        spec = ref.spec if isinstance(ref.spec, dict) else {}
        period_note = _period_note(args.period, P, T, steady, target.shape[1], fade,
                                   spec.get("frequency") if ref.kind in PERIODIC_KINDS else None)
        settle = fade + int(args.settle_periods * ref.period_samples)
        if steady is not None:        # the repeating part the trial is judged on
            settle = max(settle, steady)
        # no period given (a CSV file without --period): the reference's own, found from it,
        # sets a first trial's lag tolerance and, when it repeats (a raster's lines), the window
        found = reference_fundamental(ref.signal, T) if P is None else None
        fundamental_samples = P or (found.samples(T) if found is not None else 0)
        if found is not None and found.period_samples:
            Pf = found.period_samples
            settle = max(fade + int(args.settle_periods * Pf), max(fade, Pf) + 2 * Pf)
        # nor before the learnt change is passed whole (keep_start's blend: over the fade-in and
        # one period, or a tenth of the record after the fade-in without a period): the error
        # of the start-up there is not what the learning corrects, and was judged every trial
        # (a 37/41 Hz Lissajous CSV: 1.25 µm over 0.3 s after the fade while the rest fell
        # from 1.2 to 0.13 µm)
        onset = learning_onset(N, fade, ref.period_samples)
        onset_note = None
        if onset > settle:
            settle = onset
            if P is None:
                onset_note = (f"note: no --period: judged from {onset * T:.4g} s, where the learnt "
                              f"change enters the drive whole (it is blended in over a tenth of the "
                              f"record after the fade-in; --period blends it in over one period)")
        found_note = None if found is None else (
            f"note: no --period: the reference's fundamental {found.frequency_hz:.4g} Hz "
            f"({found.how}) sets a first trial's lag tolerance"
            + (" and the judged window (from two periods after the fade-in)"
               if found.period_samples else "")
            + (f"; the file repeats every {found.repeat_samples * T:.6g} s "
               f"({found.repeat_samples} samples): --period {found.repeat_samples * T:.6g} learns "
               f"it per harmonic of that period" if found.repeat_samples else ""))
        # not the drive's response (channels swapped, another drive's, a saturated sensor):
        # refused before anything is learnt from it (hammerstein.cli._learn_checks)
        implausible = measurement_problem(predicted, y, model.output_names, lambda m: trial_lag(
            predicted, m, target, ref.period_samples, T), fade, fundamental_samples, ref.signal,
            delay_search_span(target, ref.period_samples, T), T, plant.units[1])
        if implausible:
            raise DataFileError(implausible)
        # an actuator that changed since it was identified (warmer, loaded): its gain against
        # the model's prediction, said once per trial when beyond what a fresh model leaves
        # (below the first mode: at it the mode's gain is too sensitive to judge the actuator)
        g_band = gain_band(fundamental_samples, ref.signal, plant_first_mode(plant))
        first_mode_hz = None if plant_first_mode(plant) is None else plant_first_mode(plant) / T
        drift_gain = None if g_band == 0.0 else model_gain_note(
            model_gains(predicted, y, delay, settle, g_band), model.output_names,
            stepping_outputs(ref.signal), getattr(plant, "identify_misfit", None))
        shifted = y[:, delay:]            # aligned on the drive; the last `delay` samples unmeasured
        window = slice(min(settle, N - delay - 1), None)
        rec = error_summary(aim[:, :N - delay], shifted, window)
        euclid = np.linalg.norm(aim[:, :N - delay][:, window] - shifted[:, window], axis=0)
        settled_max, settled_rms = float(np.max(euclid)), float(np.sqrt(np.mean(euclid ** 2)))
        # against the reference as asked too, when the shaping reaches the judged window (a
        # start-up shaped within the fade-in leaves the two equal there: nothing to add)
        shaped_within = shaped_ref is not None and float(np.max(np.abs(
            (target - aim)[:, :N - delay][:, window]), initial=0.0)) > SHAPED_WITHIN_UM
        as_asked = None if not shaped_within else float(np.max(np.linalg.norm(
            target[:, :N - delay][:, window] - shifted[:, window], axis=0)))
        # the best trial so far (--history): a trial worse beyond the noise is not learnt from
        state = _read_state(args.history, N) if args.history else None
        fingerprint = _fingerprint(target)
        remeasured = bool(args.history) and _check_history(
            args.history, state, fingerprint, u,
            lambda: _read_best(args.history, model, u.shape, y.shape, N)[:2], y,
            args.fade_in is None and drive_fade_samples(args.drive) is None)
        expected_offset = None if state is None else state.get("lag_offset")
        out_of_step = None if lag is None else lag_problem(
            lag, delay, expected_offset, fundamental_samples,
            "the model's delay" if args.delay == "auto" else "--delay", T)
        advice = None if out_of_step is None else lag_advice(lag, expected_offset,
                                                             args.period is not None)
        score, score_noise = _judged_error(aim, y, delay, P, steady)
        # two noisy maxima of the same error differ by about sqrt(2) times the averaged noise
        margin = NOISE_MARGIN * np.sqrt(2.0) * score_noise
        # a reference that does not repeat: its RMS error less the noise, over the printed window
        judged_start = min(max(fade, settle), N - delay - 1)
        judged = None if steady is not None else _window_error(
            aim, y, delay, judged_start, T, args.q_cutoff_hz)
        if judged is not None:
            score = judged.score
        k_next = 1 + max((r[0] for r in history_rows(args.history)), default=-1) \
            if args.history and (Path(args.history) / HISTORY_MARK).exists() else 0
        judged_line = _judged_line(k_next if args.history else None, score, judged,
                                   _judged_rms(aim, y, delay, P, steady), ref.scale, plant.units[1])
        learn_u, learn_y, note, halvings, best, stall = u, y, None, 0, True, None
        followed, drive_kind_ = followed_reference(args.drive, list(model.output_names), target, T)
        followed_now = followed          # the reference this trial's drive was computed for
        bu = by = bf = None
        verdict = Verdict(rejections=0)
        if out_of_step is not None and state is None:
            raise DataFileError(f"--measured: this trial {out_of_step}; nothing written: {advice}")
        if state is not None:
            best_score, what = state["score"], "averaged"
            better = score < best_score
            worse = score > best_score + margin
            if judged is not None:       # judged against the best trial's record, same statistic
                bu, by, bf = _read_best(args.history, model, u.shape, y.shape, N)
                cmp = compare_trials(judged, _window_error(
                    aim, by, delay, judged_start, T, args.q_cutoff_hz), 1.0, NOISE_MARGIN)
                score, best_score, margin, worse, better = (cmp.score, cmp.best_score, cmp.margin,
                                                            cmp.worse, cmp.better)
                what = (f"RMS less the noise's {', '.join(f'{v:.2g}' for v in cmp.sigma)} "
                        f"{plant.units[1]} "
                        f"estimated from the records")
                # the number printed is the one compared and kept in settled.csv (the noise
                # estimated from both records: it was the first record's alone, 11 % apart)
                judged_line = _judged_line(k_next if args.history else None, score, judged,
                                           None, ref.scale, plant.units[1])
            verdict = judge_trial(state, k_next, score, best_score, margin, worse, better,
                                  remeasured, judged is None, what, JUDGED, out_of_step, advice,
                                  args.q_cutoff_hz, first_mode_hz, plant.units[1],
                                  held_inputs(u, plant.amplifier, fade, aim, rest,
                                              list(model.input_names), plant.units[0]))
            halvings, best, note, stall = (verdict.halvings, verdict.best, verdict.note,
                                           verdict.stall)
            if verdict.from_best:
                if bu is None:
                    bu, by, bf = _read_best(args.history, model, u.shape, y.shape, N)
                learn_u, learn_y, followed = bu, by, bf
        gain = args.learning_gain * gain_factor(halvings, verdict.rejections)
        law_gain, law_check_, notes = _inverse_gain(model, args.gain, args.check, plant.units)
        notes = ([f"note: {line}" for line in rate_notes] + ([] if q_note is None else [q_note])
                 + notes + ([] if period_note is None else [period_note])
                 + ([] if found_note is None else [found_note])
                 + ([] if onset_note is None else [onset_note])
                 + ([] if drift_gain is None else [f"note: {drift_gain}"]))
        if (note or stall) and steady is not None:
            notes += _drift_note(aim[:, :N - delay] - y[:, delay:N], P, steady, plant.units[1])
        if plant.amplifier is not None:     # compensate says it; a trial that stalls or rises
            # there was blamed on the modes or the gain, ten trials on
            reach = reach_note(output_reach(model, plant.amplifier, plant.creep), ref.signal,
                               list(model.output_names), plant.units[1])
            if reach:
                notes.append(f"note: {reach}; the error there is the reach's, which no trial "
                             f"removes (what a stalled or worse trial then shows)")
        ilc = IterativeLearning(model, plant.dynamics, T, gain, args.q_cutoff_hz,
                                inversion=args.inversion, delay=delay, slope_floor=args.slope_floor,
                                gain=law_gain)
        cond = ilc.convergence()
        gains = None
        if steady is not None:         # a repeating reference: learnt per harmonic of its period
            base = harmonic_base_gains(ilc, P, None, args.q_cutoff_hz, INVERSE_GAIN_LIMIT)
            gains = HarmonicGains(base)
            note_ar = _anti_resonance_note(ilc, P, T, args.q_cutoff_hz, plant.units[1])
            if note_ar:
                notes.append(note_ar)
            if args.history and not verdict.reset:     # a stale best: start afresh
                _restore_gains(args.history, gains)
                if verdict.from_best:  # no growth compared with the trial not learnt from
                    gains.previous = None
                if verdict.halve:      # as the gain: halved (a worse trial, the noise reached)
                    gains.gains *= 0.5
                elif verdict.restored:     # accepted after worse trials: their halvings undone
                    gains.gains *= 2.0 ** verdict.restored
                # within the floor and full gain (base is at this trial's gain)
                full = base * (args.learning_gain / gain)
                gains.gains = np.clip(gains.gains, full * 0.5 ** MAX_HALVINGS, full)
        problems, shaped, learnt = [], [], None
        if verdict.remeasure:       # the best drive itself, unchanged: the next trial re-measures it
            u_next, learnt = bu, followed
        elif steady is not None and followed is not None and N - delay - steady >= 2 * P:
            # a repeating reference: the compensator's reference corrected per harmonic, the
            # drive the compensator's for it (from rest, its start-up consistent with the model)
            e_al = aim[:, :N - delay] - learn_y[:, delay:N]
            # c: what the drive followed beyond the reference as asked, plus the learnt step
            c = reference_correction(target, followed, e_al, P, steady, gains)
            c_full = c[:, (np.arange(N) - steady) % P]
            corrected = Reference(ref.t, ref.signal + c_full,
                                  ref.period_samples, ref.scale, ref.spec, ref.kind)
            # the law over a classical PI runs with the gain compensate chose for the first
            # drive (convergent_gain, as _inverse_gain's), not with the law's own default
            law = drive_kind_ in LAW_KINDS and model_class(model).exact_inverse_kind is None
            # the reference is not shaped again: the target was shaped once (compensate's
            # <output>_shaped), and a learnt correction stepping a little beyond the slew rate
            # had the whole record smoothed again, a trial 34 times worse; the drive is shaped
            _, drive = compensate(plant, corrected, drive_kind_, args.inversion, fade * T,
                                  args.limits, law_gain if law else args.gain,
                                  law_check_ if law else args.check, lead,
                                  shape=False)
            u_next, learnt = drive.inputs, drive.reference
            problems, shaped = list(drive.problems), list(drive.shaped)
            notes.append(f"note: the reference the compensator follows is learnt per harmonic of "
                         f"the period (the drive is compensate's for it, from rest; its "
                         f"{', '.join(learnt_names(model.output_names))} columns)")
        else:
            u_next = ilc.step(aim, learn_u, learn_y, P, steady, gains)
            # the fade-in is not judged: the base drive's start, faded into the learning as the
            # reference
            u_next = keep_start(learn_u, u_next, fade, ref.period_samples)
            # and ends as the base drive: the update's last samples read past the record
            u_next = keep_end(learn_u, u_next, settled_step(learn_u, fade))
            if plant.amplifier is not None and plant.amplifier.from_records:
                u_next, shaped = shape_drive(plant.amplifier, u_next, T, plant.units[0])
            elif plant.amplifier is not None:
                problems = plant.amplifier.check(u_next, T, args.limits, unit=plant.units[0])
                if problems:
                    u_next, _ = plant.amplifier.limit(u_next, T)
        # no start-up step beyond the settled drive's largest (as compensate's default)
        before = u_next
        u_next, more = (u_next, []) if verdict.remeasure else limit_start_up(
            u_next, fade, ref.period_samples,
            None if plant.amplifier is None else plant.amplifier.rest_voltages(),
            list(model.input_names), T, plant.units[0])
        if more:        # the limit the exported C needs to give this drive too
            more[-1] += export_slew_words(before, u_next, min(fade + max(ref.period_samples or 1, 1),
                                                              u_next.shape[1]), T, plant.amplifier)
        shaped += more
        # an input held on its range's edge after the fade-in, named as compensate names it
        edge = edge_hold_note(u_next, plant.amplifier, fade, T, None if plant.amplifier is None
                              else plant.amplifier.rest_voltages(), plant.units[0],
                              reference_at_rest(aim[:, :u_next.shape[1]], rest))
        owned = owned_problem(args.out, args.force)
        if owned:
            print_err(f"hammerstein learn: error: {owned}")
            return 2
        kind_text = "" if learnt is None or drive_kind_ is None else f", kind {drive_kind_}"
        unit_in, unit_out = plant.units          # the model's: the header's and the notes'
        comment = (f"learn drive: t [s]; {', '.join(model.input_names)} [{unit_in}]"
                   + ("" if learnt is None else
                      f"; {', '.join(learnt_names(model.output_names))} [{unit_out}]: the learnt "
                      f"reference the drive was computed for (fade-in included)")
                   + f"\nactuator {args.actuator}{kind_text}, sampling period {T:g} s, "
                   f"fade-in {fade} samples ({fade * T:g} s, {rest_lead_text(lead)}excluded from the metrics)\n"
                   f"{START_NOTE}\n"
                   f"{end_note(u_next, T, list(model.input_names), plant.amplifier, unit_in)}\n"
                   + (f"learned from {args.drive} and {args.measured}" if note is None else
                      f"not learnt: the best trial {state['trial']}'s drive ({BEST_FILE}), to "
                      f"measure it again ({args.drive} and {args.measured} were worse)"
                      if verdict.remeasure else
                      f"learned from the best trial {state['trial']} ({BEST_FILE}; {args.drive} "
                      f"and {args.measured} were worse)")
                   + f": delay {delay} samples, "
                   f"gain {gain:g}, Q {args.q_cutoff_hz:g} Hz"
                   + ("\nlearnt on the voltages (the reference does not repeat within the "
                      "record): no reference fed to the exported compensator reproduces this "
                      "drive; play it as a file" if learnt is None else "")
                   + (f"\nlimited by the amplifier: {'; '.join(problems)}" if problems else "")
                   + "".join(f"\nshaped: {n}" for n in shaped)
                   + ("" if edge is None else f"\nnote: {edge}"))
        if edge is not None:
            notes.append(f"note: {edge}")
        widths = None if plant.amplifier is None else plant.amplifier.range_widths()
        chatter = chatter_warnings(u_next, T, widths, list(model.input_names), unit=unit_in)
        severe = chatter_warnings(u_next, T, widths, list(model.input_names),
                                  CHATTER_REFUSE_FRACTION, unit_in)
        if severe and args.limits == "error":
            print_err(f"hammerstein learn: error: the next drive chatters, nothing written: "
                      f"{'; '.join(severe)} (--limits warn writes it with this warning)")
            return 1
        chatter = severe or chatter       # written anyway (--limits warn): the stronger words
        comment += "".join(f"\nwarning: {line}" for line in chatter)
        notes += [f"warning: {line}" for line in chatter]
        t = np.arange(N) * T
        # the drive and the history together, or none (a full disk); on a failure no directory
        # this command created is left behind
        with removed_if_failed(Path(args.out).parent, args.history), all_or_nothing():
            k = _write_outputs(args, model, t, u, y, u_next, comment, rec, ref, gains, best, state,
                               score, halvings, fingerprint, learnt, followed_now, shaped_ref,
                               (settled_max, score), (delay, window.start * T),
                               (verdict.rejections, None if lag is None or out_of_step is not None
                                else lag - delay), plant.units)
            rose = (_settled_rows(args.history, k, settled_max, settled_rms, score, margin,
                                  (delay, window.start * T), plant.units[1])
                    if args.history else None)
        if args.history:        # the digests of what was just written: a later change is seen
            write_history_manifest(args.history)
    except catch() as exc:
        print_err(f"hammerstein learn: error: {' '.join(str(exc).split())}")
        return 1
    return _summary(args, model, rec, ref, k, delay, T, delay_note, note or stall or verdict.info,
                    cond, settled=(settled_max, settled_rms, window, fade, as_asked, lag,
                                   judged_line),
                    rose=(rose, score, margin), notes=notes, worse=note is not None or not best,
                    static=plant.dynamics is None, remeasure=verdict.remeasure,
                    unit=plant.units[1])


def _write_outputs(args, model, t, u, y, u_next, comment, rec, ref, gains, best, state, score,
                   halvings, fingerprint, learnt=None, followed=None, shaped=None, settled=None,
                   aligned=None, rules=(0, None), units=("V", "µm")):
    """Write the next drive and, with ``--history``, the trial's history; the trial number or None.

    The state keeps the reference's ``fingerprint`` and samples of ``u_next`` (the drive the
    next trial must apply, :func:`_check_history`). ``learnt``: the reference ``u_next`` was
    computed for (its ``<output>_learnt`` columns); ``followed``: that of ``u`` (kept with the
    best trial); ``shaped``: the shaped reference learnt and judged (``<output>_shaped``,
    carried over from the drive learnt from); ``settled``: this trial's settled max Euclidean
    and judged errors [µm], for the convergence figure; ``aligned``: the delay removed
    [samples] and the window's start [s] of the errors (written in the history); ``rules``:
    the trials not learnt from in a row and the lag less the delay of this trial when it is
    learnt from (else None: the state's is kept); ``units``: the model's (input, output)
    units, the headers' (``HammersteinPlant.units``).
    """
    unit_in, unit_out = units
    columns = dict(zip(model.input_names, u_next))
    if learnt is not None:
        columns.update(zip(learnt_names(model.output_names), learnt))
    if shaped is not None:
        columns.update(zip([f"{o}_shaped" for o in model.output_names], shaped))
        comment += (f"\n{' '.join(f'{o}_shaped' for o in model.output_names)} [{unit_out}]: "
                    f"the shaped reference the drive aims at, learnt and judged (fade-in included)")
    safe_write(args.out, signals_csv(t, columns, comment), "drive file")
    if not args.history:
        return None
    k = _write_history(args.history, list(model.output_names), rec, ref.scale,
                       "the raster's size" if ref.kind == "raster" else "radius / amplitude",
                       args.out, settled, aligned, unit_out)
    if gains is not None:
        _save_gains(args.history, gains, unit_out)
    if best:
        columns = {**dict(zip(model.input_names, u)), **dict(zip(model.output_names, y))}
        if followed is not None:
            columns.update(zip(learnt_names(model.output_names), followed))
        if shaped is not None:
            columns.update(zip([f"{o}_shaped" for o in model.output_names], shaped))
        # the drive file's own header (fade-in, rest, kind): the file replays as a --drive
        head = "".join(f"\n{line[1:].strip()}" for line in head_lines(args.drive, 18)[1:]
                       if line.startswith("#"))
        safe_write(Path(args.history) / BEST_FILE, signals_csv(
            t, columns, f"learn best trial {k}: the drive [{unit_in}], its measured response "
            f"[{unit_out}]"
            + ("" if followed is None else f", the reference it was computed for [{unit_out}]")
            + ("" if shaped is None else f", the shaped reference it aims at [{unit_out}]")
            + "; replay it as --drive to re-measure the best drive" + head),
            "best trial file", root=args.history)
        state = {"trial": k, "score": score, "samples": t.size}
    _write_state(args.history, {**state, "halvings": halvings, "reference": fingerprint,
                                "drive": _drive_samples(u_next)[0], "rejections": rules[0],
                                "lag_offset": rules[1] if rules[1] is not None
                                else state.get("lag_offset")}, unit_out)
    return k


def _summary(args, model, rec, ref, k, delay, T, delay_note, note, cond, settled, rose, notes,
             worse=False, static=False, remeasure=False, unit="µm"):
    """Print the trial's error, notes and convergence condition; exit status 0.

    ``settled`` is (max, RMS Euclidean error [µm], the judged window, fade-in samples, the
    error against the reference as asked, the trial's measured lag or None, the judged line);
    ``rose`` is (the previous trial and its judged error when this one rose, else None,
    this trial's judged error, the noise margin [µm]); ``notes`` the kind-choice lines;
    ``worse``: the trial was worse than the best beyond the noise (not learnt from), or not
    better than it (within the noise): "monotonic" is then not said;
    ``static``: the model has no identified dynamics (its condition is its static gain's);
    ``remeasure``: the next drive is the best trial's own (not learnt); ``unit``: the
    model's output unit, the errors'.
    """
    settled_max, settled_rms, window, fade, as_asked, lag, judged_line = settled
    rose, score, margin = rose
    scale = f" ({100 * rec.max_euclidean_error / ref.scale:.3g} % of {ref.scale:g} {unit})" \
        if ref.scale else ""
    axes = ", ".join(f"{n} max {a:.4g} RMS {b:.4g}" for n, a, b in
                     zip(model.output_names, rec.max_error, rec.rms_error))
    trial = f"trial {k}: " if k is not None else ""
    rms_scale = f" ({100 * settled_rms / ref.scale:.3g} %)" if ref.scale else ""
    print(f"{trial}settled (from {window.start * T:.4g} s, after the {fade * T:.4g} s fade-in): "
          f"max Euclidean error {settled_max:.4g} {unit}{scale}, RMS {settled_rms:.4g} "
          f"{unit}{rms_scale}; {axes} {unit}; " + (f"measured delay {delay} samples ({delay * T * 1e6:.4g} µs)"
                             if lag is None else
                             f"delay removed {delay} samples ({delay * T * 1e6:.4g} µs), "
                             f"measured lag {lag} samples"), file=sys.stdout)
    print(judged_line, file=sys.stdout)
    if as_asked is not None:
        pct = f" ({100 * as_asked / ref.scale:.3g} %)" if ref.scale else ""
        print(f"errors against the shaped reference the drive aims at (its <output>_shaped "
              f"columns: the reference as asked is beyond the amplifier or the dynamics there; "
              f"against it the settled max is {as_asked:.4g} {unit}{pct})", file=sys.stdout)
    if delay_note is not None:
        print_err(delay_note)
    if note is not None:
        print(note, file=sys.stdout)
    summary = cond.summary(list(model.output_names))
    if static:                      # no dynamics: the model's static gain against itself
        summary = summary.replace("<= 1: monotonic", "<= 1 on the model's static gain only: it "
                                  "has no dynamics, the actuator's modes are not in it")
    elif rose is None and not worse:  # a new best: a condition on the model, not a measured fact
        # (a trial not better than the best, even within the noise, hears no "monotonic")
        summary = summary.replace("<= 1: monotonic", "<= 1: monotonic on the model")
    else:                           # the model's condition is not what the actuator did
        summary = summary.replace("<= 1: monotonic", "<= 1 on the model")
    if rose is not None:
        print(f"the judged settled error ({JUDGED}) rose from {rose[1]:.4g} {unit} (trial "
              f"{rose[0]}) to {score:.4g} {unit}, beyond the {margin:.2g} {unit} of noise: the "
              f"learning is not monotonic "
              f"on this actuator (the next drive is "
              + ("the best trial's own, to measure it again" if remeasure else
                 "learnt from the best trial") + ")", file=sys.stdout)
    print(summary, file=sys.stdout)
    for line in notes:
        print_err(line)
    if not cond.holds:
        lo, hi = cond.exceeds
        print_err(f"warning: the learning is not guaranteed to converge: ||I - gamma Q L G|| "
                  f"exceeds 1 from {lo:.4g} to {hi:.4g} Hz: lower --learning-gain or "
                  f"--q-cutoff-hz")
    print(f"wrote {args.out}", file=sys.stdout)
    if args.history:        # what the history holds now, as it is on disk
        names = sorted(p.name for p in Path(args.history).iterdir()
                       if p.is_file() and not p.name.startswith("."))
        print(f"wrote {args.history.rstrip('/')}/ ({', '.join(names)})", file=sys.stdout)
    return 0
