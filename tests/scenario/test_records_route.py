"""Scenario route = command-line route: ``identify = { records = "excitation", ... }``.

A scenario that identifies from the records of ``hammerstein excitation`` with
the options of ``hammerstein identify`` must reach what a user reaches with
the commands: the same preset (model, dynamics and creep tables) and the
same drive, to 1e-9. The records the scenario plays through its plant are
written to CSV files at full precision and given to ``identify``; its preset
goes to ``compensate``; the scenario's compensator computes the drive of the
same reference.
"""

import itertools
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from hammerstein.cli._hardware import load_actuator, load_reference
from hammerstein.cli.main import main
from hammerstein.compensation.drive import apply_amplifier, hardware_drive, rest_output
from hammerstein.compensation.shaping import first_mode_hz, mode_decay_s
from hammerstein.io.presets import load_plant
from hammerstein.scenario.identification import (ResolveContext, excitation_records,
                                                 identified_from_records)
from hammerstein.scenario.identify_tables import identify_table
from hammerstein.scenario.registry import build_compensator
from route_files import toml_numbers, write_record

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
CIRCLE = '{ kind = "circle", radius = 12, frequency = 40, periods = 4 }'



def test_identify_table_with_records_takes_identify_defaults():
    spec = identify_table({"records": "excitation"})
    assert spec["model"] == "auto" and spec["method"] == "least-squares"
    assert spec["n_hysterons"] == 15 and spec["partition"] == "auto" and spec["creep"] is False
    with pytest.raises(Exception, match="model"):
        identify_table({"records": "excitation", "model": "chebyshev"})


@pytest.mark.parametrize("key, default, other, bad", [
    ("level_weighting", "amplitude", "none", "relative"),
    ("record_start", "demagnetised", "rest", "cold")])
def test_pipeline_keys_as_the_identify_options(key, default, other, bad):
    """``level_weighting`` and ``record_start`` are ``identify --level-weighting`` and
    ``--record-start``: the same default, the same choices, and they reach the pipeline's
    options."""
    from hammerstein.scenario.records_route import _pipeline_options
    assert identify_table({"records": "excitation"})[key] == default
    spec = identify_table({"records": "excitation", key: other})
    assert getattr(_pipeline_options(spec, "m"), key) == other
    with pytest.raises(Exception, match=key):
        identify_table({"records": "excitation", key: bad})


@pytest.mark.parametrize("value, expected", [
    (None, []), ([], []), ("standard", [0.8, 0.6, 0.4, 0.2, 0.0, -0.2, -0.4, -0.6, -0.8]),
    ([0.5, -0.25], [0.5, -0.25])])
def test_reversals_key_as_the_excitation_option(value, expected):
    """``reversals`` is ``excitation --reversals``: absent or [] none, "standard" its points."""
    table = {"records": "excitation"} | ({} if value is None else {"reversals": value})
    assert identify_table(table)["reversals"] == expected


@pytest.mark.parametrize("value", [[1.0], [0.5, 0.5], "all", [True], 0.5])
def test_bad_reversals_name_the_key(value):
    with pytest.raises(Exception, match="reversals: expected .*fractions in \\(-1, 1\\)"):
        identify_table({"records": "excitation", "reversals": value})


@pytest.mark.parametrize("table, key, message", [
    ({"model": "preisach", "method": "closed-form"}, "method", "fitted by least squares"),
    ({"model": "generalized", "method": "closed-form"}, "method", "fitted by least squares"),
    ({"output_map": "deadzone", "method": "closed-form"}, "output_map", "only used by method"),
    ({"creep_refits": 1}, "creep_refits", "only used with creep = true"),
    ({"components": "bogus"}, "components", "OUTPUT:INPUT=pi|gain|none entries"),
    ({"components": "x:ux=maybe"}, "components", "OUTPUT:INPUT=pi|gain|none entries"),
    ({"amplitude": 10.0, "range": [-10.0, 10.0]}, "amplitude", "not both")])
