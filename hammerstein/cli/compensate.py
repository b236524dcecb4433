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
from pathlib import Path

import numpy as np

from hammerstein.cli._common import out_file_problem, print_err
from hammerstein.cli._hardware import (START_NOTE, add_actuator_arguments, catch, end_note,
                                       check_reference_first, load_actuator,
                                       load_reference, nonnegative_float, owned_problem)
from hammerstein.models.amplifier import LIMITS
from hammerstein.compensation.drive import (FADE_DECAYS, MIN_FADE_S, apply_amplifier,
                                            hardware_drive, rest_output, signals_csv,
                                            starts_at_rest)
from hammerstein.compensation.drive_files import rest_lead_text
from hammerstein.core.files import guard_inputs, output_problem, safe_write
from hammerstein.compensation.hammerstein_compensator import INVERSIONS
from hammerstein.compensation.lookahead import FIRST_SAMPLE_TOLERANCE
from hammerstein.compensation.model_classes import choose_kind, kind_problem
from hammerstein.compensation.reach import REACH_NOTE_START, output_reach, reach_note
from hammerstein.compensation.shaping import (CHATTER_REFUSE_FRACTION, chatter_warnings,
                                              first_mode_hz, mode_decay_s, mode_note, zpetc_note)
from hammerstein.exceptions import CompensatorDivergence, CompensatorError
from hammerstein.scenario.registry import build_compensator

__all__ = ["add_parser", "compensate"]

#: ``--fade-in 0`` takes a reference whose first sample is within this of the rest output [µm]
#: (the model's output at 0 V; the error message prints it to 7 digits)
REST_TOLERANCE = 1e-3
#: the kinds a drive file can be made with (``none`` drives nothing; ``ilc`` learns on the
#: hardware: ``hammerstein learn``)
KINDS = ("hammerstein", "multivariable", "diagonal", "per-axis", "static-gain", "preisach-inverse")
#: the kinds whose static part is the inverse multiplicative law (``--gain``, ``--check``)
LAW_KINDS = ("hammerstein", "multivariable", "diagonal")
#: what ``--gain`` and ``--check`` mean, for the messages of a law that may not converge
LAW_HINT = ("--gain midpoint|secant|identity sets K and --check warn runs a law that may not "
            "converge; without --kind the default kind chooses a convergent gain")


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
                        "multivariable, diagonal; default: the kind's, or the convergent gain the "
                        "default kind chooses)")
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
                   help="add the model-predicted outputs <output>_predicted [µm]")
    p.add_argument("--force", action="store_true",
                   help="replace an --out file that hammerstein did not write")
    p.set_defaults(handler=_handle)


