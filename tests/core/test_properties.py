"""Property-based tests (hypothesis) of the hysteresis operators' mathematics.

Each property is derived from the play operator's definition, eq. (1) of the
paper, ``y(t) = max(u(t) - r, min(u(t) + r, y(t - T)))`` (a clamp of the
previous output into the band ``[u - r, u + r]``), independently of the
implementation:

* rate independence: re-timing the input by repeating samples or inserting,
  between two consecutive samples u_t and u_t+1, values that run
  monotonically from u_t to u_t+1 (a time warp of the piecewise-linear input
  that keeps its extrema, which are samples) leaves the output at the
  retained samples bit-for-bit identical.  Proof: after a sample the play
  output lies in its band; on a monotone increasing run from a to b the
  clamp reduces to ``max(y, v - r)`` and ends at ``max(y_a, b - r)``, which is
  also the direct step from a to b.  Floating-point rounding is monotone, so
  the argument holds exactly.  An inserted value *beyond* u_t+1 (a new
  extremum) does change the output (tested as a counter-example);
* wiping-out: values inserted between u_t and u_t+1 in *any* order but within
  ``[min(u_t, u_t+1), max(u_t, u_t+1)]`` (a minor loop inside the range of the
  following excursion) leave every later output unchanged; and the state after
  a history equals the state after its reduced sequence of dominant
  (alternating, wiping-out) extrema, computed by an independent algorithm;
* Lipschitz continuity with constant 1 in the sup norm, per hysteron
  (``|play(u1) - play(u2)| <= max(||u1 - u2||, |s1 - s2|)``), hence with
  constant ``sum |w_i|`` for a PI operator;
* monotone output for monotone input when the weights are positive;
* additivity of the multivariable model, eq. (3), from zero initial states;
* chunked simulation equals one whole simulation for every stateful object
  (play, PI, multivariable PI, Hammerstein plant with dynamics, the
  compensator family), empty chunks included;
* the Kuhnen-Janocha inverse composed with the model is the identity, from
  zero states and from the state matching any input history.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hammerstein import (InverseMultiplicativeCompensator, MultivariablePI, PrandtlIshlinskii,
                         play)

PROPS = settings(max_examples=40, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
FEW = settings(max_examples=12, deadline=None,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# -- strategies ----------------------------------------------------------------

VOLT = st.floats(-20.0, 20.0, allow_nan=False, allow_infinity=False)
THRESHOLDS = (st.lists(st.floats(0.0, 12.0, allow_nan=False), min_size=1, max_size=6, unique=True)
              .map(sorted).map(lambda r: np.array(r, dtype=float)))


def signal(min_size=1, max_size=50):
    """1-D input records [V]."""
    return st.lists(VOLT, min_size=min_size, max_size=max_size).map(np.array)


@st.composite
def pi_operators(draw, positive=False):
    """A classical PI operator, weights of any sign or strictly positive."""
    r = draw(THRESHOLDS)
    w_el = st.floats(0.01, 5.0) if positive else st.floats(-5.0, 5.0)
    w = draw(arrays(np.float64, r.size, elements=w_el))
    return PrandtlIshlinskii(r, w)


@st.composite
def mimo_models(draw, positive=False, max_in=3, max_out=3):
    """A p x m multivariable PI model mixing PI components, gains and None."""
    m = draw(st.integers(1, max_in))
    p = draw(st.integers(1, max_out))
    gain_el = st.floats(0.0, 3.0) if positive else st.floats(-3.0, 3.0)
    comp = st.one_of(pi_operators(positive=positive), gain_el, st.none())
    grid = [[draw(comp) for _ in range(m)] for _ in range(p)]
    if not any(isinstance(c, PrandtlIshlinskii) for row in grid for c in row):
        grid[0][0] = draw(pi_operators(positive=positive))
    return MultivariablePI(grid)


def inputs_for(model, min_size=1, max_size=40):
    """(m, n_samples) input records [V] for a model."""
    return st.integers(min_size, max_size).flatmap(
        lambda n: arrays(np.float64, (model.n_inputs, n), elements=VOLT))


def chunk_bounds(n):
    """Sorted split points in [0, n] (empty chunks allowed)."""
    return st.lists(st.integers(0, n), max_size=5).map(sorted)


# -- helpers -------------------------------------------------------------------

def _retime(u, counts, thetas, monotone=True, rng=None):
    """Insert samples between consecutive samples of every row of ``u``.

    ``counts[t]`` samples go between u[:, t] and u[:, t+1].  With
    ``monotone`` they are interpolants at fractions ``thetas`` clipped to the
    segment and sorted in the direction of travel (the sort only removes
    rounding noise: the exact interpolants are monotone in theta); without,
    they are arbitrary points of the segment's range in arbitrary order.

    Returns the re-timed (n, N') array and the indices of the original samples.
    """
    u = np.atleast_2d(u)
    cols, keep, k = [], [], 0
    for t in range(u.shape[1]):
        keep.append(len(cols))
        cols.append(u[:, t])
        if t + 1 == u.shape[1]:
            break
        a, b = u[:, t], u[:, t + 1]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        th = np.asarray(thetas[k:k + counts[t]], dtype=float)
        k += counts[t]
        if th.size == 0:
            continue
        pts = np.clip(a[:, None] + th[None, :] * (b - a)[:, None], lo[:, None], hi[:, None])
        if monotone:
            pts = np.sort(pts, axis=1)
            pts[b < a] = pts[b < a][:, ::-1]
        cols.extend(pts.T)
    return np.column_stack(cols), np.array(keep)


def _dominant_extrema(u):
    """Reduced input history: the alternating dominant extrema (wiping-out).

    Independent of the operators: a stack starts at the demagnetised anchor 0
    (zero play states); a repeat is dropped; a value continuing the last
    excursion replaces its end; a value going beyond the previous reversal
    point wipes out the last two reversal points (the closed minor loop); the
    first excursion from the anchor is wiped by a value of opposite sign and
    at least the same magnitude (the zero state is symmetric about 0).
    """
    def agree(a, b):       # sign(a) * sign(b) > 0, without products that underflow
        return (a > 0 and b > 0) or (a < 0 and b < 0)

    stack = [0.0]
    for x in map(float, u):
        while True:
            if x == stack[-1]:
                break
            if len(stack) >= 2 and agree(x - stack[-1], stack[-1] - stack[-2]):
                stack.pop()            # same direction: not a reversal point
                continue
            if len(stack) >= 3 and not agree(x - stack[-2], stack[-1] - stack[-2]):
                del stack[-2:]         # minor loop stack[-2] -> stack[-1] closed
                continue
            if len(stack) == 2 and agree(x, -stack[-1]) and abs(x) >= abs(stack[-1]):
                stack.pop()            # first excursion wiped by the opposite one
                continue
            stack.append(x)
            break
    return np.array(stack)


def _split(a, bounds):
    return np.split(a, bounds, axis=-1)


# -- rate independence ---------------------------------------------------------

@st.composite
def retimings(draw, n):
    counts = draw(st.lists(st.integers(0, 3), min_size=max(n - 1, 0), max_size=max(n - 1, 0)))
    theta = st.one_of(st.sampled_from([0.0, 1.0]), st.floats(0.0, 1.0))
    thetas = draw(st.lists(theta, min_size=sum(counts), max_size=sum(counts)))
    return counts, thetas


@PROPS
@given(u=signal(2, 40), r=THRESHOLDS, data=st.data())
def test_play_is_rate_independent(u, r, data):
    counts, thetas = data.draw(retimings(u.size))
    s0 = data.draw(arrays(np.float64, r.size, elements=VOLT))
    warped, keep = _retime(u, counts, thetas)
    y, fin = play(u, r, s0)
    yw, finw = play(warped[0], r, s0)
    np.testing.assert_array_equal(yw[:, keep], y)
    np.testing.assert_array_equal(finw, fin)


@PROPS
@given(model=mimo_models(), data=st.data())
def test_multivariable_pi_is_rate_independent(model, data):
    u = data.draw(inputs_for(model, 2, 30))
    counts, thetas = data.draw(retimings(u.shape[1]))
    warped, keep = _retime(u, counts, thetas)
    y, fin = model.simulate(u)
    yw, finw = model.simulate(warped)
    np.testing.assert_array_equal(yw[:, keep], y)
    np.testing.assert_array_equal(finw, fin)


def test_inserting_a_new_extremum_is_not_a_retiming():
    """Counter-example: an overshoot beyond the next sample changes the output."""
    y, _ = play([0.0, 1.0], [0.25])
    yo, _ = play([0.0, 2.0, 1.0], [0.25])
    assert y[0, 1] == pytest.approx(0.75, abs=1e-15)      # max(1 - r, 0)
    assert yo[0, 2] == pytest.approx(1.25, abs=1e-15)     # dragged to 1.75, back to 1 + r


# -- Lipschitz -----------------------------------------------------------------

@PROPS
@given(u1=signal(1, 50), r=THRESHOLDS, data=st.data())
def test_play_is_1_lipschitz_in_sup_norm(u1, r, data):
    if data.draw(st.booleans()):
        du = data.draw(arrays(np.float64, u1.size, elements=st.floats(-1.0, 1.0)))
    else:
        du = data.draw(arrays(np.float64, u1.size, elements=VOLT)) - u1
    u2 = u1 + du
    s1 = data.draw(arrays(np.float64, r.size, elements=VOLT))
    s2 = s1 + data.draw(arrays(np.float64, r.size, elements=st.floats(-2.0, 2.0)))
    y1, _ = play(u1, r, s1)
    y2, _ = play(u2, r, s2)
    bound = np.maximum(np.max(np.abs(u1 - u2)), np.abs(s1 - s2))      # per hysteron
    gap = np.max(np.abs(y1 - y2), axis=1)
    assert np.all(gap <= bound + 1e-12), (gap, bound)


@PROPS
@given(op=pi_operators(), u1=signal(1, 40), data=st.data())
def test_pi_is_lipschitz_with_the_sum_of_absolute_weights(op, u1, data):
    """Corollary: |Gamma(u1) - Gamma(u2)| <= sum |w_i| ||u1 - u2||_inf (same initial state)."""
    u2 = u1 + data.draw(arrays(np.float64, u1.size, elements=st.floats(-2.0, 2.0)))
    s0 = data.draw(arrays(np.float64, op.n_hysterons, elements=VOLT))
    y1, _ = op.simulate(u1, s0)
    y2, _ = op.simulate(u2, s0)
    bound = np.sum(np.abs(op.weights)) * np.max(np.abs(u1 - u2))
    assert np.max(np.abs(y1 - y2)) <= bound + 1e-10


# -- wiping-out ----------------------------------------------------------------

@PROPS
@given(model=mimo_models(), data=st.data())
def test_minor_loops_inside_a_later_excursion_are_wiped_out(model, data):
    u = data.draw(inputs_for(model, 2, 25))
    n = u.shape[1]
    counts = data.draw(st.lists(st.integers(0, 5), min_size=n - 1, max_size=n - 1))
    thetas = data.draw(st.lists(st.floats(0.0, 1.0), min_size=sum(counts), max_size=sum(counts)))
    looped, keep = _retime(u, counts, thetas, monotone=False)
    y, fin = model.simulate(u)
    yl, finl = model.simulate(looped)
    np.testing.assert_array_equal(yl[:, keep], y)
    np.testing.assert_array_equal(finl, fin)


@PROPS
@given(u=signal(1, 60), r=THRESHOLDS)
def test_play_state_depends_only_on_dominant_extrema(u, r):
    reduced = _dominant_extrema(u)
    # nested extrema: each reversal strictly inside the previous excursion
    # (compared as values, not as rounded differences)
    assert reduced[0] == 0.0 and np.all(np.diff(reduced) != 0)
    if reduced.size > 2:
        assert -abs(reduced[1]) < reduced[2] < abs(reduced[1])
    for k in range(3, reduced.size):
        lo, hi = sorted(reduced[k - 2:k])
        assert lo < reduced[k] < hi
    _, fin = play(u, r)
    _, fin_reduced = play(reduced, r)
    np.testing.assert_allclose(fin_reduced, fin, rtol=0, atol=1e-12)


@pytest.mark.parametrize("history, reduced", [
    ([5.0, -3.0], [0.0, 5.0, -3.0]),
    ([5.0, -6.0], [0.0, -6.0]),
    ([1.0, 4.0, 2.0, 3.0, 1.0, 5.0], [0.0, 5.0]),
    ([4.0, -3.0, 2.0, -1.0, 3.0], [0.0, 4.0, -3.0, 3.0]),
    ([0.5, 5e-324, 0.0], [0.0, 0.5, 0.0]),   # subnormal steps: products would underflow
])
def test_dominant_extrema_reduction_examples(history, reduced):
    np.testing.assert_array_equal(_dominant_extrema(history), reduced)


# -- monotonicity --------------------------------------------------------------

@PROPS
@given(op=pi_operators(positive=True), u=signal(1, 50), increasing=st.booleans(),
       data=st.data())
def test_positive_pi_is_monotone(op, u, increasing, data):
    u = np.sort(u) if increasing else -np.sort(u)
    s0 = data.draw(arrays(np.float64, op.n_hysterons, elements=VOLT))
    y, _ = op.simulate(u, s0)
    d = np.diff(y[1:]) if increasing else -np.diff(y[1:])   # from the first sample on
    assert np.all(d >= -1e-12 * (1 + np.max(np.abs(y))))


@PROPS
@given(model=mimo_models(positive=True), increasing=st.booleans(), data=st.data())
def test_positive_multivariable_pi_outputs_are_monotone(model, increasing, data):
    u = np.sort(data.draw(inputs_for(model, 1, 40)), axis=1)
    if not increasing:
        u = -u
    y, _ = model.simulate(u)
    d = np.diff(y, axis=1) if increasing else -np.diff(y, axis=1)
    assert np.all(d >= -1e-12 * (1 + np.max(np.abs(y))))


# -- additivity (eq. 3) --------------------------------------------------------

@PROPS
@given(model=mimo_models(max_in=3), data=st.data())
def test_multivariable_pi_is_additive_over_inputs(model, data):
    u = data.draw(inputs_for(model, 1, 40))
    y, _ = model.simulate(u)
    total = np.zeros_like(y)
    for k in range(model.n_inputs):
        only_k = np.zeros_like(u)
        only_k[k] = u[k]
        total += model.simulate(only_k)[0]
    np.testing.assert_allclose(total, y, rtol=1e-12, atol=1e-9)


# -- chunked == whole ----------------------------------------------------------

@PROPS
@given(u=signal(0, 60), r=THRESHOLDS, data=st.data())
def test_play_chunked_equals_whole(u, r, data):
    bounds = data.draw(chunk_bounds(u.size))
    y, fin = play(u, r)
    parts, s = [], None
    for chunk in _split(u, bounds):
        yc, s = play(chunk, r, s)
        parts.append(yc)
    np.testing.assert_array_equal(np.concatenate(parts, axis=1), y)
    np.testing.assert_array_equal(s, fin)


@PROPS
@given(op=pi_operators(), u=signal(0, 60), data=st.data())
def test_pi_chunked_equals_whole(op, u, data):
    bounds = data.draw(chunk_bounds(u.size))
    y, fin = op.simulate(u)
    parts, s = [], None
    for chunk in _split(u, bounds):
        yc, s = op.simulate(chunk, s)
        parts.append(yc)
    np.testing.assert_allclose(np.concatenate(parts), y, rtol=1e-13, atol=1e-12)
    np.testing.assert_array_equal(s, fin)


@PROPS
@given(model=mimo_models(), data=st.data())
def test_multivariable_pi_chunked_equals_whole(model, data):
    u = data.draw(inputs_for(model, 0, 40))
    bounds = data.draw(chunk_bounds(u.shape[1]))
    y, fin = model.simulate(u)
    parts, s = [], None
    for chunk in _split(u, bounds):
        yc, s = model.simulate(chunk, s)
        parts.append(yc)
    np.testing.assert_allclose(np.concatenate(parts, axis=1), y, rtol=1e-13, atol=1e-12)
    np.testing.assert_array_equal(s, fin)


@FEW
@given(data=st.data())
def test_plant_with_dynamics_chunked_equals_whole(preset_plant, data):
    u = data.draw(st.integers(0, 200).flatmap(
        lambda n: arrays(np.float64, (2, n), elements=st.floats(-10.0, 10.0))))
    bounds = data.draw(chunk_bounds(u.shape[1]))
    y, fin = preset_plant.simulate(u)
    parts, s = [], None
    for chunk in _split(u, bounds):
        yc, s = preset_plant.simulate(chunk, s)
        parts.append(yc)
    np.testing.assert_allclose(np.concatenate(parts, axis=1), y, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(s, fin, rtol=1e-12, atol=1e-9)


def _compensator(kind, plant):
    model = plant.hysteresis
    if kind == "secant":
        return InverseMultiplicativeCompensator(model)
    if kind == "two-iterations":
        return InverseMultiplicativeCompensator(model, iterations=2)
    if kind == "lowpass":
        return InverseMultiplicativeCompensator(model, feedback="lowpass", cutoff_hz=2000.0,
                                                sampling_period=plant.sampling_period,
                                                check="ignore")
    from hammerstein import PerAxisInverseCompensator
    return PerAxisInverseCompensator(model)


@pytest.mark.parametrize("kind", ["secant", "two-iterations", "lowpass", "per-axis"])
@FEW
@given(amp=st.floats(1.0, 50.0), freq=st.floats(5.0, 200.0), phase=st.floats(0.0, 6.3),
       n=st.integers(0, 300), data=st.data())
def test_compensator_chunked_equals_whole(preset_plant, kind, amp, freq, phase, n, data):
    comp = _compensator(kind, preset_plant)
    t = np.arange(n) * preset_plant.sampling_period
    ref = np.vstack([amp * np.sin(2 * np.pi * freq * t),
                     0.6 * amp * np.sin(2 * np.pi * freq * t + phase)])
    bounds = data.draw(chunk_bounds(n))
    u, fin = comp.simulate(ref)
    parts, s = [], None
    for chunk in _split(ref, bounds):
        uc, s = comp.simulate(chunk, s)
        parts.append(uc)
    np.testing.assert_allclose(np.concatenate(parts, axis=1), u, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(s, fin, rtol=1e-12, atol=1e-10)


# -- Kuhnen-Janocha inverse ----------------------------------------------------

def _kuhnen_inverse():
    try:
        module = importlib.import_module("hammerstein.compensation.inverse")
    except ImportError:
        pytest.skip("hammerstein.inverse is absent: no Kuhnen-Janocha inverse to test yet")
    if not hasattr(module, "kuhnen_inverse"):
        pytest.skip("hammerstein.inverse.kuhnen_inverse is absent")
    return module.kuhnen_inverse


@st.composite
def invertible_pi(draw):
    """PI operator with every cumulative weight sum S_i > 0 (docs/per-axis-inverse.md).

    Thresholds at least 1 mV apart: the inverse thresholds
    ``r'_i+1 - r'_i = S_i (r_i+1 - r_i)`` must stay distinct in floating point
    (thresholds 5e-324 V apart underflow to a duplicated inverse threshold).
    """
    first = draw(st.floats(0.0, 2.0))
    gaps = draw(st.lists(st.floats(1e-3, 3.0), max_size=5))
    r = first + np.concatenate([[0.0], np.cumsum(gaps)])
    w, S = [], 0.0
    for _ in range(r.size):
        lo = 0.1 if S == 0.0 else -0.9 * S
        wi = draw(st.floats(lo, 5.0))
        w.append(wi)
        S += wi
    return PrandtlIshlinskii(r, np.array(w))


@PROPS
@given(op=invertible_pi(), y=st.lists(st.floats(-60.0, 60.0), min_size=1, max_size=50).map(np.array))
def test_kuhnen_inverse_then_model_is_identity(op, y):
    inverse = _kuhnen_inverse()(op)
    u, _ = inverse.simulate(y)
    y_back, _ = op.simulate(u)
    np.testing.assert_allclose(y_back, y, rtol=1e-9, atol=1e-9)


@PROPS
@given(op=invertible_pi(), history=signal(1, 20),
       y=st.lists(st.floats(-60.0, 60.0), min_size=1, max_size=40).map(np.array))
def test_kuhnen_inverse_is_identity_from_a_consistent_state(op, history, y):
    """After any input history, the inverse started from the matching state."""
    inverse = _kuhnen_inverse()(op)
    _, z = op.simulate(history)
    u, _ = inverse.simulate(y, inverse.consistent_state(z, history[-1]))
    y_back, _ = op.simulate(u, z)
    np.testing.assert_allclose(y_back, y, rtol=1e-9, atol=1e-9)
