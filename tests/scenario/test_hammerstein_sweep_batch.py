"""Hammerstein sweep cases in the batch kernel equal the one-by-one run (``run_case``)."""

import numpy as np
import pytest

from hammerstein.compensation.hammerstein_compensator import fade_in
from hammerstein.scenario import sweeps
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.resolve import load_scenario
from hammerstein.scenario.sweeps import _batchable, run_cases

SCENARIO = """
name = "hb"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[compensator]
kind = "hammerstein"
[[sweeps]]
name = "s"
frequencies = [20.0, 75.0, 150.0, 300.0]
reference = { kind = "sine", output = ["x", "y"], amplitude = 20.0, periods = 4 }
settle_periods = 2
[sweeps.compensators]
zpetc = { kind = "hammerstein", inversion = "zpetc" }
stable = { kind = "hammerstein", inversion = "stable" }
zpetc-lowpass = { kind = "hammerstein", feedback = "lowpass", cutoff_hz = 3000.0, iterations = 1 }
rate-independent = { kind = "multivariable" }
[[sweeps]]
name = "c"
frequencies = [50.0, 200.0]
reference = { kind = "circle", radius = 40.0, periods = 3 }
settle_periods = 2
compensator = { kind = "hammerstein", fade_in = 0.002 }
[[cases]]
name = "alone"
reference = { kind = "circle", radius = 10.0, frequency = 100.0, periods = 3 }
settle_periods = 2
"""


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("hb") / "hb.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    return load_scenario(path)


def test_hammerstein_sweep_cases_are_batched(scenario):
    batched = {c.name for c in scenario.cases if _batchable(c)}
    sweep_cases = {c.name for c in scenario.cases if c.sweep is not None}
    assert batched == sweep_cases and "alone" not in batched
    assert len([n for n in batched if "stable" in n]) == 8


def test_batch_equals_one_by_one(scenario, monkeypatch):
    calls = []
    real = sweeps.simulate_chain_batch

    def counting(*args, **kwargs):
        calls.append(len(args[2]))
        return real(*args, **kwargs)

    monkeypatch.setattr(sweeps, "simulate_chain_batch", counting)
    batch = run_cases(scenario.cases)
    # 4 labels x 2 axes x 4 frequencies + 2 circles, every one in a batch kernel call
    assert sum(calls) == 34
    for case, got in zip(scenario.cases, batch):
        ref = run_case(case)
        assert got.name == ref.name == case.name
        assert (got.divergence is None) == (ref.divergence is None)
        np.testing.assert_allclose(got.inputs, ref.inputs, rtol=1e-12, atol=1e-12 * np.nanmax(
            np.abs(ref.inputs)), err_msg=case.name)
        np.testing.assert_allclose(got.outputs, ref.outputs, rtol=1e-12, atol=1e-12 * np.nanmax(
            np.abs(ref.outputs)), err_msg=case.name)
        assert got.warnings == ref.warnings, case.name
        a = {(r["channel"], r["metric"]): r["value"] for r in got.metrics}
        b = {(r["channel"], r["metric"]): r["value"] for r in ref.metrics}
        assert a.keys() == b.keys(), case.name
        for k in b:
            assert a[k] == pytest.approx(b[k], rel=1e-10, abs=1e-12), (case.name, k)


def test_batched_hammerstein_tracks_the_reference(scenario):
    """Independent of the one-by-one path: the ZPETC and stable inversions on the true models
    follow a 20 µm sine to within 2 % RMS at 150 Hz (the law's residual lag)."""
    cases = [c for c in scenario.cases if c.name in ("s-zpetc-x-150Hz", "s-stable-x-150Hz")]
    for res in run_cases(cases):
        rms = {r["channel"]: r["value"] for r in res.metrics if r["metric"] == "rms_error"}
        assert rms["x"] < 0.02 * 20.0, (res.name, rms)


