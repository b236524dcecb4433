"""``hammerstein export``: a compensator as dependency-free C99 code or as an FMU.

``hammerstein export MODEL_OR_PRESET --target c|fmu --out DIR [--name NAME]
[--kind KIND] [--inversion zpetc] [--precision double|float] ...`` builds the
compensator of ``KIND`` on the preset or model file (the scenario defaults:
:mod:`hammerstein.export.build`), generates its C code
(:func:`hammerstein.export.export_c`) and writes ``DIR/NAME.h`` and
``DIR/NAME.c`` (``--target c``) or ``DIR/NAME.fmu`` (``--target fmu``, FMI 2.0
co-simulation with the sources and, when a C compiler is found, a binary for
this machine). See docs/real-time.md.

Exit status: 0 on success; 1 when the compensator cannot be built or
exported (one line naming what cannot be); 2 on a usage error. Nothing is
written unless everything succeeded; a file that hammerstein export did not
write is never replaced without ``--force``.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np

from hammerstein import __version__
from hammerstein.cli._common import number_type, out_dir_problem, print_err
from hammerstein.core.files import guard_inputs
from hammerstein.compensation.model_classes import kind_problem
from hammerstein.compensation.kind_choice import choose_kind, explicit_law
from hammerstein.core.numbers import MAX_ITERATIONS, integer_problem
from hammerstein.exceptions import (CompensatorError, ExportError, FeedbackError, FileLimitError,
                                    HammersteinWarning,
                                    PresetError)
from hammerstein.export import MARKER, check_name, export_c
from hammerstein.export.c_code import struct_ints
from hammerstein.export.build import (KINDS, REFUSED_KINDS, check_fmu_owned, check_owned,
                                      compensator_from_source,
                                      limits_from_table, load_source, write_files)
from hammerstein.export.feedback_c import export_feedback_c
from hammerstein.export.fmu import build_fmu, find_compiler
from hammerstein.io.presets import load_plant, read_toml, resolve_preset
from hammerstein.models.plant import HammersteinPlant
from hammerstein.scenario.feedback import build_loops
from hammerstein.scenario.feedback_table import check_feedback_table

__all__ = ["add_parser", "handler"]


def add_parser(subparsers):
    """Register ``hammerstein export`` (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "export", help="write a compensator as C99 code or as an FMI 2.0 FMU",
        description="Build the compensator of --kind on a preset or model file and write it as "
                    "dependency-free C99 (NAME.h, NAME.c: static tables, no allocation) or as an "
                    "FMI 2.0 co-simulation FMU (sources, and a binary for this machine when a C "
                    "compiler is found). See docs/real-time.md.")
    p.add_argument("source", metavar="MODEL_OR_PRESET",
                   help="bundled preset name, preset file or model file (TOML)")
    p.add_argument("--target", choices=["c", "fmu"], default="c",
                   help="C sources (default) or an FMI 2.0 FMU")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--name", metavar="NAME",
                   help="C prefix and file stem (default: <preset>_<kind>, as a C identifier of at "
                        "most 40 characters, the preset's name shortened to keep the kind whole)")
    p.add_argument("--kind", choices=list(KINDS) + list(REFUSED_KINDS), default=None,
                   help="compensator kind (default: the best for the model, printed with why: "
                        "hammerstein with dynamics, else the exact inverse of a Preisach or "
                        "generalised-PI model, else multivariable with a convergent gain; "
                        "docs/models-and-kinds.md). --kind none (no compensator) is refused "
                        "on its own, since there is nothing to export; with --closed-loop it "
                        "exports the controller alone")
    p.add_argument("--inversion", choices=["zpetc", "stable"], default=None,
                   help="inverse of the dynamics for --kind hammerstein (default zpetc; stable: "
                        "a filter of the reference PREVIEW samples ahead, docs/real-time.md)")
    p.add_argument("--gain", choices=["secant", "midpoint", "identity"], default=None,
                   help="normalisation K of the law (default secant, midpoint for hammerstein; "
                        "the convergent gain where that does not converge)")
    p.add_argument("--iterations", type=int, default=None, metavar="N",
                   help="fixed-point iterations per sample (default 1; 3 for hammerstein)")
    p.add_argument("--feedback", choices=["delay", "lowpass"], default="delay",
                   help="what the multiplicative law feeds back: its own last output U(t-T) "
                        "(delay, default) or a low-pass of it (lowpass, with --cutoff-hz); "
                        "docs/compensator.md")
    p.add_argument("--cutoff-hz", type=number_type(0, low_open=True, unit="Hz"),
                   default=None, metavar="HZ",
                   help="cut-off of the low-pass feedback [Hz]")
    p.add_argument("--check", choices=["error", "warn", "ignore"], default=None,
                   help="convergence check rho(I - K^-1 J) < 1 of the law (default error)")
    p.add_argument("--precision", choices=["double", "float"], default="double",
                   help="type of the generated code, interface included (default double; "
                        "float: no double anywhere, for a single-precision FPU)")
    p.add_argument("--sampling-period", type=number_type(0, low_open=True, unit="s"),
                   default=None, metavar="S",
                   help="sampling period [s] (default the preset's, or a model file's records' "
                        "when they agree; required for a model file without one)")
    p.add_argument("--amplifier-range", type=number_type(-1e6, 1e6, unit="V"), nargs=2,
                   default=None, metavar=("MIN", "MAX"),
                   help="clamp every voltage to [MIN, MAX] V inside step (overrides the file's "
                        "[amplifier] range)")
    p.add_argument("--slew-rate", type=_rates, default=None, metavar="V_PER_S[,V_PER_S...]",
                   help="limit every voltage's rate of change [V/s], one rate or one per input "
                        "in the model's order (with --amplifier-range, else the model's "
                        "[amplifier] range); a drive whose start-up compensate slew-limited names "
                        "the rates that make the C reproduce it")
    p.add_argument("--closed-loop", nargs="?", const="", default=None, metavar="FILE",
                   help="export the discrete feedback controller of FILE's [feedback] table (a "
                        "feedback scenario or a preset; without FILE, MODEL_OR_PRESET's) with "
                        "the compensator as feedforward: one NAME_step(state, reference, "
                        "measurement, voltage) with the anti-windup and the [feedback] amplifier "
                        "limits; --kind none exports the controller alone; with --target "
                        "fmu the FMU has measurement inputs too")
    p.add_argument("--no-binary", action="store_true",
                   help="--target fmu: sources only, do not compile a binary")
    p.add_argument("--force", action="store_true",
                   help="replace files in DIR that hammerstein export did not write")
    p.set_defaults(handler=handler)


