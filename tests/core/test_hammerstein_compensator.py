"""The Hammerstein compensator: chunked = whole, compiled chain = numpy oracle, round trips,
state-space presets, scenario keys and the rate-dependence warning."""

import warnings

import re

import numpy as np
import pytest

from hammerstein.compensation.compensators import CompensatorError
from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
from hammerstein.compensation.hammerstein_compensator import (HammersteinCompensator, continuation,
                                                      fade_in)
from hammerstein.io.presets import PresetError, dynamics_from_table, load_dynamics, load_plant, \
    save_dynamics
from hammerstein.models.lti import dc_gain

COUPLED = "scenarios/presets/coupled-2dof.toml"


@pytest.fixture
def plant(preset_plant):
    return preset_plant


@pytest.fixture(scope="module")
def coupled():
    return load_plant(COUPLED)


def circle(T, n, f, R):
    t = np.arange(n) * T
    return R * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def oracle_chain(comp, plant, lead):
    """Naive per-sample loop, written out from the definitions (not the package's loops).

    ZPETC: FIR taps over the reference window + acceptable-mode state; PI law:
    ``iterations`` fixed-point steps from U(t-T) with frozen plays; plant: plays, PI
    sum, ``x <- A x + B h``, ``y = C x + D h``.
    """
    inv, pic = comp.inverse, comp.hysteresis_compensator
    Af, Bf, Cf, Df = inv.state_space()
    xf = np.zeros(inv.n_states)
    hm, hp = pic.model.hysterons(), plant.hysteresis.hysterons()
    A, B, C, D = (np.asarray(M) for M in plant.matrices)

    def pi(h, u, s):
        ui = u[h["input_index"]]
        s_new = np.maximum(ui - h["thresholds"], np.minimum(ui + h["thresholds"], s))
        y = np.zeros(h["gain"].shape[0])
        for j in range(s_new.size):
            y[h["output_index"][j]] += h["weights"][j] * s_new[j]
        return y + h["gain"] @ u, s_new

    u_prev, sc = np.zeros(2), np.zeros(hm["thresholds"].size)
    sp, x = np.zeros(hp["thresholds"].size), np.zeros(A.shape[0])
    Y = np.empty_like(lead)
    for k in range(lead.shape[1]):
        v = Cf @ xf + Df @ lead[:, k]
        xf = Af @ xf + Bf @ lead[:, k]
        u = u_prev.copy()
        for _ in range(pic.iterations):
            yh, _ = pi(hm, u, sc)
            u = u + pic.K_inv @ (v - yh)
        _, sc = pi(hm, u, sc)
        u_prev = u
        h, sp = pi(hp, u, sp)
        Y[:, k] = C @ x + D @ h
        x = A @ x + B @ h
    return Y


@pytest.mark.parametrize("preset", ["rakotondrabe-2dof", COUPLED])
def test_compiled_chain_equals_numpy_oracle(preset):
    """Also on the coupled preset: a non-diagonal inverse (full MIMO pre-filter, P = 3)."""
    plant = load_plant(preset)
    comp = HammersteinCompensator(plant.hysteresis, plant.dynamics, iterations=3)
    lead = fade_in(circle(plant.sampling_period, 600, 200.0, 20.0), 100)
    res = comp.chain(plant, lead)
    assert not res.diverged
    np.testing.assert_allclose(res.outputs, oracle_chain(comp, plant, lead), atol=1e-9)


