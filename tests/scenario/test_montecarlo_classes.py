"""Monte-Carlo studies of every model class and every compensator kind, off the batch kernel.

A Preisach, generalised-PI or mixed plant, or a kind the batch kernel cannot
run (the exact inverse, the Hammerstein compensator), runs each drawn plant
under the nominal drive. Checked against the chain run another way (the
compiled chain, ``run_reference``), against the batch kernel on a classical
PI plant, and the drawn components against their closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.preisach import Polynomial, PreisachModel
from hammerstein.scenario import montecarlo as mc
from hammerstein.scenario import montecarlo_draw as draw
from hammerstein.scenario.identification import ResolveContext
from hammerstein.scenario.registry import build_compensator
from hammerstein.scenario.validate import validate_scenario
from hammerstein.simulation import simulate_chain

STUDY = """
name = "mcc"
seed = 5
[plant]
preset = "{preset}"
[compensator]
kind = "{kind}"
[[sweeps]]
kind = "monte-carlo"
name = "mm"
cases = {cases}
frequencies = [20.0, 80.0]
reference = {{ kind = "circle", radius = 15.0, periods = 2 }}
settle_periods = 1
[sweeps.vary]
weights = {{ relative_sd = 0.05 }}
cross_coupling = {{ relative_sd = 0.3, distribution = "lognormal" }}
noise = {{ sd = 0.01 }}
"""


def _built(tmp_path, preset, kind, cases=4):
    f = tmp_path / f"{kind}.toml"
    f.write_text(STUDY.format(preset=preset, kind=kind, cases=cases))
    sc = validate_scenario(f)
    study = sc.studies[0]
    study.compensator = build_compensator(sc.compensator_spec, study.plant, ResolveContext(tmp_path))
    return sc, study


def _expected_row(study, j, y, i):
    """The metrics of one run, reduced by hand (settle_periods = 1)."""
    y = y + study.vary["noise"]["sd"] * np.random.default_rng([study.seed, i, j + 1]).standard_normal(y.shape)
    r, P = study.references[j], study.period_samples[j]
    e = r[:, P:] - y[:, P:]
    row = []
    for l in range(e.shape[0]):
        row += [np.sqrt(np.mean(e[l] ** 2)), np.max(np.abs(e[l]))]
    ee = np.sqrt(np.sum(e ** 2, axis=0))
    return row + [np.sqrt(np.mean(ee ** 2)), ee.max()]


@pytest.fixture
def realistic_b(repo_root, tmp_path):
    """The bundled Preisach / generalised-PI / polynomial preset, copied beside the study."""
    f = tmp_path / "realistic-b.toml"
    f.write_text((repo_root / "scenarios" / "presets" / "realistic-b.toml").read_text())
    return f.name


@pytest.mark.parametrize("preset, kind", [
    ("realistic-2dof", "preisach-inverse"),      # Preisach plant, exact inverse
    ("realistic-b", "preisach-inverse"),         # Preisach + generalised PI + polynomial
    ("realistic-2dof", "hammerstein"),           # look-ahead kind: preview and fade-in
])
def test_metrics_equal_the_chain_on_the_drawn_plant(tmp_path, realistic_b, preset, kind):
    sc, study = _built(tmp_path, realistic_b if preset == "realistic-b" else preset, kind)
    study.feedforward = mc._drives(study, sc.compensator_spec, "s")
    _, v = mc.run_chunk(study, 1, 3)
    assert np.all(np.isfinite(v))
    for i in (1, 2):
        plant = mc.case_plant(study, i)
        for j, r in enumerate(study.references):
            if kind == "hammerstein":       # the fade of one period, as the study's
                P = study.period_samples[j]
                y = study.compensator.run_reference(plant, r, P, P).outputs
            else:
                y = simulate_chain(study.compensator, plant, r).outputs
            np.testing.assert_allclose(v[i - 1, j], _expected_row(study, j, y, i), rtol=1e-9)


def test_off_kernel_route_equals_the_batch_kernel_on_a_classical_pi(tmp_path):
    sc, study = _built(tmp_path, "rakotondrabe-2dof", "multivariable")
    _, fused = mc.run_chunk(study, 0, 4)
    study.feedforward = mc._drives(study, sc.compensator_spec, "s")
    _, drive = mc.run_chunk(study, 0, 4)
    np.testing.assert_allclose(drive, fused, rtol=1e-9)
    assert not np.array_equal(fused[0], fused[1])            # the cases do differ


def test_off_kernel_cases_depend_only_on_seed_and_index(tmp_path):
    sc, study = _built(tmp_path, "realistic-2dof", "preisach-inverse", cases=5)
    study.feedforward = mc._drives(study, sc.compensator_spec, "s")
    _, whole = mc.run_chunk(study, 0, 5)
    again = np.concatenate([mc.run_chunk(study, a, b)[1] for a, b in [(0, 2), (2, 5)]])
    assert np.array_equal(whole, again)
    res = mc.run_study(study, chunk=2)
    assert np.array_equal(res.values, whole) and res.diverged.sum() == 0


def test_run_scenario_picks_the_drive_route_for_a_preisach_plant(tmp_path):
    f = tmp_path / "p.toml"
    f.write_text(STUDY.format(preset="realistic-2dof", kind="preisach-inverse", cases=3))
    sc = validate_scenario(f)
    res = mc.run_montecarlo_scenario(sc)[0]
    assert sc.studies[0].feedforward is not None and res.values.shape == (3, 2, 6)
    assert np.all(np.isfinite(res.quantiles))


def _hysteretic(c, y, u):
    """A component's output minus its reversible part and offset."""
    rev = c.reversible if not isinstance(c, Polynomial) else c.coefficients
    return y - sum(a * u ** (n + 1) for n, a in enumerate(rev)) - c.offset


