"""``hammerstein identify``: identify a p x m PI model from measured records.

Reads one or more delimited text files (:func:`hammerstein.io.datafiles.read_records`),
each holding the time (or given the sampling period), every input column and
every output column; identifies a multivariable hysteresis model (``--model
auto``, the default: classical PI, Preisach or generalised PI, whichever
predicts the held-out minor loops best; a classical PI from records of one
amplitude) (:func:`hammerstein.identification.record_identification.identify_records`: split at
reversal points, held-out complete branches or periods, partition and
component structure chosen automatically unless given), reports the fit on
the training and held-out samples, and writes a model file
(:func:`hammerstein.io.presets.save_model`) that ``model = "path"`` in a
scenario and the compensators accept. Optional: ``--metrics`` (long CSV),
``--plot`` (loops and errors), ``--dynamics`` (a preset with linear dynamics).

Exit status: 0 on success, 1 on a data or identification error (one line on
stderr), 2 on a usage error; nothing is written unless everything succeeded,
every file is written through a temporary file and a rename, and a file the
project did not write is never overwritten without ``--force``.

Length: the options, their checks and the report of one command (the report's lines and
metrics rows are in :mod:`hammerstein.cli._identify_report`).
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from hammerstein.io.datafiles import DataFileError, column_list, read_records
from hammerstein.cli._common import number_type, out_file_problem, print_err
from hammerstein.cli._output import tty_progress
from hammerstein.cli._identify_report import (
    _line, creep_metrics_rows, delay_report_lines, dynamics_metrics_rows, dynamics_report_lines,
    cut_note, level_metrics_rows, level_report_lines, metrics_rows, modes_above_band_warning)
from hammerstein.io.unit_checks import unit_warnings
from hammerstein.models.amplifier import records_amplifier_table, records_hold_steps
from hammerstein.core.files import (FileLimitError, all_or_nothing, file_limit_problem,
                                    guard_inputs, png_provenance, provenance_line,
                                    replace_problem, safe_write)
from hammerstein.io.presets import PresetError, save_model
from hammerstein.identification.defaults import PREISACH_LEVELS, smoothing_option
from hammerstein.identification.loop_orientation import clockwise_loop_warnings
from hammerstein.identification.identification_pipeline import (PipelineOptions, identify_pipeline,
                                                                 minor_loop_warning,
                                                                 dynamics_fit_warning,
                                                                 static_gain_warning)
from hammerstein.identification.record_identification import DYNAMICS_DEFAULTS
from hammerstein.models.dynamics import DynamicsError
from hammerstein.models.lti import check_delay_by_fit, estimate_measurement_delay
from hammerstein.report.dynamics_figure import measured_bode_figure
from hammerstein.exceptions import HysteresisError, IdentificationError
from hammerstein.scenario.schema import MAX_HYSTERONS

#: Largest --delay [samples].
MAX_DELAY = 10000

__all__ = ["add_parser"]

for _f in (creep_metrics_rows, delay_report_lines, dynamics_metrics_rows, dynamics_report_lines,
           level_metrics_rows, level_report_lines, metrics_rows):
    _f.__module__ = __name__          # documented as this command's (defined in _identify_report)
del _f

#: Header of a metrics file (the project's long format).
METRICS_HEADER = "case,channel,metric,value,unit"


def _smoothing_type(text):
    """argparse ``type`` of ``--preisach-smoothing``: ``"auto"`` or a weight >= 0."""
    try:
        return smoothing_option(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_parser(subparsers):
    """Register the ``identify`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "identify", help="identify a (multivariable) hysteresis model from measured records",
        description="Identify a multivariable hysteresis model from CSV/text records (one or "
                    "more files, each with every input and output column): by default (--model "
                    "auto) the classical Prandtl-Ishlinskii, Preisach or generalised PI model "
                    "that predicts the held-out minor loops best, the classical PI when the "
                    "records hold a single amplitude; report the fit on training and held-out "
                    "periods, and save a model file.")
    p.add_argument("data", nargs="+", metavar="DATA.csv",
                   help="delimited text files (header optional); typically one per excited input")
    p.add_argument("--input", "--inputs", dest="inputs", required=True, metavar="COLS",
                   help="input column(s), names or 0-based indices separated by commas")
    p.add_argument("--output", "--outputs", dest="outputs", required=True, metavar="COLS",
                   help="output column(s), names or 0-based indices separated by commas")
    p.add_argument("--time", metavar="COL", help="time column [s], name or 0-based index")
    p.add_argument("--sampling-period", type=number_type(0, 1e6, low_open=True, unit="s"), metavar="S",
                   help="sampling period [s] when there is no time column")
    p.add_argument("--skip-rows", type=int, default=0, metavar="N",
                   help="lines before the table to ignore (an instrument's preamble); a row of "
                        "units under the header is recognised without it")
    p.add_argument("--delay", default=None, metavar="auto|N",
                   help="samples every record's measured outputs lag its inputs (the "
                        "acquisition's delay, not the actuator's): the outputs are advanced by N "
                        "before anything is fitted, so G does not carry it, and the model file "
                        "keeps it for `learn --delay auto`. auto: estimated from the phase slope "
                        "of the --dynamics-records' measured frequency response over the upper "
                        "half of their band (needs --dynamics). Default: auto with --dynamics "
                        "(0 with a note when the records cannot tell it), else 0")
    p.add_argument("--input-unit", default="V", metavar="UNIT", help="input unit (default V)")
    p.add_argument("--output-unit", default="µm", metavar="UNIT", help="output unit (default µm)")
    p.add_argument("--method", choices=["closed-form", "least-squares"], default="least-squares",
                   help="least squares over the training samples (default) or the Appendix "
                        "closed form on the ascending branches (one excited input per file)")
    p.add_argument("--thresholds", default="15", metavar="N|r1,r2,...",
                   help="hysterons per component, or explicit thresholds in the input unit "
                        "(default 15)")
    p.add_argument("--partition", choices=["auto", "time", "input"], default="auto",
                   help="threshold partition; auto (default) keeps the one with the smaller "
                        "held-out error")
    p.add_argument("--bounds", choices=["none", "nonnegative", "monotone"], default="none",
                   help="least squares: constrain the direct transfers' weights (default "
                        "none); with every choice a rising direct transfer's first weight, "
                        "the initial slope of its loops, is at least a tenth of its secant, "
                        "so that every compensator inverts it")
    p.add_argument("--components", default="auto", metavar="auto|all|OUT:IN=KIND,...",
                   help="auto (default): components whose contribution is below the noise "
                        "become pure gains or absent; all: every component a PI; or explicit "
                        "kinds pi, gain, none per OUT:IN")
    p.add_argument("--model", choices=["auto", "classical", "preisach", "generalized"],
                   default="auto",
                   help="model class of the hysteresis. classical: multivariable classical PI "
                        "(+ output map); preisach: discrete Preisach model, density by "
                        "non-negative least squares with smoothing (monotone direct paths, "
                        "signed cross-couplings); generalized: generalised PI (plays under "
                        "per-side envelope functions, fitted by variable projection); auto "
                        "(default): with multi-amplitude records (held-out amplitude levels) "
                        "all three are fitted and the one with the lowest held-out minor-loop "
                        "error is kept; otherwise classical")
    p.add_argument("--threshold-spacing", choices=["power", "uniform", "auto"], default="uniform",
                   help="--model generalized/auto: play thresholds S j/n (uniform, default; 16 "
                        "plays per component), S (j/n)^1.5 (power: dense near zero), or auto: "
                        "both fitted, the lower mean held-out minor-loop error kept (twice the "
                        "CPU; the held-out levels hardly tell the two apart, docs/records.md)")
    p.add_argument("--level-weighting", choices=["amplitude", "none"], default="amplitude",
                   help="--model generalized/auto: the generalised PI's fit weighs each "
                        "amplitude level's samples by A_max / A_level, so that each level's "
                        "error counts relative to its amplitude, as the held-out levels are "
                        "scored (amplitude, default), or every sample alike (none: the "
                        "full-amplitude levels decide the small loops)")
    p.add_argument("--record-start", choices=["demagnetised", "rest"], default="demagnetised",
                   help="--model preisach/generalized/auto: the state every record starts "
                        "from: after the demagnetising cycle (demagnetise.csv) played before "
                        "it (demagnetised, default), or at rest (rest: records taken without "
                        "the cycle; the plays at rest, the ideal demagnetised Preisach state)")
    p.add_argument("--preisach-levels", type=int, default=PREISACH_LEVELS, metavar="N",
                   help="--model preisach/auto: cells of each input's switching grid "
                        "(N (N + 1) / 2 hysterons per component; default %(default)s). Fewer: "
                        "a faster fit and exported real-time step, small loops less close "
                        "(docs/records.md)")
    p.add_argument("--preisach-smoothing", default="auto", metavar="auto|LAMBDA",
                   type=_smoothing_type,
                   help="--model preisach/auto: the Preisach density's smoothing weight: "
                        "searched on the held-out records (auto, default; among scores "
                        "within 2 %% of each other, the least smoothing), or this one. "
                        "Weights the records cannot tell apart can give circles 1 %% of the "
                        "radius apart: compare two on the actuator (hammerstein evaluate)")
    p.add_argument("--hold-out", choices=["auto", "none"], default="auto",
                   help="auto (default): hold out the last complete branches or periods of "
                        "each record; none: train on everything, no validation")
    p.add_argument("--output-map", choices=["auto", "none", "deadzone"], default="auto",
                   help="static monotone map after the PI, the modified PI of Kuhnen (one-sided "
                        "dead zones; models asymmetric and saturating loops, exactly "
                        "invertible). auto (default): kept when the loop is not "
                        "point-symmetric and the map lowers the held-out error, or when it "
                        "lowers it by more than 10 %%; deadzone: always; none: classical PI")
    p.add_argument("--train-fraction", type=number_type(0, 1), metavar="F",
                   help="split instead at the reversal point nearest to this fraction of "
                        "each record")
    p.add_argument("--skip", type=number_type(0, unit="s"), metavar="SECONDS",
                   help="burn-in [s] that only warms up the play states (default: up to the "
                        "first complete branch)")
    p.add_argument("--out", required=True, metavar="MODEL.toml", help="model file to write")
    p.add_argument("--metrics", metavar="FILE.csv",
                   help="write the fit metrics (case,channel,metric,value,unit)")
    p.add_argument("--plot", metavar="FILE.png",
                   help="write measured vs model loops per component and the error")
    p.add_argument("--dynamics", action="store_true",
                   help="also identify linear dynamics from --dynamics-records and write a "
                        "preset (PI + state_space dynamics) instead of a model file")
    p.add_argument("--dynamics-records", nargs="+", metavar="FILE.csv", default=[],
                   help="broadband records (same columns) for --dynamics; with two or more "
                        "per input the last of each input is held out to choose the order")
    p.add_argument("--order", type=int, metavar="N",
                   help="--dynamics: fixed model order of G (default: chosen on held-out data)")
    p.add_argument("--max-order", type=int, metavar="N",
                   help=f"--dynamics: largest candidate order (default "
                        f"{DYNAMICS_DEFAULTS['max_order']})")
    p.add_argument("--creep-records", nargs="+", metavar="FILE.csv", default=[],
                   help="voltage staircases (same columns, e.g. creep-<input>.csv of "
                        "'hammerstein excitation'): identify the creep after the hysteresis "
                        "(first-order lags 0.01-100 s, non-negative weights) and write it as "
                        "[creep] (with --dynamics, fitted through the identified G); the "
                        "hysteresis is then refitted on the records with the creep removed")
    p.add_argument("--creep-refits", type=int, default=None, metavar="N",
                   help="--creep-records: refits of the hysteresis on the records with the "
                        "identified creep removed, each followed by a new creep fit "
                        "(default: 1 for a Preisach model, 0 for a classical PI, whose step "
                        "levels the refit made worse on an actuator outside its class; 0: the "
                        "hysteresis keeps the creep of its records)")
    p.add_argument("--force", action="store_true",
                   help="overwrite --out, --metrics or --plot even if the project did not write it "
                        "(or --metrics changed since)")
    p.set_defaults(handler=_handler)


class _Usage(ValueError):
    """A usage error (exit 2)."""


def _parse_thresholds(text):
    text = text.strip()
    if "," not in text:
        try:
            n = int(text)
        except ValueError:
            raise _Usage(f"--thresholds: expected a count N or a list r1,r2,..., found {text!r}") from None
        if not 1 <= n <= MAX_HYSTERONS:
            raise _Usage(f"--thresholds: expected 1 <= N <= {MAX_HYSTERONS} hysterons, found {n}")
        return n, None
    if any(not v.strip() for v in text.split(",")):
        raise _Usage(f"--thresholds: expected numbers separated by commas, found an empty entry "
                     f"in {text!r}")
    try:
        r = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise _Usage(f"--thresholds: expected numbers separated by commas, found {text!r}") from None
    if r.size > MAX_HYSTERONS:
        raise _Usage(f"--thresholds: expected at most {MAX_HYSTERONS} thresholds, found {r.size}")
    if r.size == 0 or not np.all(np.isfinite(r)) or r[0] < 0 or np.any(np.diff(r) <= 0):
        raise _Usage(f"--thresholds: expected increasing thresholds >= 0, found {text!r}")
    return r.size, r


def _check_target(path, option, kind, force, inputs):
    """A usage error when ``path`` cannot be written or is a file the project did not write.

    Ownership is judged by content: an existing file is replaced only when
    it carries the project's provenance mark (the first-line comment of a
    model or metrics file, the text chunk of a PNG;
    :func:`hammerstein.core.files.carries_provenance`) or with ``--force``;
    an input of the command is never an output.
    """
    problem = out_file_problem(path, f"{kind} file", inputs)  # empty, directory, special, under a file
    if problem:
        raise _Usage(problem.replace("--out", option, 1))
    problem = replace_problem(path, inputs, force, "hammerstein identify",
                              "one of the data files")
    if problem:
        raise _Usage(f"{option}: {problem}")


def _same_record_twice(paths):
    """The first record file given twice (by its path resolved, or a hard link to it), as
    '(a) and (b)', or None: the same record twice made every fit's matrices singular (numpy's
    overflow warnings, then 'input uy never excited')."""
    seen = {}
    for p in paths:
        try:
            st = os.stat(p)
            key = (st.st_dev, st.st_ino)
        except OSError:
            key = os.path.realpath(p)
        if key in seen:
            return f"{seen[key]} and {p}"
        seen[key] = p
    return None


def _check_usage(args):
    for what, paths in (("records", args.data), ("--dynamics-records", args.dynamics_records),
                        ("--creep-records", args.creep_records)):
        twice = _same_record_twice(paths or [])
        if twice:
            raise _Usage(f"{what}: the same file given twice ({twice}); give each record once")
    n, thresholds = _parse_thresholds(args.thresholds)
    if args.train_fraction is not None and not 0 < args.train_fraction <= 1:
        raise _Usage(f"--train-fraction: expected in (0, 1], found {args.train_fraction}")
    if args.train_fraction is not None and args.hold_out == "none":
        raise _Usage("--train-fraction and --hold-out none: give one of them")
    if args.time is None and args.sampling_period is None:
        raise _Usage("give --time COL or --sampling-period S")
    if args.skip_rows < 0:
        raise _Usage(f"--skip-rows: expected a number of lines >= 0, found {args.skip_rows}")
    if args.sampling_period is not None and not (np.isfinite(args.sampling_period)
                                                 and args.sampling_period > 0):
        raise _Usage(f"--sampling-period: expected a positive time [s], found {args.sampling_period}")
    _parse_delay(args)
    if args.skip is not None and not (np.isfinite(args.skip) and args.skip >= 0):
        raise _Usage(f"--skip: expected a time >= 0 [s], found {args.skip}")
    if args.bounds != "none" and args.method == "closed-form":
        raise _Usage("--bounds: only used by --method least-squares")
    if args.output_map == "deadzone" and args.method == "closed-form":
        raise _Usage("--output-map deadzone: only used by --method least-squares")
    if not 2 <= args.preisach_levels <= 60:
        raise _Usage(f"--preisach-levels: expected an integer from 2 to 60, found "
                     f"{args.preisach_levels}")
    if args.preisach_smoothing != "auto" and args.model in ("classical", "generalized"):
        raise _Usage(f"--preisach-smoothing: only used by --model preisach or auto (the "
                     f"Preisach density's smoothing), found --model {args.model}")
    if args.model in ("preisach", "generalized") and args.thresholds != "15":
        # the classical PI's hysterons: another class has its own grid, and ignored them
        raise _Usage(f"--thresholds: only used by --model classical or auto (the classical PI's "
                     f"hysterons); --model {args.model} sets its "
                     + ("grid with --preisach-levels" if args.model == "preisach"
                        else "plays with --threshold-spacing"))
    if args.model in ("preisach", "generalized") and args.method == "closed-form":
        raise _Usage(f"--model {args.model}: fitted by least squares; leave out --method "
                     f"closed-form")
    if args.creep_refits is not None and not args.creep_records:
        raise _Usage("--creep-refits: only used with --creep-records")
    if args.creep_refits is not None and not 0 <= args.creep_refits <= 5:
        raise _Usage(f"--creep-refits: expected an integer from 0 to 5, found {args.creep_refits}")
    if args.dynamics_records and not args.dynamics:
        raise _Usage("--dynamics-records: only used with --dynamics")
    if args.dynamics and not args.dynamics_records:
        raise _Usage("--dynamics: give the broadband records with --dynamics-records FILE ...")
    for opt, value in (("--order", args.order), ("--max-order", args.max_order)):
        if value is not None and not args.dynamics:
            raise _Usage(f"{opt}: only used with --dynamics")
        if value is not None and not 1 <= value <= 50:
            raise _Usage(f"{opt}: expected an integer from 1 to 50, found {value}")
    if args.order is not None and args.max_order is not None:
        raise _Usage("--order and --max-order: give one of them")
    for unit, opt in ((args.input_unit, "--input-unit"), (args.output_unit, "--output-unit")):
        if not unit.strip():
            raise _Usage(f"{opt}: expected a unit name")
    inputs = list(args.data) + list(args.dynamics_records) + list(args.creep_records)
    guard_inputs(*inputs)          # never an output, even with --force (safe_write refuses it)
    _check_target(args.out, "--out", "model", args.force, inputs)
    targets = [Path(args.out).resolve()]
    plots = [(args.metrics, "--metrics", "metrics"), (args.plot, "--plot", "plot")]
    if args.plot and args.dynamics:
        plots.append((_bode_path(args.plot), "--plot (its Bode figure)", "plot"))
    for path, opt, kind in plots:
        if path is not None:
            _check_target(path, opt, kind, args.force, inputs)
            if Path(path).resolve() in targets:
                raise _Usage(f"{opt}: {path} is already another output of this command")
            targets.append(Path(path).resolve())
    return n, thresholds


def _parse_delay(args):
    """``args.delay`` as an int or ``"auto"``; ``args.delay_given`` whether the user gave it."""
    text = args.delay
    args.delay_given = text is not None
    args.delay_estimate = None
    if text is None:
        args.delay = "auto" if args.dynamics else 0
        return
    text = str(text).strip()
    if text == "auto":
        if not args.dynamics:
            raise _Usage("--delay auto: estimated from the broadband records; give --dynamics "
                         "--dynamics-records FILE ... or --delay N")
        args.delay = "auto"
        return
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not 0 <= value <= MAX_DELAY:
        raise _Usage(f"--delay: expected auto or an integer from 0 to {MAX_DELAY} [samples], "
                     f"found {text!r}")
    args.delay = value


def _estimate_delay(args):
    """``--delay auto``: the integer delay of the --dynamics-records (read as they are).

    Sets ``args.delay`` (int) and ``args.delay_estimate``
    (:class:`hammerstein.models.lti.MeasurementDelay`). An estimate the records
    cannot support is a data error naming --delay when ``auto`` was given,
    else (the default) the delay stays 0 and the report says why.
    """
    records = [_read_raw(args, d) for d in args.dynamics_records]
    T = records[0].sampling_period
    if any(not np.isclose(r.sampling_period, T, rtol=0.01) for r in records):
        raise DataFileError("--delay auto: the --dynamics-records have different sampling periods")
    try:
        est = estimate_measurement_delay([r.u for r in records], [r.y for r in records], T)
        est = check_delay_by_fit([r.u for r in records], [r.y for r in records], T, est)
    except DynamicsError as exc:
        raise DataFileError(f"--delay auto: {exc}") from None
    if est.problem is None and est.delay > MAX_DELAY:
        est = replace(est, problem=f"{est.delay} samples, more than {MAX_DELAY}")
    if est.problem is not None and args.delay_given:
        raise DataFileError(f"--delay auto: no delay estimate from the --dynamics-records: "
                            f"{est.problem}; give --delay N")
    args.delay_estimate = est
    args.delay = est.delay if est.problem is None else 0


def _write_metrics(path, rows):
    import pandas as pd  # lazy: only for --metrics
    frame = pd.DataFrame(rows, columns=METRICS_HEADER.split(","))
    body = frame.to_csv(index=False, float_format="%.7g")
    # signed: a metrics file a user added a column or a note to is not replaced
    safe_write(path, provenance_line("identify", body=body) + body, "metrics file")


def fit_figure(fit, input_unit, output_unit):
    """Measured vs model loops per component (rows outputs, columns inputs) and the error.

    Each loop panel (l, k) shows output l against input k over the records
    whose excitation is input k: training samples as large blue points,
    held-out samples as small orange points on them, the model as a thin
    black line on top (a legend under the panels says so).
    The last column shows the error of output l (measured minus model)
    against time over all records, one after another (held-out part
    shaded); the time is the records' time column, or sample times of the
    given sampling period.

    Parameters
    ----------
    fit : RecordFit
        Result of :func:`hammerstein.identification.record_identification.identify_records`
        for a p x m model.
    input_unit : str
        Unit of the inputs for the axis labels (e.g. ``"V"``).
    output_unit : str
        Unit of the outputs and of the error (e.g. ``"µm"``).

    Returns
    -------
    matplotlib.figure.Figure
        p rows by m + 1 columns of axes and one legend; the caller saves and
        closes it.
    """
    import matplotlib  # lazy: only for --plot
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    model = fit.model
    p, m = model.n_outputs, model.n_inputs
    fig, axes = plt.subplots(p, m + 1, figsize=(3.4 * (m + 1), 2.7 * p + 0.5), squeeze=False,
                             layout="constrained")
    handles = {}
    for l in range(p):
        for k in range(m):
            ax = axes[l][k]
            kind = fit.structure[l][k]
            for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
                if s.excitation != k:
                    continue
                used = s.train | s.held_out
                # the loops retrace one path: large training points, smaller held-out points
                # on them, the model a thin line on top, so that each stays visible
                for part, color, ms, label in ((s.train, "tab:blue", 4.0, "measured, training"),
                                               (s.held_out, "tab:orange", 1.6,
                                                "measured, held out")):
                    if part.any():
                        pts, = ax.plot(rec.u[k][part], rec.y[l][part], "o", ms=ms, mew=0,
                                       color=color, zorder=2)
                        handles.setdefault(label, pts)
                line, = ax.plot(rec.u[k][used], pred[l][used], "-", lw=0.6, color="k", zorder=3)
                handles.setdefault("model", line)
            ax.set_title(f"{model.output_names[l]} <- {model.input_names[k]} ({kind})", fontsize=9)
            ax.set_xlabel(f"{model.input_names[k]} [{input_unit}]", fontsize=8)
            ax.set_ylabel(f"{model.output_names[l]} [{output_unit}]", fontsize=8)
            ax.tick_params(labelsize=7)
        ax = axes[l][m]
        start = 0.0
        for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
            t = rec.timepts - rec.timepts[0] + start        # records one after another
            used = s.train | s.held_out
            ax.plot(t[used], (rec.y[l] - pred[l])[used], lw=0.6, color="tab:red")
            if s.held_out.any():
                h = t[s.held_out]
                ax.axvspan(h[0], h[-1], color="tab:orange", alpha=0.15, lw=0)
            start = t[-1] + rec.sampling_period
        name = model.output_names[l]
        ax.set_title(f"error of {name} (held out shaded)", fontsize=9)
        ax.set_xlabel("time [s]" + (" (records one after another)" if len(fit.records) > 1 else ""),
                      fontsize=8)
        ax.set_ylabel(f"{name} measured - model [{output_unit}]", fontsize=8)
        ax.tick_params(labelsize=7)
    order = [k for k in ("measured, training", "measured, held out", "model") if k in handles]
    fig.legend([handles[k] for k in order], order, loc="outside lower center", ncol=len(order),
               fontsize=8, frameon=False, markerscale=2)
    fig.suptitle("identified model vs measured records", fontsize=10)
    return fig


def _write_plot(path, fit, input_unit, output_unit):
    import matplotlib.pyplot as plt  # lazy: only for --plot
    fig = fit_figure(fit, input_unit, output_unit)
    try:
        safe_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110,
                                                metadata=png_provenance("identify")), "figure")
    finally:
        plt.close(fig)


def _metadata(args, fit, records):
    rec = fit.record()     # the fit's own record, as a scenario's records route writes it
    meta = {"method": rec.pop("method"), "sources": [str(d) for d in args.data],
            "input_columns": str(args.inputs), "output_columns": str(args.outputs),
            "partition": rec.pop("partition"),
            "partition_scores_percent": rec.pop("partition_scores_percent"),
            "components": rec.pop("components"), "bounds": args.bounds,
            "output_map": rec.pop("output_map"),
            "sampling_period_s": [r.sampling_period for r in records],
            "input_unit": args.input_unit, "output_unit": args.output_unit}
    validation = {k: rec.pop(k) for k in list(rec) if k.startswith("validation")}
    levels = rec.pop("levels", None)
    meta.update(rec)                    # held_out, notes, train_rms ...
    est = args.delay_estimate
    # a delay given, 0 included (learn --delay auto takes it: not kept, learn estimated one
    # sample from its model's prediction on an outside stage, and converged to that lag)
    if args.delay or args.delay_given or (est is not None and est.problem is None):
        meta["measurement_delay_samples"] = int(args.delay)
    if est is not None:
        meta["measurement_delay_estimate"] = {
            "method": "phase slope of the measured H1 frequency response of the dynamics records",
            "samples": float(est.samples), "std_samples": float(est.std),
            "band_hz": [float(v) for v in est.band_hz],
            "halves_samples": [float(v) for v in est.halves],
            "residual_phase_deg": float(est.residual_deg), "lines": int(est.n_lines),
            "used": est.problem is None}
        if est.problem is not None:
            meta["measurement_delay_estimate"]["problem"] = str(est.problem)
        if est.checked is not None:
            meta["measurement_delay_estimate"]["checked"] = str(est.checked)
    meta.update(validation)
    if levels:
        meta["levels"] = levels
    return meta


def _falling_direct_paths(records, inputs, outputs, out_unit, in_unit):
    """Warnings for outputs that fall as their own input rises over the records.

    A piezo's direct path rises with its input; a falling one is a sensor of
    inverted sign or inputs and outputs paired in the wrong order, and the
    model written then cannot be inverted (a classical PI's cumulative weight
    sums <= 0: ``compensate`` refused it with a message about S_i). The
    slope is the least-squares one of the output on its input (output k on
    input k), over every hysteresis record.
    """
    lines = []
    for k in range(min(len(inputs), len(outputs))):
        u = np.concatenate([np.asarray(r.u[k], dtype=float) for r in records])
        y = np.concatenate([np.asarray(r.y[k], dtype=float) for r in records])
        du, dy = u - u.mean(), y - y.mean()
        var = float(np.dot(du, du))
        if var <= 0:
            continue
        slope = float(np.dot(du, dy)) / var
        if slope < 0:
            lines.append(f"{outputs[k]} falls as {inputs[k]} rises over the records (slope "
                         f"{slope:.4g} {out_unit}/{in_unit}): a sensor of inverted sign, or the "
                         f"inputs and outputs paired in the wrong order? The compensators need a "
                         f"rising direct path; invert the column or reorder --inputs/--outputs")
    return lines


#: Share of an output's samples at exactly its largest (or smallest) value above which
#: ``identify`` says the sensor may have saturated.
FLAT_SHARE = 0.005


def _flat_extremes(records, outputs, out_unit):
    """Warnings for outputs that sit at exactly their extreme value on many samples.

    A sensor at the end of its range reads one value while the actuator
    moves on; the model then learns a flat top. A tester's x clipped at
    12 µm (9.9 % of the samples) was identified without a word, and a 10 µm
    circle then ended at 6.6 % where the unclipped records gave 3.2 %. A
    quantised but unclipped peak repeats its extreme on a few samples per
    peak, far below :data:`FLAT_SHARE`.
    """
    lines = []
    for k, name in enumerate(outputs):
        y = np.concatenate([np.asarray(r.y[k], dtype=float) for r in records])
        y = y[np.isfinite(y)]
        if y.size < 100:
            continue
        for which, value in (("largest", float(y.max())), ("smallest", float(y.min()))):
            n = int(np.count_nonzero(y == value))
            if n >= 20 and n > FLAT_SHARE * y.size:
                flat = "top" if which == "largest" else "bottom"
                lines.append(f"{name} reads exactly {value:.6g} {out_unit}, its {which} value, on "
                             f"{n} samples ({100 * n / y.size:.3g} % of them): a sensor at the "
                             f"end of its range? The model learns that flat {flat}; record "
                             f"within the sensor's range, or leave those samples out")
    return lines


def _handler(args):

    try:
        n, thresholds = _check_usage(args)
    except _Usage as exc:
        print(f"hammerstein identify: error: {exc}", file=sys.stderr)
        return 2
    try:
        # every record's size before any is read: the delay's estimate read the dynamics
        # records first, and a hysteresis record over the limit was named after 36 s
        for path in [*args.data, *args.dynamics_records, *args.creep_records]:
            problem = file_limit_problem(path, "data", "data file")
            if problem:
                raise FileLimitError(problem)
        given = column_list(args.inputs), column_list(args.outputs)
        if args.dynamics and all(given):          # before any estimate or fit
            _square_for_dynamics(*given)
        if args.delay == "auto":
            _estimate_delay(args)
        records = [_read(args, d) for d in args.data]
        names = _names(records[0], *given)
        _every_input_excited(records, names[0])
        if args.dynamics:
            _square_for_dynamics(*names)
        result = identify_pipeline(
            records, _options(args, n, thresholds), names,
            _dynamics_recs(args) if args.dynamics else None,
            _creep_recs(args) if args.creep_records else None,
            progress=tty_progress("identify"))
        fit, dyn, creep = result.fit, result.dynamics, result.creep
        extra = result.tables()
        meta = _metadata(args, fit, records)
        rows = metrics_rows(fit, args.output_unit) + level_metrics_rows(fit, args.output_unit)
        if dyn is not None:
            meta["dynamics"] = dyn.summary
            if creep is not None:    # G on the PI outputs through the creep: G(0) = I for G (I + C)
                meta["dynamics"]["inputs"] = "hysteresis model outputs through the identified creep"
        if creep is not None:
            meta["creep"] = creep.summary()
            rows += creep_metrics_rows(creep, args.output_unit)
        if dyn is not None:
            rows += dynamics_metrics_rows(dyn.summary, fit.model.output_names,
                                          fit.model.input_names)
        extra = dict(extra or {})     # drives stay within what the records spanned
        every = (records + (_dynamics_recs(args) if args.dynamics else [])
                 + (_creep_recs(args) if args.creep_records else []))
        extra["amplifier"] = records_amplifier_table(every, list(fit.model.input_names))
        hold_notes = _hold_step_notes(every, extra["amplifier"], args.input_unit)
        units = unit_warnings(every, list(fit.model.output_names), args.output_unit, args.time,
                              list(fit.model.input_names), args.input_unit)
        with all_or_nothing():  # a failed write (full disk) leaves none of the outputs
            save_model(fit.model, args.out, meta, args.input_unit, args.output_unit, extra)
            if args.plot:
                _write_plot(args.plot, fit, args.input_unit, args.output_unit)
                if dyn is not None:
                    _write_bode(_bode_path(args.plot), dyn, fit.model.output_names)
            if args.metrics:
                _write_metrics(args.metrics, rows)
    except (DataFileError, IdentificationError, HysteresisError, PresetError, FileLimitError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {exc.filename or args.out}: cannot write ({exc.strerror or exc})",
              file=sys.stderr)
        return 1
    _report(args, fit, records, dyn, creep)
    for line in hold_notes:
        print_err(f"note: {line}")
    for line in units:
        print_err(f"warning: {line}")
    est = args.delay_estimate
    if est is not None and est.problem is not None:       # the default auto, refused: said loud
        print(f"warning: the measurement delay could not be estimated from the "
              f"--dynamics-records ({est.problem}) and was taken as 0: a delay of your "
              f"acquisition then ends up in G, so that drives lead the position by it, and "
              f"`learn`, which sees the same measurement, cannot tell; give --delay N when you "
              f"know it (your sensor's and converters' samples; docs/records.md)",
              file=sys.stderr)
    return 0


def _square_for_dynamics(inputs, outputs):
    """Refuse ``--dynamics`` on a rectangular actuator before anything is fitted."""
    if len(inputs) != len(outputs):
        raise IdentificationError(
            f"--dynamics: expected as many outputs as inputs (the dynamics act on the hysteresis "
            f"model's outputs, one per input, and every compensator needs a square model), found "
            f"{len(inputs)} inputs ({', '.join(inputs)}) and {len(outputs)} outputs "
            f"({', '.join(outputs)}); identify without --dynamics for the hysteresis and creep "
            f"alone")


def _envelope_text(g):
    """``a0 tanh(a1 u + a2) + a3`` with its signs written once: "+ -0.355" read as a typo, and
    the rising envelope's a3 was left out."""
    def signed(x, fmt):
        return f"{'-' if x < 0 else '+'} {abs(x):{fmt}}"
    return f"{g[0]:.4g} tanh({g[1]:.4g} u {signed(g[2], '.3g')}) {signed(g[3], '.3g')}"


def _options(args, n, thresholds):
    """The pipeline's options of the command line (:class:`PipelineOptions`)."""
    return PipelineOptions(
        method=args.method, n=n, thresholds=thresholds, partition=args.partition,
        bounds=args.bounds, components=args.components, model=args.model,
        threshold_spacing=args.threshold_spacing, level_weighting=args.level_weighting,
        record_start=args.record_start, preisach_levels=args.preisach_levels,
        preisach_smoothing=args.preisach_smoothing,
        hold_out=args.hold_out, output_map=args.output_map,
        train_fraction=args.train_fraction, skip=args.skip, order=args.order,
        max_order=args.max_order, creep_refits=args.creep_refits, output_unit=args.output_unit,
        name=Path(args.out).stem)


def _read_raw(args, path):
    """The record of ``path`` as it is in the file, read once per command."""
    cache = args.__dict__.setdefault("_raw_records", {})
    if path not in cache:
        cache[path] = read_records(path, args.inputs, args.outputs, args.time,
                                   args.sampling_period, args.skip_rows,
                                   args.input_unit, args.output_unit)
    return cache[path]


def _read(args, path):
    """One record of ``path`` with its outputs advanced by ``--delay`` samples.

    Sample ``t`` of the outputs becomes sample ``t + N`` of the file: the last
    N inputs, whose response was not measured, are dropped.
    """
    rec = _read_raw(args, path)
    d = args.delay
    if not d:
        return rec
    n = rec.u.shape[1]
    if n <= 10 * d:
        raise DataFileError(f"{path}: {n} samples; --delay {d} needs more than {10 * d}")
    return replace(rec, timepts=rec.timepts[:n - d], u=rec.u[:, :n - d], y=rec.y[:, d:])


def _dynamics_recs(args):
    """The --dynamics-records, read once per command."""
    if getattr(args, "_dynamics_read", None) is None:
        args._dynamics_read = [_read(args, d) for d in args.dynamics_records]
    return args._dynamics_read


def _creep_recs(args):
    """The --creep-records, read once per command."""
    if getattr(args, "_creep_read", None) is None:
        args._creep_read = [_read(args, d) for d in args.creep_records]
    return args._creep_read


def _every_input_excited(records, inputs):
    """Refuse, before any fit, an input that no hysteresis record varies.

    One record of a two-input stage (``hysteresis-ux.csv`` alone): every model class
    was fitted on a still uy, numpy's overflow warnings leaked, then the classical fit
    said "input 'uy': never excited".

    Raises
    ------
    IdentificationError
        Naming the input, its constant value and what to give.
    """
    for k, name in enumerate(inputs):
        if any(np.ptp(np.asarray(r.u[k], dtype=float)) > 0 for r in records if np.size(r.u[k])):
            continue
        value = float(np.asarray(records[0].u[k], dtype=float).flat[0])
        files = ", ".join(str(getattr(r, "source", "?")) for r in records[:3])
        raise IdentificationError(
            f"{files}{' and more' if len(records) > 3 else ''}: input {name!r}: the input is "
            f"constant ({value:g}) in every record given; expected a record that excites it "
            f"(`excitation` writes one per input, hysteresis-{name}.csv): add it, or leave "
            f"{name!r} out of --inputs")


def _names(record, in_keys, out_keys):
    """Model names: the column names, or u0.. / y0.. for headerless files."""
    ins = [n if not n.startswith("column ") else f"u{i}" for i, n in enumerate(record.input_names)]
    outs = [n if not n.startswith("column ") else f"y{i}" for i, n in enumerate(record.output_names)]
    if len(ins) == 1 and ins[0] == "u0":
        ins = ["u"]
    if len(outs) == 1 and outs[0] == "y0":
        outs = ["y"]
    return ins, outs


def _report(args, fit, records, dyn=None, creep=None):
    iu, ou = args.input_unit, args.output_unit
    model = fit.model
    read = {r.source: r.n_samples for r in records}
    for rec, s in zip(fit.records, fit.splits):
        cut = cut_note(rec.n_samples, read.get(rec.source, 0))
        print(f"{rec.source}: {rec.n_samples} samples{cut}, T = {rec.sampling_period:.6g} s, "
              f"excitation {model.input_names[s.excitation]}; {s.description}")
    print(f"{fit.method}: {model.n_outputs} output(s) x {model.n_inputs} input(s), partition "
          f"{fit.partition}, inputs [{iu}] -> outputs [{ou}]")
    for line in delay_report_lines(args.delay, args.delay_estimate, fit.records[0].sampling_period,
                                   args.delay_given):
        print(f"  {line}")
    for note in fit.notes:
        print(f"  {note}")
    # what the sensor reads at rest: the offset sits in a Preisach or generalised-PI model's
    # direct path (its output_offset is None), where "output offset 0" misled a user whose
    # sensor read 12.5 um at 0 V
    at_rest = model.simulate(np.zeros((model.n_inputs, 1)))[0][:, 0]
    for l, out in enumerate(model.output_names):
        parts = []
        for k, inp in enumerate(model.input_names):
            c = model.components[l][k]
            if fit.structure[l][k] == "pi":
                parts.append(f"{inp}: PI {c.n_hysterons} hysterons, thresholds "
                             f"{c.thresholds[0]:.4g}..{c.thresholds[-1]:.4g} {iu}")
            elif fit.structure[l][k] == "preisach":
                parts.append(f"{inp}: Preisach {c.n_levels} levels ({c.n_states} hysterons"
                             f"{', signed density' if c.signed else ''}), grid "
                             f"{c.edges[0]:.4g}..{c.edges[-1]:.4g} {iu}")
            elif fit.structure[l][k] == "generalized":
                parts.append(f"{inp}: generalized PI {c.n_states} plays, envelopes "
                             f"{_envelope_text(c.gamma_l)} rising, "
                             f"{_envelope_text(c.gamma_r)} falling")
            elif fit.structure[l][k] == "gain":
                parts.append(f"{inp}: gain {c:.4g} {ou}/{iu}")
            else:
                parts.append(f"{inp}: absent")
        print(f"  {out} <- " + "; ".join(parts) + f"; output at 0 V (demagnetised) "
              f"{at_rest[l]:.4g} {ou}")
        mp = None if getattr(model, "output_map", None) is None else model.output_map[l]
        if mp is not None:
            print(f"  {out}: output map, {mp.knots.size} knots, slopes "
                  f"{mp.slopes.min():.4g}..{mp.slopes.max():.4g}")
    single = model.n_outputs == 1
    for label, reps in (("training", fit.train), ("held-out", fit.validation)):
        for name, rep in zip(model.output_names, reps or []):
            print(_line(label, "" if single else f" {name}", rep, ou))
    for line in level_report_lines(fit, ou):
        print(line)
    loops = minor_loop_warning(fit, list(model.input_names), list(model.output_names))
    if loops:
        print_err(f"warning: {loops}")
    for line in _falling_direct_paths(records, list(model.input_names), list(model.output_names),
                                      ou, iu):
        print_err(f"warning: {line}")
    for line in _flat_extremes(records, list(model.output_names), ou):
        print_err(f"warning: {line}")
    for line in clockwise_loop_warnings(records, list(model.input_names),
                                        list(model.output_names)):
        print_err(f"warning: {line}")
    if dyn is not None:
        for line in dynamics_report_lines(dyn.summary, model.output_names, model.input_names):
            print(line)
        poor = dynamics_fit_warning(dyn.summary, dyn.conditions, ou)
        if poor:
            print_err(f"warning: {poor}")
        above = modes_above_band_warning(dyn.summary)
        if above:
            print_err(f"warning: {above}")
        gain = static_gain_warning(dyn.summary, list(model.output_names),
                                   list(model.input_names))
        if gain:
            print_err(f"warning: {gain}")
    if creep is not None:
        for line in creep.report_lines(ou):
            print(line)
    if args.metrics:
        print(f"wrote {args.metrics}")
    if args.plot:
        print(f"wrote {args.plot}")
        if dyn is not None:
            print(f"wrote {_bode_path(args.plot)}")
    print(f"wrote {args.out}")


def _hold_step_notes(records, table, unit):
    """Notes for the records' steps out of (or into) a hold that the stored slew leaves out.

    Only those larger than the slew stored: a real record that is 0 V for
    3 s and then starts a sine at -87 V in one sample would have given every
    drive 435 kV/s of slew where the sine itself moves at 942 V/s.
    """
    lines = []
    for name, (step, time, rate) in records_hold_steps(records, list(table)[1:]).items():
        slew = table[name].get("slew_rate", 0.0)
        if rate > slew * (1 + 1e-9):
            lines.append(f"{name}: the records' step of {step:.4g} {unit} at {time:.4g} s, out "
                         f"of a hold or into one (the amplifier switched on or off), is not "
                         f"counted in the slew rate the model file takes from the records "
                         f"({slew:.4g} {unit}/s): drives stay within the slew the records "
                         f"followed; widen the model file's [amplifier] table if your "
                         f"amplifier is faster (docs/drives.md)")
    return lines


def _bode_path(plot):
    """The Bode figure written next to ``--plot FILE.png``: ``FILE-dynamics.png``."""
    path = Path(plot)
    return path.with_name(f"{path.stem}-dynamics{path.suffix or '.png'}")


def _write_bode(path, dyn, names):
    import matplotlib.pyplot as plt  # lazy: only for --plot
    s = dyn.summary
    fig = measured_bode_figure(
        dyn.identifier.system_, dyn.frf_frequency_hz, dyn.frf, names,
        title=f"Identified G (order {s['order']}, held-out fit {s['held_out_fit_percent']:.1f} %) "
              f"over the measured H1 estimate")
    try:
        safe_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110,
                                                metadata=png_provenance("identify")), "figure")
    finally:
        plt.close(fig)
