"""`validate` reports every mistake of a scenario file in one run, each once, at its place.

A CI-gate user needed three rounds: a misspelt compensator kind hid the keys of its
``identify`` table, a misspelt sweep metric hid the sweep's cases (one above Nyquist),
a raster's bad keys hid its unknown output, and a missing record file of the top-level
``[compensator.identify]`` was named after the first case that reached it.

An outside tester then found the record files' columns checked one problem at a time: a
column count that differs from the plant's hid every column check, a file kept only its
first missing column, and a misspelt identification ``model`` hid the columns altogether.
"""

import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.scenario.validate import validate_scenario

# realistic-2dof samples at T = 5e-5 s: Nyquist 10 kHz
ALL_MISTAKES = """
name = "bad"
[plant]
preset = "{preset}"
dynamic = true

[compensator]
kind = "hamerstein"
model = "identified"
dynamics = "identified"

[compensator.identify]
records = "files"
hysteresis_record = ["meas/hysteresis-ux.csv", "meas/hysteresis-uy.csv"]
dynamics_records = ["meas/multisine-ux.csv", "meas/missing.csv"]
time = "t"

[[cases]]
name = "circle-15um-10Hz"
reference = {{ kind = "circle", radus = 15.0, frequency = "10", periods = 6 }}
settle_periods = -1
[[cases]]
name = "circle-15um-10Hz"
reference = {{ kind = "circel", radius = 15.0, frequency = 10.0, periods = 6 }}
[[cases]]
name = "raster"
reference = {{ kind = "raster", outputs = ["x", "z"], size = [40.0, 40.0], lines = 1, frequency = 20.0, periods = 3 }}

[[sweeps]]
name = "freq"
frequencies = [10.0, 12000.0]
reference = {{ kind = "circle", radius = 20.0, periods = 10 }}
metric = "max_euclidian_error"
"""

# (where the mistake is written, a word of its message), each expected on exactly one line
EXPECTED = [
    ("plant.dynamic", "unknown key"),
    ("compensator.kind", "'hamerstein'"),
    ("compensator.identify.hysteresis_record", "unknown key"),
    ("compensator.identify.dynamics_records", "meas/missing.csv: no such file"),
    ("cases[0].settle_periods", "-1"),
    ("cases[0].reference.radus", "unknown key"),
    ("cases[0].reference.frequency", "'10'"),
    ("cases[1].name", "duplicate"),
    ("cases[1].reference.kind", "'circel'"),
    ("cases[2].reference.lines", "found 1"),
    ("cases[2].reference.periods", "unknown key"),
    ("cases[2].reference.outputs", "'z'"),
    ("sweeps[0].metric", "'max_euclidian_error'"),
    ("sweeps[0](freq-12000Hz).reference.frequency", "Nyquist"),
]


def _scenario(tmp_path, preset="realistic-2dof"):
    (tmp_path / "meas").mkdir()
    for name in ("hysteresis-ux.csv", "hysteresis-uy.csv", "multisine-ux.csv"):
        (tmp_path / "meas" / name).write_text("t,ux,uy,x,y\n" + "".join(
            f"{k * 1e-4:.4f},0,0,0,0\n" for k in range(20)))
    path = tmp_path / "bad.toml"
    path.write_text(ALL_MISTAKES.format(preset=preset))
    return path


def _lines(path):
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    return str(err.value).splitlines()


def test_every_mistake_is_reported_in_one_run_once_at_its_place(tmp_path):
    path = _scenario(tmp_path)
    lines = _lines(path)
    for key, word in EXPECTED:
        hits = [ln for ln in lines if f"{path}: {key}: " in ln and word in ln]
        assert len(hits) == 1, (key, word, lines)
    # the missing record file is the top-level table's mistake: not a case's, and named once
    assert sum("missing.csv" in ln for ln in lines) == 1, lines


def test_a_missing_plant_preset_stops_only_the_checks_that_need_the_plant(tmp_path):
    # the outputs and the Nyquist frequency need the plant; nothing else does
    path = _scenario(tmp_path, preset="realistic-2dof.tml")
    lines = _lines(path)
    assert sum(f"{path}: plant.preset: " in ln for ln in lines) == 1, lines
    for key, word in EXPECTED:
        if key in ("cases[2].reference.outputs", "sweeps[0](freq-12000Hz).reference.frequency"):
            continue
        assert sum(f"{path}: {key}: " in ln and word in ln for ln in lines) == 1, (key, lines)


def test_a_case_that_overrides_the_identify_table_names_its_own_file(tmp_path):
    path = _scenario(tmp_path)
    text = path.read_text().replace('kind = "hamerstein"', 'kind = "hammerstein"').replace(
        "hysteresis_record =", "hysteresis_records =").replace("dynamic =", "dynamics =")
    text = text.split("[[cases]]")[0] + (
        '[[cases]]\nname = "a"\nreference = { kind = "circle", radius = 15.0, frequency = 10.0, '
        'periods = 3 }\n'
        '[[cases]]\nname = "b"\nreference = { kind = "circle", radius = 15.0, frequency = 10.0, '
        'periods = 3 }\n'
        'compensator = { identify = { records = "files", hysteresis_records = '
        '["meas/gone.csv"] } }\n')
    path.write_text(text)
    lines = _lines(path)
    assert [ln.split(": ", 2)[1] for ln in lines] == [
        "compensator.identify.dynamics_records", "cases[1].compensator"], lines
    assert "meas/gone.csv: no such file" in lines[1]


