"""Generalised-PI identification from records, its exact inverse, and the Hammerstein
compensator over its model (also on a plant outside its class).

Expectations come from the true actuators (their own loops simulated independently of the
fit), from closed forms (an even coupling is the same at +A and -A; a play under envelopes
followed by hand), from round trips (forward(inverse(y)) = y, file round trip) and from a
naive per-sample root search written here.
"""

import numpy as np
import pytest
import scipy.optimize

from hammerstein.io.datafiles import MultiRecord
from hammerstein.signals.excitation import LEVELS, decreasing_sine, hysteresis_excitation
from hammerstein.models.generalized_pi import GeneralizedPI, envelope
from hammerstein.identification.gpi_identification import (
    GeneralizedPIIdentifier, envelopes, monotone_quadratic_columns, play_thresholds,
    quadratic_coefficients)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.models.plant import HammersteinPlant
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.io.presets import load_model, load_plant, save_model
from hammerstein.exceptions import HysteresisError, IdentificationError

T = 1e-3          # quasi-static records: the hysteresis is rate independent
T_FIT = 2.5e-3    # the fits' records: 400 samples a period draw the same loops, see `fitted`
# Envelope trials per output: the fits below reach the same loops and circles (to 0.01 %) with
# 60 as with the default 300 that a 2 x 2 actuator with creep needs, in a fifth of the CPU.
BUDGET = 60
#: the excitation's levels before the 30 and 15 % ones: the records of the tests below that
#: check loops never recorded (30 and 15 %) hold these
LEVELS_100_TO_10 = (1.0, 0.8, 0.6, 0.4, 0.2, 0.1)


def records(hysteresis, noise=0.0, seed=0, amplitude=10.0, sampling_period=T, reversals=(),
            levels=LEVELS):
    """One decreasing-amplitude sine per input (others at 0; then the reversal curves at
    ``reversals``), outputs from ``hysteresis``."""
    rng = np.random.default_rng(seed)
    m = hysteresis.n_inputs
    out = []
    for k in range(m):
        t, one = hysteresis_excitation(sampling_period, amplitude, levels=levels,
                                        reversals=reversals)
        u = np.zeros((m, t.size))
        u[k] = one
        y, _ = hysteresis.simulate(u)
        y = y + noise * rng.standard_normal(y.shape)
        out.append(MultiRecord(t, u, y, tuple(hysteresis.input_names),
                               tuple(hysteresis.output_names), sampling_period, f"rec-{k}"))
    return out


def gpi_actuator(demagnetised=10.0):
    """Asymmetric saturating GPI direct paths (thresholds and envelopes the identifier does not
    use), a hysteretic GPI cross-coupling x <- uy and an even one y <- ux. Every record and
    every simulation starts after a demagnetising cycle from ``demagnetised`` V (the records'
    amplitude; 0: from the plays at rest), as a real actuator after ``demagnetise.csv``."""
    x = GeneralizedPI([0.0, 0.6, 1.7, 3.1, 5.2], [1.1, 0.35, 0.22, 0.15, 0.08],
                      gamma_l=[18.0, 0.065, 0.12, 0.0], gamma_r=[15.0, 0.075, -0.02, 0.6],
                      demagnetised=demagnetised)
    y = GeneralizedPI([0.0, 0.9, 2.2, 4.0], [0.9, 0.4, 0.2, 0.1],
                      gamma_l=[14.0, 0.08, -0.1, 0.3], gamma_r=[17.0, 0.06, 0.05, -0.2],
                      demagnetised=demagnetised)
    xy = GeneralizedPI([0.0, 1.5, 3.0], [0.15, 0.06, 0.04],
                       gamma_l=[12.0, 0.09, 0.1, 0.0], gamma_r=[11.0, 0.1, 0.0, 0.3],
                       demagnetised=demagnetised)
    return MultivariableHysteresis([[x, xy], [Polynomial([0.06, -0.03]), y]], ["ux", "uy"],
                                   ["x", "y"], [10.0, 10.0])