def compensate(plant, reference, kind=None, inversion="zpetc", fade_in=None, limits="error",
               gain=None, check=None, rest_lead=None, shape=True):
    """Compensator and drive of a reference on an actuator (what the command writes).

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (its hysteresis model of any class, dynamics, creep and
        amplifier are the model).
    reference : hammerstein.cli._hardware.Reference
        The reference record.
    kind : str, optional
        Compensator kind (default: :func:`hammerstein.compensation.model_classes.choose_kind`).
    inversion : {'zpetc', 'stable'}
    fade_in : float, optional
        [s]; 0 only for a reference that starts at rest.
    limits : {'error', 'warn', 'clip'}
    gain : str or array_like, optional
        K of the inverse multiplicative law (default: the kind's, or the
        convergent gain of the default kind).
    check : {'error', 'warn', 'ignore'}, optional
        The law's convergence check (default the kind's, ``error``).
    rest_lead : int, optional
        With ``fade_in``: its first samples at rest [samples] (a drive file's, for ``learn``).
    shape : bool
        Shape the reference into the limits measured on the records (default); False
        shapes only the drive (:func:`hammerstein.compensation.drive.hardware_drive`).

    Returns
    -------
    comp : object
        The compensator.
    drive : hammerstein.compensation.drive.DriveResult
        Its ``notes`` name a harmonic of a periodic reference that the
        identified dynamics amplify at least twice over their static gain
        (:func:`hammerstein.compensation.shaping.mode_note`).

    Raises
    ------
    CompensatorError
        A kind that does not work with the model (naming those that do), or
        ``fade_in = 0`` for a reference that does not start at rest.
    """
    kind, options, _ = _kind_and_options(plant, kind, gain, check, inversion)
    spec = {"kind": kind, "model": "plant", **options}
    if kind == "hammerstein":
        spec["inversion"] = inversion
        spec["creep"] = "plant"        # the actuator's creep (e.g. identified) is inverted with G
    comp = build_compensator(spec, plant, Path.cwd())
    n = reference.signal.shape[1]
    if fade_in is not None and fade_in / plant.sampling_period > n:
        raise CompensatorError(
            f"--fade-in: {fade_in:g} s is longer than the reference ({n} samples, "
            f"{n * plant.sampling_period:g} s); expected at most {n * plant.sampling_period:g} s")
    fade = None if fade_in is None else int(round(fade_in / plant.sampling_period))
    rest = rest_output(plant.hysteresis, plant.creep)
    if fade == 0 and not starts_at_rest(reference.signal, rest, REST_TOLERANCE):
        names = plant.hysteresis.output_names
        first = ", ".join(f"{n} = {v:.7g} µm" for n, v in zip(names, reference.signal[:, 0]))
        at = ", ".join(f"{n} = {v:.7g} µm" for n, v in zip(names, rest))
        raise CompensatorError(
            f"--fade-in 0: the reference starts at {first}, not at rest ({at}: the model's "
            f"output at 0 V, within {REST_TOLERANCE:g} µm); the drive would start with a step "
            f"that the actuator (and the exported C, which starts there) cannot follow: give a "
            f"fade-in > 0 (the default: a duration, at least one period, {MIN_FADE_S:g} s and "
            f"{FADE_DECAYS:g} decay times of the slowest bending mode) or a reference that "
            f"starts at rest")
    T = plant.sampling_period

    at_rest = plant.rest_state()         # the actuator before the drive: settled at 0 V

    def predict(u):
        return plant.simulate(apply_amplifier(plant.amplifier, u, T), at_rest)[0]

    linear = plant.matrices              # creep then dynamics, built once
    drive = hardware_drive(comp, reference.signal, T, reference.period_samples, fade,
                           plant.amplifier, limits, rest=rest,
                           first_mode=first_mode_hz(linear[0], T), predict=predict,
                           names=plant.hysteresis.output_names, mode_decay=mode_decay_s(linear[0], T),
                           rest_lead=rest_lead, shape=shape)
    note = reach_note(output_reach(plant.hysteresis, plant.amplifier, plant.creep),
                      reference.signal, plant.hysteresis.output_names)
    if note:
        drive.notes.append(note)
    note = mode_note(linear, T, drive.reference, reference.period_samples)
    if note:
        drive.notes.append(note)
    zeros = _zpetc_zeros(comp)
    note = None if zeros is None else zpetc_note(zeros, T, drive.reference,
                                                 reference.period_samples)
    if note:
        drive.notes.append(note)
    note = _first_sample_note(plant, drive, inversion if kind == "hammerstein" else None)
    if note:
        drive.notes.append(note)
    return comp, drive


def _first_sample_note(plant, drive, inversion):
    """A note when the drive's first sample is not the rest voltage (beyond
    :data:`FIRST_SAMPLE_TOLERANCE`), or None."""
    off = np.asarray(drive.inputs, dtype=float)[:, 0] - _rest_voltages(plant)
    if np.max(np.abs(off)) <= FIRST_SAMPLE_TOLERANCE:
        return None
    why = ("the stable inversion's anti-causal part, G's zeros outside the unit circle, starts "
           "acting before the reference moves and had not decayed over the fade's rest lead (a "
           "zero near the unit circle decays slowly: the default fade-in lengthens its rest "
           "lead up to a quarter of the record; a longer record, or a longer --fade-in, gives "
           "it room)"
           if inversion == "stable" else
           "the inverse's start at rest, within its tolerance")
    return ("the drive's first sample is " + ", ".join(
        f"{n} {v:+.3g} V" for n, v in zip(plant.hysteresis.input_names, off))
            + f" from rest: {why}")