def test_preisach_plant_and_exact_static_part_equal_one_by_one(tmp_path):
    """Off the fused path: a Preisach plant (the batch runs each case's law unfused) and a
    Preisach model (exact static inverse, no fused law: the case runs alone)."""
    from pathlib import Path

    from hammerstein.io.presets import load_plant, save_model

    save_model(load_plant("rakotondrabe-2dof").hysteresis, tmp_path / "pi.toml")
    src = Path(__file__).resolve().parents[2] / "scenarios" / "presets" / "realistic-b-nocreep.toml"
    text = src.read_text(encoding="utf-8")   # its generalised-PI cross-coupling as a gain
    gpi = text.index("[model.components.x.uy]")
    text = text[:gpi] + "[model.components.x.uy]\nkind = \"polynomial\"\ncoefficients = [0.2]\n\n" + \
        text[text.index("[model.components.y.ux]"):]
    (tmp_path / "plant.toml").write_text(text, encoding="utf-8")
    path = tmp_path / "pb.toml"
    path.write_text(f"""
name = "pb"
[plant]
preset = "plant.toml"
[compensator]
kind = "hammerstein"
[[sweeps]]
name = "s"
frequencies = [40.0, 160.0]
reference = {{ kind = "sine", output = "x", amplitude = 10.0, periods = 3 }}
settle_periods = 2
[sweeps.compensators]
pi = {{ kind = "hammerstein", model = "pi.toml", check = "ignore" }}
exact = {{ kind = "hammerstein", model = "plant" }}
""", encoding="utf-8")
    cases = load_scenario(path).cases
    assert all(_batchable(c) for c in cases)
    exact = [c for c in cases if "exact" in c.name]
    assert len(exact) == 2 and all(c.compensator.fused_run(c.signal) is None for c in exact)
    for case, got in zip(cases, run_cases(cases)):
        ref = run_case(case)
        np.testing.assert_allclose(got.inputs, ref.inputs, rtol=1e-12, atol=1e-12, err_msg=case.name)
        np.testing.assert_allclose(got.outputs, ref.outputs, rtol=1e-12, atol=1e-12,
                                   err_msg=case.name)
        assert got.warnings == ref.warnings and len(got.metrics) == len(ref.metrics)


def _general_start(comp, reference, period_samples, fade):
    """The start-up written with the inverse's public calls (initial_state, then filter)."""
    from hammerstein.compensation.hammerstein_compensator import continuation, fade_in
    faded = fade_in(reference, fade)
    P = comp.preview_samples
    ext = np.concatenate([faded, continuation(faded, P, period_samples)], axis=1)
    s0 = comp.inverse.initial_state(ext[:, 0])
    if P:
        _, s0 = comp.inverse.filter(ext[:, :P], s0)
    state = comp.initial_state()
    state[comp.hysteresis_compensator.n_states:] = s0
    return ext[:, P:], state


@pytest.mark.parametrize("fade", [0, 1, 37])
def test_start_up_equals_the_general_filter_path_bit_for_bit(scenario, fade):
    """The start-up's fast path (from rest) gives the states of filter() exactly.

    With fade 0 the first sample is away from rest, so the general path runs
    (the same answer by construction); with a fade the first sample is 0 and
    the fast path runs.
    """
    rng = np.random.default_rng(7)
    case = next(c for c in scenario.cases if c.name.startswith("s-zpetc-x"))
    comp = case.compensator
    for period in (None, 50):
        ref = np.cumsum(rng.normal(size=(2, 200)), axis=1) + 1.0
        lead, state, faded = comp.start(ref, period, fade)
        lead0, state0 = _general_start(comp, ref, period, fade)
        assert np.array_equal(lead, lead0)
        assert np.array_equal(faded, fade_in(ref, fade))
        assert np.array_equal(state, state0)
        assert state[comp.hysteresis_compensator.n_states:].any()   # the preview moved it


def test_batched_reference_checks_warn_per_case_as_one_by_one(tmp_path):
    """The range check runs once per batch; the cases beyond the range still warn one by one.

    The bundled model was identified up to 58.4 µm on x and 50.6 µm on y
    (``check_reference_range``): a 55 µm sine is within the range on x, beyond it
    on y, so a batch of both axes holds cases with and without the warning.
    """
    path = tmp_path / "rw.toml"
    path.write_text("""
name = "rw"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[[sweeps]]
name = "s"
frequencies = [20.0, 60.0]
reference = { kind = "sine", output = ["x", "y"], amplitude = 55.0, periods = 3 }
settle_periods = 2
[sweeps.compensators]
h = { kind = "hammerstein" }
m = { kind = "multivariable" }
""", encoding="utf-8")
    cases = load_scenario(path).cases
    got = run_cases(cases)
    beyond = set()
    for case, res in zip(cases, got):
        ref = run_case(case)
        assert res.warnings == ref.warnings, case.name
        if any("beyond the range" in w for w in res.warnings):
            beyond.add(case.name)
    assert beyond == {c.name for c in cases if "-y-" in c.name}


