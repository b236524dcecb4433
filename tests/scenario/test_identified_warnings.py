"""Warnings from measurements (issue 17 item 5): dynamics and range of what was identified.

A preset written as ``hammerstein identify`` writes it (``[identification]``
with the record files, ``[dynamics]``, ``[model]``) whose identified first
resonance (100 Hz) differs from the plant's (290 Hz): the dynamics warning of
a rate-independent compensator at 20 Hz must quote the identified 100 Hz and
name the preset it comes from; the range warning names the hysteresis records.
"""

import numpy as np
import pytest
import tomli_w

from hammerstein.compensation.compensators import RangeWarning, check_reference_range
from hammerstein.io.presets import load_model, load_plant, model_to_table
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.resolve import load_scenario


@pytest.fixture
def scenario_dir(tmp_path):
    plant = load_plant("rakotondrabe-2dof")
    doc = {"identification": {"method": "least-squares",
                              "sources": ["lab/hysteresis-ux.csv", "lab/hysteresis-uy.csv"]},
           "preset": {"name": "id", "sampling_period": plant.sampling_period},
           "dynamics": {"kind": "bending_modes", "natural_frequency": [100.0, 120.0],
                        "damping_ratio": [0.2, 0.2]},
           "model": model_to_table(plant.hysteresis)}
    (tmp_path / "id.toml").write_text(tomli_w.dumps(doc))
    return tmp_path


def _scenario(d, model, radius):
    text = (f'name = "w"\n[plant]\npreset = "rakotondrabe-2dof"\ndynamics = true\n'
            f'[compensator]\nkind = "multivariable"\nmodel = "{model}"\n'
            f'[[cases]]\nname = "c"\nreference = {{ kind = "circle", radius = {radius}, '
            f'frequency = 20.0, periods = 2 }}\nsettle_periods = 1\n')
    (d / "s.toml").write_text(text)
    return load_scenario(d / "s.toml").cases[0]


def test_dynamics_warning_uses_the_identified_dynamics_and_says_so(scenario_dir):
    case = _scenario(scenario_dir, "id.toml", 20.0)
    text = " ".join(case.warnings)
    # the dynamics' own file, not the hysteresis records (the multisines are not listed)
    assert "at 20 Hz the linear dynamics of id.toml (first resonance 100 Hz)" in text
    assert "hysteresis-ux.csv" not in text
    # with the plant's own model the plant's dynamics (first resonance 290 Hz) are judged
    plant_text = " ".join(_scenario(scenario_dir, "plant", 20.0).warnings)
    assert "identified" not in plant_text
    assert "the plant's linear dynamics (first resonance 290 Hz)" in plant_text


def test_range_warning_names_the_records_the_range_was_identified_on(scenario_dir):
    model = load_model(scenario_dir / "id.toml")
    assert model.identified_from == "records hysteresis-ux.csv, hysteresis-uy.csv (preset id.toml)"
    with pytest.warns(RangeWarning, match=r"identified from records hysteresis-ux\.csv, "
                                          r"hysteresis-uy\.csv \(preset id\.toml\)"):
        check_reference_range(model, np.full((2, 3), 200.0))
    result = run_case(_scenario(scenario_dir, "id.toml", 80.0))
    assert any("beyond the range the model was identified on" in w and "preset id.toml" in w
               for w in result.warnings)


def test_dynamics_warning_judges_the_outputs_the_reference_moves(scenario_dir):
    """A sine on y alone is judged by y's column of G(f) G(0)^-1 - I: x's mode (100 Hz,
    damping 0.2) and y's (120 Hz) at 60 Hz change each axis's response by a closed-form
    amount; the whole matrix's norm, x's figure, was given to a sine on y."""
    from hammerstein.models.dynamics import sampled_bending_modes
    text = ('name = "w"\n[plant]\npreset = "rakotondrabe-2dof"\ndynamics = true\n'
            '[compensator]\nkind = "multivariable"\nmodel = "id.toml"\n'
            '[[cases]]\nname = "c"\nreference = {{ kind = "sine", output = "{o}", '
            'amplitude = 10.0, frequency = 60.0, periods = 2 }}\n')
    T = load_plant("rakotondrabe-2dof").sampling_period
    G = sampled_bending_modes(np.array([100.0, 120.0]), np.array([0.2, 0.2]), ["x", "y"], T)
    c = G.frequency_response_hz([1e-3, 60.0])
    change = np.abs(np.diag(c[:, :, 1] @ np.linalg.inv(np.real(c[:, :, 0])) - np.eye(2)))
    assert change[0] > 1.3 * change[1]
    for o, expect in zip("xy", change):
        (scenario_dir / "s.toml").write_text(text.format(o=o))
        words = " ".join(load_scenario(scenario_dir / "s.toml").cases[0].warnings)
        assert f"change the response by {100 * expect:.1f} %" in words, words