def _default_name(stem, kind, limit=40):
    """``<stem>_<kind>`` as a C identifier of at most ``limit`` characters, the kind kept whole.

    The stem is shortened, never the kind: cut at 40 characters, a long preset name
    (``my-xy-stage-2026-11-identified-classical-model``) lost the kind, and exporting a
    second kind replaced the first's files without a word.
    """
    tail = re.sub(r"[^A-Za-z0-9_]", "_", f"_{kind}")
    head = re.sub(r"[^A-Za-z0-9_]", "_", str(stem))
    if not re.match(r"[A-Za-z_]", head):
        head = "c_" + head
    return (head[:max(limit - len(tail), 1)].rstrip("_") or "c") + tail


def _owned_problem(args, source, kind):
    """Why the files the export will write may not be written (one line), or None."""
    closed = args.closed_loop is not None
    name = args.name or _default_name(source.name, f"{kind}_loop" if closed else kind)
    try:
        if args.target != "c":
            check_fmu_owned(os.path.join(args.out, f"{name}.fmu"), args.force)
            return None
        stems = [name] + ([f"{name}_ff"] if closed and kind != "none" else [])
        for stem in stems:
            for ext in (".h", ".c"):
                check_owned(Path(args.out) / f"{stem}{ext}", MARKER.encode(), args.force)
    except ExportError as exc:
        return " ".join(str(exc).split())
    return None


