"""``hammerstein compensate``: the drive file (input voltages) for a reference.

Builds the compensator of ``--kind`` from the actuator file exactly as a
scenario with ``model = "plant"`` does
(:func:`hammerstein.scenario.registry.build_compensator`), computes the
voltages from rest with :func:`hammerstein.compensation.drive.drive_signal` (fade-in,
ZPETC preview, the amplifier's limits) and writes ``t`` and one column per
input [V] at full precision, optionally the model-predicted outputs
(``<output>_predicted`` [µm], the preset's plant driven through its
amplifier from its rest state, ``HammersteinPlant.rest_state``). With
limits measured on the identification records, a
reference the drive would leave them for (a raster's line steps, a range
beyond the records) is shaped first
(:func:`hammerstein.compensation.shaping.shape_reference`), printed and
written in the header, and the shaped reference is written as
``<output>_shaped`` [µm].

Exit status: 0 written; 1 a bad file or reference, or, with ``--limits
error`` (the default), a drive the amplifier cannot deliver or one that
chatters (:func:`hammerstein.compensation.shaping.chatter_warnings`: steps
of alternating sign on consecutive samples, each beyond
:data:`~hammerstein.compensation.shaping.CHATTER_REFUSE_FRACTION` of the
range) (one line, nothing written); 2 a usage error.
"""

from __future__ import annotations

import sys

import numpy as np

from hammerstein.cli._common import out_file_problem, print_err
from hammerstein.cli._output import tty_progress
from hammerstein.cli._hardware import (START_NOTE, add_actuator_arguments, catch, end_note,
                                       check_reference_first, load_actuator,
                                       load_reference, nonnegative_float, owned_problem)
from hammerstein.models.amplifier import LIMITS
from hammerstein.compensation.drive import (FADE_DECAYS, MIN_FADE_S, ROUNDING_WORDS,
                                            apply_amplifier, compensator_rest)
from hammerstein.compensation.drive_files import rest_lead_text, signals_writer
from hammerstein.compensation.drive_size import drive_file_limit
from hammerstein.core.files import guard_inputs, output_problem, safe_write
from hammerstein.compensation.hammerstein_compensator import INVERSIONS
from hammerstein.compensation.reach import REACH_NOTE_START
from hammerstein.compensation.shaping import (CHATTER_REFUSE_FRACTION, RANGE_MARGINS,
                                              chatter_warnings)
from hammerstein.exceptions import CompensatorDivergence, FileLimitError
from hammerstein.signals.fundamental import reference_fundamental
from hammerstein.scenario.hardware_route import (_kind_and_options, _rest_voltages,
                                                 compensate_reference, plant_units)

__all__ = ["add_parser", "compensate"]

#: the kinds a drive file can be made with (``none`` drives nothing; ``ilc`` learns on the
#: hardware: ``hammerstein learn``)
KINDS = ("hammerstein", "multivariable", "diagonal", "per-axis", "static-gain", "preisach-inverse")
#: a reference of at least this many samples has each pass of the compensator over it said on a
#: terminal (a 60 s circle at 20 kHz over an identified Preisach model: four passes, 30 s)
PROGRESS_SAMPLES = 200_000
#: what ``--gain`` and ``--check`` mean, for the messages of a law that may not converge
LAW_HINT = ("--gain midpoint|secant|identity sets K and --check warn runs a law that may not "
            "converge; without --gain, kinds hammerstein and multivariable take a gain that "
            "converges where their own does not")


