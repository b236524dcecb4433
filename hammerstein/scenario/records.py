"""Identification scenarios on measured records (``kind = "identification"``).

A scenario file of this kind has no plant: it identifies a classical PI
model from a measured single-input single-output record, trains on the
first part of the record (the start-up / virgin curve only warms up the play
states, :func:`hammerstein.core.record_identification.identify_record`), validates on the
held-out rest and writes a report directory like the simulated scenarios::

    kind = "identification"
    name = "real-data-piezo-stack"
    [data]
    file = "bundled:piezo-stack-150V-1Hz.csv"   # or a path relative to the scenario file
    input = 2        # column [V]: 0-based index or header name
    output = 1       # column [µm]
    time = 0         # column [s]; or sampling_period = 2e-4
    [identification]
    method = "least-squares"   # or "closed-form"
    n_hysterons = 15           # or thresholds = [r_1, ..., r_n] [V]
    partition = "time"         # or "input"
    bounds = "none"            # least squares: "nonnegative" or "monotone"
    train_fraction = 0.6       # first 60 % of the samples train, the rest validates

The report holds ``metrics.csv`` (cases ``train`` and ``validation``;
metrics ``rms_error`` [µm], ``rms_error_percent`` [% of the measured output
range of the window], ``max_abs_error`` [µm], ``output_range`` [µm]),
``timeseries-<case>.csv``, the model file ``models/identified-<method>.toml``,
an overlay figure and ``report.md``. The runner dispatches here through
:data:`hammerstein.runner.SCENARIO_KINDS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.report import figures as plots
from hammerstein.core.datafiles import DataFileError, Record, bundled_data, read_record
from hammerstein.core.hysteresis import MultivariablePI
from hammerstein.core.identification import IdentificationError
from hammerstein.core.record_identification import identify_record
from hammerstein.core.presets import save_model
from hammerstein.scenario.schema import (NAME, Field, Invalid, ScenarioError, check_table, choice, integer,
                        number, string)

__all__ = [
    "DATA_FIELDS",
    "IDENTIFICATION_FIELDS",
    "RecordScenario",
    "RecordResult",
    "resolve_data_path",
    "load_identification_scenario",
    "run_identification_scenario",
    "write_identification_report",
]


def _column(v):
    if isinstance(v, bool) or not isinstance(v, (int, str)) or (isinstance(v, int) and v < 0):
        raise Invalid(f"expected a 0-based column index or a header name, found {v!r}")
    return v


def _thresholds(v):
    if (isinstance(v, list) and v and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                           and a >= 0 for a in v)
            and all(b > a for a, b in zip(v, v[1:]))):
        return [float(a) for a in v]
    raise Invalid(f"expected increasing thresholds >= 0 [V], found {v!r}")


def _fraction(v):
    if isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < 1:
        return float(v)
    raise Invalid(f"expected a fraction in (0, 1) (the rest is held out), found {v!r}")


TOP = {
    "kind": Field(choice("identification"), required=True),
    "name": Field(string(NAME, "a name of letters, digits, '.', '_' or '-'")),
    "title": Field(string()),
    "description": Field(string()),
    "seed": Field(integer(0), default=0),
    "data": Field(lambda v: v, required=True),
    "identification": Field(lambda v: v),
}
#: Schema of the ``[data]`` table.
DATA_FIELDS = {
    "file": Field(string(), required=True),
    "input": Field(_column, required=True),
    "output": Field(_column, required=True),
    "time": Field(_column),
    "sampling_period": Field(number("s", 0)),
    "input_name": Field(string(NAME, "a name")),
    "output_name": Field(string(NAME, "a name")),
}
#: Schema of the ``[identification]`` table.
IDENTIFICATION_FIELDS = {
    "method": Field(choice("closed-form", "least-squares"), default="least-squares"),
    "n_hysterons": Field(integer(1), default=15),
    "thresholds": Field(_thresholds),
    "partition": Field(choice("time", "input"), default="time"),
    "bounds": Field(choice("none", "nonnegative", "monotone"), default="none"),
    "train_fraction": Field(_fraction, default=0.6),
    "skip": Field(number("s", 0, exclusive=False)),
}


@dataclass
class RecordScenario:
    """A validated identification scenario.

    Attributes
    ----------
    name, title, description : str
    seed : int
    path : pathlib.Path
    data : dict
        Validated ``[data]`` table.
    identification : dict
        Validated ``[identification]`` table (defaults filled).
    record : hammerstein.datafiles.Record
    cases : list of str
        ``["train", "validation"]``.
    kind : str
        ``"identification"`` (the runner's dispatch key).
    """

    name: str
    title: str
    description: str
    seed: int
    path: Path
    data: dict
    identification: dict
    record: Record
    cases: list = field(default_factory=lambda: ["train", "validation"])
    kind: str = "identification"


@dataclass
class RecordResult:
    """One window (train or validation) of an identification scenario.

    Attributes
    ----------
    name : str
        ``"train"`` or ``"validation"``.
    window : slice
        Samples of the evaluation window.
    metrics : list of dict
        Rows ``{channel, metric, value, unit}``.
    model_output : numpy.ndarray, shape (n_samples,)
        Model output + offset over the whole record [µm].
    identifier : ClosedFormPI or LeastSquaresPI
        Fitted (the same object in both results).
    """

    name: str
    window: slice
    metrics: list
    model_output: np.ndarray
    identifier: object


def resolve_data_path(text, base_dir):
    """Path of a data file named in a scenario.

    Parameters
    ----------
    text : str
        ``"bundled:<name>"`` (a file shipped in ``hammerstein/data``, so the
        scenario works from an installed package), an absolute path, or a
        path relative to ``base_dir``.
    base_dir : pathlib.Path
        Directory of the scenario file.

    Returns
    -------
    pathlib.Path
    """
    if text.startswith("bundled:"):
        return bundled_data(text[len("bundled:"):])
    path = Path(text)
    return path if path.is_absolute() else Path(base_dir) / path


def load_identification_scenario(path, data):
    """Validate an identification scenario and read its record.

    Parameters
    ----------
    path : pathlib.Path
        Scenario file.
    data : dict
        Its parsed TOML.

    Returns
    -------
    RecordScenario

    Raises
    ------
    ScenarioError
        Listing every problem (unknown keys with hints, bad values, an
        unreadable data file or column).
    """
    path, source, problems = Path(path), str(path), []
    top = check_table(data, TOP, "", problems, source) or {}
    dat = check_table(data.get("data"), DATA_FIELDS, "data", problems, source) \
        if "data" in data else None
    ident = check_table(data.get("identification", {}), IDENTIFICATION_FIELDS, "identification",
                        problems, source) or {}
    if ident.get("bounds", "none") != "none" and ident.get("method") == "closed-form":
        problems.append(f"{source}: identification.bounds: only used by method = 'least-squares'")
    record = None
    if dat is not None and not problems:
        if "time" not in dat and "sampling_period" not in dat:
            problems.append(f"{source}: data: give time (a column) or sampling_period [s]")
        else:
            try:
                record = read_record(resolve_data_path(dat["file"], path.parent), dat["input"],
                                     dat["output"], dat.get("time"), dat.get("sampling_period"))
            except DataFileError as exc:
                problems.append(f"{source}: data.file: {exc}")
    if problems:
        raise ScenarioError(problems)
    return RecordScenario(name=top.get("name", path.stem), title=top.get("title", path.stem),
                          description=top.get("description", ""), seed=top.get("seed", 0),
                          path=path, data=dat, identification=ident, record=record)


def _rows(channel, rep):
    return [{"channel": channel, "metric": "rms_error", "value": rep["rms_um"], "unit": "µm"},
            {"channel": channel, "metric": "rms_error_percent",
             "value": rep["rms_percent_of_range"], "unit": "%"},
            {"channel": channel, "metric": "max_abs_error", "value": rep["max_abs_um"], "unit": "µm"},
            {"channel": channel, "metric": "output_range", "value": rep["output_range_um"],
             "unit": "µm"}]


def _names(scenario):
    rec = scenario.record
    u = scenario.data.get("input_name") or ("u" if rec.input_name.startswith("column ")
                                             else rec.input_name)
    y = scenario.data.get("output_name") or ("y" if rec.output_name.startswith("column ")
                                              else rec.output_name)
    return u, (y if y != u else y + "_out")


def run_identification_scenario(scenario):
    """Identify on the training samples and validate on the held-out rest.

    Parameters
    ----------
    scenario : RecordScenario

    Returns
    -------
    list of RecordResult
        ``train`` (after the virgin curve / burn-in) and ``validation``.

    Raises
    ------
    IdentificationError
        If the training samples cannot be identified (reported by the runner
        as a failed scenario).
    """
    spec, rec = scenario.identification, scenario.record
    thresholds = spec.get("thresholds")
    ident, train, val = identify_record(
        rec, spec["method"], spec["n_hysterons"], None if thresholds is None else np.asarray(thresholds),
        spec["partition"], None if spec["bounds"] == "none" else spec["bounds"],
        spec["train_fraction"], spec.get("skip"))
    if val is None:
        raise IdentificationError("identification.train_fraction: no held-out samples left")
    pred, _ = ident.model_.simulate(rec.u)
    pred = pred + ident.offset_
    n_train = int(round(spec["train_fraction"] * rec.n_samples))
    start = n_train - train["n_samples"]
    _, yname = _names(scenario)
    return [RecordResult("train", slice(start, n_train), _rows(yname, train), pred, ident),
            RecordResult("validation", slice(n_train, rec.n_samples), _rows(yname, val), pred, ident)]


def write_identification_report(scenario, results, directory):
    """Write metrics.csv, the time series, the model file, the figure and report.md.

    Parameters
    ----------
    scenario : RecordScenario
    results : list of RecordResult
        From :func:`run_identification_scenario`.
    directory : pathlib.Path
        Existing (temporary) report directory.
    """
    from hammerstein.report.model_figures import record_fit_figure
    from hammerstein.report.scenario import markdown_table, metrics_frame
    directory = Path(directory)
    rec, spec = scenario.record, scenario.identification
    uname, yname = _names(scenario)
    ident = results[0].identifier
    frame = metrics_frame(results)
    frame.to_csv(directory / "metrics.csv", index=False)
    for r in results:
        w = r.window
        pd.DataFrame({"time_s": rec.timepts[w], f"{uname}_V": rec.u[w], f"{yname}_um": rec.y[w],
                      f"{yname}_model_um": r.model_output[w]}).to_csv(
            directory / f"timeseries-{r.name}.csv", index=False, float_format="%.7g")
    model = MultivariablePI([[ident.model_]], [uname], [yname], [ident.amplitude_])
    model_file = f"models/identified-{spec['method']}.toml"
    val = {row["metric"]: row["value"] for row in results[1].metrics}
    save_model(model, directory / model_file, {
        "method": spec["method"], "source": str(scenario.data["file"]),
        "n_hysterons": int(ident.thresholds_.size),
        "partition": "explicit" if "thresholds" in spec else spec["partition"],
        "bounds": spec["bounds"], "train_fraction": spec["train_fraction"],
        "sampling_period_s": rec.sampling_period, "amplitude_V": ident.amplitude_,
        "offset_um": ident.offset_, "validation_rms_um": val["rms_error"],
        "validation_rms_percent_of_range": val["rms_error_percent"]})
    split = rec.timepts[results[1].window.start]
    fig = record_fit_figure(rec.timepts, rec.u, rec.y, results[0].model_output,
                            results[0].window.start, results[1].window.start,
                            f"{uname} [V]", f"{yname} [µm]",
                            f"{scenario.title}: measured vs identified PI model")
    plots.save(fig, directory / "record-fit.png")
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description.strip(), ""]
    lines += [f"Scenario `{scenario.path}` (name `{scenario.name}`, kind identification).", "",
              f"Record `{rec.source}`: {rec.n_samples} samples, T = {rec.sampling_period:.6g} s, "
              f"input `{rec.input_name}` [V] -> output `{rec.output_name}` [µm].", "",
              f"Identification: {spec['method']}, {ident.thresholds_.size} hysterons (thresholds "
              f"{ident.thresholds_[0]:.4g} to {ident.thresholds_[-1]:.4g} V), partition "
              f"{'explicit' if 'thresholds' in spec else spec['partition']}, bounds {spec['bounds']}, "
              f"output offset {ident.offset_:.4g} µm. Trained on samples "
              f"{results[0].window.start}..{results[0].window.stop - 1} (the start-up / virgin "
              f"curve before them only warms up the play states); validated on the held-out "
              f"samples from t = {split:.4g} s on. Model file: [`{model_file}`]({model_file}).", "",
              "## Figures", "", "### Measured vs model", "",
              "![Measured vs model](record-fit.png)", "",
              "## Metrics", "", "RMS error in µm and in % of the measured output range "
              "(peak to peak) of each window.", "", markdown_table(frame), ""]
    (directory / "report.md").write_text("\n".join(lines), encoding="utf-8")