def test_what_identify_refuses_the_table_refuses_when_validated(table, key, message):
    """Every combination here is a usage error of ``hammerstein identify`` (exit 2); a
    scenario's table accepted them, then ignored the first four without a word or failed
    at run time in the command's words. All are now named by their key when the file is
    validated, every problem at once."""
    from hammerstein.exceptions import NestedInvalid
    with pytest.raises(NestedInvalid) as info:
        identify_table({"records": "excitation", **table})
    assert [k for k, _ in info.value.problems] == [key]
    assert message in info.value.problems[0][1]
    assert identify_table({"records": "excitation", "creep": True, "creep_refits": 1})
    assert identify_table({"records": "excitation", "components": "x:uy=none, y:ux=gain"})
    with pytest.raises(NestedInvalid, match="only used with creep_records"):
        identify_table({"records": "files", "hysteresis_records": ["a.csv"], "creep_refits": 2})


def test_an_amplitude_per_input_of_another_plant_is_named():
    """Three amplitudes for a 2-input plant gave numpy's broadcasting message."""
    from hammerstein.exceptions import IdentificationError
    with pytest.raises(IdentificationError, match=r"identify.amplitude: expected 1 or 2 values "
                                                  r"\(one per input of the plant\), found 3"):
        excitation_records(load_plant("rakotondrabe-2dof"),
                           identify_table({"records": "excitation", "amplitude": [10.0, 8.0, 5.0]}))


def test_range_and_slew_rate_keys_play_the_commands_records(tmp_path, capsys):
    """``range`` and ``slew_rate`` are ``excitation --range`` and ``--slew-rate``: the
    scenario plays the very inputs the command writes (a unipolar 0-20 V amplifier here)."""
    plant = load_plant("rakotondrabe-2dof")
    T = plant.sampling_period
    spec = identify_table({"records": "excitation", "range": [0.0, 20.0], "slew_rate": 2e4,
                           "frequency": 5.0, "hold": 0.25, "multisine_periods": 2})
    recs = excitation_records(plant, spec)
    out = tmp_path / "exc"
    assert main(["excitation", "--inputs", ",".join(plant.hysteresis.input_names), "--range",
                 "0,20", "--slew-rate", "2e4", "--sampling-period", repr(T), "--out", str(out),
                 "--sine-frequency", "5", "--hold", "0.25", "--periods", "2"]) == 0
    capsys.readouterr()
    for kind, files in (("hysteresis", ["hysteresis"]), ("creep", ["creep"])):
        for rec, name in zip(recs[kind], plant.hysteresis.input_names):
            data = np.loadtxt(out / f"{files[0]}-{name}.csv", delimiter=",", skiprows=1)
            np.testing.assert_allclose(rec.u, data[:, 1:].T, atol=1e-6, rtol=1e-8)
            assert rec.u.min() >= 0.0 and rec.u.max() <= 20.0 + 1e-9
    with pytest.raises(Exception, match="range: expected \\[low, high\\]"):
        identify_table({"records": "excitation", "range": [20.0, 0.0]})


def _assert_same_drive(tmp_path, preset, plant, identify):
    """compensate's drive of CIRCLE on ``preset`` equals, to 1e-9, the scenario compensator's
    hardware drive (faded in from rest over a duration, kept in the records' amplifier range
    and slew: the preset's [amplifier], source = "records")."""
    drive = tmp_path / "d.csv"
    assert main(["compensate", str(preset), "--reference", CIRCLE, "--kind", "hammerstein",
                 "--out", str(drive)]) == 0
    lines = [ln for ln in drive.read_text().splitlines() if not ln.startswith("#")]
    u_cli = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])[:, 1:3].T
    comp = build_compensator({"kind": "hammerstein", "model": "identified", "identify": identify,
                              "dynamics": "identified"}, plant, ResolveContext(tmp_path))
    actuator = load_actuator(str(preset))
    ref = load_reference(CIRCLE, actuator)
    T = plant.sampling_period
    at_rest = actuator.rest_state()
    linear = actuator.matrices
    # the drive pipeline compensate runs (hardware_route.compensate_reference): faded in,
    # shaped into the records' limits, the start-up bounded by the settled drive's steps
    res = hardware_drive(comp, ref.signal, T, ref.period_samples, None,
                         actuator.amplifier, "error",
                         rest=rest_output(actuator.hysteresis, actuator.creep),
                         first_mode=first_mode_hz(linear[0], T),
                         predict=lambda u: actuator.simulate(
                             apply_amplifier(actuator.amplifier, u, T), at_rest)[0],
                         names=actuator.hysteresis.output_names,
                         mode_decay=mode_decay_s(linear[0], T),
                         input_names=list(actuator.hysteresis.input_names))
    assert u_cli.shape == res.inputs.shape
    assert np.max(np.abs(u_cli - res.inputs)) <= 1e-9 * np.max(np.abs(u_cli))


