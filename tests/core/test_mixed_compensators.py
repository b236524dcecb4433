"""The rate-independent kinds over a Preisach (mixed) model: hammerstein.core.mixed_compensators.

Expectations from the laws themselves, not from the code's output:

* the inverse multiplicative law ``u_t = u_{t-1} + K^-1 (y_r - Gamma(u_{t-1}))``
  has the fixed point ``Gamma(u) = y_r``: on a held reference it ends there;
* the diagonal law's fixed point is ``Gamma_ll(u_l) = y_r,l``, so what is left on
  output l is exactly the cross-couplings ``sum_{k != l} Gamma_lk(u_k)``,
  computed here component by component;
* the per-axis inverse is exact per direct path at every sample: the same
  cross-coupling residual at every sample;
* the static gain inverts ``y = K u + c`` exactly, K and c read here from a
  major loop simulated in the test.
"""

import numpy as np
import pytest

from hammerstein.core.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                           StaticGainCompensator)
from hammerstein.core.mixed_compensators import (LinearInverseCompensator, diagonal_model,
                                                 mixed_compensator, mixed_gain)
from hammerstein.core.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.core.presets import load_plant
from hammerstein.exceptions import CompensatorError
from hammerstein.scenario.registry import build_compensator

EDGES = np.linspace(-12.0, 12.0, 21)


def _model():
    """2 x 2: tilted Preisach direct paths, a hysteretic and an even cross-coupling."""
    x = PreisachModel.from_density(EDGES, total=20.0, tilt=0.5, bias=0.5, bias_width=4.0,
                                   coercivity=1.5, coercivity_width=2.0, reversible=[1.2, 0.02],
                                   offset=-1.0)
    y = PreisachModel.from_density(EDGES, total=16.0, tilt=-0.4, bias_width=3.0,
                                   coercivity=1.0, coercivity_width=2.5, reversible=[1.0])
    xy = PreisachModel.from_density(EDGES, total=0.9, tilt=0.2, bias_width=5.0, reversible=[0.03])
    yx = Polynomial([0.05, 0.02])
    return MultivariableHysteresis([[x, xy], [yx, y]], ("ux", "uy"), ("x", "y"), [10.0, 10.0])


def _held(levels, hold):
    return np.repeat(np.asarray(levels, dtype=float), hold, axis=1)


LEVELS = [[0.0, 15.0, 3.0, -12.0, 6.0], [2.0, -8.0, 10.0, 4.0, -3.0]]
HOLD = 300


def _cross(model, u):
    """sum_{k != l} Gamma_lk(u_k) per output, each component from its own rest state."""
    out = np.zeros((model.n_outputs, u.shape[1]))
    for l in range(model.n_outputs):
        for k in range(model.n_inputs):
            c = model.components[l][k]
            if k != l and c is not None:
                out[l] += c.simulate(u[k])[0]
    return out


@pytest.mark.parametrize("gain", ["secant", "midpoint"])
def test_multivariable_law_ends_on_its_fixed_point(gain):
    model = _model()
    comp = mixed_compensator(model, "multivariable", gain=gain)
    ref = _held(LEVELS, HOLD)
    u, _ = comp.simulate(ref)
    y, _ = model.simulate(u)
    ends = np.arange(1, len(LEVELS[0]) + 1) * HOLD - 1
    np.testing.assert_allclose(y[:, ends], ref[:, ends], atol=1e-6)


def test_diagonal_law_leaves_exactly_the_cross_couplings():
    model = _model()
    u, _ = mixed_compensator(model, "diagonal").simulate(_held(LEVELS, HOLD))
    y, _ = model.simulate(u)
    ref = _held(LEVELS, HOLD)
    ends = np.arange(1, len(LEVELS[0]) + 1) * HOLD - 1
    np.testing.assert_allclose((y - ref)[:, ends], _cross(model, u)[:, ends], atol=1e-6)
    assert np.max(np.abs(_cross(model, u)[:, ends])) > 0.1     # there is something left


def test_per_axis_inverse_is_exact_per_direct_path_at_every_sample():
    model = _model()
    t = np.arange(3000) / 3000
    ref = np.vstack([14 * np.sin(2 * np.pi * 3 * t) * np.exp(-2 * t),
                     9 * np.cos(2 * np.pi * 5 * t) * (1 - 0.5 * t)])
    comp = mixed_compensator(model, "per-axis")
    u, _ = comp.simulate(ref)
    y, _ = model.simulate(u)
    np.testing.assert_allclose(y - ref, _cross(model, u), atol=1e-7)


