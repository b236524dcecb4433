"""Plants outside the classical-PI class: Preisach, generalised PI, creep, mixed models.

Expectations are derived independently: naive numpy loops written from the
definitions (oracles of the compiled kernels), closed forms (creep step
response, the Everett function as first-order reversal curves), and the
mathematical properties of the Preisach model (wiping-out, PI-like minor
loops when the density depends on alpha - beta only).
"""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein import (HammersteinPlant, InverseMultiplicativeCompensator, MultivariablePI,
                         PrandtlIshlinskii, simulate_chain, simulate_chain_batch)
from hammerstein.models.creep import Creep, creep_from_table
from hammerstein.models.dynamics import sampled_bending_modes
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.preisach import (MultivariableHysteresis, Polynomial, PreisachModel,
                                       component_from_table, hysteresis_from_table)
from hammerstein.io.presets import model_from_table, model_to_table
from hammerstein.exceptions import HysteresisError, PresetError

T = 5e-5


# -- oracles ---------------------------------------------------------------------
def ramp(u, lo, hi):
    return float(np.clip(2 * (u - lo) / (hi - lo) - 1, -1, 1))


def preisach_oracle(model, u, state):
    """Every hysteron of the lower triangle, one by one, from the definitions."""
    e, n = model.edges, model.n_levels
    s = np.array(state, dtype=float)
    y = np.empty(len(u))
    for t, ut in enumerate(u):
        q, acc = 0, 0.0
        for i in range(n):
            for j in range(i + 1):
                up, down = ramp(ut, e[i], e[i + 1]), ramp(ut, e[j], e[j + 1])
                s[q] = max(up, min(down, s[q]))
                acc += model.weights[i, j] * s[q]
                q += 1
        y[t] = acc + sum(c * ut ** (k + 1) for k, c in enumerate(model.reversible)) + model.offset
    return y, s


def gpi_oracle(g, u, state):
    s = np.array(state, dtype=float)
    y = np.empty(len(u))
    for t, ut in enumerate(u):
        lo = g.gamma_l[0] * np.tanh(g.gamma_l[1] * ut + g.gamma_l[2]) + g.gamma_l[3]
        hi = g.gamma_r[0] * np.tanh(g.gamma_r[1] * ut + g.gamma_r[2]) + g.gamma_r[3]
        s = np.maximum(lo - g.thresholds, np.minimum(hi + g.thresholds, s))
        y[t] = g.weights @ s + g.offset
    return y, s


def random_walk(n, seed, amp=10.0):
    rng = np.random.default_rng(seed)
    return np.clip(np.cumsum(rng.normal(0, 1.5, n)), -amp * 1.1, amp * 1.1)


EDGES = np.linspace(-10.5, 10.5, 15)


def asymmetric():
    return PreisachModel.from_density(EDGES, 20.0, bias=0.5, bias_width=2.5, tilt=0.4,
                                      coercivity=2.0, coercivity_width=1.5,
                                      reversible=[4.0, 0.05], offset=0.3)


def pi_like(edges=EDGES):
    return PreisachModel.from_density(edges, 20.0, bias_width=1e6, coercivity=2.0,
                                      coercivity_width=1.5)


# -- Preisach --------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_preisach_kernel_matches_the_naive_oracle(seed):
    model = asymmetric()
    u = random_walk(300, seed)
    s0 = model.initial_state()
    y, s = model.simulate(u, s0)
    y_ref, s_ref = preisach_oracle(model, u, s0)
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=1e-12)


def test_preisach_chunked_equals_whole():
    model = asymmetric()
    u = random_walk(500, 3)
    y, s = model.simulate(u)
    y1, s1 = model.simulate(u[:123])
    y2, s2 = model.simulate(u[123:], s1)
    np.testing.assert_array_equal(np.concatenate([y1, y2]), y)
    np.testing.assert_array_equal(s2, s)


def test_wiping_out_a_minor_loop_leaves_the_same_state():
    model = asymmetric()
    base = [0.0, 8.0, -8.0, 5.0]
    with_minor = [0.0, 8.0, -8.0, 3.0, -2.0, 2.5, -1.0, 5.0]
    path = lambda pts: np.concatenate([np.linspace(a, b, 60) for a, b in zip(pts, pts[1:])])
    _, s_base = model.simulate(path(base))
    _, s_minor = model.simulate(path(with_minor))
    np.testing.assert_allclose(s_minor, s_base, atol=1e-12)


