"""The figure pool's size: one worker is a pool too (forked, same PNGs as inline)."""

import os
from pathlib import Path

import numpy as np
import pytest

from hammerstein.report import figures as plots
from hammerstein.report import render
from hammerstein.report.render import FigureJobs, FigureRenderer


def _loop_in(pid_file, k):  # module level: the pool pickles it by reference
    Path(pid_file).write_text(str(os.getpid()))
    th = np.linspace(0, 2 * np.pi, 101)
    curves = [{"label": "c", "column": 0, "x": 10 * np.sin(th),
               "outputs": np.vstack([5 * np.sin(th + 0.2 * k), 0.1 * np.cos(th)])}]
    return plots.loop_grid(curves, ["u1 [V]", "u2 [V]"], ["x [µm]", "y [µm]"], f"loop {k}")


@pytest.mark.figure_pool
@pytest.mark.skipif(not hasattr(os, "fork"), reason="the pool needs fork")
@pytest.mark.parametrize("workers", [0, 1])
def test_one_worker_draws_in_another_process_the_same_pngs(tmp_path, workers):
    inline, drawn = tmp_path / "inline", tmp_path / f"w{workers}"
    inline.mkdir()
    drawn.mkdir()
    plain = FigureJobs()
    for k in range(2):
        plain.add(inline / f"loop-{k}.png", _loop_in, str(inline / f"pid-{k}"), k)
    with FigureRenderer(workers=workers) as renderer:
        jobs = FigureJobs(renderer)
        for k in range(2):
            jobs.add(drawn / f"loop-{k}.png", _loop_in, str(drawn / f"pid-{k}"), k)
        jobs.wait()
    pids = {int((drawn / f"pid-{k}").read_text()) for k in range(2)}
    if workers == 0:
        assert pids == {os.getpid()}
    else:
        assert len(pids) == 1 and os.getpid() not in pids      # one worker drew both
    for k in range(2):
        assert (inline / f"loop-{k}.png").read_bytes() == (drawn / f"loop-{k}.png").read_bytes()


def test_default_workers_leave_a_core_to_the_main_process():
    cores = render._usable_cores()
    assert cores >= 1
    assert 1 <= render.WORKERS <= 2
    assert render.WORKERS <= max(1, cores - 1)
    assert FigureRenderer().workers in (0, render.WORKERS)       # 0 where fork is unavailable


def test_job_key_depends_on_array_values_not_memory_layout():
    from hammerstein.report.render import FigureJob, job_key
    a = np.arange(12.0).reshape(3, 4)
    f = np.asfortranarray(a)
    assert f.flags.f_contiguous and not f.flags.c_contiguous

    def key(*args, **kwargs):
        return job_key(FigureJob(Path("x.png"), plots.loop_grid, args, kwargs))
    assert key({"C": a}, [a]) == key({"C": f}, [f])                 # cached vs fresh identification
    assert key(a[:, ::2]) == key(np.ascontiguousarray(a[:, ::2]))  # strided view
    assert key(a) != key(a.reshape(4, 3))                           # same bytes, other shape
    assert key(a) != key(a.astype(np.float32))                      # other dtype
    b = a.copy()
    b[2, 3] = np.nextafter(b[2, 3], 20.0)
    assert key(a) != key(b)                                          # one value, one ulp apart
    assert key(k=a) != key(a)                                        # keyword vs positional
    objects = np.array([1, "a"], dtype=object)                       # pickled as numpy does
    assert key(objects) == key(objects.copy())
