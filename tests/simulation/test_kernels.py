"""Compiled kernels (backend='numba') against the plain numpy oracle (backend='numpy').

Random models: random p x m grids of PI operators with random numbers of
thresholds, negative weights, pure gains and absent components; random
inputs and initial states. Agreement is required to 1e-9 (the kernels only
change the order of the weighted sums).
"""

import numpy as np
import pytest

from hammerstein import (CompensatorDivergence, CompensatorError, HammersteinPlant,
                         HysteresisError, InverseMultiplicativeCompensator, MultivariablePI,
                         PrandtlIshlinskii, StaticGainCompensator, bending_modes, discretize,
                         load_plant)
from hammerstein import simulation as sim
from hammerstein.models.hysteresis import play

# the kernels are checked on random references, which often leave the identified range:
# its RangeWarning says so at every call and is not what these tests are about
pytestmark = pytest.mark.filterwarnings("ignore::hammerstein.exceptions.RangeWarning")

ATOL = 1e-9
T = 5e-5


def random_pi(rng, n_max=6, shared=None):
    n = int(rng.integers(1, n_max + 1)) if shared is None else shared.size
    r = np.sort(rng.choice(np.linspace(0, 8, 81), n, replace=False)) if shared is None else shared
    w = rng.normal(0.5, 0.8, n)          # includes negative weights
    return PrandtlIshlinskii(r, w)


def random_model(rng, p=None, m=None, square=False, shared=False):
    p = int(rng.integers(1, 4)) if p is None else p
    m = (p if square else int(rng.integers(1, 4))) if m is None else m
    r_shared = np.sort(rng.choice(np.linspace(0, 8, 81), 5, replace=False)) if shared else None
    comps = []
    for l in range(p):
        row = []
        for k in range(m):
            kind = rng.choice(["pi", "pi", "gain", "none"])
            row.append(random_pi(rng, shared=r_shared) if kind == "pi"
                       else float(rng.normal()) if kind == "gain" else None)
        comps.append(row)
    comps[0][0] = random_pi(rng, shared=r_shared)      # at least one hysteresis
    return MultivariablePI(comps)


def random_inputs(rng, m, n):
    t = np.arange(n)
    u = rng.normal(0, 3, (m, n)).cumsum(axis=1) * 0.3
    return u + 6 * np.sin(2 * np.pi * t / rng.integers(20, 200))


def square_model(rng, m):
    """A square model whose normalised compensator converges (checked at construction).

    Positive direct weights with a first threshold of 0 (no dead band) and
    thresholds below 3 V for a 10 V range keep the slopes within (0, 1.5) times the secant gain: rho(I - K^-1 J) < 1.
    """
    comps = []
    for l in range(m):
        row = []
        for k in range(m):
            r = np.r_[0.0, np.sort(rng.choice(np.linspace(0.1, 3, 30), int(rng.integers(1, 6)),
                                               replace=False))]
            w = (rng.uniform(0.2, 1.5, r.size) if l == k else rng.normal(0, 0.02, r.size))
            row.append(PrandtlIshlinskii(r, w))
        comps.append(row)
    return MultivariablePI(comps, input_amplitude=np.full(m, 10.0))


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("shared", [False, True])
def test_forward_model_matches_oracle(seed, shared):
    rng = np.random.default_rng(seed)
    model = random_model(rng, shared=shared)
    u = random_inputs(rng, model.n_inputs, 300)
    s0 = None if seed % 2 else rng.normal(0, 2, model.n_hysterons)
    y_ref, s_ref = sim.simulate_hysteresis(model, u, s0, backend="numpy")
    y, s = sim.simulate_hysteresis(model, u, s0)
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=ATOL)
    # model.simulate (used by every caller) is the kernel
    np.testing.assert_allclose(model.simulate(u, s0)[0], y_ref, rtol=0, atol=ATOL)


@pytest.mark.parametrize("seed", range(4))
def test_forward_model_chunked_equals_whole(seed):
    rng = np.random.default_rng(100 + seed)
    model = random_model(rng, shared=bool(seed % 2))
    u = random_inputs(rng, model.n_inputs, 400)
    y_whole, s_whole = model.simulate(u)
    cuts = np.sort(rng.choice(np.arange(1, 400), 3, replace=False))
    s, parts = None, []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, 400]):
        y, s = model.simulate(u[:, a:b], s)
        parts.append(y)
    np.testing.assert_allclose(np.hstack(parts), y_whole, rtol=0, atol=ATOL)
    np.testing.assert_allclose(s, s_whole, rtol=0, atol=ATOL)


def test_shared_plays_are_merged_only_with_equal_states():
    rng = np.random.default_rng(7)
    model = random_model(rng, p=3, m=2, shared=True)
    model = MultivariablePI([[random_pi(rng, shared=np.array([0.0, 1.0, 2.0]))
                              for _ in range(2)] for _ in range(3)])
    packed = sim.pack_model(model)
    assert packed.r.size == 2 * 4            # 2 inputs x 3 thresholds, padded to 4 lanes
    state = rng.normal(0, 1, model.n_hysterons)
    assert np.count_nonzero(sim.pack_model(model, state).rep >= 0) == model.n_hysterons
    u = random_inputs(rng, 2, 200)
    np.testing.assert_allclose(model.simulate(u, state)[0],
                               sim.simulate_hysteresis(model, u, state, backend="numpy")[0],
                               rtol=0, atol=ATOL)


