"""A model file in a scenario carries what `hammerstein compensate` takes from it.

Regressions: ``model = "<preset>"`` with ``kind = "hammerstein"`` inverted the plant's
true G and dropped the preset's [creep], while ``compensate`` on the same file inverts
both (a tester's settled drives 12 mV apart); and the report said "creep not
inverted" for a records table whose creep_records it had inverted.
"""

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from hammerstein.exceptions import PresetError
from hammerstein.io.presets import load_creep, load_plant, save_model
from hammerstein.report.scenario import compensator_summary
from hammerstein.scenario.hardware_route import compensate_reference, compensator_plant, start_drive
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


#: realistic-b with a Preisach cross-coupling, every Preisach path starting after a demagnetising
#: cycle, and an amplifier whose range and slew the drive is shaped into
_AMPLIFIER = """
[amplifier]
source = "records"

[amplifier.ux]
range = [-10.0, 10.0]
slew_rate = 2000.0

[amplifier.uy]
range = [-10.0, 10.0]
slew_rate = 2000.0
"""


def _shaped_preset(path):
    s = (SCENARIOS / "presets" / "realistic-b.toml").read_text()
    s = s.replace('kind = "preisach"\n', 'kind = "preisach"\ndemagnetised = 10.0\n')
    s = s.replace('kind = "polynomial"\ncoefficients = [0.08, -0.028]',
                  'kind = "preisach"\ndemagnetised = 10.0\nrange = [-10.5, 10.5]\nn_levels = 10\n'
                  'reversible = [0.05]\ndensity = { kind = "gaussian", total = 1.5, bias = 2.0, '
                  'bias_width = 3.0, tilt = 0.5, coercivity = 1.0, coercivity_width = 2.0 }')
    path.write_text(s + _AMPLIFIER)
    return path


@pytest.mark.parametrize("kind", ["per-axis", "diagonal", "multivariable"])
def test_a_scenarios_drive_of_a_kind_inverting_the_diagonal_is_compensates(tmp_path, kind):
    """An outside check: on a Preisach or generalised-PI model, ``per-axis`` and ``diagonal``
    invert only the model's diagonal, and the scenario shaped their drive into the amplifier's
    range and slew on that diagonal model: 0.072 and 0.159 V off ``compensate``'s drive on the
    same preset (a 25 µm circle at 20 Hz). It is shaped on the whole model, as the command's."""
    plant = load_plant(_shaped_preset(tmp_path / "actuator.toml"))
    spec = {"kind": kind, "model": "actuator.toml"}
    spec.update({} if kind == "per-axis" else {"gain": "midpoint", "check": "warn"})
    comp = build_compensator(spec, plant, ResolveContext(tmp_path))
    _, ref = circle(plant.sampling_period, radius=25.0, frequency=20.0, periods=3)
    P = int(round(1 / (20.0 * plant.sampling_period)))
    scenario = start_drive(compensator_plant(plant, comp), comp, ref, P, None, "warn")
    _, cli = compensate_reference(plant, ref, period_samples=P, kind=kind, limits="warn",
                                  **({} if kind == "per-axis" else {"gain": "midpoint",
                                                                     "check": "warn"}))
    assert scenario.inputs.shape == cli.inputs.shape
    assert np.max(np.abs(scenario.inputs - cli.inputs)) <= 1e-9 * np.max(np.abs(cli.inputs))


def test_a_model_file_identify_wrote_is_a_plant(tmp_path):
    """An outside check: ``[plant] preset = "model.toml"``, the model file ``identify`` wrote
    without ``--dynamics``, was refused ("preset.sampling_period: missing (required)") although
    the file holds its records' sampling period, which ``compensate`` reads; the docs offer
    "a preset, or the model file identify wrote". A file without it still names what is
    missing."""
    save_model(load_plant("rakotondrabe-2dof").hysteresis, tmp_path / "m.toml",
               {"sampling_period_s": [1e-4, 1e-4]})
    plant = load_plant(tmp_path / "m.toml")
    assert plant.sampling_period == 1e-4 and plant.is_static and plant.name == "m"
    save_model(load_plant("rakotondrabe-2dof").hysteresis, tmp_path / "n.toml", {"note": "x"})
    with pytest.raises(PresetError, match=r"preset\.sampling_period: missing \(required; the "
                                          r"model file gives no sampling period") as e:
        load_plant(tmp_path / "n.toml")
    assert "--sampling-period" not in str(e.value)


