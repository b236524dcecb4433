"""Figure jobs drawn in the worker pool: same files as inline, errors become the scenario's error."""

import os
from pathlib import Path

import numpy as np
import pytest

from hammerstein.report import figures as plots
from hammerstein.report.render import FigureJobs, FigureRenderer
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
        assert not any((tmp_path / "pool").iterdir())   # queued, not drawn yet
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


def test_failed_figure_is_the_scenarios_one_line_error(tmp_path, monkeypatch):
    monkeypatch.setattr(plots, "trajectory_figure", _failing_figure)
    outcomes = run_pipelined([ROOT / "scenarios" / "default.toml"], tmp_path)
    (o,) = outcomes
    assert not o.ok and "the legend does not fit" in o.error and "\n" not in o.error
    # nothing half written: no report directory, no temporary left
    assert not any(p.name == o.name or p.name.startswith(TMP_PREFIX) for p in tmp_path.iterdir())


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
