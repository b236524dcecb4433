"""Analytic inverse PI (Kuhnen & Janocha, docs/per-axis-inverse.md) and the inverse play operator."""

import numpy as np
import pytest

from hammerstein.models.hysteresis import HysteresisError, PrandtlIshlinskii, play
from hammerstein.compensation.inverse import InversePlay, kuhnen_inverse, kuhnen_inverse_parameters

T = 5e-5


@pytest.fixture
def model(static_plant):
    return static_plant.hysteresis


def piecewise_monotone(rng, peak, n_extrema=12, samples=(20, 300)):
    """Random piecewise-linear record through random extrema in [-peak, peak]."""
    ext = np.concatenate([[0.0], rng.uniform(-peak, peak, n_extrema)])
    parts = [np.linspace(a, b, rng.integers(*samples), endpoint=False) for a, b in zip(ext[:-1], ext[1:])]
    return np.concatenate(parts + [ext[-1:]])


# -- closed form ---------------------------------------------------------------------------
@pytest.mark.parametrize("r, w, r_inv, w_inv", [
    # hand: S = (2, 3); r'_2 = w_1 (r_2 - r_1) = 2; w'_2 = -1 / (3 * 2)
    ([0.0, 1.0], [2.0, 1.0], [0.0, 2.0], [0.5, -1.0 / 6.0]),
    # hand: S = (2, 3, 4); r'_3 = 2*3 + 1*2 = 8; w'_3 = -1 / (4 * 3)
    ([0.0, 1.0, 3.0], [2.0, 1.0, 1.0], [0.0, 2.0, 8.0], [0.5, -1.0 / 6.0, -1.0 / 12.0]),
    # a negative weight with positive sums: S = (4, 3); w'_2 = +1 / (3 * 4)
    ([0.0, 0.5], [4.0, -1.0], [0.0, 2.0], [0.25, 1.0 / 12.0]),
])
def test_closed_form_weights_by_hand(r, w, r_inv, w_inv):
    got_r, got_w = kuhnen_inverse_parameters(r, w)
    np.testing.assert_allclose(got_r, r_inv, rtol=0, atol=1e-15)
    np.testing.assert_allclose(got_w, w_inv, rtol=1e-15, atol=0)


def test_inverse_slopes_are_reciprocal_cumulative_sums(model):
    """On any branch the inverse's slopes are 1/S_i: cumsum(w') = 1/cumsum(w)."""
    pi = model.component("x", "ux")
    _, w_inv = kuhnen_inverse_parameters(pi.thresholds - pi.thresholds[0], pi.weights)
    np.testing.assert_allclose(np.cumsum(w_inv), 1.0 / np.cumsum(pi.weights), rtol=1e-12)


