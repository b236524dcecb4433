"""Identification scenarios on measured records (``kind = "identification"``).

A scenario file of this kind has no plant: it identifies a (multivariable)
hysteresis model (``model``: the classical PI by default, or a Preisach,
generalised-PI or automatically chosen class as ``identify --model`` fits it,
:func:`hammerstein.identification.identification_pipeline.identify_hysteresis`)
from measured records with the options of
``hammerstein identify`` (:func:`hammerstein.identification.record_identification.identify_records`:
split at reversal points, the last complete branches or periods held out,
partition and component structure chosen automatically unless given) and
writes a report directory like the simulated scenarios::

    kind = "identification"
    name = "real-data-piezo-stack"
    [data]
    file = "bundled:piezo-stack-150V-1Hz.csv"   # or files = [...]; paths relative to the scenario
    input = 2        # column(s): 0-based index, header name, or a list (inputs = [...])
    output = 1       # column(s) (outputs = [...])
    time = 0         # column [s]; or sampling_period = 2e-4
    input_unit = "V"
    output_unit = "µm"
    [identification]
    method = "least-squares"   # or "closed-form"
    n_hysterons = 15           # or thresholds = [r_1, ..., r_n]
    partition = "auto"         # "time" or "input"; auto keeps the smaller held-out error
    bounds = "none"            # least squares: "nonnegative" or "monotone"
    components = "auto"        # "all", or "OUT:IN=pi|gain|none,..."
    hold_out = "auto"          # or "none"; train_fraction = 0.6 splits at the nearest reversal
    output_map = "auto"        # "none" (classical PI) or "deadzone" (modified PI, always)
    model = "classical"        # or "preisach", "generalized", "auto" (preisach_levels,
                               # threshold_spacing, level_weighting, record_start as identify's)

The report holds ``metrics.csv`` (cases ``train`` and ``validation``;
per output channel ``rms_error``, ``rms_error_percent`` [% of the measured
output range of the window], ``max_abs_error``, ``output_range``),
``timeseries-<case>.csv`` (first record), the model file
``models/identified-<method>.toml``, an overlay figure and ``report.md``. The
runner dispatches here through :data:`hammerstein.runner.SCENARIO_KINDS`.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hammerstein.io.datafiles import DataFileError, bundled_data, read_records
from hammerstein.io.unit_checks import unit_warnings
from hammerstein.exceptions import HammersteinWarning
from hammerstein.core.files import confined_path, escape
from hammerstein.identification.defaults import PREISACH_LEVELS
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification.identification_pipeline import PipelineOptions, identify_hysteresis
from hammerstein.identification.preisach_identification import refit_on_every_level
from hammerstein.identification.record_identification import KINDS as COMPONENT_KINDS
from hammerstein.identification.record_identification import identify_records, parse_components
from hammerstein.scenario.identify_tables import preisach_smoothing
from hammerstein.scenario.schema import (MAX_HYSTERONS, NAME, Field, Invalid, ScenarioError, check_table,
                                         choice, integer, name_field,
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


def _columns(v):
    if isinstance(v, list) and v:
        return [_column(c) for c in v]
    return [_column(v)]


def _files(v):
    if isinstance(v, list) and v and all(isinstance(f, str) and f for f in v):
        return list(v)
    raise Invalid(f"expected a non-empty list of file names, found {v!r}")


def _names_list(v):
    if isinstance(v, str):
        v = [v]
    if isinstance(v, list) and v and all(isinstance(n, str) and re.fullmatch(NAME, n) for n in v):
        return list(v)
    raise Invalid(f"expected a name or a list of names (letters, digits, '.', '_', '-'), found {v!r}")


def _components(v):
    if isinstance(v, str) and v.strip():
        if v.strip() in ("auto", "all"):
            return v
        for part in (p.strip() for p in v.split(",") if p.strip()):
            key, sep, kind = part.partition("=")
            if not sep or len(key.split(":")) != 2 or kind.strip() not in COMPONENT_KINDS:
                raise Invalid(f"expected 'auto', 'all' or OUTPUT:INPUT=pi|gain|none entries "
                              f"separated by commas, found {v!r} (entry {part!r})")
        return v
    raise Invalid(f"expected 'auto', 'all' or 'OUT:IN=pi|gain|none,...', found {v!r}")


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
    "file": Field(string()),
    "files": Field(_files),
    "input": Field(_columns),
    "inputs": Field(_columns),
    "output": Field(_columns),
    "outputs": Field(_columns),
    "time": Field(_column),
    "sampling_period": Field(number("s", 0)),
    "input_name": Field(_names_list),
    "output_name": Field(_names_list),
    "input_names": Field(_names_list),
    "output_names": Field(_names_list),
    "input_unit": Field(string(), default="V"),
    "output_unit": Field(string(), default="µm"),
}
#: Schema of the ``[identification]`` table.
IDENTIFICATION_FIELDS = {
    "method": Field(choice("closed-form", "least-squares"), default="least-squares"),
    "n_hysterons": Field(integer(1, MAX_HYSTERONS), default=15),
    "thresholds": Field(_thresholds),
    "partition": Field(choice("auto", "time", "input"), default="auto"),
    "bounds": Field(choice("none", "nonnegative", "monotone"), default="none"),
    "components": Field(_components, default="auto"),
    "hold_out": Field(choice("auto", "none"), default="auto"),
    "output_map": Field(choice("auto", "none", "deadzone"), default="auto"),
    "train_fraction": Field(_fraction),
    "skip": Field(number("s", 0, exclusive=False)),
    # the model class, as identify --model (default: the classical PI this kind always fitted)
    "model": Field(choice("classical", "auto", "preisach", "generalized"), default="classical"),
    "preisach_levels": Field(integer(2, 60), default=PREISACH_LEVELS),
    "preisach_smoothing": Field(preisach_smoothing, default="auto"),
    "threshold_spacing": Field(choice("uniform", "power", "auto"), default="uniform"),
    "level_weighting": Field(choice("amplitude", "none"), default="amplitude"),
    "record_start": Field(choice("demagnetised", "rest"), default="demagnetised"),
}


@dataclass
class RecordScenario:
    """A validated identification scenario.

    Parameters
    ----------
    name, title, description : str
    seed : int
    path : pathlib.Path
    data : dict
        Validated ``[data]`` table.
    identification : dict
        Validated ``[identification]`` table (defaults filled; no ``n_hysterons`` beside
        ``thresholds``: the list's length is the count).
    records : list of hammerstein.io.datafiles.MultiRecord
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
    records: list
    cases: list = field(default_factory=lambda: ["train", "validation"])
    kind: str = "identification"


@dataclass
class RecordResult:
    """One window (train or validation) of an identification scenario.

    Parameters
    ----------
    name : str
        ``"train"`` or ``"validation"``.
    metrics : list of dict
        Rows ``{channel, metric, value, unit}``, one set per output.
    fit : hammerstein.identification.record_identification.RecordFit
        The identification (the same object in both results): model,
        splits (training and held-out samples of each record), predictions.
    """

    name: str
    metrics: list
    fit: object


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

    Raises
    ------
    DataFileError
        ``bundled:`` with a directory in the name, or a path outside the
        scenario's directory (:func:`hammerstein.core.files.confined_path`:
        ``HAMMERSTEIN_ALLOW_PATHS`` allows more), a NUL character or a path
        too long.
    """
    if text.startswith("bundled:"):
        name = text[len("bundled:"):]
        if not name or Path(name).name != name or name in (".", "..") or "\\" in name:
            raise DataFileError(f"{escape(text)}: expected bundled:<file name> of a file "
                                f"shipped with hammerstein (no directory)")
        return bundled_data(name)
    return confined_path(text, base_dir, DataFileError)


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
    model = ident.get("model", "classical")
    if model in ("preisach", "generalized") and ident.get("method") == "closed-form":
        problems.append(f"{source}: identification.method: model = {model!r} is fitted by "
                        f"least squares; expected 'least-squares' (the default)")
    if model != "classical" and "thresholds" in ident:
        problems.append(f"{source}: identification.thresholds: only used by model = "
                        f"'classical', found model = {model!r}")
    # a count written beside a thresholds list (15 too, the default's value) was ignored
    # without a word: refused as identify's one --thresholds option and the files tables do
    # (hammerstein.scenario.identify_tables); a validated table with a list holds no count
    # (the list's length is it), so that validating it again finds none
    written = data.get("identification")
    if "thresholds" in ident and isinstance(written, dict) and "n_hysterons" in written:
        problems.append(f"{source}: identification.thresholds: give n_hysterons (a count) or "
                        f"thresholds (a list), not both (identify --thresholds takes one of them)")
    if "thresholds" in ident:
        ident.pop("n_hysterons", None)
    if ident.get("output_map") == "deadzone" and ident.get("method") == "closed-form":
        problems.append(f"{source}: identification.output_map: deadzone only with method = "
                        f"'least-squares'")
    if ident.get("train_fraction") is not None and ident.get("hold_out") == "none":
        # identify refuses it (exit 2); here the fraction was used and hold_out ignored
        problems.append(f"{source}: identification.train_fraction: give train_fraction or "
                        f"hold_out = 'none', not both")
    records = []
    if dat is not None:
        files = dat.get("files", [dat["file"]] if "file" in dat else [])
        ins = dat.get("inputs", dat.get("input"))
        outs = dat.get("outputs", dat.get("output"))
        for key, alias, val in (("file", "files", files), ("input", "inputs", ins),
                                ("output", "outputs", outs)):
            if key in dat and alias in dat:
                problems.append(f"{source}: data.{alias}: give {key} or {alias}, not both")
            elif not val and alias not in data.get("data", {}) and key not in data.get("data", {}):
                problems.append(f"{source}: data.{key}: missing (required); or data.{alias} "
                                f"as a list")
        if "time" not in dat and "sampling_period" not in dat:
            problems.append(f"{source}: data: give time (a column) or sampling_period [s]")
        if not problems:
            for f in files:
                try:
                    records.append(read_records(resolve_data_path(f, path.parent), ins, outs,
                                                dat.get("time"), dat.get("sampling_period")))
                except DataFileError as exc:
                    problems.append(f"{source}: data.{'files' if 'files' in dat else 'file'}: "
                                    f"{exc}")
    if problems:
        raise ScenarioError(problems)
    scenario = RecordScenario(name=top.get("name", path.stem), title=top.get("title", path.stem),
                              description=top.get("description", ""), seed=top.get("seed", 0),
                              path=path, data=dat, identification=ident, records=records)
    if records and "components" in ident:     # the names it gives are the records' channels
        ins, outs = _names(scenario)
        try:
            parse_components(ident["components"], ins, outs)
        except IdentificationError as exc:
            raise ScenarioError([f"{source}: identification.{exc}"]) from None
    return scenario


def _rows(channel, rep, unit):
    return [{"channel": channel, "metric": "rms_error", "value": rep["rms"], "unit": unit},
            {"channel": channel, "metric": "rms_error_percent", "value": rep["rms_percent"],
             "unit": "%"},
            {"channel": channel, "metric": "max_abs_error", "value": rep["max_abs"], "unit": unit},
            {"channel": channel, "metric": "output_range", "value": rep["range"], "unit": unit}]


def _names(scenario):
    """Model input and output names: given, or the column names (u/y for headerless files)."""
    rec = scenario.records[0]
    dat = scenario.data
    ins = dat.get("input_names", dat.get("input_name"))
    outs = dat.get("output_names", dat.get("output_name"))
    if ins is None:
        ins = [n if not n.startswith("column ") else f"u{i}" for i, n in enumerate(rec.input_names)]
        ins = ["u"] if ins == ["u0"] else ins
    if outs is None:
        outs = [n if not n.startswith("column ") else f"y{i}" for i, n in enumerate(rec.output_names)]
        outs = ["y"] if outs == ["y0"] else outs
    return list(ins), list(outs)


def run_identification_scenario(scenario):
    """Identify on the training periods and validate on the held-out ones.

    Parameters
    ----------
    scenario : RecordScenario

    Returns
    -------
    list of RecordResult
        ``train`` and ``validation``.

    Raises
    ------
    IdentificationError
        If the records cannot be identified or nothing is held out (reported
        by the runner as a failed scenario).
    """
    spec = scenario.identification
    ins, outs = _names(scenario)
    rec = scenario.records[0]
    # identify's unit checks (a time column in ms read as s, an output in nm read as µm)
    for line in unit_warnings(scenario.records, outs, scenario.data["output_unit"],
                              scenario.data.get("time"), ins, scenario.data.get("input_unit", "V")):
        warnings.warn(f"data: {line}".replace("--sampling-period S", "data.sampling_period"),
                      HammersteinWarning, stacklevel=2)
    if len(ins) != rec.u.shape[0] or len(outs) != rec.y.shape[0]:
        raise IdentificationError(
            f"data.input_names/output_names: expected {rec.u.shape[0]} input and "
            f"{rec.y.shape[0]} output names, found {ins} and {outs}")
    if spec.get("model", "classical") != "classical":
        fit = identify_hysteresis(scenario.records, PipelineOptions(
            method=spec["method"], n=spec["n_hysterons"], partition=spec["partition"],
            bounds=spec["bounds"], components=spec["components"], model=spec["model"],
            threshold_spacing=spec["threshold_spacing"], level_weighting=spec["level_weighting"],
            record_start=spec["record_start"], preisach_levels=spec["preisach_levels"],
            preisach_smoothing=spec["preisach_smoothing"], hold_out=spec["hold_out"],
            output_map=spec["output_map"], train_fraction=spec.get("train_fraction"),
            skip=spec.get("skip"), output_unit=scenario.data["output_unit"]), (ins, outs))
        # as identify writes it: a Preisach model refitted on every level (its held-out
        # errors stay those of the held-out fit; the fit's notes say so)
        return _results(refit_on_every_level(fit, spec["preisach_levels"]), scenario)
    thresholds = spec.get("thresholds")
    partition = spec["partition"]
    if thresholds is not None and partition == "auto":
        partition = "time"
    fit = identify_records(     # a thresholds list is the count (no n_hysterons beside it)
        scenario.records, spec["method"],
        spec["n_hysterons"] if thresholds is None else len(thresholds),
        None if thresholds is None else np.asarray(thresholds), partition, spec["bounds"],
        spec["components"], spec["hold_out"], spec.get("train_fraction"), spec.get("skip"),
        ins, outs, output_map=spec.get("output_map", "auto"))
    return _results(fit, scenario)


def _results(fit, scenario):
    """The ``train`` and ``validation`` results of a fit (a validation part required)."""
    if fit.validation is None:
        raise IdentificationError("identification.hold_out: nothing held out; the report "
                                  "needs a validation part (hold_out = 'auto')")
    unit = scenario.data["output_unit"]
    return [RecordResult(case, [row for name, rep in zip(fit.model.output_names, reps)
                                for row in _rows(name, rep, unit)], fit)
            for case, reps in (("train", fit.train), ("validation", fit.validation))]
