"""``compensate`` and ``export`` without ``--kind``: the kind chosen for the model, and why.

The drives are judged through the model they were built from only for the
exact inverses (its output equals the reference); the end-to-end route on
actuators outside the classes is tests/cli/test_route_every_class.py.
"""

from pathlib import Path

import re

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.io.presets import load_plant, save_model

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
CIRCLE = '{ kind = "circle", radius = 10, frequency = 20, periods = 3 }'


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _model_file(tmp_path, preset):
    path = tmp_path / "model.toml"
    save_model(load_plant(preset).hysteresis, path, {"note": "test"})
    return path


def _drive(path):
    lines = [ln for ln in Path(path).read_text().splitlines() if not ln.startswith("#")]
    return np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


@pytest.mark.parametrize("preset, kind", [
    ("rakotondrabe-2dof", "hammerstein"),
    ("realistic-2dof", "hammerstein"),
    (str(SCENARIOS / "presets" / "realistic-gpi.toml"), "hammerstein")])
def test_compensate_default_prints_the_kind_and_why(tmp_path, capsys, preset, kind):
    code, out, err = _run(capsys, "compensate", preset, "--reference", CIRCLE,
                          "--out", str(tmp_path / "d.csv"))
    assert code == 0, err
    notes = [ln for ln in err.splitlines() if ln.startswith("note: kind = ")]
    assert len(notes) == 1 and notes[0].startswith(f"note: kind = {kind} because ")
    assert f"kind {kind}" in (tmp_path / "d.csv").read_text().splitlines()[1]


@pytest.mark.parametrize("preset", ["realistic-2dof", str(SCENARIOS / "presets" / "realistic-gpi.toml")])
def test_static_preisach_and_gpi_default_to_the_exact_inverse(tmp_path, capsys, preset):
    model = _model_file(tmp_path, preset)
    code, _, err = _run(capsys, "compensate", str(model), "--sampling-period", "5e-5",
                        "--reference", CIRCLE, "--out", str(tmp_path / "d.csv"))
    assert code == 0, err
    assert "note: kind = preisach-inverse because" in err
    data = _drive(tmp_path / "d.csv")
    hyst = load_plant(preset).hysteresis
    y, _ = hyst.simulate(data[:, 1:3].T)
    t = data[:, 0]
    ref = 10 * np.vstack([np.cos(2 * np.pi * 20 * t), np.sin(2 * np.pi * 20 * t)])
    text = (tmp_path / "d.csv").read_text()
    head = [ln for ln in text.splitlines() if ln and not ln.startswith("#")][0].split(",")
    if "x_shaped" in head:      # a start-up corrected in the reference: the drive follows it
        ref = data[:, [head.index("x_shaped"), head.index("y_shaped")]].T
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    # past the fade-in the drive's header states, and the few samples after it where the
    # header says the start-up is slew-limited to the settled drive's largest step
    settled = np.arange(t.size) >= fade + 50
    until = re.search(r"start-up corrected in the reference \(.*?until ([\d.]+) s\)", text)
    if until:                   # and after a start-up corrected in the reference
        settled &= t > float(until.group(1))
    # 1e-4 µm: the slew-limited samples after the fade leave the Preisach memory a few
    # 1e-5 µm off what the exact inverse assumed (the drive is limited after the inverse)
    assert np.max(np.abs(y[:, settled] - ref[:, settled])) < 1e-4


def test_hammerstein_on_a_static_model_names_the_kinds_that_work(tmp_path, capsys):
    model = _model_file(tmp_path, str(SCENARIOS / "presets" / "realistic-gpi.toml"))
    code, _, err = _run(capsys, "compensate", str(model), "--sampling-period", "5e-5",
                        "--reference", CIRCLE, "--out", str(tmp_path / "d.csv"),
                        "--kind", "hammerstein")
    assert code == 1 and len(err.strip().splitlines()) == 1
    works = err.split("kinds that work with it: ")[1]
    assert "preisach-inverse" in works and "hammerstein" not in works


