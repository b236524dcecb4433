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
an overlay figure and ``report.md``. Validation dispatches here through
:data:`hammerstein.scenario.validate.VALIDATORS`, the runner through
:data:`hammerstein.runner.SCENARIO_KINDS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hammerstein.core.datafiles import DataFileError, Record, bundled_data, read_record
from hammerstein.core.identification import IdentificationError
from hammerstein.core.record_identification import identify_record
from hammerstein.scenario.schema import (MAX_HYSTERONS, NAME, name_field, Field, Invalid, ScenarioError, check_table, choice, integer,
                                         number, string)

__all__ = [
    "DATA_FIELDS",
    "IDENTIFICATION_FIELDS",
    "RecordScenario",
    "RecordResult",
    "resolve_data_path",
    "load_identification_scenario",
    "run_identification_scenario",
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
    "name": Field(name_field()),
    "title": Field(string(max_length=200)),
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
    "n_hysterons": Field(integer(1, MAX_HYSTERONS), default=15),
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
