"""The Python compensators in a caller's own loop: bad samples, shapes, the start at rest.

* A reference sample the exported C skips with status 4 (beyond its
  ``NAME_reference_bound``, read here from the generated C) is refused by
  ``simulate`` with one CompensatorError naming the sample, before anything
  runs: the caller's state stays valid and the run continues as if the sample
  had never come (it had left the compensator saturating for good).
* ``compensate_reference`` on a transposed record says so in one line.
* A chunked loop from ``rest_state()`` on compensate's faded reference gives
  compensate's voltages (``initial_state()`` is 0 µm, not this stage's rest).
"""

import re

import control
import numpy as np
import pytest

import hammerstein as hs
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.exceptions import CompensatorError, HysteresisError
from hammerstein.export import export_c
from hammerstein.models.plant import HammersteinPlant
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel

T = 1e-4


def _asymmetric_model():
    """A 2 x 2 Preisach model whose output at 0 V is not 0 µm (tilted densities)."""
    edges = np.linspace(-12.0, 12.0, 17)
    x = PreisachModel.from_density(edges, total=20.0, tilt=0.6, bias=1.0, bias_width=4.0,
                                   coercivity=2.0, coercivity_width=2.0, reversible=[1.5])
    y = PreisachModel.from_density(edges, total=15.0, tilt=-0.5, bias=-1.5, bias_width=3.0,
                                   coercivity=1.0, coercivity_width=2.0, reversible=[1.0, 0.02])
    xy = PreisachModel.from_density(edges, total=0.8, tilt=0.3, bias_width=4.0, reversible=[0.05])
    return MultivariableHysteresis([[x, xy], [None, y]], ("ux", "uy"), ("x", "y"), [10.0, 10.0])


def _modes():
    w, z = 2 * np.pi * np.array([400.0, 900.0]), 0.05
    A = np.zeros((4, 4))
    for i in range(2):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-w[i] ** 2, -2 * z * w[i]]]
    B = np.array([[0.0, 0.0], [w[0] ** 2, 0.0], [0.0, 0.0], [0.0, w[1] ** 2]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    return control.c2d(control.ss(A, B, C, np.zeros((2, 2))), T, "zoh")


@pytest.fixture(scope="module")
def preisach_plant():
    return HammersteinPlant(_asymmetric_model(), T, dynamics=_modes())


def _compensators(preset_plant):
    exact = HammersteinCompensator(_asymmetric_model(), _modes())       # exact inverse path
    law = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)   # fused law
    return [exact, law, hs.InverseMultiplicativeCompensator(preset_plant.hysteresis)]


def _c_bound(comp):
    """The bound the exported C step skips references beyond (status 4)."""
    source = export_c(comp, "stage", T).source
    return float(re.search(r"stage_reference_bound = ([-+0-9.eE]+);", source).group(1))


def _lead(comp, n=300):
    t = np.arange(n) * T
    return np.vstack([3.0 * np.sin(2 * np.pi * 50 * t), 2.0 * np.sin(2 * np.pi * 70 * t)]) + 0.5


@pytest.mark.parametrize("which", [0, 1, 2])
def test_a_glitch_is_refused_naming_the_sample_and_the_state_survives(preset_plant, which):
    comp = _compensators(preset_plant)[which]
    lead = _lead(comp)
    with comp.previewed() if hasattr(comp, "previewed") else _nothing():
        u_all, _ = comp.simulate(lead, comp.initial_state())
        u1, s1 = comp.simulate(lead[:, :100], comp.initial_state())
        kept = s1.copy()
        bad = lead[:, 100:200].copy()
        bad[0, 37] = 1e7
        with pytest.raises(CompensatorError, match=r"reference: sample 37 of output 'x' is 1e\+07 µm"):
            comp.simulate(bad, s1)
        assert np.array_equal(s1, kept)
        u2, _ = comp.simulate(lead[:, 100:], s1)     # the caller carries on from its state
    assert np.max(np.abs(np.concatenate([u1, u2], axis=1) - u_all)) < 1e-12


@pytest.mark.filterwarnings("ignore::hammerstein.exceptions.RangeWarning")
@pytest.mark.parametrize("which", [0, 1, 2])
def test_python_and_the_exported_c_skip_the_same_samples(preset_plant, which):
    comp = _compensators(preset_plant)[which]
    bound = _c_bound(comp)
    assert 10 < bound < 1e6                 # a scale of the model's outputs, not a float limit
    lead = _lead(comp, 20)
    with comp.previewed() if hasattr(comp, "previewed") else _nothing():
        inside = lead.copy()
        inside[1, 4] = -bound * (1 - 1e-9)
        comp.simulate(inside, comp.initial_state())         # taken (status 0 or range: not 4)
        beyond = lead.copy()
        beyond[1, 4] = -bound * (1 + 1e-9)
        with pytest.raises(CompensatorError, match="sample 4 of output 'y'"):
            comp.simulate(beyond, comp.initial_state())


def test_a_non_finite_sample_is_named(preset_plant):
    comp = _compensators(preset_plant)[0]
    lead = _lead(comp, 20)
    lead[1, 6] = np.nan
    with comp.previewed():
        with pytest.raises(HysteresisError, match="reference: expected finite values; sample 6 "
                                                  "of output 'y' is nan"):
            comp.simulate(lead, comp.initial_state())


class _nothing:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def test_compensate_reference_names_a_transposed_reference(preset_plant):
    _, r = hs.circle(preset_plant.sampling_period, radius=10.0, frequency=50.0, periods=2)
    with pytest.raises(CompensatorError) as err:
        hs.compensate_reference(preset_plant, r.T, period_samples=400)
    assert str(err.value) == (f"reference: expected shape (2, n_samples), one row per output [µm], "
                              f"found {r.T.shape}")


@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_a_loop_from_rest_state_gives_compensates_drive(preisach_plant, chunk):
    plant = preisach_plant
    _, r = hs.circle(T, radius=6.0, frequency=25.0, periods=3)
    comp, drive = hs.compensate_reference(plant, r, period_samples=400)
    yf, P = drive.reference, comp.preview_samples
    N = yf.shape[1]
    y0, _ = plant.hysteresis.simulate(np.zeros((2, 1)))
    assert np.max(np.abs(y0)) > 0.5 and np.allclose(yf[:, 0], y0[:, 0])   # rests away from 0 µm
    n = min(N - P, 900)
    state, parts = comp.rest_state(), []
    with comp.previewed():
        for i in range(0, n, chunk):
            u, state = comp.simulate(yf[:, P + i:P + min(i + chunk, n)], state)
            parts.append(u)
    u = np.concatenate(parts, axis=1)
    assert np.max(np.abs(u[:, :5])) < 1e-6            # at rest: 0 V, as compensate starts
    assert np.max(np.abs(u - drive.commanded[:, :n])) < 1e-9   # before its start-up shaping
