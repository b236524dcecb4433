"""Time every figure function of the reports on representative data.

Run: ``python benchmarks/figures.py [--repeat N]`` (from the repository root).

Not a test: it prints one row per figure function with the time to build the
figure (the function call: plotting and layout), to write it (``savefig`` as
the reports do, PNG at :data:`hammerstein.report.figures.DPI`) and the total,
best of ``--repeat`` runs, in milliseconds of wall time, and the CPU time of
the process (steadier than the wall time on a shared machine). The data imitate the bundled
scenarios (T = 50 µs): loop grids of one 50 Hz period (401 samples) with 8
curves, trajectory figures of 80 ms (circle, 1600 samples) and 1 s (20 000
samples, decimated to :data:`hammerstein.report.figures.MAX_POINTS` per
line), the XY overlay of four circles, the Fig. 6 model grid, the Fig. 7
model-error and Fig. 9 sweep grids (6 compensators x 15 frequencies), the
stability map, the record-fit figure of a 20 000-sample record, the error map
of a 64-line raster scan and the Bode plot of identified against true 2x2
dynamics (python-control, 300 frequencies).

The paper run (``hammerstein run scenarios/paper/*.toml``) writes about 25
figures; the sum of the totals below for its mix is the plotting part of its
wall time. Other processes on the machine inflate the numbers (the load
average is printed).

``--encoding`` draws every figure once and prints, for the PNG encodings
:func:`hammerstein.report.figures.save` could use (RGBA as matplotlib's
``savefig`` writes it, or RGB: the canvas is opaque; zlib levels 1, 3, 6),
the CPU time to encode all of them and their total size.

``--phases`` draws every figure once to warm the caches, then once more and
prints where the CPU goes (inclusive process time summed over the figures):
building, drawing, and within the drawing the tick objects created, the tick
updates, the text drawn, the axis-label placement; then the PNG encoding.
It times with ``time.process_time`` around those matplotlib methods rather
than with cProfile, whose per-call overhead inflates functions made of many
tiny calls (cProfile put 1.6 s of the paper run on the 5 184 deep copies of
tick markers that take 0.11 s).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

# As the CLI: one OpenBLAS thread, so that identifications run by --paper (and cached
# on disk) are the ones `hammerstein run` computes, to the last digit.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hammerstein.models.dynamics import bending_modes, discretize  # noqa: E402
from hammerstein.signals.references import raster_line_index  # noqa: E402
from hammerstein.report import figures as plots  # noqa: E402
from hammerstein.report import trajectories  # noqa: E402
from hammerstein.report import model_figures  # noqa: E402
from hammerstein.report.dynamics_figure import dynamics_bode_figure  # noqa: E402

try:  # the sweep figures moved from scenario/ to report/
    from hammerstein.report import sweeps as sweep_figs  # noqa: E402
except ImportError:  # pragma: no cover
    from hammerstein.scenario import sweeps as sweep_figs  # noqa: E402

T = 50e-6


def _loop(n=401, amp=10.0, gain=5.8, width=0.17, phase=0.0):
    th = np.linspace(0, 2 * np.pi, n)
    u = amp * np.sin(th)
    return u, gain * u + width * gain * amp * np.cos(th + phase)


def _loop_curves(n_per_column=4, outputs=2):
    curves = []
    for k in range(2):
        for i in range(n_per_column):
            u, y = _loop(phase=0.1 * i)
            outs = np.vstack([y if l == k else 0.03 * y for l in range(outputs)])
            curves.append({"label": f"case-{k}-{i}", "column": k, "x": u, "outputs": outs})
    return curves


def _trajectory(n, radius=30.0, f=50.0):
    t = np.arange(n) * T
    r = np.vstack([radius * np.cos(2 * np.pi * f * t), radius * np.sin(2 * np.pi * f * t)])
    y = 1.05 * r + 0.5 * np.sin(2 * np.pi * 150 * t) + 5 * np.exp(-t / 0.004)
    u = r / 5.8
    return t, r, y, u


def cases():
    """[(name, builder)]: each builder returns a new Figure."""
    names_in, names_out = ["ux [V]", "uy [V]"], ["x [µm]", "y [µm]"]
    out = [("loop_grid (2x2, 8 curves of 401 samples)",
            lambda: plots.loop_grid(_loop_curves(), names_in, names_out, "open-loop maps")),
           ("loop_grid (one driven input: 2x1)",
            lambda: plots.loop_grid([c for c in _loop_curves() if c["column"] == 0], names_in,
                                    names_out, "compensated maps"))]
    for n, what in ((1600, "circle, 80 ms"), (20000, "1 s record, decimated")):
        t, r, y, u = _trajectory(n)
        out.append((f"trajectory_figure ({what}: {n} samples)",
                    lambda t=t, r=r, y=y, u=u: trajectories.trajectory_figure(
                        t, r, y, ["x", "y"], "trajectory", settle_time=0.04, inputs=u,
                        input_names=["ux", "uy"])))
    circles = []
    for i, R in enumerate((15.0, 30.0, 50.0, 50.0)):
        _, r, y, _ = _trajectory(800, radius=R)
        circles.append({"label": f"circle-{i}", "reference": r, "outputs": y})
    out.append(("xy_overlay (4 circles of 800 samples)",
                lambda: trajectories.xy_overlay(circles, ["x", "y"], "all trajectories")))
    u = np.zeros((2, 9))
    u[0] = 0.8 * 8.0 ** np.arange(9)
    u[1] = 0.1 * 8.0 ** np.arange(9)
    out.append(("divergence_figure (8 samples)",
                lambda: trajectories.divergence_figure(u, ["ux", "uy"], 8, "|U| exceeds the bound",
                                                "diverged")))
    mcurves = [{"label": c["label"], "column": c["column"], "x": c["x"], "plant": c["outputs"],
                "model": 0.98 * c["outputs"]} for c in _loop_curves(2)]
    out.append(("model_loop_grid (2x2, 4 cases plant + model)",
                lambda: model_figures.model_loop_grid(mcurves, names_in, names_out,
                                                      "model vs plant")))
    f = np.array([10, 20, 30, 40, 50, 60, 75, 100, 125, 150, 175, 200, 250, 300, 350, 420.0])
    rows = [{"input": i, "output": o, "frequency_hz": fr,
             "model_rms_error": 0.1 + abs(fr - 50) / 10} for i in ("ux", "uy") for o in ("x", "y")
            for fr in f]
    table = pd.DataFrame(rows)
    out.append(("rms_vs_frequency_figure (2x2, 16 frequencies)",
                lambda: model_figures.rms_vs_frequency_figure(table, ["ux", "uy"], ["x", "y"],
                                                              "model error", 50.0)))
    comps = [f"mv-{k}Hz" for k in (50, 100, 150, 200)] + ["per-axis-50Hz", "static-gain-50Hz"]
    srows = [{"frequency_hz": fr, "compensator": c, "axis": a, "channel": ch,
              "rms_error": 0.1 * (j + 1) + fr / 100.0}
             for j, c in enumerate(comps) for a in ("x", "y") for ch in ("x", "y") for fr in f[:15]]
    stable = pd.DataFrame(srows)
    spec = SimpleNamespace(metric="rms_error", axes=["x", "y"], mode="reference", name="rms")
    out.append(("sweep_figure (2x2, 6 compensators x 15 frequencies)",
                lambda: sweep_figs.sweep_figure(stable, spec, ["x", "y"], "sweep")))
    s = np.geomspace(0.05, 20, 81)
    smap = pd.DataFrame([{"compensator": c, "scale": v, "max_radius": abs(1 - 1 / v) + 0.1 * j}
                         for j, c in enumerate(("paper", "id50", "id200", "diag")) for v in s])
    smap.attrs["laws"] = {c: {"literal_scale": 0.2, "literal_max_radius": 9.0,
                              "normalised_max_radius": 0.7} for c in ("paper", "id50", "id200", "diag")}
    out.append(("stability_figure (4 compensators x 81 scales)",
                lambda: sweep_figs.stability_figure(smap, "stability map")))
    n = 20000
    tt = np.arange(n) * 1e-3
    uu = 75 + 75 * np.sin(2 * np.pi * tt)
    yy = 0.26 * uu + 2 * np.cos(2 * np.pi * tt)
    out.append((f"record_fit_figure ({n} samples)",
                lambda: model_figures.record_fit_figure(tt, uu, yy, yy + 0.05, 100, 12000,
                                                        "u [V]", "y [µm]", "record fit")))
    lines, f_fast = 64, 50.0                      # 64 lines of a 50 Hz fast axis: 25 600 samples
    tr = np.arange(int(round(lines / f_fast / T))) * T
    cycles = tr * f_fast
    fast = 40.0 * (1 - np.abs(2 * np.mod(cycles, 1.0) - 1))          # triangle, 0..40 µm
    err = np.vstack([0.3 * np.sin(2 * np.pi * 3 * cycles), 0.1 * np.cos(2 * np.pi * cycles)])
    out.append((f"raster_error_map ({lines} lines, {tr.size} samples)",
                lambda: trajectories.raster_error_map(fast, err, ["x_r - x (fast)", "y_r - y (slow)"],
                                               raster_line_index(tr, f_fast),
                                               np.mod(cycles, 1.0) < 0.5, 40.0, "x", "raster")))
    G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2], ["x", "y"]), T)
    out.append(("dynamics_bode_figure (2x2, 300 frequencies)",
                lambda: dynamics_bode_figure(G, G, title="identified vs true")))
    return out


def encodings(repeat):
    """Print CPU time and size of every figure's PNG per encoding (mode, zlib level)."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    images = []
    for _, build in cases():
        fig = build()
        plots._ticks_in_view(fig)
        fig.set_dpi(plots.DPI)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        images.append(Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(),
                                       "raw", "RGBA", 0, 1).copy())
        plots.plt.close(fig)
    print(f"{len(images)} figures, {sum(i.width * i.height for i in images) / 1e6:.1f} Mpixel; "
          f"encoding CPU best of {repeat}")
    print(f"{'mode':<6} {'zlib level':>10} {'cpu [ms]':>9} {'size [kB]':>10}")
    for mode in ("RGBA", "RGB"):
        for level in (1, 3, 6):
            best = None
            for _ in range(repeat):
                c0, size = time.process_time(), 0
                for image in images:
                    out = io.BytesIO()
                    (image if mode == "RGBA" else image.convert("RGB")).save(
                        out, format="png", compress_level=level)
                    size += out.tell()
                cpu = time.process_time() - c0
                best = cpu if best is None else min(best, cpu)
            print(f"{mode:<6} {level:>10} {best * 1e3:9.1f} {size / 1e3:10.0f}")