def test_a_missing_preset_under_an_identified_model_is_one_line(tmp_path):
    # the identify frequency is checked against the plant's Nyquist: no plant, no check (and
    # no crash: "unexpected AttributeError")
    path = tmp_path / "s.toml"
    path.write_text('[plant]\npreset = "nope.toml"\n[compensator]\nkind = "multivariable"\n'
                    'model = "identified"\nidentify = { frequency = 50.0 }\n[[cases]]\nname = "c"\n'
                    'reference = { kind = "circle", radius = 10.0, frequency = 20.0, periods = 3 }\n')
    lines = _lines(path)
    assert len(lines) == 1 and f"{path}: plant.preset: nope.toml" in lines[0], lines


def test_a_case_settling_past_its_record_is_named_beside_a_compensator_problem(tmp_path):
    """A compensator table with a bad value (identify.creep = "yes") made every case skip
    its own checks: a case settling over more periods than its record has went unsaid
    until the compensator was fixed."""
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\n[plant]\npreset = "realistic-2dof"\n[compensator]\n'
                 'kind = "hammerstein"\nmodel = "identified"\n'
                 'identify = { records = "excitation", creep = "yes" }\n'
                 '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                 'frequency = 50.0, periods = 4 }\nsettle_periods = 40\n')
    with pytest.raises(ScenarioError) as err:
        validate_scenario(f)
    text = str(err.value)
    assert "compensator.identify.creep: expected true or false" in text
    assert "cases[0].settle_periods: 40 periods of settling leave less than one sample" in text


IDENTIFY_FILES = """
name = "cols"
[plant]
preset = "realistic-2dof"
[compensator]
kind = "hammerstein"
model = "identified"
dynamics = "identified"
[compensator.identify]
records = "files"
hysteresis_records = ["h-ux.csv", "h-uy.csv"]
{keys}
[[cases]]
name = "c"
reference = {{ kind = "circle", radius = 10.0, frequency = 20.0, periods = 3 }}
"""

_COUNT = "1 column(s) ['x'] for the plant's 2 outputs"
_NO_UZ = "h-ux.csv, h-uy.csv: no input column named 'uz'"
_NO_TIME = "h-ux.csv, h-uy.csv: no time column named 'time'"


@pytest.mark.parametrize("keys, header, expected", [
    # a count that differs from the plant's hides no column check
    ('inputs = ["ux", "uz"]\noutputs = ["x"]\ntime = "time"', "t,ux,uy,x,y",
     [("outputs", _COUNT), ("inputs", _NO_UZ), ("time", _NO_TIME)]),
    # every missing column of a file, not only its first
    ('inputs = ["ux", "uz"]\noutputs = ["x", "y"]\ntime = "time"', "t,ux,uy,x,y",
     [("inputs", _NO_UZ), ("time", _NO_TIME)]),
    ('inputs = ["ua", "ub"]', "t,ux,uy,x,y",
     [("inputs", "no input column named 'ua'"), ("inputs", "no input column named 'ub'")]),
    ('outputs = ["x_nm", "y_nm"]', "t,ux,uy,x_nm,y_nm",
     [("outputs", "output column 'x_nm' is named in nm"),
      ("outputs", "output column 'y_nm' is named in nm")]),
    # a misspelt identification model leaves the records' columns knowable
    ('inputs = ["ux", "uz"]\noutputs = ["x"]\ntime = "time"\nmodel = "preisch"', "t,ux,uy,x,y",
     [("model", "'preisch'"), ("outputs", _COUNT), ("inputs", _NO_UZ), ("time", _NO_TIME)]),
    ('model = "preisch"', "time,ux,uy,x,y",
     [("model", "'preisch'"), ("time", "h-ux.csv, h-uy.csv: no time column named 't'")]),
    # ... but a wrong inputs key leaves them unknown: the files are only looked for
    ('inputs = 5\nmodel = "preisch"\ndynamics_records = ["gone.csv"]', "time,ux,uy,x,y",
     [("inputs", "expected column names"), ("model", "'preisch'"),
      ("dynamics_records", "gone.csv: no such file")]),
], ids=["count-beside-columns", "input-and-time", "two-inputs", "two-outputs-in-nm",
        "misspelt-model", "misspelt-model-default-time", "wrong-inputs-key"])
