"""ZOH without python-control: equal to control.sample_system; presets' plants load no python-control."""

import control
import numpy as np
import pytest

from hammerstein.models.dynamics import bending_modes, discretize, sampled_bending_modes, zoh
from hammerstein.exceptions import DynamicsError
from hammerstein.io.presets import load_plant


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


@pytest.mark.parametrize("key", [(0, 0), (0, 1), (1, 0), (1, 1)])
def test_subsystem_indexing_equals_python_control(key):
    s = sampled_bending_modes([310.0, 290.0], [0.15, 0.2], ["x", "y"], 5e-5)
    s.B = s.B + np.array([[0.0, 0.1], [0.2, 0.0], [0.0, 0.3], [0.4, 0.0]])   # cross-couplings
    got, ref = s[key], s.to_control()[key]
    for k in "ABCD":
        assert np.array_equal(getattr(got, k), np.asarray(getattr(ref, k))), k
    assert got.dt == ref.dt and got.inputs == ref.input_labels and got.outputs == ref.output_labels


@pytest.mark.parametrize("key", [(2, 0), (0, 5), 0, ("x", 0), (0, 1, 0)])
def test_subsystem_indexing_names_what_was_expected(key):
    s = sampled_bending_modes([310.0, 290.0], [0.15, 0.2], ["x", "y"], 5e-5)
    with pytest.raises(DynamicsError, match=r"subsystem: expected \(output, input\) indices of a 2x2"):
        s[key]


@pytest.mark.parametrize("coupled", [False, True])
def test_zpetc_of_a_sampled_system_equals_that_of_its_control_system(coupled):
    # the ZPETC design reads A, B, C, D, dt (and the diagonal subsystems when G is decoupled):
    # from the SampledSystem it must give the filter of the control.StateSpace bit for bit
    from hammerstein.compensation.inversion import ZPETCInverse
    s = sampled_bending_modes([310.0, 290.0], [0.15, 0.2], ["x", "y"], 5e-5)
    if coupled:
        s.C = s.C + np.array([[0.0, 0.0, 0.05, 0.0], [0.08, 0.0, 0.0, 0.0]])  # modes coupled
    a, b = ZPETCInverse(s), ZPETCInverse(s.to_control())
    assert a.decoupled == b.decoupled == (not coupled)
    assert a.preview_samples == b.preview_samples and a.window == b.window
    for attr in ("_taps_v", "_taps_w", "_Ag", "_Bg", "_Cg", "relative_degree"):
        assert np.array_equal(getattr(a, attr), getattr(b, attr)), attr
    yr = np.vstack([np.sin(np.arange(300) / 20.0), np.cos(np.arange(300) / 30.0)])
    assert np.array_equal(a.filter(yr, a.initial_state(yr[:, 0]))[0],
                          b.filter(yr, b.initial_state(yr[:, 0]))[0])
