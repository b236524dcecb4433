"""A sine or triangle reference on a plant with one output needs no ``output`` key.

`compensate --reference '{ kind = "sine", ... }'` took it on a one-output preset; a
scenario case refused the same table with ``reference.output: missing (required)``.
"""

import numpy as np
import pytest

import hammerstein as hs
from hammerstein.exceptions import ScenarioError
from hammerstein.runner import run_scenario
from hammerstein.scenario.validate import validate_scenario

SCENARIO = """
name = "siso"
[plant]
preset = "{preset}"
dynamics = false
[compensator]
kind = "multivariable"
[[cases]]
name = "sine"
reference = {{ kind = "sine", amplitude = 30.0, frequency = 50.0, periods = 3 }}
[[cases]]
name = "tri"
reference = {{ kind = "triangle", amplitude = 20.0, frequency = 25.0, periods = 2 }}
"""


def _one_output_preset(tmp_path):
    pi = hs.PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.3, 0.2])
    model = hs.MultivariablePI([[pi]], input_names=["u"], output_names=["z"],
                               input_amplitude=[40.0])
    hs.save_model(model, tmp_path / "one.toml",
                  extra={"preset": {"name": "one", "sampling_period": 1e-4}})
    return "one.toml"


def test_the_one_output_is_the_default_and_the_signal_lies_on_it(tmp_path):
    path = tmp_path / "siso.toml"
    path.write_text(SCENARIO.format(preset=_one_output_preset(tmp_path)))
    spec = validate_scenario(path)
    sine, tri = spec.cases
    assert sine.signal_spec["output"] == "z" and tri.signal_spec["output"] == "z"
    # 30 sin(2 pi 50 t) sampled at 1e-4 s: peak 30 µm at t = 5 ms (sample 50)
    assert sine.signal.shape == (1, 600)
    assert sine.signal[0, 50] == pytest.approx(30.0)
    assert np.max(np.abs(tri.signal)) == pytest.approx(20.0)
    assert sine.loop_channel == 0


def test_the_report_names_the_defaulted_output(tmp_path):
    path = tmp_path / "siso.toml"
    path.write_text(SCENARIO.format(preset=_one_output_preset(tmp_path)))
    out = run_scenario(path, tmp_path / "out")
    assert out.ok, out.error
    md = (out.out_dir / "report.md").read_text()
    assert "sine on z" in md and "sine on None" not in md


def test_several_outputs_still_need_the_output_named(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text(SCENARIO.format(preset="rakotondrabe-2dof"))
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    lines = str(err.value).splitlines()
    assert [ln.split(": ", 2)[1:] for ln in lines] == [
        ["cases[0].reference.output", "missing (required)"],
        ["cases[1].reference.output", "missing (required)"]], lines