@pytest.mark.parametrize("preset", ["rakotondrabe-2dof", COUPLED])
@pytest.mark.parametrize("inversion", ["zpetc"])
def test_chunked_equals_whole(preset, inversion):
    plant = load_plant(preset)
    comp = HammersteinCompensator(plant.hysteresis, plant.dynamics, inversion=inversion)
    lead, s0, _ = comp.start(circle(plant.sampling_period, 900, 150.0, 25.0), 133, 133)
    whole = comp.chain(plant, lead, s0)
    a = comp.chain(plant, lead[:, :317], s0)
    b = comp.chain(plant, lead[:, 317:], a.compensator_state, a.plant_state)
    np.testing.assert_allclose(np.hstack([a.outputs, b.outputs]), whole.outputs, atol=1e-10)
    np.testing.assert_allclose(b.compensator_state, whole.compensator_state, atol=1e-10)
    u1, s1 = comp.simulate(lead[:, :400], s0)
    u2, _ = comp.simulate(lead[:, 400:], s1)
    np.testing.assert_allclose(np.hstack([u1, u2]), whole.inputs, atol=1e-10)


@pytest.mark.parametrize("inversion", ["zpetc", "stable"])
@pytest.mark.parametrize("preset", ["rakotondrabe-2dof", COUPLED])
def test_round_trip_true_plant(preset, inversion):
    """True models: the output follows the reference within 0.5 % of the radius at 200 Hz.

    Bound: ZPETC gain error 2|b|(1 - cos wT)/(1 - b)^2 ~ 0.1 % at 200 Hz plus the
    3-iteration law's residual (< 0.3 %).
    """
    pl = load_plant(preset)
    comp = HammersteinCompensator(pl.hysteresis, pl.dynamics, inversion=inversion)
    T, f, R = pl.sampling_period, 200.0, 30.0
    per = int(round(1 / (f * T)))
    yr = circle(T, 8 * per, f, R)
    res = comp.run_reference(pl, yr, per, 2 * per)
    e = np.linalg.norm(res.outputs[:, 4 * per:] - yr[:, 4 * per:], axis=0)
    assert e.max() < 0.005 * R


def test_without_inverse_the_dynamics_remain(plant):
    """Control experiment: the hysteresis compensator alone misses by ~|G(200 Hz)| - 1 (> 20 %)."""
    T, f, R = plant.sampling_period, 200.0, 30.0
    per = int(round(1 / (f * T)))
    yr = fade_in(circle(T, 8 * per, f, R), 2 * per)
    from hammerstein.simulation import simulate_chain
    res = simulate_chain(InverseMultiplicativeCompensator(plant.hysteresis, iterations=3), plant, yr)
    assert np.linalg.norm(res.outputs[:, 4 * per:] - yr[:, 4 * per:], axis=0).max() > 0.2 * R


def test_fade_and_continuation():
    r = np.vstack([np.arange(10.0) ** 2, np.ones(10)])
    np.testing.assert_allclose(continuation(r, 3), [[100, 121, 144], [1, 1, 1]])
    np.testing.assert_allclose(continuation(r, 2, period_samples=4), [[100, 121], [1, 1]])  # not periodic
    per = np.tile([[0.0, 1.0, 3.0, 2.0, -1.0]], (1, 4))
    np.testing.assert_allclose(continuation(per, 3, period_samples=5), [[0.0, 1.0, 3.0]])
    f = fade_in(np.ones((1, 8)), 4)
    np.testing.assert_allclose(f[0], [0, 0.5 - 0.5 * np.cos(np.pi / 4), 0.5,
                                      0.5 + 0.5 * np.cos(np.pi / 4), 1, 1, 1, 1])


