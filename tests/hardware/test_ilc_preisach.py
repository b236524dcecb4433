"""ILC from, and linearised along, a Hammerstein compensator over a Preisach model.

Expectations, derived without the learning's own numbers:

* static model = plant, gain 1, no Q: one update puts the model's output on
  the reference (``v_1 = v_0 + e_0 = y_r``, then the exact inverse), so the
  second trial's error is the root tolerance, whatever the first one was
  (without the gain floor of ``IterativeLearning.limit_update``);
* a plant outside the model's class (realistic-2dof: Preisach on a finer,
  asymmetric grid with ``u^2`` terms, hysteretic cross-couplings and log
  creep; the learning model a symmetric 10-level Preisach without
  cross-couplings or creep), 40 nm sensor noise: no trial more than 10 %
  worse than the previous one, and the error falls by a factor 30;
* the scenario kind ``ilc`` accepts a Preisach start model (it used to refuse it)
  and learns from it.
"""

import warnings

import numpy as np
import pytest

from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.ilc import IterativeLearning, LearningCompensator
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.io.presets import load_plant
from hammerstein.exceptions import CompensatorError

EDGES = np.linspace(-10.5, 10.5, 11)      # 10 levels: not the plant's 28/14-level grids


def _model():
    """A symmetric Preisach model without cross-couplings (the learning's, not the plant's)."""
    dx = PreisachModel.from_density(EDGES, total=24.0, bias_width=6.0, coercivity_width=2.5,
                                    reversible=[3.2])
    dy = PreisachModel.from_density(EDGES, total=22.0, bias_width=6.0, coercivity_width=2.5,
                                    reversible=[3.0])
    return MultivariableHysteresis([[dx, None], [None, dy]], input_names=["ux", "uy"],
                                   output_names=["x", "y"], input_amplitude=[10.0, 10.0])


def _circle(T, f, R, periods):
    t = np.arange(int(round(periods / f / T))) * T
    return R * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def test_static_exact_model_reaches_the_reference_in_one_update():
    model = _model()
    T = 5e-5
    rng = np.random.default_rng(3)
    t = np.arange(3000) * T       # a decaying circle with minor loops: every branch kind
    yr = 25 * np.exp(-t / 0.05) * np.vstack([np.sin(2 * np.pi * 40 * t), np.cos(2 * np.pi * 40 * t) - 1])
    u0 = rng.uniform(-3, 3, (2, 1)) + 0.5 * PreisachInverseCompensator(model).simulate(yr)[0]
    # slope_floor=0: the exact law (the floor, a robustness margin, shortens steps where the model is flat)
    ilc = IterativeLearning(model, None, T, learning_gain=1.0, q_cutoff_hz=None, slope_floor=0.0)
    y0, _ = model.simulate(u0)
    u1 = ilc.step(yr, u0, y0)
    y1, _ = model.simulate(u1)
    assert np.max(np.abs(yr - y0)) > 5.0
    assert np.max(np.abs(yr - y1)) < 1e-8


def test_update_is_the_linearised_inverse_to_first_order():
    """A small error e: u_1 - u_0 = J^-1 e, J the Preisach slope along u_0 in the direction of the
    update (finite difference of the model along the shifted trajectory, from the model alone:
    a small rise on a descending branch sees the reversible slope, not the branch's)."""
    model = _model()
    T = 5e-5
    t = np.arange(400) * T
    u0 = np.vstack([6 * np.sin(2 * np.pi * 50 * t), 4 * np.cos(2 * np.pi * 50 * t) - 1])
    y0, _ = model.simulate(u0)
    e = 1e-4 * np.vstack([np.ones(t.size), -np.ones(t.size)])
    ilc = IterativeLearning(model, None, T, learning_gain=1.0, q_cutoff_hz=None)
    du = ilc.step(y0 + e, u0, y0) - u0
    # the slope of each direct path along u0 towards e: (y(u0 + h) - y(u0)) / h
    h = 1e-5 * np.sign(e)
    yh, _ = model.simulate(u0 + h)
    J = (yh - y0) / h
    assert np.all(J > 0)
    np.testing.assert_allclose(du, e / J, rtol=0.05)


