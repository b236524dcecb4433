"""A 200-frequency sweep with ``kind = "hammerstein"`` against a rate-independent kind.

Run: ``python benchmarks/sweep_hammerstein.py [--repeat 5] [--inversion zpetc|stable]
[--iterations-study] [--phases] [--update-sizes] [--cli]``
(from the repository root; ``NUMBA_NUM_THREADS`` unset for both cores).

Not a test. Two scenarios on the same plant (the bundled preset with its
bending modes, T = 50 µs): one ``[[sweeps]]`` table of 200 frequencies
(10..420 Hz, log spaced), a 20 µm sine on x, 6 periods, 4 settling, with
``kind = "multivariable"`` (rate independent, 1 iteration) and with
``kind = "hammerstein"`` (true plant models, ZPETC inverse of the bending
modes as the law's pre-filter, 3 iterations, faded in over one period),
and ``kind = "multivariable"`` with ``iterations = 3`` (the Hammerstein
kind's static law without the inverse of G).
The scenarios are loaded once (the compensators built); what is timed is
:func:`hammerstein.scenario.sweeps.run_cases` on their cases (simulation and
metrics, the part of ``hammerstein run`` the batching changes), and for
comparison the same Hammerstein cases one by one
(:func:`hammerstein.scenario.execute.run_case`, the path before the batch).

The three runs are alternated ``--repeat`` times after a warm-up; printed:
the median wall and CPU (``time.process_time``: both threads of a batch)
of each, the ratios of the medians, and the load average before and after
(other processes on the 2 cores inflate the wall times; the CPU time is the
steadier number).

Target (issue 20): the Hammerstein sweep within 1.2x of the rate-independent one.

``--iterations-study`` instead runs the bundled ``scenarios/hammerstein-*.toml``
(copied to a temporary folder, ``iterations = 1, 2, 3`` written into every
``kind = "hammerstein"`` table) and prints, per scenario, the ratio of each
case's tracking error (``rms_error`` of every channel, ``max_euclidean_error``)
with 1 and 2 iterations to the error with 3 (the default): what the law's
iterations buy once G is inverted (the cost side is the ``rate-indep., 3
iterations`` row of the timing).

``--phases`` instead prints, per phase of :func:`run_cases`, the CPU time of
the rate-independent and the Hammerstein sweep and their difference
(medians of ``--repeat`` alternated runs, :func:`phases`): where the
Hammerstein sweep's excess goes.

``--cli`` instead times whole ``hammerstein run`` processes on the two
sweeps (rate independent and Hammerstein; imports, the compensators'
construction, simulation, report and figure), alternated, warm caches:
the ratio a user feels (:func:`cli_runs`).

``--update-sizes`` prints the size of the law's 1st, 2nd and 3rd update on
some of the Hammerstein cases (:func:`update_sizes`): what an adaptive stop
of the iterations at a tolerance would save.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SCENARIO = """
name = "sweep-{kind}"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[compensator]
{table}
[[sweeps]]
name = "s"
frequencies = [{freqs}]
reference = {{ kind = "sine", output = "x", amplitude = 20.0, periods = 6 }}
settle_periods = 4
"""


def scenarios(folder, inversion, n_freqs=200):
    """The two resolved scenarios (rate independent, Hammerstein) of the benchmark."""
    from hammerstein.scenario.resolve import load_scenario

    freqs = ", ".join(f"{f:.6g}" for f in np.geomspace(10.0, 420.0, n_freqs))
    out = {}
    for kind, table in (("multivariable", 'kind = "multivariable"'),
                        ("multivariable-3", 'kind = "multivariable"\niterations = 3'),
                        ("hammerstein", f'kind = "hammerstein"\ninversion = "{inversion}"')):
        path = Path(folder) / f"{kind}.toml"
        path.write_text(SCENARIO.format(kind=kind, table=table, freqs=freqs), encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out[kind] = load_scenario(path).cases
    return out


def iterations_study(min_error=0.05):
    """Error ratios of 1 and 2 law iterations against 3 on the bundled Hammerstein scenarios.

    Channels whose error with 3 iterations is below ``min_error`` µm (the
    cross-coupling channels of a sine on one axis) are left out of the ratios.
    """
    import pandas as pd

    from hammerstein.scenario.resolve import load_scenario
    from hammerstein.scenario.sweeps import run_cases

    root = Path(__file__).resolve().parents[1] / "scenarios"
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        shutil.copytree(root, Path(folder) / "s")
        for path in sorted(root.glob("hammerstein-*.toml")):
            text = path.read_text(encoding="utf-8")
            for it in (1, 2, 3):
                copy = Path(folder) / "s" / f"{path.stem}-it{it}.toml"
                copy.write_text(text.replace('kind = "hammerstein"',
                                             f'kind = "hammerstein", iterations = {it}')
                                if '{ kind = "hammerstein"' in text else
                                text.replace('kind = "hammerstein"\n',
                                             f'kind = "hammerstein"\niterations = {it}\n'),
                                encoding="utf-8")
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    cases = load_scenario(copy).cases
                    for case, res in zip(cases, run_cases(cases)):
                        for r in res.metrics:
                            if r["metric"] in ("rms_error", "max_euclidean_error"):
                                rows.append((path.stem, it, case.name, r["channel"], r["metric"],
                                             r["value"]))
    df = pd.DataFrame(rows, columns=["scenario", "it", "case", "channel", "metric", "value"])
    wide = df.pivot_table(index=["scenario", "metric", "case", "channel"], columns="it",
                          values="value")
    wide = wide[wide[3] >= min_error]
    print(f"tracking error with 1 and 2 iterations / with 3 (channels with >= {min_error} um):")
    print(f"{'scenario':36s} {'metric':20s} {'n':>3s} {'1 it median':>12s} {'1 it max':>9s} "
          f"{'2 it median':>12s} {'2 it max':>9s}")
    for (scen, metric), g in wide.groupby(level=["scenario", "metric"]):
        r1, r2 = g[1] / g[3], g[2] / g[3]
        print(f"{scen:36s} {metric:20s} {len(g):3d} {r1.median():11.2f}x {r1.max():8.2f}x "
              f"{r2.median():11.2f}x {r2.max():8.2f}x")


def update_sizes(n_freqs=12, every=3):
    """Size of each law iteration's update on Hammerstein sweep cases (an adaptive stop's gain).

    Runs the delay law of the benchmark's Hammerstein cases (every ``every``-th
    of ``n_freqs`` frequencies) sample by sample in numpy, from its fused start
    (lead reference, ZPETC pre-filter, play states), and prints per case the
    median ``max_k |dU_k|`` [V] of iterations 1, 2 and 3 and the share of
    samples whose 2nd (3rd) update is below 1e-9 V or 1e-12 of the input range:
    the samples on which an adaptive stop at that tolerance would skip an
    evaluation of ``Gamma``.
    """
    from hammerstein.scenario.execute import fade_samples

    with tempfile.TemporaryDirectory() as folder:
        cases = scenarios(folder, "zpetc", n_freqs)["hammerstein"]
    print(f"{'case':16s} {'samples':>7s} {'|dU1|':>9s} {'|dU2|':>9s} {'|dU3|':>9s} "
          f"{'dU2<1e-9V':>10s} {'dU2<1e-12 range':>16s} {'dU3<1e-9V':>10s}  (medians [V], shares)")
    for c in cases[::every]:
        law, lead, state = c.compensator.fused_run(c.signal, c.period_samples, fade_samples(c))
        model = law.model
        u_prev, _, s, xf = law.split_state(state)
        Af, Bf, Cf, Df = law.prefilter
        span = 2.0 * float(np.max(model.input_amplitude))
        d = np.empty((3, lead.shape[1]))
        for t in range(lead.shape[1]):
            target = Cf @ xf + Df @ lead[:, t]
            xf = Af @ xf + Bf @ lead[:, t]
            u = u_prev
            for it in range(3):
                y, _ = model.evaluate(u, s)
                du = law.K_inv @ (target - y)
                d[it, t] = np.max(np.abs(du))
                u = u + du
            _, s = model.evaluate(u, s)
            u_prev = u
        med = np.median(d, axis=1)
        print(f"{c.name:16s} {d.shape[1]:7d} {med[0]:9.2e} {med[1]:9.2e} {med[2]:9.2e} "
              f"{np.mean(d[1] < 1e-9):10.3f} {np.mean(d[1] < 1e-12 * span):16.3f} "
              f"{np.mean(d[2] < 1e-9):10.3f}")


def phases(cases, repeat):
    """Per-phase CPU [ms] of :func:`run_cases` on the rate-independent and Hammerstein cases.

    Each phase's function is wrapped to add up its ``time.process_time``
    (the kernel's: the threads that run it, summed): ``start-up``
    (``_prepared_chunk``: the Hammerstein cases' fade-in, preview and
    continuation), ``reference check``, ``batch`` (``simulate_chain_batch``
    whole), of it ``packing`` (``_ragged``) and ``kernel`` (the kernel
    calls), and ``metrics`` (``chain_result``). The two kinds alternate,
    ``repeat`` times after a warm-up; returns ``{phase: (rate independent,
    hammerstein)}`` medians [ms], ``total`` included.
    """
    import functools
    from concurrent.futures import ThreadPoolExecutor

    from hammerstein.scenario import sweeps
    from hammerstein.simulation import _stepping

    acc = {}
    saved = []

    def wrap(mod, name, key):
        f = getattr(mod, name)
        saved.append((mod, name, f))

        @functools.wraps(f)
        def g(*a, **k):
            c0 = time.process_time()
            try:
                return f(*a, **k)
            finally:
                acc[key] = acc.get(key, 0.0) + time.process_time() - c0
        setattr(mod, name, g)

    wrap(sweeps, "_prepared_chunk", "start-up")
    wrap(sweeps, "_check_references", "reference check")
    wrap(sweeps, "simulate_chain_batch", "batch")
    wrap(sweeps, "chain_result", "metrics")
    wrap(_stepping, "_ragged", "packing")

    class Pool(ThreadPoolExecutor):          # the kernel on several threads
        def __enter__(self):
            self._c0 = time.process_time()
            return super().__enter__()

        def __exit__(self, *exc):
            out = super().__exit__(*exc)
            acc["kernel"] = acc.get("kernel", 0.0) + time.process_time() - self._c0
            return out

    saved.append((_stepping, "ThreadPoolExecutor", ThreadPoolExecutor))
    _stepping.ThreadPoolExecutor = Pool
    kinds = ("multivariable", "hammerstein")
    got = {k: [] for k in kinds}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for k in kinds:                  # warm-up
                sweeps.run_cases(cases[k])
            for _ in range(repeat):
                for k in kinds:
                    acc.clear()
                    c0 = time.process_time()
                    sweeps.run_cases(cases[k])
                    acc["total"] = time.process_time() - c0
                    got[k].append(dict(acc))
    finally:
        for mod, name, f in saved:
            setattr(mod, name, f)
    keys = ("total", "start-up", "reference check", "batch", "packing", "kernel", "metrics")
    return {key: tuple(1e3 * statistics.median(r.get(key, 0.0) for r in got[k]) for k in kinds)
            for key in keys}


def cli_runs(repeat, inversion, n_freqs=200):
    """Whole ``hammerstein run`` processes on the two sweeps, alternated: what a user waits for.

    Each run is a fresh interpreter (imports, validation, the compensators'
    construction, the simulation, the report with its figure), timed from
    outside by ``resource.getrusage(RUSAGE_CHILDREN)`` (user + system CPU)
    and the wall clock; the numba cache is warm. Returns ``{kind: (wall
    median, CPU median)}`` [s].
    """
    import resource
    import subprocess

    root = Path(__file__).resolve().parents[1]
    freqs = ", ".join(f"{f:.6g}" for f in np.geomspace(10.0, 420.0, n_freqs))
    kinds = {"rate-independent": 'kind = "multivariable"',
             "hammerstein": f'kind = "hammerstein"\ninversion = "{inversion}"'}
    got = {k: [] for k in kinds}
    with tempfile.TemporaryDirectory() as folder:
        paths = {}
        for k, table in kinds.items():
            paths[k] = Path(folder) / f"{k}.toml"
            paths[k].write_text(SCENARIO.format(kind=k, table=table, freqs=freqs),
                                encoding="utf-8")
        for i in range(repeat + 1):              # the first round warms the caches
            for k, path in paths.items():
                out = Path(folder) / f"out-{k}-{i}"
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                w0 = time.perf_counter()
                subprocess.run([sys.executable, "-m", "hammerstein", "run", str(path), "--out",
                                str(out), "-q"], cwd=root, check=True)
                wall = time.perf_counter() - w0
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
                if i:
                    got[k].append((wall, cpu))
    return {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
            for k, v in got.items()}


def timed(fn):
    c0, w0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fn()
    return time.perf_counter() - w0, time.process_time() - c0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--inversion", choices=("zpetc", "stable"), default="zpetc")
    ap.add_argument("--frequencies", type=int, default=200)
    ap.add_argument("--iterations-study", action="store_true",
                    help="tracking errors with 1/2/3 law iterations on scenarios/hammerstein-*.toml")
    ap.add_argument("--phases", action="store_true",
                    help="per-phase CPU of the rate-independent and Hammerstein sweeps")
    ap.add_argument("--update-sizes", action="store_true",
                    help="size of each law iteration's update on Hammerstein sweep cases")
    ap.add_argument("--cli", action="store_true",
                    help="whole `hammerstein run` processes on the two sweeps, alternated")
    args = ap.parse_args(argv)
    if args.cli:
        print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on "
              f"{os.cpu_count()} cores; `hammerstein run` on each sweep (report and figure)")
        med = cli_runs(args.repeat, args.inversion, args.frequencies)
        print(f"{'':18s} {'wall [s]':>9s} {'CPU [s]':>9s}   (medians of {args.repeat}, alternated)")
        for k, (w, c) in med.items():
            print(f"{k:18s} {w:9.2f} {c:9.2f}")
        (rw, rc), (hw, hc) = med["rate-independent"], med["hammerstein"]
        print(f"hammerstein / rate-independent: wall {hw / rw:.2f}x, CPU {hc / rc:.2f}x "
              f"(target <= 1.2x)")
        print(f"load average now {os.getloadavg()[0]:.2f}")
        return
    if args.iterations_study:
        iterations_study()
        return
    if args.update_sizes:
        update_sizes()
        return

    from hammerstein.scenario.execute import run_case
    from hammerstein.scenario.sweeps import run_cases
    from hammerstein.simulation._kernels import threads

    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} "
          f"cores; numba threads {threads()}")
    with tempfile.TemporaryDirectory() as folder:
        cases = scenarios(folder, args.inversion, args.frequencies)
    samples = {k: sum(c.signal.shape[1] for c in v) for k, v in cases.items()}
    print(f"{args.frequencies} frequencies, {samples['hammerstein']} samples per sweep "
          f"(inversion {args.inversion})")
    if args.phases:
        print(f"{'CPU [ms]':18s} {'rate-indep.':>12s} {'hammerstein':>12s} {'excess':>8s}   "
              f"(medians of {args.repeat}, alternated)")
        for key, (ri, ha) in phases(cases, args.repeat).items():
            print(f"{key:18s} {ri:12.1f} {ha:12.1f} {ha - ri:8.1f}")
        print(f"load average now {os.getloadavg()[0]:.2f}")
        return
    runs = {
        "rate-independent (batched)": lambda: run_cases(cases["multivariable"]),
        "rate-indep., 3 iterations": lambda: run_cases(cases["multivariable-3"]),
        "hammerstein (batched)": lambda: run_cases(cases["hammerstein"]),
        "hammerstein (one by one)": lambda: [run_case(c) for c in cases["hammerstein"]],
    }
    for fn in runs.values():      # warm-up: compile or load the kernels
        timed(fn)
    got = {k: [] for k in runs}
    for _ in range(args.repeat):  # alternated
        for k, fn in runs.items():
            got[k].append(timed(fn))
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in got.items()}
    print(f"{'':30s} {'wall [s]':>9s} {'CPU [s]':>9s}   (medians of {args.repeat}, alternated)")
    for k, (w, c) in med.items():
        print(f"{k:30s} {w:9.3f} {c:9.3f}")
    ri, r3, hb, h1 = (med[k] for k in runs)
    print(f"hammerstein batched / rate-independent: wall {hb[0] / ri[0]:.2f}x, "
          f"CPU {hb[1] / ri[1]:.2f}x (target <= 1.2x)")
    print(f"hammerstein batched / rate-indep. 3 it: wall {hb[0] / r3[0]:.2f}x, "
          f"CPU {hb[1] / r3[1]:.2f}x (the same static law: the share of the inverse of G)")
    print(f"hammerstein one by one / batched:       wall {h1[0] / hb[0]:.2f}x, "
          f"CPU {h1[1] / hb[1]:.2f}x")
    print(f"load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
