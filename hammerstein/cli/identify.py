"""``hammerstein identify``: identify a classical PI model from a measured record.

Reads a delimited text file (:func:`hammerstein.datafiles.read_record`),
identifies a classical PI model on the first ``--train-fraction`` of the
record (closed form or least squares, :mod:`hammerstein.identification`),
reports the fit on the training loops and on the held-out rest (RMS in µm and
in % of the output range), and saves a 1x1 model file with
:func:`hammerstein.presets.save_model` and an ``[identification]`` table.

Exit status: 0 on success, 1 on a data or identification error, 2 on a
usage error; the model file is written only on success (atomically).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

__all__ = ["add_parser"]


def add_parser(subparsers):
    """Register the ``identify`` subcommand (sets ``handler``)."""
    p = subparsers.add_parser(
        "identify", help="identify a classical PI model from a measured record",
        description="Identify a classical Prandtl-Ishlinskii model (input [V] -> output [µm]) "
                    "from a CSV/text record, report the fit on training and held-out samples, "
                    "and save a model file.")
    p.add_argument("data", metavar="DATA.csv", help="delimited text file (header optional)")
    p.add_argument("--input", required=True, metavar="COL", help="input column [V], name or 0-based index")
    p.add_argument("--output", required=True, metavar="COL", help="output column [µm], name or 0-based index")
    p.add_argument("--time", metavar="COL", help="time column [s], name or 0-based index")
    p.add_argument("--sampling-period", type=float, metavar="S",
                   help="sampling period [s] when there is no time column")
    p.add_argument("--method", choices=["closed-form", "least-squares"], default="least-squares",
                   help="Appendix closed form or least squares over the record (default)")
    p.add_argument("--thresholds", default="15", metavar="N|r1,r2,...",
                   help="number of hysterons, or explicit thresholds [V] (default 15)")
    p.add_argument("--partition", choices=["time", "input"], default="time",
                   help="threshold partition of the ascending half period (default time)")
    p.add_argument("--bounds", choices=["none", "nonnegative"], default="none",
                   help="least-squares weight bounds (default none)")
    p.add_argument("--train-fraction", type=float, default=0.7, metavar="F",
                   help="fraction of the record used for training; the rest is held out (default 0.7)")
    p.add_argument("--skip", type=float, metavar="SECONDS",
                   help="least squares: burn-in [s] that only warms up the play states "
                        "(default: up to the first complete ascending branch)")
    p.add_argument("--out", required=True, metavar="MODEL.toml", help="model file to write")
    p.set_defaults(handler=_handler)


def _parse_thresholds(text):
    text = text.strip()
    if "," not in text:
        try:
            n = int(text)
        except ValueError:
            raise ValueError(f"--thresholds: expected a count N or a list r1,r2,..., found {text!r}") from None
        if n < 1:
            raise ValueError(f"--thresholds: expected N >= 1, found {n}")
        return n, None
    try:
        r = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise ValueError(f"--thresholds: expected numbers [V] separated by commas, found {text!r}") from None
    return r.size, r


def _line(label, rep):
    return (f"{label}: RMS {rep['rms_um']:.4g} µm = {rep['rms_percent_of_range']:.3g} % of the "
            f"{rep['output_range_um']:.4g} µm range, max |error| {rep['max_abs_um']:.4g} µm "
            f"({rep['n_samples']} samples)")


def _handler(args):
    from hammerstein.core.datafiles import DataFileError, read_record
    from hammerstein.core.hysteresis import HysteresisError, MultivariablePI
    from hammerstein.core.identification import IdentificationError
    from hammerstein.core.presets import save_model
    from hammerstein.core.record_identification import identify_record

    try:
        n, thresholds = _parse_thresholds(args.thresholds)
        if not 0 < args.train_fraction <= 1:
            raise ValueError(f"--train-fraction: expected in (0, 1], found {args.train_fraction}")
        if args.time is None and args.sampling_period is None:
            raise ValueError("give --time COL or --sampling-period S")
        if args.sampling_period is not None and not (np.isfinite(args.sampling_period)
                                                     and args.sampling_period > 0):
            raise ValueError(f"--sampling-period: expected a positive time [s], "
                             f"found {args.sampling_period}")
        if args.skip is not None and not (np.isfinite(args.skip) and args.skip >= 0):
            raise ValueError(f"--skip: expected a time >= 0 [s], found {args.skip}")
        if Path(args.out).is_dir():
            raise ValueError(f"--out: {args.out} is a directory; expected a model file name")
    except ValueError as exc:
        print(f"hammerstein identify: error: {exc}", file=sys.stderr)
        return 2
    try:
        rec = read_record(args.data, args.input, args.output, args.time, args.sampling_period)
        ident, train, val = identify_record(
            rec, args.method, n, thresholds, args.partition,
            None if args.bounds == "none" else args.bounds, args.train_fraction, args.skip)
        in_name = "u" if rec.input_name.startswith("column ") else rec.input_name
        out_name = "y" if rec.output_name.startswith("column ") else rec.output_name
        if in_name == out_name:
            out_name = out_name + "_out"
        model = MultivariablePI([[ident.model_]], [in_name], [out_name], [ident.amplitude_])
        meta = {"method": args.method, "source": str(args.data),
                "input_column": str(args.input), "output_column": str(args.output),
                "n_hysterons": int(ident.thresholds_.size),
                "partition": "explicit" if thresholds is not None else args.partition,
                "bounds": args.bounds, "train_fraction": args.train_fraction,
                "sampling_period_s": rec.sampling_period, "amplitude_V": ident.amplitude_,
                "offset_um": ident.offset_,
                "train_rms_um": train["rms_um"],
                "train_rms_percent_of_range": train["rms_percent_of_range"]}
        if val is not None:
            meta.update(validation_rms_um=val["rms_um"],
                        validation_rms_percent_of_range=val["rms_percent_of_range"],
                        validation_max_abs_um=val["max_abs_um"])
        save_model(model, args.out, meta)
    except (DataFileError, IdentificationError, HysteresisError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {args.out}: cannot write the model ({exc.strerror or exc})", file=sys.stderr)
        return 1
    print(f"{rec.source}: {rec.n_samples} samples, T = {rec.sampling_period:.6g} s, "
          f"input {rec.input_name!r} [V] -> output {rec.output_name!r} [µm]")
    print(f"{args.method}: {ident.thresholds_.size} hysterons, thresholds "
          f"{ident.thresholds_[0]:.4g}..{ident.thresholds_[-1]:.4g} V, input amplitude "
          f"{ident.amplitude_:.4g} V, output offset {ident.offset_:.4g} µm")
    print(_line("training", train))
    if val is not None:
        print(_line("held-out", val))
    print(f"wrote {args.out}")
    return 0
