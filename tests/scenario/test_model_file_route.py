"""A model file in a scenario carries what `hammerstein compensate` takes from it.

Regressions: ``model = "<preset>"`` with ``kind = "hammerstein"`` inverted the plant's
true G and dropped the preset's [creep], while ``compensate`` on the same file inverts
both (a tester's settled drives 12 mV apart); and the report said "creep not
inverted" for a records table whose creep_records it had inverted.
"""

import shutil
from pathlib import Path

import numpy as np

from hammerstein.io.presets import load_creep, load_plant, save_model
from hammerstein.report.scenario import compensator_summary
from hammerstein.scenario.hardware_route import compensate_reference
from hammerstein.scenario.identification import ResolveContext
from hammerstein.scenario.registry import build_compensator, model_file_dynamics
from hammerstein.signals.references import circle

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
PRESET = SCENARIOS / "presets" / "realistic-gpi.toml"      # [model], [dynamics], [creep]


def _inputs(comp, ref):
    return comp.simulate(ref)[0]


def test_a_preset_as_model_inverts_its_dynamics_and_creep_as_compensate_does(tmp_path):
    shutil.copy(PRESET, tmp_path / "actuator.toml")
    plant = load_plant(tmp_path / "actuator.toml")
    spec = {"kind": "hammerstein", "model": "actuator.toml"}
    comp = build_compensator(spec, plant, ResolveContext(tmp_path))
    creep = load_creep(tmp_path / "actuator.toml", plant.hysteresis.output_names)
    assert comp.creep is not None and [c.static_gain for c in comp.creep] == \
        [c.static_gain for c in creep]
    _, ref = circle(plant.sampling_period, radius=10.0, frequency=20.0, periods=2)
    cli, _ = compensate_reference(plant, ref, period_samples=None, kind="hammerstein")
    u, u_cli = _inputs(comp, ref), _inputs(cli, ref)
    assert np.max(np.abs(u - u_cli)) <= 1e-9 * np.max(np.abs(u_cli))
    # the table the report shows: the file's G and creep, said so
    shown = model_file_dynamics(spec, tmp_path)
    assert shown["dynamics"] == "actuator.toml"
    words = compensator_summary({**shown, "creep": "auto"}, comp)
    assert "the creep of actuator.toml inverted" in words and "dynamics G from actuator.toml" in words


def test_a_model_file_without_dynamics_keeps_the_plant_g(tmp_path):
    save_model(load_plant(PRESET).hysteresis, tmp_path / "m.toml")     # [model] only
    spec = {"kind": "hammerstein", "model": "m.toml"}
    assert model_file_dynamics(spec, tmp_path) is spec
    assert model_file_dynamics({**spec, "dynamics": "plant"}, tmp_path)["dynamics"] == "plant"


def test_the_creep_words_follow_the_built_compensator():
    files = {"kind": "hammerstein", "model": "identified", "dynamics": "identified", "creep": "auto",
             "identify": {"records": "files", "hysteresis_records": ["h.csv"],
                          "creep_records": ["c.csv"]}}

    class Built:
        creep = ["a creep"]

    assert "the identified creep inverted" in compensator_summary(files)
    assert "the identified creep inverted" in compensator_summary(files, Built())
    Built.creep = None
    assert "creep not inverted" in compensator_summary(files, Built())
