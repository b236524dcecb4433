"""Creep identified from staircases (identification/creep_identification.py).

Expectations are derived independently of the fit: the true creep's closed-form
step response ``s(t) = d + sum_k w_k (1 - exp(-t / tau_k))`` (lags on another
grid than the identifier's, and a log law), the normalisation's closed form at
the hysteresis frequency, and the minimum-phase bound of the discrete creep.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.models.creep import Creep, creep_from_table
from hammerstein.identification.creep_identification import (CreepIdentifier, hysteresis_frequency,
                                                   remove_creep, staircase_steps)
from hammerstein.io.datafiles import MultiRecord
from hammerstein.signals.excitation import decreasing_sine, excitation_set
from hammerstein.models.plant import HammersteinPlant
from hammerstein.identification.preisach_identification import identify_preisach_records
from hammerstein.io.presets import load_plant
from hammerstein.exceptions import IdentificationError

T = 1e-3           # creep is slow: 1 kHz is enough and keeps the tests fast
NOISE_UM = 0.04
TIMES = np.array([0.1, 0.3, 1.0, 3.0, 10.0])


def _drift(creep, t=TIMES):
    s = creep.step_response(t)
    return (s - s[0]) / s[0]


@pytest.fixture(scope="module")
def hysteresis():
    return load_plant("realistic-2dof").hysteresis   # Preisach, asymmetric, not a PI


def _records(hysteresis, creeps, seed=3, noise=NOISE_UM, hold=2.0):
    plant = HammersteinPlant(hysteresis, T, None, creep=creeps)
    rng = np.random.default_rng(seed)
    out = []
    for r in excitation_set(["ux", "uy"], 10.0, T, multisine_periods=1, hold=hold):
        if r.kind == "creep":
            y, _ = plant.simulate(r.u)
            out.append(SimpleNamespace(u=r.u, y=y + noise * rng.standard_normal(y.shape),
                                       sampling_period=T, source=r.name))
    return out


@pytest.mark.parametrize("true", [
    Creep([0.05, 0.5, 5.0], [0.01, 0.01, 0.01]),               # another grid than 0.01-100 s
    Creep.log_law(0.015, 0.01, 100.0, per_decade=3),             # log law, 3 lags per decade
], ids=["lags-other-grid", "log-law"])
def test_known_creep_is_recovered_through_a_hysteretic_plant_with_noise(hysteresis, true):
    ident = CreepIdentifier().fit(hysteresis, _records(hysteresis, [true, true]))
    want = _drift(true)
    for l in range(2):
        got = _drift(ident.creeps_[l])
        # drift after a step, 0.1 s to 10 s: within 10 % of the true drift at 10 s
        assert np.max(np.abs(got - want)) <= 0.10 * want[-1], (l, got, want)
        assert np.all(ident.weights_[l] >= 0)
        # the residual is the sensor noise: creep explains the rest
        assert ident.residual_rms_[l] < 1.1 * NOISE_UM < ident.residual_rms_no_creep_[l]


def test_normalised_to_unit_gain_at_the_hysteresis_frequency(hysteresis):
    true = Creep([0.05, 0.5], [0.02, 0.01])
    ident = CreepIdentifier([0.03, 0.3, 3.0], hysteresis_frequency_hz=2.0).fit(
        hysteresis, _records(hysteresis, [true, None]))
    w = 2 * np.pi * 2.0
    for c in ident.creeps_:
        # real part of d + sum_k w_k / (1 + j w tau_k) at f_h
        re = c.instantaneous + np.sum(c.weights / (1 + (w * c.time_constants) ** 2))
        assert re == pytest.approx(1.0, abs=1e-12)
    # the output without creep gets (almost) none
    assert ident.weights_[1].sum() < 0.1 * ident.weights_[0].sum()


@pytest.fixture(scope="module")
def one_lag(hysteresis):
    return CreepIdentifier().fit(hysteresis, _records(hysteresis, [Creep([0.3], [0.03])] * 2))


def test_minimum_phase_bound_of_the_discrete_creep(one_lag):
    """Zeros of the ZOH creep d + sum w_k (1 - a_k) / (z - a_k) lie inside the unit circle."""
    ident = one_lag
    for c in ident.creeps_:
        A, B, C, D = c.discrete(T)
        zeros = np.linalg.eigvals(A - B @ C / D[0, 0])        # zeros of a SISO state space
        assert np.all(np.abs(zeros) < 1)


def test_preset_table_round_trip(one_lag):
    ident = one_lag
    for c in ident.creeps_:
        back = creep_from_table(c.to_table())
        np.testing.assert_array_equal(back.time_constants, c.time_constants)
        np.testing.assert_array_equal(back.weights, c.weights)
        assert back.instantaneous == c.instantaneous < 1
        np.testing.assert_allclose(back.step_response(TIMES), c.step_response(TIMES), rtol=0)


def test_summary_and_report_carry_the_fit(one_lag):
    ident = one_lag
    s = ident.summary()
    assert s["time_constants_s"][0] == pytest.approx(0.01) and s["identifiable_up_to_s"] == 2.0
    assert set(s["outputs"]) == {"x", "y"}
    assert s["outputs"]["x"]["drift_0p1_to_10s_percent"] == pytest.approx(100 * ident.drift_[0])
    text = "\n".join(ident.report_lines())
    assert "drift" in text and "residual RMS" in text and "extrapolated" in text


def test_staircase_steps_and_hysteresis_frequency():
    u = np.array([[0.0, 0.0, 1.0, 1.0, -1.0], [0.0, 0.0, 0.0, 2.0, 2.0]])
    assert staircase_steps(u).tolist() == [0, 0, 1, 2, 3]
    _, s, _ = decreasing_sine(1e-3, 10.0, frequency=2.0)
    rec = SimpleNamespace(u=s[None, :], sampling_period=1e-3)
    assert hysteresis_frequency([rec]) == pytest.approx(2.0, rel=0.05)


def test_records_that_are_not_staircases_are_refused(hysteresis):
    t = np.arange(2000) * T
    u = np.vstack([np.sin(2 * np.pi * t), np.zeros_like(t)])
    rec = SimpleNamespace(u=u, y=hysteresis.simulate(u)[0], sampling_period=T, source="sine.csv")
    with pytest.raises(IdentificationError, match="sine.csv: expected a voltage staircase"):
        CreepIdentifier().fit(hysteresis, [rec])
    with pytest.raises(IdentificationError, match="time_constants"):
        CreepIdentifier([0.1, -1.0])


def test_a_staircase_behind_an_oscillation_is_refused_before_any_allocation(hysteresis,
                                                                             monkeypatch):
    """A staircase whose record starts with an oscillation (a "step" at every sample) used to
    allocate one regressor column per sample with G: 413 GiB for an 18 s record at 20 kHz.
    Beyond the buffer bound it is refused and the message says why; a slew-limited staircase
    (ramps of a few samples between the steps) is still fitted."""
    import hammerstein.identification.creep_identification as ci
    import control
    G = control.sample_system(control.ss(-2000.0 * np.eye(2), 2000.0 * np.eye(2), np.eye(2),
                                         0 * np.eye(2)), T)             # a 318 Hz low-pass
    t = np.arange(3000) * T
    osc = np.vstack([np.sin(2 * np.pi * 5 * t) * (1 - t / t[-1]), np.zeros_like(t)])
    stairs = np.repeat(np.array([[0.0, 5.0, 10.0, 5.0, 0.0], [0.0] * 5]), 600, axis=1)
    u = np.hstack([osc, stairs])
    rec = SimpleNamespace(u=u, y=hysteresis.simulate(u)[0], sampling_period=T, source="c.csv")
    assert int(staircase_steps(u)[-1]) + 1 > 2000          # the oscillation's samples
    monkeypatch.setattr(ci, "_MAX_BUFFER_BYTES", 2 ** 24)  # 16 MiB: this record needs 0.54 GiB
    with pytest.raises(IdentificationError, match=r"c.csv: expected a voltage staircase .*"
                                                  r"shorter \(a ramp or an oscillation.*GiB"):
        CreepIdentifier().fit(hysteresis, [rec], G)
    ramps = np.repeat(np.array([[0.0, 5.0, 10.0, 5.0, 0.0], [0.0] * 5]), 600, axis=1)
    for k in (600, 1200, 1800, 2400):                       # 5-sample ramps between the steps
        ramps[0, k - 5:k] = np.linspace(ramps[0, k - 6], ramps[0, k], 7)[1:-1]
    ok = SimpleNamespace(u=ramps, y=hysteresis.simulate(ramps)[0], sampling_period=T,
                         source="s.csv")
    assert CreepIdentifier().fit(hysteresis, [ok], G).creeps_


@pytest.mark.parametrize("creep, offset", [
    (Creep([0.01, 0.1, 1.0], [0.01, 0.02, 0.03], instantaneous=0.96), 0.0),
    (Creep.log_law(0.015, 0.01, 100.0), -3.5),            # the realistic-2dof creep, offset
], ids=["lags", "log-law-offset"])
def test_remove_creep_inverts_the_creep_exactly(creep, offset):
    """Round trip: a record through (I + C) after an offset, removed again, is the record."""
    rng = np.random.default_rng(5)
    v = np.cumsum(rng.standard_normal((2, 3000)), axis=1) + offset
    y = np.vstack([creep.simulate(v[0] - offset, T)[0] + offset, v[1]])
    rec = MultiRecord(np.arange(3000) * T, np.zeros((1, 3000)), y, ("u",), ("x", "y"), T, "r")
    back = remove_creep([rec], [creep, None], [offset, 0.0])[0]
    np.testing.assert_allclose(back.y, v, rtol=0, atol=1e-9 * np.max(np.abs(v)))
    assert back.source == "r" and back.u is rec.u


def test_remove_creep_refuses_a_creep_that_is_not_minimum_phase():
    bad = Creep([0.01], [1.0], instantaneous=0.01)   # d below w (1 - a) / (1 + a) at T = 1 ms
    rec = SimpleNamespace(y=np.zeros((1, 10)), sampling_period=T)
    with pytest.raises(IdentificationError, match="output 0 is not minimum phase"):
        remove_creep([rec], [bad])
    with pytest.raises(IdentificationError, match="expected 1 entries"):
        remove_creep([rec], [bad, bad])


def _chain_error(model, creeps, plant):
    """Largest |plant - model (then identified creep)| [µm] over 1 Hz sines of 15-100 %."""
    t = np.arange(int(round(3.0 / REFIT_T))) * REFIT_T
    chain = HammersteinPlant(model, REFIT_T, None, creep=creeps)
    worst = 0.0
    for frac in (1.0, 0.6, 0.3, 0.15):
        for k in range(2):
            u = np.zeros((2, t.size))
            u[k] = frac * 10.0 * np.sin(2 * np.pi * t)
            worst = max(worst, float(np.max(np.abs(plant.simulate(u)[0] - chain.simulate(u)[0]))))
    return worst


REFIT_T = 2e-3       # the creep's fastest lag is 10 ms: 500 Hz keeps the three fits short


@pytest.mark.slow
def test_hysteresis_refitted_without_creep_is_as_good_as_without_creep(hysteresis):
    """The hysteresis records carry creep; the refit on v = (I + C)^-1 y removes its effect.

    Plant: realistic-2dof's Preisach hysteresis (not the Preisach grid of the
    fit) and its log creep, 40 nm noise. Reference: the same fit on records of
    the plant without creep, whose error (grid and noise) bounds what any
    creep handling can reach: the refit's error must be within 10 % + one
    noise sigma of it, and the fit on the raw records must not (the creep does
    matter here). 30-60 s CPU.
    """
    creeps = load_plant("realistic-2dof").creep
    rng = np.random.default_rng(11)
    recs = {True: {}, False: {}}
    noise = {}
    for r in excitation_set(["ux", "uy"], 10.0, REFIT_T, multisine_periods=1):
        if r.kind not in ("hysteresis", "creep"):
            continue
        noise[r.name] = NOISE_UM * rng.standard_normal((2, r.u.shape[1]))
        for with_creep in (True, False):
            plant = HammersteinPlant(hysteresis, REFIT_T, None, creep=creeps if with_creep else None)
            y = plant.simulate(r.u)[0] + noise[r.name]
            recs[with_creep].setdefault(r.kind, []).append(
                MultiRecord(r.time, r.u, y, ("ux", "uy"), ("x", "y"), REFIT_T, r.name))
    fit = lambda records: identify_preisach_records(records, 12, "auto")
    creep_of = lambda model, records: CreepIdentifier().fit(model, records).creeps_
    ref = _chain_error(fit(recs[False]["hysteresis"]).model, None,
                       HammersteinPlant(hysteresis, REFIT_T, None))
    plant = HammersteinPlant(hysteresis, REFIT_T, None, creep=creeps)
    first = fit(recs[True]["hysteresis"]).model
    first_creep = creep_of(first, recs[True]["creep"])
    clean = remove_creep(recs[True]["hysteresis"], first_creep, first.output_offset)
    refit = fit(clean).model
    refit_creep = creep_of(refit, recs[True]["creep"])
    bound = 1.1 * ref + NOISE_UM
    assert _chain_error(refit, refit_creep, plant) <= bound
    assert _chain_error(first, first_creep, plant) > bound


def test_a_slew_limited_staircase_through_g_joins_its_ramps(hysteresis, monkeypatch):
    """``excitation --slew-rate`` writes staircases whose steps ramp (one step per sample):
    with dynamics, one offset column per ramp sample asked 1.1 GiB for a 2000 V/s amplifier
    at 20 kHz, and ``identify --dynamics --creep-records`` refused the very files it was told
    to take. A ramp now joins the hold it leads to; the creep is recovered as from steps."""
    import hammerstein.identification.creep_identification as ci
    import control
    G = control.sample_system(control.ss(-2000.0 * np.eye(2), 2000.0 * np.eye(2), np.eye(2),
                                         0 * np.eye(2)), T)             # a 318 Hz low-pass
    true = Creep([0.05, 0.5, 5.0], [0.01, 0.01, 0.01])
    plant = HammersteinPlant(hysteresis, T, G, creep=[true, true])
    rng = np.random.default_rng(5)
    recs = []
    for r in excitation_set(["ux", "uy"], 10.0, T, multisine_periods=1, hold=2.0,
                            slew_rate=1000.0):                          # 1 V per sample
        if r.kind == "creep":
            y, _ = plant.simulate(r.u)
            recs.append(SimpleNamespace(u=r.u, y=y + NOISE_UM * rng.standard_normal(y.shape),
                                        sampling_period=T, source=r.name))
    raw = [int(staircase_steps(r.u)[-1]) + 1 for r in recs]
    joined = [ci.ramps_joined(staircase_steps(r.u), r.u, ci._MIN_STEP_SAMPLES)[1] for r in recs]
    assert all(j < 0.5 * n for j, n in zip(joined, raw))     # mostly ramp samples
    N = max(r.u.shape[1] for r in recs)

    def size(n_steps):
        return 8.0 * 2 * N * (1 + 2 * (9 + n_steps))
    # a bound between what the joined steps need and what one column per ramp sample asks
    monkeypatch.setattr(ci, "_MAX_BUFFER_BYTES", 0.5 * (size(max(joined)) + size(min(raw))))
    ident = CreepIdentifier().fit(hysteresis, recs, G)
    want = _drift(true)
    for l in range(2):
        got = _drift(ident.creeps_[l])
        assert np.max(np.abs(got - want)) <= 0.10 * want[-1], (l, got, want)