def add_parser(subparsers):
    """Register the ``compensate`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "compensate", help="write the drive file (input voltages) for a reference",
        description="Compute the input voltages that make the actuator follow a reference, "
                    "from rest and within the amplifier's limits, and write them as a CSV "
                    "drive file (t [s], one column per input [V]).")
    add_actuator_arguments(p)
    p.add_argument("--out", required=True, metavar="DRIVE.csv", help="drive file to write")
    p.add_argument("--kind", choices=KINDS, default=None,
                   help="compensator (default: the best for the model, printed with why: "
                        "hammerstein with dynamics, else the exact inverse of a Preisach or "
                        "generalised-PI model, else multivariable with a convergent gain; "
                        "docs/models-and-kinds.md)")
    p.add_argument("--gain", choices=["secant", "midpoint", "identity"], default=None,
                   help="normalisation K of the inverse multiplicative law (kinds hammerstein, "
                        "multivariable, diagonal; default: the kind's own, midpoint for "
                        "hammerstein and secant for the others, or the convergent gain where "
                        "the kind's own does not converge)")
    p.add_argument("--check", choices=["error", "warn", "ignore"], default=None,
                   help="when rho(I - K^-1 J) >= 1: error (default, nothing written), warn or "
                        "ignore")
    p.add_argument("--inversion", choices=list(INVERSIONS), default="zpetc",
                   help="inverse of the dynamics (kind hammerstein; default zpetc)")
    p.add_argument("--fade-in", type=nonnegative_float, metavar="S",
                   help="fade-in from rest [s] (0 only for a reference that starts at rest; "
                        f"default: a duration, at least one period, {MIN_FADE_S:g} s and "
                        f"{FADE_DECAYS:g} decay times of the slowest identified bending mode, "
                        "lengthened until the drive never steps faster while fading in than "
                        "once settled, nor than the amplifier's slew rate)")
    p.add_argument("--limits", choices=list(LIMITS), default="error",
                   help="beyond the amplifier, or a drive that chatters: error (default, "
                        "nothing written), warn or clip (the drive is clipped and slew-limited; "
                        "a chattering drive is written with a warning)")
    p.add_argument("--predicted", action="store_true",
                   help="add the model-predicted outputs <output>_predicted, in the model's "
                        "output unit (µm by default)")
    p.add_argument("--force", action="store_true",
                   help="replace an --out file that hammerstein did not write, or a drive "
                        "changed since it wrote it (a measured column added)")
    p.set_defaults(handler=_handle)


def compensate(plant, reference, kind=None, inversion="zpetc", fade_in=None, limits="error",
               gain=None, check=None, rest_lead=None, shape=True, progress=None):
    """:func:`hammerstein.scenario.hardware_route.compensate_reference` of a command's reference.

    Parameters
    ----------
    plant : HammersteinPlant
    reference : hammerstein.cli._hardware.Reference
        Its ``signal`` [µm] and ``period_samples``.
    kind, inversion, fade_in, limits, gain, check, rest_lead, shape, progress
        As :func:`~hammerstein.scenario.hardware_route.compensate_reference`.

    Returns
    -------
    comp : object
    drive : hammerstein.compensation.drive.DriveResult
    """
    return compensate_reference(plant, reference.signal, reference.period_samples, kind,
                                inversion, fade_in, limits, gain, check, rest_lead, shape,
                                progress)


def _peaks_text(plant, drive):
    """Each input's peak |u| and slew of the drive as written (the first step from rest), and
    the compensator's own where the limits changed them, in the model's input unit."""
    names, unit = plant.hysteresis.input_names, plant_units(plant)[0]
    u = np.asarray(drive.inputs, dtype=float)
    steps = np.abs(np.diff(np.concatenate([_rest_voltages(plant)[:, None], u], axis=1), axis=1))
    peak, slew = np.max(np.abs(u), axis=1), steps.max(axis=1) / plant.sampling_period
    text = ", ".join(f"{n} {pk:.4g} {unit} {sl:.4g} {unit}/s"
                     for n, pk, sl in zip(names, peak, slew))
    asked = ", ".join(f"{n} {pk:.4g} {unit} {sl:.4g} {unit}/s" for n, pk, sl in
                      zip(names, drive.peak_input, drive.peak_slew))
    if asked != text:       # the same numbers as printed: nothing the limits changed to tell
        # the start-up's slew limit changes them too, with no amplifier limit hit (a new user
        # read "before the limits" as the amplifier's): said as what it is
        text += (f" (the compensator asked for {asked} before the start-up's slew limit or "
                 f"the amplifier's; the header's lines say which)")
    return text


#: A shaped reference departing from the one asked by more than this share of its half-span
#: after the fade-in is a warning, not only a ``shaped:`` line.
SHRINK_WARNING = 0.25
#: ... by more than this share, held back by a slew taken from the records (not by their
#: range), the drive follows less than half of the reference: with ``--limits error`` (the
#: default) nothing is written
SHRINK_REFUSE = 0.5
#: ... judged at this quantile of the departure after the fade-in, per output (on a quarter of
#: the samples)
SHRINK_QUANTILE = 0.75


def _shrink_warning(plant, ref, drive):
    """The warning for a reference shaped far from the one asked, or None.

    A model identified on quasi-static records only (1 Hz: 63 V/s) took
    their slew as the amplifier's, and a 10 µm circle at 20 Hz was shaped
    to 0.67 µm with one ``shaped:`` line and exit 0.

    Returns
    -------
    tuple of (str, bool) or None
        The warning, and whether the slew taken from the records held the
        reference back by more than :data:`SHRINK_REFUSE` of its half-span
        (a refusal under ``--limits error``).
    """
    amp = plant.amplifier
    if amp is None or not getattr(amp, "from_records", False):
        return None
    if not drive.limited:
        # only the band limit below the first mode changed it (a step-and-hold's steps
        # smoothed over a period of the mode): widening the table changes nothing, and the
        # shaped: lines say where (a stage whose table was widened to +-1000 V and 1e9 V/s
        # was told its limits held a 10-step reference back by 69 % of its half-span)
        return None
    asked = np.asarray(ref.signal, dtype=float)
    got = np.asarray(drive.reference, dtype=float)
    n = min(asked.shape[1], got.shape[1])
    start = min(int(drive.fade_samples), n)
    if n - start < 2:
        return None
    half = 0.5 * np.ptp(asked[:, start:n], axis=1)
    gap = np.abs(got[:, start:n] - asked[:, start:n])
    dev = np.max(gap, axis=1)
    # judged on most of the samples (SHRINK_QUANTILE), not on the largest: a staircase's or a
    # raster's steps are shaped by their whole height on a few samples each (a 5-level
    # staircase: 99 % of its half-span at the steps, its levels all reached, was told the range
    # held it back), a circle too fast for the slew on every sample
    typical = np.quantile(gap, SHRINK_QUANTILE, axis=1)
    share = np.where(half > 0, typical / np.where(half > 0, half, 1.0), 0.0)
    k = int(np.argmax(share))
    if share[k] <= SHRINK_WARNING:
        return None
    unit_in, unit_out = plant_units(plant)          # the model's
    limits = "; ".join(f"{name} [{c.low:g}, {c.high:g}] {unit_in}, {c.slew_rate:.4g} {unit_in}/s"
                       for name, c in zip(amp.inputs, amp.channels))
    u = np.asarray(drive.inputs, dtype=float)[:, start:]
    # within what the range stage's margins leave inside the range (shaping.RANGE_MARGINS)
    edge = [(1.0 - min(RANGE_MARGINS)) * 0.5 * (c.high - c.low) for c in amp.channels]
    at_edge = [name for name, c, row, e in zip(amp.inputs, amp.channels, u, edge)
               if drive.range_limited and row.size
               and (row.max() >= c.high - e or row.min() <= c.low + e)]
    head = (f"the reference was shaped by up to {dev[k]:.3g} {unit_out} on "
            f"{plant.hysteresis.output_names[k]}, by {100 * share[k]:.3g} % of its half-span or "
            f"more on a quarter of the samples after the fade-in: the limits measured on the records "
            f"({limits}) hold it back")
    # the slew, when the drive moves at the records' slew somewhere after the fade-in (a
    # 1 Hz record's 63 V/s); else the range (a file circle beyond the reach, smoothed by the
    # range stage to 21 % of its size, its drive neither at the edge nor at the slew)
    steps = np.abs(np.diff(u, axis=1)) / plant.sampling_period if u.shape[1] > 1 else u[:, :0]
    # the range stage scales the reference a few % inside the limit it left (RANGE_MARGINS),
    # so a slew-bound drive may stay below 0.99 of the slew (a 30 µm circle at 80 Hz behind
    # 2000 V/s: 1918-1931 V/s, told the range held it back and written): its words say which
    by_slew = any(f"reaches within the {left}" in line for line in drive.shaped
                  for left in ("slew rate", "range and slew rate"))
    slew_bound = [name for name, c, row in zip(amp.inputs, amp.channels, steps)
                  if row.size and (row.max() >= 0.99 * c.slew_rate
                                   or (by_slew and row.max() >= min(RANGE_MARGINS) * c.slew_rate))]
    if at_edge or not slew_bound:      # the range, not the slew: faster records would not help
        where = (f"The drive sits at the edge of the range on {', '.join(at_edge)}" if at_edge
                 else "The drive stays below the records' slew")
        return (f"{head}. {where}: the "
                f"reference asks more than the records' range reaches there (with the "
                f"cross-couplings); make it smaller or move its center, or, if your amplifier "
                f"goes further than the records did, widen the model file's [amplifier] range "
                f"(docs/drives.md)"), False
    return (f"{head}. If your amplifier slews faster than the records did (a 1 Hz record's "
            f"slew is its own), widen the model file's [amplifier] table to its limits "
            f"(docs/drives.md) or identify on faster records; if those are its limits, the "
            f"reference is faster than it can follow: lower its frequency or its size"), \
        bool(share[k] > SHRINK_REFUSE)


def _handle(args):
    problem = out_file_problem(args.out, "drive file", (args.actuator, args.reference))
    if not problem:
        guard_inputs(args.actuator, args.reference)   # never an output, even with --force
        problem = output_problem(args.out)
        problem = f"--out: {problem}" if problem else None
    if not problem:     # before the drive's computation (a minute on a long reference), and after
        problem = owned_problem(args.out, args.force)
    if problem:
        print_err(f"hammerstein compensate: error: {problem}")
        return 2
    kind = note = None
    try:
        check_reference_first(args.actuator, args.sampling_period, args.reference, args.time,
                              args.outputs, args.period)     # the budget before re-sampling
        plant = load_actuator(args.actuator, args.sampling_period)
        ref = load_reference(args.reference, plant, args.time, args.outputs, args.period)
        kind, options, note = _kind_and_options(plant, args.kind, args.gain, args.check,
                                                args.inversion)
        comp, drive = compensate(plant, ref, kind, args.inversion, args.fade_in, args.limits,
                                 options.get("gain"), options.get("check"),
                                 progress=(tty_progress("compensate") if ref.signal.shape[1]
                                           >= PROGRESS_SAMPLES else None))
        owned = owned_problem(args.out, args.force)
        if owned:
            print_err(f"hammerstein compensate: error: {owned}")
            return 2
        cols = dict(zip(plant.hysteresis.input_names, drive.inputs))
        unit_in, unit_out = plant.units          # the model's: the header's and the notes'
        units = ", ".join(plant.hysteresis.input_names) + f" [{unit_in}]"
        shaped_cols = ""
        # the reference the drive follows differs from the one asked (shaped into the limits,
        # or its start-up corrected): its columns, which the exported C is fed
        if any(w in line for line in drive.shaped
               for w in ("reference shaped", "corrected in the reference")):
            names = [f"{n}_shaped" for n in plant.hysteresis.output_names]
            cols.update(zip(names, drive.reference))
            shaped_cols = (f"\n{' '.join(names)} [{unit_out}]: the shaped reference the drive follows "
                           f"(fade-in included)")
        if args.predicted:
            y, _ = plant.simulate(apply_amplifier(plant.amplifier, drive.inputs,
                                                  plant.sampling_period), plant.rest_state())
            cols.update({f"{n}_predicted": v for n, v in zip(plant.hysteresis.output_names, y)})
            units += "; " + ", ".join(f"{n}_predicted" for n in plant.hysteresis.output_names) \
                + f" [{unit_out}] (model)"
        peaks = _peaks_text(plant, drive)
        rest_text = ", ".join(f"{n} = {float(v)!r} {unit_out}" for n, v in zip(
            plant.hysteresis.output_names, compensator_rest(plant.hysteresis, comp)))
        widths = None if plant.amplifier is None else plant.amplifier.range_widths()
        chatter = chatter_warnings(drive.inputs, plant.sampling_period, widths,
                                   list(plant.hysteresis.input_names), unit=unit_in)
        severe = chatter_warnings(drive.inputs, plant.sampling_period, widths,
                                  list(plant.hysteresis.input_names), CHATTER_REFUSE_FRACTION,
                                  unit_in)
        if severe and args.limits == "error":
            cause = "".join(f"{n}; " for n in drive.notes if n.startswith(REACH_NOTE_START))
            print_err(f"hammerstein compensate: error: the drive chatters, nothing written: "
                      f"{cause}{'; '.join(severe)} (--limits warn writes it with this warning)")
            return 1
        chatter = severe or chatter       # written anyway (--limits warn): the stronger words
        shrink = _shrink_warning(plant, ref, drive)
        if shrink and shrink[1] and args.limits == "error":
            # a student's model from 1 Hz records alone (63 V/s): 20 µm circles at 10-150 Hz
            # were shaped by 95-117 % of their half-span, written with exit 0, and followed
            # nothing on his stage
            print_err(f"hammerstein compensate: error: the drive would follow less than half "
                      f"of the reference, nothing written: {shrink[0]} (--limits warn writes "
                      f"it with this warning)")
            return 1
        ending = end_note(drive.inputs, plant.sampling_period,
                          list(plant.hysteresis.input_names), plant.amplifier, unit_in)
        comment = (f"compensate drive: t [s]; {units}\n"
                   f"actuator {args.actuator}, kind {kind}, sampling period "
                   f"{plant.sampling_period:g} s, fade-in {drive.fade_samples} samples "
                   f"({drive.fade_samples * plant.sampling_period:g} s, "
                   f"{rest_lead_text(drive.rest_lead)}excluded from the metrics) "
                   f"from the rest output {rest_text} (the model's output at 0 {unit_in})\n"
                   f"peak input and slew: {peaks}\n"
                   f"{START_NOTE}\n{ending}" + shaped_cols
                   + (f"\nlimited by the amplifier: {'; '.join(drive.problems)}"
                      if drive.problems else "")
                   + "".join(f"\nshaped: {line}" for line in drive.shaped)
                   + "".join(f"\nnote: {line}" for line in ref.notes + list(drive.notes))
                   + "".join(f"\nwarning: {line}" for line in chatter))
        # written by blocks of rows (the whole text had taken 1.8 GB for 3e6 samples), within
        # the limit evaluate and learn read a drive file of these columns in: the largest
        # drive of the largest accepted record (a 10-minute drive at 20 kHz, 640 MiB, had
        # been written, then refused by evaluate at once)
        safe_write(args.out, signals_writer(ref.t, cols, comment,
                                            cap=drive_file_limit(len(cols) + 1)), "drive file")
    except CompensatorDivergence as exc:
        print_err(f"hammerstein compensate: error: the compensator diverged: {exc}")
        return 1
    except catch() as exc:
        text = ' '.join(str(exc).split())
        if "rho(I - K^-1 J)" in text and "--check warn" not in text:
            text += f" ({LAW_HINT})"
        if isinstance(exc, FileLimitError):     # a file's problem: the kind is not its cause
            pass
        elif note and args.kind is None:
            text += f" (kind {kind}, the default for this model; --kind names another)"
        elif note:          # the gain chosen for the kind named: said, as on success
            text += f" ({note.removeprefix('note: ')})"
        print_err(f"hammerstein compensate: error: {text}")
        return 1
    if note:
        print_err(note)
    if kind == "hammerstein" and getattr(plant, "dynamics_problem", None):
        print_err(f"warning: {plant.dynamics_problem}")
    for line in drive.shaped:
        if ROUNDING_WORDS not in line:          # the header keeps it
            print(f"shaped: {line}", file=sys.stdout)
    for line in ref.notes + list(drive.notes):
        print_err(f"note: {line}")
    if ref.kind == "file" and args.period is None:     # a repeating file, its period not given
        found = reference_fundamental(ref.signal, plant.sampling_period)
        if found is not None and found.repeat_samples:
            L = found.repeat_samples
            print_err(f"note: {args.reference} repeats every {L * plant.sampling_period:.6g} s "
                      f"({L} samples) and --period was not given: --period "
                      f"{L * plant.sampling_period:.6g} continues it over whole periods, fades "
                      f"it in over one, and has learn learn it per harmonic of that period")
    for line in chatter:
        print_err(f"warning: {line}")
    if shrink:
        print_err(f"warning: {shrink[0]}")
    if any(w in n for n in drive.shaped for w in ("beyond the range", "faster than",
                                                     "reference shaped")) \
            and ref.kind == "raster" and not (ref.spec or {}).get("smoothing"):
        print("the raster's line steps and turns were shaped (above): to choose how, spread them "
              "with smoothing = S in the reference (a fraction of a line, e.g. 0.1)",
              file=sys.stdout)
    print(f"wrote {args.out} ({ref.t.size} samples, fade-in "
          f"{drive.fade_samples * plant.sampling_period:g} s, peak {peaks})", file=sys.stdout)
    return 0
