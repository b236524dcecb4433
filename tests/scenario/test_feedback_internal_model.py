"""Internal-model (resonant) elements in a designed axis: internal_model_hz."""

import textwrap

import numpy as np
import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.scenario.feedback import run_feedback_scenario
from hammerstein.scenario.validate import validate_scenario

SCENARIO = """
name = "im"
kind = "feedback"
[plant]
preset = "realistic-2dof"
[compensator]
kind = "preisach-inverse"
model = "plant"
[[cases]]
name = "circle"
reference = {{ kind = "circle", radius = 15.0, frequency = 20.0, periods = 8 }}
settle_periods = 6
[feedback]
modes = ["feedback"]
sensor = {{ noise_nm = 0.0, bandwidth_hz = 5000.0, delay = 1 }}
[feedback.axes.x]
kind = "pi-notch"
crossover_hz = 150.0
notch_hz = 450.0
{x}
[feedback.axes.y]
kind = "pi-notch"
crossover_hz = 150.0
notch_hz = 420.0
{y}
"""


def _spec(tmp_path, x="", y=""):
    path = tmp_path / "im.toml"
    path.write_text(textwrap.dedent(SCENARIO.format(x=x, y=y)), encoding="utf-8")
    return validate_scenario(path)


def _harmonics(result):
    """Amplitudes of the error's fundamental and 3rd harmonic over the last 2 periods [µm]."""
    P = result.case.period_samples
    e = (result.reference - result.outputs)[:, -2 * P:]
    F = np.abs(np.fft.rfft(e, axis=1)) * 2 / e.shape[1]
    return F[:, 2], F[:, 6]


def test_the_internal_model_rejects_its_frequencies(tmp_path):
    """|S| = 0 at the resonators' frequencies: the fundamental and the 3rd harmonic of the
    circle's error fall to a few % of the PI + notch's, the rest of the loop unchanged."""
    plain = run_feedback_scenario(_spec(tmp_path))[0]
    im = "internal_model_hz = [20.0, 60.0]"
    spec = _spec(tmp_path, im, im)
    with_im = run_feedback_scenario(spec)[0]
    f1, f3 = _harmonics(plain)
    g1, g3 = _harmonics(with_im)
    assert np.all(f1 > 0.3)                       # the PI + notch leaves ~1-2 µm at 20 Hz
    assert np.all(g1 < 0.03 * f1) and np.all(g3 < 0.1 * f3)
    assert all("internal model at 20, 60 Hz" in d for d in spec.analysis["descriptions"])
    assert spec.analysis["linear_stable"]


def test_problems_of_the_internal_model_keys(tmp_path):
    with pytest.raises(ScenarioError) as exc:
        _spec(tmp_path, "internal_model_hz = [-1.0]", "internal_model_decay = 0")
    text = str(exc.value)
    assert "feedback.axes.x.internal_model_hz" in text
    assert "feedback.axes.y.internal_model_decay" in text


def test_an_internal_model_above_nyquist_is_refused(tmp_path):
    spec = _spec(tmp_path, "internal_model_hz = [20.0, 12000.0]")
    with pytest.raises(ScenarioError, match=r"axes\.x\.internal_model_hz: 12000 Hz is not below"):
        run_feedback_scenario(spec)
