"""A scenario on an identified or hardware-like plant starts as ``compensate`` starts its drive.

The fixture is the bundled rakotondrabe-2dof preset made unipolar: an
``[amplifier]`` of 0..100 V and an output offset of (4, 3) µm, what an
identified preset carries (its output at 0 V is not 0 µm). A user's four-axis
stage of that kind drove every input to its lower limit: the scenario faded
its reference in from 0 µm, which needs negative voltages, where ``compensate``
fades in from the model's rest output.
"""

from pathlib import Path

import numpy as np
import pytest

from hammerstein.io.presets import resolve_preset
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.hardware_route import compensate_reference
from hammerstein.scenario.resolve import load_scenario
from hammerstein.scenario.schema import ScenarioError

OFFSET = (4.0, 3.0)       # µm: the fixture's output at 0 V
CIRCLE = ('{ kind = "circle", radius = 10.0, frequency = 50.0, periods = 10, '
          'center = [30.0, 25.0] }')


def _scenario(tmp_path, compensator="", preset="uni.toml"):
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    text = text.replace('output_unit = "µm"\n',
                        f'output_unit = "µm"\noutput_offset = [{OFFSET[0]}, {OFFSET[1]}]\n', 1)
    (tmp_path / "uni.toml").write_text(text + '\n[amplifier]\nrange = [0.0, 100.0]\n'
                                              'slew_rate = 1e6\n')
    path = tmp_path / "s.toml"
    path.write_text(f'[plant]\npreset = "{preset}"\n[compensator]\nkind = "hammerstein"\n'
                    f'model = "plant"\n{compensator}'
                    f'[[cases]]\nname = "c"\nreference = {CIRCLE}\n')
    return path


def test_the_drive_is_compensates_faded_in_from_the_rest_output(tmp_path):
    case = load_scenario(_scenario(tmp_path)).cases[0]
    result = run_case(case)
    # the reference is faded in from the model's output at 0 V (the fixture's offset, the
    # PI's output at 0 V being 0), not from 0 µm: the first commanded voltages are rest, 0 V
    assert np.allclose(result.reference[:, 0], OFFSET, atol=1e-12)
    assert np.all(np.abs(result.inputs[:, 0]) <= 1e-9)
    assert not any("needs" in w for w in result.warnings), result.warnings
    # and it is compensate's drive, sample for sample, over its default fade-in (at least
    # MIN_FADE_S = 20 ms, 400 samples at 20 kHz, more than the one period of old)
    _, drive = compensate_reference(case.plant, case.signal, case.period_samples,
                                    kind="hammerstein", limits="warn")
    assert np.max(np.abs(np.asarray(drive.inputs) - result.inputs)) <= 1e-9
    assert case.start_fade == drive.fade_samples >= 400


def test_a_fade_in_longer_than_the_settling_is_taken_and_skipped_by_the_metrics(tmp_path):
    # 0.1 s = 2000 samples, five periods of the 50 Hz circle: on such a plant the metrics skip
    # the fade-in, so it is no longer refused as longer than the one settling period
    case = load_scenario(_scenario(tmp_path, "fade_in = 0.1\n")).cases[0]
    result = run_case(case)
    assert case.start_fade == 2000
    assert any("metrics start at its end, after 5 periods" in n for n in case.notes), case.notes
    # the metrics are those of the record after the fade, computed here from the outputs
    e = np.linalg.norm(result.outputs[:, 2000:] - case.signal[:, 2000:], axis=0)
    rows = {r["metric"]: r["value"] for r in result.metrics if r["channel"] == "x+y"}
    assert rows["max_euclidean_error"] == pytest.approx(float(e.max()), rel=1e-12)


def test_a_fade_in_as_long_as_the_record_is_refused(tmp_path):
    with pytest.raises(ScenarioError) as err:
        load_scenario(_scenario(tmp_path, "fade_in = 0.2\n"))
    assert "cases[0].compensator.fade_in: 0.2 s leaves nothing of the 0.2 s record" in str(err.value)