def phases(paper_run=False):
    """Print the CPU time of every drawing phase summed over the figures (see the module doc).

    Parameters
    ----------
    paper_run : bool
        Time the figures of the paper run (:func:`paper_jobs`) instead of
        the representative ones of :func:`cases`.
    """
    import io
    from collections import defaultdict

    import matplotlib.axis as maxis
    import matplotlib.text as mtext
    from matplotlib.axes import Axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    spent, depth = defaultdict(float), defaultdict(int)

    def timed(owner, name, key):
        original = getattr(owner, name)

        def wrapper(*args, **kwargs):
            depth[key] += 1
            c0 = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                depth[key] -= 1
                if depth[key] == 0:                     # outermost call only (no double count)
                    spent[key] += time.process_time() - c0
        setattr(owner, name, wrapper)
        return original

    keys = [(FigureCanvasAgg, "draw", "draw (all below and lines, patches)"),
            (maxis.Tick, "__init__", "  tick objects created"),
            (maxis.Axis, "_update_ticks", "  tick locations, labels, positions"),
            (maxis.XAxis, "_update_label_position", "  axis label placement (x)"),
            (maxis.YAxis, "_update_label_position", "  axis label placement (y)"),
            (mtext.Text, "draw", "  text drawn"),
            (plots._TextCachingRenderer, "draw_text", "    glyphs laid out and rasterised"),
            (mtext.Text, "_get_layout", "    text measured (layout)"),
            (Axes, "__init__", "axes created (build and draw)"),
            (Image.Image, "save", "PNG encoding")]
    if paper_run:
        builders = [(job.path.name, (lambda job=job: job.function(*job.args, **job.kwargs)))
                    for _, job in paper_jobs()]
    else:
        builders = cases()
    for _, build in builders:                           # warm: fonts, mathtext, caches
        plots.save(build(), io.BytesIO())
    originals = [(owner, name, timed(owner, name, key)) for owner, name, key in keys]
    try:
        c0, total = time.process_time(), 0.0
        for _, build in builders:
            fig = build()
            spent["build (figure function)"] += time.process_time() - c0
            plots.save(fig, io.BytesIO())
            total += time.process_time() - c0
            c0 = time.process_time()
    finally:
        for owner, name, original in originals:
            setattr(owner, name, original)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{len(builders)} figures, CPU per phase (inclusive, ms); load average {load:.2f}")
    for key in ["build (figure function)"] + [k for _, _, k in keys]:
        print(f"{key:<44} {spent[key] * 1e3:8.1f} {100 * spent[key] / total:5.1f} %")
    print(f"{'total':<44} {total * 1e3:8.1f}")