def preisach_actuator():
    """Asymmetric Preisach direct paths and an even cross-coupling: outside the GPI class."""
    e = np.linspace(-10.5, 10.5, 31)
    x = PreisachModel.from_density(e, total=24.0, bias_width=7.0, tilt=0.5, coercivity_width=3.0,
                                   reversible=[3.0, 0.035])
    y = PreisachModel.from_density(e, total=22.0, bias=0.3, bias_width=6.0, tilt=-0.4,
                                   coercivity_width=2.6, reversible=[2.8, -0.04])
    return MultivariableHysteresis([[x, None], [Polynomial([0.05, 0.03]), y]], ["ux", "uy"],
                                   ["x", "y"], [10.0, 10.0])


def loop_amplitude(model, k, fraction, amplitude=10.0):
    """Peak-to-peak of output k over the second period of a 1 Hz sine of input k."""
    n = int(round(1 / T))
    u = np.zeros((model.n_inputs, 2 * n))
    u[k] = fraction * amplitude * np.sin(2 * np.pi * np.arange(2 * n) / n)
    return float(np.ptp(model.simulate(u)[0][k, n:]))


@pytest.fixture(scope="module")
def fitted():
    # the defaults (16 uniform plays): with 8 uniform plays y's 15 % loop below was 6.7 % off,
    # with 10 2.8 % (the class notes)
    true = gpi_actuator()
    est = GeneralizedPIIdentifier(max_evaluations=BUDGET)
    return true, est.fit(records(true, noise=0.01, sampling_period=T_FIT,
                                 levels=LEVELS_100_TO_10))


def test_recovers_loops_and_minor_loops_of_other_thresholds_and_envelopes(fitted):
    true, est = fitted
    assert sorted({round(r["percent"]) for r in est.fit_.levels if r["held_out"]}) == [10, 40, 80]
    for row in est.fit_.levels:                 # direct paths, held-out and trained levels
        if row["output"] == ("x" if row["source"] == "rec-0" else "y"):
            # the 10 % level is held out below every trained loop: y's is 1.37 % off there
            assert row["rms_percent"] < (1.0 if row["percent"] > 15 else 2.0), row
    for k in range(2):                           # minor loops never recorded (30 %, 15 %)
        for frac in (0.3, 0.15):
            a, b = loop_amplitude(true, k, frac), loop_amplitude(est.model_, k, frac)
            assert abs(b / a - 1) < 0.02, (k, frac, a, b)


def test_rest_value_identified_from_the_initial_loading_curve():
    # the true plays rest inside their bands, not at 0 (x: 0.5, y: -0.8 in envelope units); the
    # identifier is not told: it fits the burn-in, so the loading curve from rest and a 15 %
    # loop from rest (which never wipes out the larger plays) follow the truth. With the rest
    # at 0 and the burn-in left out, the loading curve was 0.15 µm off (2.9 µm with seed 1).
    # Records taken without a demagnetising cycle: record_start = "rest".
    base = gpi_actuator(demagnetised=0.0)
    grid = [list(row) for row in base.components]
    for l, rest in ((0, 0.5), (1, -0.8)):
        grid[l][l] = grid[l][l].replace(rest=rest)
    true = MultivariableHysteresis(grid, base.input_names, base.output_names, [10.0, 10.0])
    assert np.ptp(true.components[1][1].initial_state()) == 0.0 != true.components[1][1].rest
    est = GeneralizedPIIdentifier(n_plays=8, max_evaluations=BUDGET, threshold_spacing="power",
                                  record_start="rest").fit(records(true, noise=0.01,
                                                                   sampling_period=T_FIT))
    for k in range(2):
        u = np.zeros((2, 250))                  # from rest to the first peak and back to 7 V
        u[k] = 10 * np.sin(2 * np.pi * np.arange(250) * T)
        np.testing.assert_allclose(est.model_.simulate(u)[0][k], true.simulate(u)[0][k], atol=0.1)
        u = np.zeros((2, 2000))                 # 15 % loop from rest, second period
        u[k] = 1.5 * np.sin(2 * np.pi * np.arange(2000) * T)
        np.testing.assert_allclose(est.model_.simulate(u)[0][k, 1000:],
                                   true.simulate(u)[0][k, 1000:], atol=0.15)


