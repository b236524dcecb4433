"""The realistic presets are what their comments say (modes, G(0), asymmetry, couplings, creep)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.io.presets import load_plant

ROOT = Path(__file__).resolve().parents[2]
PRESETS = {
    "realistic-2dof": ("realistic-2dof", [450.0, 420.0, 1300.0], True),
    "realistic-b": (ROOT / "scenarios/presets/realistic-b.toml", [380.0, 520.0, 1500.0], True),
    "realistic-b-nocreep": (ROOT / "scenarios/presets/realistic-b-nocreep.toml",
                            [380.0, 520.0, 1500.0], False),
    "realistic-pi-minor": (ROOT / "scenarios/presets/realistic-pi-minor.toml",
                           [450.0, 420.0, 1300.0], True),
}


def loop(model, k, n=4000):
    """Second period of a 10 V sine on input k, the other input at 0."""
    u = np.zeros((2, 2 * n))
    u[k] = 10 * np.sin(2 * np.pi * np.arange(2 * n) / n)
    return model.simulate(u)[0][:, n:]


@pytest.mark.parametrize("name", PRESETS)
def test_modes_and_unit_static_gain_of_the_dynamics(name):
    preset, modes, _ = PRESETS[name]
    plant = load_plant(preset)
    assert isinstance(plant.hysteresis, MultivariableHysteresis)
    d = plant.sampled_dynamics
    A, B, C, D = d.A, d.B, d.C, d.D
    G0 = C @ np.linalg.solve(np.eye(A.shape[0]) - A, B) + D
    np.testing.assert_allclose(G0, np.eye(2), atol=1e-6)
    freqs = np.abs(np.log(np.linalg.eigvals(A))) / plant.sampling_period / (2 * np.pi)
    np.testing.assert_allclose(sorted(set(np.round(freqs, 3))), sorted(modes), rtol=1e-6)


@pytest.mark.parametrize("name", PRESETS)
def test_direct_loops_are_asymmetric_and_cross_couplings_a_few_micrometres(name):
    preset, _, _ = PRESETS[name]
    model = load_plant(preset, dynamics=False).hysteresis
    n = 4000
    for k in range(2):
        y = loop(model, k, n)
        direct = y[k] - (y[k].max() + y[k].min()) / 2
        # u(t + P/2) = -u(t): a point-symmetric (PI) loop has y(t + P/2) = -y(t)
        asym = np.max(np.abs(direct[:n // 2] + direct[n // 2:]))
        assert 6.0 < asym < 13.0
        assert 100.0 < np.ptp(y[k]) < 125.0
        assert 2.5 < np.ptp(y[1 - k]) < 7.0          # the cross-coupling of input k


def test_even_cross_coupling_has_the_same_sign_at_plus_and_minus_10_volts():
    model = load_plant("realistic-2dof", dynamics=False).hysteresis
    y = loop(model, 0)[1]                            # y driven by ux
    n = y.size
    plus, minus = y[n // 4] - y[0], y[3 * n // 4] - y[0]      # at +10 V and at -10 V
    assert plus > 1.0 and minus > 1.0                        # the same sign: even
    assert (plus + minus) / 2 > 2 * abs(plus - minus) / 2    # even part above the odd one


def state_after_steps(A, b, k):
    """State after k steps of ``x <- A x + b`` from 0, i.e. the sum of ``A^i b`` for i < k.

    By binary splitting over the bits of k (``x_2m = x_m + A^m x_m``, ``x_m+1 = A x_m + b``):
    a few dozen matrix products instead of k steps (200 000 for 10 s at 50 µs).
    """
    x, P = np.zeros(A.shape[0]), np.eye(A.shape[0])          # x_m and A^m, m = 0
    for bit in bin(k)[2:]:
        x, P = x + P @ x, P @ P
        if bit == "1":
            x, P = A @ x + b, A @ P
    return x


@pytest.mark.parametrize("name", PRESETS)
def test_creep_after_a_step(name):
    preset, _, creeps = PRESETS[name]
    plant = load_plant(preset)
    T = plant.sampling_period
    A, B, C, D = plant.matrices
    if not creeps:
        assert plant.creep is None
        return
    # step response of the linear part alone (creep then modes), by the matrices: y at 0.1 s
    # and at 10 s after a unit step on ux
    h = np.array([1.0, 0.0])
    ys = {t: (C @ state_after_steps(A, B @ h, int(round(t / T))) + D @ h)[0] for t in (0.1, 10.0)}
    growth = ys[10.0] / ys[0.1] - 1
    assert 0.015 < growth < 0.035


def test_pi_minor_preset_has_pi_like_minor_loops():
    """Rise after a descent to m by d: independent of m for a PI-like density (not for the other)."""
    def rise(model, m, d):
        comp = model.component("x", "ux")
        u = np.array([11.0, m, m + d])
        y, _ = comp.simulate(u)
        y = y - comp.reversible_part(u)
        return y[2] - y[1]
    pim = load_plant(ROOT / "scenarios/presets/realistic-pi-minor.toml", dynamics=False).hysteresis
    real = load_plant("realistic-2dof", dynamics=False).hysteresis
    e = pim.component("x", "ux").edges
    assert rise(pim, e[4], e[8] - e[4]) == pytest.approx(rise(pim, e[16], e[8] - e[4]), rel=1e-3)
    assert abs(rise(real, e[4], e[8] - e[4]) / rise(real, e[16], e[8] - e[4]) - 1) > 0.1


def test_classical_presets_are_unchanged_in_kind():
    assert isinstance(load_plant("rakotondrabe-2dof").hysteresis, MultivariablePI)
    assert load_plant("rakotondrabe-2dof").creep is None