def paper_jobs(scenarios=None):
    """The figure jobs of ``hammerstein run scenarios/paper/*.toml``, each drawn once.

    Runs the scenarios (into a temporary directory) with a renderer that
    records the jobs instead of drawing them; jobs equal by
    :func:`hammerstein.report.render.job_key` (which the run's renderer
    copies instead of drawing) are kept once.

    Parameters
    ----------
    scenarios : list of str, optional
        Scenario files (default: ``scenarios/paper/*.toml``).

    Returns
    -------
    list of (str, hammerstein.report.render.FigureJob)
        The scenario file's stem and the job.
    """
    from concurrent.futures import Future

    from hammerstein import runner
    from hammerstein.report.render import job_key

    root = Path(__file__).resolve().parents[1]
    scenarios = scenarios or sorted(str(p) for p in (root / "scenarios" / "paper").glob("*.toml"))
    jobs, keys, current = [], set(), [""]

    class Recorder:
        def __init__(self, *args, **kwargs):
            pass

        def submit(self, batch):
            out = []
            for job in batch:
                key = job_key(job)
                if key is None or key not in keys:
                    keys.add(key)
                    jobs.append((current[0], job))
                f = Future()
                f.set_result(b"")
                out.append(f)
            return out

        def close(self, cancel=False):
            pass

    saved = runner.FigureRenderer
    runner.FigureRenderer = Recorder
    try:
        with tempfile.TemporaryDirectory(prefix="hammerstein-figures-") as tmp:
            outcomes = runner.run_pipelined(scenarios, tmp,
                                            on_start=lambda p: current.__setitem__(0, Path(p).stem))
    finally:
        runner.FigureRenderer = saved
    failed = [o.error for o in outcomes if not o.ok]
    if failed:
        raise RuntimeError("; ".join(failed))
    return jobs


