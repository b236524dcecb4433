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


def _slow_plant():
    """The dominant-direct plant behind two critically damped 12 Hz lags: a 100 Hz reference
    needs 1 / |G| = 1 + (100 / 12)^2 = 70 times its static voltages. Its model bounded by the
    records' range, as ``identify`` writes it: the exact inverse never asks beyond it."""
    from hammerstein.models.dynamics import sampled_bending_modes
    plant = _plant(60.0, 0.3)
    plant.hysteresis.input_range = np.array([[-10.0, 10.0], [-10.0, 10.0]])
    slow = HammersteinPlant(plant.hysteresis, 1e-4,
                            sampled_bending_modes([12.0, 12.0], [1.0, 1.0], ["x", "y"], 1e-4),
                            name="slow")
    slow.amplifier = plant.amplifier
    return slow


def _fast_circle():
    return hs.circle(1e-4, radius=5.0, frequency=100.0, periods=20)[1]


def test_an_inverse_held_on_its_bounds_by_the_dynamics_is_refused():
    # the exact inverse answers every sample within its bounds, so the limits see nothing; the
    # drive jumps between the bounds and misses the circle on the model itself
    with pytest.raises(CompensatorError) as err:
        compensate_reference(_slow_plant(), _fast_circle(), period_samples=100)
    text = str(err.value)
    assert text.startswith("nothing written: the drive, played through the model it was "
                           "computed from, misses the reference")
    gain = float(re.search(r"pass the reference's 100 Hz at ([0-9.e-]+) of", text).group(1))
    assert gain == pytest.approx(1 / (1 + (100 / 12) ** 2), rel=0.05)
    assert re.search(r"ux [0-9.]+ %, uy [0-9.]+ % of the samples", text)


def test_with_limits_warn_it_is_written_with_the_note():
    plant = _slow_plant()
    _, drive = compensate_reference(plant, _fast_circle(), period_samples=100, limits="warn")
    (note,) = [n for n in drive.notes if "misses the reference" in n]
    median = float(re.search(r"by ([0-9.]+) µm on half of them", note).group(1))
    y, _ = plant.simulate(drive.inputs, plant.rest_state())
    after = slice(drive.fade_samples, None)
    miss = np.hypot(*(y[:, after] - drive.reference[:, after]))
    assert median == pytest.approx(np.median(miss), rel=0.01)
    assert median > 0.5 * 5.0                        # more than half the radius: refused above


def test_a_slow_reference_on_the_same_plant_has_no_note():
    plant = _slow_plant()
    _, drive = compensate_reference(plant, hs.circle(1e-4, radius=5.0, frequency=2.0,
                                                     periods=3)[1], period_samples=5000)
    assert not [n for n in drive.notes if "misses the reference" in n]
    y, _ = plant.simulate(drive.inputs, plant.rest_state())
    after = slice(drive.fade_samples, None)
    assert np.max(np.hypot(*(y[:, after] - drive.reference[:, after]))) < 0.1 * 5.0