def test_direct_paths_monotone_and_cross_couplings_kept(fitted):
    true, est = fitted
    for l in range(2):
        d = est.model_.components[l][l]
        assert isinstance(d, GeneralizedPI) and np.all(d.weights >= 0) and d.reversible[0] > 0
    assert est.structure_ == [["generalized", "generalized"], ["generalized", "generalized"]]
    u = np.zeros((2, 4))                         # the even coupling: same at +A and -A (closed form)
    u[0] = [0.0, 10.0, 0.0, -10.0]
    yt, ye = true.simulate(u)[0][1], est.model_.simulate(u)[0][1]
    assert abs(ye[1] - yt[1]) < 0.3 and abs(ye[3] - yt[3]) < 0.3     # µm, 3 µm even coupling
    u = np.zeros((2, 2000))                      # the hysteretic coupling's loop, 1 Hz, full range
    u[1] = 10 * np.sin(2 * np.pi * np.arange(2000) * T)
    np.testing.assert_allclose(est.model_.simulate(u)[0][0, 1000:], true.simulate(u)[0][0, 1000:],
                               atol=0.25)


def test_round_trip_identify_preset_load(fitted, tmp_path):
    _, est = fitted
    path = tmp_path / "identified.toml"
    save_model(est.model_, path, {"method": "generalized-pi"})
    back = load_model(str(path))
    assert isinstance(back.components[1][0], GeneralizedPI)
    assert back.components[1][0].reversible.size == 3
    u = records(est.model_)[1].u
    np.testing.assert_allclose(back.simulate(u)[0], est.model_.simulate(u)[0], atol=1e-9)


def test_thresholds_follow_the_envelopes():
    gl, gr = [4.0, 0.2, 0.1, 0.0], [5.0, 0.15, -0.1, 0.5]
    r = play_thresholds(gl, gr, -10.0, 10.0, 4)
    mid = 0.5 * (envelope(gl, 10.0) + envelope(gr, 10.0) - envelope(gl, -10.0) - envelope(gr, -10.0))
    np.testing.assert_allclose(r, 0.5 * mid * np.array([0.0, 0.25, 0.5, 0.75]) ** 1.5)


def test_uniform_thresholds_closed_form():
    gl, gr = [4.0, 0.2, 0.1, 0.0], [5.0, 0.15, -0.1, 0.5]
    r = play_thresholds(gl, gr, -10.0, 10.0, 4, "uniform")
    np.testing.assert_allclose(r, play_thresholds(gl, gr, -10.0, 10.0, 4)[-1]
                               * np.array([0.0, 0.25, 0.5, 0.75]) / 0.75 ** 1.5)
    with pytest.raises(ValueError, match="spacing"):
        play_thresholds(gl, gr, -10.0, 10.0, 4, "cubic")


def test_reversible_polynomial_closed_form():
    g = GeneralizedPI([0.0], [0.0], [1.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0], offset=0.5,
                      reversible=[0.2, -0.03])
    u = np.array([0.0, 2.0, -3.0])
    np.testing.assert_allclose(g.simulate(u)[0], 0.5 + 0.2 * u - 0.03 * u ** 2)
    with pytest.raises(HysteresisError, match="reversible"):
        GeneralizedPI([0.0], [1.0], [1, 1, 0, 0], [1, 1, 0, 0], reversible=["a"])


@pytest.mark.parametrize("kwargs, match", [({"n_plays": 1}, "n_plays"),
                                           ({"max_evaluations": 0}, "max_evaluations"),
                                           ({"threshold_spacing": "cubic"}, "threshold_spacing"),
                                           ({"n_starts": 0}, "n_starts"),
                                           ({"n_starts": 5}, "n_starts"),
                                           ({"n_starts": True}, "n_starts"),
                                           ({"level_weighting": "relative"}, "level_weighting")])
def test_bad_parameters_are_named(kwargs, match):
    with pytest.raises(IdentificationError, match=match):
        GeneralizedPIIdentifier(**kwargs)


def test_drops_only_couplings_below_the_noise():
    true = gpi_actuator()
    true.components[0][1] = None                # no x <- uy at all
    true = MultivariableHysteresis(true.components, ["ux", "uy"], ["x", "y"], [10.0, 10.0])
    est = GeneralizedPIIdentifier(n_plays=6, max_evaluations=20).fit(
        records(true, noise=0.01, sampling_period=T_FIT))
    assert est.model_.components[0][1] is None
    assert est.model_.components[1][0] is not None        # 3 µm even coupling stays
    assert any("x <- uy: absent" in n for n in est.notes_)