@pytest.mark.parametrize("scale, offset, periodic", [
    (1.0, 0.0, True),          # exactly periodic
    (1.0, 5e-9, False),        # beyond atol = 1e-9 (max |r| <= 1)
    (100.0, 5e-9, True),       # within atol = 1e-9 * max |r| = 1e-7
    (100.0, 5e-7, False),
])
def test_continuation_periodic_tolerance(scale, offset, periodic):
    """The continuation repeats the record one period earlier when its last 8 samples
    repeat those one period earlier to ``1e-9 max(max |r|, 1)``, else extrapolates."""
    from hammerstein.compensation.hammerstein_compensator import continuation
    period = 10
    k = np.arange(35)
    r = scale * np.sin(2 * np.pi * k / period)[np.newaxis] * 0.9
    r[0, -8:] += offset
    got = continuation(r, 3, period)
    if periodic:
        np.testing.assert_array_equal(got, r[:, 35 - period:35 - period + 3])
    else:
        a, b, c = r[0, -3], r[0, -2], r[0, -1]      # quadratic through the last three
        kk = np.arange(1, 4)
        np.testing.assert_allclose(got[0], c + (c - b) * kk + (c - 2 * b + a) / 2 * kk * (kk + 1))


@pytest.mark.parametrize("scale, offset, periodic", [
    (1.0, 0.0, True), (1.0, 5e-9, False), (100.0, 5e-9, True), (100.0, 5e-7, False)])
def test_continuations_of_many_records_follow_the_same_rule(scale, offset, periodic):
    """``continuations`` on records side by side: each one repeated one period earlier
    (to the same tolerance as one record) or extrapolated by the quadratic through its
    last three samples; short records hold their last sample; 0 samples is empty."""
    from hammerstein.compensation.hammerstein_compensator import continuations
    period = 10
    k = np.arange(35)
    r = scale * np.sin(2 * np.pi * k / period)[np.newaxis] * 0.9
    r[0, -8:] += offset
    poly = np.vstack([0.5 * k ** 2 - 3.0 * k + 1.0, -2.0 * k + 4.0])[:, :23]   # degree 2 and 1
    records = [np.vstack([r, -r]), poly, np.array([[1.0, 2.0], [3.0, -4.0]]), np.vstack([r, r])[:, :20]]
    got = continuations(records, 3, [period, None, 5, period])
    if periodic:
        np.testing.assert_array_equal(got[0], np.vstack([r, -r])[:, 25:28])
    else:
        a, b, c = r[0, -3], r[0, -2], r[0, -1]
        q = np.arange(1, 4)
        np.testing.assert_array_equal(got[0][0], c + (c - b) * q + (c - 2 * b + a) / 2 * (q * (q + 1)))
        np.testing.assert_array_equal(got[0][1], -got[0][0])
    # a polynomial of degree <= 2 is extrapolated exactly (not periodic)
    kp = np.arange(23, 26)
    np.testing.assert_allclose(got[1], np.vstack([0.5 * kp ** 2 - 3.0 * kp + 1.0, -2.0 * kp + 4.0]),
                               rtol=1e-14, atol=1e-12)
    np.testing.assert_array_equal(got[2], [[2.0] * 3, [-4.0] * 3])     # 2 samples: held
    # 20 samples < period + 8: not tested for periodicity, a quadratic
    assert got[3].shape == (2, 3)
    assert [g.shape for g in continuations(records, 0, [period] * 4)] == [(2, 0)] * 3 + [(2, 0)]