def test_static_gain_inverts_the_major_loops_secant_line():
    model = _model()
    comp = mixed_compensator(model, "static-gain")
    n = 4000
    for k in range(2):                 # K and c from major loops simulated here
        u = np.zeros((2, 2 * n))
        u[k] = 10.0 * np.sin(2 * np.pi * np.arange(2 * n) / n)
        y = model.simulate(u)[0][k, n:]
        uk = u[k, n:]
        assert comp.K[k, k] == pytest.approx((y.max() - y.min()) / 20.0, rel=2e-3)
        at_zero = y[np.flatnonzero(np.abs(uk) < 10.0 * np.sin(2 * np.pi / n) / 2)]
        assert comp.centre[k] == pytest.approx(np.mean(at_zero), abs=2e-3 * np.ptp(y))
    ref = np.array([[1.0, 5.0, -3.0], [0.0, 2.0, 7.0]])
    u, _ = comp.simulate(ref)
    np.testing.assert_allclose(comp.K @ u + comp.centre[:, None], ref, atol=1e-12)


def test_static_gain_of_a_linear_model_is_its_inverse():
    g, c = 2.5, 0.7
    lin = PreisachModel(EDGES, np.zeros((20, 20)), reversible=[g], offset=c)
    model = MultivariableHysteresis([[lin]], input_amplitude=[10.0])
    u, _ = LinearInverseCompensator(model).simulate(np.array([[c, c + g, c - 3 * g]]))
    np.testing.assert_allclose(u, [[0.0, 1.0, -3.0]], atol=1e-12)


def test_gains():
    model = _model()
    K = mixed_gain(model, "midpoint")
    assert K[0, 1] == K[1, 0] == 0 and np.all(np.diag(K) > 0)
    np.testing.assert_array_equal(mixed_gain(model, [[2.0, 0.1], [0.0, 3.0]]), [[2.0, 0.1], [0.0, 3.0]])
    with pytest.raises(CompensatorError, match="gain: expected 'secant'"):
        mixed_gain(model, "biggest")
    with pytest.raises(CompensatorError, match="gain: expected an invertible 2x2"):
        mixed_gain(model, [[1.0, 2.0], [2.0, 4.0]])


@pytest.mark.parametrize("options, match", [
    ({"iterations": 3}, "iterations: .* one step per sample"),
    ({"feedback": "lowpass"}, "feedback: only 'delay'"),
    ({"gain": [[0.2, 0.0], [0.0, 0.2]]}, "may not converge, rho"),
])
def test_options_the_law_over_a_preisach_model_does_not_have(options, match):
    with pytest.raises(CompensatorError, match=match):
        mixed_compensator(_model(), "multivariable", **options)


def test_diagonal_model_keeps_the_direct_paths_only():
    d = diagonal_model(_model())
    assert d.components[0][1] is None and d.components[1][0] is None
    u = np.vstack([np.linspace(-8, 8, 50), np.linspace(5, -5, 50)])
    np.testing.assert_allclose(d.simulate(u)[0], _model().simulate(u)[0] - _cross(_model(), u),
                               atol=1e-12)


@pytest.mark.parametrize("kind", ["multivariable", "diagonal", "per-axis", "static-gain"])
def test_every_rate_independent_kind_over_a_preisach_plant_and_a_classical_one(kind, tmp_path):
    preisach = load_plant("realistic-2dof", dynamics=False)
    comp = build_compensator({"kind": kind, "model": "plant"}, preisach, tmp_path)
    assert comp.name == kind
    T = preisach.sampling_period
    t = np.arange(int(round(0.04 / T))) * T
    ref = 30 * np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 50 * t)])
    u, _ = comp.simulate(ref)
    y, _ = preisach.hysteresis.simulate(u)
    err = np.linalg.norm(y - ref, axis=0)[t.size // 2:].max()
    # bounds from the kind's law: what no compensation leaves, and what the exact root leaves
    uncompensated = np.linalg.norm(ref - preisach.hysteresis.simulate(np.zeros_like(ref))[0], axis=0).max()
    assert err < 0.5 * uncompensated
    classical = load_plant("rakotondrabe-2dof", dynamics=False)
    pi = build_compensator({"kind": kind, "model": "plant"}, classical, tmp_path)
    assert isinstance(pi, (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                           StaticGainCompensator))