def test_gain_and_check_are_options_of_compensate(tmp_path, capsys):
    preset = "realistic-2dof"
    code, _, err = _run(capsys, "compensate", preset, "--reference", CIRCLE, "--out",
                        str(tmp_path / "d.csv"), "--kind", "multivariable", "--gain", "identity")
    assert code == 1 and "rho(I - K^-1 J)" in err and "--check warn" in err
    code, _, err = _run(capsys, "compensate", preset, "--reference", CIRCLE, "--out",
                        str(tmp_path / "d.csv"), "--kind", "multivariable", "--gain", "midpoint",
                        "--check", "warn", "--limits", "warn")
    assert code == 0, err
    code, _, err = _run(capsys, "compensate", preset, "--reference", CIRCLE, "--out",
                        str(tmp_path / "d.csv"), "--kind", "per-axis", "--gain", "midpoint")
    assert code == 1 and "--gain/--check" in err
    # an outside check: kind hammerstein over a Preisach model (its exact inverse) ignored
    # --gain identity without a word, named or as the default kind
    for kind in (["--kind", "hammerstein"], []):
        code, _, err = _run(capsys, "compensate", preset, "--reference", CIRCLE, "--out",
                            str(tmp_path / "h.csv"), *kind, "--gain", "identity")
        assert code == 1 and len(err.strip().splitlines()) == 1
        assert ("kind 'hammerstein' over a Preisach model inverts it exactly per sample, without "
                "the inverse multiplicative law (they apply to multivariable, diagonal)") in err
    assert not (tmp_path / "h.csv").exists()


def test_export_default_kind_is_printed(tmp_path, capsys):
    code, out, err = _run(capsys, "export", "rakotondrabe-2dof", "--target", "c", "--out",
                          str(tmp_path / "c"))
    assert code == 0, err
    assert err.startswith("note: kind = hammerstein because")
    assert (tmp_path / "c" / "rakotondrabe_2dof_hammerstein.c").exists()


def test_list_shows_which_kind_works_with_which_class(capsys):
    code, out, _ = _run(capsys, "list")
    assert code == 0
    block = out.split("model classes and the compensator kinds")[1].split("reference kinds:")[0]
    for name in ("classical", "preisach", "generalized"):
        assert f"  {name}: " in block
    classical = block.split("  classical: ")[1].split("  preisach: ")[0]
    assert "preisach-inverse" not in classical.split("kinds: ")[1].split("\n")[0]


def test_scenario_validates_a_records_identify_table(tmp_path, capsys, monkeypatch):
    text = (SCENARIOS / "realistic-b.toml").read_text(encoding="utf-8")
    good = tmp_path / "good.toml"
    good.write_text(text.replace('preset = "presets/', f'preset = "{SCENARIOS}/presets/'))
    bad = tmp_path / "bad.toml"
    bad.write_text(good.read_text().replace('records = "excitation", creep = true',
                                            'records = "excitation", creep = true, modle = "auto"', 1))
    monkeypatch.setenv("HAMMERSTEIN_ALLOW_PATHS", str(SCENARIOS))
    assert _run(capsys, "validate", str(good))[0] == 0
    code, out, err = _run(capsys, "validate", str(bad))
    assert code != 0 and "modle" in out + err and "model" in out + err


def test_a_preset_with_creep_and_no_dynamics_gets_the_exact_inverse_and_is_told(tmp_path,
                                                                                 capsys):
    # the preset's creep made the plant "not static", so the default was hammerstein, which
    # then failed for want of bending modes: "dynamics: the plant is static"
    src = (SCENARIOS / "presets" / "realistic-gpi.toml").read_text()
    kept, skip = [], False
    for line in src.splitlines():
        if line.startswith("["):
            skip = line.startswith("[dynamics")
        if not skip:
            kept.append(line)
    path = tmp_path / "creep-only.toml"
    path.write_text("\n".join(kept) + "\n")
    plant = load_plant(path)
    assert plant.dynamics is None and plant.creep is not None
    code, out, err = _run(capsys, "compensate", str(path), "--reference", CIRCLE,
                          "--out", str(tmp_path / "d.csv"))
    assert code == 0, err
    (note,) = [ln for ln in err.splitlines() if ln.startswith("note: kind = ")]
    assert note.startswith("note: kind = preisach-inverse because the model has no dynamics")
    assert "its creep is not inverted" in note