@pytest.mark.slow
def test_scenario_and_commands_write_the_same_preset_and_drive(tmp_path, capsys):
    plant = load_plant(SCENARIOS / "presets" / "realistic-gpi.toml")
    identify = {"records": "excitation", "model": "generalized", "creep": True,
                "frequency": 5.0, "hold": 0.25, "multisine_periods": 2}
    spec = identify_table(identify)
    recs = excitation_records(plant, spec)
    files = {kind: [write_record(tmp_path / f"{kind}-{i}.csv", r) for i, r in enumerate(rs)]
             for kind, rs in recs.items()}
    preset = tmp_path / "id.toml"
    T = repr(plant.sampling_period)
    assert main(["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
                 "--sampling-period", T, "--model", "generalized", "--dynamics",
                 "--dynamics-records", *files["dynamics"], "--creep-records", *files["creep"],
                 "--out", str(preset)]) == 0
    capsys.readouterr()
    cli = tomllib.loads(preset.read_text(encoding="utf-8"))
    assert cli["identification"].get("measurement_delay_samples", 0) == 0   # no acquisition delay

    found = identified_from_records(plant, identify, True)
    scen = tomllib.loads(found.preset_text)
    # the amplifier too: the drives of a scenario stay within what the records spanned, as
    # compensate's (before, this route wrote none and its drives could leave the range)
    assert scen["amplifier"]["source"] == "records"
    for table in ("model", "dynamics", "creep", "amplifier"):
        a, b = np.array(toml_numbers(cli[table])), np.array(toml_numbers(scen[table]))
        assert a.shape == b.shape and a.size > 0
        assert np.max(np.abs(a - b)) <= 1e-9 * max(np.max(np.abs(a)), 1.0), table

    _assert_same_drive(tmp_path, preset, plant, identify)


def test_the_report_says_what_a_records_table_asked_for():
    """report.md and the figure titles named a records route "model identified at 1 Hz (15
    hysterons, least-squares)", the words of the classical route, while auto kept another
    class from the excitation records."""
    from hammerstein.report.compensator_words import _model_summary
    from hammerstein.report.scenario import compensator_summary
    spec = identify_table({"records": "excitation", "creep": True, "range": [0.0, 10.0],
                           "slew_rate": 2000.0})
    table = {"kind": "hammerstein", "model": "identified", "identify": spec}
    for text in (compensator_summary(table), _model_summary(table)):
        assert "identified from the excitation records (model auto, with creep, range [0, 10] V, " \
               "slew rate 2000 V/s)" in text and "least-squares" not in text and "hysterons" not in text


@pytest.mark.slow
def test_the_report_names_an_identified_preisach_model_by_its_class(tmp_path):
    """A new user's identified Preisach model was saved as ``hammerstein-1-pi.toml`` and the
    report called it "PI": the file and the report now carry its class."""
    path = tmp_path / "classes.toml"
    path.write_text(f'''
name = "classes"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[compensator]
kind = "hammerstein"
model = "identified"
dynamics = "identified"
identify = {{ records = "excitation", model = "preisach" }}
[[cases]]
name = "c"
reference = {CIRCLE}
''')
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    out = tmp_path / "out" / "classes"
    saved = sorted(p.name for p in (out / "models").glob("hammerstein-1-*.toml"))
    assert saved == ["hammerstein-1-dynamics.toml", "hammerstein-1-preisach.toml"]
    assert "Preisach model [`models/hammerstein-1-preisach.toml`]" in (out / "report.md").read_text()