def _rest_voltages(plant):
    """Each input's rest voltage [V]: the amplifier's, 0 without one."""
    return (np.zeros(plant.hysteresis.n_inputs) if plant.amplifier is None
            else plant.amplifier.rest_voltages())


def _zpetc_zeros(comp):
    """The zeros of G a Hammerstein compensator's ZPETC inverse approximates, or None."""
    return getattr(getattr(comp, "inverse", None), "unacceptable_zeros", None)


def _kind_and_options(plant, kind, gain, check, inversion="zpetc"):
    """(kind, options of the kind, the note of a chosen kind or None).

    A given kind is checked against the model's class (the message names the
    kinds that work); none given: :func:`hammerstein.compensation.model_classes.choose_kind`.
    """
    note = None
    if kind is None:
        choice = choose_kind(plant.hysteresis, not plant.is_static, gain, inversion or "zpetc")
        kind, options, note = choice.kind, dict(choice.options), choice.note()
    else:
        problem = kind_problem(plant.hysteresis, kind, not plant.is_static)
        if problem:
            raise CompensatorError(problem)
        options = {}
    if kind in LAW_KINDS:
        if gain is not None:
            options["gain"] = gain
        if check is not None:
            options["check"] = check
    elif gain is not None or check is not None:
        raise CompensatorError(f"--gain/--check: kind {kind!r} has no inverse multiplicative law "
                               f"(they apply to {', '.join(LAW_KINDS)})")
    return kind, options, note


def _peaks_text(plant, drive):
    """Each input's peak |u| [V] and slew [V/s] of the drive as written (the first step from
    rest), and the compensator's own where the limits changed them."""
    names = plant.hysteresis.input_names
    u = np.asarray(drive.inputs, dtype=float)
    steps = np.abs(np.diff(np.concatenate([_rest_voltages(plant)[:, None], u], axis=1), axis=1))
    peak, slew = np.max(np.abs(u), axis=1), steps.max(axis=1) / plant.sampling_period
    text = ", ".join(f"{n} {pk:.4g} V {sl:.4g} V/s" for n, pk, sl in zip(names, peak, slew))
    if not (np.allclose(peak, drive.peak_input, rtol=1e-9, atol=1e-9)
            and np.allclose(slew, drive.peak_slew, rtol=1e-9, atol=1e-6)):
        text += " (the compensator asked for " + ", ".join(
            f"{n} {pk:.4g} V {sl:.4g} V/s" for n, pk, sl in
            zip(names, drive.peak_input, drive.peak_slew)) + " before the limits)"
    return text