@pytest.mark.parametrize("component", [
    PreisachModel.from_density(np.linspace(-10, 10, 9), total=20.0, coercivity=2.0,
                               coercivity_width=2.0, reversible=[0.5, 0.02], offset=1.5),
    GeneralizedPI([0.0, 1.0, 2.5], [0.8, 0.3, 0.2], gamma_l=[12.0, 0.1, 0.05, 0.2],
                  gamma_r=[11.0, 0.1, -0.05, -0.1], offset=-0.7, reversible=[0.0, 0.01]),
    # starting demagnetised: the scaled one starts from the same plays
    GeneralizedPI([0.0, 1.0, 2.5, 6.0], [0.8, 0.3, 0.2, 0.2], gamma_l=[12.0, 0.1, 0.05, 0.2],
                  gamma_r=[11.0, 0.1, -0.05, 2.0], offset=-0.7, demagnetised=12.0),
    Polynomial([0.1, 0.03], offset=0.4),
])
def test_a_scaled_component_is_its_weights_times_the_factors(component):
    # the output is linear in the hysteron weights and in the reversible coefficients: weight
    # factors f and a cross-coupling factor g scale the hysteretic part's move from rest by
    # f * g and the reversible part by g; the component rests where the nominal one does
    # (a generalised PI's plays rest at their envelopes' values, a Preisach model's relays
    # at +-1: scaling their weights alone moved the rest output, a gain drawn became an
    # offset)
    u = 9.0 * np.sin(np.linspace(0, 5 * np.pi, 400)) * np.linspace(1, 0.4, 400)
    f, g = 1.3, 0.6
    n = draw._n_weights(component)
    scaled = draw._scaled(component, np.full(n, f), g)
    y0, y1 = component.simulate(u)[0], scaled.simulate(u)[0]
    rest0, rest1 = component.simulate(np.zeros(1))[0][0], scaled.simulate(np.zeros(1))[0][0]
    assert abs(rest1 - rest0) <= 1e-12 * max(1.0, abs(rest0))
    h0 = _hysteretic(component, y0, u) + component.offset - rest0
    h1 = _hysteretic(scaled, y1, u) + scaled.offset - rest1
    np.testing.assert_allclose(h1, (f * g if n else g) * h0, rtol=1e-12, atol=1e-12)
    if isinstance(component, PreisachModel):
        assert n == component.n_states
        w = draw._scaled(component, np.full(n, -2.0), 1.0).weights   # unsigned: clipped at 0
        assert np.all(w == 0.0)


@pytest.mark.parametrize("preset, kinds", [
    ("realistic-2dof", "multivariable, diagonal, per-axis, static-gain, hammerstein, "
                       "preisach-inverse"),
    ("rakotondrabe-2dof", "multivariable, diagonal, per-axis, static-gain, hammerstein")])
def test_ilc_is_refused_naming_the_field_and_the_kinds_that_work(tmp_path, preset, kinds):
    """An outside check: the refusal named no kind a study takes (the issue: where one does
    not work, the message names the kinds that do)."""
    f = tmp_path / "ilc.toml"
    f.write_text(STUDY.format(preset=preset, kind="ilc", cases=2))
    with pytest.raises(ScenarioError, match=r"compensator\.kind: .*'ilc' learns on a plant") as e:
        validate_scenario(f)
    assert f"the kinds a study takes for this plant: {kinds}" in str(e.value)