@pytest.mark.parametrize("other", ['gain = "nope"', "iterations = -3", "cutoff_hz = -1.0"])
def test_a_fade_in_as_long_as_the_record_is_said_beside_another_bad_value(tmp_path, other):
    # every problem at once: the too-long fade_in was said only once the other value was right
    with pytest.raises(ScenarioError) as err:
        load_scenario(_scenario(tmp_path, f"fade_in = 0.2\n{other}\n"))
    text = str(err.value)
    assert f"compensator.{other.split()[0]}: expected" in text
    assert "cases[0].compensator.fade_in: 0.2 s leaves nothing of the 0.2 s record" in text
    # a second case, its own fade_in too long as well: named although the first case's was
    path = _scenario(tmp_path, f"{other}\n")
    path.write_text(path.read_text() + '[[cases]]\nname = "d"\nreference = ' + CIRCLE
                    + '\ncompensator = { fade_in = 0.2 }\n[[cases]]\nname = "e"\nreference = '
                    + CIRCLE + '\ncompensator = { fade_in = 0.25 }\n')
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert "cases[1].compensator.fade_in: 0.2 s leaves nothing" in text, text
    assert "cases[2].compensator.fade_in: 0.25 s leaves nothing" in text, text


def test_a_cases_own_fade_in_is_named_beside_a_bad_top_level_one(tmp_path):
    # a reviewer's: the top table's bad fade_in silenced the case's own, too long one
    path = _scenario(tmp_path, "fade_in = -1.0\n")
    text = path.read_text().replace('[[cases]]\nname = "c"\nreference = ' + CIRCLE + '\n', "")
    path.write_text(text + '[[cases]]\nname = "a"\nreference = ' + CIRCLE
                    + '\ncompensator = { fade_in = 0.25, iterations = -3 }\n[[cases]]\nname = "b"'
                    '\nreference = ' + CIRCLE + '\ncompensator = { fade_in = 0.25 }\n')
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert "compensator.fade_in: expected" in text, text
    assert "cases[0].compensator.fade_in: 0.25 s leaves nothing" in text, text
    assert "cases[1].compensator.fade_in: 0.25 s leaves nothing" in text, text


def test_a_paper_preset_keeps_the_scenarios_own_start(tmp_path):
    # no amplifier, 0 µm at 0 V: the fade-in is the settling period's, from 0 µm, and a longer
    # one is still refused (the metrics would measure it)
    path = _scenario(tmp_path, preset="rakotondrabe-2dof")
    case = load_scenario(path).cases[0]
    result = run_case(case)
    assert case.start_fade is None and np.all(result.reference[:, 0] == 0.0)
    path.write_text(path.read_text().replace('model = "plant"\n', 'model = "plant"\nfade_in = 0.1\n'))
    with pytest.raises(ScenarioError, match="longer than the 1 settling periods"):
        load_scenario(path)


def test_a_feedback_scenario_still_refuses_a_fade_in_longer_than_the_settling(tmp_path):
    # a guard (old code refused it too): the feedback route measures from the settling
    # periods on, on every plant, so the refusal stays there
    path = _scenario(tmp_path, "fade_in = 0.1\n")
    text = path.read_text().replace("[plant]", 'kind = "feedback"\n[plant]')
    path.write_text(text + '[feedback]\n[feedback.axes.x]\nkind = "pi-notch"\ncrossover_hz = 150.0\n'
                           'notch_hz = 310.0\n[feedback.axes.y]\nkind = "pi-notch"\n'
                           'crossover_hz = 150.0\nnotch_hz = 290.0\n')
    with pytest.raises(ScenarioError, match=r"compensator.fade_in: 0.1 s is longer than the 1 "
                                            r"settling periods \(0.02 s\)"):
        load_scenario(path)
