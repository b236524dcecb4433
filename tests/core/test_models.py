"""One actuator model type: the class registry, the kinds each class takes, the default kind.

Expectations are derived independently of the rules they check: a chosen gain
is judged by running its law through the model (the fixed point it reaches),
the exact inverse by the model's own output, and the kinds that work by
building each of them.
"""

from pathlib import Path

import numpy as np
import pytest

from hammerstein.compensation.compensators import convergence_report
from hammerstein.compensation.model_classes import MODEL_CLASSES, kind_problem, model_class
from hammerstein.compensation.kind_choice import choose_kind, convergent_gain, law_radius
from hammerstein.io.presets import load_plant
from hammerstein.exceptions import CompensatorError
from hammerstein.scenario.registry import COMPENSATORS, build_compensator

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
#: One example per registered class: a class added to MODEL_CLASSES without one fails
#: test_every_registered_class_has_an_example, and with one runs every registry-wide test.
PLANTS = {"classical": "rakotondrabe-2dof", "preisach": "realistic-2dof",
          "generalized": str(SCENARIOS / "presets" / "realistic-gpi.toml"),
          "mixed": "realistic-2dof's Preisach x with realistic-gpi's generalised-PI y"}


def _mixed_plant():
    """Direct paths of two classes: realistic-2dof's Preisach x, realistic-gpi's y."""
    from hammerstein.models.plant import HammersteinPlant
    from hammerstein.models.preisach import MultivariableHysteresis
    p, g = load_plant(PLANTS["preisach"]), load_plant(PLANTS["generalized"])
    a, b = p.hysteresis, g.hysteresis
    hyst = MultivariableHysteresis([[a.components[0][0], None], [None, b.components[1][1]]],
                                   a.input_names, a.output_names,
                                   [a.input_amplitude[0], b.input_amplitude[1]])
    return HammersteinPlant(hyst, p.sampling_period, p.dynamics, name="mixed")


@pytest.fixture(scope="module")
def plants():
    return {k: (_mixed_plant() if k == "mixed" else load_plant(v)) for k, v in PLANTS.items()}


def _slow_circle(model, n=4000, fraction=0.5):
    """A slow circle over ``fraction`` of each output's reach from the model's own major loop."""
    t = np.arange(n) / n
    amp = np.asarray(model.input_amplitude, dtype=float)
    u = np.zeros((model.n_inputs, 400))
    reach = []
    for k in range(model.n_inputs):
        u[:] = 0.0
        u[k] = amp[k] * np.sin(2 * np.pi * np.arange(400) / 400)
        reach.append(np.ptp(model.simulate(u)[0][k]) / 2)
    r = fraction * min(reach)
    return np.vstack([r * np.sin(2 * np.pi * 2 * t), r * (1 - np.cos(2 * np.pi * 2 * t))][:model.n_outputs])


def test_every_bundled_class_is_found(plants):
    for name, plant in plants.items():
        assert model_class(plant.hysteresis).name == name


def test_every_registered_class_has_an_example():
    """A new class is one module and one entry; its example here makes the registry-wide
    tests below run on it (they ran on a fixed list: an incomplete new class passed)."""
    assert set(PLANTS) == set(MODEL_CLASSES), "add an example preset of the new class to PLANTS"


@pytest.mark.parametrize("name", list(MODEL_CLASSES))
def test_a_class_builds_what_it_lists_and_refuses_the_rest(plants, name):
    """Through its entry alone: each listed rate-independent kind builds and runs, each other
    rate-independent kind is refused naming the listed ones (the entry's list, not the
    builder, decides), and the exact inverse exists exactly where the entry says and
    inverts the model."""
    from hammerstein.compensation.model_classes import RATE_INDEPENDENT_KINDS
    model = plants[name].hysteresis
    entry = MODEL_CLASSES[name]
    yr = _slow_circle(model, 400)
    for kind in RATE_INDEPENDENT_KINDS:
        if kind in entry.kinds:
            comp = entry.compensator(model, kind, check="ignore") if kind in ("multivariable", "diagonal") \
                else entry.compensator(model, kind)
            assert np.all(np.isfinite(comp.simulate(yr)[0]))
        else:
            with pytest.raises(CompensatorError, match="kinds that work with it"):
                entry.compensator(model, kind)
    inverse = entry.exact_inverse(model)
    assert (inverse is None) == (entry.exact_inverse_kind is None)
    if inverse is not None:
        assert entry.exact_inverse_kind in entry.kinds
        y, _ = model.simulate(inverse.simulate(yr)[0])
        assert np.max(np.abs(y - yr)) < 1e-6 * np.max(np.abs(yr))


