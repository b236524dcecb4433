"""The sensor and the amplifier of a preset in the feedback loop: [sensor], [amplifier]."""

import textwrap
import tomllib
from importlib import resources

import numpy as np
import pytest
import tomli_w

from hammerstein.exceptions import PresetError
from hammerstein.io.presets import load_plant
from hammerstein.io.sensor import sensor_from_table, sensor_to_table
from hammerstein.scenario.feedback import build_loops
from hammerstein.scenario.validate import validate_scenario

PRESET = (resources.files("hammerstein") / "presets" / "realistic-2dof.toml").read_text("utf-8")

HARDWARE = """
[sensor]
noise_nm = 25.0
bandwidth_hz = 4000.0
delay = 2

[amplifier]
range = [-8.0, 9.0]
slew_rate = 2.0e5
"""

SCENARIO = """
name = "fb"
kind = "feedback"
[plant]
preset = "{preset}"
[compensator]
kind = "preisach-inverse"
model = "plant"
[[cases]]
name = "circle"
reference = {{ kind = "circle", radius = 5.0, frequency = 50.0, periods = 2 }}
settle_periods = 1
[feedback]
{extra}
[feedback.axes.x]
kind = "integral"
crossover_hz = 30.0
[feedback.axes.y]
kind = "integral"
crossover_hz = 30.0
"""


def _preset(tmp_path, hardware):
    path = tmp_path / "stage.toml"
    path.write_text(PRESET + textwrap.dedent(hardware), encoding="utf-8")
    return path


def _scenario(tmp_path, preset, extra=""):
    path = tmp_path / "fb.toml"
    path.write_text(SCENARIO.format(preset=preset.as_posix(), extra=extra), encoding="utf-8")
    return validate_scenario(path)


def test_preset_sensor_round_trip(tmp_path):
    plant = load_plant(_preset(tmp_path, HARDWARE))
    assert plant.sensor == {"noise_nm": 25.0, "bandwidth_hz": 4000.0, "delay": 2}
    text = tomli_w.dumps({"sensor": sensor_to_table(plant.sensor)})
    again = sensor_from_table(tomllib.loads(text)["sensor"], "again")
    assert again == plant.sensor
    assert load_plant(_preset(tmp_path, "")).sensor is None      # no [sensor]: none


def test_every_hardware_problem_is_listed_at_once(tmp_path):
    bad = """
[sensor]
noise_nm = -1.0
delay = 1.5
colour = "pink"

[amplifier]
range = [10.0, -10.0]
"""
    with pytest.raises(PresetError) as exc:
        load_plant(_preset(tmp_path, bad))
    text = str(exc.value)
    for key in ("sensor.noise_nm", "sensor.delay", "sensor.colour", "amplifier"):
        assert key in text, key
    assert text.count("\n") == 0


def test_the_loop_takes_the_presets_hardware(tmp_path):
    """Sensor and amplifier from the preset run the same loop as the same values in [feedback]."""
    preset = _preset(tmp_path, HARDWARE)
    spec = _scenario(tmp_path, preset)
    plant = spec.cases[0].plant
    fb, _ = build_loops(spec.table, plant)
    assert fb.sensor.noise_rms == pytest.approx(0.025) and fb.sensor.delay == 2
    np.testing.assert_array_equal(np.broadcast_to(fb.amplifier.low, (2,)), [-8.0, -8.0])
    np.testing.assert_array_equal(np.broadcast_to(fb.amplifier.high, (2,)), [9.0, 9.0])
    explicit = ('sensor = { noise_nm = 25.0, bandwidth_hz = 4000.0, delay = 2 }\n'
                'amplifier = { range = [-8.0, 9.0], slew_rate = 2.0e5 }')
    plain = tmp_path / "plain"
    plain.mkdir()
    spec2 = _scenario(plain, _preset(plain, ""), explicit)
    fb2, _ = build_loops(spec2.table, spec2.cases[0].plant)
    r = np.vstack([np.linspace(0.0, 70.0, 4000)] * 2)   # 70 µm: beyond +9 V on both axes
    a, b = fb.simulate(r, seed=3), fb2.simulate(r, seed=3)
    np.testing.assert_array_equal(a.outputs, b.outputs)
    assert np.max(a.inputs) <= 9.0 + 1e-12 and np.min(a.inputs) >= -8.0 - 1e-12
    assert np.max(a.inputs) == pytest.approx(9.0)       # clamped at the preset's +9 V


def test_the_scenario_overrides_a_sensor_key(tmp_path):
    preset = _preset(tmp_path, HARDWARE)
    spec = _scenario(tmp_path, preset, "sensor = { noise_nm = 0.0 }")
    fb, _ = build_loops(spec.table, spec.cases[0].plant)
    assert fb.sensor.noise_rms == 0.0 and fb.sensor.delay == 2
