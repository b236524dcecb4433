"""hammerstein.compensation.inversion: round trips G(G^-1 r) = r, ZPETC preview and gain error,
chunked = whole, coupled non-minimum-phase MIMO, FFT periodic inverse."""

import control
import numpy as np
import pytest

from hammerstein.compensation.inversion import ZPETCInverse, inverse_system, preview_inverse
from hammerstein.models.lti import state_space_dynamics
from hammerstein.models.dynamics import DynamicsError, bending_modes, discretize

T = 5e-5


@pytest.fixture(scope="module")
def preset_G():
    return discretize(bending_modes([310.0, 290.0], [0.15, 0.20]), T)


@pytest.fixture(scope="module")
def coupled_G():
    """Two bending modes, 8 % / 6 % cross-coupling modes at other frequencies, and a
    right-half-plane zero at 2 kHz on x: a discrete zero outside the unit circle."""
    w1, w2, w3 = 2 * np.pi * np.array([310.0, 290.0, 450.0])
    z1, z2, z3 = 0.15, 0.2, 0.1
    wz = 2 * np.pi * 2000.0
    A = np.zeros((6, 6))
    for k, (w, z) in enumerate([(w1, z1), (w2, z2), (w3, z3)]):
        A[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[0.0, w], [-w, -2 * z * w]]
    B = np.zeros((6, 2))
    B[1, 0] = w1
    B[3, 1] = w2
    B[5] = [0.08 * w3, 0.06 * w3]
    C = np.zeros((2, 6))
    C[0, :2] = [1.0, -w1 / wz]          # y = x - xdot/wz (x1 velocity state = xdot / w1)
    C[1, 2] = 1.0
    C[:, 4] = [1.0, 1.0]
    return discretize(state_space_dynamics(A, B, C), T)


def burst(n, f, p=2, start=300, stop_margin=300):
    """Smooth sine bursts (rest at both ends) on every channel, phase-shifted."""
    t = np.arange(n) * T
    env = np.zeros(n)
    k = np.arange(n - start - stop_margin)
    env[start:n - stop_margin] = np.sin(np.pi * k / k.size) ** 2
    return np.vstack([env * np.sin(2 * np.pi * f * t + 1.3 * i) for i in range(p)])


def simulate(G, v, x0=None):
    return control.forced_response(G, U=v, X0=0 if x0 is None else x0).outputs.reshape(v.shape)


def test_exact_stable_inverse_round_trip(preset_G):
    t = np.arange(2000) * T
    yr = np.vstack([np.sin(2 * np.pi * 200 * t), 0.5 * np.sin(2 * np.pi * 50 * t)])
    v = preview_inverse(preset_G, yr, method="stable")
    np.testing.assert_allclose(simulate(preset_G, v), yr, atol=1e-9)


def test_zpetc_preview_and_zero_phase_gain_error(preset_G):
    inv = ZPETCInverse(preset_G)
    assert inv.preview_samples == 2                     # relative degree 1 + 1 sampling zero
    assert inv.relative_degree.tolist() == [1, 1] and inv.decoupled
    # independently: the ZOH sampling zero of each channel from its transfer function
    betas = np.array([np.real(control.zeros(control.tf(preset_G[i, i]))[0]) for i in range(2)])
    np.testing.assert_allclose(np.sort(inv.unacceptable_zeros.real), np.sort(betas), atol=1e-8)
    assert np.all((betas < -0.95) & (betas > -1))
    n, f = 4000, 200.0
    t = np.arange(n + 2) * T
    ref = np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])
    v = inv.apply(ref[:, :n], tail=ref[:, n:])
    y = simulate(preset_G, v, inv.plant_state(ref[:, 0]))
    e = np.max(np.abs(y - ref[:, :n])[:, 1000:], axis=1)
    wT = 2 * np.pi * f * T
    bound = 2 * np.abs(betas) * (1 - np.cos(wT)) / (1 - betas) ** 2   # Tomizuka's gain error
    np.testing.assert_allclose(e, bound, rtol=0.02)
    assert np.all(e < 1.1e-3)