def _write(args, code, name):
    """Write the C files or the FMU of ``code``; the paths written."""
    if args.target == "c":
        return write_files(args.out, code.files(), MARKER.encode(), args.force)
    check_fmu_owned(os.path.join(args.out, f"{name}.fmu"), args.force)
    data, binary = build_fmu(code, __version__, binary=not args.no_binary)
    written = write_files(args.out, {f"{name}.fmu": data}, {f"{name}.fmu": b"PK"}, True)
    if binary is None and not args.no_binary:
        print_err(f"warning: {written[0]}: no C compiler found ({find_compiler() or 'cc'}): "
                  f"the FMU holds the sources only")
    return written


def _closed_loop_table(args, source):
    """The validated ``[feedback]`` table of ``--closed-loop FILE`` (or of the source file)."""
    path = resolve_preset(args.closed_loop) if args.closed_loop else source.path
    data = read_toml(path, "feedback scenario or preset")
    if "feedback" not in data:
        raise PresetError(f"{path}: --closed-loop needs a [feedback] table (the controller; "
                          f"docs/feedback.md), found none")
    problems = []
    table = check_feedback_table(data["feedback"], f"{path}: feedback", problems)
    names = list(source.model.output_names)
    if not problems and table.get("axes") is not None and sorted(table["axes"]) != sorted(names):
        problems.append(f"{path}: feedback.axes: expected one table per output "
                        f"({', '.join(names)}), found {', '.join(sorted(table['axes']))}")
    if problems:
        raise PresetError(problems[0])
    other = _scenario_plant(data, path)
    if args.closed_loop and other is not None and other != _resolved(source.path):
        # a user exported one model with another stage's scenario: the named designs took
        # this model's slopes and modes (k_p 0.076 where the scenario's report said 0.196)
        warnings.warn(f"{path}: feedback: designed here on {args.source} (the model exported), "
                      f"not on the scenario's [plant] {data['plant']['preset']}: a controller "
                      f"designed by name takes this model's gains and modes, other than its "
                      f"report's", HammersteinWarning, stacklevel=2)
    return table


def _resolved(path):
    try:
        return Path(path).resolve()
    except (OSError, RuntimeError, TypeError):
        return None


def _scenario_plant(data, path):
    """The preset file a scenario's ``[plant]`` names, resolved, or None."""
    plant = data.get("plant")
    preset = plant.get("preset") if isinstance(plant, dict) else None
    if not isinstance(preset, str):
        return None
    try:
        return _resolved(resolve_preset(preset, Path(path).parent))
    except PresetError:
        return None


def _closed_loop_code(args, source, comp, T, name):
    """The feedback controller (and ``comp`` as feedforward) as C: FeedbackCExport."""
    table = _closed_loop_table(args, source)
    if args.amplifier_range is not None:        # the command line overrides the table's range
        table = {**table, "amplifier": {**table.get("amplifier", {}),
                                        "range": list(args.amplifier_range),
                                        **({"slew_rate": args.slew_rate[0]}
                                           if args.slew_rate is not None else {})}}
    elif args.slew_rate is not None:            # the table's range, this slew rate
        table = {**table, "amplifier": _with_slew_rate(
            table.get("amplifier") or source.amplifier or {}, args.slew_rate[:1], [])}
    if source.preset:                           # a preset: its actuator (dynamics, creep)
        plant = load_plant(source.path)
    else:
        plant = HammersteinPlant(source.model, T)
    try:
        loop = build_loops(table, plant)[0]
    except FeedbackError as exc:
        raise ExportError(f"closed loop: {exc}") from None
    return export_feedback_c(loop, name, feedforward=comp, version=__version__)


