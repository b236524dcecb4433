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
from types import SimpleNamespace

import numpy as np
import pytest

import hammerstein
from hammerstein.cli.main import main
from hammerstein.exceptions import NestedInvalid
from hammerstein.io.presets import load_model, load_plant
from hammerstein.scenario.identification import excitation_records, identified_from_records
from hammerstein.scenario.identify_tables import identify_table
from route_files import run_files_scenario, toml_numbers, write_record

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
    # identify's model is in mV and nm; the scenario's in its plant's V and µm (converted on
    # reading): the same model, its thresholds [mV] a thousand times the scenario's [V] and
    # every prediction [nm] a thousand times the scenario's [µm]
    assert (cli["model"]["input_unit"], cli["model"]["output_unit"]) == ("mV", "nm")
    assert (scen["model"]["input_unit"], scen["model"]["output_unit"]) == ("V", "µm")
    assert scen["identification"]["converted_from_units"] == "mV, nm"
    assert (scen["identification"]["input_unit"], scen["identification"]["output_unit"]) == (
        "V", "µm")                       # the model's, as identify writes them
    np.testing.assert_allclose(1e3 * np.array(scen["model"]["thresholds"]), THRESHOLDS,
                               rtol=1e-12, atol=1e-9)
    mine, theirs = found.plant.hysteresis, load_model(out)
    u = np.vstack([
        12 * np.sin(np.linspace(0, 6 * np.pi, 900)) * np.linspace(0.2, 1, 900),
        9 * np.cos(np.linspace(0, 4 * np.pi, 900))])
    y_v, y_mv = mine.simulate(u)[0], theirs.simulate(1e3 * u)[0]
    assert np.ptp(y_v) > 1.0
    np.testing.assert_allclose(y_v, 1e-3 * y_mv, rtol=0, atol=1e-9 * np.ptp(y_v))
    for key in ("partition", "held_out"):
        assert scen["identification"][key] == cli["identification"][key], key
    for key in ("train_rms", "validation_rms"):                  # [µm] and [nm]
        np.testing.assert_allclose(1e3 * np.array(scen["identification"][key]),
                                   cli["identification"][key], rtol=1e-9)


@pytest.mark.parametrize("argv, table", [
    (["--thresholds", "0,1.5,3,6"], {"thresholds": [0, 1.5, 3, 6]}),
    (["--thresholds", "0,2", "--partition", "input"], {"thresholds": [0, 2], "partition": "input"}),
    (["--output-unit", "nm"], {"output_unit": "nm"}),
    (["--preisach-smoothing", "3e-5"], {"preisach_smoothing": 3e-5}),
    (["--preisach-smoothing", "0", "--model", "preisach"], {"preisach_smoothing": 0,
                                                            "model": "preisach"}),
    (["--preisach-smoothing", "auto"], {"preisach_smoothing": "auto"}),
    (["--input-unit", "mV", "--output-unit", "nm", "--thresholds", "7"],
     {"input_unit": "mV", "output_unit": "nm", "n_hysterons": 7}),
])
def test_a_files_table_gives_the_pipeline_identify_s_thresholds_in_the_plant_s_units(argv, table):
    from hammerstein.cli.identify import _options, _parse_thresholds
    from hammerstein.cli.main import build_parser
    from hammerstein.scenario.records_route import _pipeline_options
    args = build_parser().parse_args(["identify", "r.csv", "--inputs", "ux", "--outputs", "x",
                                      "--time", "t", "--out", "/nonexistent/m.toml", *argv])
    n, thresholds = _parse_thresholds(args.thresholds)
    cli = replace(_options(args, n, thresholds), name="m")
    spec = identify_table({"records": "files", "hysteresis_records": ["r.csv"], **table})
    ours = _pipeline_options(spec, "m")
    # the scenario reads its records in its plant's V and µm: thresholds given in mV are
    # passed in V, and the outputs the pipeline names are in µm
    volts = 1e-3 if table.get("input_unit") == "mV" else 1.0
    assert ours.output_unit == "µm"
    if cli.thresholds is None:
        assert ours == replace(cli, output_unit="µm")
    else:
        np.testing.assert_allclose(ours.thresholds, volts * cli.thresholds, rtol=1e-15)
        assert replace(ours, thresholds=None) == replace(cli, thresholds=None, output_unit="µm")