@pytest.mark.slow
def test_a_scenario_identifies_from_measured_files_as_identify_does(tmp_path, capsys):
    # the user's own records (here the excitation records of realistic-gpi written to files):
    # `identify = { records = "files", ... }` must give identify's preset (model, dynamics,
    # creep, the records' amplifier limits) and compensate's drive; before, a scenario could
    # only identify from records it played through its own simulated plant
    plant = load_plant(SCENARIOS / "presets" / "realistic-gpi.toml")
    spec = identify_table({"records": "excitation", "model": "generalized", "creep": True,
                           "frequency": 5.0, "hold": 0.25, "multisine_periods": 2})
    recs = excitation_records(plant, spec)
    names = {kind: [write_record(tmp_path / f"{kind}-{i}.csv", r) for i, r in enumerate(rs)]
             for kind, rs in recs.items()}
    preset = tmp_path / "id.toml"
    assert main(["identify", *names["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
                 "--time", "t", "--model", "generalized", "--dynamics", "--dynamics-records",
                 *names["dynamics"], "--creep-records", *names["creep"], "--out",
                 str(preset)]) == 0
    capsys.readouterr()
    cli = tomllib.loads(preset.read_text(encoding="utf-8"))
    identify = {"records": "files", "model": "generalized",
                "hysteresis_records": [Path(f).name for f in names["hysteresis"]],
                "dynamics_records": [Path(f).name for f in names["dynamics"]],
                "creep_records": [Path(f).name for f in names["creep"]]}
    # dynamics False: what a rate-independent kind's table asks for. An outside check: its
    # creep was then fitted without G and its amplifier's slew taken from the hysteresis
    # records alone (125.7 V/s against 3.46e5 V/s), another preset than identify's
    for with_g in (False, True):
        found = identified_from_records(plant, identify, with_g, base_dir=tmp_path)
        scen = tomllib.loads(found.preset_text)
        for table in ("model", "dynamics", "creep", "amplifier"):
            a, b = np.array(toml_numbers(cli[table])), np.array(toml_numbers(scen[table]))
            assert a.shape == b.shape and a.size > 0, (with_g, table)
            assert np.max(np.abs(a - b)) <= 1e-9 * max(np.max(np.abs(a)), 1.0), (with_g, table)
    assert scen["identification"]["records"].startswith("measured files: ")
    # the fit's record too: its partition, the windows held out and its errors (the report's
    # model file held only the method and the notes)
    keys = ("partition", "partition_scores_percent", "components", "output_map", "held_out",
            "train_rms", "train_rms_percent_of_range", "validation_rms",
            "validation_rms_percent_of_range", "validation_max_abs", "levels")
    for key in keys:
        assert scen["identification"][key] == cli["identification"][key], key
    assert scen["identification"]["input_columns"] == cli["identification"]["input_columns"]
    # the class identified, not "PI identified from records" for every class
    assert cli["preset"]["description"] == scen["preset"]["description"] == (
        "generalised-PI hysteresis identified from records + identified linear dynamics + "
        "identified creep")

    _assert_same_drive(tmp_path, preset, plant, identify)


@pytest.mark.parametrize("table, expect", [
    ({"records": "files"}, "hysteresis_records: missing"),
    ({"records": "files", "hysteresis_records": []}, "hysteresis_records: expected a file name"),
    ({"records": "files", "hysteresis_records": ["a.csv"], "frequency": 5.0},
     "frequency: unknown key"),
    ({"records": "files", "hysteresis_records": ["a.csv"], "delay": -1}, "delay: expected"),
    ({"records": "file", "hysteresis_records": ["a.csv"]}, "records: expected"),
])
def test_a_files_table_names_what_is_wrong(table, expect):
    with pytest.raises(Exception, match=expect):
        identify_table(table)


def test_validate_names_a_record_file_that_is_not_there(tmp_path):
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    (tmp_path / "h.csv").write_text("t,ux,uy,x,y\n")
    f = tmp_path / "s.toml"
    f.write_text('[plant]\npreset = "realistic-2dof"\n[compensator]\nkind = "hammerstein"\n'
                 'model = "identified"\ndynamics = "identified"\nidentify = { records = "files", '
                 'hysteresis_records = ["h.csv"], dynamics_records = ["nope.csv"] }\n'
                 '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                 'frequency = 20.0, periods = 3 }\n')
    with pytest.raises(ScenarioError, match=r"identify\.dynamics_records: nope\.csv: no such file"):
        validate_scenario(f)


def _rows(header, n=20):
    return header + "\n" + "".join(f"{k * 1e-4:.4f},{k},{-k},{2 * k},{-2 * k}\n"
                                   for k in range(n))


def test_validate_names_every_column_the_records_do_not_hold(tmp_path):
    # validate said ok; `run` then stopped on the first file's column, one problem a run,
    # named at the record's key where the table's `inputs` or `time` sets the column
    from hammerstein.scenario import records_route
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    for name in ("h1.csv", "h2.csv", "h3.csv", "h4.csv"):
        (tmp_path / name).write_text(_rows("t,Vx,uy,x,y"))      # no column ux (the plant's)
    (tmp_path / "d.csv").write_text(_rows("time,ux,uy,x,y"))      # no column t
    (tmp_path / "c.csv").write_text(_rows("t,ux,uy,x,y", n=4))    # too short
    scenario = ('[plant]\npreset = "realistic-2dof"\n[compensator]\nkind = "hammerstein"\n'
                'model = "identified"\ndynamics = "identified"\nidentify = { records = "files", '
                'hysteresis_records = ["h1.csv", "h2.csv", "h3.csv", "h4.csv"], '
                'dynamics_records = ["d.csv"], creep_records = ["c.csv"] }\n'
                '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                'frequency = 20.0, periods = 3 }\n')
    f = tmp_path / "s.toml"
    f.write_text(scenario)
    with pytest.raises(ScenarioError) as err:
        validate_scenario(f)
    lines = sorted(line.split(": ", 1)[1] for line in str(err.value).splitlines())
    assert len(lines) == 3, lines
    assert lines[0].startswith("compensator.identify.creep_records: ") and "too short" in lines[0]
    # one line for the four files, at the key that sets the column, with what the files hold
    assert lines[1] == ("compensator.identify.inputs: h1.csv, h2.csv, h3.csv and 1 more records: "
                        "no input column named 'ux'; available columns: 0:t, 1:Vx, 2:uy, 3:x, "
                        "4:y (identify.inputs not given: the plant's input names were read)")
    assert lines[2].startswith("compensator.identify.time: d.csv: no time column named 't'")
    # the words are those of the run's own read, which stops at the first
    with pytest.raises(Exception) as first:
        records_route.file_records(
            validate_scenario.__globals__["load_plant"]("realistic-2dof"),
            {"hysteresis_records": ["h1.csv"], "time": "t", "delay": 0}, tmp_path)
    assert "no input column named 'ux'; available columns: 0:t, 1:Vx, 2:uy, 3:x, 4:y" in str(
        first.value)
    # as many columns as the plant has inputs and outputs: counted before any file is read
    f.write_text(scenario.replace('records = "files", ', 'records = "files", inputs = "Vx", '))
    with pytest.raises(ScenarioError) as err:
        validate_scenario(f)
    assert "compensator.identify.inputs: 1 column(s) ['Vx'] for the plant's 2 inputs ['ux', 'uy']" \
        in str(err.value)
    # ... and the columns named are still looked for beside it: d.csv holds no Vx, and no t
    # (a count that differs from the plant's hid them, one more run each)
    assert sum(": compensator.identify." in ln for ln in str(err.value).splitlines()) == 4
    assert "compensator.identify.inputs: d.csv: no input column named 'Vx'" in str(err.value)
    assert "compensator.identify.time: d.csv: no time column named 't'" in str(err.value)
    # and from Python, where validate did not run (an IndexError in the unit check before)
    with pytest.raises(Exception, match=r"identify\.outputs: 1 column\(s\) \['x'\] for the "
                                        r"plant's 2 outputs"):
        records_route.file_records(
            validate_scenario.__globals__["load_plant"]("realistic-2dof"),
            {"hysteresis_records": ["h1.csv"], "time": "t", "delay": 0, "outputs": ["x"]},
            tmp_path)
    # a column that is not time
    f.write_text(scenario.replace('records = "files", ', 'records = "files", time = "uy", ')
                 .replace('"h1.csv", "h2.csv", "h3.csv", "h4.csv"', '"d.csv"')
                 .replace('creep_records = ["c.csv"]', 'delay = 0'))
    with pytest.raises(ScenarioError, match=r"identify\.time: d\.csv: time column 'uy' is not "
                                            r"increasing at data row 2"):
        validate_scenario(f)
    # the table's own names are the ones checked, and a table that holds them passes
    f.write_text(scenario.replace('records = "files", ', 'records = "files", time = "time", '
                                  'inputs = "ux,uy", ')
                 .replace('"h1.csv", "h2.csv", "h3.csv", "h4.csv"', '"d.csv"')
                 .replace('creep_records = ["c.csv"]', 'delay = 0'))
    validate_scenario(f)


def test_a_misspelt_files_route_has_the_rest_checked_as_a_files_table():
    # records = "file" checked the table as an excitation one: six keys called unknown
    from hammerstein.exceptions import NestedInvalid
    with pytest.raises(NestedInvalid) as err:
        identify_table({"records": "file", "time": "t_s", "inputs": ["a", "b"],
                        "hysteresis_records": ["h.csv"], "creep_records": ["c.csv"],
                        "ordr": 4})
    problems = err.value.problems
    assert [k for k, _ in problems] == ["records", "ordr"], problems
    assert "did you mean 'files'?" in problems[0][1] and "did you mean 'order'?" in problems[1][1]


def test_titles_and_the_report_name_a_files_table_as_such():
    # the figures' titles read "model identified at 0 Hz (least-squares, none)"
    from hammerstein.report.compensator_words import _model_summary
    from hammerstein.report.scenario import compensator_summary
    c = {"kind": "hammerstein", "model": "identified",
         "identify": {"records": "files", "hysteresis_records": ["h1.csv", "h2.csv"],
                      "creep_records": ["c.csv"], "model": "auto"}}
    expect = ("model identified from 3 measured record file(s) (hysteresis, creep; auto class)")
    assert _model_summary(c) == expect
    assert expect in compensator_summary(c)


def test_a_record_beyond_the_size_limit_or_a_fifo_is_named_before_anything_is_read(
        tmp_path, monkeypatch):
    # validate said ok and run read a 3 GiB record whole (52 s, 6.5 GB) for the cache key
    # before the limit refused it
    import os
    from hammerstein.core import files
    from hammerstein.scenario import records_route
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", "1000")
    (tmp_path / "big.csv").write_text("t,ux,uy,x,y\n" + "0,0,0,0,0\n" * 500)   # 5 kB
    os.mkfifo(tmp_path / "pipe.csv")
    f = tmp_path / "s.toml"
    f.write_text('[plant]\npreset = "realistic-2dof"\n[compensator]\nkind = "hammerstein"\n'
                 'model = "identified"\ndynamics = "identified"\nidentify = { records = "files", '
                 'hysteresis_records = ["big.csv"], dynamics_records = ["pipe.csv"] }\n'
                 '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                 'frequency = 20.0, periods = 3 }\n')
    with pytest.raises(ScenarioError) as err:
        validate_scenario(f)
    text = str(err.value)
    assert "identify.hysteresis_records: " in text and "larger than the limit of 1000 bytes" in text
    assert "identify.dynamics_records: " in text and "not a regular file" in text
    # the cache key reads no byte beyond the limit (the read that follows names the problem)
    reads = []
    real = files.bounded_read_bytes
    monkeypatch.setattr(records_route, "bounded_read_bytes",
                        lambda *a, **k: reads.append(a) or real(*a, **k))
    records_route._files_digest({"hysteresis_records": ["big.csv"]}, tmp_path)
    assert reads and reads[0][1] == "data"


@pytest.fixture(scope="module")
def hysteresis_files(tmp_path_factory):
    """The hysteresis records of `hammerstein excitation` on realistic-gpi, written as files."""
    plant = load_plant(SCENARIOS / "presets" / "realistic-gpi.toml")
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    d = tmp_path_factory.mktemp("records")
    (d / "plant.toml").write_text((SCENARIOS / "presets" / "realistic-gpi.toml").read_text())
    return d, [Path(write_record(d / f"h{i}.csv", r)).name for i, r in enumerate(recs["hysteresis"])]


@pytest.mark.slow
@pytest.mark.parametrize("delay, written", [("auto", None), (0, 0), (2, 2)])
def test_a_delay_is_written_only_when_given_or_estimated(hysteresis_files, delay, written):
    """An outside check: a files table without dynamics records wrote
    ``measurement_delay_samples = 0`` where identify writes nothing, so that ``learn --delay
    auto`` took 0 as a known delay instead of estimating one."""
    d, files = hysteresis_files
    plant = load_plant(d / "plant.toml")
    found = identified_from_records(plant, {"records": "files", "model": "classical",
                                            "hysteresis_records": files, "delay": delay},
                                    False, base_dir=d)
    ident = tomllib.loads(found.preset_text)["identification"]
    assert ident.get("measurement_delay_samples") == written


@pytest.mark.slow
@pytest.mark.parametrize("kind, model", [
    *itertools.product(("multivariable", "diagonal", "per-axis", "static-gain"),
                       ("classical", "preisach", "generalized")),
    # the exact inverse of the Preisach and generalised-PI classes (none for a classical PI)
    ("preisach-inverse", "preisach"), ("preisach-inverse", "generalized")])
def test_every_kind_runs_on_a_model_identified_from_files(hysteresis_files, kind, model,
                                                          no_figures):
    """A tester's scenarios: every kind but hammerstein, on a model identified from his
    measured records, simulated every case and then stopped on "unexpected KeyError:
    'frequency'" while naming the model file, and wrote no report; preisach-inverse
    refused the identify table. The report says where the model came from."""
    from hammerstein.runner import run_scenario
    d, files = hysteresis_files
    extra = 'gain = "midpoint"\ncheck = "warn"\n' if kind == "multivariable" else ""
    f = d / f"s-{kind}-{model}.toml"
    f.write_text(f'name = "s"\n[plant]\npreset = "plant.toml"\n'
                 f'dynamics = false\n[compensator]\nkind = "{kind}"\nmodel = "identified"\n{extra}'
                 f'[compensator.identify]\nrecords = "files"\nmodel = "{model}"\n'
                 f'hysteresis_records = {files!r}\n'.replace("'", '"')
                 + '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                   'frequency = 5.0, periods = 3 }\n')
    outcome = run_scenario(f, d / f"out-{kind}-{model}", renderer=no_figures)
    assert outcome.ok, outcome.error
    out = outcome.out_dir
    saved = sorted(p.name for p in (Path(out) / "models").iterdir())
    assert saved == [f"identified-files-{model}.toml"], saved
    report = (Path(out) / "report.md").read_text()
    assert "Identified from the measured record files" in report
    assert "by a sine on each input" not in report


def test_a_shared_identify_table_that_fails_is_named_once_with_every_case_using_it(tmp_path):
    """A top-level [compensator] whose identification fails was reported once per case (three
    times for three cases); one line now names the table's cases, and the run writes nothing."""
    from hammerstein.exceptions import ScenarioError
    from hammerstein.scenario.resolve import load_scenario
    path = tmp_path / "s.toml"
    path.write_text(
        'name = "dup"\n[plant]\npreset = "rakotondrabe-2dof"\n[compensator]\nkind = "hammerstein"\n'
        'model = "identified"\ndynamics = "identified"\n'
        'identify = { records = "excitation", amplitude = [10.0, 8.0, 5.0] }\n'
        + "".join(f'[[cases]]\nname = "c{i}"\nreference = {{ kind = "circle", radius = 5.0, '
                  f'frequency = 20.0, periods = 3 }}\n' for i in range(3)))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    lines = str(info.value).splitlines()
    assert len([ln for ln in lines if "identify.amplitude" in ln]) == 1
    assert "cases[0].compensator, cases[1].compensator, cases[2].compensator: identify.amplitude" \
        in str(info.value)


@pytest.mark.parametrize("argv, table", [
    ([], {}),
    (["--hold-out", "none"], {"hold_out": "none"}),
    (["--train-fraction", "0.7", "--skip", "0.5"], {"train_fraction": 0.7, "skip": 0.5}),
    (["--train-fraction", "1"], {"train_fraction": 1}),
    (["--model", "generalized", "--threshold-spacing", "power", "--max-order", "8"],
     {"model": "generalized", "threshold_spacing": "power", "max_order": 8}),
    (["--method", "closed-form", "--partition", "input", "--thresholds", "9"],
     {"method": "closed-form", "partition": "input", "n_hysterons": 9}),
])
@pytest.mark.parametrize("route", ["excitation", "files"])
def test_a_table_reaches_the_pipeline_with_the_options_identify_gives_it(argv, table, route):
    """The same option on the command line and in an ``identify`` table gives the pipeline
    the same options (name and unit aside). ``hold_out``, ``train_fraction`` and ``skip``
    were options of ``identify`` only: a table could not hold out nothing, split elsewhere,
    or skip a burn-in."""
    from dataclasses import replace
    from hammerstein.cli.identify import _options
    from hammerstein.cli.main import build_parser
    from hammerstein.scenario.records_route import _pipeline_options
    args = build_parser().parse_args([
        "identify", "r.csv", "--inputs", "ux", "--outputs", "x", "--time", "t", "--out", "m.toml",
        *argv])
    n = 9 if "--thresholds" in argv else 15
    cli = replace(_options(args, n, None), name="m", output_unit="µm")
    base = {"records": "excitation"} if route == "excitation" else \
        {"records": "files", "hysteresis_records": ["r.csv"], "dynamics_records": ["d.csv"]}
    assert _pipeline_options(identify_table({**base, **table}), "m") == cli


def test_a_table_refuses_a_training_fraction_with_nothing_held_out():
    from hammerstein.exceptions import NestedInvalid
    with pytest.raises(NestedInvalid, match="train_fraction: give train_fraction or hold_out"):
        identify_table({"records": "excitation", "hold_out": "none", "train_fraction": 0.5})
    with pytest.raises(NestedInvalid, match=r"train_fraction: expected a fraction in \(0, 1\]"):
        identify_table({"records": "files", "hysteresis_records": ["a.csv"], "train_fraction": 0})


@pytest.mark.parametrize("ident, words, file", [
    ({"frequency": 5.0, "model": "preisach", "n_hysterons": 15, "method": "closed-form"},
     "model identified at 5 Hz (preisach class)", "identified-5Hz-preisach.toml"),
    ({"frequency": 5.0, "model": "auto", "n_hysterons": 15, "method": "closed-form"},
     "model identified at 5 Hz (the class auto chose)", "identified-5Hz-auto.toml"),
    ({"frequency": 50.0, "n_hysterons": 15, "method": "least-squares"},
     "model identified at 50 Hz (15 hysterons, least-squares)", "identified-50Hz-least-squares.toml"),
])
def test_the_sine_route_names_the_class_it_identified(ident, words, file):
    """A Preisach model identified on the sine route was called "(15 hysterons, closed-form)"
    and saved as identified-5Hz-closed-form.toml, the words of the classical PI."""
    from hammerstein.report.compensator_words import _identify_summary
    from hammerstein.report.model_files import model_file_name
    assert _identify_summary(ident) == words and model_file_name(ident) == file


@pytest.mark.parametrize("scale, warned", [(1.0, False), (1000.0, True)])
def test_a_files_table_warns_of_an_output_in_another_unit_as_identify_does(
        hysteresis_files, monkeypatch, scale, warned):
    """`identify = { records = "files" }` reads the user's files as `identify` does, with its
    unit check: the same records written in nm (1000 times the µm) are named before
    anything is identified, and the same records in µm are not."""
    from hammerstein.scenario import records_route
    d, files = hysteresis_files
    scaled = []
    for name in files:
        rows = np.loadtxt(d / name, delimiter=",", skiprows=1)
        header = (d / name).read_text().splitlines()[0]
        rows[:, 3:] *= scale                       # t, ux, uy, then the outputs x, y
        np.savetxt(d / f"nm{scale:g}-{name}", rows, delimiter=",", header=header, comments="",
                   fmt="%.17g")
        scaled.append(f"nm{scale:g}-{name}")

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):                     # the fit itself is not what is judged here
        raise Stop
    monkeypatch.setattr(records_route.identification_pipeline, "identify_pipeline", stop)
    plant = load_plant(d / "plant.toml")
    with warnings.catch_warnings(record=True) as caught, pytest.raises(Stop):
        warnings.simplefilter("always")
        records_route.identified_from_records(
            plant, {"records": "files", "hysteresis_records": scaled}, False, base_dir=d)
    said = [str(w.message) for w in caught if "spans" in str(w.message)]
    assert bool(said) == warned, said
    if warned:
        assert said[0].startswith("identify (records = 'files'): output 'x' spans")