def test_a_one_axis_classical_pi_defaults_to_its_exact_analytic_inverse(tmp_path, capsys):
    # the multivariable law lagged it by its one-step fixed point: a 20 Hz sine left 0.14 µm on
    # the model's own prediction; the per-axis analytic inverse of the one transfer is exact
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    model = MultivariablePI([[PrandtlIshlinskii([0.0, 2.0, 5.0, 9.0], [1.0, 0.4, 0.2, 0.1])]],
                            input_amplitude=[20.0], input_names=["u"], output_names=["y"])
    path = tmp_path / "stack.toml"
    save_model(model, path, {"note": "test"})
    code, out, err = _run(capsys, "compensate", str(path), "--sampling-period", "1e-4",
                          "--reference", '{ kind = "sine", output = "y", amplitude = 8, '
                                         'offset = 12, frequency = 20, periods = 6 }',
                          "--out", str(tmp_path / "d.csv"), "--predicted")
    assert code == 0, err
    (note,) = [ln for ln in err.splitlines() if ln.startswith("note: kind = ")]
    assert note.startswith("note: kind = per-axis because the model has no dynamics and one "
                           "direct transfer")
    assert "the drive is right only well below the actuator's first bending mode" in note
    import pandas as pd
    d = pd.read_csv(tmp_path / "d.csv", comment="#")
    t = d["t"].to_numpy()
    settled = t >= 0.1                                       # after the fade-in
    r = 12 + 8 * np.sin(2 * np.pi * 20 * t)
    assert np.max(np.abs(d["y_predicted"].to_numpy()[settled] - r[settled])) < 1e-9


def test_a_one_output_model_needs_no_output_key(tmp_path, capsys):
    # '{ kind = "sine", amplitude = 8, ... }' on a one-output stage: "reference.output: missing
    # (required)", where the model has only one output to choose
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    model = MultivariablePI([[PrandtlIshlinskii([0.0, 2.0, 5.0], [1.0, 0.4, 0.2])]],
                            input_amplitude=[20.0], input_names=["u"], output_names=["z"])
    path = tmp_path / "stack.toml"
    save_model(model, path, {"note": "test"})
    for kind in ("sine", "triangle"):
        code, _, err = _run(capsys, "compensate", str(path), "--sampling-period", "1e-4",
                            "--reference", f'{{ kind = "{kind}", amplitude = 5, offset = 8, '
                                           f'frequency = 20, periods = 4 }}',
                            "--out", str(tmp_path / f"{kind}.csv"))
        assert code == 0, err


def _coupled_pi_with_dynamics(tmp_path, amplifier=None):
    """A 2x2 classical PI whose cross-couplings are 0.3 of its direct transfers, with a
    2 kHz mode on each axis: the law's midpoint gain reaches rho(I - K^-1 J) = 1.3 over its
    slopes, the secant gain 0.88 (law_radius)."""
    import control

    from hammerstein.io.presets import dynamics_to_table
    from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii

    r = np.array([0.0, 1.0, 2.0, 4.0, 6.0, 8.0])
    w = np.array([0.3, 1.0, 0.3, 0.3, 0.2, 0.2])
    pi = MultivariablePI([[PrandtlIshlinskii(r, w), PrandtlIshlinskii(r, 0.3 * w)],
                          [PrandtlIshlinskii(r, 0.3 * w), PrandtlIshlinskii(r, w)]],
                         input_names=["ux", "uy"], output_names=["x", "y"],
                         input_amplitude=[10.0, 10.0])
    wn = 2 * np.pi * 2000.0
    mode = control.tf([wn ** 2], [1.0, 2 * 0.05 * wn, wn ** 2])
    G = control.ss(control.append(control.ss(mode), control.ss(mode)))
    path = tmp_path / "coupled.toml"
    save_model(pi, path, {"note": "test"}, extra={
        "preset": {"name": "coupled", "sampling_period": 5e-5},
        "dynamics": dynamics_to_table(G), **({"amplifier": amplifier} if amplifier else {})})
    return pi, path