@pytest.mark.parametrize("seed", range(3))
def test_play_kernel_matches_closed_form_recursion(seed):
    rng = np.random.default_rng(seed)
    u = random_inputs(rng, 1, 250)[0]
    r = np.array([0.0, 0.5, 1.7, 4.0])
    s0 = rng.normal(0, 2, r.size)
    y, s = play(u, r, s0)
    expected = np.empty_like(y)
    prev = s0.copy()
    for t in range(u.size):            # eq. (1), written out
        prev = np.maximum(u[t] - r, np.minimum(u[t] + r, prev))
        expected[:, t] = prev
    np.testing.assert_allclose(y, expected, rtol=0, atol=0)
    np.testing.assert_allclose(s, expected[:, -1], rtol=0, atol=0)


@pytest.mark.parametrize("seed", range(3))
def test_inverse_play_kernel_matches_oracle(seed):
    """The compiled inverse play equals the numpy loop bit for bit, on held runs, motions
    below the tolerance and large motions."""
    rng = np.random.default_rng(seed)
    e = 10.0 ** rng.uniform(-12, -2)
    v = np.cumsum(rng.normal(size=800) * (rng.random(800) < 0.5)
                  + rng.uniform(-e, e, 800) * (rng.random(800) < 0.5))
    state = np.array([v[0], 0.3 * rng.uniform(-1, 1)])
    u, s = sim.simulate_inverse_play(v, 0.3, e, state)
    u_ref, s_ref = sim.simulate_inverse_play(v, 0.3, e, state, backend="numpy")
    np.testing.assert_array_equal(u, u_ref)
    np.testing.assert_array_equal(s, s_ref)


def random_plant(rng, model, dynamics):
    dyn = None
    if dynamics:
        p = model.n_outputs
        dyn = discretize(bending_modes(rng.uniform(200, 600, p), rng.uniform(0.05, 0.5, p)), T)
    return HammersteinPlant(model, T, dyn)


@pytest.mark.parametrize("dynamics", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_plant_matches_oracle_and_chunks(seed, dynamics):
    rng = np.random.default_rng(200 + seed)
    plant = random_plant(rng, random_model(rng), dynamics)
    u = random_inputs(rng, plant.hysteresis.n_inputs, 300)
    x0 = rng.normal(0, 1, plant.n_states)
    y_ref, s_ref = sim.simulate_plant(plant, u, x0, backend="numpy")
    y, s = plant.simulate(u, x0)
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=ATOL)
    y1, s1 = plant.simulate(u[:, :117], x0)
    y2, s2 = plant.simulate(u[:, 117:], s1)
    np.testing.assert_allclose(np.hstack([y1, y2]), y_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(s2, s_ref, rtol=0, atol=ATOL)


def _compare_chain(comp, plant, yr, **kw):
    ref = sim.simulate_chain(comp, plant, yr, backend="numpy", **kw)
    got = sim.simulate_chain(comp, plant, yr, **kw)
    assert got.diverged == ref.diverged
    if ref.diverged:
        assert got.divergence.sample == ref.divergence.sample
        n = ref.divergence.sample
        np.testing.assert_allclose(got.inputs[:, :n], ref.inputs[:, :n], rtol=0, atol=ATOL)
        np.testing.assert_allclose(got.outputs[:, :n], ref.outputs[:, :n], rtol=0, atol=ATOL)
        assert np.all(np.isnan(got.inputs[:, n:]))
    else:
        for a in ("inputs", "outputs", "compensator_state", "plant_state"):
            np.testing.assert_allclose(getattr(got, a), getattr(ref, a), rtol=0, atol=ATOL)
    return got


@pytest.mark.parametrize("iterations", [1, 3])
@pytest.mark.parametrize("dynamics", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_compensator_chain_matches_oracle(seed, dynamics, iterations):
    rng = np.random.default_rng(300 + seed)
    m = int(rng.integers(1, 4))
    model = square_model(rng, m)
    comp = InverseMultiplicativeCompensator(model, iterations=iterations, check="error")
    plant = random_plant(rng, square_model(rng, m), dynamics)
    yr = random_inputs(rng, m, 300) * 2
    got = _compare_chain(comp, plant, yr)
    assert not got.diverged
    u_ref, c_ref = sim.simulate_compensator(comp, yr, backend="numpy")
    u, c = comp.simulate(yr)
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(c, c_ref, rtol=0, atol=ATOL)
    # chunked == whole, states carried over
    a = sim.simulate_chain(comp, plant, yr[:, :140])
    b = sim.simulate_chain(comp, plant, yr[:, 140:], a.compensator_state, a.plant_state)
    np.testing.assert_allclose(np.hstack([a.outputs, b.outputs]), got.outputs, rtol=0, atol=ATOL)


def _naive_delay_law(model, K_inv, iterations, yr):
    """The delay law written out hysteron by hysteron (plain Python, no packing, no pairs).

    ``Gamma(U; s)`` adds, for every hysteron h (input k, output l, threshold
    r, weight w), ``w * max(U_k - r, min(U_k + r, s_h))`` to output l, then
    the pure gains; the plays s stay frozen over a sample's iterations and
    are moved to the final U.
    """
    f = model.hysterons()
    m, n = K_inv.shape[0], yr.shape[1]
    s = np.zeros(f["thresholds"].size)

    def gamma(u, s):
        moved = np.maximum(u[f["input_index"]] - f["thresholds"],
                           np.minimum(u[f["input_index"]] + f["thresholds"], s))
        y = f["gain"] @ u
        for h in range(s.size):
            y[f["output_index"][h]] += f["weights"][h] * moved[h]
        return y, moved

    u_prev = np.zeros(m)
    out = np.empty((m, n))
    for t in range(n):
        u = u_prev.copy()
        for _ in range(iterations):
            u = u + K_inv @ (yr[:, t] - gamma(u, s)[0])
        s = gamma(u, s)[1]
        out[:, t] = u_prev = u
    return out


@pytest.mark.parametrize("m", [1, 2, 3, 4])
def test_law_iterations_match_the_written_out_law_to_rounding(m):
    # the law's re-evaluations Gamma(U; s) run outputs in pairs (an odd last one alone),
    # each play moved in a register: the same sums as the hysteron-by-hysteron law
    # regrouped, so equal to rounding (1e-12 of the input range), on 1 to 4 outputs
    rng = np.random.default_rng(1200 + m)
    model = square_model(rng, m)
    comp = InverseMultiplicativeCompensator(model, iterations=3, check="error")
    yr = random_inputs(rng, m, 400) * 2
    u, _ = sim.simulate_compensator(comp, yr)
    ref = _naive_delay_law(model, np.asarray(comp.packed_law().K_inv), 3, yr)
    np.testing.assert_allclose(u, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))


@pytest.mark.parametrize("iterations", [2, 3])
@pytest.mark.parametrize("seed", range(3))
def test_closed_form_2x2_law_is_the_written_out_law_and_chunks(seed, iterations, monkeypatch):
    # a 2 x 2 law with 2 or 3 iterations runs in closed form where Gamma is linear around
    # U(t-T) (d_i = N_i e): the written-out law to rounding, on references with reversals and
    # steps (where it falls back on the iterations); the prefixes it keeps are a function
    # of the state, so chunks cut anywhere give the whole run (to rounding: a chunk
    # packs the plays of its own initial state, merging others, which regroups the sums)
    from hammerstein.simulation import _stepping
    rng = np.random.default_rng(1500 + seed)
    model = square_model(rng, 2)
    comp = InverseMultiplicativeCompensator(model, iterations=iterations, check="error")
    yr = random_inputs(rng, 2, 1500) * 2
    u, c = sim.simulate_compensator(comp, yr)
    ref = _naive_delay_law(model, np.asarray(comp.packed_law().K_inv), iterations, yr)
    np.testing.assert_allclose(u, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))
    for cut in (1, 777, 1499):
        ua, ca = sim.simulate_compensator(comp, yr[:, :cut])
        ub, cb = sim.simulate_compensator(comp, yr[:, cut:], ca)
        np.testing.assert_allclose(np.hstack([ua, ub]), u, rtol=0,
                                   atol=1e-12 * np.max(np.abs(ref)))
        np.testing.assert_allclose(cb, c, rtol=0, atol=1e-12 * np.max(np.abs(ref)))
    # the closed form did run: the kernel without its table (the iterations as written)
    # rounds otherwise somewhere in 1500 samples
    monkeypatch.setattr(_stepping, "law_slopes", lambda *args: None)
    u_iterated, _ = sim.simulate_compensator(comp, yr)
    np.testing.assert_allclose(u_iterated, u, rtol=0, atol=1e-12 * np.max(np.abs(ref)))
    assert not np.array_equal(u_iterated, u)


