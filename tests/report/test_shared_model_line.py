"""report.md says when the plant is the compensator's own model.

A scenario whose plant was the preset its compensator inverted reported 0.002 %
errors where the user's actuator showed 6.4 %, without saying that the numbers were
the compensator's self-consistency.
"""

import pytest

from hammerstein.io.presets import load_plant, save_model
from hammerstein.runner import run_scenario

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]

ONE_MODEL = "**One model:**"

SCENARIO = """
name = "{name}"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
{model}
[[cases]]
name = "circle"
reference = {{ kind = "circle", radius = 15.0, frequency = 50.0, periods = 3 }}
[[cases]]
name = "drive"
drive = {{ kind = "sine", input = "ux", amplitude = 5.0, frequency = 50.0, periods = 2 }}
"""


def _report(tmp_path, name, model):
    path = tmp_path / f"{name}.toml"
    path.write_text(SCENARIO.format(name=name, model=model))
    out = run_scenario(path, tmp_path / "out")
    assert out.ok, out.error
    return (out.out_dir / "report.md").read_text()


def _saved_model(tmp_path, scale):
    """The plant's model saved to a file, its first weight scaled by ``scale``."""
    save_model(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis, tmp_path / "m.toml")
    text = (tmp_path / "m.toml").read_text()
    head, tail = text.split("weights = [\n    4.3,", 1)
    (tmp_path / "m.toml").write_text(f"{head}weights = [\n    {4.3 * scale!r},{tail}")
    return 'model = "m.toml"'


@pytest.mark.parametrize("model", ['model = "plant"', "copy"], ids=["plant", "same-model-file"])
def test_a_plant_that_is_the_compensators_model_is_said_so(tmp_path, model):
    if model == "copy":
        model = _saved_model(tmp_path, 1.0)
    md = _report(tmp_path, "one", model)
    lines = [ln for ln in md.splitlines() if ln.startswith(ONE_MODEL)]
    assert len(lines) == 1, md
    # the one compensated case (the drive has no compensator)
    assert "in every compensated case" in lines[0]
    assert "not the error it would leave on the actuator" in lines[0]
    assert "docs/hardware.md" in lines[0]
    # said where the numbers are: after the cases table, before the metrics
    assert md.index("## Cases") < md.index(ONE_MODEL) < md.index("## Metrics")


def test_a_compensator_model_other_than_the_plant_is_not_said_to_be_it(tmp_path):
    # one weight of one hysteron 1 % off: a different model
    md = _report(tmp_path, "other", _saved_model(tmp_path, 1.01))
    assert ONE_MODEL not in md


@pytest.mark.slow
def test_a_bundled_realistic_scenario_is_not_said_to_share_its_model(tmp_path):
    # realistic-2dof identifies its compensator's Preisach model on the actuator: one case
    text = (ROOT / "scenarios" / "realistic-2dof.toml").read_text().split("[[cases]]")[0]
    path = tmp_path / "realistic.toml"
    path.write_text(text + '[[cases]]\nname = "circle"\nreference = { kind = "circle", '
                           'radius = 15.0, frequency = 20.0, periods = 4 }\nsettle_periods = 2\n')
    out = run_scenario(path, tmp_path / "out")
    assert out.ok, out.error
    md = (out.out_dir / "report.md").read_text()
    assert "## Identified dynamics" in md and ONE_MODEL not in md