def test_fused_runs_equal_the_start_up_of_each_record_bit_for_bit(scenario):
    """The start-up of several records at once (``fused_runs``: fade weights, continuation
    and ZPETC preview of all records together) gives each record the lead reference and
    state of the start-up written with the inverse's public calls, bit for bit: records
    of different lengths, fades (0: the first sample away from rest, the general path)
    and periods, beside each other in one call."""
    rng = np.random.default_rng(11)
    case = next(c for c in scenario.cases if c.name.startswith("s-zpetc-x"))
    comp = case.compensator
    refs, periods, fades = [], [], []
    for n, period, fade in ((200, None, 37), (333, 50, 50), (90, 30, 0), (500, None, 1),
                            (64, 16, 64), (400, 100, 120), (1, None, 0), (2, None, 2)):
        t = np.arange(n)
        ref = np.vstack([10 * np.sin(2 * np.pi * t / (period or 77)),
                         np.cumsum(rng.normal(size=n))]) + (0.0 if fade else 1.0)
        refs.append(ref)
        periods.append(period)
        fades.append(fade)
    # periodic to 1e-9 of its peak only (5e-9 apart, peak 90): repeated, not extrapolated
    t = np.arange(350)
    ref = 90 * np.vstack([np.sin(2 * np.pi * t / 50), np.cos(2 * np.pi * t / 50)])
    ref[:, -8:] += 5e-9
    refs.append(ref)
    periods.append(50)
    fades.append(40)
    assert comp.preview_samples > 1                  # the records of 1 and 2 samples are shorter
    got = comp.fused_runs(refs, periods, fades)
    assert len(got) == len(refs)
    for (law, lead, state), ref, period, fade in zip(got, refs, periods, fades):
        lead0, state0 = _general_start(comp, ref, period, fade)
        assert np.array_equal(lead, lead0) and np.array_equal(state, state0)
        assert law.prefilter is not None and law.n_states == state.size
        one = comp.fused_run(ref, period, fade)
        assert np.array_equal(one[1], lead) and np.array_equal(one[2], state)
    with pytest.raises(ValueError, match="one of each per record"):
        comp.fused_runs(refs, periods[:-1], fades)
    stable = next(c for c in scenario.cases if c.name.startswith("s-stable-x")).compensator
    for (law, v, state), ref in zip(stable.fused_runs(refs[:2], periods[:2], fades[:2]), refs):
        one = stable.fused_run(ref, periods[0] if ref is refs[0] else periods[1],
                               fades[0] if ref is refs[0] else fades[1])
        assert np.array_equal(v, one[1]) and np.array_equal(state, one[2])


def test_a_warning_of_the_joint_start_up_reprepares_the_cases_one_by_one(scenario, monkeypatch):
    """Warnings cannot be told apart in a joint start-up: when ``fused_runs`` warns, the
    group's cases are prepared again one by one, so each keeps its own warnings."""
    import warnings

    from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
    real = HammersteinCompensator.fused_runs
    calls = []

    def warning(self, *args):
        calls.append(len(args[0]))
        warnings.warn("from the joint start-up", RuntimeWarning)
        return real(self, *args)

    monkeypatch.setattr(HammersteinCompensator, "fused_runs", warning)
    cases = [c for c in scenario.cases if c.name.startswith("s-zpetc-") and "lowpass" not in c.name]
    got = run_cases(cases)
    assert calls == [len(cases)]
    for case, res in zip(cases, got):
        ref = run_case(case)
        assert res.warnings == ref.warnings and not any("joint" in w for w in res.warnings)
        np.testing.assert_array_equal(res.outputs, ref.outputs)



def test_the_plants_own_dynamics_are_inverted_as_python_control_would(tmp_path):
    # dynamics = "plant" hands the preset's SampledSystem to the ZPETC design (no
    # python-control); the same compensator built on the plant's control.StateSpace must
    # run every sample of the case to the same bits
    from hammerstein.models.dynamics import SampledSystem
    from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
    from hammerstein.scenario.execute import fade_samples

    path = tmp_path / "own.toml"
    path.write_text("""
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "hammerstein"
dynamics = "plant"
[[sweeps]]
name = "s"
frequencies = [40.0, 250.0]
reference = { kind = "sine", output = "x", amplitude = 20.0, periods = 3 }
settle_periods = 1
""", encoding="utf-8")
    cases = load_scenario(path).cases
    comp = cases[0].compensator
    assert isinstance(comp.dynamics, SampledSystem)
    other = HammersteinCompensator(comp.model, cases[0].plant.dynamics)
    assert not isinstance(other.dynamics, SampledSystem)
    for case, res in zip(cases, run_cases(cases)):
        ref = other.run_reference(case.plant, case.signal, case.period_samples, fade_samples(case))
        assert res.divergence is None
        assert np.array_equal(res.inputs, ref.inputs)
        assert np.array_equal(res.outputs, ref.outputs)