def test_the_budget_counts_the_cost_of_a_sample_off_the_kernel(tmp_path, monkeypatch):
    # a budget that lets the classical PI study run refuses the same study on a Preisach plant,
    # whose samples cost about 25 times as much CPU
    samples = 4 * sum(int(round(2 / fr / 5e-5)) for fr in (20.0, 80.0))
    monkeypatch.setenv(mc.STUDY_SAMPLES_ENV, str(2 * samples))
    ok = tmp_path / "pi.toml"
    ok.write_text(STUDY.format(preset="rakotondrabe-2dof", kind="multivariable", cases=4))
    validate_scenario(ok)
    bad = tmp_path / "preisach.toml"
    bad.write_text(STUDY.format(preset="realistic-2dof", kind="preisach-inverse", cases=4))
    with pytest.raises(ScenarioError, match=r"sweeps\[0\]\.cases: .* ns a sample"):
        validate_scenario(bad)


@pytest.mark.parametrize("ff, fd", [([1.1, 0.9], [1.0, 1.0]), ([1.0, 1.0], [1.5, 0.7]),
                                    ([0.8, 1.2], [2.0, 0.5])])
def test_scaled_modes_are_the_held_bending_modes_of_the_new_parameters(ff, fd):
    # a bending mode's numerator is constant: its modal scaling equals the zero-order hold of
    # the mode with the new frequency and damping (sampled_modes, a closed form)
    from hammerstein.models.dynamics import sampled_bending_modes
    fn, zeta, T = np.array([450.0, 600.0]), np.array([0.03, 0.05]), 5e-5
    nominal = sampled_bending_modes(fn, zeta, ["x", "y"], T)
    got = draw.scaled_modes(nominal, ff, fd)
    expect = draw.sampled_modes(fn * ff, zeta * fd, T, nominal)
    for f in (0.0, 10.0, 100.0, 500.0, 2000.0):
        h, g = got.frequency_response_hz([f]), expect.frequency_response_hz([f])
        assert np.abs(h - g).max() <= 1e-12 * np.abs(g).max()
    np.testing.assert_allclose(draw.oscillating_modes(got)[0], np.sort(fn * ff), rtol=1e-9)


def test_state_space_modes_are_varied_mode_by_mode(tmp_path):
    # realistic-2dof: three coupled modes in a continuous state space, G(0) = I
    text = STUDY.format(preset="realistic-2dof", kind="preisach-inverse", cases=3).replace(
        "noise = { sd = 0.01 }",
        "natural_frequency = { relative_sd = 0.05 }\ndamping_ratio = { relative_sd = 0.2 }")
    f = tmp_path / "modes.toml"
    f.write_text(text)
    study = validate_scenario(f).studies[0]
    fn, zeta = study.modes
    assert "natural_frequency" in study.vary and "damping_ratio" in study.vary
    assert study.modal and np.allclose(fn, [420.0, 450.0, 1300.0]) and np.allclose(zeta, [0.06, 0.08, 0.03])
    for i in range(3):
        fac = draw.draw_factors(study, i)
        lin = draw.case_plant(study, i).sampled_dynamics
        got_f, got_z = draw.oscillating_modes(lin)
        order = np.argsort(fn * fac["natural_frequency"])
        np.testing.assert_allclose(got_f, (fn * fac["natural_frequency"])[order], rtol=1e-9)
        np.testing.assert_allclose(got_z, (zeta * fac["damping_ratio"])[order], rtol=1e-9)
        np.testing.assert_allclose(lin.frequency_response_hz([0.0])[:, :, 0], np.eye(2), atol=1e-9)


def test_run_counts_the_drawn_plants_as_validate_does(tmp_path, capsys):
    # run printed "(1 cases)" for a study of many plants (the metrics' one case column)
    from hammerstein.cli.main import main
    f = tmp_path / "p.toml"
    f.write_text(STUDY.format(preset="realistic-2dof", kind="preisach-inverse", cases=3))
    assert main(["validate", str(f)]) == 0
    assert main(["run", str(f), "--out", str(tmp_path / "out"), "--figures", "none"]) == 0
    out = capsys.readouterr().out
    assert "ok (3 cases)" in out and "wrote" in out and "(3 cases)" in out.split("wrote")[1]


@pytest.mark.parametrize("varied", ["natural_frequency", "damping_ratio"])
def test_one_mode_parameter_varied_alone_on_state_space_modes(tmp_path, varied):
    # the other one's factors were one per output (2) for three modes: an IndexError
    text = STUDY.format(preset="realistic-2dof", kind="preisach-inverse", cases=2).replace(
        "noise = { sd = 0.01 }", f"{varied} = {{ relative_sd = 0.05 }}")
    f = tmp_path / "one.toml"
    f.write_text(text)
    study = validate_scenario(f).studies[0]
    fac = draw.draw_factors(study, 1)
    assert fac["natural_frequency"].shape == fac["damping_ratio"].shape == (3,)
    fn, zeta = draw.oscillating_modes(draw.case_plant(study, 1).sampled_dynamics)
    other = "damping_ratio" if varied == "natural_frequency" else "natural_frequency"
    assert np.all(fac[other] == 1.0)
    np.testing.assert_allclose(sorted(fn if varied == "natural_frequency" else zeta),
                               sorted(np.asarray(study.modes[0 if varied == "natural_frequency"
                                                            else 1]) * fac[varied]), rtol=1e-9)