def test_closed_form_2x2_law_falls_back_on_play_states_out_of_order():
    # play states given by hand need not be ordered as an input history leaves them; the
    # closed form's prefixes would then miss plays, so the kernel runs the iterations: the
    # numpy oracle's result, from the same state
    rng = np.random.default_rng(1600)
    model = square_model(rng, 2)
    comp = InverseMultiplicativeCompensator(model, iterations=3, check="error")
    yr = random_inputs(rng, 2, 500) * 2
    state = np.zeros(comp.n_states)
    state[2:] = rng.uniform(-2.0, 2.0, comp.n_states - 2)      # the plays, out of order
    u, c = sim.simulate_compensator(comp, yr, state)
    u_ref, c_ref = sim.simulate_compensator(comp, yr, state, backend="numpy")
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(c, c_ref, rtol=0, atol=ATOL)


@pytest.mark.parametrize("seed", range(3))
def test_chain_plant_part_is_the_plant_kernel_bit_for_bit(seed):
    # the chain kernel runs the plant with the same inlined steps as the plant kernel:
    # the plant fed the chain's inputs must give the chain's outputs exactly, and the
    # compensator alone (no plant) the chain's inputs exactly
    rng = np.random.default_rng(900 + seed)
    m = int(rng.integers(1, 4))
    comp = InverseMultiplicativeCompensator(square_model(rng, m), iterations=1 + seed % 2,
                                            check="error")
    plant = random_plant(rng, square_model(rng, m), True)
    yr = random_inputs(rng, m, 250) * 2
    got = sim.simulate_chain(comp, plant, yr)
    assert not got.diverged
    y, final = sim.simulate_plant(plant, got.inputs)
    assert np.array_equal(y, got.outputs)
    assert np.array_equal(final, got.plant_state)
    u, c_final = sim.simulate_compensator(comp, yr)
    assert np.array_equal(u, got.inputs)
    assert np.array_equal(c_final, got.compensator_state)


def test_literal_law_diverges_at_the_same_sample_as_the_oracle():
    plant = load_plant("rakotondrabe-2dof")
    comp = InverseMultiplicativeCompensator(plant.hysteresis, gain="identity", check="ignore")
    t = np.arange(400) * T
    yr = np.vstack([50 * np.sin(2 * np.pi * 50 * t), np.zeros_like(t)])
    got = _compare_chain(comp, plant, yr)
    assert got.divergence.sample == 8            # the core's documented number
    with pytest.raises(CompensatorDivergence) as exc:
        comp.simulate(yr)
    assert exc.value.sample == 8


def _lowpass(model, cutoff_hz):
    return InverseMultiplicativeCompensator(model, check="ignore", feedback="lowpass",
                                            cutoff_hz=cutoff_hz, sampling_period=T)


@pytest.mark.parametrize("cutoff_hz", [50.0, 2000.0])
def test_lowpass_feedback_matches_oracle(cutoff_hz):
    rng = np.random.default_rng(400)
    model = square_model(rng, 2)
    plant = random_plant(rng, model, True)
    yr = random_inputs(rng, 2, 300)
    comp = _lowpass(model, cutoff_hz)
    _compare_chain(comp, plant, yr)
    x0 = np.concatenate([rng.normal(0, 1, 4), np.zeros(model.n_hysterons)])
    u_ref, s_ref = sim.simulate_compensator(comp, yr, x0, backend="numpy")
    u, s = comp.simulate(yr, x0)
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=ATOL)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=ATOL)