def _handle(args):
    problem = out_file_problem(args.out, "drive file")
    if not problem:
        guard_inputs(args.actuator, args.reference)   # never an output, even with --force
        problem = output_problem(args.out)
        problem = f"--out: {problem}" if problem else None
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
        _, drive = compensate(plant, ref, kind, args.inversion, args.fade_in, args.limits,
                              options.get("gain"), options.get("check"))
        owned = owned_problem(args.out, args.force)
        if owned:
            print_err(f"hammerstein compensate: error: {owned}")
            return 2
        cols = dict(zip(plant.hysteresis.input_names, drive.inputs))
        units = ", ".join(plant.hysteresis.input_names) + " [V]"
        shaped_cols = ""
        if any("reference shaped" in line for line in drive.shaped):
            names = [f"{n}_shaped" for n in plant.hysteresis.output_names]
            cols.update(zip(names, drive.reference))
            shaped_cols = (f"\n{' '.join(names)} [µm]: the shaped reference the drive follows "
                           f"(fade-in included)")
        if args.predicted:
            y, _ = plant.simulate(apply_amplifier(plant.amplifier, drive.inputs,
                                                  plant.sampling_period), plant.rest_state())
            cols.update({f"{n}_predicted": v for n, v in zip(plant.hysteresis.output_names, y)})
            units += "; " + ", ".join(f"{n}_predicted" for n in plant.hysteresis.output_names) \
                + " [µm] (model)"
        peaks = _peaks_text(plant, drive)
        rest_text = ", ".join(f"{n} = {float(v)!r} µm" for n, v in zip(
            plant.hysteresis.output_names, rest_output(plant.hysteresis, plant.creep)))
        widths = None if plant.amplifier is None else plant.amplifier.range_widths()
        chatter = chatter_warnings(drive.inputs, plant.sampling_period, widths,
                                   list(plant.hysteresis.input_names))
        severe = chatter_warnings(drive.inputs, plant.sampling_period, widths,
                                  list(plant.hysteresis.input_names), CHATTER_REFUSE_FRACTION)
        if severe and args.limits == "error":
            cause = "".join(f"{n}; " for n in drive.notes if n.startswith(REACH_NOTE_START))
            print_err(f"hammerstein compensate: error: the drive chatters, nothing written: "
                      f"{cause}{'; '.join(severe)} (--limits warn writes it with this warning)")
            return 1
        chatter = severe or chatter       # written anyway (--limits warn): the stronger words
        ending = end_note(drive.inputs, plant.sampling_period,
                          list(plant.hysteresis.input_names), plant.amplifier)
        comment = (f"compensate drive: t [s]; {units}\n"
                   f"actuator {args.actuator}, kind {kind}, sampling period "
                   f"{plant.sampling_period:g} s, fade-in {drive.fade_samples} samples "
                   f"({drive.fade_samples * plant.sampling_period:g} s, "
                   f"{rest_lead_text(drive.rest_lead)}excluded from the metrics) "
                   f"from the rest output {rest_text} (the model's output at 0 V)\n"
                   f"peak input and slew: {peaks}\n"
                   f"{START_NOTE}\n{ending}" + shaped_cols
                   + (f"\nlimited by the amplifier: {'; '.join(drive.problems)}"
                      if drive.problems else "")
                   + "".join(f"\nshaped: {line}" for line in drive.shaped)
                   + "".join(f"\nnote: {line}" for line in drive.notes)
                   + "".join(f"\nwarning: {line}" for line in chatter))
        safe_write(args.out, signals_csv(ref.t, cols, comment), "drive file")
    except CompensatorDivergence as exc:
        print_err(f"hammerstein compensate: error: the compensator diverged: {exc}")
        return 1
    except catch() as exc:
        text = ' '.join(str(exc).split())
        if "rho(I - K^-1 J)" in text:
            text += f" ({LAW_HINT})"
        if note:
            text += f" (kind {kind}, the default for this model; --kind names another)"
        print_err(f"hammerstein compensate: error: {text}")
        return 1
    if note:
        print_err(note)
    for line in drive.shaped:
        print(f"shaped: {line}", file=sys.stdout)
    for line in drive.notes:
        print(f"note: {line}", file=sys.stdout)
    for line in chatter:
        print_err(f"warning: {line}")
    if any(w in n for n in drive.shaped for w in ("beyond the range", "faster than",
                                                     "reference shaped")) \
            and ref.kind == "raster" and not (ref.spec or {}).get("smoothing"):
        print("the raster's line steps and turns were shaped (above): to choose how, spread them "
              "with smoothing = S in the reference (a fraction of a line, e.g. 0.1)",
              file=sys.stdout)
    print(f"wrote {args.out} ({ref.t.size} samples, fade-in "
          f"{drive.fade_samples * plant.sampling_period:g} s, peak {peaks})", file=sys.stdout)
    return 0