def paper(repeat):
    """Print the CPU time of every figure of the paper run (build, draw, PNG encoding).

    Parameters
    ----------
    repeat : int
        Drawings per figure (the smallest CPU time of each phase is shown).
    """
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    jobs = paper_jobs()
    for _, job in jobs:                                   # warm: fonts, mathtext, lazy imports
        plots.save(job.function(*job.args, **job.kwargs), io.BytesIO())
    spent = {}
    draw, encode = FigureCanvasAgg.draw, Image.Image.save

    def timed(original, key):
        def wrapper(*args, **kwargs):
            c0 = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                spent[key] = spent.get(key, 0.0) + time.process_time() - c0
        return wrapper

    FigureCanvasAgg.draw, Image.Image.save = timed(draw, "draw"), timed(encode, "encode")
    rows = []
    try:
        for scenario, job in jobs:
            best = None
            for _ in range(max(1, repeat)):
                spent.clear()
                c0 = time.process_time()
                fig = job.function(*job.args, **job.kwargs)
                build = time.process_time() - c0
                plots.save(fig, io.BytesIO())
                total = time.process_time() - c0
                row = (build, spent.get("draw", 0.0), spent.get("encode", 0.0), total)
                best = row if best is None else tuple(map(min, best, row))
            rows.append((f"{scenario[:24]}/{job.path.name}", job.function.__name__,
                         best))
    finally:
        FigureCanvasAgg.draw, Image.Image.save = draw, encode
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{len(rows)} figures of the paper run (each drawn once), CPU [ms], best of "
          f"{repeat}; load average {load:.2f}")
    print(f"{'figure':<62} {'function':<24} {'build':>7} {'draw':>7} {'encode':>7} {'total':>7}")
    sums = [0.0] * 4
    for name, function, best in rows:
        sums = [a + b for a, b in zip(sums, best)]
        print(f"{name:<62} {function:<24} " + " ".join(f"{v * 1e3:7.0f}" for v in best))
    print(f"{'sum':<62} {'':<24} " + " ".join(f"{v * 1e3:7.0f}" for v in sums))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per figure (best is shown)")
    ap.add_argument("--encoding", action="store_true",
                    help="compare PNG encodings (CPU time and size) instead")
    ap.add_argument("--phases", action="store_true",
                    help="CPU time per drawing phase (ticks, text, encoding) instead")
    ap.add_argument("--paper", action="store_true",
                    help="CPU time of every figure of the paper run (its own data) instead; "
                         "with --phases, its CPU time per drawing phase")
    args = ap.parse_args(argv)
    if args.paper and args.phases:
        phases(paper_run=True)
        return
    if args.paper:
        paper(args.repeat)
        return
    if args.phases:
        phases()
        return
    if args.encoding:
        encodings(args.repeat)
        return
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"figure functions, best of {args.repeat} (ms); load average {load:.2f}; "
          f"PNG at {plots.DPI} dpi, at most {plots.MAX_POINTS} points per line")
    print(f"{'figure':<58} {'build':>8} {'save':>8} {'total':>8} {'cpu':>8}")
    total = cpu_total = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "figure.png"
        for name, build in cases():
            best, cpu = None, None
            for _ in range(args.repeat):
                c0, t0 = time.process_time(), time.perf_counter()
                fig = build()
                t1 = time.perf_counter()
                plots.save(fig, path)
                t2, c2 = time.perf_counter(), time.process_time()
                if best is None or t2 - t0 < best[0] + best[1]:
                    best = (t1 - t0, t2 - t1)
                cpu = c2 - c0 if cpu is None else min(cpu, c2 - c0)
            total += sum(best)
            cpu_total += cpu
            print(f"{name:<58} {best[0] * 1e3:8.1f} {best[1] * 1e3:8.1f} {sum(best) * 1e3:8.1f} "
                  f"{cpu * 1e3:8.1f}")
    print(f"{'sum':<58} {'':>8} {'':>8} {total * 1e3:8.1f} {cpu_total * 1e3:8.1f}")


if __name__ == "__main__":
    main()