# -- the exact inverse over a GPI model -------------------------------------------------------
def naive_inverse(model, yr, lo=-12.0, hi=12.0):
    """Per sample, Gauss-Seidel over the outputs with a root search on each direct path
    (Brent's method, bracketed by the input bounds); each trial a fresh one-sample simulation
    from the committed state (no shared code)."""
    m, n = model.n_inputs, yr.shape[1]
    state = model.initial_state()
    u_now = np.zeros(m)
    out = np.empty((m, n))

    def gap(x, l, t):
        trial = u_now.copy()
        trial[l] = x
        return model.simulate(trial[:, None], state)[0][l, 0] - yr[l, t]

    for t in range(n):
        for _ in range(60):
            before = u_now.copy()
            for l in range(m):
                u_now[l] = scipy.optimize.brentq(gap, lo, hi, args=(l, t), xtol=1e-13, rtol=1e-15)
            if np.max(np.abs(u_now - before)) < 1e-12:
                break
        out[:, t] = u_now
        state = model.simulate(u_now[:, None], state)[1]
    return out


def reference(n):
    t = np.arange(n) * T
    return np.vstack([14 * np.sin(2 * np.pi * t) * np.exp(-t), 8 * np.cos(2 * np.pi * 1.5 * t) - 2])  # in reach


def test_inverse_round_trip_and_chunks(fitted):
    _, est = fitted
    comp = PreisachInverseCompensator(est.model_)
    yr = reference(3000)
    u, _ = comp.simulate(yr)
    # 1e-6 µm: the fit may leave a play's weight at 0 (its bound), a direct path nearly flat
    # just after a reversal (slope 1e-3 of the secant), where one sample's inverse settles to
    # 2e-7 µm; elsewhere to 1e-12
    err = np.abs(est.model_.simulate(u)[0] - yr)
    assert np.max(err) < 1e-6 and np.median(err) < 1e-11
    u1, s1 = comp.simulate(yr[:, :1234])
    u2, _ = comp.simulate(yr[:, 1234:], s1)
    np.testing.assert_allclose(np.hstack([u1, u2]), u, atol=1e-12)


def test_inverse_matches_a_naive_root_search(fitted):
    _, est = fitted
    yr = reference(400)[:, ::20]      # 20 samples over 0.4 s: both outputs turn back once
    u, _ = PreisachInverseCompensator(est.model_, input_bound=[12.0, 12.0]).simulate(yr)
    np.testing.assert_allclose(u, naive_inverse(est.model_, yr), atol=1e-7)


# -- the Hammerstein compensator over a GPI model -------------------------------------------
def circle(n, f, R, Ts):
    t = np.arange(n) * Ts
    return np.vstack([R * np.cos(2 * np.pi * f * t), R * np.sin(2 * np.pi * f * t)])


@pytest.mark.slow  # end-to-end; default pytest stays fast, .ci/run runs -m slow
@pytest.mark.parametrize("plant_kind", ["gpi", "preisach"])
def test_hammerstein_over_a_gpi_model(plant_kind):
    true = gpi_actuator() if plant_kind == "gpi" else preisach_actuator()
    est = GeneralizedPIIdentifier(max_evaluations=BUDGET).fit(records(true, noise=0.02))
    G = load_plant("realistic-2dof").dynamics
    plant = HammersteinPlant(true, G.dt, G)
    comp = HammersteinCompensator(est.model_, G)
    assert comp.exact_static
    R, f, n = 10.0, 50.0, 3000                  # y reaches about +-12 µm
    ref = circle(n, f, R, G.dt)
    res = comp.run_reference(plant, ref, period_samples=int(round(1 / (f * G.dt))), fade_samples=400)
    err = np.linalg.norm(res.outputs[:, 1600:] - ref[:, 1600:], axis=0)
    # identified hysteresis, true G. Measured: GPI plant 1.6 % of R worst, 0.6 % median (the
    # fit's own error from 20 nm noise); Preisach plant (outside the class, non-congruent minor
    # loops) 6.9 % worst, 4.2 % median although its held-out levels fit to 0.1 % RMS
    worst, median = {"gpi": (0.03, 0.012), "preisach": (0.1, 0.06)}[plant_kind]
    assert err.max() < worst * R and np.median(err) < median * R, (err.max(), np.median(err))