def test_the_reading_keys_take_identify_s_defaults():
    from hammerstein.scenario.identify_tables import record_time
    from hammerstein.scenario.identify_tables import record_units
    spec = identify_table({"records": "files", "hysteresis_records": ["r.csv"]})
    # the units default to the plant's (V and µm without one)
    assert spec["skip_rows"] == 0 and "input_unit" not in spec and "output_unit" not in spec
    assert record_units(spec) == ("V", "µm")
    plant = type("P", (), {"units": ("mV", "nm")})()
    assert record_units(spec, plant) == ("mV", "nm")
    assert record_units({**spec, "output_unit": "µm"}, plant) == ("mV", "µm")
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
    assert found["output_unit"] == "expected a string, found 3"
    assert "increasing thresholds >= 0" in found["thresholds"]
    # a count and a list: identify's --thresholds takes one of them
    with pytest.raises(NestedInvalid, match="thresholds: give n_hysterons .* or thresholds"):
        identify_table({"records": "files", "hysteresis_records": ["r.csv"],
                        "thresholds": [0.0, 1.0], "n_hysterons": 4})


@pytest.mark.parametrize("plant_units, keys, message", [
    (None, 'output_unit = "counts", ',
     "outputs in 'counts' for a plant whose outputs are in 'µm': expected 'µm' or a unit "
     "converted to it ('um', 'nm', 'mm', 'm')"),
    (("counts", "µm"), 'input_unit = "V", ',
     "inputs in 'V' for a plant whose inputs are in 'counts': expected 'counts' (no other unit "
     "converts to it)"),
    (("counts", "nm"), 'input_unit = "counts", output_unit = "mm", ', None),
])
def test_validate_refuses_record_units_that_do_not_convert_to_the_plant_s(
        tmp_path, plant_units, keys, message):
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    preset = "realistic-2dof"
    if plant_units is not None:       # a plant in other units: a model file identify wrote
        text = (Path(hammerstein.__file__).parent / "presets" / "realistic-2dof.toml").read_text(
            encoding="utf-8")
        assert 'input_unit = "V"\n' in text and 'output_unit = "µm"\n' in text
        (tmp_path / "p.toml").write_text(text.replace(
            'input_unit = "V"\n', f'input_unit = "{plant_units[0]}"\n', 1).replace(
            'output_unit = "µm"\n', f'output_unit = "{plant_units[1]}"\n', 1), encoding="utf-8")
        assert load_plant(tmp_path / "p.toml").units == plant_units
        preset = "p.toml"
    (tmp_path / "r.csv").write_text("t,ux,uy,x,y\n" + "".join(
        f"{k * 1e-4:.4f},{k % 7},{-(k % 5)},{2 * (k % 7)},{-2 * (k % 5)}\n" for k in range(40)))
    path = _scenario(tmp_path / "s.toml", keys).resolve()
    path.write_text(path.read_text().replace('"realistic-2dof"', f'"{preset}"'))
    if message is None:
        validate_scenario(path)
        return
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    lines = [ln for ln in str(err.value).splitlines() if "compensator.identify." in ln]
    assert lines == [f"{path}: compensator.identify.{keys.split(' ')[0]}: {message}"], lines


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


def test_a_scenario_follows_its_circle_alike_from_records_in_mv_and_nm(measured, tmp_path):
    """A scenario's plant takes V and gives µm: a model identified from records in mV and nm
    was used as it was, and a 12 µm circle was followed with a 126 000 % error. Read in the
    plant's units, the scenario follows it as from the same records written in V and µm, its
    thresholds given in each file's unit (a files table with thresholds also failed to run:
    validated twice, its n_hysterons default was taken for a count given beside them)."""
    d, plant, names, T = measured
    errors = {}
    for units, scale in (("mV/nm", 1.0), ("V/µm", 1e-3)):
        # thresholds in the records' input unit, as identify takes them (read in the plant's)
        thresholds = [scale * r for r in THRESHOLDS]
        here = tmp_path / units.replace("/", "-")
        here.mkdir()
        for n in names:
            rows = (d / n).read_text(encoding="utf-8").splitlines()[5:]
            (here / n).write_text("ux,uy,x,y\n" + "".join(",".join(
                repr(scale * float(v)) for v in row.split(",")) + "\n" for row in rows))
        iu, ou = units.split("/")
        report = run_files_scenario(
            here, (SCENARIOS / "presets" / "realistic-gpi.toml").read_text(encoding="utf-8"),
            'kind = "multivariable"\nmodel = "identified"', f"""records = "files"
model = "classical"
sampling_period = {T!r}
input_unit = "{iu}"
output_unit = "{ou}"
thresholds = {thresholds}
hysteresis_records = {names}""", "{ kind = \"circle\", radius = 12, frequency = 10, periods = 4 }")
        rows = (report / "metrics.csv").read_text(encoding="utf-8").splitlines()
        errors[units] = next(float(r.split(",")[3]) for r in rows
                             if r.startswith("c,x+y,max_euclidean_error,"))
    assert errors["V/µm"] < 0.2 * 12                 # a compensated circle, not a failure
    assert errors["mV/nm"] == pytest.approx(errors["V/µm"], rel=1e-6)


