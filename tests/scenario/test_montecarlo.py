"""Monte-Carlo studies: reproducibility per (seed, case), chunking and dask invariance,
distributions, streaming quantiles against naive references, validation messages."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from hammerstein.io.presets import resolve_preset
from hammerstein.models.hysteresis import PrandtlIshlinskii
from hammerstein.exceptions import ScenarioError
from hammerstein.scenario import montecarlo as mc
from hammerstein.scenario import montecarlo_draw as draw
from hammerstein.scenario.identification import ResolveContext
from hammerstein.scenario.registry import build_compensator
from hammerstein.scenario.validate import validate_scenario
from hammerstein.simulation import simulate_chain

STUDY = """
name = "mc"
seed = 11
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
[[sweeps]]
kind = "monte-carlo"
name = "mm"
cases = 7
frequencies = [50.0, 120.0]
reference = {{ kind = "sine", output = "x", amplitude = 20.0, periods = 2 }}
settle_periods = 1
[sweeps.vary]
{vary}
"""

VARY = """weights = { relative_sd = 0.05 }
cross_coupling = { relative_sd = 0.2, distribution = "lognormal" }
natural_frequency = { relative_sd = 0.05, distribution = "uniform" }
damping_ratio = { relative_sd = 0.2 }
noise = { sd = 0.05 }"""


#: Why the dask tests skip when the extra is not installed.
_NO_DASK = "dask.distributed (extra [distributed]) is not installed"


def _study(tmp_path, vary=VARY, name="s.toml"):
    f = tmp_path / name
    f.write_text(STUDY.format(vary=vary))
    sc = validate_scenario(f)
    study = sc.studies[0]
    study.compensator = build_compensator(sc.compensator_spec, study.plant, ResolveContext(tmp_path))
    return study


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    return _study(tmp_path_factory.mktemp("mc"))


def test_case_depends_only_on_seed_and_index(study):
    _, whole = mc.run_chunk(study, 0, 7)
    parts = [mc.run_chunk(study, a, b) for a, b in [(5, 7), (0, 2), (2, 5)]]   # any order
    again = np.empty_like(whole)
    for start, v in parts:
        again[start:start + len(v)] = v
    assert np.array_equal(whole, again)                      # bit for bit
    assert not np.array_equal(whole[0], whole[1])            # the cases do differ


def test_chunk_size_does_not_change_the_study(study):
    a, b = mc.run_study(study, chunk=7), mc.run_study(study, chunk=2)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.quantiles, b.quantiles)
    assert a.exact and a.values.shape == (7, 2, len(study.columns))


def test_metrics_equal_a_naive_simulation_of_the_drawn_plant(study):
    _, v = mc.run_chunk(study, 3, 4)
    plant = mc.case_plant(study, 3)
    for j, r in enumerate(study.references):
        y = simulate_chain(study.compensator, plant, r).outputs
        y = y + study.vary["noise"]["sd"] * np.random.default_rng([study.seed, 3, j + 1]).standard_normal(y.shape)
        P = study.period_samples[j]
        e = r[:, P:] - y[:, P:]                              # settle_periods = 1
        expect = []
        for l in range(2):
            expect += [math.sqrt(np.mean(e[l] ** 2)), np.max(np.abs(e[l]))]
        ee = np.hypot(e[0], e[1])
        expect += [math.sqrt(np.mean(ee ** 2)), ee.max()]
        np.testing.assert_allclose(v[0, j], expect, rtol=1e-12)


def test_no_variation_gives_the_nominal_plant(tmp_path):
    s = dataclasses.replace(_study(tmp_path), vary={})     # what validation now refuses
    plant, nominal = mc.case_plant(s, 4), s.plant
    for row_a, row_b in zip(plant.hysteresis.components, nominal.hysteresis.components):
        for a, b in zip(row_a, row_b):
            if isinstance(a, PrandtlIshlinskii):
                assert np.array_equal(a.weights, b.weights)
    r = s.references[0]
    assert np.array_equal(simulate_chain(s.compensator, plant, r).outputs,
                          simulate_chain(s.compensator, nominal, r).outputs)


def test_factors_of_one_case_are_reproducible_and_diagonal_untouched(study):
    a, b, c = mc.draw_factors(study, 5), mc.draw_factors(study, 5), mc.draw_factors(study, 6)
    assert np.array_equal(a["natural_frequency"], b["natural_frequency"])
    assert not np.array_equal(a["natural_frequency"], c["natural_frequency"])
    assert np.array_equal(np.diag(a["cross_coupling"]), [1.0, 1.0])
    assert all(np.array_equal(a["weights"][k], b["weights"][k]) for k in a["weights"])


@pytest.mark.parametrize("dist", ["normal", "uniform", "lognormal"])
def test_distributions_have_mean_one_and_the_stated_relative_sd(dist):
    z = np.random.default_rng(0).standard_normal(400_000)
    f = draw._factor(z, {"relative_sd": 0.1, "distribution": dist})
    se = 0.1 / math.sqrt(z.size)
    assert abs(f.mean() - 1.0) < 5 * se
    assert abs(f.std() - 0.1) < 0.002
    if dist == "uniform":
        half = 0.1 * math.sqrt(3.0)
        assert f.min() >= 1 - half and f.max() <= 1 + half
    if dist == "lognormal":
        assert f.min() > 0


def test_positive_quantities_are_clipped():
    f = draw._factor(np.array([-50.0, 0.0]), {"relative_sd": 0.5}, positive=True)
    assert f[0] == mc.MIN_FACTOR and f[1] == 1.0


def _naive_quantile(x, q):
    s = np.sort(x)
    return s[max(math.ceil(q * len(s)), 1) - 1]


def test_accumulator_exact_and_histogram_against_naive_quantiles():
    rng = np.random.default_rng(3)
    vals = rng.lognormal(0.0, 1.0, size=(1000, 2, 3))
    vals[17, 1, 2] = np.inf                                  # a diverged run
    exact = mc.QuantileAccumulator(1000, (2, 3))
    hist = mc.QuantileAccumulator(1000, (2, 3), exact_limit=0)
    order = rng.permutation(np.arange(0, 1000, 100))
    for start in order:                                      # chunks in any order
        exact.add(start, vals[start:start + 100])
        hist.add(start, vals[start:start + 100])
    qe, qh = exact.quantiles(), hist.quantiles()
    tol = 10 ** (1 / (2 * mc.BINS_PER_DECADE)) - 1
    for j in range(2):
        for c in range(3):
            x = vals[:, j, c]
            for a, q in enumerate(mc.QUANTILES):
                ref = _naive_quantile(x, q)
                assert qe[a, j, c] == ref
                assert abs(qh[a, j, c] / ref - 1) <= tol * 1.0001
            assert qe[-1, j, c] == qh[-1, j, c] == x.max()
    assert np.isinf(qe[-1, 1, 2])
    whole = mc.QuantileAccumulator(1000, (2, 3), exact_limit=0)
    whole.add(0, vals)
    assert np.array_equal(whole.counts, hist.counts)


@pytest.fixture(scope="module")
def local_result(study):
    return mc.run_study(study, chunk=3)


@pytest.fixture(scope="module")
def clusters():
    """In-process LocalCluster of n single-threaded workers, created once per n."""
    distributed = pytest.importorskip("distributed", reason=_NO_DASK)
    made = {}

    def get(n):
        if n not in made:
            made[n] = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=False,
                                               dashboard_address=":0")
        return made[n]

    yield get
    for c in made.values():
        c.close()


@pytest.mark.parametrize("n_workers, chunk", [(1, None), (2, None), (2, 2), (1, 7), (2, 1)])
def test_dask_in_process_cluster_is_bit_identical(study, local_result, clusters, n_workers, chunk):
    distributed = pytest.importorskip("distributed", reason=_NO_DASK)
    with distributed.Client(clusters(n_workers)) as client:
        assert len(client.nthreads()) == n_workers
        remote = mc.run_study(study, client=client, chunk=chunk)
    assert np.array_equal(local_result.values, remote.values)
    assert np.array_equal(local_result.quantiles, remote.quantiles)
    assert np.array_equal(local_result.diverged, remote.diverged)


def test_dask_histogram_results_are_compact_and_equal_the_local_histogram(
        study, clusters, monkeypatch):
    distributed = pytest.importorskip("distributed", reason=_NO_DASK)
    monkeypatch.setattr(mc, "EXACT_VALUES", 0)       # workers return int16 bins, not values
    local = mc.run_study(study, chunk=7)
    start, (bins, mx, div) = mc._remote_chunk(study, 2, 5, False)
    _, values = mc.run_chunk(study, 2, 5)
    assert bins.dtype == np.int16 and np.array_equal(bins, mc.QuantileAccumulator.bins(values))
    assert np.array_equal(mx, values.max(axis=0)) and start == 2
    with distributed.Client(clusters(2)) as client:
        remote = mc.run_study(study, client=client, chunk=2)
    assert remote.values is None and not remote.exact
    assert np.array_equal(local.quantiles, remote.quantiles)
    assert np.array_equal(local.diverged, remote.diverged)


def test_batches_inside_a_chunk_do_not_change_the_bits(study, monkeypatch):
    _, whole = mc.run_chunk(study, 0, 7)
    monkeypatch.setattr(mc, "BATCH_SAMPLES", 1)      # one plant per batch-kernel call
    assert mc._batch_plants(study) == 1
    _, single = mc.run_chunk(study, 0, 7)
    assert np.array_equal(whole, single)


def test_metrics_equal_a_per_run_naive_reduction(study):
    """Vectorised metrics == the same formulas applied run by run (bit for bit)."""
    _, v = mc.run_chunk(study, 0, 3)
    from hammerstein.simulation import simulate_chain_batch
    for i in range(3):
        plant = mc.case_plant(study, i)
        for j, r in enumerate(study.references):
            y = simulate_chain_batch(study.compensator, [plant], [r])[0].outputs
            noise = np.random.default_rng([study.seed, i, j + 1]).standard_normal(y.shape)
            y = y + study.vary["noise"]["sd"] * noise
            P = study.period_samples[j]
            e = r[:, P:] - y[:, P:]
            ee = np.sqrt(np.sum(e ** 2, axis=0))
            expect = [np.sqrt(np.mean(e[0] ** 2)), np.max(np.abs(e[0])),
                      np.sqrt(np.mean(e[1] ** 2)), np.max(np.abs(e[1])),
                      np.sqrt(np.mean(ee ** 2)), ee.max()]
            assert v[i, j].tolist() == expect


@pytest.mark.parametrize("cases, workers", [(1, 1), (7, 2), (100, 1), (10_000, 2), (10 ** 6, 64)])
def test_auto_chunk_is_coarse_and_balanced(study, cases, workers):
    s = mc.MonteCarloStudy(**{**study.__dict__, "cases": cases})
    per_plant = sum(r.shape[1] + mc.RUN_COST_SAMPLES for r in s.references)
    c = mc.auto_chunk(s, workers)
    assert 1 <= c <= math.ceil(mc.TASK_SAMPLES / per_plant)             # at most ~one coarse task
    tasks = math.ceil(cases / c)
    if cases * per_plant >= mc.TASKS_PER_WORKER * workers * mc.TASK_SAMPLES:
        assert tasks >= mc.TASKS_PER_WORKER * workers                     # every worker busy
    assert c * per_plant >= min(mc.TASK_SAMPLES // 8, per_plant)          # never tiny tasks


@pytest.mark.parametrize("vary, expect", [
    ("gain = { relative_sd = 0.1 }", "sweeps[0].vary.gain"),
    ("weights = { relative_sd = -0.1 }", "sweeps[0].vary.weights"),
    ("weights = { relative_sd = 0.1, distribution = \"cauchy\" }", "sweeps[0].vary.weights"),
    ("noise = { level = 1 }", "sweeps[0].vary.noise"),
])
def test_bad_vary_tables_name_the_field(tmp_path, vary, expect):
    f = tmp_path / "bad.toml"
    f.write_text(STUDY.format(vary=vary))
    with pytest.raises(ScenarioError, match=expect.replace(".", r"\.").replace("[", r"\[").replace("]", r"\]")):
        validate_scenario(f)


def test_a_study_that_varies_nothing_is_refused_unless_its_loop_has_noise(tmp_path):
    """Nothing in [sweeps.vary] (or no table): every case would be the nominal plant, so
    the study is refused, naming the table and what it takes; with a [feedback] loop whose
    sensor is noisy (seeded per case) the cases differ and the study stands."""
    f = tmp_path / "none.toml"
    for vary in ("", None):
        text = STUDY.format(vary="")
        f.write_text(text if vary is not None else text.replace("[sweeps.vary]\n", ""))
        with pytest.raises(ScenarioError, match=r"sweeps\[0\]\.vary: nothing varies: each of "
                                                r"the 7 cases would be the nominal plant; give "
                                                r"one or more of weights, "):
            validate_scenario(f)
    loop = ('\n[feedback]\nsensor = { noise_nm = 10.0 }\n[feedback.axes.x]\nkind = "integral"\n'
            'crossover_hz = 60.0\n[feedback.axes.y]\nkind = "integral"\ncrossover_hz = 60.0\n')
    f.write_text(STUDY.format(vary="").replace("[sweeps.vary]\n", "") + loop)
    assert validate_scenario(f).studies[0].vary == {}


@pytest.mark.parametrize("edit, expect", [
    (lambda s: s.replace("[plant]", "[[cases]]\nname = \"x\"\ndrive = { kind = \"sine\", input = \"ux\", "
                         "amplitude = 1.0, frequency = 10.0 }\n[plant]"), "cases:"),
    (lambda s: s.replace("cases = 7", "cases = 0"), "sweeps[0].cases"),
    (lambda s: s.replace('preset = "rakotondrabe-2dof"', 'preset = "rakotondrabe-2dof"\ndynamics = false')
     + 'natural_frequency = { relative_sd = 0.1 }\n', "vary.natural_frequency"),
    (lambda s: s.replace('kind = "multivariable"', 'kind = "none"'), "compensator.kind"),
    (lambda s: s.replace("periods = 2 }", "periods = 2, frequency = 3.0 }"), "reference.frequency"),
])
def test_bad_studies_name_the_field(tmp_path, edit, expect):
    f = tmp_path / "bad.toml"
    f.write_text(edit(STUDY.format(vary="")))
    with pytest.raises(ScenarioError, match=expect.replace(".", r"\.").replace("[", r"\[").replace("]", r"\]")):
        validate_scenario(f)


@pytest.mark.parametrize("args", [["--workers", "0"], ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]])
def test_cli_rejects_bad_worker_options(tmp_path, capsys, args):
    from hammerstein.cli.main import main
    f = tmp_path / "s.toml"
    f.write_text(STUDY.format(vary=""))
    assert main(["run", str(f), "--out", str(tmp_path / "r"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--workers" in err[0]
    assert not (tmp_path / "r" / "mc").exists()


def test_cli_unreachable_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    from hammerstein.cli.main import main
    pytest.importorskip("distributed", reason=_NO_DASK)
    monkeypatch.setattr(mc, "SCHEDULER_TIMEOUT_S", 1)      # the same failure, 9 s sooner
    f = tmp_path / "s.toml"
    f.write_text(STUDY.format(vary=""))
    assert main(["run", str(f), "--out", str(tmp_path / "r"), "--scheduler", "tcp://127.0.0.1:9",
                 "-q"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "scheduler" in err[0]
    assert not (tmp_path / "r" / "mc").exists()


@pytest.mark.slow
def test_cli_two_local_workers_write_the_same_report(tmp_path):
    from hammerstein.cli.main import main
    f = tmp_path / "s.toml"
    f.write_text(STUDY.format(vary=VARY))
    assert main(["run", str(f), "--out", str(tmp_path / "a"), "--figures", "none", "-q"]) == 0
    assert main(["run", str(f), "--out", str(tmp_path / "b"), "--figures", "none", "-q",
                 "--workers", "2"]) == 0
    for name in ("metrics.csv", "montecarlo-mm.csv", "montecarlo-mm-cases.csv"):
        assert (tmp_path / "a" / "mc" / name).read_bytes() == (tmp_path / "b" / "mc" / name).read_bytes()
    # the report says what was varied in words, not as Python dicts, with no empty lines
    report = (tmp_path / "a" / "mc" / "report.md").read_text(encoding="utf-8")
    assert ("varied: weights: relative sd 5 % (normal), cross_coupling: relative sd 20 % "
            "(lognormal), natural_frequency: relative sd 5 % (uniform), damping_ratio: relative "
            "sd 20 % (normal), noise: sd 0.05 µm.") in report
    assert "{'" not in report and "## mm\n\n\n" not in report


def test_memory_of_a_huge_study_does_not_grow_with_the_cases():
    small, huge = mc.QuantileAccumulator(10, (20, 6)), mc.QuantileAccumulator(10 ** 9, (20, 6))
    assert huge.values is None and not huge.exact
    assert huge.counts.nbytes == small.counts.nbytes < 10 * 2 ** 20


def test_histogram_quantiles_of_a_study_match_its_exact_ones(study, monkeypatch):
    exact = mc.run_study(study)
    monkeypatch.setattr(mc, "EXACT_VALUES", 0)
    hist = mc.run_study(study, chunk=3)
    assert hist.values is None and not hist.exact
    tol = 10 ** (1 / (2 * mc.BINS_PER_DECADE)) - 1
    np.testing.assert_allclose(hist.quantiles[:-1], exact.quantiles[:-1], rtol=tol * 1.0001)
    assert np.array_equal(hist.quantiles[-1], exact.quantiles[-1])


@pytest.mark.slow
def test_cli_on_a_scheduler_and_two_workers_started_by_hand(tmp_path):
    """As the README shows: `dask scheduler` + two `dask worker` processes, then --scheduler."""
    import json
    import os
    import subprocess
    import sys
    import time
    from pathlib import Path
    import hammerstein
    from hammerstein.cli.main import main
    pytest.importorskip("distributed", reason=_NO_DASK)
    # this interpreter's dask (python -m, not a `dask` script that may belong to another
    # Python), this checkout's hammerstein, loopback only
    root = str(Path(hammerstein.__file__).resolve().parents[1])
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    sched_file = tmp_path / "scheduler.json"
    log = open(tmp_path / "dask.log", "w")
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                               "--scheduler-file", str(sched_file), "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard"],
                              env=env, stdout=log, stderr=log)]
    try:
        t0 = time.monotonic()
        while not sched_file.exists() and time.monotonic() - t0 < 60:
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        procs += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                    "--host", "127.0.0.1", "--nthreads", "1", "--no-dashboard",
                                    "--local-directory", str(tmp_path / f"w{k}")],
                                   env=env, stdout=log, stderr=log)
                  for k in range(2)]
        f = tmp_path / "s.toml"
        f.write_text(STUDY.format(vary=VARY).replace("cases = 7", "cases = 40\nchunk = 3"))
        assert main(["run", str(f), "--out", str(tmp_path / "a"), "--figures", "none", "-q"]) == 0
        assert main(["run", str(f), "--out", str(tmp_path / "b"), "--figures", "none", "-q",
                     "--scheduler", address]) == 0
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=60)
        log.close()
    for name in ("metrics.csv", "montecarlo-mm.csv", "montecarlo-mm-cases.csv"):
        assert (tmp_path / "a" / "mc" / name).read_bytes() == (tmp_path / "b" / "mc" / name).read_bytes()
    # the report says what was varied in words, not as Python dicts, with no empty lines
    report = (tmp_path / "a" / "mc" / "report.md").read_text(encoding="utf-8")
    assert ("varied: weights: relative sd 5 % (normal), cross_coupling: relative sd 20 % "
            "(lognormal), natural_frequency: relative sd 5 % (uniform), damping_ratio: relative "
            "sd 20 % (normal), noise: sd 0.05 µm.") in report
    assert "{'" not in report and "## mm\n\n\n" not in report


@pytest.mark.parametrize("amplitude, expect", [(20.0, 0), (500.0, 1)])
def test_range_warning_is_reported_once_per_study_not_per_case(tmp_path, amplitude, expect):
    f = tmp_path / "s.toml"
    f.write_text(STUDY.format(vary="noise = { sd = 0.01 }").replace("amplitude = 20.0",
                                                                  f"amplitude = {amplitude}"))
    res, = mc.run_montecarlo_scenario(validate_scenario(f))
    beyond = [w for w in res.warnings if "beyond the range" in w]
    assert len(beyond) == expect                             # 7 cases x 2 frequencies: one line
    # and the rate-independent kind at 50 and 120 Hz on a plant whose first mode is at 290 Hz:
    # one line per frequency, as a frequency sweep says it
    rate = [w for w in res.warnings if "is rate independent" in w]
    assert [w.split(": ")[1].split(" the plant's")[0] for w in rate] == ["at 50 Hz", "at 120 Hz"]
    assert len(res.warnings) == len(beyond) + len(rate)


@pytest.mark.parametrize("fn, zeta, T", [
    ([900.0, 1100.0], [0.05, 0.2], 1e-4), ([10.0, 3000.0], [1.0, 0.999999], 1e-5),
    ([50.0, 200.0], [0.01, 0.7], 1e-3), ([2000.0, 1.0], [2.5, 1.000001], 2e-5),
    ([5000.0, 5000.0], [0.3, 1.0], 1e-3)])
def test_closed_form_zoh_equals_the_matrix_exponential(fn, zeta, T):
    """sampled_modes == expm(T [[A, B], [0, 0]]) of the continuous modes (overdamped too)."""
    from hammerstein.models.dynamics import sampled_bending_modes, zoh
    fn, zeta = np.array(fn), np.array(zeta)
    p = len(fn)
    A, B = np.zeros((2 * p, 2 * p)), np.zeros((2 * p, p))
    for l in range(p):
        w = 2 * math.pi * fn[l]
        A[2 * l:2 * l + 2, 2 * l:2 * l + 2] = [[0.0, w], [-w, -2 * zeta[l] * w]]
        B[2 * l + 1, l] = w
    Ad, Bd = zoh(A, B, T)
    nominal = sampled_bending_modes([100.0] * p, [0.1] * p, None, T)
    got = mc.sampled_modes(fn, zeta, T, nominal)
    scale = max(1.0, np.abs(np.hstack([Ad, Bd])).max())
    assert np.abs(got.A - Ad).max() <= 2e-15 * scale
    assert np.abs(got.B - Bd).max() <= 2e-15 * scale
    assert np.array_equal(got.C, nominal.C) and got.dt == T and got.outputs == nominal.outputs
    if np.all(zeta <= 1):                                   # the project's own ZOH
        ref = sampled_bending_modes(fn, zeta, None, T)
        assert np.abs(got.A - ref.A).max() <= 2e-15 * scale


def test_an_overdamped_drawn_mode_runs(tmp_path, monkeypatch):
    """A damping factor taking a mode above zeta = 1 is an overdamped mode, not an error (a
    spread beyond what validate accepts, to reach it with seven cases)."""
    from hammerstein.scenario import montecarlo_spec
    monkeypatch.setitem(montecarlo_spec.MAX_RELATIVE_SD, "normal", 100.0)
    s = _study(tmp_path, vary="damping_ratio = { relative_sd = 60.0 }")
    zetas = [s.modes[1] * mc.draw_factors(s, i)["damping_ratio"] for i in range(s.cases)]
    assert max(z.max() for z in zetas) > 1.0
    res = mc.run_study(s)
    assert np.all(np.isfinite(res.quantiles))


def test_a_study_beyond_the_sample_budget_is_refused_at_validation(tmp_path, repo_root, monkeypatch):
    # 2e7 cases of the bundled study's four references (8e7 runs, within the run budget):
    # ~1e12 samples, hours of CPU, refused
    # while validating, naming the budget and its override; within a raised budget it passes
    text = (repo_root / "scenarios" / "robustness-monte-carlo.toml").read_text()
    assert "cases = 40\n" in text
    big = tmp_path / "big.toml"
    big.write_text(text.replace("cases = 40\n", "cases = 20000000\n"))
    with pytest.raises(ScenarioError) as info:
        validate_scenario(big)
    assert mc.STUDY_SAMPLES_ENV in str(info.value) and "cases" in str(info.value)
    small = tmp_path / "small.toml"
    small.write_text(text)
    monkeypatch.setenv(mc.STUDY_SAMPLES_ENV, "10")
    with pytest.raises(ScenarioError, match=mc.STUDY_SAMPLES_ENV):
        validate_scenario(small)
    monkeypatch.delenv(mc.STUDY_SAMPLES_ENV)
    validate_scenario(small)


@pytest.mark.parametrize("vary, words", [
    ("weights = { relative_sd = 50.0 }", "from 0 to 1 for a normal factor"),
    ('cross_coupling = { relative_sd = 1e6, distribution = "lognormal" }',
     "from 0 to 10 for a lognormal factor"),
    ("noise = { sd = 1e9 }", "sensor noise sd from 0 to 1000 µm"),
])
def test_a_spread_no_actuator_has_is_refused(tmp_path, vary, words):
    # an outside check: 5000 %, 1e+08 % and 1e9 µm ran, and the report quoted them
    with pytest.raises(ScenarioError, match=words):
        _study(tmp_path, vary=vary)


def test_a_drawn_plant_keeps_the_nominal_plant_s_units(tmp_path):
    """A plant preset in mV and nm ([model] input_unit, output_unit): every drawn plant is in
    them too (they were dropped, the drawn plants said V and µm)."""
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text(encoding="utf-8")
    assert text.count('input_unit = "V"\n') == 1 and text.count('output_unit = "µm"\n') == 1
    (tmp_path / "p.toml").write_text(text.replace('input_unit = "V"\n', 'input_unit = "mV"\n')
                                     .replace('output_unit = "µm"\n', 'output_unit = "nm"\n'),
                                     encoding="utf-8")
    (tmp_path / "s.toml").write_text(STUDY.format(vary=VARY).replace(
        'preset = "rakotondrabe-2dof"', 'preset = "p.toml"'), encoding="utf-8")
    study = validate_scenario(tmp_path / "s.toml").studies[0]
    assert study.plant.units == ("mV", "nm")
    for i in (0, 3):
        assert mc.case_plant(study, i).units == ("mV", "nm")
