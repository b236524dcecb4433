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


@pytest.mark.slow
def test_a_plant_identified_from_the_compensators_records_is_said_to_share_g(tmp_path, capsys):
    # the user's route: identify a preset from measured files, then a scenario whose plant is
    # that preset and whose compensator identifies from the same files: one model, one G
    import numpy as np

    from hammerstein.cli.main import main
    from hammerstein.scenario.identification import excitation_records
    from hammerstein.scenario.identify_tables import identify_table

    plant = load_plant("realistic-2dof")
    recs = excitation_records(plant, identify_table({
        "records": "excitation", "model": "classical", "frequency": 5.0, "hold": 0.25,
        "multisine_periods": 2}))
    names = {}
    for kind in ("hysteresis", "dynamics"):
        for i, rec in enumerate(recs[kind]):
            path = tmp_path / f"{kind}-{i}.csv"
            data = np.column_stack([rec.timepts, rec.u.T, rec.y.T])
            np.savetxt(path, data, delimiter=",", comments="",
                       header=",".join(["t", *rec.input_names, *rec.output_names]))
            names.setdefault(kind, []).append(path.name)
    assert main(["identify", *[str(tmp_path / n) for n in names["hysteresis"]], "--inputs",
                 "ux,uy", "--outputs", "x,y", "--time", "t", "--model", "classical",
                 "--dynamics", "--dynamics-records", *[str(tmp_path / n) for n in names["dynamics"]],
                 "--out", str(tmp_path / "id.toml")]) == 0
    capsys.readouterr()
    listed = lambda files: "[" + ", ".join(f'"{n}"' for n in files) + "]"  # noqa: E731
    path = tmp_path / "stage.toml"
    path.write_text(
        'name = "stage"\n[plant]\npreset = "id.toml"\n[compensator]\nkind = "hammerstein"\n'
        'model = "identified"\ndynamics = "identified"\n[compensator.identify]\n'
        f'records = "files"\nmodel = "classical"\nhysteresis_records = {listed(names["hysteresis"])}\n'
        f'dynamics_records = {listed(names["dynamics"])}\n'
        '[[cases]]\nname = "circle"\nreference = { kind = "circle", radius = 10.0, '
        'frequency = 20.0, periods = 3 }\n')
    out = run_scenario(path, tmp_path / "out")
    assert out.ok, out.error
    md = (out.out_dir / "report.md").read_text()
    lines = [ln for ln in md.splitlines() if ln.startswith(ONE_MODEL)]
    assert len(lines) == 2, md
    assert "in every compensated case" in lines[0]
    assert "the figure compares G with itself" in lines[1] and "`circle`" in lines[1]
    assert md.index("## Identified dynamics") < md.index(lines[1])