def test_lowpass_with_a_zero_pole_is_the_delay_law():
    # a = exp(-2 pi fc T) -> 0: v_f(t) = v(t-T) and U(t) = U(t-T) + K^-1 (Yr - Gamma(U(t-T)))
    rng = np.random.default_rng(401)
    model = square_model(rng, 2)
    yr = random_inputs(rng, 2, 200)
    comp = _lowpass(model, 9_000.0)
    comp.cutoff_hz = 1e9                     # below Nyquist is enforced at construction only
    assert sim.compensator_law(comp)[1] == 0.0
    delay = InverseMultiplicativeCompensator(model, check="ignore")
    np.testing.assert_allclose(comp.simulate(yr)[0], delay.simulate(yr)[0], rtol=0, atol=ATOL)


@pytest.mark.parametrize("parallel", [False, True])
def test_batch_equals_individual_runs(parallel):
    rng = np.random.default_rng(500)
    base = square_model(rng, 2)
    scaled = MultivariablePI([[PrandtlIshlinskii(c.thresholds, c.weights * 0.95)
                               for c in row] for row in base.components],
                             input_amplitude=base.input_amplitude)
    models = [base, scaled]
    comps = [InverseMultiplicativeCompensator(models[0], check="ignore"),
             InverseMultiplicativeCompensator(models[1], iterations=3, check="ignore"),
             _lowpass(models[1], 300.0),
             InverseMultiplicativeCompensator(models[0], gain=0.1, check="ignore")]
    plants = [random_plant(rng, base, True), random_plant(rng, base, False),
              random_plant(rng, base, True), random_plant(rng, base, True)]
    refs = [random_inputs(rng, 2, n) * 3 for n in (250, 90, 300, 200)]
    results = sim.simulate_chain_batch(comps, plants, refs, parallel=parallel)
    # the batch runs chain_kernel itself on each case: equal bit for bit, not within a tolerance
    for comp, plant, yr, got in zip(comps, plants, refs, results):
        one = sim.simulate_chain(comp, plant, yr)
        assert got.diverged == one.diverged
        np.testing.assert_array_equal(got.inputs, one.inputs)
        np.testing.assert_array_equal(got.outputs, one.outputs)
        if not one.diverged:
            np.testing.assert_array_equal(got.plant_state, one.plant_state)
            np.testing.assert_array_equal(got.compensator_state, one.compensator_state)
        else:
            assert got.divergence.sample == one.divergence.sample
    assert results[3].diverged                 # K = 0.1 I: rho(I - K^-1 J) > 1


def test_bad_backend_is_named():
    model = random_model(np.random.default_rng(0))
    with pytest.raises(ValueError, match="backend"):
        sim.simulate_hysteresis(model, np.zeros((model.n_inputs, 3)), backend="fortran")


# -- linear reference pre-filter ----------------------------------------------------------
class Prefiltered:
    """The law of ``inner`` behind a linear reference pre-filter (the compensator protocol)."""

    def __init__(self, inner, prefilter):
        self.inner, self.prefilter = inner, prefilter

    def packed_law(self):
        return self.inner.packed_law()._replace(prefilter=self.prefilter)

    def simulate(self, reference, initial_state=None):
        return sim.simulate_compensator(self, reference, initial_state)


def stable_filter(rng, n, p):
    """A random discrete state space of n states, p inputs/outputs, spectral radius 0.8."""
    A = rng.normal(size=(n, n))
    A *= 0.8 / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-12)
    return sim.LinearArrays(A, rng.normal(size=(n, p)), rng.normal(size=(p, n)),
                            np.eye(p) + 0.1 * rng.normal(size=(p, p)))


def filter_loop(f, yr, x0):
    """v(t) = C x + D Yr(t); x <- A x + B Yr(t), written out."""
    x, v = x0.copy(), np.empty_like(yr)
    for t in range(yr.shape[1]):
        v[:, t] = f.C @ x + f.D @ yr[:, t]
        x = f.A @ x + f.B @ yr[:, t]
    return v, x


@pytest.mark.parametrize("law", ["delay", "iterations", "lowpass"])
@pytest.mark.parametrize("seed", range(2))
def test_prefilter_equals_the_compensator_on_the_filtered_reference(seed, law):
    rng = np.random.default_rng(600 + seed)
    model = square_model(rng, 2)
    inner = (_lowpass(model, 400.0) if law == "lowpass" else
             InverseMultiplicativeCompensator(model, iterations=3 if law == "iterations" else 1,
                                              check="ignore"))
    f = stable_filter(rng, 3, 2)
    comp = Prefiltered(inner, f)
    plant = random_plant(rng, square_model(rng, 2), True)
    yr = random_inputs(rng, 2, 250)
    v, xf_final = filter_loop(f, yr, np.zeros(3))
    expected = sim.simulate_chain(inner, plant, v)
    got = _compare_chain(comp, plant, yr)               # numba against the numpy oracle
    assert not got.diverged and not expected.diverged
    np.testing.assert_allclose(got.inputs, expected.inputs, rtol=0, atol=ATOL)
    np.testing.assert_allclose(got.outputs, expected.outputs, rtol=0, atol=ATOL)
    np.testing.assert_allclose(got.compensator_state,
                               np.concatenate([expected.compensator_state, xf_final]),
                               rtol=0, atol=ATOL)
    # chunked == whole: the final states (pre-filter state included) are fed back
    a = sim.simulate_chain(comp, plant, yr[:, :101])
    b = sim.simulate_chain(comp, plant, yr[:, 101:], a.compensator_state, a.plant_state)
    np.testing.assert_allclose(np.hstack([a.outputs, b.outputs]), got.outputs, rtol=0, atol=ATOL)
    np.testing.assert_allclose(b.compensator_state, got.compensator_state, rtol=0, atol=ATOL)
    u1, s1 = comp.simulate(yr[:, :60])
    u2, s2 = comp.simulate(yr[:, 60:], s1)
    np.testing.assert_allclose(np.hstack([u1, u2]), got.inputs, rtol=0, atol=ATOL)