def test_threshold_spacing_auto_keeps_the_lower_held_out_error_and_says_so():
    """``threshold_spacing="auto"`` is the two explicit fits, the lower held-out score kept.

    The actuator's thresholds are exactly the identifier's uniform ones (its
    envelopes in the identifier's parametrisation, A = 10 V). The expectation
    is not which spacing wins (the held-out levels hardly tell them apart:
    see the class notes) but that auto's scores are those of the two explicit
    fits, its choice their minimum, reported in the attributes, the fit's
    ``partition`` and the notes, and its model the chosen explicit fit's.
    """
    gl, gr = envelopes([0.8, 0.1, 1.1, 0.9, -0.05, 0.04, 0.0], 10.0)
    true = GeneralizedPI(play_thresholds(gl, gr, -10.0, 10.0, 6, "uniform"),
                         [1.0, 0.5, 0.4, 0.3, 0.2, 0.15], gl, gr, 0.0, [0.3])
    t, u, _ = decreasing_sine(T, 10.0)
    y, _ = true.simulate(u)
    rec = MultiRecord(t, u[np.newaxis], y[np.newaxis], ("u",), ("y",), T, "sim")
    fits = {sp: GeneralizedPIIdentifier(n_plays=6, max_evaluations=BUDGET,
                                        threshold_spacing=sp).fit(rec)
            for sp in ("power", "uniform", "auto")}
    auto = fits["auto"]
    scores = {sp: fits[sp].spacing_scores_[sp] for sp in ("power", "uniform")}
    assert fits["power"].threshold_spacing_ == "power"
    assert list(fits["power"].spacing_scores_) == ["power"]
    assert auto.spacing_scores_ == pytest.approx(scores, rel=1e-9)
    best = min(scores, key=scores.get)
    assert auto.threshold_spacing_ == auto.fit_.partition == best
    assert auto.fit_.partition_scores == pytest.approx(scores, rel=1e-9)
    assert auto.notes_[0].startswith(f"threshold spacing auto: chose {best} (power ")
    np.testing.assert_allclose(auto.model_.components[0][0].thresholds,
                               fits[best].model_.components[0][0].thresholds, rtol=1e-12)
    r = fits["uniform"].model_.components[0][0].thresholds
    np.testing.assert_allclose(np.diff(r), r[1], rtol=1e-9)          # uniform: S j / n


def test_monotone_quadratic_columns_slopes_at_the_ends():
    """Coefficients are the slopes at lo and hi; slopes >= m there give p' >= m on [lo, hi]."""
    lo, hi = -0.8, 1.0
    u = np.linspace(lo, hi, 2001)
    rng = np.random.default_rng(3)
    assert np.all(monotone_quadratic_columns(np.zeros(1), lo, hi) == 0.0)
    for g in rng.uniform(0.01, 5.0, size=(20, 2)):
        p = monotone_quadratic_columns(u, lo, hi) @ g
        c1, c2 = quadratic_coefficients(g, lo, hi)
        np.testing.assert_allclose(p, c1 * u + c2 * u ** 2, atol=1e-12)
        slope = c1 + 2 * c2 * u                  # exact derivative of the monomial form
        np.testing.assert_allclose(slope[[0, -1]], g, rtol=1e-12)
        assert np.all(slope >= g.min() - 1e-12)


def test_direct_paths_increase_wherever_the_inverse_drives_them(fitted):
    """The reversible quadratic's slope stays positive on [-1.2 A, 1.2 A], not only on the
    measured range: the exact inverse (inputs kept within 1.2 x the amplitude) accepts the model
    and its forward model increases along a ramp over that whole range."""
    _, est = fitted
    u = np.linspace(-12.0, 12.0, 4801)
    for l in range(2):
        c1, *rest = est.model_.components[l][l].reversible
        c2 = rest[0] if rest else 0.0
        assert np.all(c1 + 2 * c2 * u > 0), (l, c1, c2)
        assert np.all(np.diff(est.model_.components[l][l].simulate(u)[0]) > 0)
    PreisachInverseCompensator(est.model_)       # would raise on a decreasing direct path


