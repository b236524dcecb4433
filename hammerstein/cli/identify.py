"""``hammerstein identify``: identify a p x m PI model from measured records.

Reads one or more delimited text files (:func:`hammerstein.core.datafiles.read_records`),
each holding the time (or given the sampling period), every input column and
every output column; identifies a multivariable classical PI model
(:func:`hammerstein.core.record_identification.identify_records`: split at
reversal points, held-out complete branches or periods, partition and
component structure chosen automatically unless given), reports the fit on
the training and held-out samples, and writes a model file
(:func:`hammerstein.core.presets.save_model`) that ``model = "path"`` in a
scenario and the compensators accept. Optional: ``--metrics`` (long CSV),
``--plot`` (loops and errors), ``--dynamics`` (a preset with linear dynamics).

Exit status: 0 on success, 1 on a data or identification error (one line on
stderr), 2 on a usage error; nothing is written unless everything succeeded,
every file is written through a temporary file and a rename, and a file the
project did not write is never overwritten without ``--force``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from hammerstein.core.datafiles import DataFileError, column_list, read_records
from hammerstein.cli._common import out_file_problem
from hammerstein.core.files import (FileLimitError, all_or_nothing, png_provenance,
                                    provenance_line, replace_problem, safe_write)
from hammerstein.core.presets import PresetError, save_model
from hammerstein.core.record_identification import dynamics_tables, identify_records
from hammerstein.exceptions import HysteresisError, IdentificationError
from hammerstein.scenario.schema import MAX_HYSTERONS

__all__ = ["add_parser"]

#: Header of a metrics file (the project's long format).
METRICS_HEADER = "case,channel,metric,value,unit"


def add_parser(subparsers):
    """Register the ``identify`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "identify", help="identify a (multivariable) PI model from measured records",
        description="Identify a multivariable classical Prandtl-Ishlinskii model from CSV/text "
                    "records (one or more files, each with every input and output column), "
                    "report the fit on training and held-out periods, and save a model file.")
    p.add_argument("data", nargs="+", metavar="DATA.csv",
                   help="delimited text files (header optional); typically one per excited input")
    p.add_argument("--input", "--inputs", dest="inputs", required=True, metavar="COLS",
                   help="input column(s), names or 0-based indices separated by commas")
    p.add_argument("--output", "--outputs", dest="outputs", required=True, metavar="COLS",
                   help="output column(s), names or 0-based indices separated by commas")
    p.add_argument("--time", metavar="COL", help="time column [s], name or 0-based index")
    p.add_argument("--sampling-period", type=float, metavar="S",
                   help="sampling period [s] when there is no time column")
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
                   help="least squares: constrain the direct transfers (default none)")
    p.add_argument("--components", default="auto", metavar="auto|all|OUT:IN=KIND,...",
                   help="auto (default): components whose contribution is below the noise "
                        "become pure gains or absent; all: every component a PI; or explicit "
                        "kinds pi, gain, none per OUT:IN")
    p.add_argument("--hold-out", choices=["auto", "none"], default="auto",
                   help="auto (default): hold out the last complete branches or periods of "
                        "each record; none: train on everything, no validation")
    p.add_argument("--output-map", choices=["auto", "none", "deadzone"], default="auto",
                   help="static monotone map after the PI, the modified PI of Kuhnen (one-sided "
                        "dead zones; models asymmetric and saturating loops, exactly "
                        "invertible). auto (default): kept when the loop is not "
                        "point-symmetric and the map lowers the held-out error, or when it "
                        "lowers it by more than 10 %%; deadzone: always; none: classical PI")
    p.add_argument("--train-fraction", type=float, metavar="F",
                   help="split instead at the reversal point nearest to this fraction of "
                        "each record")
    p.add_argument("--skip", type=float, metavar="SECONDS",
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
                   help="broadband records (same columns) for --dynamics")
    p.add_argument("--force", action="store_true",
                   help="overwrite --out, --metrics or --plot even if the project did not write it")
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
    problem = out_file_problem(path, f"{kind} file")  # empty, directory, special, under a file
    if problem:
        raise _Usage(problem.replace("--out", option, 1))
    problem = replace_problem(path, inputs, force, "hammerstein identify",
                              "one of the data files")
    if problem:
        raise _Usage(f"{option}: {problem}")


def _atomic_write(path, write):
    """``write(binary file)`` through an exclusive temporary file next to ``path``, then rename
    (:func:`hammerstein.core.files.safe_write`: symlink target written, permissions kept)."""
    safe_write(path, write, "file")


def _check_usage(args):
    n, thresholds = _parse_thresholds(args.thresholds)
    if args.train_fraction is not None and not 0 < args.train_fraction <= 1:
        raise _Usage(f"--train-fraction: expected in (0, 1], found {args.train_fraction}")
    if args.train_fraction is not None and args.hold_out == "none":
        raise _Usage("--train-fraction and --hold-out none: give one of them")
    if args.time is None and args.sampling_period is None:
        raise _Usage("give --time COL or --sampling-period S")
    if args.sampling_period is not None and not (np.isfinite(args.sampling_period)
                                                 and args.sampling_period > 0):
        raise _Usage(f"--sampling-period: expected a positive time [s], found {args.sampling_period}")
    if args.skip is not None and not (np.isfinite(args.skip) and args.skip >= 0):
        raise _Usage(f"--skip: expected a time >= 0 [s], found {args.skip}")
    if args.bounds != "none" and args.method == "closed-form":
        raise _Usage("--bounds: only used by --method least-squares")
    if args.output_map == "deadzone" and args.method == "closed-form":
        raise _Usage("--output-map deadzone: only used by --method least-squares")
    if args.dynamics_records and not args.dynamics:
        raise _Usage("--dynamics-records: only used with --dynamics")
    if args.dynamics and not args.dynamics_records:
        raise _Usage("--dynamics: give the broadband records with --dynamics-records FILE ...")
    for unit, opt in ((args.input_unit, "--input-unit"), (args.output_unit, "--output-unit")):
        if not unit.strip():
            raise _Usage(f"{opt}: expected a unit name")
    inputs = list(args.data) + list(args.dynamics_records)
    _check_target(args.out, "--out", "model", args.force, inputs)
    targets = [Path(args.out).resolve()]
    for path, opt, kind in ((args.metrics, "--metrics", "metrics"), (args.plot, "--plot", "plot")):
        if path is not None:
            _check_target(path, opt, kind, args.force, inputs)
            if Path(path).resolve() in targets:
                raise _Usage(f"{opt}: {path} is already another output of this command")
            targets.append(Path(path).resolve())
    return n, thresholds


def _line(label, name, rep, unit):
    return (f"{label}{name}: RMS {rep['rms']:.4g} {unit} = {rep['rms_percent']:.3g} % of the "
            f"{rep['range']:.4g} {unit} range, max |error| {rep['max_abs']:.4g} {unit} "
            f"({rep['n_samples']} samples)")


def metrics_rows(fit, output_unit):
    """Rows ``(case, channel, metric, value, unit)`` of a fit (train, validation).

    Parameters
    ----------
    fit : RecordFit
        Result of :func:`hammerstein.core.record_identification.identify_records`.
    output_unit : str
        Unit of the outputs (e.g. ``"µm"``), written in the unit column of the
        absolute errors.

    Returns
    -------
    list of tuple
        Per window (``"train"``, then ``"validation"`` when something was
        held out) and output: ``rms_error`` [output unit],
        ``rms_error_percent`` [%] of the measured range and ``max_abs_error``
        [output unit].
    """
    rows = []
    for case, reps in (("train", fit.train), ("validation", fit.validation)):
        for name, rep in zip(fit.model.output_names, reps or []):
            rows += [(case, name, "rms_error", rep["rms"], output_unit),
                     (case, name, "rms_error_percent", rep["rms_percent"], "%"),
                     (case, name, "max_abs_error", rep["max_abs"], output_unit)]
    return rows


def _write_metrics(path, rows):
    import pandas as pd  # lazy: only for --metrics
    frame = pd.DataFrame(rows, columns=METRICS_HEADER.split(","))
    text = provenance_line("identify") + frame.to_csv(index=False, float_format="%.7g")
    _atomic_write(path, lambda fh: fh.write(text.encode()))


def fit_figure(fit, input_unit, output_unit):
    """Measured vs model loops per component (rows outputs, columns inputs) and the error.

    Each loop panel (l, k) shows output l against input k over the records
    whose excitation is input k, training samples in blue, held-out samples
    in orange, the model dashed; the last column shows the error of output l
    over all records (held-out part shaded).

    Parameters
    ----------
    fit : RecordFit
        Result of :func:`hammerstein.core.record_identification.identify_records`
        for a p x m model.
    input_unit : str
        Unit of the inputs for the axis labels (e.g. ``"V"``).
    output_unit : str
        Unit of the outputs and of the error (e.g. ``"µm"``).

    Returns
    -------
    matplotlib.figure.Figure
        p rows by m + 1 columns of axes; the caller saves and closes it.
    """
    import matplotlib  # lazy: only for --plot
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    model = fit.model
    p, m = model.n_outputs, model.n_inputs
    fig, axes = plt.subplots(p, m + 1, figsize=(3.2 * (m + 1), 2.6 * p), squeeze=False,
                             layout="constrained")
    for l in range(p):
        for k in range(m):
            ax = axes[l][k]
            kind = fit.structure[l][k]
            for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
                if s.excitation != k:
                    continue
                used = s.train | s.held_out
                ax.plot(rec.u[k][s.train], rec.y[l][s.train], ".", ms=1.5, color="tab:blue")
                ax.plot(rec.u[k][s.held_out], rec.y[l][s.held_out], ".", ms=1.5,
                        color="tab:orange")
                ax.plot(rec.u[k][used], pred[l][used], "--", lw=0.8, color="k")
            ax.set_title(f"{model.output_names[l]} <- {model.input_names[k]} ({kind})", fontsize=9)
            ax.set_xlabel(f"{model.input_names[k]} [{input_unit}]", fontsize=8)
            ax.set_ylabel(f"{model.output_names[l]} [{output_unit}]", fontsize=8)
            ax.tick_params(labelsize=7)
        ax = axes[l][m]
        start = 0
        for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
            idx = np.arange(rec.n_samples) + start
            used = s.train | s.held_out
            ax.plot(idx[used], (rec.y[l] - pred[l])[used], lw=0.6, color="tab:red")
            if s.held_out.any():
                h = idx[s.held_out]
                ax.axvspan(h[0], h[-1], color="tab:orange", alpha=0.15, lw=0)
            start += rec.n_samples
        ax.set_title(f"error of {model.output_names[l]} (held out shaded)", fontsize=9)
        ax.set_xlabel("sample (records in order)", fontsize=8)
        ax.set_ylabel(f"[{output_unit}]", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle("measured (training blue, held out orange) vs model (dashed)", fontsize=10)
    return fig


def _write_plot(path, fit, input_unit, output_unit):
    import matplotlib.pyplot as plt  # lazy: only for --plot
    fig = fit_figure(fit, input_unit, output_unit)
    try:
        _atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110,
                                                   metadata=png_provenance("identify")))
    finally:
        plt.close(fig)


def _metadata(args, fit, records):
    val = fit.validation
    meta = {"method": fit.method, "sources": [str(d) for d in args.data],
            "input_columns": str(args.inputs), "output_columns": str(args.outputs),
            "partition": fit.partition,
            "partition_scores_percent": {k: float(v) for k, v in fit.partition_scores.items()},
            "components": {out: {inp: fit.structure[l][k]
                                 for k, inp in enumerate(fit.model.input_names)}
                           for l, out in enumerate(fit.model.output_names)},
            "bounds": args.bounds, "output_map": fit.output_map, "sampling_period_s": [r.sampling_period for r in records],
            "input_unit": args.input_unit, "output_unit": args.output_unit,
            "held_out": [s.description for s in fit.splits],
            "notes": list(fit.notes),
            "train_rms": [r["rms"] for r in fit.train],
            "train_rms_percent_of_range": max(r["rms_percent"] for r in fit.train)}
    if val is not None:
        meta.update(validation_rms=[r["rms"] for r in val],
                    validation_rms_percent_by_output=[r["rms_percent"] for r in val],
                    validation_rms_percent_of_range=max(r["rms_percent"] for r in val),
                    validation_max_abs=[r["max_abs"] for r in val])
    return meta


def _handler(args):

    try:
        n, thresholds = _check_usage(args)
    except _Usage as exc:
        print(f"hammerstein identify: error: {exc}", file=sys.stderr)
        return 2
    try:
        records = [read_records(d, args.inputs, args.outputs, args.time, args.sampling_period)
                   for d in args.data]
        names = _names(records[0], column_list(args.inputs), column_list(args.outputs))
        fit = identify_records(
            records, args.method, n, thresholds, "time" if thresholds is not None and
            args.partition == "auto" else args.partition, args.bounds, args.components,
            args.hold_out, args.train_fraction, args.skip, *names, output_map=args.output_map)
        extra = None
        if args.dynamics:
            extra = _dynamics_tables(args, fit)
        rows = metrics_rows(fit, args.output_unit)
        with all_or_nothing():  # a failed write (full disk) leaves none of the outputs
            save_model(fit.model, args.out, _metadata(args, fit, records), args.input_unit,
                       args.output_unit, extra)
            if args.plot:
                _write_plot(args.plot, fit, args.input_unit, args.output_unit)
            if args.metrics:
                _write_metrics(args.metrics, rows)
    except (DataFileError, IdentificationError, HysteresisError, PresetError, FileLimitError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {exc.filename or args.out}: cannot write ({exc.strerror or exc})",
              file=sys.stderr)
        return 1
    _report(args, fit, records)
    return 0


def _names(record, in_keys, out_keys):
    """Model names: the column names, or u0.. / y0.. for headerless files."""
    ins = [n if not n.startswith("column ") else f"u{i}" for i, n in enumerate(record.input_names)]
    outs = [n if not n.startswith("column ") else f"y{i}" for i, n in enumerate(record.output_names)]
    if len(ins) == 1 and ins[0] == "u0":
        ins = ["u"]
    if len(outs) == 1 and outs[0] == "y0":
        outs = ["y"]
    return ins, outs


def _report(args, fit, records):
    iu, ou = args.input_unit, args.output_unit
    model = fit.model
    for rec, s in zip(fit.records, fit.splits):
        print(f"{rec.source}: {rec.n_samples} samples, T = {rec.sampling_period:.6g} s, "
              f"excitation {model.input_names[s.excitation]}; {s.description}")
    print(f"{fit.method}: {model.n_outputs} output(s) x {model.n_inputs} input(s), partition "
          f"{fit.partition}, inputs [{iu}] -> outputs [{ou}]")
    for note in fit.notes:
        print(f"  {note}")
    for l, out in enumerate(model.output_names):
        parts = []
        for k, inp in enumerate(model.input_names):
            c = model.components[l][k]
            if fit.structure[l][k] == "pi":
                parts.append(f"{inp}: PI {c.n_hysterons} hysterons, thresholds "
                             f"{c.thresholds[0]:.4g}..{c.thresholds[-1]:.4g} {iu}")
            elif fit.structure[l][k] == "gain":
                parts.append(f"{inp}: gain {c:.4g} {ou}/{iu}")
            else:
                parts.append(f"{inp}: absent")
        off = 0.0 if model.output_offset is None else model.output_offset[l]
        print(f"  {out} <- " + "; ".join(parts) + f"; output offset {off:.4g} {ou}")
        mp = None if model.output_map is None else model.output_map[l]
        if mp is not None:
            print(f"  {out}: output map, {mp.knots.size} knots, slopes "
                  f"{mp.slopes.min():.4g}..{mp.slopes.max():.4g}")
    single = model.n_outputs == 1
    for label, reps in (("training", fit.train), ("held-out", fit.validation)):
        for name, rep in zip(model.output_names, reps or []):
            print(_line(label, "" if single else f" {name}", rep, ou))
    if args.metrics:
        print(f"wrote {args.metrics}")
    if args.plot:
        print(f"wrote {args.plot}")
    print(f"wrote {args.out}")


def _dynamics_tables(args, fit):
    """``[preset]`` and ``[dynamics]`` tables of a preset with identified linear dynamics."""
    dyn = [read_records(d, args.inputs, args.outputs, args.time, args.sampling_period)
           for d in args.dynamics_records]
    try:
        return dynamics_tables(fit, dyn, name=Path(args.out).stem)
    except ImportError:
        raise IdentificationError(
            "--dynamics: the linear-dynamics identifier (hammerstein.core.lti) is not part of "
            "this installation") from None
