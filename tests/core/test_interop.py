"""python-control interop systems against the compiled kernels (1e-9)."""

import control
import numpy as np
import pytest

from hammerstein import InverseMultiplicativeCompensator, load_plant
from hammerstein import simulation as sim
from hammerstein.io.interop import (chain_system, compensator_system, hammerstein_system,
                                 pi_system)

ATOL = 1e-9
N = 120


@pytest.fixture
def plant(preset_plant):
    return preset_plant


def _record(plant, n=N):
    t = np.arange(n) * plant.sampling_period
    u = np.vstack([9 * np.sin(2 * np.pi * 180 * t), 6 * np.sin(2 * np.pi * 330 * t + 1)])
    return t, u


def test_interconnected_hammerstein_plant_matches_kernel(plant):
    sys = hammerstein_system(plant)
    assert sys.isdtime(strict=True) and sys.dt == plant.sampling_period
    assert sys.input_labels == ["ux", "uy"] and sys.output_labels == ["x", "y"]
    assert sys.nstates == plant.n_states              # play states + 4 linear states
    t, u = _record(plant)
    resp = control.input_output_response(sys, t, u)
    y, _ = plant.simulate(u)
    np.testing.assert_allclose(resp.outputs, y, rtol=0, atol=ATOL)
    # the state vector is the flat plant state (plays, then linear states)
    _, s_before_last = plant.simulate(u[:, :-1])
    np.testing.assert_allclose(resp.states[:, -1], s_before_last, rtol=0, atol=ATOL)


def test_pi_system_matches_kernel_from_a_nonzero_state(plant):
    model = plant.hysteresis
    sys = pi_system(model, plant.sampling_period)
    t, u = _record(plant)
    s0 = np.random.default_rng(1).normal(0, 2, model.n_hysterons)
    resp = control.input_output_response(sys, t, u, X0=s0)
    np.testing.assert_allclose(resp.outputs, model.simulate(u, s0)[0], rtol=0, atol=ATOL)


def test_static_plant_system_is_the_pi_system():
    plant = load_plant("rakotondrabe-2dof", dynamics=False)
    sys = hammerstein_system(plant)
    t, u = _record(plant)
    resp = control.input_output_response(sys, t, u)
    np.testing.assert_allclose(resp.outputs, plant.simulate(u)[0], rtol=0, atol=ATOL)


@pytest.mark.parametrize("kwargs", [{"iterations": 1}, {"iterations": 3},
                                    {"feedback": "lowpass", "cutoff_hz": 500.0,
                                     "sampling_period": 5e-5}])
def test_compensator_and_chain_systems_match_kernel(plant, kwargs):
    comp = InverseMultiplicativeCompensator(plant.hysteresis, **kwargs)
    t = np.arange(N) * plant.sampling_period
    yr = np.vstack([40 * np.sin(2 * np.pi * 150 * t), 20 * np.cos(2 * np.pi * 90 * t)])
    u_kernel, _ = comp.simulate(yr)
    resp = control.input_output_response(compensator_system(comp, plant.sampling_period), t, yr)
    np.testing.assert_allclose(resp.outputs, u_kernel, rtol=0, atol=ATOL)
    chain = chain_system(comp, plant)
    assert chain.input_labels == ["x_r", "y_r"]
    resp = control.input_output_response(chain, t, yr)
    np.testing.assert_allclose(resp.outputs, sim.simulate_chain(comp, plant, yr).outputs,
                               rtol=0, atol=ATOL)


def test_an_identified_preisach_plant_is_a_python_control_system_too():
    # identify writes Preisach and generalised-PI models; the bridge took only the classical
    # PI ("'MultivariableHysteresis' object has no attribute 'hysterons'")
    plant = load_plant("realistic-2dof")
    assert not hasattr(plant.hysteresis, "hysterons")
    sys = hammerstein_system(plant)
    t = np.arange(300) * plant.sampling_period
    u = np.vstack([8 * np.sin(2 * np.pi * 50 * t), 5 * np.sin(2 * np.pi * 70 * t)])
    resp = control.input_output_response(sys, t, u, X0=plant.rest_state())
    y, _ = plant.simulate(u, plant.rest_state())
    np.testing.assert_allclose(resp.outputs, y, rtol=0, atol=1e-9 * np.abs(y).max())