def sparse_filter(rng, p, window=4):
    """Mostly zeros, as a ZPETC inverse's state space: a shift register of the past
    ``window - 1`` reference samples (entries exactly 1), one stable mode per output fed
    by the window, taps on the window; a state row and column of zeros besides."""
    nw = p * (window - 1)
    n = nw + p + 1                                   # the last state: all-zero row and column
    A, B = np.zeros((n, n)), np.zeros((n, p))
    C, D = np.zeros((p, n)), np.diag(rng.uniform(0.5, 1.5, p))
    for j in range(window - 2):
        A[j * p:(j + 1) * p, (j + 1) * p:(j + 2) * p] = np.eye(p)
    B[(window - 2) * p:(window - 1) * p] = np.eye(p)
    for l in range(p):
        A[nw + l, nw + l] = rng.uniform(0.2, 0.6)
        A[nw + l, l::p][:window - 1] = rng.normal(size=window - 1)
        C[l, l:nw:p] = rng.normal(size=window - 1)
        C[l, nw + l] = rng.normal()
    return sim.LinearArrays(A, B, C, D)


@pytest.mark.parametrize("quiet", [0, 5, 300, 700])
def test_prefilter_state_at_a_divergence_is_the_state_after_that_sample(quiet):
    # the kernel filters the reference ahead of the law, a block of samples at a time; at a
    # diverging sample (the literal law on a sine after `quiet` samples at rest, in the
    # first, second or third block) the pre-filter state it leaves is the written-out
    # filter's state after that sample, and the inputs before it are the filtered law's
    from hammerstein.simulation._stepping import _run_chain_kernel
    plant = load_plant("rakotondrabe-2dof")
    rng = np.random.default_rng(77)
    f = stable_filter(rng, 3, 2)
    comp = Prefiltered(InverseMultiplicativeCompensator(plant.hysteresis, gain="identity",
                                                        check="ignore"), f)
    t = np.arange(quiet + 400) * T
    yr = np.vstack([50 * np.sin(2 * np.pi * 50 * t), 20 * np.cos(2 * np.pi * 30 * t)])
    yr[:, :quiet] = 0.0
    law = sim.compensator_law(comp) and comp.packed_law()
    x0 = 1e-6 * rng.normal(size=3)          # decays within the quiet samples
    state = np.concatenate([np.zeros(2 + plant.hysteresis.n_hysterons), x0])
    u, _, c_final, _, status, sample = _run_chain_kernel(law, yr, state)
    assert status != 0 and quiet <= sample < quiet + 400
    _, x_after = filter_loop(f, yr[:, :sample + 1], x0)
    np.testing.assert_allclose(c_final[-3:], x_after, rtol=1e-12, atol=1e-12)
    v, _ = filter_loop(f, yr[:, :sample], x0)
    inner = InverseMultiplicativeCompensator(plant.hysteresis, gain="identity", check="ignore")
    u_ref, _ = sim.simulate_compensator(inner, v)
    np.testing.assert_allclose(u[:, :sample], u_ref, rtol=0, atol=1e-9)


@pytest.mark.parametrize("p", [1, 2, 3])
def test_sparse_prefilter_equals_the_written_out_filter(p):
    """The kernel steps the pre-filter on its non-zero entries (delay lines read from the
    reference, the other terms summed a block at a time): same outputs and final
    state as the dense filter written out (``filter_loop``), chunked == whole."""
    rng = np.random.default_rng(620 + p)
    model = square_model(rng, p)
    f = sparse_filter(rng, p)
    assert np.count_nonzero(np.hstack([f.A, f.B])) < f.A.size / 2
    plant = random_plant(rng, square_model(rng, p), True)
    yr = random_inputs(rng, p, 300)
    x0 = rng.normal(size=f.A.shape[0])
    x0[-1] = 0.0
    check_prefiltered_chain(model, f, plant, yr, x0, 137)


def check_prefiltered_chain(model, f, plant, yr, x0, split):
    """The chain with the pre-filter ``f`` (initial state ``x0``) ahead of the 3-iteration law
    of ``model``: the law run on the filter written out (``filter_loop``), the same final
    filter state, and chunked at ``split`` == whole."""
    inner = InverseMultiplicativeCompensator(model, iterations=3, check="ignore")
    comp = Prefiltered(inner, f)
    state0 = np.concatenate([np.zeros(model.n_inputs + model.n_hysterons), x0])
    v, xf_final = filter_loop(f, yr, x0)
    expected = sim.simulate_chain(inner, plant, v)
    got = sim.simulate_chain(comp, plant, yr, state0)
    np.testing.assert_allclose(got.inputs, expected.inputs, rtol=0, atol=ATOL)
    np.testing.assert_allclose(got.outputs, expected.outputs, rtol=0, atol=ATOL)
    np.testing.assert_allclose(got.compensator_state[-x0.size:], xf_final, rtol=0, atol=ATOL)
    a = sim.simulate_chain(comp, plant, yr[:, :split], state0)
    b = sim.simulate_chain(comp, plant, yr[:, split:], a.compensator_state, a.plant_state)
    np.testing.assert_array_equal(np.hstack([a.outputs, b.outputs]), got.outputs)
    np.testing.assert_array_equal(b.compensator_state, got.compensator_state)