def test_state_space_preset(coupled, tmp_path):
    G0 = dc_gain(coupled.dynamics)
    np.testing.assert_allclose(G0, [[1.08, -0.06], [0.08, 0.94]], atol=1e-9)   # not forced to I
    with pytest.raises(PresetError, match=r"dynamics\.A: expected an asymptotically stable"):
        dynamics_from_table({"kind": "state_space", "A": [[1.0]], "B": [[1.0, 0.0]],
                             "C": [[1.0], [1.0]]}, ["x", "y"])
    with pytest.raises(PresetError, match=r"dynamics\.C: expected shape"):
        dynamics_from_table({"kind": "state_space", "A": [[-1.0]], "B": [[1.0, 0.0]],
                             "C": [[1.0]]}, ["x", "y"])
    with pytest.raises(PresetError, match=r"dynamics\.B: expected shape \(1, 2\)"):
        dynamics_from_table({"kind": "state_space", "A": [[-1.0]], "B": [[1.0]], "C": [[1.0]]},
                            ["x", "y"])
    with pytest.raises(PresetError, match=r"dynamics\.A: missing"):
        dynamics_from_table({"kind": "state_space", "B": [[1.0]]}, ["x"])
    save_dynamics(coupled.dynamics, tmp_path / "g.toml")
    G = load_dynamics(tmp_path / "g.toml", ["x", "y"], coupled.sampling_period)
    np.testing.assert_allclose(dc_gain(G), G0, atol=1e-8)
    w = np.exp(1j * 2 * np.pi * 300.0 * coupled.sampling_period)
    np.testing.assert_allclose(G(w), coupled.dynamics(w), atol=1e-8)


def _scenario(tmp_path, comp, reference, name="s"):
    p = tmp_path / f"{name}.toml"
    p.write_text(f'name = "{name}"\n[plant]\npreset = "rakotondrabe-2dof"\n[compensator]\n{comp}\n'
                 f'[[cases]]\nname = "c"\nreference = {reference}\nsettle_periods = 4\n',
                 encoding="utf-8")
    return p


def test_multivariable_300hz_sine_warns_once(tmp_path):
    from hammerstein.scenario.resolve import load_scenario
    sc = load_scenario(_scenario(tmp_path, 'kind = "multivariable"',
                                 '{ kind = "sine", output = "y", amplitude = 30.0, '
                                 'frequency = 300.0, periods = 6 }'))
    hits = [w for w in sc.cases[0].warnings if 'kind = "hammerstein"' in w]
    assert len(hits) == 1


def test_slow_reference_does_not_warn(tmp_path):
    from hammerstein.scenario.resolve import load_scenario
    sc = load_scenario(_scenario(tmp_path, 'kind = "multivariable"',
                                 '{ kind = "sine", output = "y", amplitude = 30.0, '
                                 'frequency = 5.0, periods = 6 }'))
    assert not [w for w in sc.cases[0].warnings if "hammerstein" in w]


def test_validation_names_keys(tmp_path):
    from hammerstein.scenario.schema import ScenarioError
    from hammerstein.scenario.validate import validate_scenario
    p = _scenario(tmp_path, 'kind = "hammerstein"\ndynamics = "nope.toml"\ninversion = "fft"\n'
                            'identify_dynamics = { amplitud = 3.0 }',
                  '{ kind = "circle", radius = 20.0, frequency = 100.0, periods = 6 }')
    with pytest.raises(ScenarioError) as err:
        validate_scenario(p)
    text = str(err.value)
    assert "compensator.inversion" in text and "identify_dynamics" in text


def test_hammerstein_kind_with_true_models_runs(tmp_path):
    from hammerstein.scenario.execute import run_case
    from hammerstein.scenario.resolve import load_scenario
    sc = load_scenario(_scenario(tmp_path, 'kind = "hammerstein"',
                                 '{ kind = "circle", radius = 20.0, frequency = 150.0, periods = 6 }'))
    r = run_case(sc.cases[0])
    val = {m["metric"]: m["value"] for m in r.metrics}
    assert val["max_euclidean_error_percent"] < 0.5
    assert sc.cases[0].compensator.preview_samples == 2


@pytest.mark.slow
def test_identified_hammerstein_meets_targets(tmp_path):
    """Identified PI (F = 50 Hz requested) and G, sensor on: a 20 µm circle at 170 Hz <= 2 %."""
    from hammerstein.scenario.execute import run_case
    from hammerstein.scenario.resolve import load_scenario
    sc = load_scenario(_scenario(
        tmp_path, 'kind = "hammerstein"\nmodel = "identified"\n'
                  'identify = { frequency = 50.0, sensor = true }\ndynamics = "identified"',
        '{ kind = "circle", radius = 20.0, frequency = 170.0, periods = 8 }'))
    val = {m["metric"]: m["value"] for m in run_case(sc.cases[0]).metrics}
    assert val["max_euclidean_error_percent"] < 2.0


