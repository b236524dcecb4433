"""``hammerstein compensate``: the drive file (input voltages) for a reference.

Builds the compensator of ``--kind`` from the actuator file exactly as a
scenario with ``model = "plant"`` does
(:func:`hammerstein.scenario.registry.build_compensator`), computes the
voltages from rest with :func:`hammerstein.core.drive.drive_signal` (fade-in,
ZPETC preview, the amplifier's limits) and writes ``t`` and one column per
input [V] at full precision, optionally the model-predicted outputs
(``<output>_predicted`` [µm], the preset's plant driven through its
amplifier).

Exit status: 0 written; 1 a bad file or reference, or a drive the
amplifier cannot deliver with ``--limits error`` (one line, nothing
written); 2 a usage error.
"""

from __future__ import annotations

import sys
from pathlib import Path

from hammerstein.cli._common import out_file_problem, print_err
from hammerstein.cli._hardware import (add_actuator_arguments, catch, load_actuator,
                                       load_reference, nonnegative_float, owned_problem)
from hammerstein.core.amplifier import LIMITS
from hammerstein.core.drive import (MIN_FADE_S, apply_amplifier, hardware_drive, rest_output,
                                    signals_csv, starts_at_rest)
from hammerstein.core.files import safe_write
from hammerstein.core.hammerstein_compensator import INVERSIONS
from hammerstein.exceptions import CompensatorDivergence, CompensatorError
from hammerstein.scenario.registry import build_compensator

__all__ = ["add_parser", "compensate"]

#: the kinds a drive file can be made with (``none`` drives nothing)
KINDS = ("hammerstein", "multivariable", "diagonal", "per-axis", "static-gain")


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
                   help="compensator (default: hammerstein for a preset with dynamics, else "
                        "multivariable)")
    p.add_argument("--inversion", choices=list(INVERSIONS), default="zpetc",
                   help="inverse of the dynamics (kind hammerstein; default zpetc)")
    p.add_argument("--fade-in", type=nonnegative_float, metavar="S",
                   help="fade-in from rest [s] (0 only for a reference that starts at rest; "
                        f"default: a duration, at least one period and {MIN_FADE_S:g} s, "
                        "lengthened until the drive never steps faster while fading in than "
                        "once settled, nor than the amplifier's slew rate)")
    p.add_argument("--limits", choices=list(LIMITS), default="error",
                   help="beyond the amplifier: error (default, nothing written), warn or clip "
                        "(the drive is clipped and slew-limited)")
    p.add_argument("--predicted", action="store_true",
                   help="add the model-predicted outputs <output>_predicted [µm]")
    p.add_argument("--force", action="store_true",
                   help="replace an --out file that hammerstein did not write")
    p.set_defaults(handler=_handle)


def compensate(plant, reference, kind=None, inversion="zpetc", fade_in=None, limits="error"):
    """Compensator and drive of a reference on an actuator (what the command writes).

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (its PI, dynamics and amplifier are the model).
    reference : hammerstein.cli._hardware.Reference
        The reference record.
    kind : str, optional
        Compensator kind (default: ``"hammerstein"`` with dynamics).
    inversion : {'zpetc', 'stable'}
    fade_in : float, optional
        [s]; 0 only for a reference that starts at rest.
    limits : {'error', 'warn', 'clip'}

    Returns
    -------
    comp : object
        The compensator.
    drive : hammerstein.core.drive.DriveResult

    Raises
    ------
    CompensatorError
        ``fade_in = 0`` for a reference that does not start at rest.
    """
    kind = kind or ("multivariable" if plant.is_static else "hammerstein")
    spec = {"kind": kind, "model": "plant"}
    if kind == "hammerstein":
        spec["inversion"] = inversion
        spec["creep"] = "plant"        # the actuator's creep (e.g. identified) is inverted with G
    comp = build_compensator(spec, plant, Path.cwd())
    fade = None if fade_in is None else int(round(fade_in / plant.sampling_period))
    if fade == 0 and not starts_at_rest(reference.signal):
        first = ", ".join(f"{n} = {v:.4g} µm" for n, v in
                          zip(plant.hysteresis.output_names, reference.signal[:, 0]))
        raise CompensatorError(
            f"--fade-in 0: the reference starts at {first}, not at rest (0 µm); the drive would "
            f"start with a step that the actuator (and the exported C, which starts at rest) "
            f"cannot follow: give a fade-in > 0 (default: one period, "
            f"{reference.period_samples * plant.sampling_period:g} s) or a reference that starts "
            f"at rest")
    drive = hardware_drive(comp, reference.signal, plant.sampling_period,
                           reference.period_samples, fade, plant.amplifier, limits,
                           rest=rest_output(plant.hysteresis))
    return comp, drive