def tangled_filter(rng, p):
    """Delay lines next to states that only look like them (10 states, input k = min(1, p-1)).

    s0 = r0 one sample back, s1 = s0 one back (r0 two back), s2 = r0 one back again (a
    second delay line of the same input and lag: its initial value differs), s3 = s2 one
    back, s4 a mode fed by s1, s3 and rk, s5 = s4 one back (a delay of a mode), s6 = s6
    (holds its value), s7 and s8 swap (a ring), s9 = rk one back."""
    k = min(1, p - 1)
    n = 10
    A, B = np.zeros((n, n)), np.zeros((n, p))
    B[0, 0] = 1.0
    A[1, 0] = 1.0
    B[2, 0] = 1.0
    A[3, 2] = 1.0
    A[4, 4], A[4, 1], A[4, 3], B[4, k] = 0.5, 0.3, -0.2, 0.7
    A[5, 4] = 1.0
    A[6, 6] = 1.0
    A[7, 8] = A[8, 7] = 1.0
    B[9, k] = 1.0
    C = rng.normal(size=(p, n))
    D = np.eye(p) + 0.1 * rng.normal(size=(p, p))
    return sim.LinearArrays(A, B, C, D)


def test_prefilter_plan_reads_only_true_delay_lines():
    from hammerstein.simulation._kernels import _prefilter_plan
    f = tangled_filter(np.random.default_rng(630), 2)
    lag, src, dyn = _prefilter_plan(f.A, f.B, f.C, f.D)[:3]
    # s0, s1: r0 one and two back; s9: r1 one back; s2 repeats s0's line, so s2 and s3
    # (which copies it), the mode s4, its copy s5, the held s6 and the ring s7, s8 step
    assert lag.tolist() == [1, 2, 0, 0, 0, 0, 0, 0, 0, 1]
    assert src[[0, 1, 9]].tolist() == [0, 0, 1]
    assert dyn.tolist() == [2, 3, 4, 5, 6, 7, 8]
    # the plan a single run makes in Python (nothing compiled) is the compiled planner's
    from hammerstein.simulation._kernels import prefilter_plan
    compiled, python = _prefilter_plan(f.A, f.B, f.C, f.D), prefilter_plan(f)
    used = [None] * 5 + [compiled[4][-1]] * 3 + [None] + [compiled[8][-1]] * 4  # head, tail
    for a, b, n in zip(compiled, python, used):
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(a[:n], b[:n])    # past the rows' ends: scratch


@pytest.mark.parametrize("p", [1, 2])
def test_prefilter_with_tangled_delay_lines_equals_the_written_out_filter(p):
    """The kernel reads the delay lines of a pre-filter from the reference: same outputs
    and final state as the filter written out, from a random initial state (the two delay
    lines of one input and lag start apart), over several blocks, chunked == whole."""
    rng = np.random.default_rng(640 + p)
    model = square_model(rng, p)
    f = tangled_filter(rng, p)
    plant = random_plant(rng, square_model(rng, p), True)
    yr = random_inputs(rng, p, 700)
    x0 = rng.normal(size=f.A.shape[0])
    check_prefiltered_chain(model, f, plant, yr, x0, 301)


@pytest.mark.parametrize("feedback", ["delay", "lowpass"])
def test_empty_prefilter_is_the_exact_identity(feedback):
    rng = np.random.default_rng(610)
    model = square_model(rng, 2)
    inner = (_lowpass(model, 300.0) if feedback == "lowpass"
             else InverseMultiplicativeCompensator(model, iterations=2, check="ignore"))
    plant = random_plant(rng, model, True)
    yr = random_inputs(rng, 2, 200)
    plain = sim.simulate_chain(inner, plant, yr)
    empty = sim.simulate_chain(Prefiltered(inner, sim.identity_filter(2)), plant, yr)
    np.testing.assert_array_equal(empty.inputs, plain.inputs)
    np.testing.assert_array_equal(empty.outputs, plain.outputs)
    np.testing.assert_array_equal(empty.compensator_state, plain.compensator_state)


def test_batch_runs_prefiltered_and_plain_cases():
    rng = np.random.default_rng(620)
    model = square_model(rng, 2)
    inner = InverseMultiplicativeCompensator(model, check="ignore")
    comps = [Prefiltered(inner, stable_filter(rng, 2, 2)), inner,
             Prefiltered(_lowpass(model, 200.0), stable_filter(rng, 1, 2))]
    plant = random_plant(rng, model, True)
    refs = [random_inputs(rng, 2, n) for n in (180, 120, 150)]
    for parallel in (False, True):
        for comp, yr, got in zip(comps, refs,
                                 sim.simulate_chain_batch(comps, plant, refs, parallel=parallel)):
            one = sim.simulate_chain(comp, plant, yr)
            np.testing.assert_array_equal(got.outputs, one.outputs)
            np.testing.assert_array_equal(got.compensator_state, one.compensator_state)


def test_batch_of_one_shared_prefilter_equals_single_runs():
    """Equal-size cases (stacked without padding) sharing one pre-filter (checked once)."""
    rng = np.random.default_rng(625)
    model = square_model(rng, 2)
    comp = Prefiltered(InverseMultiplicativeCompensator(model, iterations=3, check="ignore"),
                       stable_filter(rng, 3, 2))
    plant = random_plant(rng, model, True)
    refs = [random_inputs(rng, 2, n) for n in (140, 60, 100, 80)]
    for got, yr in zip(sim.simulate_chain_batch(comp, plant, refs), refs):
        one = sim.simulate_chain(comp, plant, yr)
        np.testing.assert_array_equal(got.inputs, one.inputs)
        np.testing.assert_array_equal(got.outputs, one.outputs)
        np.testing.assert_array_equal(got.compensator_state, one.compensator_state)


