"""ZOH without python-control: equal to control.sample_system; presets' plants load no python-control."""

import control
import numpy as np
import pytest

from hammerstein.core.dynamics import bending_modes, discretize, sampled_bending_modes, zoh
from hammerstein.core.presets import load_plant


@pytest.mark.parametrize("T", [1e-5, 5e-5, 1e-3])
def test_zoh_equals_control_sample_system(T):
    rng = np.random.default_rng(3)
    A = rng.standard_normal((5, 5)) - 3 * np.eye(5)
    B = rng.standard_normal((5, 2))
    sysd = control.sample_system(control.ss(A, B, np.eye(5), np.zeros((5, 2))), T, method="zoh")
    Ad, Bd = zoh(A, B, T)
    np.testing.assert_allclose(Ad, sysd.A, rtol=0, atol=1e-12)
    np.testing.assert_allclose(Bd, sysd.B, rtol=0, atol=1e-12)


def test_zoh_scalar_closed_form():
    # dx/dt = -a x + u: A_d = exp(-a T), B_d = (1 - exp(-a T)) / a
    a, T = 40.0, 1e-3
    Ad, Bd = zoh([[-a]], [[1.0]], T)
    assert Ad[0, 0] == pytest.approx(np.exp(-a * T), rel=1e-14)
    assert Bd[0, 0] == pytest.approx((1 - np.exp(-a * T)) / a, rel=1e-12)


def test_sampled_bending_modes_equal_discretized_control_system():
    fn, zeta, names, T = [310.0, 290.0], [0.15, 0.2], ["x", "y"], 5e-5
    ref = discretize(bending_modes(fn, zeta, names), T)
    s = sampled_bending_modes(fn, zeta, names, T)
    for k in "ABCD":
        np.testing.assert_allclose(getattr(s, k), getattr(ref, k), rtol=0, atol=1e-12)
    G = s.to_control()
    assert G.dt == ref.dt and G.name == ref.name
    assert G.input_labels == ref.input_labels and G.output_labels == ref.output_labels
    f = [1e-3, 50.0, 300.0, 2000.0]
    np.testing.assert_allclose(s.frequency_response_hz(f),
                               control.frequency_response(ref, 2 * np.pi * np.array(f)).complex,
                               rtol=1e-10, atol=1e-12)


def test_plant_dynamics_is_a_control_system_on_access():
    plant = load_plant("rakotondrabe-2dof", dynamics=True)
    assert not plant.is_static and plant.n_linear_states == 4
    G = plant.dynamics
    assert isinstance(G, control.StateSpace) and G.isdtime(strict=True)
    np.testing.assert_array_equal(plant.matrices[0], np.asarray(G.A))


# That simulating a preset plant imports neither python-control nor scipy.signal is checked
# in the fresh interpreter of tests/core/test_core_layering.py (one process for all such checks).