@pytest.mark.parametrize("R, f, periods", [
    (50.0, 200.0, 12),
    pytest.param(15.0, 10.0, 6, marks=pytest.mark.slow),   # 2 s: in .ci/run's -m slow
])
def test_learning_on_a_plant_outside_the_preisach_model_never_grows(R, f, periods):
    plant = load_plant("realistic-2dof")
    T = plant.sampling_period
    P = int(round(1 / f / T))
    start = HammersteinCompensator(_model(), plant.dynamics)
    assert start.exact_static
    ilc = LearningCompensator(start, T, 10, learning_gain=0.8, q_cutoff_hz=500.0,
                              sensor_noise=0.04, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ilc.run_reference(plant, _circle(T, f, R, periods), P, P)
    errs = np.array([r.max_euclidean_error for r in ilc.history])
    assert errs.size == 11
    assert np.all(errs[1:] <= 1.1 * errs[:-1]), errs
    assert errs.min() < errs[0] / 30, errs


def test_a_preisach_model_its_inverse_refuses_is_a_clear_error():
    d = PreisachModel.from_density(EDGES, total=20.0)
    rect = MultivariableHysteresis([[d, d]], input_names=["a", "b"], output_names=["x"])
    with pytest.raises(CompensatorError, match="model: .*exactly.*as many inputs as outputs"):
        IterativeLearning(rect, None, 5e-5)


MODEL_TOML = """
[model]
inputs = ["ux", "uy"]
outputs = ["x", "y"]
input_amplitude = [10.0, 10.0]
[model.components.x.ux]
kind = "preisach"
range = [-10.5, 10.5]
n_levels = 10
reversible = [3.2]
density = { kind = "gaussian", total = 24.0, bias_width = 6.0, coercivity_width = 2.5 }
[model.components.y.uy]
kind = "preisach"
range = [-10.5, 10.5]
n_levels = 10
reversible = [3.0]
density = { kind = "gaussian", total = 22.0, bias_width = 6.0, coercivity_width = 2.5 }
"""


def test_scenario_kind_ilc_starts_from_a_preisach_model(tmp_path):
    from hammerstein.scenario.execute import run_case
    from hammerstein.scenario.resolve import load_scenario
    (tmp_path / "preisach.toml").write_text(MODEL_TOML, encoding="utf-8")
    p = tmp_path / "ilc.toml"
    p.write_text("""
name = "ilc-preisach"
[plant]
preset = "realistic-2dof"
[compensator]
kind = "ilc"
iterations = 4
learning_gain = 0.8
q_cutoff_hz = 500.0
sensor_noise = 0.04
start = { kind = "hammerstein", model = "preisach.toml", dynamics = "plant" }
[[cases]]
name = "c"
settle_periods = 2
reference = { kind = "circle", radius = 30.0, frequency = 100.0, periods = 10 }
""", encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run_case(load_scenario(p).cases[0])
    m = {(r["channel"], r["metric"]): r["value"] for r in res.metrics}
    first = m[("iteration-0", "max_euclidean_error")]
    assert m[("x+y", "max_euclidean_error")] < first / 5
    assert ("iteration-4", "max_abs_error_x") in m


def test_learn_through_files_with_a_preisach_preset(tmp_path, repo_root):
    """`compensate` then three `learn` calls on a Preisach preset (model above, the actuator's
    modes), against realistic-2dof with a 3-sample delay and 40 nm noise: the true error falls
    by a factor 5 and never grows by more than 10 %."""
    import contextlib
    import io

    import pandas as pd

    from hammerstein.cli.main import main
    from hammerstein.compensation.drive import read_signals
    text = (repo_root / "hammerstein/presets/realistic-2dof.toml").read_text(encoding="utf-8")
    dynamics = text[text.index("[dynamics]"):text.index("[creep")]
    (tmp_path / "p.toml").write_text('[preset]\nname = "preisach-model"\nsampling_period = 5e-5\n'
                                     + MODEL_TOML + dynamics, encoding="utf-8")
    ref = '{ kind = "circle", radius = 30, frequency = 100, periods = 10 }'
    plant = load_plant("realistic-2dof")

    def cli(*args):
        out, err = io.StringIO(), io.StringIO()
        with contextlib.chdir(tmp_path), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            code = main(list(args))
        assert code == 0, err.getvalue()

    cli("compensate", "p.toml", "--reference", ref, "--out", "u0.csv")
    errors = []
    for k in range(4):
        t, u, _ = read_signals(tmp_path / f"u{k}.csv", ["ux", "uy"])
        clean, _ = plant.simulate(u)
        r = 30 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
        w = t >= 0.04 - 1e-12
        errors.append(np.linalg.norm(r[:, w] - clean[:, w], axis=0).max())
        y = np.concatenate([np.zeros((2, 3)), clean[:, :-3]], axis=1)
        y = y + np.random.default_rng(k).normal(0.0, 0.04, y.shape)
        pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(tmp_path / f"y{k}.csv", index=False)
        if k < 3:
            cli("learn", "p.toml", "--reference", ref, "--drive", f"u{k}.csv", "--measured",
                f"y{k}.csv", "--out", f"u{k + 1}.csv", "--learning-gain", "0.8",
                "--q-cutoff-hz", "500", "--delay", "3")
    errors = np.array(errors)
    assert np.all(errors[1:] <= 1.1 * errors[:-1]), errors
    assert errors[-1] < errors[0] / 5, errors