def test_everett_table_is_the_first_order_reversal_curve_and_round_trips():
    model = asymmetric()
    E = model.everett()
    e = model.edges
    for a, b in [(10, 3), (14, 0), (7, 6), (12, 9)]:
        # from negative saturation up to L_a, then down to L_b
        y, _ = model.simulate([e[0] - 1, e[a], e[b]], -np.ones(model.n_states))
        hyst = y - model.reversible_part(np.array([e[0] - 1, e[a], e[b]]))
        assert hyst[1] - hyst[2] == pytest.approx(E[a, b], abs=1e-9)
    back = PreisachModel.from_everett(model.edges, E)
    np.testing.assert_allclose(back.weights, model.weights, atol=1e-12)


def _rise_after_descent(model, m, d):
    """Output change rising by d after a descent from positive saturation to m."""
    y, _ = model.simulate([11.0, m, m + d], model.initial_state())
    y = y - model.reversible_part(np.array([11.0, m, m + d]))
    return y[2] - y[1]


def test_pi_like_density_gives_pi_minor_loops_and_a_tilted_one_does_not():
    step = EDGES[1] - EDGES[0]
    m1, m2, d = EDGES[2], EDGES[8], 3 * step
    pi = pi_like()
    assert _rise_after_descent(pi, m1, d) == pytest.approx(_rise_after_descent(pi, m2, d), rel=1e-9)
    tilted = asymmetric()
    r1, r2 = _rise_after_descent(tilted, m1, d), _rise_after_descent(tilted, m2, d)
    assert abs(r1 - r2) > 0.2 * max(r1, r2)


def test_preisach_loop_is_asymmetric_and_point_symmetric_without_tilt():
    u = 10 * np.sin(2 * np.pi * np.arange(2001) / 1000)
    for model, symmetric in ((pi_like(), True), (asymmetric(), False)):
        y, _ = model.simulate(u)
        # point symmetry of the loop: u(t + P/2) = -u(t) gives y(t + P/2) = -y(t) (second period)
        asym = np.max(np.abs(y[1000:1500] + y[1500:2000]))
        assert (asym < 1e-9) if symmetric else (asym > 5.0)


@pytest.mark.parametrize("table,message", [
    ({"kind": "preisach", "range": [-1, 1], "n_levels": 4}, "exactly one of weights"),
    ({"kind": "preisach", "range": [1, -1], "n_levels": 4, "density": {"total": 1}}, "range"),
    ({"kind": "preisach", "range": [-1, 1], "n_levels": 0, "density": {"total": 1}}, "n_levels"),
    ({"kind": "preisach", "edges": [0, 1], "weights": [[-1.0]]}, "non-negative"),
    ({"kind": "preisach", "edges": [0, 1, 2], "weights": [[1.0, 1.0], [0, 1]]}, "above the diagonal"),
    ({"kind": "preisach", "range": [-1, 1], "n_levels": 4, "density": {"total": 1, "bais": 0}},
     "density.bais"),
    ({"kind": "preisach", "range": [-1, 1], "n_levels": 4, "density": {"total": -1}}, "total"),
    ({"kind": "preisach", "range": [-1, 1], "n_levels": 4, "densty": {}}, "densty: unknown key"),
    ({"kind": "presach"}, "kind: expected one of"),
    ({"kind": "generalized_pi", "thresholds": [0, 1], "weights": [1, 1]}, "gamma_l: missing"),
    ({"kind": "generalized_pi", "thresholds": [0, 1], "weights": [1], "gamma_l": [1, 1, 0, 0],
      "gamma_r": [1, 1, 0, 0]}, "weights: expected 2"),
    ({"kind": "polynomial"}, "coefficients: missing"),
])
def test_component_errors_name_the_key(table, message):
    with pytest.raises(HysteresisError, match="model.components.x.ux") as exc:
        component_from_table(table, "model.components.x.ux")
    assert message in str(exc.value)