def handler(args):
    """Build, generate and write; exit status 0, 1 or 2.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``hammerstein export``.

    Returns
    -------
    int
        0 on success, 1 when the source cannot be read or the compensator
        cannot be built or exported, 2 on a usage error (bad ``--out``,
        ``--name``, an option that does not apply).
    """
    prog = "hammerstein export"
    problem = out_dir_problem(args.out)
    if problem:
        print_err(f"{prog}: error: {problem}")
        return 2
    if args.amplifier_range is not None and not args.amplifier_range[0] < args.amplifier_range[1]:
        lo, hi = args.amplifier_range
        print_err(f"{prog}: error: --amplifier-range: expected MIN MAX [V] with MIN < MAX, "
                  f"found {lo:g} {hi:g}")
        return 2
    if args.cutoff_hz is not None and args.feedback != "lowpass":
        print_err(f"{prog}: error: --cutoff-hz: only used with --feedback lowpass")
        return 2
    if args.feedback == "lowpass" and args.cutoff_hz is None:
        # the law's own message named its keys 'cutoff_hz, sampling_period' (exit 1)
        print_err(f"{prog}: error: --feedback lowpass needs --cutoff-hz HZ (the low-pass "
                  f"feedback's cut-off frequency)")
        return 2
    problem = None if args.iterations is None else integer_problem(args.iterations, 1, MAX_ITERATIONS)
    if problem:
        print_err(f"{prog}: error: --iterations: {problem}")
        return 2
    if args.name is not None:
        try:
            check_name(args.name)
        except ExportError as exc:
            print_err(f"{prog}: error: --{exc}")
            return 2
    guard_inputs(args.source)      # a model file is never an output
    try:
        source = load_source(args.source)
    except PresetError as exc:
        print_err(f"{prog}: error: {' '.join(str(exc).split())}")
        return 1
    m = len(source.model.input_names)
    if args.slew_rate is not None and len(args.slew_rate) not in (1, m):
        print_err(f"{prog}: error: --slew-rate: expected 1 or {m} rates [V/s] (one per input: "
                  f"{', '.join(source.model.input_names)}), found {len(args.slew_rate)}")
        return 2
    if args.slew_rate is not None and args.amplifier_range is None \
            and not _has_range(source.amplifier, list(source.model.input_names)):
        print_err(f"{prog}: error: --slew-rate needs a range: {args.source} has no [amplifier] "
                  f"range for every input; give --amplifier-range MIN MAX")
        return 2
    kind, gain, check, note = args.kind, args.gain, args.check, None
    args.kind_given = args.kind          # (args.kind is set to the chosen kind below)
    if kind is None:
        try:
            choice = choose_kind(source.model, source.dynamics is not None, gain,
                                 args.inversion or "zpetc", check, source.units)
        except CompensatorError as exc:
            print_err(f"{prog}: error: {args.source}: {' '.join(str(exc).split())}")
            return 1
        kind = choice.kind
        gain = choice.options.get("gain", gain)
        if gain is not None and not isinstance(gain, str):
            gain = [list(map(float, row)) for row in gain]    # K [µm/V], a scaled midpoint
        check = check or choice.options.get("check")
        note = choice.note()
    elif not kind_problem(source.model, kind, source.dynamics is not None):
        try:        # (a kind the class cannot build is refused with its own words later)
            options, note = explicit_law(source.model, kind, gain, check, source.units)
        except CompensatorError as exc:
            print_err(f"{prog}: error: {args.source}: {' '.join(str(exc).split())}")
            return 1
        gain = options.get("gain", gain)
        if gain is not None and not isinstance(gain, str):
            gain = [list(map(float, row)) for row in gain]    # K [µm/V], a scaled midpoint
        check = check or options.get("check")
    args.kind = kind
    problem = _owned_problem(args, source, kind)
    if problem:         # before building anything: a file of the user's is never replaced
        print_err(f"{prog}: error: {problem}")
        return 2
    if args.closed_loop is not None:
        if args.precision != "double":
            print_err(f"{prog}: error: --closed-loop: the controller is exported in double "
                      f"precision only")
            return 2
        if args.slew_rate is not None and len(args.slew_rate) > 1:
            print_err(f"{prog}: error: --closed-loop: the [feedback] amplifier takes one "
                      f"--slew-rate for every input, found {len(args.slew_rate)}")
            return 2
        try:
            return _closed_loop(args, source, kind, gain, check, note)
        except PresetError as exc:
            print_err(f"{prog}: error: {' '.join(str(exc).split())}")
            return 1
    try:
        limits = _limits(args, source)
    except ExportError as exc:
        print_err(f"{prog}: error: {args.source}: {' '.join(str(exc).split())}")
        return 1
    return _written(args, kind, note, lambda: _open_loop(args, source, kind, gain, check, limits),
                    after=[_limits_line(limits, source, args)])