def test_direct_path_with_a_quadratic_reversible_term_is_recovered():
    """A direct path with ``c_1 u + c_2 u^2`` (realistic-gpi's y path) predicts its loops.

    With a linear reversible term only, the noiseless fit bent the envelopes to
    mimic the curvature and small loops from rest were 0.48 µm off in shape;
    with the quadratic the reversible curvature is the true one and the
    never-recorded 15 % and 30 % loops follow the truth.
    """
    true = GeneralizedPI([0.0, 0.9, 2.0, 3.4, 5.2], [1.1, 0.55, 0.33, 0.22, 0.13],
                         gamma_l=[13.0, 0.09, -0.08, 0.3], gamma_r=[15.0, 0.075, 0.06, -0.2],
                         reversible=[3.6, -0.025])
    t, u, _ = decreasing_sine(5e-4, 10.0, levels=LEVELS_100_TO_10)
    y, _ = true.simulate(u)
    rec = MultiRecord(t, u[np.newaxis], y[np.newaxis], ("u",), ("y",), 5e-4, "sim")
    est = GeneralizedPIIdentifier(max_evaluations=BUDGET).fit(rec)
    c = est.model_.components[0][0].reversible
    np.testing.assert_allclose(c[1], -0.025, rtol=0.05)
    for frac in (0.3, 0.15):
        v = frac * 10.0 * np.sin(2 * np.pi * np.arange(4000) / 2000)
        np.testing.assert_allclose(est.model_.simulate(v[None])[0][0, 2000:],
                                   true.simulate(v)[0][2000:], atol=0.01 * np.ptp(y) * frac)


@pytest.mark.slow
def test_four_starts_fit_the_training_samples_better_outside_the_class():
    """The envelope fit is not convex. On the Preisach actuator (outside the class), its
    rows unweighted, the default start alone stops in a higher minimum: with four starts
    (each screened, the lowest cost fitted on) the training RMS of x falls by more than 5 %,
    and neither output's rises (screening is not a guarantee: a start ahead after its
    screening steps could end higher than another would have). With the levels weighted (the
    default) both reach the same minimum on these records. Measured on the five levels
    100..20 % (with the default's 10 % level too, the fall is 4.6 %), with the plays starting
    at rest, where the starts were chosen (from the demagnetised state, the default since,
    one start reaches the same minimum here)."""
    R = records(preisach_actuator(), noise=0.01, sampling_period=T_FIT,
                levels=(1.0, 0.8, 0.6, 0.4, 0.2))
    one = GeneralizedPIIdentifier(max_evaluations=BUDGET, n_starts=1, level_weighting="none",
                                  record_start="rest").fit(R).fit_.train
    four = GeneralizedPIIdentifier(max_evaluations=BUDGET, n_starts=4, level_weighting="none",
                                   record_start="rest").fit(R).fit_.train
    for a, b in zip(one, four):
        assert b["rms_percent"] <= a["rms_percent"] * (1 + 1e-9), (a, b)
    assert four[0]["rms_percent"] < 0.95 * one[0]["rms_percent"]


def test_the_reversal_curves_after_the_levels_do_not_move_the_fit():
    """Records of ``hammerstein excitation`` (the decreasing sine, then first-order reversal
    curves): the generalised PI fits the amplitude levels only, so two record sets whose curves
    differ (other reversal points, then the same first move up to the amplitude) give the same
    model, bit for bit, and its notes say so; the Preisach class is the one that uses them."""
    true = gpi_actuator()
    a = GeneralizedPIIdentifier(max_evaluations=BUDGET, n_starts=1).fit(
        records(true, sampling_period=T_FIT, reversals=(0.5, -0.5)))
    b = GeneralizedPIIdentifier(max_evaluations=BUDGET, n_starts=1).fit(
        records(true, sampling_period=T_FIT, reversals=(0.8, 0.1, -0.3)))
    assert a.model_.to_table() == b.model_.to_table()
    assert any("not the reversal curves after them" in n for n in a.notes_)


