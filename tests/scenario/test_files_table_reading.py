"""A ``records = "files"`` table reads records as ``hammerstein identify`` reads them.

``identify`` takes records without a time column (``--sampling-period``),
after an instrument's preamble (``--skip-rows``), in other units
(``--input-unit``, ``--output-unit``) and explicit thresholds
(``--thresholds r1,r2,...``); the files table had none of them, so that such
records could not be identified by a scenario, and validate's hints named the
command's options or the ``inputs``/``outputs`` keys. The same records with
the same options must give the same model as ``identify``, to 1e-9.
"""

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.exceptions import NestedInvalid
from hammerstein.io.presets import load_plant
from hammerstein.scenario.identification import excitation_records, identified_from_records
from hammerstein.scenario.identify_tables import identify_table
from route_files import toml_numbers

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
PREAMBLE = "Instrument: DAQ-9000\nOperator: lab\nRate: 20 kHz\n"
#: Explicit thresholds [mV] (identify --thresholds in the input unit).
THRESHOLDS = [0.0, 1000.0, 2500.0, 4000.0, 6000.0, 8000.0, 10000.0]


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The hysteresis records of realistic-gpi written as a lab's files: a three-line
    preamble, no time column, a units row under the header, inputs in mV, outputs in nm."""
    plant = load_plant(SCENARIOS / "presets" / "realistic-gpi.toml")
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    d = tmp_path_factory.mktemp("lab")
    names = []
    for i, r in enumerate(recs["hysteresis"]):
        data = np.column_stack([1e3 * r.u.T, 1e3 * r.y.T])          # V -> mV, µm -> nm
        rows = "".join(",".join(repr(float(v)) for v in row) + "\n" for row in data)
        (d / f"lab-{i}.csv").write_text(PREAMBLE + "ux,uy,x,y\nmV,mV,nm,nm\n" + rows)
        names.append(f"lab-{i}.csv")
    return d, plant, names, float(recs["hysteresis"][0].sampling_period)


def test_a_scenario_identifies_a_labs_records_as_identify_does(measured, capsys):
    d, plant, names, T = measured
    out = d / "cli.toml"
    assert main(["identify", *[str(d / n) for n in names], "--inputs", "ux,uy", "--outputs",
                 "x,y", "--sampling-period", repr(T), "--skip-rows", "3", "--input-unit", "mV",
                 "--output-unit", "nm", "--model", "classical", "--thresholds",
                 ",".join(repr(r) for r in THRESHOLDS), "--out", str(out), "--force"]) == 0
    capsys.readouterr()
    cli = tomllib.loads(out.read_text(encoding="utf-8"))
    # the thresholds given are the model's: the comparison below is not of two defaults
    assert cli["model"]["thresholds"] == THRESHOLDS
    table = {"records": "files", "hysteresis_records": names, "model": "classical",
             "sampling_period": T, "skip_rows": 3, "input_unit": "mV", "output_unit": "nm",
             "thresholds": THRESHOLDS}
    found = identified_from_records(plant, table, False, base_dir=d)
    scen = tomllib.loads(found.preset_text)
    a, b = np.array(toml_numbers(cli["model"])), np.array(toml_numbers(scen["model"]))
    assert a.shape == b.shape and a.size > 0
    assert np.max(np.abs(a - b)) <= 1e-9 * max(np.max(np.abs(a)), 1.0)
    # the model file carries the records' units, as identify writes them
    assert (scen["model"]["input_unit"], scen["model"]["output_unit"]) == ("mV", "nm")
    for key in ("partition", "held_out", "train_rms", "validation_rms"):
        assert scen["identification"][key] == cli["identification"][key], key


@pytest.mark.parametrize("argv, table", [
    (["--thresholds", "0,1.5,3,6"], {"thresholds": [0, 1.5, 3, 6]}),
    (["--thresholds", "0,2", "--partition", "input"], {"thresholds": [0, 2], "partition": "input"}),
    (["--output-unit", "nm"], {"output_unit": "nm"}),
    (["--input-unit", "mV", "--output-unit", "nm", "--thresholds", "7"],
     {"input_unit": "mV", "output_unit": "nm", "n_hysterons": 7}),
])
def test_a_files_table_gives_the_pipeline_identify_s_thresholds_and_units(argv, table):
    from hammerstein.cli.identify import _options, _parse_thresholds
    from hammerstein.cli.main import build_parser
    from hammerstein.scenario.records_route import _pipeline_options
    args = build_parser().parse_args(["identify", "r.csv", "--inputs", "ux", "--outputs", "x",
                                      "--time", "t", "--out", "/nonexistent/m.toml", *argv])
    n, thresholds = _parse_thresholds(args.thresholds)
    cli = replace(_options(args, n, thresholds), name="m")
    spec = identify_table({"records": "files", "hysteresis_records": ["r.csv"], **table})
    ours = _pipeline_options(spec, "m")
    if cli.thresholds is None:
        assert ours == cli
    else:
        np.testing.assert_array_equal(ours.thresholds, cli.thresholds)
        assert replace(ours, thresholds=None) == replace(cli, thresholds=None)


def test_the_reading_keys_take_identify_s_defaults():
    from hammerstein.scenario.identify_tables import record_time
    spec = identify_table({"records": "files", "hysteresis_records": ["r.csv"]})
    assert (spec["skip_rows"], spec["input_unit"], spec["output_unit"]) == (0, "V", "µm")
    assert "thresholds" not in spec and "sampling_period" not in spec
    assert record_time(spec) == "t"
    # a sampling period alone: no time column; with a time column both (checked together)
    assert record_time({**spec, "sampling_period": 1e-4}) is None
    assert record_time({**spec, "sampling_period": 1e-4, "time": "t"}) == "t"


def test_bad_reading_keys_are_named_all_at_once():
    with pytest.raises(NestedInvalid) as info:
        identify_table({"records": "files", "hysteresis_records": ["r.csv"],
                        "sampling_period": 0, "skip_rows": -1, "input_unit": " ",
                        "output_unit": 3, "thresholds": [1.0, 0.5], "n_hysterons": 4})
    found = dict(info.value.problems)
    assert sorted(found) == ["input_unit", "output_unit", "sampling_period", "skip_rows",
                             "thresholds"], found
    assert "expected a number > 0" in found["sampling_period"] and "[s]" in found["sampling_period"]
    assert "expected an integer >= 0" in found["skip_rows"]
    assert "expected a unit name" in found["input_unit"]
    assert "increasing thresholds >= 0" in found["thresholds"]
    # a count and a list: identify's --thresholds takes one of them
    with pytest.raises(NestedInvalid, match="thresholds: give n_hysterons .* or thresholds"):
        identify_table({"records": "files", "hysteresis_records": ["r.csv"],
                        "thresholds": [0.0, 1.0], "n_hysterons": 4})


def _scenario(path, keys):
    path.write_text('[plant]\npreset = "realistic-2dof"\n[compensator]\nkind = "hammerstein"\n'
                    'model = "identified"\ndynamics = "identified"\n'
                    f'identify = {{ records = "files", {keys}hysteresis_records = ["r.csv"] }}\n'
                    '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                    'frequency = 20.0, periods = 3 }\n')
    return path


@pytest.mark.parametrize("head, keys, key, words", [
    ("ux,uy,x,y\n", "", "time",
     "no time column named 't'; available columns: 0:ux, 1:uy, 2:x, 3:y (identify.time is 't' "
     "unless given; records without a time column: identify.sampling_period [s])"),
    (PREAMBLE + "t,ux,uy,x,y\n", "", "skip_rows",
     "(a preamble before the table? skip it with identify.skip_rows = 3"),
    ("t,ux,uy,x,y\ns,V,V,nm,nm\n", "", "output_unit",
     "the units row says 'nm', and outputs are read in µm: convert the column to µm, or "
     "declare it: identify.output_unit = 'nm'"),
    ("t,ux,uy,x,y\ns,mV,mV,µm,µm\n", "", "input_unit", "or declare it: identify.input_unit = 'mV'"),
])
def test_validate_names_a_reading_problem_at_the_key_that_fixes_it(tmp_path, head, keys, key,
                                                                   words):
    """validate named a preamble's, a unit's and a missing time column's problem at
    identify.inputs, .outputs or .time, with the command's --skip-rows or nothing to give;
    the table's key now fixes it, and with it the file validates."""
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    timed = not head.startswith("ux")
    rows = "".join((f"{k * 1e-4:.4f}," if timed else "") + f"{k % 7},{-(k % 5)},{2 * (k % 7)},"
                   f"{-2 * (k % 5)}\n" for k in range(40))
    (tmp_path / "r.csv").write_text(head + rows)
    with pytest.raises(ScenarioError) as err:
        validate_scenario(_scenario(tmp_path / "s.toml", keys))
    lines = [ln for ln in str(err.value).splitlines() if "compensator.identify." in ln]
    assert lines and all(f"compensator.identify.{key}: r.csv: " in ln for ln in lines), lines
    assert words in lines[0], lines
    assert len(lines) == (2 if key.endswith("_unit") else 1), lines     # the preamble once
    fix = {"time": "sampling_period = 1e-4, ", "skip_rows": "skip_rows = 3, ",
           "output_unit": 'output_unit = "nm", ', "input_unit": 'input_unit = "mV", '}[key]
    validate_scenario(_scenario(tmp_path / "s.toml", fix))