def _limits(args, source):
    """The amplifier limits built into ``NAME_step``: the command line's, else the file's."""
    inputs = list(source.model.input_names)
    if args.amplifier_range is not None:
        table = {"range": list(args.amplifier_range)}
        if args.slew_rate is not None:
            table = _with_slew_rate(table, args.slew_rate, inputs)
        return limits_from_table(table, inputs, "--amplifier-range/--slew-rate")
    if args.slew_rate is not None:     # the preset's [amplifier] range, these slew rates
        return limits_from_table(_with_slew_rate(source.amplifier, args.slew_rate, inputs),
                                 inputs, "amplifier")
    return limits_from_table(source.amplifier, inputs, "amplifier")


def _limits_line(limits, source, args):
    """``limits: ...``: the range and slew rate built into the step, and where they come from.

    A slew rate taken from the records (``identify``'s ``[amplifier]``,
    ``source = "records"``) is the records' own speed, not the amplifier's:
    from slow hysteresis records alone it bounds the drive far below what the
    amplifier does, so the fastest sine over the whole range is named with it.
    """
    if limits is None:
        return "limits: none (the voltages are not clamped; --amplifier-range sets a range)"
    names = list(source.model.input_names)
    lo, hi, slew = limits.arrays(len(names))
    unit = source.units[0]             # the model's input unit, the drive's
    parts = [f"{n} [{a:g}, {b:g}] {unit}" + (f", {v:.4g} {unit}/s" if np.isfinite(v) else "")
             for n, a, b, v in zip(names, lo, hi, slew)]
    text = "limits: " + "; ".join(parts)
    table = source.amplifier if isinstance(source.amplifier, dict) else {}
    if table.get("source") == "records" and args.amplifier_range is None \
            and args.slew_rate is None:
        text += " (the range and largest slew of the records identify read, not the amplifier's"
        rates = [v / (np.pi * (b - a)) for a, b, v in zip(lo, hi, slew)
                 if np.isfinite(v) and np.isfinite(b - a)]
        if rates:
            text += (f": a sine over the whole range is slew-limited above {min(rates):.3g} Hz; "
                     f"--slew-rate gives your amplifier's")
        text += ")"
    return text


def _written(args, kind, note, make, after=()):
    """Run ``make`` (the files it wrote), print them; an export error is one line, exit 1."""
    prog = "hammerstein export"
    try:
        written = make()
    except (ExportError, FileLimitError) as exc:
        about_plant = "closed loop: plant:" in str(exc)     # the model, whatever the kind
        a_file = isinstance(exc, FileLimitError) or isinstance(exc.__cause__, OSError)
        chosen = ("" if not note or about_plant or a_file else
                  f" (kind {kind}, the default for this model; --kind names another)"
                  if getattr(args, "kind_given", None) is None else f" ({note.removeprefix('note: ')})")
        print_err(f"{prog}: error: {args.source}: {' '.join(str(exc).split())}{chosen}")
        return 1
    if note:
        print_err(note)
    for path in written:
        print(f"wrote {path}")
    for path in written:
        if str(path).endswith(".h"):
            line = state_line(Path(path).read_text(encoding="utf-8"))
            if line:
                print(line)
    for line in after:
        print(line)
    return 0