def test_level_weights_closed_form():
    """Levels of 100, 50 and 25 % of the amplitude: their samples weigh 1, 2 and 4, the
    burn-in before the first level and the samples after the last 1."""
    from hammerstein.identification.record_identification import (level_weights,
                                                                   split_level_records)
    t = np.arange(9000) * T
    amp = np.select([t < 3.0, t < 6.0], [8.0, 4.0], 2.0)
    u = amp * np.sin(2 * np.pi * t)
    u = np.concatenate([np.zeros(500), u, np.zeros(500)])
    rec = MultiRecord(np.arange(u.size) * T, u[None], u[None], ("u",), ("y",), T, "levels")
    _, (split,) = split_level_records([rec])
    assert [round(lv["percent"]) for lv in split.levels] == [100, 50, 25]
    w = level_weights(split, u.size)
    expected = np.ones(u.size)
    for lv, weight in zip(split.levels, (1.0, 2.0, 4.0)):
        expected[lv["start"]:lv["stop"]] = weight
    np.testing.assert_array_equal(w, expected)
    assert w[:500].tolist() == [1.0] * 500 and w[-500:].tolist() == [1.0] * 500
    assert set(np.unique(w)) == {1.0, 2.0, 4.0}


@pytest.mark.slow
def test_level_weighting_trades_the_full_level_for_the_small_ones():
    """Weighted least squares: each fit is best on its own measure. On the Preisach actuator
    (outside the class), weighting each level by A_max / A_level lowers the 20 % level's
    training RMS relative to its range on both direct paths and raises the 100 % level's,
    and the never-recorded 15 % loops come out closer in amplitude."""
    true = preisach_actuator()
    R = records(true, noise=0.01, sampling_period=T_FIT, levels=LEVELS_100_TO_10)
    fits = {lw: GeneralizedPIIdentifier(max_evaluations=BUDGET, level_weighting=lw).fit(R)
            for lw in ("none", "amplitude")}

    def rms(est, k, percent):
        return next(r["rms_percent"] for r in est.fit_.levels if r["source"] == f"rec-{k}"
                    and r["output"] == "xy"[k] and round(r["percent"]) == percent)

    for k in range(2):
        assert rms(fits["amplitude"], k, 20) < 0.9 * rms(fits["none"], k, 20)
        assert rms(fits["amplitude"], k, 100) > rms(fits["none"], k, 100)
        a = loop_amplitude(true, k, 0.15)
        err = {lw: abs(loop_amplitude(f.model_, k, 0.15) / a - 1) for lw, f in fits.items()}
        assert err["amplitude"] < err["none"], err


@pytest.mark.slow
def test_the_fit_does_not_depend_on_the_output_unit():
    """The same records with x in nm (x 1000) and y in metres (x 1e-6) give the same model to
    the unit: a held-out loop's RMS error in % of its range equal to 1e-4 of itself. Before, a ridge of
    1e-13 |y|^2 on unit columns and least_squares' absolute gradient tolerance made the score of
    a bench actuator's records 1.01 % in µm, 11.8 % with x in nm."""
    true = gpi_actuator()
    recs = records(true, noise=0.01, sampling_period=T_FIT)
    n = int(round(1 / T))
    held = np.zeros((2, 2 * n))
    held[0] = 5.5 * np.sin(2 * np.pi * np.arange(2 * n) / n)     # 55 %: a level not fitted
    held[1] = 3.0 * np.sin(2 * np.pi * np.arange(2 * n) / n + 1.0)
    y_true = true.simulate(held)[0]
    scores = []
    for unit in (np.array([1.0, 1.0]), np.array([1e3, 1e-6])):
        scaled = [MultiRecord(r.timepts, r.u, r.y * unit[:, None], r.input_names, r.output_names,
                              r.sampling_period, r.source) for r in recs]
        model = GeneralizedPIIdentifier(max_evaluations=BUDGET).fit(scaled).model_
        err = model.simulate(held)[0] / unit[:, None] - y_true
        scores.append(100 * np.sqrt(np.mean(err ** 2, axis=1)) / np.ptp(y_true, axis=1))
    np.testing.assert_allclose(scores[1], scores[0], rtol=1e-4)