def test_shared_prefilter_of_the_wrong_shape_is_named_in_a_batch():
    rng = np.random.default_rng(635)
    model = square_model(rng, 2)
    f = stable_filter(rng, 2, 2)
    bad = Prefiltered(InverseMultiplicativeCompensator(model, check="ignore"),
                      f._replace(C=np.zeros((3, 2))))
    with pytest.raises(HysteresisError, match=r"prefilter\.C: expected shape \(2, 2\)"):
        sim.simulate_chain_batch(bad, random_plant(rng, model, False),
                                 [random_inputs(rng, 2, 10)] * 3)


def test_prefilter_of_the_wrong_shape_is_named():
    rng = np.random.default_rng(630)
    model = square_model(rng, 2)
    f = stable_filter(rng, 2, 2)
    bad = Prefiltered(InverseMultiplicativeCompensator(model, check="ignore"),
                      f._replace(B=np.zeros((2, 3))))
    with pytest.raises(HysteresisError, match=r"prefilter\.B: expected shape \(2, 2\)"):
        sim.simulate_chain(bad, random_plant(rng, model, False), random_inputs(rng, 2, 10))


def test_compensators_without_a_law_run_their_own_simulate():
    plant = load_plant("rakotondrabe-2dof")
    static = StaticGainCompensator(plant.hysteresis)
    assert static.packed_law() is None and not sim.is_fusable(static)
    t = np.arange(200) * T
    yr = np.vstack([5 * np.sin(2 * np.pi * 50 * t), np.zeros_like(t)])
    res = sim.simulate_chain(static, plant, yr)
    np.testing.assert_allclose(res.inputs, np.linalg.solve(static.K, yr), rtol=1e-12, atol=1e-12)
    with pytest.raises(CompensatorError, match="packed_law"):
        sim.simulate_chain_batch(static, plant, [yr])


# -- the batch kernel: ragged records, thread balance ------------------------------------
def _sweep_like(rng, n_cases):
    model = square_model(rng, 2)
    comps = [InverseMultiplicativeCompensator(model, check="ignore"),
             InverseMultiplicativeCompensator(model, iterations=2, check="ignore")]
    plant = random_plant(rng, model, True)
    lengths = rng.integers(5, 400, n_cases)
    refs = [random_inputs(rng, 2, int(n)) for n in lengths]
    return [comps[b % 2] for b in range(n_cases)], plant, refs


def test_batch_records_are_ragged_not_padded():
    rng = np.random.default_rng(700)
    comps, plant, refs = _sweep_like(rng, 12)
    refs[3] = random_inputs(rng, 2, 3000)          # one long case
    results = sim.simulate_chain_batch(comps, plant, refs, parallel=False)
    total = sum(r.shape[1] for r in refs)
    for yr, got in zip(refs, results):
        assert got.inputs.shape == yr.shape and got.outputs.shape == yr.shape
        assert got.inputs.flags.c_contiguous and got.outputs.flags.c_contiguous
        # the inputs of every case are views of one buffer of exactly sum(m n_b) values
        assert got.inputs.base is results[0].inputs.base
        assert got.inputs.base.size == 2 * total


@pytest.mark.parametrize("n_threads", [1, 2])
def test_batch_is_the_same_on_one_or_two_threads(n_threads):
    import numba
    if numba.config.NUMBA_NUM_THREADS < n_threads:
        pytest.skip("numba has fewer threads")
    rng = np.random.default_rng(710)
    comps, plant, refs = _sweep_like(rng, 9)
    serial = sim.simulate_chain_batch(comps, plant, refs, parallel=False)
    previous = numba.get_num_threads()
    numba.set_num_threads(n_threads)
    try:
        threaded = sim.simulate_chain_batch(comps, plant, refs, parallel=True)
    finally:
        numba.set_num_threads(previous)
    assert numba.get_num_threads() == previous          # the batch restores the setting
    for a, b in zip(serial, threaded):
        np.testing.assert_array_equal(a.outputs, b.outputs)
        np.testing.assert_array_equal(a.compensator_state, b.compensator_state)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("n_threads", [2, 3, 4])
def test_balanced_order_gives_each_thread_equal_work(seed, n_threads):
    from hammerstein.simulation._stepping import _balanced_order
    rng = np.random.default_rng(seed)
    lengths = rng.integers(1, 10_000, int(rng.integers(n_threads, 300)))
    order = _balanced_order(lengths, n_threads)
    assert sorted(order.tolist()) == list(range(lengths.size))     # a permutation
    # numba's prange: n_threads contiguous chunks of n // n_threads or one more
    work = [lengths[c].sum() for c in np.array_split(order, n_threads)]
    # greedy longest-first: no thread exceeds another by more than the longest case
    assert max(work) - min(work) <= lengths.max()
    assert max(work) <= lengths.sum() / n_threads + lengths.max()


# -- compile notices ---------------------------------------------------------------------
def test_compile_notice_is_one_line_per_top_level_kernel_compilation():
    from numba.core import event

    from hammerstein.simulation import _compile
    from hammerstein.simulation import _kernels as kernels
    messages = []

    def compile_event(dispatcher):
        return event.trigger_event("numba:compile", data={"dispatcher": dispatcher})

    with sim.compile_notices(messages.append):
        with compile_event(kernels.chain_kernel):
            with compile_event(kernels.plant_kernel):        # nested: part of the same wait
                pass
        with compile_event(kernels.play_kernel):             # estimated < MIN_NOTICE_SECONDS
            pass
        with compile_event(kernels.chain_batch):
            pass
    with compile_event(kernels.chain_kernel):                # outside the block: silent
        pass
    assert len(messages) == 2
    assert messages[0].startswith("compiling the simulation kernels once, about ")
    assert messages[1].startswith("compiling one more simulation kernel once, about ")
    assert all("\n" not in m for m in messages)
    assert _compile.COMPILE_SECONDS["play_kernel"] < _compile.MIN_NOTICE_SECONDS