def _handle(args):
    problem = out_file_problem(args.out, "drive file")
    if problem:
        print_err(f"hammerstein compensate: error: {problem}")
        return 2
    try:
        plant = load_actuator(args.actuator, args.sampling_period)
        ref = load_reference(args.reference, plant, args.time, args.outputs, args.period)
        if args.kind not in (None, "multivariable", "diagonal", "per-axis", "static-gain") \
                and plant.is_static:
            raise ValueError(f"--kind {args.kind}: {args.actuator} has no dynamics to invert; "
                             f"use --kind multivariable")
        _, drive = compensate(plant, ref, args.kind, args.inversion, args.fade_in, args.limits)
        owned = owned_problem(args.out, args.force)
        if owned:
            print_err(f"hammerstein compensate: error: {owned}")
            return 2
        cols = dict(zip(plant.hysteresis.input_names, drive.inputs))
        units = ", ".join(plant.hysteresis.input_names) + " [V]"
        if args.predicted:
            y, _ = plant.simulate(apply_amplifier(plant.amplifier, drive.inputs,
                                                  plant.sampling_period))
            cols.update({f"{n}_predicted": v for n, v in zip(plant.hysteresis.output_names, y)})
            units += "; " + ", ".join(f"{n}_predicted" for n in plant.hysteresis.output_names) \
                + " [µm] (model)"
        peaks = ", ".join(f"{n} {pk:.4g} V {sl:.4g} V/s" for n, pk, sl in
                          zip(plant.hysteresis.input_names, drive.peak_input, drive.peak_slew))
        comment = (f"compensate drive: t [s]; {units}\n"
                   f"actuator {args.actuator}, sampling period {plant.sampling_period:g} s, "
                   f"fade-in {drive.fade_samples} samples "
                   f"({drive.fade_samples * plant.sampling_period:g} s, excluded from the metrics)\n"
                   f"peak input and slew: {peaks}"
                   + (f"\nlimited by the amplifier: {'; '.join(drive.problems)}"
                      if drive.problems else "")
                   + "".join(f"\nshaped: {note}" for note in drive.shaped))
        safe_write(args.out, signals_csv(ref.t, cols, comment), "drive file")
    except CompensatorDivergence as exc:
        print_err(f"hammerstein compensate: error: the compensator diverged: {exc}")
        return 1
    except catch() as exc:
        print_err(f"hammerstein compensate: error: {' '.join(str(exc).split())}")
        return 1
    for note in drive.shaped:
        print(f"shaped: {note}", file=sys.stdout)
    if any("beyond the range" in n or "faster than" in n for n in drive.shaped) \
            and ref.kind == "raster" and not (ref.spec or {}).get("smoothing"):
        print("the raster's line steps and turns ask more than the records' limits: spread them "
              "with smoothing = S in the reference (a fraction of a line, e.g. 0.1)",
              file=sys.stdout)
    print(f"wrote {args.out} ({ref.t.size} samples, fade-in "
          f"{drive.fade_samples * plant.sampling_period:g} s, peak {peaks})", file=sys.stdout)
    return 0
