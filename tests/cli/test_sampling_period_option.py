"""``--sampling-period`` other than the preset's: the same actuator sampled again.

A preset's continuous dynamics are discretised again at the new period; its
creep (continuous lags), amplifier and rest output are the actuator's and
must not change with it, and ``export`` samples the dynamics the same way as
``compensate`` (it refused before).
"""

import control
import numpy as np
import pytest

from hammerstein.cli._hardware import load_actuator
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.export.build import compensator_from_source, load_source


def test_a_preset_sampled_again_keeps_its_creep_and_amplifier():
    nominal = load_actuator("realistic-2dof")
    again = load_actuator("realistic-2dof", 1e-4)
    assert again.sampling_period == 1e-4 and nominal.sampling_period == 5e-5
    assert again.creep is not None
    assert [c.static_gain for c in again.creep] == [c.static_gain for c in nominal.creep]
    # the same continuous modes: the static gains of the two samplings agree
    g0 = np.asarray(again.sampled_dynamics.frequency_response_hz([0.0]))
    g1 = np.asarray(nominal.sampled_dynamics.frequency_response_hz([0.0]))
    np.testing.assert_allclose(g0, g1, atol=1e-9)
    # a slow input: the creep's settled gain appears in both (the hysteresis alone lacks it)
    T0, T1 = 5e-5, 1e-4
    u0 = np.vstack([np.full(int(2.0 / T0), 5.0), np.zeros(int(2.0 / T0))])
    u1 = u0[:, ::2]
    y0, y1 = nominal.simulate(u0)[0], again.simulate(u1)[0]
    assert y1[0, -1] == pytest.approx(y0[0, -1], rel=1e-3)


def test_export_samples_the_dynamics_again_as_compensate_does():
    source = load_source("realistic-2dof")
    comp, T = compensator_from_source(source, "hammerstein", sampling_period=1e-4)
    assert T == 1e-4 and float(comp.dynamics.dt) == 1e-4
    plant = load_actuator("realistic-2dof", 1e-4)
    same = HammersteinCompensator(plant.hysteresis, plant.dynamics, gain="midpoint", iterations=3,
                                  sampling_period=1e-4, creep=plant.creep)
    w = 2 * np.pi * np.array([0.1, 10.0, 100.0, 400.0, 1000.0])
    np.testing.assert_allclose(control.frequency_response(comp.dynamics, w).complex,
                               control.frequency_response(same.dynamics, w).complex,
                               rtol=1e-12, atol=1e-15)


def _hysteresis_model(tmp_path, periods):
    """The outside actuator's identified model without its [preset] and dynamics."""
    from pathlib import Path
    text = (Path(__file__).parents[1] / "hardware" / "data"
            / "outside-gpi-identified.toml").read_text(encoding="utf-8")
    head, rest = text.split("\n[preset]", 1)
    model = "\n[model]" + rest.split("\n[model]", 1)[1]
    head = head.replace("sampling_period_s = [\n    4.99999999999e-05,\n    4.99999999999e-05,\n]",
                        f"sampling_period_s = {periods}")
    path = tmp_path / "m.toml"
    path.write_text(head + model, encoding="utf-8")
    return path


# A model file identified with --time said "a model file has no sampling period" although
# its [identification] sampling_period_s held the records' period: it is used.
def test_a_model_file_is_sampled_at_its_records_period(tmp_path):
    plant = load_actuator(str(_hysteresis_model(tmp_path, "[1e-4, 1e-4]")))
    assert plant.sampling_period == 1e-4
    assert load_actuator(str(tmp_path / "m.toml"), 2e-4).sampling_period == 2e-4


@pytest.mark.parametrize("periods, words", [
    ("[1e-4, 2e-4]", "the model's records were sampled at different periods (0.0001, 0.0002 s, "
                     "[identification] sampling_period_s); give --sampling-period S"),
    ("[]", "the model file gives no sampling period ([identification] sampling_period_s, "
           "written by identify); give --sampling-period S")])
def test_a_model_file_without_one_period_asks_for_it(tmp_path, periods, words):
    from hammerstein.exceptions import PresetError
    path = _hysteresis_model(tmp_path, periods)
    with pytest.raises(PresetError) as err:
        load_actuator(str(path))
    assert str(err.value) == f"{path}: {words}"


def test_export_takes_a_model_files_records_period_as_compensate_does(tmp_path, capsys):
    # compensate used [identification] sampling_period_s; export said "a model file without a
    # sampling period; give --sampling-period SECONDS"
    import re
    from hammerstein.cli.main import main
    path = _hysteresis_model(tmp_path, "[1e-4, 1e-4]")
    assert main(["export", str(path), "--target", "c", "--name", "m", "--out",
                 str(tmp_path / "gen")]) == 0, capsys.readouterr().err
    header = (tmp_path / "gen" / "m.h").read_text()
    assert re.search(r"#define m_SAMPLING_PERIOD 0\.0001\n", header), header[:2000]