def test_a_named_law_kind_without_gain_runs_the_convergent_gain(tmp_path, capsys):
    """``--kind hammerstein`` on a classical PI ran the law with its own default gain (the
    midpoint) and was refused where the midpoint diverges, while the default kind chose a
    convergent one: an outside stage's identified PI, rho 1.17 against 0.904. The named kind
    now takes law_check's gain, says so, and writes the drive that the default kind writes;
    export names the same gain."""
    from hammerstein.compensation.kind_choice import law_radius

    pi, path = _coupled_pi_with_dynamics(tmp_path)
    assert law_radius(pi, "midpoint") > 1.0 > law_radius(pi, "secant")
    ref = '{ kind = "circle", radius = 5, frequency = 20, periods = 3 }'
    base = ["compensate", str(path), "--reference", ref]
    code, _, err = _run(capsys, *base, "--out", str(tmp_path / "named.csv"),
                        "--kind", "hammerstein")
    assert code == 0, err
    assert "note: kind hammerstein runs the multivariable law with gain secant, rho(I - K^-1 J) 0.879 < 1, the convergent gain: the kind's midpoint gain reaches rho(I - K^-1 J) 1.3" in err
    code, _, err = _run(capsys, *base, "--out", str(tmp_path / "default.csv"))
    assert code == 0, err
    assert "note: kind = hammerstein because" in err and "gain secant" in err
    assert np.array_equal(_drive(tmp_path / "named.csv"), _drive(tmp_path / "default.csv"))
    # the user's gain is still the user's: the midpoint is refused, naming rho
    code, _, err = _run(capsys, *base, "--out", str(tmp_path / "mid.csv"), "--kind",
                        "hammerstein", "--gain", "midpoint")
    assert code == 1 and "rho(I - K^-1 J) reaches 1.3" in err
    code, _, err = _run(capsys, "export", str(path), "--kind",
                        "hammerstein", "--target", "c", "--out", str(tmp_path / "c"))
    assert code == 0, err
    assert "note: kind hammerstein runs the multivariable law with gain secant, rho(I - K^-1 J) 0.879 < 1, the convergent gain: the kind's midpoint gain reaches rho(I - K^-1 J) 1.3" in err


def test_a_named_kind_is_not_called_the_default_and_check_keeps_the_gain_choice(tmp_path,
                                                                               capsys):
    """A reviewer's: an error after a gain chosen for a named kind said "(kind hammerstein,
    the default for this model; --kind names another)"; and --check given with the named
    kind kept its diverging own gain, where the default kind chooses a convergent one."""
    _, path = _coupled_pi_with_dynamics(tmp_path, {"range": [-10.0, 10.0]})
    # beyond the amplifier's range: an error after the law's choice, which names the gain
    ref = '{ kind = "circle", radius = 18, frequency = 20, periods = 3 }'
    code, _, err = _run(capsys, "compensate", str(path), "--reference", ref, "--kind",
                        "hammerstein", "--out", str(tmp_path / "far.csv"))
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert "the default for this model" not in err
    assert "(kind hammerstein runs the multivariable law with gain secant" in err
    ref = '{ kind = "circle", radius = 5, frequency = 20, periods = 3 }'
    code, _, err = _run(capsys, "compensate", str(path), "--reference", ref, "--kind",
                        "hammerstein", "--check", "error", "--out", str(tmp_path / "c.csv"))
    assert code == 0, err
    assert "runs the multivariable law with gain secant" in err


def test_the_python_route_says_which_kind_and_gain_it_took(tmp_path, capsys):
    """``compensate_reference`` from Python took the kind and the law's gain for the model
    and dropped the note that ``compensate`` prints: the caller could not tell."""
    from hammerstein.io.presets import load_plant as load
    from hammerstein.scenario.hardware_route import compensate_reference
    from hammerstein.signals.references import circle

    _, path = _coupled_pi_with_dynamics(tmp_path)
    plant = load(str(path))
    _, r = circle(plant.sampling_period, radius=5.0, frequency=20.0, periods=3)
    P = round(1 / 20.0 / plant.sampling_period)
    code, _, err = _run(capsys, "compensate", str(path), "--reference",
                        '{ kind = "circle", radius = 5, frequency = 20, periods = 3 }',
                        "--kind", "hammerstein", "--out", str(tmp_path / "named.csv"))
    assert code == 0, err
    printed = [ln.removeprefix("note: ") for ln in err.splitlines()
               if ln.startswith("note: kind hammerstein runs")]
    _, drive = compensate_reference(plant, r, P, kind="hammerstein")
    assert printed == [drive.kind_note]
    _, drive = compensate_reference(plant, r, P)
    assert drive.kind_note.startswith("kind = hammerstein because") and "gain secant" in drive.kind_note
    # the caller's own kind and gain: nothing was chosen for them
    _, drive = compensate_reference(plant, r, P, kind="hammerstein", gain="secant")
    assert drive.kind_note is None


