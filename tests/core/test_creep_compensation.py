"""The Hammerstein compensator inverts creep with the dynamics: G (I + C).

Expectations: the exact inverse of a known creep makes the compensated plant
track a slow staircase (error at the level of the hysteresis inverse alone,
the same plant without creep), an identified creep leaves at most its
identification error (10 % of the drift, test_creep_identification), the
cascade's state space equals its filter, chunked runs equal one run.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.compensation.compensators import CompensatorError
from hammerstein.models.creep import Creep, creep_dynamics, minimum_phase_margin
from hammerstein.identification.creep_identification import CreepIdentifier
from hammerstein.models.dynamics import bending_modes, discretize
from hammerstein.signals.excitation import excitation_set
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.models.plant import HammersteinPlant
from hammerstein.io.presets import load_plant
from hammerstein.simulation import linear_steps

T = 1e-3
TRUE = [Creep.log_law(0.015, 0.01, 100.0, per_decade=2)] * 2
LEVELS = np.array([0.0, 20.0, 40.0, 20.0, -20.0, -40.0, 0.0])   # µm, x; y = x / 2
HOLD = int(1.0 / T)
SKIP = int(0.1 / T)     # the step edges are the dynamics' business


@pytest.fixture(scope="module")
def setup():
    hyst = load_plant("rakotondrabe-2dof").hysteresis
    G = discretize(bending_modes([60.0, 70.0], [0.6, 0.6]), T)
    return hyst, G, HammersteinPlant(hyst, T, G, creep=TRUE), HammersteinPlant(hyst, T, G)


def _staircase():
    r = np.repeat(LEVELS, HOLD)
    n = int(0.05 / T)
    w = 0.5 * (1 - np.cos(np.pi * np.arange(n) / n))
    for j in range(1, LEVELS.size):
        r[j * HOLD:j * HOLD + n] = LEVELS[j - 1] + w * (LEVELS[j] - LEVELS[j - 1])
    return np.vstack([r, 0.5 * r])


def _held_error(plant, comp, ref):
    e = comp.run_reference(plant, ref).outputs - ref
    idx = np.concatenate([np.arange(j * HOLD + SKIP, (j + 1) * HOLD) for j in range(1, LEVELS.size)])
    return float(np.max(np.abs(e[:, idx])))


@pytest.mark.parametrize("inversion", ["zpetc", "stable"])
def test_exact_creep_inverse_tracks_a_slow_staircase(setup, inversion):
    hyst, G, plant, plant0 = setup
    ref = _staircase()
    base = _held_error(plant0, HammersteinCompensator(hyst, G, inversion=inversion), ref)
    without = _held_error(plant, HammersteinCompensator(hyst, G, inversion=inversion), ref)
    with_creep = _held_error(plant, HammersteinCompensator(hyst, G, inversion=inversion,
                                                           creep=TRUE), ref)
    # creep inverted: as good as on the plant without creep (+ 1 nm)
    assert with_creep <= base + 1e-3
    assert without > 0.5          # µm: the drift the creep leaves otherwise (the test can fail)


def test_identified_creep_leaves_its_identification_error(setup):
    hyst, G, plant, _ = setup
    rng = np.random.default_rng(5)
    recs = []
    for r in excitation_set(["ux", "uy"], 10.0, T, multisine_periods=1):
        if r.kind == "creep":
            y, _ = plant.simulate(r.u)
            recs.append(SimpleNamespace(u=r.u, y=y + 0.04 * rng.standard_normal(y.shape),
                                        sampling_period=T, source=r.name))
    # the true hysteresis is the instantaneous response: d = 1 (no 1 Hz normalisation)
    ident = CreepIdentifier(hysteresis_frequency_hz=np.inf).fit(hyst, recs, G)
    assert all(c.instantaneous == 1.0 for c in ident.creeps_)
    ref = _staircase()
    without = _held_error(plant, HammersteinCompensator(hyst, G), ref)
    with_id = _held_error(plant, HammersteinCompensator(hyst, G, creep=ident.creeps_), ref)
    assert with_id <= 0.15 * without, (with_id, without)


def test_cascade_state_space_chunks_and_combined_system(setup):
    hyst, G, _, _ = setup
    comp = HammersteinCompensator(hyst, G, creep=TRUE)
    inv = comp.inverse
    r = _staircase()[:, :3000]
    s0 = inv.initial_state()
    whole, final = inv.filter(r, s0)
    a, s1 = inv.filter(r[:, :1234], s0)
    b, s2 = inv.filter(r[:, 1234:], s1)
    np.testing.assert_allclose(np.hstack([a, b]), whole, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s2, final, rtol=0, atol=1e-12)
    y, _ = linear_steps(r, inv.state_space(), s0)
    np.testing.assert_allclose(y, whole, rtol=0, atol=1e-9)
    # the inverted system is G (I + C): its DC gain is G(1) (1 + sum w) = 1 + sum w
    dc = comp.dynamics.C @ np.linalg.solve(np.eye(comp.dynamics.nstates) - comp.dynamics.A,
                                           comp.dynamics.B) + comp.dynamics.D
    np.testing.assert_allclose(np.diag(dc), 1 + TRUE[0].weights.sum(), rtol=1e-6)
    assert comp.bending_dynamics is G and "with creep" in repr(comp)


def test_creep_that_is_not_minimum_phase_is_refused(setup):
    hyst, G, _, _ = setup
    bad = Creep([1e-3], [5.0], instantaneous=0.1)     # d below w (1 - a) / (1 + a) = 1.16
    assert minimum_phase_margin(bad, T) < 0 < minimum_phase_margin(TRUE[0], T)
    with pytest.raises(CompensatorError, match="not minimum phase"):
        HammersteinCompensator(hyst, G, creep=[bad, None])
    with pytest.raises(Exception, match="one per output"):
        creep_dynamics([bad], G)