def test_causal_filter_delays_by_preview(preset_G):
    inv = ZPETCInverse(preset_G)
    P = inv.preview_samples
    yr = burst(1500, 100.0)
    v, _ = inv.filter(yr)                               # reference not known in advance
    y = simulate(preset_G, v)
    # y(t) = yr(t - P) up to the ZPETC gain error (2.5e-4 at 100 Hz)
    np.testing.assert_allclose(y[:, P:], yr[:, :-P], atol=3e-4)


def test_chunked_equals_whole(preset_G, coupled_G):
    for G in (preset_G, coupled_G):
        inv = ZPETCInverse(G)
        yr = burst(900, 150.0)
        s0 = inv.initial_state(yr[:, 0])
        v, s = inv.filter(yr, s0)
        parts, state = [], s0
        for a, b in [(0, 1), (1, 250), (250, 251), (251, 900)]:
            vp, state = inv.filter(yr[:, a:b], state)
            parts.append(vp)
        np.testing.assert_array_equal(np.hstack(parts), v)
        np.testing.assert_array_equal(state, s)
        v1, s1 = inv.step(yr[:, 0], s0)
        np.testing.assert_array_equal(v1, v[:, 0])


def test_coupled_nonminimum_phase_mimo(coupled_G):
    inv = ZPETCInverse(coupled_G)
    zeros = inverse_system(coupled_G).zeros
    assert np.any(np.abs(zeros) > 1.2)                  # the RHP zero, z ~ exp(2 pi 2000 T) = 1.87
    assert not inv.decoupled
    n_bad = inv.unacceptable_zeros.size
    assert np.any(np.abs(inv.unacceptable_zeros) > 1.2)
    assert inv.preview_samples == 1 + n_bad
    yr = burst(3000, 100.0, start=600, stop_margin=600)
    # ZPETC: zero phase, small gain error at 100 Hz
    v = inv.apply(yr)
    y = simulate(coupled_G, v)
    assert np.max(np.abs(y - yr)) < 0.02 * np.max(np.abs(yr))
    # exact stable inversion (anti-causal unstable part): exact when the burst is at rest at both ends
    vs = preview_inverse(coupled_G, yr, method="stable")
    np.testing.assert_allclose(simulate(coupled_G, vs), yr, atol=1e-8)
    assert np.max(np.abs(vs)) < 100 * np.max(np.abs(yr))         # bounded (stable) inverse


def test_fft_inverse_periodic_steady_state(coupled_G):
    n = 1000                                            # 5 periods of 100 Hz
    t = np.arange(n) * T
    yr = np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 200 * t)])
    v = preview_inverse(coupled_G, yr, method="fft")
    y = simulate(coupled_G, np.tile(v, 8))[:, -n:]      # periodic steady state
    np.testing.assert_allclose(y, yr, atol=1e-6)


def test_invalid_systems_and_references(preset_G):
    with pytest.raises(DynamicsError, match="discrete"):
        ZPETCInverse(bending_modes([300.0], [0.2]))
    with pytest.raises(DynamicsError, match="square"):
        ZPETCInverse(preset_G[:, :1])
    with pytest.raises(DynamicsError, match="reference"):
        ZPETCInverse(preset_G).filter(np.zeros((3, 10)))
    with pytest.raises(DynamicsError, match="method"):
        preview_inverse(preset_G, np.zeros((2, 10)), method="nope")


def test_the_state_space_filter_is_the_designs_taps(preset_G, coupled_G):
    """filter runs state_space() (as the exported C does); the design's own form, FIR taps over
    the window plus the acceptable modes' recursion (_filter_taps), is the same operator: equal
    outputs and final states up to rounding (2.3e-11 relative was the largest seen, coupled)."""
    for G in (preset_G, coupled_G):
        inv = ZPETCInverse(G)
        yr = burst(900, 150.0)
        s0 = inv.initial_state(yr[:, 0])
        v, s = inv.filter(yr, s0)
        v_taps, s_taps = inv._filter_taps(yr, s0)
        scale = np.max(np.abs(v_taps))
        np.testing.assert_allclose(v, v_taps, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(s, s_taps, rtol=0, atol=1e-9 * max(np.max(np.abs(s_taps)), 1.0))