# -- generalised PI --------------------------------------------------------------
def gpi():
    return GeneralizedPI([0.0, 0.8, 2.0, 4.0], [3.0, 0.8, 0.5, 0.3],
                         gamma_l=[12.0, 0.09, 0.05, 0.2], gamma_r=[11.0, 0.1, -0.02, 0.0],
                         offset=-0.5)


@pytest.mark.parametrize("seed", [0, 1])
def test_generalized_pi_matches_the_oracle_and_chunks(seed):
    g = gpi()
    u = random_walk(400, seed)
    y, s = g.simulate(u)
    y_ref, s_ref = gpi_oracle(g, u, g.initial_state())
    np.testing.assert_allclose(y, y_ref, atol=1e-10)
    y1, s1 = g.simulate(u[:150])
    y2, s2 = g.simulate(u[150:], s1)
    np.testing.assert_array_equal(np.concatenate([y1, y2]), y)
    np.testing.assert_array_equal(s2, s)


def test_generalized_pi_rest_value_is_clipped_to_each_play_band():
    # gamma_l(0) = 12 tanh(0.05) + 0.2 = 0.7996, gamma_r(0) = 11 tanh(-0.02) = -0.2200: the
    # band of play j at rest is [0.7996 - r_j, -0.2200 + r_j]; r = 0 has an empty band (both
    # bounds clip to gamma_l(0) - r first, as the play law max(lo, min(hi, s)) does)
    lo = 12.0 * np.tanh(0.05) + 0.2 - np.array([0.0, 0.8, 2.0, 4.0])
    hi = 11.0 * np.tanh(-0.02) + np.array([0.0, 0.8, 2.0, 4.0])
    for rest, expected in [(0.0, [lo[0], 0.0, 0.0, 0.0]), (-1.5, [lo[0], lo[1], lo[2], -1.5]),
                           (3.0, [lo[0], hi[1], 1.78, 3.0])]:
        g = GeneralizedPI(gpi().thresholds, gpi().weights, gpi().gamma_l, gpi().gamma_r,
                          rest=rest)
        np.testing.assert_allclose(g.initial_state(), expected, atol=1e-4)
        np.testing.assert_allclose(g.initial_state(), np.maximum(lo, np.minimum(hi, rest)))
        y, _ = g.simulate(np.zeros(3))            # at rest: the weighted rest states
        np.testing.assert_allclose(y, g.weights @ g.initial_state(), atol=1e-12)
        back = GeneralizedPI.from_table(g.to_table())
        assert back.rest == rest and ("rest" in g.to_table()) == (rest != 0.0)
    with pytest.raises(HysteresisError, match="rest"):
        GeneralizedPI([0.0], [1.0], [1.0, 1.0, 0, 0], [1.0, 1.0, 0, 0], rest=float("nan"))


def test_generalized_pi_with_near_linear_envelopes_is_the_classical_pi():
    r, w = [0.0, 1.0, 2.5], [1.0, 0.5, 0.25]
    lin = [1e4, 1e-4, 0.0, 0.0]                   # 1e4 tanh(1e-4 u) = u - 3e-5 at 10 V
    g = GeneralizedPI(r, w, lin, lin)
    u = random_walk(300, 5)
    y, _ = g.simulate(u, np.zeros(3))
    y_pi, _ = PrandtlIshlinskii(r, w).simulate(u)
    np.testing.assert_allclose(y, y_pi, atol=1e-4)


# -- creep -----------------------------------------------------------------------
def test_creep_step_response_is_the_closed_form_at_every_sample():
    c = Creep([0.01, 0.3], [0.02, 0.05])
    n = 2000
    y, _ = c.simulate(np.ones((1, n)), T)
    t = np.arange(n) * T
    expected = 1 + 0.02 * (1 - np.exp(-t / 0.01)) + 0.05 * (1 - np.exp(-t / 0.3))
    np.testing.assert_allclose(y[0], expected, rtol=1e-12)