def test_loading_a_compiled_kernel_announces_nothing():
    messages = []
    model = random_model(np.random.default_rng(0))
    sim.simulate_hysteresis(model, np.zeros((model.n_inputs, 5)))       # compiled or loaded
    with sim.compile_notices(messages.append):
        sim.simulate_hysteresis(model, np.zeros((model.n_inputs, 5)))
    assert messages == []


def test_announce_compiles_keeps_one_listener():
    from numba.core import event
    sim.announce_compiles(None)                 # e.g. left on by an in-process CLI run
    before = len(event._registered["numba:compile"])
    sim.announce_compiles(print)
    sim.announce_compiles(print)
    assert len(event._registered["numba:compile"]) == before + 1
    sim.announce_compiles(None)
    assert len(event._registered["numba:compile"]) == before


@pytest.mark.parametrize("parallel", [False, True])
def test_batch_with_initial_states_continues_each_case(parallel):
    """Per-case compensator states (play, v_f and pre-filter states): chunked == whole.

    Each case's first part runs alone; the batch continues every case from its
    final state, so its voltages and final states are those of the whole run,
    and all its results those of the continuation run alone (plant at rest)."""
    rng = np.random.default_rng(640)
    model = square_model(rng, 2)
    inner = InverseMultiplicativeCompensator(model, iterations=2, check="ignore")
    comps = [Prefiltered(inner, stable_filter(rng, 3, 2)), inner,
             Prefiltered(_lowpass(model, 250.0), stable_filter(rng, 1, 2)), _lowpass(model, 400.0)]
    plant = random_plant(rng, model, True)
    refs = [random_inputs(rng, 2, n) * 2 for n in (220, 160, 190, 130)]
    cut = [70, 40, 100, 65]
    whole = [sim.simulate_chain(c, plant, yr) for c, yr in zip(comps, refs)]
    first = [sim.simulate_chain(c, plant, yr[:, :k]) for c, yr, k in zip(comps, refs, cut)]
    states = [f.compensator_state for f in first]
    assert all(np.any(s != 0) for s in states)
    # a CompensatorLaw is accepted in place of its compensator
    batch_comps = [comps[0].packed_law()] + comps[1:]
    got = sim.simulate_chain_batch(batch_comps, plant, [yr[:, k:] for yr, k in zip(refs, cut)],
                                   parallel=parallel, compensator_states=states)
    for b, (c, yr, k) in enumerate(zip(comps, refs, cut)):
        assert not whole[b].diverged and not got[b].diverged
        # chunked == whole (to rounding: the first sample after the cut evaluates Gamma anew)
        np.testing.assert_allclose(got[b].inputs, whole[b].inputs[:, k:], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got[b].compensator_state, whole[b].compensator_state,
                                   rtol=1e-12, atol=1e-12)
        # and the continuation run alone from the same state, bit for bit
        alone = sim.simulate_chain(c, plant, yr[:, k:], states[b])
        np.testing.assert_array_equal(got[b].inputs, alone.inputs)
        np.testing.assert_array_equal(got[b].outputs, alone.outputs)
        np.testing.assert_array_equal(got[b].compensator_state, alone.compensator_state)


def test_batch_initial_state_of_the_wrong_length_is_named():
    rng = np.random.default_rng(650)
    model = square_model(rng, 2)
    comp = InverseMultiplicativeCompensator(model, check="ignore")
    plant = random_plant(rng, model, False)
    with pytest.raises(HysteresisError, match=r"compensator_states\[1\]"):
        sim.simulate_chain_batch(comp, plant, [np.zeros((2, 5))] * 2,
                                 compensator_states=[None, np.zeros(3)])
    with pytest.raises(HysteresisError, match="compensator_states: expected 2"):
        sim.simulate_chain_batch(comp, plant, [np.zeros((2, 5))] * 2, compensator_states=[None])


def test_compile_estimate_counts_the_chain_kernel_specialisation(monkeypatch):
    # the chain kernel with a pre-filter plan and a closed-form table compiles longer than
    # the default run's; the batch adds the chain kernel when that specialisation is
    # neither compiled nor cached, and the planner with a pre-filter
    import numba

    from hammerstein.simulation import _compile
    from hammerstein.simulation._prefetch import chain_kernel_arguments
    base, extra = _compile.COMPILE_SECONDS, _compile.COMPILE_EXTRA_SECONDS
    default = tuple(numba.typeof(a) for a in chain_kernel_arguments("default"))
    hamm = tuple(numba.typeof(a) for a in chain_kernel_arguments("hammerstein"))
    assert _compile.compile_estimate("chain_kernel", default) == base["chain_kernel"]
    assert _compile.compile_estimate("chain_kernel", hamm) == pytest.approx(
        base["chain_kernel"] + extra["prefilter"] + extra["closed_form"])
    batch = (None,) * 5 + (hamm[4], hamm[5])            # chain_batch's prefilter and slopes
    monkeypatch.setattr(_compile, "_chain_variant_ready", lambda prefiltered, closed: False)
    cold = _compile.compile_estimate("chain_batch", batch)
    monkeypatch.setattr(_compile, "_chain_variant_ready", lambda prefiltered, closed: True)
    warm = _compile.compile_estimate("chain_batch", batch)
    assert cold - warm == pytest.approx(base["chain_kernel"] + extra["prefilter"]
                                        + extra["closed_form"])
    assert warm == pytest.approx(base["chain_batch"] + extra["planner"])
    assert _compile.compile_estimate("plant_kernel", default) == base["plant_kernel"]