def test_inverse_thresholds_lie_on_the_virgin_curve(model):
    """r'_i is the shifted operator's virgin-curve output at r~_i (zero states)."""
    pi = model.component("y", "uy")
    shifted = PrandtlIshlinskii(pi.thresholds - pi.thresholds[0], pi.weights)
    r_inv, _ = kuhnen_inverse_parameters(shifted.thresholds, shifted.weights)
    virgin = [shifted.simulate(np.linspace(0, r, 50))[0][-1] for r in shifted.thresholds]
    np.testing.assert_allclose(r_inv, virgin, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("w, bad_i", [([1.0, -2.0], 2), ([-1.0, 3.0], 1), ([1.0, 1.0, -2.0], 3)])
def test_non_positive_cumulative_sum_is_rejected(w, bad_i):
    r = np.arange(len(w), dtype=float) * 0.5 + 0.1
    with pytest.raises(HysteresisError, match=rf"Gamma_test: weights: .*S_{bad_i} = .*<= 0"):
        kuhnen_inverse(PrandtlIshlinskii(r, w), name="Gamma_test")


def test_closed_form_needs_zero_first_threshold():
    with pytest.raises(HysteresisError, match="r_1 = 0"):
        kuhnen_inverse_parameters([0.1, 1.0], [1.0, 1.0])


# -- play semigroup and the inverse play ---------------------------------------------------
@pytest.mark.parametrize("seed", range(4))
def test_play_semigroup(seed):
    """play_a o play_b = play_{a+b} in discrete time, from consistent states."""
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(0, 2, 2)
    u = np.cumsum(rng.normal(size=2000)) + 5 * rng.normal(size=2000) * (rng.random(2000) < 0.05)
    z0 = rng.uniform(-b, b)           # play_b state, input u(-T) = 0
    y0 = z0 + rng.uniform(-a, a)      # play_a state, |y0 - z0| <= a
    z, _ = play(u, [b], [z0])
    y_composed, _ = play(z[0], [a], [y0])
    y_direct, _ = play(u, [a + b], [y0])
    np.testing.assert_allclose(y_composed, y_direct, rtol=0, atol=1e-12)


def test_inverse_play_exact_on_dyadic_signals():
    """With values exactly representable, play_r(inverse(y)) == y bit for bit."""
    rng = np.random.default_rng(0)
    y = np.repeat(rng.integers(-40, 40, 300), rng.integers(1, 4, 300)) / 8.0
    r, y0, u0 = 0.25, 0.5, 0.375
    u, final = InversePlay(r).simulate(y, [y0, u0])
    back, state = play(u, [r], [y0])
    np.testing.assert_array_equal(back[0], y)
    np.testing.assert_array_equal(final, [y[-1], u[-1]])
    assert np.all(np.abs(u - y) <= r)


@pytest.mark.parametrize("r", [0.0, 0.07, 1.3])
def test_inverse_play_random(r):
    rng = np.random.default_rng(1)
    y = np.cumsum(rng.normal(size=3000) * (rng.random(3000) < 0.7))  # with flat stretches
    y0 = 0.3
    u0 = y0 - 0.5 * r
    u, _ = InversePlay(r).simulate(y, [y0, u0])
    back, _ = play(u, [r], [y0])
    np.testing.assert_allclose(back[0], y, rtol=0, atol=1e-12)


def test_inverse_play_chunked_equals_single_run():
    rng = np.random.default_rng(2)
    y = np.cumsum(rng.normal(size=1000))
    inv = InversePlay(0.4)
    u_all, f_all = inv.simulate(y)
    u1, s1 = inv.simulate(y[:377])
    u2, s2 = inv.simulate(y[377:], s1)
    np.testing.assert_array_equal(np.concatenate([u1, u2]), u_all)
    np.testing.assert_array_equal(s2, f_all)


@pytest.mark.parametrize("r, e", [(0.4, 1e-3), (0.0, 1e-3), (1.3, 0.05)])
def test_inverse_play_with_a_tolerance_stays_within_it(r, e):
    """Held runs, motions below e (a slow drift of e/7 per sample included) and large
    motions: the play operator driven by u outputs y within e, y itself (to rounding) on
    the samples where y moved by more than e, and u never moves while y stays within e of
    where it stopped. Chunked equals whole."""
    rng = np.random.default_rng(3)
    big = rng.normal(size=600) * (rng.random(600) < 0.4)
    tiny = rng.uniform(-e, e, 600) * (rng.random(600) < 0.5)
    y = np.cumsum(np.concatenate([big + tiny, np.full(200, e / 7.3)]))
    inv = InversePlay(r, e)
    u, final = inv.simulate(y, [y[0], y[0]])
    back, _ = play(u, [r], [y[0]])
    assert np.max(np.abs(back[0] - y)) <= e * (1 + 1e-12)
    anchor, exact, still = y[0], [], []
    for t in range(y.size):             # the rule written out
        if abs(y[t] - anchor) > e:
            anchor = y[t]
            exact.append(t)
        elif t:
            still.append(t)
    np.testing.assert_allclose(back[0, exact], y[exact], rtol=0, atol=1e-13)
    still = np.array(still)
    np.testing.assert_array_equal(u[still], u[still - 1])
    u1, s1 = inv.simulate(y[:301], [y[0], y[0]])
    u2, s2 = inv.simulate(y[301:], s1)
    np.testing.assert_allclose(np.concatenate([u1, u2]), u, rtol=0, atol=1e-15)
    np.testing.assert_allclose(s2, final, rtol=0, atol=1e-15)


@pytest.mark.parametrize("seed", range(12))
def test_a_held_rest_output_after_the_cycle_holds_the_inputs_at_rest(seed):
    """The per-axis inverse of a classical PI started after a demagnetising cycle, fed a
    reference held at the model's rest output: the inputs stay at 0 V. The cycle leaves
    the inverse plays at their bands' edges; the rest output, rounded 1 ulp away, moved
    them, and the inverse play answered that rounding by jumping up to 2 r_1 (on 11 of
    these 12 random models before the inverse play ignored motions below 1e-12 of the
    operator's voltage scale)."""
    from hammerstein import PerAxisInverseCompensator
    from random_models import random_direct_model
    model = random_direct_model(seed, 30.0)
    comp = PerAxisInverseCompensator(model)
    rest = model.simulate(np.zeros((2, 1)))[0]
    u, _ = comp.simulate(np.repeat(rest, 20, axis=1))
    assert np.max(np.abs(u)) <= 1e-12, np.max(np.abs(u), axis=1)


@pytest.mark.parametrize("state, match", [([0.0, 0.5], "exceeds the threshold"),
                                          ([0.0], "expected \\[y_prev, u_prev\\]")])
def test_inverse_play_rejects_bad_state(state, match):
    with pytest.raises(HysteresisError, match=match):
        InversePlay(0.2).simulate([1.0, 2.0], state)


# -- the inverse of the preset's direct transfers (r_1 = 0.07 V) ---------------------------
def references(peak):
    t = np.arange(1200) * T
    yield "sine 50 Hz", 0.95 * peak * np.sin(2 * np.pi * 50 * t)
    for seed in range(3):
        yield f"piecewise monotone {seed}", piecewise_monotone(np.random.default_rng(seed), 0.95 * peak)


@pytest.mark.parametrize("axis", ["x", "y"])
def test_inverse_composed_with_model_is_identity(model, axis):
    pi = model.component(axis, "u" + axis)
    assert pi.thresholds[0] == pytest.approx(0.07)
    inv = kuhnen_inverse(pi, name=f"Gamma_{axis}")
    peak = pi.peak_output(model.input_amplitude[0])
    for label, yr in references(peak):
        u, _ = inv.simulate(yr)
        y, _ = pi.simulate(u)
        np.testing.assert_allclose(y, yr, rtol=0, atol=1e-9, err_msg=label)
        assert np.max(np.abs(u)) <= 10.0 + 1e-9, label  # stays in the identified range


def test_inverse_chunked_and_consistent_state(model):
    """Continue after an arbitrary history of the operator from consistent_state."""
    pi = model.component("x", "ux")
    inv = kuhnen_inverse(pi)
    rng = np.random.default_rng(5)
    u_hist = piecewise_monotone(rng, 9.0)
    y_hist, z = pi.simulate(u_hist)
    # the inverse's own state after y_hist matches the formula on the play states
    _, own = inv.simulate(y_hist)
    state = inv.consistent_state(z, u_hist[-1])
    np.testing.assert_allclose(state[:-2], own[:-2], rtol=0, atol=1e-12)
    yr = 40 * np.sin(np.linspace(0, 12, 900)) + y_hist[-1] * np.cos(np.linspace(0, 12, 900))
    u, final = inv.simulate(yr, state)
    y, _ = pi.simulate(u, z)
    np.testing.assert_allclose(y, yr, rtol=0, atol=1e-9)
    u1, s1 = inv.simulate(yr[:400], state)
    u2, s2 = inv.simulate(yr[400:], s1)
    np.testing.assert_allclose(np.concatenate([u1, u2]), u, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s2, final, rtol=0, atol=1e-12)


@pytest.mark.parametrize("value", [-7.928, -3.1, 0.4, 6.37])
def test_a_held_reference_holds_the_voltage(value):
    """A reference held at one value gives one voltage, whole or one sample per call, as
    the exported C does. The shifted inverse's output was a matrix product whose equal
    columns came out 1 ulp apart, read by the inverse play as motion: the voltage jumped
    2 r_1 (2.4 V here) while the reference held (the model's output stayed exact, the
    jump being inside the play's dead band, but an actuator is not its model)."""
    pi = PrandtlIshlinskii([1.2, 1.5, 2.1, 3.3, 4.9], [2.9, -0.4, -0.45, 1.2, -0.3])
    inv = kuhnen_inverse(pi)
    y = np.full(64, value)
    u, _ = inv.simulate(y)
    assert np.all(u == u[0]), np.unique(u)
    s, parts = None, []
    for k in range(y.size):
        uk, s = inv.simulate(y[k:k + 1], s)
        parts.append(uk[0])
    np.testing.assert_array_equal(np.array(parts), u)
    np.testing.assert_allclose(pi.simulate(u)[0], y, rtol=0, atol=1e-12 * abs(value))
