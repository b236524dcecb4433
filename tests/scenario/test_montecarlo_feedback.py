"""Monte-Carlo studies with [feedback]: every drawn plant in the loop designed on the nominal one."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from hammerstein.compensation.feedback import FeedbackLoop
from hammerstein.exceptions import FeedbackError, ScenarioError
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.models.plant import HammersteinPlant
from hammerstein.scenario.feedback_loops import build_loops
from hammerstein.scenario import montecarlo as mc
from hammerstein.scenario.validate import validate_scenario

STUDY = """
name = "mcfb"
seed = 5
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
[[sweeps]]
kind = "monte-carlo"
name = "mm"
cases = 6
frequencies = [5.0, 20.0]
reference = { kind = "sine", output = "x", amplitude = 20.0, periods = 3 }
settle_periods = 2
[sweeps.vary]
weights = { relative_sd = 0.15 }
cross_coupling = { relative_sd = 0.3, distribution = "lognormal" }
"""

FEEDBACK = """
[feedback]
sensor = { noise_nm = 10.0, delay = 1 }
amplifier = { range = [-100.0, 100.0] }
[feedback.axes.x]
kind = "integral"
crossover_hz = 60.0
[feedback.axes.y]
kind = "integral"
crossover_hz = 60.0
"""


def _scenario(tmp_path, text, name="s.toml"):
    f = tmp_path / name
    f.write_text(text, encoding="utf-8")
    return validate_scenario(f)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    d = tmp_path_factory.mktemp("mcfb")
    open_loop = mc.run_montecarlo_scenario(_scenario(d, STUDY, "open.toml"))[0]
    sc = _scenario(d, STUDY + FEEDBACK, "closed.toml")
    closed = mc.run_montecarlo_scenario(sc)[0]
    return open_loop, closed, sc.studies[0]


def test_feedback_lowers_the_mismatch_error(results):
    """A 60 Hz integral loop divides the plants' mismatch error at 5 Hz by about |S| ~ 5/60."""
    open_loop, closed, study = results
    col = study.columns.index(("x+y", "max_euclidean_error"))
    for j in range(2):                       # every quantile, at both frequencies
        assert np.all(closed.quantiles[:, j, col] < 0.5 * open_loop.quantiles[:, j, col])
    assert not closed.diverged.any()


def test_rows_do_not_depend_on_the_chunking(results):
    _, _, study = results
    _, whole = mc.run_chunk(study, 0, 6)
    _, part = mc.run_chunk(study, 3, 5)
    np.testing.assert_array_equal(whole[3:5], part)


def test_a_row_is_the_drawn_plant_in_the_designed_loop(results, tmp_path):
    """Row i: case i's plant in a loop built from the [feedback] table, the feedforward of the
    nominal compensator, noise seeded (seed, i, j + 1)."""
    _, _, study = results
    sc = _scenario(tmp_path, STUDY + FEEDBACK)
    nominal, _ = build_loops(sc.feedback, study.plant)
    _, values = mc.run_chunk(study, 4, 5)
    for j, r in enumerate(study.references):
        loop = FeedbackLoop(mc.case_plant(study, 4), nominal.designed, nominal.sensor,
                            nominal.amplifier, nominal.anti_windup, nominal.tracking_time)
        u = study.compensator.simulate(r)[0]
        y = loop.simulate(r, feedforward=u, seed=[study.seed, 4, j + 1]).outputs
        win = slice(2 * study.period_samples[j], None)
        e = np.sqrt(np.sum((r[:, win] - y[:, win]) ** 2, axis=0))
        col = study.columns.index(("x+y", "max_euclidean_error"))
        assert values[0, j, col] == pytest.approx(np.max(e), rel=1e-9)


def test_problems_are_listed_together(tmp_path):
    bad = STUDY.replace('cross_coupling = { relative_sd = 0.3, distribution = "lognormal" }',
                        'noise = { sd = 0.05 }') + FEEDBACK.replace(
        "[feedback]\n", '[feedback]\nmodes = ["both"]\n').replace(
        "[feedback.axes.y]\nkind = \"integral\"\ncrossover_hz = 60.0\n", "").replace(
        "delay = 1", "delay = -1")
    with pytest.raises(ScenarioError) as exc:
        _scenario(tmp_path, bad)
    text = str(exc.value)
    for key in ("vary.noise", "feedback.modes", "no controller for y", "feedback.sensor.delay"):
        assert key in text, key


def test_with_plant_is_a_new_loop_on_that_plant(results):
    """FeedbackLoop.with_plant gives the loop built afresh on the other plant, sample for sample."""
    _, _, study = results
    nominal = FeedbackLoop(study.plant, *study.loop)
    other = mc.case_plant(study, 2)
    r, u = study.references[1], study.feedforward[1]
    a = nominal.with_plant(other).simulate(r, feedforward=u, seed=7)
    b = FeedbackLoop(other, *study.loop).simulate(r, feedforward=u, seed=7)
    np.testing.assert_array_equal(a.outputs, b.outputs)
    np.testing.assert_array_equal(a.inputs, b.inputs)
    c = nominal.simulate(r, feedforward=u, seed=7)
    assert not np.array_equal(a.outputs, c.outputs)      # the drawn plant differs


def test_with_plant_refuses_another_shape(results):
    _, _, study = results
    nominal = FeedbackLoop(study.plant, *study.loop)
    with pytest.raises(FeedbackError, match="plant: expected 2 inputs"):
        nominal.with_plant(_one_axis_plant())


def _one_axis_plant():
    pi = PrandtlIshlinskii([0.0, 1.0], [1.0, 0.2])
    return HammersteinPlant(MultivariablePI([[pi]]), 1e-4, None)


def test_the_study_travels_to_workers(results):
    """Pickled (as dask sends it to worker processes) the study gives the same rows; an
    in-process dask cluster the same quantiles."""
    _, closed, study = results
    again = pickle.loads(pickle.dumps(study))
    np.testing.assert_array_equal(mc.run_chunk(again, 1, 3)[1], mc.run_chunk(study, 1, 3)[1])
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed (extra [distributed]) is not installed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        remote = mc.run_study(study, client=client, chunk=2)
    np.testing.assert_array_equal(remote.quantiles, closed.quantiles)


def test_the_report_describes_the_loop(tmp_path):
    from hammerstein.runner import run_scenario
    path = tmp_path / "mcfb.toml"
    path.write_text(STUDY.replace("cases = 6", "cases = 3") + FEEDBACK, encoding="utf-8")
    out = run_scenario(path, tmp_path / "out")
    assert out.ok, out.error
    text = (tmp_path / "out" / "mcfb" / "report.md").read_text(encoding="utf-8")
    assert "runs in closed loop" in text and "crossover 60 Hz" in text and "10 nm RMS" in text
