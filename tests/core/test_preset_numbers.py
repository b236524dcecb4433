"""A preset's numeric values: a unit written in a value, or a boolean, is refused naming the key.

``natural_frequency = ["420 Hz", "420 Hz"]`` failed "could not convert string
to float" (no key; "unexpected ValueError" from export, and ``list
--scenarios`` stopped at the file); ``natural_frequency = [true, 420.0]``
became a 1 Hz mode (a Python bool is an int).
"""

import pytest

from hammerstein.cli.main import main
from hammerstein.io.presets import PresetError, load_plant

BASE = """[preset]
name = "my-stage-bm"
sampling_period = 1e-4

[model]
inputs = ["ux", "uy"]
outputs = ["x", "y"]
input_amplitude = [120.0, 120.0]
thresholds = [0.0, 10.0, 20.0, 35.0, 50.0, 70.0, 90.0]

[model.components.x.ux]
weights = [0.12, 0.03, 0.02, 0.015, 0.01, 0.008, 0.005]

[model.components.x.uy]
gain = 0.004

[model.components.y.ux]
weights = [0.005, 0.001, -0.001, 0.0005, 0.0, 0.0, 0.0]

[model.components.y.uy]
weights = [0.11, 0.035, 0.02, 0.012, 0.01, 0.006, 0.004]

[dynamics]
kind = "bending_modes"
natural_frequency = [420.0, 420.0]
damping_ratio = [0.03, 0.03]

[amplifier]
range = [-20.0, 120.0]
slew_rate = 5.0e4
"""

CREEP = '\n[creep.x]\nkind = "log"\nrate_per_decade = 0.01\nt_min = 0.01\nt_max = 100.0\n'
LAGS = '\n[creep.x]\nkind = "lags"\ntime_constants = [0.1, 10.0]\nweights = [0.01, 0.02]\n'

BAD = {
    "nf-unit": (("natural_frequency = [420.0, 420.0]", 'natural_frequency = ["420 Hz", "420 Hz"]'),
                "dynamics.natural_frequency: expected a positive number [Hz] per output, found '420 Hz'"),
    "zeta-unit": (("damping_ratio = [0.03, 0.03]", 'damping_ratio = ["3 %", "3 %"]'),
                  "dynamics.damping_ratio: expected a positive number per output (a ratio: 0.03 "
                  "for 3 %), found '3 %'"),
    "nf-bool": (("natural_frequency = [420.0, 420.0]", "natural_frequency = [true, 420.0]"),
                "dynamics.natural_frequency: expected a positive number [Hz] per output, found True"),
    "zeta-bool": (("damping_ratio = [0.03, 0.03]", "damping_ratio = [0.03, false]"),
                  "dynamics.damping_ratio: expected a positive number per output (a ratio: 0.03 "
                  "for 3 %), found False"),
    "ss-unit": (('kind = "bending_modes"\nnatural_frequency = [420.0, 420.0]\n'
                 'damping_ratio = [0.03, 0.03]',
                 'kind = "state_space"\nA = [[-1.0, 0.0], [0.0, "2 Hz"]]\nB = [[1.0, 0.0], [0.0, 1.0]]\n'
                 'C = [[1.0, 0.0], [0.0, 1.0]]'),
                "dynamics.A: expected a numeric matrix (list of rows), found '2 Hz'"),
    "ss-bool": (('kind = "bending_modes"\nnatural_frequency = [420.0, 420.0]\n'
                 'damping_ratio = [0.03, 0.03]',
                 'kind = "state_space"\nA = [[-1.0, 0.0], [0.0, -2.0]]\nB = [[true, 0.0], [0.0, 1.0]]\n'
                 'C = [[1.0, 0.0], [0.0, 1.0]]'),
                "dynamics.B: expected a numeric matrix (list of rows), found True"),
    "weight-bool": (("weights = [0.12,", "weights = [true,"),
                    "model.components.x.ux.weights[0]: expected a number, found a boolean"),
    "gain-bool": (("gain = 0.004", "gain = true"),
                  "model.components.x.uy.gain: expected a number, found a boolean"),
    "amplitude-bool": (("input_amplitude = [120.0, 120.0]", "input_amplitude = [true, 120.0]"),
                       "model.input_amplitude[0]: expected a number, found a boolean"),
    "creep-log-unit": (("[amplifier]", CREEP.replace("t_max = 100.0", 't_max = "100 s"') + "[amplifier]"),
                       "creep.x.t_max: expected a number [s], found '100 s'"),
    "creep-lags-bool": (("[amplifier]", LAGS.replace("[0.01, 0.02]", "[0.01, true]") + "[amplifier]"),
                        "creep.x.weights: expected a list of numbers, found True"),
    "creep-lags-unit": (("[amplifier]", LAGS.replace("[0.1, 10.0]", '["0.1 s", 10.0]') + "[amplifier]"),
                        "creep.x.time_constants: expected a list of numbers [s], found '0.1 s'"),
    "creep-per-decade-bool": (("[amplifier]", CREEP + "per_decade = true\n[amplifier]"),
                              "creep.x.per_decade: expected a number, found True"),
}


def _write(path, name):
    (old, new), _ = BAD[name]
    assert old in BASE
    path.write_text(BASE.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_non_number_names_its_key(tmp_path, name):
    path = _write(tmp_path / f"{name}.toml", name)
    with pytest.raises(PresetError) as err:
        load_plant(str(path))
    assert str(err.value) == f"{path}: {BAD[name][1]}"


def test_the_valid_preset_and_its_creep_still_load(tmp_path):
    for i, text in enumerate((BASE, BASE.replace("[amplifier]", CREEP + "[amplifier]"),
                              BASE.replace("[amplifier]", LAGS + "[amplifier]"))):
        (tmp_path / f"ok{i}.toml").write_text(text, encoding="utf-8")
        load_plant(str(tmp_path / f"ok{i}.toml"))


@pytest.mark.parametrize("command", ["compensate", "export"])
def test_commands_print_one_line_naming_the_key(tmp_path, capsys, command, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "p.toml", "nf-unit")
    argv = (["compensate", "p.toml", "--reference", "sine:x:10:50:3", "--out", "d.csv"]
            if command == "compensate" else ["export", "p.toml", "--out", "exp"])
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(
        "p.toml: dynamics.natural_frequency: expected a positive number [Hz] per output, "
        "found '420 Hz'"), err


def test_list_marks_the_bad_file_and_lists_the_others(tmp_path, capsys):
    (tmp_path / "good.toml").write_text(BASE, encoding="utf-8")
    _write(tmp_path / "bad.toml", "zeta-unit")
    assert main(["list", "--scenarios", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"{tmp_path / 'good.toml'}; dynamics: 4 states" in out
    assert f"{tmp_path / 'bad.toml'}; invalid: {tmp_path / 'bad.toml'}: dynamics.damping_ratio: " in out
