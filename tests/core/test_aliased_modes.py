"""A bending mode at or above the Nyquist frequency of its sampling is warned of (it is aliased).

A preset with a 6000 Hz mode at T = 1e-4 s, or ``compensate --sampling-period
2e-3`` putting a 420 Hz mode above 250 Hz, was accepted silently.
"""

import warnings

import pytest

from hammerstein.cli.main import main
from hammerstein.exceptions import DynamicsWarning
from hammerstein.io.presets import load_dynamics, load_plant

from tests.core.test_preset_numbers import BASE

REF = '{ kind = "sine", output = "x", amplitude = 10.0, frequency = 5.0, periods = 3 }'


def _preset(tmp_path, freqs="[6000.0, 420.0]"):
    path = tmp_path / "p.toml"
    path.write_text(BASE.replace("natural_frequency = [420.0, 420.0]",
                                 f"natural_frequency = {freqs}"), encoding="utf-8")
    return path


def test_a_mode_above_nyquist_is_warned_of(tmp_path):
    path = _preset(tmp_path)
    with pytest.warns(DynamicsWarning) as record:
        load_plant(str(path))
    assert len(record) == 1
    assert str(record[0].message) == (
        f"{path}: dynamics.natural_frequency: the mode at 6000 Hz is at or above the Nyquist "
        f"frequency 5000 Hz of the sampling period 0.0001 s: aliased when sampled (the plant "
        f"does not have it at that frequency, and its inverse is meaningless); sample faster "
        f"or check the value")


def test_a_resampled_preset_is_checked_at_its_new_period(tmp_path):
    path = _preset(tmp_path, "[420.0, 420.0]")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_plant(str(path))                      # 420 Hz < 5 kHz
    with pytest.warns(DynamicsWarning, match=r"modes at 420, 420 Hz are at or above the Nyquist "
                                             r"frequency 250 Hz of the sampling period 0.002 s"):
        load_dynamics(path, ["x", "y"], 2e-3)


def test_a_state_space_mode_above_nyquist_names_a(tmp_path):
    w = 2 * 3.141592653589793 * 6000.0
    text = BASE.replace('kind = "bending_modes"\nnatural_frequency = [420.0, 420.0]\n'
                        'damping_ratio = [0.03, 0.03]',
                        f'kind = "state_space"\nA = [[0.0, 1.0], [{-w * w}, {-0.06 * w}]]\n'
                        f'B = [[0.0, 0.0], [{w * w}, 0.0]]\nC = [[1.0, 0.0], [0.0, 0.0]]\n'
                        f'D = [[0.0, 0.0], [0.0, 1.0]]')
    path = tmp_path / "ss.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.warns(DynamicsWarning, match=r"dynamics\.A: the mode at 6000 Hz is at or above"):
        load_plant(str(path))


def test_compensate_prints_one_warning_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _preset(tmp_path, "[420.0, 420.0]")
    main(["compensate", "p.toml", "--sampling-period", "2e-3", "--reference", REF,
          "--out", "d.csv"])
    err = [line for line in capsys.readouterr().err.splitlines() if "Nyquist" in line]
    assert len(err) == 1 and err[0].startswith("warning: ") and "dynamics.natural_frequency" in err[0]
    assert err[0].count("p.toml") == 1, err[0]          # the file named once, not twice


def test_validate_warns_of_the_preset_of_a_scenario(tmp_path, capsys):
    _preset(tmp_path)
    scen = tmp_path / "s.toml"
    scen.write_text('[plant]\npreset = "p.toml"\n[compensator]\nkind = "multivariable"\n'
                    '[[cases]]\nname = "c"\nreference = { kind = "sine", output = "x", '
                    'amplitude = 10.0, frequency = 50.0, periods = 3 }\n', encoding="utf-8")
    assert main(["validate", str(scen)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert sum("the mode at 6000 Hz is at or above the Nyquist frequency 5000 Hz" in e
               for e in err) == 1, err