def test_a_model_file_without_dynamics_keeps_the_plant_g(tmp_path):
    save_model(load_plant(PRESET).hysteresis, tmp_path / "m.toml")     # [model] only
    spec = {"kind": "hammerstein", "model": "m.toml"}
    # the plant's G, and with it the plant's creep (its linear part, as compensate inverts it)
    assert model_file_dynamics(spec, tmp_path) == {**spec, "creep": "plant"}
    assert model_file_dynamics({**spec, "dynamics": "plant"}, tmp_path)["dynamics"] == "plant"
    assert model_file_dynamics({**spec, "creep": "none"}, tmp_path) == {**spec, "creep": "none"}


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


def _write(path, rec):
    cols = ["t", *rec.input_names, *rec.output_names]
    data = np.column_stack([rec.timepts, rec.u.T, rec.y.T])
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return path.name


def _scenario(path, compensator):
    path.write_text(f'name = "{path.stem}"\n[plant]\npreset = "plant.toml"\n[compensator]\n'
                    + compensator + '[[cases]]\nname = "c"\nreference = { kind = "circle", '
                    'radius = 10.0, frequency = 20.0, periods = 3 }\n', encoding="utf-8")
    return path


def _drive(out):
    import pandas as pd
    ts = pd.read_csv(Path(out) / "timeseries-c.csv")
    return ts[["ux_V", "uy_V"]].to_numpy()


@pytest.mark.slow
def test_a_saved_model_file_reused_as_model_builds_the_same_compensator(tmp_path, no_figures):
    """The report's model files of a records table lacked [creep] and [amplifier] (and the
    Hammerstein PI file its [dynamics]): reused as model = "<file>" they built another
    compensator (a tester's settled drive 76 mV apart). Saved as identify's preset, the
    reused file gives the same drive; the dynamics file carries the creep too."""
    from hammerstein.runner import run_scenario
    from hammerstein.scenario.identification import excitation_records
    from hammerstein.scenario.identify_tables import identify_table
    plant = load_plant(PRESET)
    recs = excitation_records(plant, identify_table({"records": "excitation", "frequency": 5.0,
                                                     "hold": 0.25, "multisine_periods": 2}))
    shutil.copy(PRESET, tmp_path / "plant.toml")
    names = {k: [_write(tmp_path / f"{k}-{i}.csv", r) for i, r in enumerate(rs)]
             for k, rs in recs.items()}
    files = (f'records = "files"\nmodel = "generalized"\n'
             f'hysteresis_records = {names["hysteresis"]}\ndynamics_records = {names["dynamics"]}\n'
             f'creep_records = {names["creep"]}\n').replace("'", '"')
    first = run_scenario(_scenario(tmp_path / "ident.toml", 'kind = "hammerstein"\nmodel = '
                                   '"identified"\n[compensator.identify]\n' + files),
                         tmp_path / "out", renderer=no_figures)
    assert first.ok, first.error
    models = Path(first.out_dir) / "models"
    pi, dyn = models / "hammerstein-1-generalized.toml", models / "hammerstein-1-dynamics.toml"
    saved = tomllib.loads(pi.read_text(encoding="utf-8"))
    assert {"model", "dynamics", "creep", "amplifier"} <= set(saved)
    assert "creep" in tomllib.loads(dyn.read_text(encoding="utf-8"))
    rel = lambda p: p.relative_to(tmp_path).as_posix()     # noqa: E731
    again = run_scenario(_scenario(tmp_path / "reuse.toml", f'kind = "hammerstein"\nmodel = '
                                   f'"{rel(pi)}"\n'), tmp_path / "out", renderer=no_figures)
    assert again.ok, again.error
    both = run_scenario(_scenario(tmp_path / "reuse2.toml", f'kind = "hammerstein"\nmodel = '
                                  f'"{rel(pi)}"\ndynamics = "{rel(dyn)}"\n'), tmp_path / "out",
                        renderer=no_figures)
    assert both.ok, both.error
    u = _drive(first.out_dir)
    assert np.max(np.abs(_drive(again.out_dir) - u)) <= 1e-9 * np.max(np.abs(u))
    assert np.max(np.abs(_drive(both.out_dir) - u)) <= 1e-6 * np.max(np.abs(u))

    # a rate-independent kind's model file is identify's preset too
    ri = run_scenario(_scenario(tmp_path / "ri.toml", 'kind = "multivariable"\nmodel = "identified"\n'
                                'gain = "midpoint"\ncheck = "warn"\n[compensator.identify]\n' + files),
                      tmp_path / "out", renderer=no_figures)
    assert ri.ok, ri.error
    saved = tomllib.loads((Path(ri.out_dir) / "models" / "identified-files-generalized.toml")
                          .read_text(encoding="utf-8"))
    assert {"model", "creep", "amplifier"} <= set(saved)
