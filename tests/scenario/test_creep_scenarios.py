"""A preset with an identified [creep] is inverted by scenarios (creep = auto | plant | none)."""

import numpy as np
import pytest
import tomli_w

from hammerstein.models.creep import Creep
from hammerstein.io.presets import load_creep, load_plant, model_to_table
from hammerstein.scenario.resolve import load_scenario

CREEP = Creep([0.05, 0.5, 5.0], [0.01, 0.008, 0.006], instantaneous=0.98)


@pytest.fixture
def scenario_dir(tmp_path):
    plant = load_plant("rakotondrabe-2dof")
    doc = {"preset": {"name": "id", "sampling_period": plant.sampling_period},
           "dynamics": {"kind": "bending_modes", "natural_frequency": [310.0, 290.0],
                        "damping_ratio": [0.15, 0.2]},
           "creep": {"x": CREEP.to_table()},
           "model": model_to_table(plant.hysteresis)}
    (tmp_path / "id.toml").write_text(tomli_w.dumps(doc))
    return tmp_path


def _compensator(d, plant, extra=""):
    (d / "s.toml").write_text(
        f'name = "c"\n[plant]\npreset = "{plant}"\n[compensator]\nkind = "hammerstein"\n'
        f'model = "id.toml"\ndynamics = "id.toml"\n{extra}[[cases]]\nname = "c"\nreference = '
        f'{{ kind = "circle", radius = 10.0, frequency = 50.0, periods = 2 }}\nsettle_periods = 1\n')
    return load_scenario(d / "s.toml").cases[0].compensator


def test_preset_creep_round_trip(scenario_dir):
    x, y = load_creep(scenario_dir / "id.toml", ["x", "y"])
    assert y is None and x.instantaneous == 0.98
    np.testing.assert_array_equal(x.weights, CREEP.weights)


@pytest.mark.parametrize("extra, expect", [("", "file"), ('creep = "none"\n', None),
                                           ('creep = "plant"\n', "plant")])
def test_scenario_inverts_the_creep_it_is_told_to(scenario_dir, extra, expect):
    comp = _compensator(scenario_dir, "realistic-2dof", extra)
    if expect is None:
        assert comp.creep is None and comp.dynamics is comp.bending_dynamics
    elif expect == "file":
        assert comp.creep[1] is None
        np.testing.assert_array_equal(comp.creep[0].weights, CREEP.weights)
    else:                      # the plant's true log creep on both outputs
        assert all(c is not None and c.instantaneous == 1.0 for c in comp.creep)
    # the inverted system's DC gain is 1 + the creep's steady gain minus 1 per output
    if comp.creep is not None:
        D = comp.dynamics
        dc = np.diag(D.C @ np.linalg.solve(np.eye(D.nstates) - D.A, D.B) + D.D)
        want = [1.0 if c is None else c.instantaneous + c.weights.sum() for c in comp.creep]
        np.testing.assert_allclose(dc, want, rtol=1e-6)
