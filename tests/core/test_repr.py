"""print(model) and print(compensator): one concise line, sizes and key numbers, no arrays."""

import numpy as np
import pytest

import hammerstein as hs


def _builders(plant):
    model = plant.hysteresis
    return {
        "PrandtlIshlinskii": lambda: model.components[0][0],
        "MultivariablePI": lambda: model,
        "HammersteinPlant": lambda: plant,
        "InverseMultiplicativeCompensator": lambda: hs.InverseMultiplicativeCompensator(model),
        "StaticGainCompensator": lambda: hs.StaticGainCompensator(model),
        "PerAxisInverseCompensator": lambda: hs.PerAxisInverseCompensator(model),
        "HammersteinCompensator": lambda: hs.HammersteinCompensator(model, plant.dynamics),
    }


@pytest.mark.parametrize("cls", ["PrandtlIshlinskii", "MultivariablePI", "HammersteinPlant",
                                 "InverseMultiplicativeCompensator", "StaticGainCompensator",
                                 "PerAxisInverseCompensator", "HammersteinCompensator"])
def test_repr_is_one_short_line_naming_class_and_sizes(preset_plant, cls):
    obj = _builders(preset_plant)[cls]()
    text = repr(obj)
    assert text.startswith(f"{cls}(") and text.endswith(")")
    assert "\n" not in text and len(text) < 400
    assert "array(" not in text and "[[" not in text           # no matrix dump
    if cls == "PrandtlIshlinskii":
        assert f"{obj.n_hysterons} hysterons" in text
        assert f"{obj.thresholds[-1]:.4g} V" in text
    else:
        model = preset_plant.hysteresis
        n = sum(c.n_hysterons for row in model.components for c in row
                if isinstance(c, hs.PrandtlIshlinskii))        # counted from the components
        assert f"{model.n_outputs}x{model.n_inputs} PI" in text and f"{n} hysterons" in text
    if cls in ("InverseMultiplicativeCompensator", "StaticGainCompensator"):
        assert f"{np.diag(obj.K)[0]:.4g}" in text                 # the gain, in µm/V
    if cls == "HammersteinCompensator":
        assert f"order {preset_plant.dynamics.nstates}" in text
        assert f"preview {obj.preview_samples} samples" in text


def test_repr_of_a_model_with_gains_and_absent_components():
    pi = hs.PrandtlIshlinskii([0.0, 1.0], [1.0, 0.5])
    model = hs.MultivariablePI([[pi, 0.25], [None, pi]], input_names=["ux", "uy"],
                               output_names=["x", "y"])
    assert repr(model) == ("MultivariablePI(2x2 PI (ux, uy -> x, y), 4 hysterons; "
                           "x: ux PI(2), uy gain 0.25; y: ux -, uy PI(2))")


def test_repr_of_a_preisach_plant_with_creep_is_one_short_line():
    # the realistic preset: Preisach components (hundreds of weights) and nine creep lags
    # per output; printed as words, the creep by its lags and settled gain
    plant = hs.load_plant("realistic-2dof")
    text = repr(plant)
    assert "\n" not in text and len(text) < 400 and "0.0075" not in text
    assert "MultivariableHysteresis(2x2 (ux, uy -> x, y), " in text
    assert f"{plant.hysteresis.n_hysterons} states" in text and "ux Preisach(28 levels)" in text
    gain = plant.creep[0].static_gain                 # 1 + 9 x 0.0075
    assert gain == pytest.approx(1.0675) and f"settled gain {gain:.4g}" in text
    assert "creep on x (9 lags 0.01..100 s" in text
