"""``hammerstein evaluate``: the metrics, figure and report of a measured response.

Reads a measured record (``t`` [s], one column per output [µm], optionally
the applied inputs [V]) and the reference it should have followed (an
inline TOML table as in scenarios, or a CSV file), and writes into
``--out DIR`` what ``hammerstein run`` writes for a compensated case:
``metrics.csv`` (the same metrics, over the same steady-state window after
``--settle-periods``, :func:`hammerstein.signals.metrics.tracking_metrics`),
``trajectory-measured.png``, ``timeseries-measured.csv`` and
``report.md``. With ``--drive`` a drive file whose reference ``compensate``
shaped to the amplifier and the identified dynamics (columns
``<output>_shaped`` [µm]) is also judged against that shaped reference:
the same metrics, ``case`` ``shaped`` in ``metrics.csv`` and a second table
in the report (the raw reference's metrics stay case ``measured``). The
figure and ``timeseries-measured.csv`` show the reference the drive
followed: with ``--drive``, its shaped reference, else the reference faded
in from rest as its header records (the metrics, after the fade-in, are
the same against either); the figure shades the fade-in apart from the
settling periods after it. Units: the ``--drive`` header's, else µm and V (a model's in
nm and mV: ``x_nm`` columns, nm metrics; :func:`~hammerstein.compensation.drive_files.drive_units`).

The delay between the reference and the measurement is estimated by
cross-correlation over the settled part (after the fade-in and ``--settle-periods``),
within half a period of a periodic reference (integer samples,
:func:`hammerstein.compensation.ilc.estimate_delay`)
and reported (metrics ``delay_samples`` and ``delay``); it is not removed
unless ``--remove-delay`` is given (then the measurement is advanced by it
and the last samples, not measured, are dropped).

Exit status: 0 written; 1 bad files (one line, nothing written); 2 a
usage error. ``DIR`` is replaced only when it is empty or carries the
``.hammerstein-report`` marker of a report (as for ``run``).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from hammerstein.core._version import VERSION
from hammerstein.cli._common import add_column_options, out_dir_problem, print_err
from hammerstein.cli._hardware import (catch, inline_table, load_actuator, load_reference, mapping,
                                       nonnegative_float, settle_periods, positive_float)
from hammerstein.signals import metrics as met
from hammerstein.models.amplifier import drive_metrics
from hammerstein.compensation.drive import (apply_amplifier, drive_fade_samples, hardware_fade,
                                           read_signals)
from hammerstein.cli._evaluate_files import Tables, drive_inputs, now_or_later
from hammerstein.compensation.drive_files import (AIMED_SUFFIXES, drive_input_names, drive_rest_lead,
                                                  drive_rest_output, drive_units,
                                                  head_lines, optional_columns)
from hammerstein.core.files import (all_or_nothing, bounded_read_bytes, guard_inputs,
                                    make_directory, output_problem, safe_write)
from hammerstein.compensation.ilc import estimate_delay
from hammerstein.cli._learn_checks import (gain_band, model_gain_note, model_gains,
                                           plant_first_mode, start_lag, start_lag_text,
                                           stepping_outputs)
from hammerstein.compensation.shaping import delay_search_span
from hammerstein.signals.references import raster_line_index
from hammerstein.exceptions import (DataFileError, FileLimitError, HammersteinError, OutputError,
                                   PresetError)
from hammerstein.io.datafiles import signal_table
from hammerstein.core.files import markdown_text
from hammerstein.report.definitions import definitions_lines
from hammerstein.report.figures import save
from hammerstein.report._ownership import (MARKER, digests_of, manifest_text, report_manifest,
                                           unlisted_entries)
from hammerstein.report.scenario import signal_summary
from hammerstein.report.tables import CSV_CHUNK_ROWS
from hammerstein.report.trajectories import trajectory_figure

__all__ = ["add_parser", "evaluate"]

#: the files ``evaluate --out DIR`` writes into DIR
OUTPUT_FILES = (MARKER, "metrics.csv", "timeseries-measured.csv", "trajectory-measured.png",
                "report.md")


def add_parser(subparsers):
    """Register the ``evaluate`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "evaluate", help="metrics and figures of a measured response",
        description="Compute the metrics, figure and report of `hammerstein run` on a measured "
                    "response to a reference; the delay between them is estimated and reported.")
    p.add_argument("--reference", required=True, metavar="SPEC_OR_CSV",
                   help="inline TOML table as a scenario's reference, or a CSV file (t [s], one "
                        "column per output), in the drive's (or --model's) output unit, µm by default")
    p.add_argument("--measured", required=True, metavar="MEASURED.csv",
                   help="t [s] from the drive's start, one column per output, optionally "
                        "one per input, in the drive's (or --model's) units, µm and V by default")
    p.add_argument("--out", required=True, metavar="DIR", help="report directory")
    p.add_argument("--model", metavar="MODEL_OR_PRESET",
                   help="names the inputs and outputs (without it: the reference's, else those "
                        "of the actuator the --drive file's header names, else x,y)")
    add_column_options(
        p, outputs_help="output names, or NAME=COLUMN for columns named otherwise (default: "
                            "--model's outputs, else a CSV reference's columns, else the --drive "
                            "header's actuator's, else x,y)",
        inputs_help="input columns [V] to report peak_input / peak_slew and plot",
        time_help="time column (default t)")
    p.add_argument("--sampling-period", type=positive_float, metavar="S",
                   help="resample the measurement onto this period [s] (default: the "
                        "--drive's, else its own); a measurement faster by an integer factor is "
                        "averaged over each period, a slower one refused")
    p.add_argument("--period", type=positive_float, metavar="S",
                   help="period of a periodic CSV reference [s] (the settling window)")
    p.add_argument("--settle-periods", type=settle_periods, default=1.0, metavar="N",
                   help="periods excluded from the metrics after the fade-in (default 1, as "
                        "scenarios)")
    p.add_argument("--drive", metavar="DRIVE.csv",
                   help="the drive file that was applied (compensate, learn): its fade-in "
                        "(header) is left out of the metrics and marked in the figure; where compensate "
                        "shaped the reference (columns <output>_shaped) the metrics against "
                        "that shaped reference are reported as well (case shaped)")
    p.add_argument("--fade-in", type=nonnegative_float, metavar="S",
                   help="fade-in to leave out of the metrics [s] (default: the --drive file's, "
                        "else 0)")
    p.add_argument("--remove-delay", action="store_true",
                   help="advance the measurement by the estimated delay before the metrics")
    p.set_defaults(handler=_handle)


def _reference_outputs(args, tables):
    """The columns of a CSV ``--reference`` but its time, when neither ``--model`` nor
    ``--output-columns`` names the outputs; for an inline reference the outputs it names
    (``output`` of a one-axis sine or triangle when the measurement has no column for x and y
    both: a one-axis stage; ``outputs`` of a planar one); None for a file that cannot be read
    (``read_signals`` then says why)."""
    if args.outputs:
        return None
    if args.reference.lstrip().startswith("{"):
        try:
            spec = inline_table(args.reference)
        except DataFileError:
            return None                   # load_reference says why
        named = spec.get("outputs") if isinstance(spec, dict) else None
        if isinstance(named, list) and named and all(isinstance(n, str) for n in named):
            return list(named)
        one = spec.get("output") if isinstance(spec, dict) else None
        center = spec.get("center") if isinstance(spec, dict) else None
        if isinstance(center, list) and len(center) > 2 and not isinstance(one, str):
            # a circle of a four-axis stage, centred on every output: the measured file's
            # outputs, in its order (center = [42, 42, 20, 30] was refused as "two values")
            found = _measured_outputs(args, tables)
            return found if found is not None and len(found) == len(center) else None
        if not isinstance(one, str):
            return None
        try:
            columns = {str(c) for c in
                       tables.get(args.measured, "--measured", args.time).frame.columns}
        except DataFileError:
            return None
        return None if {"x", "y"} <= columns else [one]
    try:
        raw = bounded_read_bytes(args.reference, "data", "data file")
        columns = signal_table(raw, args.reference, "--reference").frame.columns
    except (DataFileError, FileLimitError, OSError):
        return None
    names = [str(c) for c in columns if str(c) != args.time]
    return names or None


def _drive_actuator_outputs(args):
    """The outputs of the actuator the ``--drive`` file's header names, or None.

    Without ``--model`` or ``--output-columns`` the outputs judged default to x, y; a drive
    written by ``compensate`` or ``learn`` names the actuator it was computed for
    (``# actuator PATH, kind ...``), a path as given to that command: it is looked up as
    given and next to the drive file. None when there is no drive, no such line, no such
    file, or it cannot be read (the default then applies, and the reading says what is
    missing)."""
    if args.outputs or not args.drive:
        return None
    try:
        name = next((m.group(1).strip() for m in
                     (re.match(r"#\s*actuator\s+([^,]+),", ln)
                      for ln in head_lines(args.drive, 40)) if m), None)
    except (OSError, ValueError, DataFileError, FileLimitError):
        return None
    if not name:
        return None
    for path in (Path(name), Path(args.drive).parent / name):
        if not path.is_file():
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # its warnings are compensate's, said there
            for period in (None, 1.0):          # a model file with no period: its names
                try:
                    names = list(load_actuator(str(path), period).hysteresis.output_names)
                except (HammersteinError, OSError, ValueError):
                    continue
                return names or None
    return None


def _measured_outputs(args, tables):
    """The measured file's output columns (all but the time, the drive's inputs and what a
    drive aims at), or None when it cannot be read (``tables``: :class:`~hammerstein.cli._evaluate_files.Tables`)."""
    try:
        columns = [str(c) for c in
                   tables.get(args.measured, "--measured", args.time).frame.columns]
        inputs = set(drive_input_names(args.drive, [])) if args.drive else set()
    except (DataFileError, FileLimitError, OSError):
        return None
    return [c for c in columns if c not in (args.time, "t") and c not in inputs
            and not c.endswith(AIMED_SUFFIXES)]


def _names(text, default):
    if not text:
        return list(default), {}
    names, cols = [], {}
    for item in (s.strip() for s in text.split(",") if s.strip()):
        name, _, col = item.partition("=")
        names.append(name.strip())
        if col:
            cols[name.strip()] = col.strip()
    return names, cols


def evaluate(reference, measured, period_samples, sampling_period, output_names, settle_periods=1.0,
             scale=None, loop_channel=None, remove_delay=False, raster_frequency=None,
             output_unit="µm"):
    """Metrics of a measured response (the rows of ``metrics.csv``).

    Parameters
    ----------
    reference, measured : numpy.ndarray, shape (p, n_samples)
        [µm], on the same time grid.
    period_samples : int
    sampling_period : float
        [s].
    output_names : list of str
    settle_periods : float
    scale : float, optional
        Radius / amplitude [µm].
    loop_channel : int, optional
        Output of a single-axis sine reference.
    remove_delay : bool
        Advance the measurement by the estimated delay first.
    raster_frequency : float, optional
        Raster references: line metrics.
    output_unit : str
        The values' unit (the rows stay labelled µm), named in the error.

    Returns
    -------
    rows : list of dict
        ``{channel, metric, value, unit}``; ``delay_samples`` and ``delay``
        [s] on the channel of all outputs.
    delay : int
        Estimated delay [samples] (> 0: the measurement lags).
    measured : numpy.ndarray
        The measurement the metrics used (advanced when ``remove_delay``).
    reference : numpy.ndarray

    Raises
    ------
    DataFileError
        A metric would be infinite (values too large to compute with).
    """
    # on the settled part (the fade-in's start-up is no delay), within half a period of a
    # periodic reference (a whole period is no delay either: a 1 kHz sine read 50 samples)
    start = min(int(settle_periods * max(period_samples, 1)), max(reference.shape[1] - 8, 0))
    r_s, y_s = reference[:, start:], measured[:, start:]
    max_lag = delay_search_span(reference, period_samples, sampling_period)
    max_lag = int(max(1, min(max_lag, r_s.shape[1] // 4)))
    delay = estimate_delay(r_s, y_s, max_lag)
    if remove_delay and delay > 0:
        measured = measured[:, delay:]
        reference = reference[:, :measured.shape[1]]
    rows = met.tracking_metrics(reference, measured, output_names, period_samples, settle_periods,
                                scale=scale, loop_channel=loop_channel)
    if len(output_names) > 1:   # each axis on its own scale: the Euclidean % is of the larger
        rows += _per_axis_percent(rows, reference, output_names, period_samples, settle_periods)
    if raster_frequency:
        line = raster_line_index(np.arange(reference.shape[1]) * sampling_period, raster_frequency)
        rows += met.raster_line_metrics(reference, measured, line)
    allch = "+".join(output_names)
    rows.append({"channel": allch, "metric": "delay_samples", "value": float(delay), "unit": ""})
    rows.append({"channel": allch, "metric": "delay", "value": delay * sampling_period, "unit": "s"})
    bad = [r for r in rows if isinstance(r["value"], (float, np.floating))
           and np.isinf(r["value"])]
    if bad:     # an infinite metric is an error, not a file
        raise DataFileError(f"{bad[0]['channel']}: {bad[0]['metric']} would be "
                            f"{bad[0]['value']}; the values are too large to compute with "
                            f"(check the units: {output_unit} expected)")
    return rows, delay, measured, reference


def _per_axis_percent(rows, reference, output_names, period_samples, settle_periods):
    """``max_abs_error_percent`` rows: each output's max |e| over half its reference's span.

    On a stage whose axes differ 5x (x +-40 µm, y +-8 µm), the Euclidean error in % of the
    larger axis said 5.1 % where y's own error was 8.5 % of its amplitude. An output the
    reference holds (its span below :data:`HELD_SHARE` of the largest output's) has no
    such row: a held z whose shaped reference kept 7.7e-5 µm of its start-up correction in
    the window read 6089380 %.
    """
    ref = np.asarray(reference, dtype=float)
    win = met.steady_window(ref.shape[1], period_samples, settle_periods)   # the metrics' window
    half = 0.5 * np.ptp(ref[:, win], axis=1)
    peaks = {r["channel"]: r["value"] for r in rows if r["metric"] == "max_abs_error"}
    held = HELD_SHARE * float(np.max(half, initial=0.0))
    return [{"channel": n, "metric": "max_abs_error_percent",
             "value": float(100.0 * peaks[n] / h), "unit": "%"}
            for n, h in zip(output_names, half) if n in peaks and h > 0 and h > held]


#: An output whose reference spans less than this share of the largest output's span in the
#: metrics' window is held still: it has no error in % of its own span.
HELD_SHARE = 1e-3


def _handle(args):
    problem = out_dir_problem(args.out)
    out = Path(args.out)
    if not problem and out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
        problem = (f"--out: {out} is a directory hammerstein did not write; choose an empty or "
                   f"new directory")
    if not problem and out.is_dir() and (out / MARKER).is_file():
        problem = _report_dir_problem(out)
    if problem:
        print_err(f"hammerstein evaluate: error: {problem}")
        return 2
    guard_inputs(args.model, args.measured, args.reference)   # never an output, even with --force
    for name in OUTPUT_FILES:            # before any work: an input where an output goes
        problem = output_problem(out / name, out)
        if problem:
            print_err(f"hammerstein evaluate: error: {problem}")
            return 2
    tables = Tables()
    try:
        if args.model:
            try:        # its own sampling period: at 1 s its modes read as beyond Nyquist
                plant = load_actuator(args.model, args.sampling_period)
            except PresetError:
                if args.sampling_period is not None:
                    raise
                plant = load_actuator(args.model, 1.0)   # the names of a model with no period
            outs, ins = list(plant.hysteresis.output_names), list(plant.hysteresis.input_names)
        else:     # the outputs the reference names (a one-axis stage's x), else the drive's
            outs, ins = (_reference_outputs(args, tables) or _drive_actuator_outputs(args)
                         or ["x", "y"]), []         # (the drive's actuator's)
        outs, out_cols = _names(args.outputs, outs) if not args.model else \
            (outs, mapping(args.outputs, outs, "--output-columns"))
        n_drive, period = None, args.sampling_period
        drive_voltages = drive_shaped = None
        if args.drive:      # the measurement is read at the drive's period, as learn reads it
            table = tables.get(args.drive, "--drive")
            n_drive, period = _drive_length(args.drive, args.sampling_period, table)
            # its columns taken at once (the measurement is read at its period) and the table
            # let go before the measured file is parsed; a column's error is raised where it
            # was when the drive was read again for it
            if not args.inputs:
                drive_voltages = now_or_later(drive_inputs, args.drive, outs, period, table)
            drive_shaped = now_or_later(_shaped_reference, args.drive, outs, period, table)
            del table
            tables.drop(args.drive, "--drive")
        units = drive_units(args.drive) if args.drive else tuple(plant.units) if args.model else ("V", "µm")
        rate_notes = []
        t, y, T = read_signals(args.measured, outs, args.time, out_cols, period,
                               "--measured", upsample=False, notes=rate_notes,
                               table=tables.get(args.measured, "--measured", args.time), units=units)
        u = None
        if args.inputs:
            ins, in_cols = _names(args.inputs, ins) if not args.model else \
                (ins, mapping(args.inputs, ins, "--input-columns"))
            _, u, _ = read_signals(args.measured, ins, args.time, in_cols, T, "--measured",
                                   upsample=False, notes=[],   # the same note: said once
                                   table=tables.get(args.measured, "--measured", args.time),
                                   units=units)
        found = _measured_outputs(args, tables) or [] \
            if not args.model and not args.outputs else []
        tables.drop(args.measured, "--measured")     # its columns taken
        if not args.inputs and args.drive:   # the voltages applied: the drive's own inputs
            drive_ins, u = drive_voltages()
            ins = drive_ins if u is not None else ins
        shell = SimpleNamespace(sampling_period=T, units=units, hysteresis=SimpleNamespace(
            output_names=outs, input_names=ins or ["u"], n_outputs=len(outs)))
        ref = load_reference(args.reference, shell, args.time, None, args.period)
        rate_notes += ref.notes
        if not args.model and not args.outputs:
            left = [c for c in found if c not in outs]
            if left and set(outs) <= set(found):
                rate_notes.append(f"--measured also holds {', '.join(left)}, not judged: the "
                                  f"reference names {', '.join(outs)} (--model, or "
                                  f"--output-columns {','.join(outs + left)} with a reference "
                                  f"for each, judges them too)")
        if n_drive is not None and n_drive != ref.signal.shape[1]:
            raise DataFileError(f"--drive: {n_drive} samples; expected the reference's "
                                f"{ref.signal.shape[1]}")
        if n_drive is not None and y.shape[1] < n_drive:
            raise DataFileError(f"--measured: {y.shape[1]} samples at {T:g} s; expected at least "
                                f"the drive's {n_drive} (the measurement must cover the whole "
                                f"drive)")
        N = min(ref.signal.shape[1], y.shape[1])
        if args.fade_in is not None and args.fade_in / T > N:
            raise DataFileError(f"--fade-in: {args.fade_in:g} s is longer than the record ({N} "
                                f"samples, {N * T:g} s); expected at most {N * T:g} s")
        if N < 8:
            raise DataFileError(f"--measured: {N} samples in common with the reference; expected "
                                f"the measurement of the whole reference")
        r, y = ref.signal[:, :N], y[:, :N]
        rf = ref.spec.get("frequency") if ref.kind == "raster" and ref.spec else None
        fade = (int(round(args.fade_in / T)) if args.fade_in is not None
                else drive_fade_samples(args.drive) or 0 if args.drive else 0)
        if args.drive and args.fade_in is None and drive_fade_samples(args.drive) is None:
            # a drive whose header was removed (a user's tool re-saved it): its fade-in is
            # judged as tracking, 19.8 µm where the settled error was 0.84 µm
            rate_notes.append(f"--drive {args.drive} states no fade-in (no '# ... fade-in N "
                              f"samples' header line: not written by compensate or learn, or "
                              f"its header was removed): the metrics start after "
                              f"--settle-periods from t = 0, the fade-in and start-up "
                              f"included; give --fade-in S (the drive's fade, s)")
        # the fade-in is not tracking: the metrics start after it and --settle-periods
        args.settle_periods = args.settle_periods + fade / max(ref.period_samples, 1)
        rows, delay, ym, r = evaluate(r, y, ref.period_samples, T, outs, args.settle_periods,
                                      ref.scale, ref.loop_channel, args.remove_delay, rf, units[1])
        shaped = drive_shaped() if args.drive else None
        tracked = _tracked_reference(args.drive, outs, ref.signal[:, :N], fade, shaped)
        shaped_rows = []
        if shaped is not None and shaped.shape[1] >= N:
            # the reference the drive actually follows (compensate shaped it to the
            # amplifier and the identified dynamics): judged as well, case "shaped"
            shaped_rows, _, _, _ = evaluate(shaped[:, :N], y, ref.period_samples, T, outs,
                                            args.settle_periods, ref.scale, ref.loop_channel,
                                            args.remove_delay, rf, units[1])
        gains, offset = _model_gains(plant, u, y, T, delay, fade, ref.period_samples,
                                     ref.signal[:, :N]) if args.model else (None, None)
        if offset is not None:      # a pre-trigger: the gains and errors are of the offset
            rate_notes.append(f"{start_lag_text(offset, T)}; the metrics and "
                              f"gain_against_model are of the record as it is")
        if gains is not None:
            rows += [{"channel": n, "metric": "gain_against_model", "value": float(g), "unit": "-"}
                     for n, g in zip(outs, gains) if np.isfinite(g)]     # held outputs: none
            drift = model_gain_note(gains, outs, stepping_outputs(ref.signal[:, :N]),
                                    getattr(plant, "identify_misfit", None))
            if drift and offset is None:
                rate_notes.append(drift)
        if u is not None:
            peak, slew = drive_metrics(u[:, :N], T)
            for i, n in enumerate(ins):
                rows += [{"channel": n, "metric": "peak_input", "value": float(peak[i]), "unit": "V"},
                         {"channel": n, "metric": "peak_slew", "value": float(slew[i]), "unit": "V/s"}]
        rows, shaped_rows = ([{**w, "unit": met.unit_label(w["unit"], units)} for w in ws]
                             for ws in (rows, shaped_rows))     # the values are in the drive's
        created = not os.path.lexists(out)
        try:
            with all_or_nothing():     # a failed write (full disk) leaves none of the files
                _write(out, args, rows, delay, T, tracked[:, :r.shape[1]], ym, outs, u, ins, ref,
                       shaped_rows, fade, units)
        except BaseException:
            if created:                # the directory this run made, empty again: removed
                with contextlib.suppress(OSError):
                    os.rmdir(out)
            raise
        # then the digests of what it wrote (once written): a later evaluate or run replaces
        # no file edited since (report.md annotated by hand was). The report is complete
        # without them (its marker lists the names): a failure here is no error
        with contextlib.suppress(OSError, OutputError):
            safe_write(out / MARKER, manifest_text(VERSION, OUTPUT_FILES, digests=digests_of(
                out, OUTPUT_FILES[1:])), "report marker", root=out)
    except catch() as exc:
        print_err(f"hammerstein evaluate: error: {' '.join(str(exc).split())}")
        return 1
    for line in rate_notes:
        print_err(f"note: {line}")
    if args.drive is None and args.fade_in is None:     # after success: an error is one line
        print_err("note: no --drive: the metrics start after --settle-periods only; a drive "
                  "of compensate or learn starts with a fade-in that is no tracking, left out "
                  "when the drive is given (--drive DRIVE.csv)")
    summary = next((f"{row['value']:.4g} {row['unit']}" for row in rows
                    if row["metric"] == "max_euclidean_error"), "")
    print(f"wrote {out}/ (max Euclidean error {summary}, delay {delay} samples = "
          f"{delay * T * 1e6:.4g} µs{', removed' if args.remove_delay and delay > 0 else ', not removed'})",
          file=sys.stdout)
    if delay < 0:
        print_err(f"note: {leading_words(delay, T)}")
    return 0


def leading_words(delay, sampling_period):
    """What a negative delay (the measurement ahead of its reference) means, in words.

    Parameters
    ----------
    delay : int
        :func:`~hammerstein.compensation.ilc.estimate_delay` [samples], < 0.
    sampling_period : float
        [s].

    Returns
    -------
    str
        One line without the ``note:`` prefix.

    Examples
    --------
    >>> leading_words(-4, 5e-5)[:64]
    'the measurement is ahead of its reference by 4 samples (200 µs):'
    """
    return (f"the measurement is ahead of its reference by {-delay} samples "
            f"({-delay * sampling_period * 1e6:.4g} µs): no actuator answers before it is "
            f"driven, so this is the shape of the error (a drive whose phase leads, as a "
            f"compensator's model of slower dynamics gives) or a record started after its "
            f"drive, not a delay")


def _model_gains(plant, u, y, T, delay, fade, period_samples, reference=None):
    """Each measured output's gain against ``--model``'s prediction of the drive, or None,
    and the lag of a measurement started before the drive, or None.

    None without the drive's voltages, or when the model's sampling period is
    not the measurement's. The prediction is the model from rest (its
    amplifier's limits applied, as ``compensate --predicted``); the gains are
    :func:`~hammerstein.cli._learn_checks.model_gains` after the fade-in and
    one period, below four times the higher of the reference's fundamental and its
    spectral centroid and below 0.6 times the first mode; None when the reference
    is faster than that (:func:`~hammerstein.cli._learn_checks.gain_band`). The lag
    is :func:`~hammerstein.cli._learn_checks.start_lag`'s beyond the delay search
    (a pre-trigger: 0.2 s of rest before a drive read as "the actuator has changed").
    """
    if u is None or plant.hysteresis.n_inputs != u.shape[0] \
            or not np.isclose(plant.sampling_period, T, rtol=1e-9):
        return None, None
    N = min(u.shape[1], y.shape[1])
    predicted, _ = plant.simulate(apply_amplifier(plant.amplifier, u[:, :N], T),
                                  plant.rest_state())
    P = int(period_samples or 0)
    offset = None if reference is None else start_lag(
        predicted, y[:, :N], delay_search_span(reference, P or None, T))
    start = int(fade) + P
    if N - start - abs(int(delay)) < 8:
        return None, offset
    band = gain_band(P, reference, plant_first_mode(plant))
    return (None if band == 0.0 else model_gains(predicted, y[:, :N], int(delay), start, band),
            offset)


def _drive_length(path, sampling_period=None, table=None):
    """The samples and sampling period of the drive file ``path`` (read bounded).

    Parameters
    ----------
    path : str
        The drive file (compensate, learn), read at its own period.
    sampling_period : float, optional
        ``--sampling-period`` [s]: must be the drive's (the measurement is read at it).
    table : hammerstein.io.datafiles._Table, optional
        The drive file already parsed
        (:func:`hammerstein.compensation.drive_files.read_table`): not read again.

    Returns
    -------
    n_samples : int
    period : float
        The drive's sampling period [s].

    Raises
    ------
    DataFileError
        Unreadable drive, or ``sampling_period`` not the drive's.
    """
    t, _, Td = read_signals(path, [], "t", None, None, "--drive", table=table)
    if sampling_period is not None and not np.isclose(Td, sampling_period, rtol=1e-6):
        raise DataFileError(f"--sampling-period: {sampling_period:g} s; expected the drive's "
                            f"{Td:g} s (with --drive the measurement is read at the drive's "
                            f"period, averaged over each period when faster by an integer "
                            f"factor; leave --sampling-period out)")
    return t.size, Td


def _drive_notes(args):
    """The drive file's fade-in and shaping, as report lines (empty without ``--drive``)."""
    if not args.drive:
        return ""
    head = _drive_header(args.drive)
    keep = [h for h in head if h.startswith("shaped:") or "fade-in" in h]
    return "".join(f"  \ndrive `{args.drive}`: {h}" for h in keep)


def _shaped_reference(path, outs, T, table=None):
    """The drive file's shaped reference ``<output>_shaped`` [µm], shape (p, n), or None.

    ``compensate`` writes these columns when it shaped the reference to the
    amplifier's range and slew and the identified first mode; a drive without
    them followed the reference as given. ``table``: the drive file already
    parsed (:func:`hammerstein.compensation.drive_files.read_table`), or None
    to read it.
    """
    return optional_columns(path, [f"{o}_shaped" for o in outs], T, "--drive", table)


def _tracked_reference(drive, outs, reference, fade, shaped=None):
    """The reference the drive followed (p, n) [µm]: what the figure and the time series show.

    A drive file's shaped reference (``<output>_shaped``, fade-in included) when it
    has one; else, for a drive that faded in (``fade`` > 0), the reference faded in
    as compensate and learn fade it (:func:`hammerstein.compensation.drive.hardware_fade`,
    from the rest output and with the rest lead its header records); else the
    reference as given (no drive: how it was faded in is not known). The metrics
    use the reference as given, after the fade-in, where the two agree.
    """
    n = reference.shape[1]
    if shaped is not None and shaped.shape[1] >= n:
        return shaped[:, :n]
    if not drive or not fade:
        return reference
    return hardware_fade(reference, fade, drive_rest_output(drive, outs), drive_rest_lead(drive))


def _figure_title(args, outs):
    """Title of trajectory-measured.png: what was measured against which reference, on what."""
    actuator = args.model
    if actuator is None and args.drive:
        for line in _drive_header(args.drive):
            words = line.split()
            if "actuator" in words[:-1]:
                actuator = words[words.index("actuator") + 1].rstrip(",")
                break
    reference = " ".join(args.reference.split()) if args.reference.lstrip().startswith("{") \
        else Path(args.reference).name
    drive = f", drive {Path(args.drive).name}" if args.drive else ""
    return (f"measured response ({', '.join(outs)}) of actuator "
            f"{actuator if actuator else '(not named: no --model or --drive)'} to the reference "
            f"{reference}{drive}")


def _drive_header(path):
    """The comment lines that open a drive file, without their '#'."""
    return [line[1:].strip() for line in head_lines(path, 40) if line.startswith("#")]


def _shaped_table(rows):
    """Report lines for the metrics against the shaped reference (empty without one)."""
    if not rows:
        return ""
    table = "\n".join(f"| {row['channel']} | {row['metric']} | {_value(row['value'])} | "
                      f"{row['unit']} |" for row in rows)
    return ("\nAgainst the shaped reference the drive follows (the drive file's "
            "`<output>_shaped` columns; metrics.csv case `shaped`):\n\n"
            "| channel | metric | value | unit |\n|---|---|---|---|\n" + table + "\n")


def _report_dir_problem(out):
    """Why the marked directory ``out`` is not evaluate's to write into (one line), or None.

    Its marker's manifest must list evaluate's own files only (another command's report,
    ``run``'s, would have its manifest replaced by evaluate's and its files left unlisted),
    and the directory must hold nothing its manifest does not list (your notes: a later
    ``run`` into it deleted them, the bare marker evaluate wrote listing nothing).
    """
    listed = report_manifest(out)
    if listed is not None and not listed <= set(OUTPUT_FILES):
        other = sorted(listed - set(OUTPUT_FILES))
        return (f"--out: {out} holds another command's report ({', '.join(other[:3])}"
                f"{' ...' if len(other) > 3 else ''} in its {MARKER}); choose an empty or new "
                f"directory")
    extra = unlisted_entries(out) if listed is not None else \
        sorted(p.name for p in out.iterdir() if p.name not in OUTPUT_FILES)
    if extra:
        return (f"--out: {out} holds {len(extra)} file(s) evaluate did not write "
                f"({', '.join(extra[:3])}{' ...' if len(extra) > 3 else ''}); move them away "
                f"or choose an empty or new directory")
    return None


def _write(out, args, rows, delay, T, r, y, outs, u, ins, ref, shaped_rows=(), fade=0,
           units=("V", "µm")):
    make_directory(out, "--out")
    # the marker lists evaluate's files (its manifest): a later `run` into this directory then
    # replaces nothing else (your notes beside the report)
    safe_write(out / MARKER, manifest_text(VERSION, OUTPUT_FILES), "report marker", root=out)
    lines = ["case,channel,metric,value,unit"] + [
        f"measured,{row['channel']},{row['metric']},{row['value']!r},{row['unit']}" for row in rows] + [
        f"shaped,{row['channel']},{row['metric']},{row['value']!r},{row['unit']}"
        for row in shaped_rows]
    safe_write(out / "metrics.csv", "\n".join(lines) + "\n", "metrics file", root=out)
    n = y.shape[1]
    t = np.arange(n) * T
    cols = [t] + [r[i] for i in range(len(outs))] + [y[i] for i in range(len(outs))]
    tag_in, tag_out = (unit.replace("µ", "u") for unit in units)     # x_um, x_nm, ux_mV
    head = ["time_s"] + [f"{o}_ref_{tag_out}" for o in outs] + [f"{o}_{tag_out}" for o in outs]
    if u is not None:
        cols += [u[i, :n] for i in range(len(ins))]
        head += [f"{i}_{tag_in}" for i in ins]
    safe_write(out / "timeseries-measured.csv", lambda fh: write_rows(fh, head, cols),
               "time series file", root=out)
    figure = ""
    if len(outs) >= 1:             # the XY of the first two outputs, every output against time
        fig = trajectory_figure(t, r, y, outs, _figure_title(args, outs), args.settle_periods *
                                ref.period_samples * T, inputs=None if u is None else u[:, :n],
                                input_names=ins if u is not None else None, fade_time=fade * T,
                                units=units)
        safe_write(out / "trajectory-measured.png", lambda fh: save(fig, fh), "figure", root=out)
        figure = "\n![trajectory](trajectory-measured.png)\n"
    table = "\n".join(f"| {row['channel']} | {row['metric']} | {_value(row['value'])} | "
                      f"{row['unit']} |" for row in rows)
    start = int(round(args.settle_periods * ref.period_samples))
    if args.remove_delay and delay > 0:
        delay_words = "removed before the metrics"
    elif args.remove_delay:
        delay_words = "not removed (--remove-delay removes a positive one only)"
    else:
        delay_words = ("not removed: the metrics include it (`--remove-delay` gives the "
                       "delay-free figures, as `hammerstein learn` judges its trials)")
    defs = definitions_lines(
        [row["metric"] for row in list(rows) + list(shaped_rows)],
        {m: [str(ref.kind)] for m in ("max_euclidean_error_percent",)},
        settle=(f"Settled window: the metrics skip the first {_settling(args, ref)} of the "
                f"record (the "
                f"fade-in of the drive, when known, counted in them), counted from its first "
                f"sample: from sample {start}, t = {start * T:.4g} s, to the end. The tracking "
                f"error is e = y_r − y per output; the Euclidean error ‖Y_r − Y‖ takes all "
                f"outputs together."), units=units)
    text = (f"# {markdown_text(_heading(args, ref, units[1]))}\n\nreference: `{args.reference}`  \n"
            f"measured: `{args.measured}`"
            f"  \nsampling period {T:g} s, {n} samples, settling {_settling(args, ref)}"
            f"{_drive_notes(args)}"
            f"\n\nDelay of the measurement behind the reference (cross-correlation): {delay} "
            f"samples = {delay * T * 1e6:.4g} µs, {delay_words}"
            f"{'; ' + leading_words(delay, T) if delay < 0 else ''}.\n\n"
            + "\n".join(defs) +
            f"{figure}\n| channel | metric | value | unit |\n|---|---|---|---|\n{table}\n"
            f"{_shaped_table(shaped_rows)}")
    safe_write(out / "report.md", text, "report", root=out)


def write_rows(fh, head, cols):
    """Write a CSV table, ``%.9g`` per value, :data:`CSV_CHUNK_ROWS` rows at a time.

    A block's rows are formatted and written before the next block is: the
    memory stays a block's (20 000 rows), where the whole table's text and a
    Python float per value had cost 1.2 GB for 3e6 samples of 8 columns. The
    bytes are those of one ``%``-format per row joined by ``"\\n"``.

    Parameters
    ----------
    fh : binary file object
        Where the UTF-8 text goes.
    head : list of str
        Column names, shape (n_columns,).
    cols : list of numpy.ndarray
        Columns, each shape (n_rows,), in the order of ``head`` (s, µm, V).
    """
    fh.write((",".join(head) + "\n").encode("utf-8"))
    row = ",".join(["%.9g"] * len(cols)) + "\n"
    n = cols[0].shape[0]
    for start in range(0, n, CSV_CHUNK_ROWS):
        block = np.column_stack([c[start:start + CSV_CHUNK_ROWS] for c in cols])
        fh.write(((row * block.shape[0]) % tuple(block.ravel().tolist())).encode("utf-8"))


def _settling(args, ref):
    """``--settle-periods`` in words: periods of a periodic reference, else samples (a
    reference without a period settles for ``--settle-periods`` samples)."""
    n = args.settle_periods
    unit = "period" if ref.period_samples > 1 else "sample"
    return f"{n:g} {unit}{'' if n == 1 else 's'}"


def _value(v):
    """A metric value as ``hammerstein run``'s report writes it (4 significant digits)."""
    return f"{v:.4g}"


def _actuator(args):
    """The actuator the drive was computed for: ``--model``, else the drive file's header."""
    if getattr(args, "model", None):
        return Path(str(args.model)).name
    if getattr(args, "drive", None):
        for line in head_lines(args.drive, 40):
            m = re.match(r"#\s*actuator\s+([^,]+),", line)
            if m:
                return m.group(1).strip()
    return None


def _heading(args, ref, unit="µm"):
    """``Measured response of <actuator> to <the reference in words>`` (its lengths in ``unit``)."""
    spec = getattr(ref, "spec", None)
    what = (signal_summary("reference", spec, unit) if isinstance(spec, dict)
            else f"the reference in {Path(str(args.reference)).name}")
    actuator = _actuator(args)
    return f"Measured response of {actuator} to: {what}" if actuator else \
        f"Measured response to: {what}"
