"""The plant's rest state: 0 V held until the creep and the bending modes have settled.

A drive starts with the actuator at rest (its creep settled at 0 V). Simulated from zero
linear states instead, an identified plant whose output at 0 V is not 0 µm rang up from
0 µm over its first samples, so ``compensate --predicted`` showed the model missing its
own reference at the start and, through the creep's slow lags, all along.
"""

from pathlib import Path

import control
import numpy as np
import pandas as pd
import pytest

from hammerstein.cli.main import main
from hammerstein.compensation.drive import rest_output
from hammerstein.io.presets import load_plant

IDENTIFIED = Path(__file__).parents[1] / "hardware" / "data" / "outside-gpi-identified.toml"


@pytest.mark.parametrize("preset", [str(IDENTIFIED), "rakotondrabe-2dof"])
def test_zero_volts_from_rest_stays_at_the_dc_steady_state(preset):
    plant = load_plant(preset)
    y, _ = plant.simulate(np.zeros((plant.hysteresis.n_inputs, 400)), plant.rest_state())
    # independently: the hysteresis output at 0 V through the creep's static gain, then the
    # dynamics' DC gain (python-control)
    h0 = rest_output(plant.hysteresis, plant.creep)
    dc = np.atleast_2d(control.dcgain(plant.dynamics))
    np.testing.assert_allclose(y, np.repeat((dc @ h0)[:, None], 400, axis=1), rtol=0, atol=1e-9)


def test_the_identified_plants_rest_is_not_zero():
    # what makes the test above able to fail: from zero linear states the output rings
    plant = load_plant(str(IDENTIFIED))
    y, _ = plant.simulate(np.zeros((2, 400)))
    assert np.ptp(y, axis=1).max() > 1e-3


def test_compensate_predicted_starts_at_rest(tmp_path, capsys):
    out = tmp_path / "drive.csv"
    code = main(["compensate", str(IDENTIFIED), "--reference",
                 '{ kind = "circle", radius = 15, frequency = 50, periods = 10 }',
                 "--predicted", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    frame = pd.read_csv(out, comment="#")
    plant = load_plant(str(IDENTIFIED))
    h0 = rest_output(plant.hysteresis, plant.creep)
    rest = np.atleast_2d(control.dcgain(plant.dynamics)) @ h0
    u = frame[["ux", "uy"]].to_numpy().T
    still = int(np.argmax(np.any(np.abs(u) > 1e-9, axis=0)))    # the drive's samples at rest
    assert still > 10
    y = frame[["x_predicted", "y_predicted"]].to_numpy().T
    np.testing.assert_allclose(y[:, :still], np.repeat(rest[:, None], still, axis=1),
                               rtol=0, atol=1e-9)