def test_a_compensator_table_without_a_kind_says_so(tmp_path):
    # `model = ...` alone read "compensator.model: unknown key (valid keys: kind)"
    f = tmp_path / "nokind.toml"
    f.write_text('[plant]\npreset = "realistic-2dof"\n[compensator]\nmodel = "plant"\n'
                 '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
                 'frequency = 20.0, periods = 3 }\n')
    with pytest.raises(ScenarioError, match=r"compensator\.kind: missing: the default 'none' "
                                            r"\(no compensator\) takes no model; give a kind "
                                            r"\(.*hammerstein.*take them\)"):
        validate_scenario(f)


_STUDY = """name = "s"
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "{kind}"
model = "{model}"
[[sweeps]]
kind = "monte-carlo"
name = "m"
cases = {cases}
frequencies = [20.0]
reference = {{ kind = "circle", radius = 10.0, periods = 3 }}
settle_periods = 1
[sweeps.vary]
weights = {{ relative_sd = 0.05 }}
{extra}
"""


def test_a_study_names_a_kind_its_model_class_does_not_take(tmp_path):
    # an outside check: preisach-inverse over a classical PI model file validated "ok (20
    # cases)" in a study and the run stopped on it; in [[cases]] validate names it
    from hammerstein.io.presets import load_plant, save_model
    save_model(load_plant("rakotondrabe-2dof").hysteresis, tmp_path / "pi.toml", {"note": "t"})
    f = tmp_path / "s.toml"
    f.write_text(_STUDY.format(kind="preisach-inverse", model="pi.toml", cases=4, extra=""))
    with pytest.raises(ScenarioError, match=r"compensator\.kind: the model is a classical PI "
                                            r"model, which kind 'preisach-inverse' does not take"
                                            r"; the kinds that work with it: (.*)") as err:
        validate_scenario(f)
    named = str(err.value).split("the kinds that work with it: ")[1].split("\n")[0].split(", ")
    # a study refuses ilc (it learns on one plant), so it is not offered as a kind that works
    assert named == ["hammerstein", "multivariable", "diagonal", "per-axis", "static-gain"]
    f.write_text(_STUDY.format(kind="multivariable", model="pi.toml", cases=4, extra=""))
    assert len(validate_scenario(f).studies) == 1


def test_a_study_names_its_sweep_and_vary_mistakes_together(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(_STUDY.format(kind="multivariable", model="plant", cases=2.5,
                               extra="bogus = { relative_sd = 0.1 }"))
    with pytest.raises(ScenarioError) as err:
        validate_scenario(f)
    lines = str(err.value).splitlines()
    assert any("sweeps[0].cases: expected an integer" in ln for ln in lines), lines
    assert any("sweeps[0].vary.bogus: unknown key" in ln for ln in lines), lines


def test_a_study_of_a_rate_independent_kind_warns_where_the_dynamics_change_the_response(
        tmp_path):
    # an outside check: P50 errors of 8-10 µm on a 20 µm circle and no word, where a frequency
    # sweep of the same kind warned, once per frequency
    from hammerstein.scenario.rate_warning import dynamics_effect
    f = tmp_path / "s.toml"
    f.write_text(_STUDY.format(kind="multivariable", model="plant", cases=2, extra="")
                 .replace("frequencies = [20.0]", "frequencies = [1.0, 100.0]"))
    (res,) = mc.run_montecarlo_scenario(validate_scenario(f))
    plant = validate_scenario(f).studies[0].plant
    assert dynamics_effect(plant.sampled_dynamics, 1.0) is None        # well below the mode
    effect = dynamics_effect(plant.sampled_dynamics, 100.0)
    assert res.warnings == [f"compensator kind = 'multivariable' is rate independent: {effect}, "
                            f"which it does not compensate; kind = \"hammerstein\" does "
                            f"(docs/hammerstein-plant.md)"]
    f.write_text(_STUDY.format(kind="hammerstein", model="plant", cases=2, extra="")
                 .replace("frequencies = [20.0]", "frequencies = [1.0, 100.0]"))
    (res,) = mc.run_montecarlo_scenario(validate_scenario(f))
    assert not any("rate independent" in w for w in res.warnings)
