"""Figure jobs drawn in the worker pool: same files as inline, errors become the scenario's error."""

import os
from pathlib import Path

import numpy as np
import pytest

from hammerstein.report import figures as plots
from hammerstein.report import trajectories
from hammerstein.report.render import FigureJob, FigureJobs, FigureRenderer, job_key
from hammerstein.runner import TMP_PREFIX, run_pipelined

ROOT = Path(__file__).resolve().parents[2]


def _failing_figure(*args, **kwargs):  # module level: the pool pickles it by reference
    raise ValueError("the legend does not fit")


def _loop_jobs(directory, jobs):
    th = np.linspace(0, 2 * np.pi, 101)
    for k in range(3):
        curves = [{"label": "c", "column": 0, "x": 10 * np.sin(th),
                   "outputs": np.vstack([5 * np.sin(th + 0.2 * k), 0.1 * np.cos(th)])}]
        jobs.add(directory / f"loop-{k}.png", plots.loop_grid, curves, ["u1 [V]", "u2 [V]"],
                 ["x [µm]", "y [µm]"], f"loop {k}")


def test_pool_writes_the_same_pngs_as_inline(tmp_path):
    (tmp_path / "inline").mkdir()
    (tmp_path / "pool").mkdir()
    _loop_jobs(tmp_path / "inline", FigureJobs())
    with FigureRenderer(workers=2) as renderer:
        jobs = FigureJobs(renderer)
        _loop_jobs(tmp_path / "pool", jobs)
        jobs.wait()
    for k in range(3):
        a = (tmp_path / "inline" / f"loop-{k}.png").read_bytes()
        assert a[:8] == b"\x89PNG\r\n\x1a\n"
        assert a == (tmp_path / "pool" / f"loop-{k}.png").read_bytes()


def test_worker_error_raised_after_every_job_finished(tmp_path):
    with FigureRenderer(workers=2) as renderer:
        jobs = FigureJobs(renderer)
        _loop_jobs(tmp_path, jobs)
        jobs.add(tmp_path / "bad.png", _failing_figure)
        with pytest.raises(ValueError, match="legend does not fit"):
            jobs.wait()
        assert jobs.done()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loop-0.png", "loop-1.png", "loop-2.png"]


@pytest.mark.figure_pool
def test_failed_figure_is_the_scenarios_one_line_error(tmp_path, monkeypatch):
    monkeypatch.setattr(trajectories, "trajectory_figure", _failing_figure)
    outcomes = run_pipelined([ROOT / "scenarios" / "default.toml"], tmp_path)
    (o,) = outcomes
    assert not o.ok and "the legend does not fit" in o.error and "\n" not in o.error
    # nothing half written: no report directory, no temporary left
    assert not any(p.name == o.name or p.name.startswith(TMP_PREFIX) for p in tmp_path.iterdir())


@pytest.mark.figure_pool
@pytest.mark.skipif(not hasattr(os, "fork"), reason="the pool needs fork")
def test_pipelined_run_writes_every_figure_in_place(tmp_path):
    outcomes = run_pipelined([ROOT / "scenarios" / "default.toml"], tmp_path)
    (o,) = outcomes
    assert o.ok, o.error
    pngs = sorted(p.name for p in o.out_dir.glob("*.png"))
    assert pngs and all((o.out_dir / n).stat().st_size > 1000 for n in pngs)
    text = (o.out_dir / "report.md").read_text(encoding="utf-8")
    assert all(f"({n})" in text for n in pngs)           # every figure the report names exists
    assert not any(p.name.startswith(TMP_PREFIX) for p in tmp_path.iterdir())


CALLS = []


def _counted_loop(*args, **kwargs):  # module level: picklable by reference
    CALLS.append(args[-1])
    return plots.loop_grid(*args, **kwargs)


def _curves(k=0):
    th = np.linspace(0, 2 * np.pi, 101)
    return [{"label": "c", "column": 0, "x": 10 * np.sin(th),
             "outputs": np.vstack([5 * np.sin(th + 0.2 * k), 0.1 * np.cos(th)])}]


@pytest.mark.parametrize("workers", [0, 2])
def test_equal_jobs_are_drawn_once_and_copied(tmp_path, workers):
    CALLS.clear()
    names = (["u1 [V]", "u2 [V]"], ["x [µm]", "y [µm]"])
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    with FigureRenderer(workers=workers) as renderer:
        first, second = FigureJobs(renderer), FigureJobs(renderer)   # two report directories
        first.add(tmp_path / "a" / "loop.png", _counted_loop, _curves(), *names, "same")
        second.add(tmp_path / "b" / "loop.png", _counted_loop, _curves(), *names, "same")
        second.add(tmp_path / "b" / "other.png", _counted_loop, _curves(1), *names, "other")
        first.wait()
        second.wait()
    a = (tmp_path / "a" / "loop.png").read_bytes()
    assert a[:8] == b"\x89PNG\r\n\x1a\n" and a == (tmp_path / "b" / "loop.png").read_bytes()
    assert a != (tmp_path / "b" / "other.png").read_bytes()
    if workers == 0:                 # drawn in this process: the calls are seen here
        assert CALLS == ["same", "other"]