def test_registry_kinds_are_compensator_kinds():
    for entry in MODEL_CLASSES.values():
        assert set(entry.kinds) <= set(COMPENSATORS)


@pytest.mark.parametrize("name", list(MODEL_CLASSES))
def test_every_listed_rate_independent_kind_builds(plants, name):
    plant = plants[name]
    for kind in model_class(plant.hysteresis).kinds:
        if kind in ("ilc", "hammerstein"):
            continue
        spec = {"kind": kind, "model": "plant"}
        if kind in ("multivariable", "diagonal"):
            spec["check"] = "ignore"
        comp = build_compensator(spec, plant, Path("."))
        u, _ = comp.simulate(_slow_circle(plant.hysteresis, 400))
        assert np.all(np.isfinite(u))


def test_a_kind_that_does_not_work_names_those_that_do(plants):
    text = kind_problem(plants["classical"].hysteresis, "preisach-inverse")
    assert "preisach-inverse" in text and "multivariable" in text and "per-axis" in text
    with pytest.raises(CompensatorError, match="kinds that work with it: .*per-axis"):
        build_compensator({"kind": "preisach-inverse", "model": "plant"}, plants["classical"],
                          Path("."))
    # no dynamics: hammerstein is refused, and the message does not name it as a way out
    text = kind_problem(plants["generalized"].hysteresis, "hammerstein", has_dynamics=False)
    works = text.split("kinds that work with it: ")[1]
    assert "hammerstein" not in works and "preisach-inverse" in works
    assert kind_problem(plants["generalized"].hysteresis, "hammerstein") is None


def test_law_radius_of_a_classical_pi_is_the_convergence_report(plants):
    model = plants["classical"].hysteresis
    for gain in ("secant", "midpoint", "identity"):
        assert law_radius(model, gain) == pytest.approx(convergence_report(model, gain).max_radius)


def test_the_convergent_gain_reaches_the_fixed_point(plants):
    """Its law, iterated through the model, makes the model's output equal the reference."""
    model = plants["classical"].hysteresis
    gain, radius, radii = convergent_gain(model)
    assert radius < 1 and radius <= 1.05 * min(radii.values())
    comp = model_class(model).compensator(model, "multivariable", gain=gain, iterations=30)
    yr = _slow_circle(model)
    u, _ = comp.simulate(yr)
    y, _ = model.simulate(u)
    assert np.max(np.abs(y[:, 200:] - yr[:, 200:])) < 1e-3 * np.max(np.abs(yr))


@pytest.mark.parametrize("name", [n for n, e in MODEL_CLASSES.items() if e.exact_inverse_kind])
def test_default_without_dynamics_is_the_exact_inverse(plants, name):
    model = plants[name].hysteresis
    choice = choose_kind(model, has_dynamics=False)
    assert choice.kind == "preisach-inverse" and "exact" in choice.reason
    comp = build_compensator({"kind": choice.kind, "model": "plant", **choice.options},
                             plants[name], Path("."))
    yr = _slow_circle(model)
    y, _ = model.simulate(comp.simulate(yr)[0])
    assert np.max(np.abs(y - yr)) < 1e-6


@pytest.mark.parametrize("name", list(MODEL_CLASSES))
def test_default_with_dynamics_is_hammerstein_and_builds(plants, name):
    plant = plants[name]
    choice = choose_kind(plant.hysteresis, has_dynamics=True)
    assert choice.kind == "hammerstein"
    assert choice.note().startswith("note: kind = hammerstein because ")
    assert "(G inverted by ZPETC)" in choice.reason
    stable = choose_kind(plant.hysteresis, has_dynamics=True, inversion="stable")
    assert "(G inverted by the stable inversion)" in stable.reason and stable.kind == "hammerstein"
    comp = build_compensator({"kind": "hammerstein", "model": "plant", **choice.options}, plant,
                             Path("."))
    assert comp.preview_samples >= 0


def test_default_classical_without_dynamics_is_a_convergent_law(plants):
    model = plants["classical"].hysteresis
    choice = choose_kind(model, has_dynamics=False)
    assert choice.kind == "multivariable"
    assert law_radius(model, choice.options["gain"]) < 1