def state_line(header):
    r"""``"state: ..."``: the compensator state's size and preview read from a written header.

    Parameters
    ----------
    header : str
        The text of an exported ``NAME.h``.

    Returns
    -------
    str or None
        The reals (``NAME_STATE_REALS``), the ints of the state struct
        (``NAME_STATE_INTS`` when the header states them: a closed loop's struct holds
        its feedforward's), their bytes without the compiler's padding, and
        ``NAME_PREVIEW``; None when the header holds no state struct.

    Examples
    --------
    >>> h = ("#define a_PREVIEW 2\n#define a_STATE_REALS 10\ntypedef double a_real;\n"
    ...      "typedef struct {\n    a_real u[2];\n    int received;\n    int moved[4];\n"
    ...      "} a_state;\n")
    >>> state_line(h).split(";")[0]
    'state: 10 reals (double) and 5 ints, 100 B before padding (sizeof(a_state))'
    """
    reals = re.search(r"#define (\w+)_STATE_REALS (\d+)", header)
    body = re.search(r"typedef struct \{\n(.*?)\n\} (\w+_state);", header, re.S)
    kind = re.search(r"typedef (double|float) \w+_real;", header)
    preview = re.search(r"#define \w+_PREVIEW (\d+)", header)
    if not (reals and body and kind):
        return None
    ints = struct_ints(header)
    stated = re.search(r"#define \w+_STATE_INTS (\d+)", header)   # a struct in a struct
    if stated:
        ints = int(stated.group(1))
    n = int(reals.group(2))
    size = 8 if kind.group(1) == "double" else 4
    text = (f"state: {n} reals ({kind.group(1)}) and {ints} ints, {n * size + 4 * ints} B "
            f"before padding (sizeof({body.group(2)}))")
    if preview:
        text += f"; preview {preview.group(1)} sample(s) (the first calls return the rest voltages)"
    return text + "; time per step and stack on your target: docs/real-time.md"


def _open_loop(args, source, kind, gain, check, limits):
    """The compensator of ``kind`` alone, ``limits`` in its step: its C files, written; the paths."""
    comp, T = compensator_from_source(source, kind, gain=gain, iterations=args.iterations,
                                      feedback=args.feedback, cutoff_hz=args.cutoff_hz,
                                      inversion=args.inversion, sampling_period=args.sampling_period,
                                      check=check or "error")
    name = args.name or _default_name(source.name, args.kind)
    code = export_c(comp, name, T, precision=args.precision, limits=limits,
                    version=__version__, source_note=f"Built from {source.path.name} "
                    f"(kind {args.kind}, {args.precision}).")
    return _write(args, code, name)


def _has_range(table, inputs):
    """Whether an ``[amplifier]`` table gives every input a range."""
    if not isinstance(table, dict):
        return False
    if "range" in table:
        return True
    return all(isinstance(table.get(n), dict) and "range" in table[n] for n in inputs)


def _rates(text):
    """``--slew-rate``: one rate [V/s] or one per input, comma-separated (each > 0)."""
    one = number_type(0, low_open=True, unit="V/s")
    return tuple(one(v.strip()) for v in str(text).split(","))


def _with_slew_rate(table, rates, inputs):
    """An ``[amplifier]`` table with ``--slew-rate``'s rates: one for every input, or one per
    input (in ``inputs``' order) in its ``[amplifier.<input>]`` sub-table."""
    out = {k: ({kk: vv for kk, vv in v.items() if kk != "slew_rate"} if isinstance(v, dict)
               else v) for k, v in table.items()}
    if len(rates) == 1:
        out["slew_rate"] = rates[0]
        return out
    out.pop("slew_rate", None)
    for name, rate in zip(inputs, rates):
        out[name] = {**(out.get(name) if isinstance(out.get(name), dict) else {}), "slew_rate": rate}
    return out


def _closed_loop(args, source, kind, gain, check, note):
    """``--closed-loop``: the controller with the compensator of ``kind`` as feedforward."""
    return _written(args, kind, note, lambda: _closed_loop_files(args, source, kind, gain, check))


def _closed_loop_files(args, source, kind, gain, check):
    """The controller and the feedforward's C files, written; the paths."""
    if kind == "none":
        comp = None
        T = args.sampling_period or source.sampling_period
        if T is None:
            raise ExportError("sampling_period: a model file needs --sampling-period S")
    else:
        comp, T = compensator_from_source(source, kind, gain=gain, iterations=args.iterations,
                                          feedback=args.feedback, cutoff_hz=args.cutoff_hz,
                                          inversion=args.inversion,
                                          sampling_period=args.sampling_period,
                                          check=check or "error")
    name = args.name or _default_name(source.name, f"{kind}_loop")
    code = _closed_loop_code(args, source, comp, T, name)
    return _write(args, code, name)