def test_every_column_problem_of_the_record_files_is_named_at_once(tmp_path, keys, header,
                                                                     expected):
    for name in ("h-ux.csv", "h-uy.csv"):
        (tmp_path / name).write_text(header + "\n" + "".join(
            f"{k * 5e-5:.5f},{k},{-k},{2 * k},{-2 * k}\n" for k in range(20)))
    path = tmp_path / "cols.toml"
    path.write_text(IDENTIFY_FILES.format(keys=keys))
    lines = _lines(path)
    assert len(set(lines)) == len(lines), lines     # each problem once
    for key, word in expected:
        hits = [ln for ln in lines if ln.startswith(f"{path}: compensator.identify.{key}: ")
                and word in ln]
        assert len(hits) == 1, (key, word, lines)
    assert len(lines) == len(expected), lines       # and nothing else


_NYQUIST = "20000 Hz is at or above the Nyquist frequency 10000 Hz"


@pytest.mark.parametrize("signal, expected", [
    ('reference = { kind = "sine", output = "z", amplitude = 10.0, frequency = 20000.0, '
     'periods = 4 }',
     [("reference.output", "expected one of ['x', 'y'], found 'z'"),
      ("reference.frequency", _NYQUIST)]),
    ('reference = { kind = "triangle", output = "z", amplitude = 10.0, frequency = 5000.0, '
     'periods = 4 }',
     [("reference.output", "found 'z'"), ("reference.frequency", "4 samples per period")]),
    ('drive = { kind = "sine", input = "uz", amplitude = 10.0, frequency = 20000.0, '
     'periods = 4 }',
     [("drive.input", "expected one of ['ux', 'uy'], found 'uz'"),
      ("drive.frequency", _NYQUIST)]),
    ('reference = { kind = "circle", outputs = ["x", "z"], radius = 10.0, '
     'frequency = 20000.0, periods = 4 }',
     [("reference.outputs", "found ['x', 'z']"), ("reference.frequency", _NYQUIST)]),
    ('reference = { kind = "raster", outputs = ["x", "z"], size = [10.0, 10.0], lines = 4, '
     'frequency = 20000.0 }',
     [("reference.outputs", "found ['x', 'z']"), ("reference.frequency", _NYQUIST)]),
    # a wrong output alone is one line: the signal on the plant's output has no problem
    ('reference = { kind = "sine", output = "z", amplitude = 10.0, frequency = 20.0, '
     'periods = 4 }',
     [("reference.output", "found 'z'")]),
], ids=["sine", "triangle-samples-per-period", "drive", "circle", "raster", "output-alone"])
def test_a_wrong_output_leaves_the_frequency_checked_against_nyquist(tmp_path, signal, expected):
    path = tmp_path / "nyq.toml"
    path.write_text('name = "nyq"\n[plant]\npreset = "realistic-2dof"\n[compensator]\n'
                    'kind = "multivariable"\n[[cases]]\nname = "c"\n' + signal + "\n")
    lines = _lines(path)
    assert len(set(lines)) == len(lines), lines
    for key, word in expected:
        hits = [ln for ln in lines if ln.startswith(f"{path}: cases[0].{key}: ") and word in ln]
        assert len(hits) == 1, (key, word, lines)
    assert len(lines) == len(expected), lines


SWEEP = """
name = "sw"
[plant]
preset = "realistic-2dof"
[[sweeps]]
name = "f"
frequencies = [10.0, 50.0]
reference = {{ kind = "sine", output = ["x", "y"], amplitude = 15.0, periods = 4 }}
{keys}
"""


@pytest.mark.parametrize("keys, expected", [
    ('[sweeps.compensators]\nmv = { kind = "multivariable", model = "plant" }\n'
     'il = { kind = "ilc", model = "plant" }',
     [("sweeps[0].compensators.il.model", "unknown key (valid keys: kind, ")]),
    ('compensator = { kind = "ilc", model = "plant" }',
     [("sweeps[0].compensator.model", "unknown key (valid keys: kind, ")]),
    # a key of the template and one of the label: each named where it is written
    ('compensator = { kind = "multivariable", gian = "secant" }\n[sweeps.compensators]\n'
     'mv = { kind = "multivariable", itrations = 2 }\nmv2 = { iterations = 2 }',
     [("sweeps[0].compensator.gian", "did you mean 'gain'?"),
      ("sweeps[0].compensators.mv.itrations", "did you mean 'iterations'?")]),
    ('[sweeps.compensators]\nmv = { kind = "multivariable", model = "gone.toml" }',
     [("sweeps[0].compensators.mv.model", "gone.toml")]),
    ('[sweeps.compensators]\nil = { kind = "ilk" }',
     [("sweeps[0].compensators.il.kind", "'ilk'")]),
], ids=["label", "template", "template-and-label", "model-file", "kind"])
def test_a_sweep_compensator_problem_is_named_once_where_it_is_written(tmp_path, keys, expected):
    # sw-val.toml: the four cases of the sweep each said it, as sweeps[0](f-il-x-10Hz)...
    path = tmp_path / "sw.toml"
    path.write_text(SWEEP.format(keys=keys))
    lines = _lines(path)
    assert len(set(lines)) == len(lines), lines
    for key, word in expected:
        hits = [ln for ln in lines if ln.startswith(f"{path}: {key}: ") and word in ln]
        assert len(hits) == 1, (key, word, lines)
    assert len(lines) == len(expected), lines