def test_log_law_creep_grows_by_the_rate_per_decade():
    c = Creep.log_law(0.015, 0.01, 100.0, per_decade=3)
    Ts = 1e-3
    y, _ = c.simulate(np.ones((1, 10001)), Ts)
    at = lambda sec: y[0, int(round(sec / Ts))]
    assert at(10.0) / at(0.1) - 1 == pytest.approx(0.03, abs=0.002)
    assert at(1.0) / at(0.1) - 1 == pytest.approx(0.015, abs=0.001)


@pytest.mark.parametrize("table,message", [
    ({"kind": "log", "rate_per_decade": 0.01, "t_min": 1.0}, "creep.x.t_max: missing"),
    ({"kind": "log", "rate_per_decade": 0.01, "t_min": 1.0, "t_max": 0.5}, "t_min"),
    ({"kind": "lags", "time_constants": [1.0, -1.0], "weights": [0.1, 0.1]}, "time_constants"),
    ({"kind": "lags", "time_constants": [1.0], "weights": [0.1, 0.1]}, "weights"),
    ({"kind": "drift"}, "creep.x.kind"),
    ({"kind": "lags", "tau": [1.0]}, "creep.x.tau: unknown key"),
])
def test_creep_errors_name_the_key(table, message):
    with pytest.raises(HysteresisError) as exc:
        creep_from_table(table, "creep.x")
    assert message in str(exc.value)


# -- multivariable model, tables, plant ------------------------------------------
def mixed():
    return MultivariableHysteresis(
        [[asymmetric(), PreisachModel.from_density(EDGES, 1.0, coercivity=2.0, reversible=[0.2])],
         [Polynomial([0.05, 0.03]), gpi()]],
        input_names=["ux", "uy"], output_names=["x", "y"], input_amplitude=[10.0, 10.0])


def inputs(n=800):
    return np.vstack([random_walk(n, 7), random_walk(n, 8)])


def test_mixed_model_is_the_sum_of_its_components_and_chunks():
    model = mixed()
    u = inputs()
    y, s = model.simulate(u)
    yx = asymmetric().simulate(u[0])[0] + model.component("x", "uy").simulate(u[1])[0]
    yy = 0.05 * u[0] + 0.03 * u[0] ** 2 + gpi_oracle(gpi(), u[1], gpi().initial_state())[0]
    np.testing.assert_allclose(y, np.vstack([yx, yy]), atol=1e-9)
    y1, s1 = model.simulate(u[:, :300])
    y2, s2 = model.simulate(u[:, 300:], s1)
    np.testing.assert_array_equal(np.hstack([y1, y2]), y)
    np.testing.assert_array_equal(s2, s)


def test_model_table_round_trip_through_the_preset_reader():
    model = mixed()
    back = model_from_table(model_to_table(model))
    assert isinstance(back, MultivariableHysteresis)
    u = inputs(300)
    np.testing.assert_allclose(back.simulate(u)[0], model.simulate(u)[0], atol=1e-9)


def test_mixed_table_with_a_classical_pi_component_and_shared_thresholds():
    table = {"inputs": ["ux"], "outputs": ["x", "y"], "thresholds": [0.0, 1.0],
             "components": {"x": {"ux": {"kind": "preisach", "range": [-10, 10], "n_levels": 8,
                                         "density": {"total": 5.0, "coercivity": 1.0}}},
                            "y": {"ux": {"weights": [1.0, 0.5]}}}}
    model = hysteresis_from_table(table)
    u = random_walk(200, 9)
    np.testing.assert_allclose(model.simulate(u[None])[0][1],
                               PrandtlIshlinskii([0.0, 1.0], [1.0, 0.5]).simulate(u)[0])


def test_preset_reader_reports_every_bad_component():
    table = {"inputs": ["ux"], "outputs": ["x"],
             "components": {"x": {"ux": {"kind": "preisach", "range": [-1, 1]}},
                            "z": {"ux": {"kind": "polynomial", "coefficients": [1.0]}}}}
    with pytest.raises(PresetError) as exc:
        model_from_table(table, "f.toml")
    msg = str(exc.value)
    assert msg.startswith("f.toml: ") and "model.components.x.ux.n_levels: missing" in msg
    assert "model.components.z" in msg


