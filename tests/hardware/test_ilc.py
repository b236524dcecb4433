"""Iterative learning control: convergence on exact and mismatched models, the condition.

Expectations: with the exact model and no noise the learning removes the
modelled error (falls by orders of magnitude); with mismatched dynamics it
still converges and the error never grows by more than 10 % per trial; the
monotonic-convergence condition at low frequency equals ``|1 - gamma|``
(closed form for G = Ghat, Q ~ 1); a delay estimate finds a known shift.
"""

import numpy as np
import pytest

from hammerstein.compensation.drive import drive_signal
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.ilc import IterativeLearning, error_summary, estimate_delay
from hammerstein.models.plant import HammersteinPlant
from hammerstein.io.presets import load_dynamics
from hammerstein.exceptions import CompensatorError


def _circle(T, f, R, periods):
    n = int(round(periods / f / T))
    t = np.arange(n) * T
    return R * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def _trials(plant, model, yr, P, n, gamma=0.7, noise=0.0, q=1000.0):
    T = plant.sampling_period
    comp = HammersteinCompensator(model.hysteresis, model.dynamics)
    d = drive_signal(comp, yr, T, P, fade_samples=P)
    ilc = IterativeLearning(model.hysteresis, model.dynamics, T, learning_gain=gamma, q_cutoff_hz=q)
    rng = np.random.default_rng(1)
    u, errs = d.inputs, []
    for k in range(n):
        y, _ = plant.simulate(u)
        errs.append(error_summary(d.reference, y, slice(2 * P, None), k).max_euclidean_error)
        u = ilc.step(d.reference, u, y + rng.normal(0, noise, y.shape), P)
    return np.array(errs)


def test_exact_model_removes_the_modelled_error(preset_plant):
    T = preset_plant.sampling_period
    yr = _circle(T, 200.0, 20.0, 8)
    errs = _trials(preset_plant, preset_plant, yr, 100, 4, gamma=1.0, q=3000.0)
    assert errs[2] < errs[0] / 30


@pytest.mark.parametrize("mismatch", ["fn+5", "zeta-30"])
def test_mismatched_dynamics_converge_without_growing(preset_plant, repo_root, mismatch):
    T = preset_plant.sampling_period
    G = load_dynamics(repo_root / f"scenarios/presets/mismatch/{mismatch}.toml",
                      preset_plant.hysteresis.output_names, T)
    model = HammersteinPlant(preset_plant.hysteresis, T, G)
    errs = _trials(preset_plant, model, _circle(T, 200.0, 20.0, 8), 100, 6)
    assert errs[-1] < errs[0] / 10
    assert np.all(errs[1:] <= 1.1 * errs[:-1] + 0.002 * 20)       # <= 10 % growth (+ noise floor)


def test_condition_is_one_minus_gamma_where_q_passes(preset_plant):
    ilc = IterativeLearning(preset_plant.hysteresis, preset_plant.dynamics,
                            preset_plant.sampling_period, learning_gain=0.6, q_cutoff_hz=3000.0,
                            inversion="stable")
    cond = ilc.convergence()
    low = cond.frequencies < 100
    np.testing.assert_allclose(cond.per_axis[:, low], 0.4, atol=1e-3)
    assert cond.holds and np.all(cond.coupled <= 1 + 1e-9)
    with pytest.raises(CompensatorError, match="learning_gain"):
        IterativeLearning(preset_plant.hysteresis, None, 5e-5, learning_gain=2.5)
    with pytest.raises(CompensatorError, match="q_cutoff_hz"):
        IterativeLearning(preset_plant.hysteresis, None, 5e-5, q_cutoff_hz=1e4)


@pytest.mark.parametrize("shift", [0, 3, 17])
def test_delay_estimate_finds_a_known_shift(shift):
    t = np.arange(3000) * 5e-5
    r = np.vstack([np.cos(2 * np.pi * 80 * t), np.sin(2 * np.pi * 80 * t) ** 3])
    measured = np.concatenate([np.zeros((2, shift)), r[:, :3000 - shift]], axis=1)
    assert estimate_delay(r, measured, 50) == shift