@pytest.mark.parametrize("kwargs, key", [
    ({"period_samples": 0}, "period_samples"), ({"period_samples": -5}, "period_samples"),
    ({"period_samples": 100.5}, "period_samples"), ({"period_samples": True}, "period_samples"),
    ({"period_samples": 10 ** 9}, "period_samples"), ({"fade_in": -1.0}, "fade_in"),
    ({"fade_in": float("nan")}, "fade_in"), ({"limits": "bogus"}, "limits"),
])
def test_the_python_route_names_an_argument_it_cannot_take(kwargs, key):
    # an outside check: each was taken silently (as none, as a fade over the whole record, as
    # "error") or failed deep inside with a bare ValueError
    from hammerstein.exceptions import CompensatorError
    from hammerstein.scenario.hardware_route import compensate_reference
    from hammerstein.signals.references import circle

    plant = load_plant("rakotondrabe-2dof")
    _, r = circle(plant.sampling_period, radius=5.0, frequency=50.0, periods=4)
    with pytest.raises(CompensatorError, match=rf"^{key}: expected"):
        compensate_reference(plant, r, **{"period_samples": 400, **kwargs})


@pytest.mark.parametrize("kind", ["hammerstein", "multivariable"])
def test_a_scenario_without_gain_runs_the_gain_compensate_runs(tmp_path, capsys, kind):
    """An outside check: on a classical PI whose kind's own gain diverges (the midpoint at
    rho 1.3), ``compensate --kind hammerstein`` took the convergent gain while a scenario with
    the same kind and no ``gain`` stopped on rho. It takes the same gain and writes the same
    drive; a gain written in the table is still the table's (refused, naming rho)."""
    # the records' amplifier, as identify writes it: the scenario's drive starts as compensate's
    pi, path = _coupled_pi_with_dynamics(tmp_path, amplifier={
        "source": "records", "ux": {"range": [-10.0, 10.0]}, "uy": {"range": [-10.0, 10.0]}})
    ref = '{ kind = "circle", radius = 5, frequency = 20, periods = 3 }'
    code, _, err = _run(capsys, "compensate", str(path), "--reference", ref, "--out",
                        str(tmp_path / "cli.csv"), "--kind", kind)
    assert code == 0, err
    table = (f'name = "same"\n[plant]\npreset = "{path.name}"\n[compensator]\nkind = "{kind}"\n'
             f'[[cases]]\nname = "circle"\nreference = {ref}\n')
    (tmp_path / "same.toml").write_text(table)
    code, _, err = _run(capsys, "run", str(tmp_path / "same.toml"), "--out",
                        str(tmp_path / "rep"), "--figures", "none")
    assert code == 0, err
    lines = [ln for ln in (tmp_path / "rep" / "same" / "timeseries-circle.csv").read_text()
             .splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    ran = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    ran = ran[:, [head.index("ux_V"), head.index("uy_V")]]
    cli = _drive(tmp_path / "cli.csv")[:, 1:3]
    assert ran.shape == cli.shape
    # the report's time series holds 9 significant digits: 5e-9 V of a 4.5 V drive
    assert np.max(np.abs(ran - cli)) <= 1.5e-9 * np.max(np.abs(cli))
    assert "secant gain" in (tmp_path / "rep" / "same" / "report.md").read_text()
    (tmp_path / "mid.toml").write_text(table.replace(f'kind = "{kind}"\n',
                                                     f'kind = "{kind}"\ngain = "midpoint"\n')
                                       .replace('name = "same"', 'name = "mid"'))
    code, _, err = _run(capsys, "run", str(tmp_path / "mid.toml"), "--out",
                        str(tmp_path / "rep"), "--figures", "none")
    assert code == 1 and "rho(I - K^-1 J) reaches 1.3" in err
    # named as the kind written (kind hammerstein was called "this multivariable compensator")
    assert f"of this {kind} compensator" in err