def linear_oracle(h, mats, x):
    A, B, C, D = mats
    y = np.empty((C.shape[0], h.shape[1]))
    for t in range(h.shape[1]):
        y[:, t] = C @ x + D @ h[:, t]
        x = A @ x + B @ h[:, t]
    return y, x


def plant(model, creep=True):
    lin = sampled_bending_modes([450.0, 420.0], [0.05, 0.06], ["x", "y"], T)
    return HammersteinPlant(model, T, lin, creep=[Creep.log_law(0.015, 0.01, 10.0), None]
                            if creep else None)


def test_plant_is_hysteresis_then_creep_then_dynamics_and_chunks():
    pl = plant(mixed())
    u = inputs(1000)
    y, s = pl.simulate(u)
    h, _ = pl.hysteresis.simulate(u)
    hc, _ = Creep.log_law(0.015, 0.01, 10.0).simulate(h[:1], T)
    lin = sampled_bending_modes([450.0, 420.0], [0.05, 0.06], ["x", "y"], T)
    y_ref, _ = linear_oracle(np.vstack([hc, h[1:]]), (lin.A, lin.B, lin.C, lin.D),
                             np.zeros(lin.A.shape[0]))
    np.testing.assert_allclose(y, y_ref, atol=1e-9)
    y1, s1 = pl.simulate(u[:, :400])
    y2, s2 = pl.simulate(u[:, 400:], s1)
    np.testing.assert_allclose(np.hstack([y1, y2]), y, atol=1e-12)
    np.testing.assert_allclose(s2, s, atol=1e-12)


def test_plant_rejects_a_bad_state_and_creep():
    pl = plant(mixed())
    bad = pl.initial_state()
    bad[0] = 3.0                                   # a hysteron state outside [-1, 1]
    with pytest.raises(HysteresisError, match="initial_state"):
        pl.simulate(inputs(10), bad)
    with pytest.raises(HysteresisError, match="creep"):
        HammersteinPlant(mixed(), T, None, creep=[Creep([1.0], [0.1])])


def rakotondrabe_like():
    r = [0.0, 1.0, 2.5, 5.0]
    return MultivariablePI([[PrandtlIshlinskii(r, [4.0, 0.5, 0.3, 0.2]), 0.1],
                            [0.05, PrandtlIshlinskii(r, [3.6, 0.4, 0.3, 0.2])]],
                           input_names=["ux", "uy"], output_names=["x", "y"],
                           input_amplitude=[10.0, 10.0])


def circle(n=3000, radius=30.0, f=50.0):
    t = np.arange(n) * T
    return np.vstack([radius * np.cos(2 * np.pi * f * t), radius * np.sin(2 * np.pi * f * t)])


def test_fused_chain_with_creep_equals_compensator_then_plant():
    model = rakotondrabe_like()
    pl = plant(model)
    comp = InverseMultiplicativeCompensator(model)
    r = circle()
    fused = simulate_chain(comp, pl, r)
    u, _ = comp.simulate(r)
    y, _ = pl.simulate(u)
    np.testing.assert_allclose(fused.outputs, y, atol=1e-9)
    nocreep = simulate_chain(comp, plant(model, creep=False), r)
    assert np.max(np.abs(nocreep.outputs - fused.outputs)) > 0.1   # creep is not a no-op


def test_chain_on_a_preisach_plant_falls_back_to_compensator_then_plant():
    pl = plant(mixed())
    comp = InverseMultiplicativeCompensator(rakotondrabe_like())
    r = circle()
    res = simulate_chain(comp, pl, r)
    u, _ = comp.simulate(r)
    y, _ = pl.simulate(u)
    assert not res.diverged
    np.testing.assert_allclose(res.outputs, y, atol=1e-12)
    np.testing.assert_allclose(res.inputs, u, atol=1e-12)


def test_batch_on_preisach_plants_runs_each_case_unfused():
    pl = plant(mixed())
    comp = InverseMultiplicativeCompensator(rakotondrabe_like())
    refs = [circle(800), circle(600, radius=15.0, f=100.0)]
    outs = simulate_chain_batch(comp, pl, refs)
    for r, res in zip(refs, outs):
        np.testing.assert_allclose(res.outputs, simulate_chain(comp, pl, r).outputs, atol=1e-12)