def test_job_key_tells_arguments_apart():
    names = (["u1 [V]", "u2 [V]"], ["x [µm]", "y [µm]"])
    key = job_key(FigureJob(Path("a.png"), plots.loop_grid, (_curves(), *names, "t")))
    assert key == job_key(FigureJob(Path("b.png"), plots.loop_grid, (_curves(), *names, "t")))
    assert key != job_key(FigureJob(Path("a.png"), plots.loop_grid, (_curves(1), *names, "t")))
    assert key != job_key(FigureJob(Path("a.png"), plots.loop_grid, (_curves(), *names, "u")))
    assert key != job_key(FigureJob(Path("a.png"), _counted_loop, (_curves(), *names, "t")))
    assert job_key(FigureJob(Path("a.png"), plots.loop_grid, (lambda: 0,))) is None


@pytest.mark.parametrize("workers", [0, 2])
def test_a_copy_fails_with_the_drawing_it_copies(tmp_path, workers):
    with FigureRenderer(workers=workers) as renderer:
        first, second = FigureJobs(renderer), FigureJobs(renderer)
        first.add(tmp_path / "bad-1.png", _failing_figure, 1)
        second.add(tmp_path / "bad-2.png", _failing_figure, 1)
        for jobs in (first, second):
            with pytest.raises(ValueError, match="legend does not fit"):
                jobs.wait()
    assert not any(tmp_path.iterdir())


def _gated_loop(gate, *args, **kwargs):  # keeps a worker busy until the test opens the gate
    import time
    deadline = time.monotonic() + 120.0   # a test that forgot the gate fails instead of hanging
    while not Path(gate).exists():
        if time.monotonic() > deadline:
            raise TimeoutError(f"the gate {gate} was never opened")
        time.sleep(0.005)
    return plots.loop_grid(*args, **kwargs)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the pool needs fork")
def test_a_copy_is_drawn_when_the_report_it_copies_is_abandoned(tmp_path):
    from concurrent.futures.process import EXTRA_QUEUED_CALLS
    names = (["u1 [V]", "u2 [V]"], ["x [µm]", "y [µm]"])
    for d in ("busy", "a", "b"):
        (tmp_path / d).mkdir()
    gate = tmp_path / "gate"
    workers = 2
    try:
        with FigureRenderer(workers=workers) as renderer:
            busy = FigureJobs(renderer)
            # every worker and every slot of the pool's call queue holds a job that waits for the
            # gate, so a job added now stays pending (cancellable) however loaded the machine is
            for k in range(2 * workers + EXTRA_QUEUED_CALLS):
                busy.add(tmp_path / "busy" / f"{k}.png", _gated_loop, str(gate), _curves(k), *names,
                         f"busy {k}")
            a, b = FigureJobs(renderer), FigureJobs(renderer)
            a.add(tmp_path / "a" / "loop.png", plots.loop_grid, _curves(), *names, "same")
            b.add(tmp_path / "b" / "loop.png", plots.loop_grid, _curves(), *names, "same")
            a.cancel(wait=False)                      # report a abandoned before its figure started
            assert all(f.cancelled() for f in a._futures)
            gate.touch()                              # the busy jobs may finish now
            a.cancel()                                # (returns once the pool has dropped a's job)
            b.wait()
            busy.wait()
    finally:
        gate.touch()                              # never leave a worker waiting
    assert not (tmp_path / "a" / "loop.png").exists()
    assert len(list((tmp_path / "busy").iterdir())) == 2 * workers + EXTRA_QUEUED_CALLS
    assert (tmp_path / "b" / "loop.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


LATE_MODULE = "hammerstein_test_late_import"


def _module_seen(report, *args, **kwargs):  # module level: the pool pickles it by reference
    """Write whether this process has run LATE_MODULE's code; draw a tiny figure."""
    import sys
    import types
    module = sys.modules.get(LATE_MODULE)
    Path(report).write_text(str(type(module) is types.ModuleType and module.LOADED))
    return plots.loop_grid(_curves(), ["u1 [V]", "u2 [V]"], ["x [µm]", "y [µm]"], "late")


def _module_needed(report, *args, **kwargs):
    return _module_seen(report)


_module_needed.imports = (LATE_MODULE,)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the pool needs fork")
def test_a_job_needing_a_module_loaded_after_the_fork_gets_a_worker_that_has_it(tmp_path,
                                                                                 monkeypatch):
    import importlib
    import sys
    (tmp_path / f"{LATE_MODULE}.py").write_text("LOADED = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        with FigureRenderer(workers=2) as renderer:
            jobs = FigureJobs(renderer)
            _loop_jobs(tmp_path, jobs)                     # forks the pool: the module not loaded
            importlib.import_module(LATE_MODULE)           # loaded since, in this process only
            jobs.add(tmp_path / "plain.png", _module_seen, str(tmp_path / "plain.txt"))
            jobs.add(tmp_path / "needs.png", _module_needed, str(tmp_path / "needs.txt"))
            jobs.wait()
    finally:
        sys.modules.pop(LATE_MODULE, None)
    assert (tmp_path / "plain.txt").read_text() == "False"     # a worker forked before the import
    assert (tmp_path / "needs.txt").read_text() == "True"      # the late worker inherited it
    assert (tmp_path / "needs.png").read_bytes() == (tmp_path / "plain.png").read_bytes()