def test_scenario_kind_ilc_learns_from_a_mismatched_start(tmp_path, repo_root):
    from hammerstein.scenario.execute import run_case
    from hammerstein.scenario.resolve import load_scenario
    dyn = tmp_path / "fn+5.toml"            # scenario files name files under their directory
    dyn.write_bytes((repo_root / "scenarios/presets/mismatch/fn+5.toml").read_bytes())
    p = tmp_path / "ilc.toml"
    p.write_text(f"""
name = "ilc"
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "ilc"
iterations = 4
learning_gain = 0.7
q_cutoff_hz = 1000.0
sensor_noise = 0.04
start = {{ kind = "hammerstein", dynamics = "{dyn.name}" }}
[[cases]]
name = "c"
settle_periods = 2
reference = {{ kind = "circle", radius = 20.0, frequency = 200.0, periods = 8 }}
""")
    res = run_case(load_scenario(p).cases[0])
    m = {(r["channel"], r["metric"]): r["value"] for r in res.metrics}
    first = m[("iteration-0", "max_euclidean_error")]
    assert m[("x+y", "max_euclidean_error")] < first / 5
    assert ("iteration-4", "max_abs_error_x") in m


@pytest.mark.slow  # end-to-end; default pytest stays fast, .ci/run runs -m slow
def test_learning_outside_the_model_class_never_grows_by_more_than_10_percent():
    """realistic-2dof (Preisach loops, three coupled modes, creep), its model identified through
    the sensor (a classical PI and identified modes), 40 nm noise, 10 trials: every trial's max
    Euclidean error is at most 1.1 times the previous one, and the learning gains a factor 10."""
    import warnings

    from hammerstein.compensation.ilc import LearningCompensator
    from hammerstein.io.presets import load_plant
    from hammerstein.scenario.registry import build_compensator
    plant = load_plant("realistic-2dof")
    T = plant.sampling_period
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = build_compensator({"kind": "hammerstein", "model": "identified",
                                   "identify": {"frequency": 50.0, "sensor": True},
                                   "dynamics": "identified"}, plant, ".")
        ilc = LearningCompensator(start, T, 10, learning_gain=0.8, q_cutoff_hz=500.0,
                                  sensor_noise=0.04, seed=1)
        ilc.run_reference(plant, _circle(T, 200.0, 50.0, 12), 100, 100)
    errs = np.array([r.max_euclidean_error for r in ilc.history])
    assert errs.size == 11
    assert np.all(errs[1:] <= 1.1 * errs[:-1]), errs
    assert errs[-1] < errs[0] / 10


def test_scenario_report_has_the_convergence_figure(tmp_path, repo_root):
    from hammerstein.runner import run_scenario
    p = tmp_path / "ilc.toml"
    p.write_text("""
name = "ilc"
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "ilc"
iterations = 3
sensor_noise = 0.04
start = { kind = "multivariable" }
[[cases]]
name = "c"
settle_periods = 2
reference = { kind = "circle", radius = 20.0, frequency = 200.0, periods = 8 }
""")
    out = run_scenario(p, tmp_path / "out")
    assert out.ok, out.error
    assert (out.out_dir / "convergence-c.png").is_file()
    assert "convergence-c.png" in (out.out_dir / "report.md").read_text(encoding="utf-8")


def test_an_amplifier_keeps_the_learnt_drive_within_its_range(preset_plant):
    """Anti-windup: a circle the amplifier's range cannot reach (20 µm needs about 4 V; the
    range is -3..3 V). Without the amplifier the learnt drive leaves the range and grows
    trial after trial, learning what the actuator never receives; with it every drive stays
    within the range and under the slew rate, and so does what the actuator receives."""
    from hammerstein.compensation.drive import apply_amplifier
    from hammerstein.models.amplifier import amplifier_from_table

    T = preset_plant.sampling_period
    amp = amplifier_from_table({"range": [-3.0, 3.0], "slew_rate": 2.0e4}, ["ux", "uy"])
    yr = _circle(T, 100.0, 20.0, 6)
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    d = drive_signal(comp, yr, T, 200, fade_samples=200)
    ilc = IterativeLearning(preset_plant.hysteresis, preset_plant.dynamics, T, learning_gain=0.7,
                            q_cutoff_hz=1000.0)
    peaks = {}
    for with_amp in (False, True):
        u = d.inputs.copy()
        for _ in range(5):
            y, _ = preset_plant.simulate(apply_amplifier(amp, u, T))
            u = ilc.step(d.reference, u, y, 200, amplifier=amp if with_amp else None)
        peaks[with_amp] = np.max(np.abs(u))
        if with_amp:
            assert np.all(u >= -3.0) and np.all(u <= 3.0)
            assert np.max(np.abs(np.diff(np.concatenate([np.zeros((2, 1)), u], axis=1)))) \
                <= 2.0e4 * T * (1 + 1e-9)
    assert peaks[False] > 3.5 and peaks[True] <= 3.0