@pytest.mark.parametrize("table, key, words", [
    ({"records": "files", "model": "preisach", "thresholds": [0.0, 1.0]}, "thresholds",
     "only used by model = 'classical' or 'auto' (the classical PI's hysterons), found model "
     "= 'preisach' (its grid: preisach_levels)"),
    ({"records": "files", "model": "generalized", "n_hysterons": 9}, "n_hysterons",
     "found model = 'generalized' (its plays: threshold_spacing)"),
    ({"records": "excitation", "model": "preisach", "n_hysterons": 9}, "n_hysterons",
     "only used by model = 'classical' or 'auto'"),
    ({"records": "files", "max_order": 6}, "max_order", "only used with dynamics_records"),
    ({"records": "files", "order": 6}, "order", "only used with dynamics_records"),
])
def test_options_the_chosen_fit_would_ignore_are_named_at_their_key(table, key, words):
    """identify refuses --thresholds with a class that has its own grid, and --order without
    the broadband records; the tables said nothing, or named max_order's problem at order."""
    if table["records"] == "files":
        table = {**table, "hysteresis_records": ["r.csv"]}
    with pytest.raises(NestedInvalid) as info:
        identify_table(table)
    found = dict(info.value.problems)
    assert list(found) == [key] and words in found[key], found


def test_thresholds_stay_allowed_where_the_classical_pi_is_fitted():
    for model in ("classical", "auto"):
        spec = identify_table({"records": "files", "hysteresis_records": ["r.csv"],
                               "model": model, "thresholds": [0.0, 1.0]})
        assert spec["thresholds"] == [0.0, 1.0]


@pytest.mark.parametrize("table", [
    {"records": "excitation", "model": "preisach", "creep": True},
    {"records": "files", "model": "generalized", "hysteresis_records": ["r.csv"]},
    {"records": "files", "thresholds": [0.0, 1.5, 3.0], "hysteresis_records": ["r.csv"]},
    {"records": "excitation", "thresholds": [0.0, 1.5, 3.0]},
])
def test_a_validated_table_validates_again(table):
    """The route validates a table it was given validated (its n_hysterons default filled in):
    that default is no count given with a Preisach or generalised-PI model, nor beside a
    thresholds list (a files table with thresholds failed every scenario run so)."""
    once = identify_table(table)
    if "thresholds" in table:           # the list's length is the count: no count beside it
        assert "n_hysterons" not in once
    else:
        assert once["n_hysterons"] == 15
    assert identify_table(once) == once


def test_the_excitation_records_table_takes_thresholds_as_identify_does():
    from hammerstein.scenario.records_route import _pipeline_options
    spec = identify_table({"records": "excitation", "model": "classical",
                           "thresholds": [0.0, 2.0, 5.0]})
    options = _pipeline_options(spec, "m")
    np.testing.assert_array_equal(options.thresholds, [0.0, 2.0, 5.0])
    assert options.n == 3
    with pytest.raises(NestedInvalid, match="give n_hysterons .* or thresholds"):
        identify_table({"records": "excitation", "thresholds": [0.0, 1.0], "n_hysterons": 4})


def test_records_without_units_are_in_the_plant_s_units(tmp_path):
    """A plant in mV and nm (a model file identify wrote from such records) and records in
    them, the table naming no unit: read as they are, not as V and µm multiplied by 1000
    (the model then erred by 1000 times its outputs, without a word)."""
    text = (Path(hammerstein.__file__).parent / "presets" / "realistic-2dof.toml").read_text(
        encoding="utf-8")
    (tmp_path / "p.toml").write_text(text.replace('input_unit = "V"\n', 'input_unit = "mV"\n', 1)
                                     .replace('output_unit = "µm"\n', 'output_unit = "nm"\n', 1),
                                     encoding="utf-8")
    plant = load_plant(tmp_path / "p.toml", dynamics=False)
    assert plant.units == ("mV", "nm")
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    names = [write_record(tmp_path / f"r-{i}.csv", r) for i, r in enumerate(recs["hysteresis"])]
    base = {"records": "files", "hysteresis_records": names, "model": "classical"}
    bare = identified_from_records(plant, identify_table(base), False, base_dir=tmp_path)
    said = identified_from_records(plant, identify_table({**base, "input_unit": "mV",
                                                          "output_unit": "nm"}),
                                   False, base_dir=tmp_path)
    assert bare.preset_text == said.preset_text
    assert "converted_from_units" not in tomllib.loads(bare.preset_text)["identification"]


