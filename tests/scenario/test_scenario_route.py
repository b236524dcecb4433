"""A scenario's drive is the one ``hammerstein compensate`` writes from the compensator's model.

The scenario's ``[plant]`` is only what the drive is played on. Regressions on a plant
that starts as ``compensate`` does (an ``[amplifier]``, here added to the bundled
``realistic-gpi`` preset: generalised-PI paths, three modes, creep):

* a compensator whose model is not the plant's (a tester's, identified with ``model =
  "generalized"`` on a Preisach plant) faded its reference in from the plant's rest output
  over the plant's modes' decay (-2.896 µm over 706 samples instead of the model's own
  -2.857 µm over 721: drives 0.245 V apart from ``compensate``'s on that model);
* ``kind = "hammerstein"`` without ``model =`` did not invert the plant's creep, which
  ``compensate`` on the same preset inverts (a tester's 50 Hz sine: 1.63 % instead of
  0.099 %, drives 0.965 V apart).
"""

from pathlib import Path

import numpy as np

from hammerstein.compensation.drive import compensator_rest
from hammerstein.io.presets import load_plant
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.hardware_route import compensate_reference
from hammerstein.scenario.resolve import load_scenario

PRESET = Path(__file__).resolve().parents[2] / "scenarios" / "presets" / "realistic-gpi.toml"
AMPLIFIER = "\n[amplifier]\nrange = [-10.0, 10.0]\nslew_rate = 1e7\n"
CIRCLE = "{ kind = \"circle\", radius = 10.0, frequency = 50.0, periods = 12 }"
#: the model file's x mode damped 2.5 times less (a longer fade) and its x path's
#: loading envelope shifted by 1 µm (another rest output) from the plant's
SLOWER_X_MODE = ("[-5700683.502, -334.2654583,", "[-5700683.502, -133.7061833,")
OTHER_ENVELOPE = ("gamma_l = [14.0, 0.085, 0.12, 0.0]", "gamma_l = [14.0, 0.085, 0.12, 1.0]")


def _scenario(tmp_path, compensator):
    text = PRESET.read_text(encoding="utf-8")
    (tmp_path / "plant.toml").write_text(text + AMPLIFIER, encoding="utf-8")
    model = text.replace(*SLOWER_X_MODE).replace(*OTHER_ENVELOPE)
    assert model != text
    (tmp_path / "model.toml").write_text(model + AMPLIFIER, encoding="utf-8")
    path = tmp_path / "s.toml"
    path.write_text(f'[plant]\npreset = "plant.toml"\n[compensator]\nkind = "hammerstein"\n'
                    f'{compensator}[[cases]]\nname = "c"\nreference = {CIRCLE}\n',
                    encoding="utf-8")
    return path


def _drives(path, on):
    case = load_scenario(path).cases[0]
    result = run_case(case)
    model = load_plant(path.parent / on)
    comp, drive = compensate_reference(model, case.signal, case.period_samples,
                                       kind="hammerstein", limits="warn")
    return case, result, comp, drive


def test_the_default_compensator_inverts_the_plant_creep_as_compensate_does(tmp_path):
    case, result, comp, drive = _drives(_scenario(tmp_path, ""), "plant.toml")
    assert case.compensator.creep is not None and comp.creep is not None
    assert [c.static_gain for c in case.compensator.creep] == [c.static_gain for c in comp.creep]
    u = np.asarray(drive.inputs)
    assert np.max(np.abs(result.inputs - u)) <= 1e-9
    assert case.start_fade == drive.fade_samples


def test_a_compensator_model_other_than_the_plant_drives_as_compensate_on_it(tmp_path):
    case, result, comp, drive = _drives(_scenario(tmp_path, 'model = "model.toml"\n'),
                                        "model.toml")
    # the fade starts at the model's own rest output and lasts as long as on the model
    model, plant = load_plant(tmp_path / "model.toml"), case.plant
    start = compensator_rest(model.hysteresis, comp)
    assert np.max(np.abs(start - compensator_rest(plant.hysteresis, comp))) > 1.0   # µm
    assert np.allclose(result.reference[:, 0], start, atol=1e-9)
    _, on_plant = compensate_reference(plant, case.signal, case.period_samples,
                                       kind="hammerstein", limits="warn")
    assert drive.fade_samples != on_plant.fade_samples
    assert case.start_fade == drive.fade_samples
    u = np.asarray(drive.inputs)
    assert np.max(np.abs(result.inputs - u)) <= 1e-9


def test_the_report_names_the_exact_static_inverse_not_the_gain_law(tmp_path):
    from hammerstein.report.compensator_words import _compensator_title
    from hammerstein.report.scenario import compensator_summary
    case = load_scenario(_scenario(tmp_path, "")).cases[0]
    assert case.compensator.exact_static     # generalised PI: the model's exact inverse runs
    words = compensator_summary(case.compensator_spec, case.compensator)
    title = _compensator_title(case)
    for text in (words, title):
        assert "midpoint gain" not in text and "3 iterations" not in text, text
    assert "the exact inverse of its model" in words
    # a classical PI runs the law: its gain and iterations are still named
    pi = load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "default.toml").cases
    comp = next(c for c in pi if c.compensator is not None)
    assert not getattr(comp.compensator, "exact_static", False)
    assert "gain" in compensator_summary(comp.compensator_spec, comp.compensator)


def test_a_monte_carlo_study_names_the_plant_creep_it_inverts():
    # the study's compensator is built from the table the report names: without model = its
    # G is the nominal plant's, and so is the creep (realistic-2dof creeps)
    from hammerstein.report.scenario import compensator_summary
    from hammerstein.scenario.validate import validate_scenario
    scenario = validate_scenario(PRESET.parents[1] / "robustness-realistic.toml")
    assert scenario.compensator_spec["creep"] == "plant"
    assert "the plant's true creep inverted" in compensator_summary(scenario.compensator_spec)