@pytest.mark.parametrize("A, match", [
    ([[0.0, 1.0, 0.0], [-1.0, -0.5, 0.0]], r"dynamics\.A: expected a non-empty square matrix .* \(2, 3\)"),
    ([1.0, 2.0], r"dynamics\.A: expected a non-empty square matrix .* \(2,\)"),
    ([], r"dynamics\.A: expected a non-empty square matrix")])
def test_non_square_state_matrix_is_named_as_such(A, match):
    """Regression: a 2 x 3 A read 'expected shape (2, 2) for 2 outputs and 2 states'."""
    table = {"kind": "state_space", "A": A, "B": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
             "C": [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]}
    with pytest.raises(PresetError, match=match):
        dynamics_from_table(table, ["x", "y"])


def test_the_stable_inversion_reads_the_periods_past_the_record_end():
    """A zero of G outside the unit circle near z = -1 (a sampling zero of an identified G)
    is an anti-causal Nyquist-rate mode of the stable inverse. Held at its last value, a
    circle's record kinks at its end and that mode rings back over its last samples (the drive
    reverses every sample: a new user's stage, 15-50 V); read on over its own periods, the
    record's end is like any other period: the drive's last period equals the one before."""
    import control
    pl = load_plant("rakotondrabe-2dof")
    T = pl.sampling_period
    zero = control.ss(control.tf([1.0, 1.15], [2.15, 0.0], T))   # unit DC gain, zero at -1.15
    G = control.ss(pl.dynamics) * control.append(zero, zero)
    comp = HammersteinCompensator(pl.hysteresis, G, inversion="stable")
    assert comp.stable_lookahead(1e-9) == int(np.ceil(np.log(1e9) / np.log(1.15)))
    f, R = 100.0, 20.0
    per = int(round(1 / (f * T)))
    yr = circle(T, 12 * per, f, R)
    lead, s0, _ = comp.start(yr, per, 2 * per)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                      # within the model's range
        u, _ = comp.simulate(lead, s0)
    last, before = u[:, -per:], u[:, -2 * per:-per]
    np.testing.assert_allclose(last, before, atol=1e-6 * np.abs(u).max())
    comp._stable_period = None                              # held at its last value, as before
    with pytest.warns(Warning, match="beyond the range"):  # the ring leaves the model's range
        u_held, _ = comp.simulate(lead, s0)
    d = np.diff(u_held[:, -20:], axis=1)
    assert np.any(d[:, :-1] * d[:, 1:] < 0) and np.abs(u_held[:, -per:] - last).max() > \
        100 * np.abs(last - before).max()


@pytest.mark.parametrize("bad, shape", [(lambda r: r[0], "(1600,)"), (lambda r: r.T, "(1600, 2)"),
                                        (lambda r: r[:1], "(1, 1600)")])
def test_a_misshapen_reference_is_named_with_the_shape_given(preset_plant, bad, shape):
    # a (1600,) record was reported as "found shape (1600, 2)", the preview-padded array's
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    t = np.arange(1600) * preset_plant.sampling_period
    r = 20 * np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 50 * t)])
    with pytest.raises(CompensatorError, match=r"reference: expected a finite \(2, n_samples\) "
                                               r"array \[µm\], one row per output, found shape "
                                               + re.escape(shape)):
        comp.run_reference(preset_plant, bad(r), period_samples=400, fade_samples=400)
    r[1, 700] = np.nan
    with pytest.raises(CompensatorError, match="non-finite value at sample 700"):
        comp.start(r, 400, 400)
