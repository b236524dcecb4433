"""A compensator that cannot solve its reference is refused, not written as a drive of zeros.

A tester's tip-tilt-piston platform: outputs that mix all three stacks (direct secant gains
2.5 and 5.5 µm/V against 88 and 62 from the other stacks). The exact inverse's Gauss-Seidel
over the direct paths ended at its -120 V bound on every sample, the limits clipped that to
0 V, and `compensate` wrote a drive of zeros with exit 0. Here a 2x2 Preisach model whose
cross-couplings (3 µm/V) outweigh its direct paths (0.55 µm/V), against the same model with
the roles swapped.
"""

import re

import numpy as np
import pytest

import hammerstein as hs
from hammerstein import HammersteinPlant
from hammerstein.cli.main import main
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import save_model
from hammerstein.models.amplifier import RECORDS_SOURCE, Amplifier, AmplifierChannel
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.scenario.hardware_route import compensate_reference


def _plant(direct_total, cross_slope):
    def path(total):
        return PreisachModel.from_density(np.linspace(-10, 10, 21), total=total, coercivity=1.0,
                                          coercivity_width=2.0, reversible=[0.01 * total])
    model = MultivariableHysteresis([[path(direct_total), Polynomial([cross_slope])],
                                     [Polynomial([cross_slope]), path(direct_total)]],
                                    input_amplitude=[10.0, 10.0], input_names=["ux", "uy"],
                                    output_names=["x", "y"])
    plant = HammersteinPlant(model, 1e-4, name="dense")
    plant.amplifier = Amplifier([AmplifierChannel(-10, 10, 1e5)] * 2, ["ux", "uy"],
                                RECORDS_SOURCE)
    return plant


def _circle():
    return hs.circle(1e-4, radius=5.0, frequency=20.0, periods=4)[1]


def test_cross_couplings_that_outweigh_the_direct_paths_are_named():
    with pytest.raises(CompensatorError) as err:
        compensate_reference(_plant(5.0, 3.0), _circle(), period_samples=500)
    text = str(err.value)
    # refused before any drive: the sweeps over the direct paths cannot solve it (their
    # radius, 2x2 Gauss-Seidel undamped: (3 / 0.55)^2 = 29.75)
    assert "Gauss-Seidel over the direct paths" in text
    undamped = float(re.search(r"\(([0-9.]+) undamped;", text).group(1))
    assert undamped == pytest.approx((3 / 0.55) ** 2, rel=0.01)
    assert "x: direct 0.55 µm/V against 3 from the others" in text


def test_dominant_direct_paths_follow_the_reference():
    plant = _plant(60.0, 0.3)
    _, drive = compensate_reference(plant, _circle(), period_samples=500)
    settled = slice(drive.fade_samples + 1000, None)
    y, _ = plant.hysteresis.simulate(drive.inputs)
    assert np.max(np.abs(y[:, settled] - drive.reference[:, settled])) < 1e-6


def test_compensate_writes_no_drive_and_exits_1(tmp_path, capsys):
    path = tmp_path / "dense.toml"
    plant = _plant(5.0, 3.0)
    save_model(plant.hysteresis, path, {"method": "test"},
               extra={"amplifier": {"source": "records",
                                    "ux": {"range": [-10.0, 10.0], "slew_rate": 1e5},
                                    "uy": {"range": [-10.0, 10.0], "slew_rate": 1e5}}})
    out = tmp_path / "d.csv"
    code = main(["compensate", str(path), "--sampling-period", "1e-4", "--reference",
                 '{ kind = "circle", radius = 5, frequency = 20, periods = 4 }', "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and not out.exists()
    assert err[-1].startswith("hammerstein compensate: error: model: the exact inverse cannot "
                              "solve it")