def test_a_count_of_15_beside_thresholds_is_refused_as_any_count(tmp_path, capsys):
    """``n_hysterons = 15`` (the default's value) written beside ``thresholds``: refused at the
    key as any other count is, since identify's one ``--thresholds`` takes a count or a list
    (it was ignored without a word); the list alone runs, its length the model's count."""
    text = (Path(hammerstein.__file__).parent / "presets" / "realistic-2dof.toml").read_text(
        encoding="utf-8")
    plant = load_plant(Path(hammerstein.__file__).parent / "presets" / "realistic-2dof.toml",
                       dynamics=False)
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    names = [Path(write_record(tmp_path / f"r-{i}.csv", r)).name
             for i, r in enumerate(recs["hysteresis"])]
    compensator = 'kind = "multivariable"\nmodel = "identified"'
    identify = (f'records = "files"\nhysteresis_records = {names!r}\nmodel = "classical"\n'
                f'thresholds = [0.0, 2.0, 5.0]')
    circle = '{ kind = "circle", radius = 5, frequency = 10, periods = 2 }'
    out = run_files_scenario(tmp_path, text, compensator, identify, circle)
    model = tomllib.loads((out / "models" / "identified-files-classical.toml").read_text(
        encoding="utf-8"))
    assert model["model"]["thresholds"] == [0.0, 2.0, 5.0]
    capsys.readouterr()
    for count in (15, 4):
        scenario = (tmp_path / "s.toml").read_text(encoding="utf-8").replace(
            "thresholds = [", f"n_hysterons = {count}\nthresholds = [")
        (tmp_path / f"s{count}.toml").write_text(scenario, encoding="utf-8")
        for command in ("validate", "run"):
            argv = [command, str(tmp_path / f"s{count}.toml")] + (
                ["--out", str(tmp_path / "out2"), "-q", "--figures", "none"]
                if command == "run" else [])
            assert main(argv) != 0
            err = capsys.readouterr().err
            assert (f"s{count}.toml: compensator.identify.thresholds: give n_hysterons (a count) "
                    f"or thresholds (a list), not both") in err, err


def test_the_unit_warning_of_a_files_table_says_that_a_declared_unit_is_converted(tmp_path):
    """identify converts nothing and says so; a files table converts records in a declared
    unit to its plant's: its warning on outputs in nm read as µm said "nothing is converted"
    too. Followed, its advice (identify.output_unit = "nm") gives the model of the same
    records in µm."""
    preset = Path(hammerstein.__file__).parent / "presets" / "realistic-2dof.toml"
    plant = load_plant(preset, dynamics=False)
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    models, said = {}, {}
    for unit, scale, declared in (("µm", 1.0, ""), ("nm", 1e3, ""),
                                  ("nm", 1e3, 'output_unit = "nm"\n')):
        d = tmp_path / f"{unit}-{bool(declared)}"
        d.mkdir()
        names = [Path(write_record(d / f"r-{i}.csv", SimpleNamespace(
            timepts=r.timepts, u=r.u, y=scale * r.y, input_names=r.input_names,
            output_names=r.output_names))).name for i, r in enumerate(recs["hysteresis"])]
        out = run_files_scenario(
            d, preset.read_text(encoding="utf-8"), 'kind = "multivariable"\nmodel = "identified"',
            f'records = "files"\nhysteresis_records = {names!r}\nmodel = "classical"\n{declared}',
            '{ kind = "circle", radius = 5, frequency = 10, periods = 2 }')
        key = (unit, bool(declared))
        models[key] = tomllib.loads((out / "models" / "identified-files-classical.toml")
                                    .read_text(encoding="utf-8"))["model"]
        said[key] = [line for line in (out / "warnings.csv").read_text(encoding="utf-8")
                     .splitlines() if "a column in nm?" in line]
    assert not said["µm", False] and not said["nm", True]
    assert len(said["nm", False]) == 2, said                 # x and y
    for line in said["nm", False]:
        assert "nothing is converted" not in line
        assert ("Outputs are read in µm: declare the column's unit with identify.output_unit "
                "(the records are then converted to the plant's units)") in line
    np.testing.assert_allclose(toml_numbers(models["nm", True]), toml_numbers(models["µm", False]),
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("bad", ["lots", -1e-5, float("nan"), True])
def test_a_bad_preisach_smoothing_is_named(bad):
    with pytest.raises(NestedInvalid, match="preisach_smoothing: expected auto or a smoothing "
                                            "weight >= 0"):
        identify_table({"records": "files", "hysteresis_records": ["r.csv"],
                        "preisach_smoothing": bad})
