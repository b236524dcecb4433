"""Wall and CPU time of the warm CLI runs a user feels.

Run: ``python benchmarks/cli.py [--repeat N] [--only default|paper] [--no-cache] [--cold]``
(from the repository root).

Not a test. For each command it runs the CLI once to warm the caches (numba's
kernels, the file system), then ``--repeat`` times in fresh processes
(``python -m hammerstein run ... --out <temporary> -q`` with this checkout on
``PYTHONPATH``) and prints the best wall time, the user+system CPU time of
that run (the process and its figure workers, from ``getrusage`` of the
children) and the load average before and after. On a machine shared with
other work the wall time follows the load; the CPU time is the steadier
number (it does not count time spent waiting for a core).

Warm means: numba's kernels compiled and cached, and the identifications of
the scenarios in hammerstein's on-disk cache (``HAMMERSTEIN_CACHE_DIR``;
the warm-up run fills it). ``--no-cache`` turns that cache off for the
warm-up and the timed runs (``HAMMERSTEIN_CACHE_DIR=off``): every run
identifies again, as the first run of a new scenario does.

``--cold`` times the first run on a new machine instead: every timed run
gets an empty numba cache (``NUMBA_CACHE_DIR``) and an empty identification
cache, so it compiles its kernels (the chain kernel in a helper process
while the run goes on, :func:`hammerstein.simulation._compile.prefetch`)
and identifies; no warm-up run. Target: the default run <= 6 s wall.

``--profile`` (with ``--only``, default paper) instead runs the command once
more after the warm-up, in a fresh process instrumented from inside, and
prints where the CPU time goes per process: the main process's imports
(everything the run imports, before the first scenario), then per phase of
the scenarios (validation; resolution, which loads or runs the
identifications; simulation and metrics; writing the report: CSV files,
``report.md``, figure jobs handed to the pool; the rest), and every figure
worker's jobs by figure function (count, CPU in total and per figure, from
``os.times`` around each job in the worker), with each worker's CPU beyond
its jobs (start-up, receiving the jobs). CPU = user + system.

Targets (2-core machine, warm): ``run scenarios/paper/*.toml`` <= 8 s wall
and <= 10 s CPU; ``run scenarios/default.toml`` <= 2 s wall.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = {
    "default": (["scenarios/default.toml"], 2.0),
    "paper": (sorted(glob.glob(str(ROOT / "scenarios" / "paper" / "*.toml"))), 8.0),
}
#: wall-time targets [s] of the first run on a new machine (``--cold``)
COLD_TARGETS = {"default": 6.0}


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime, r.ru_stime


def time_run(scenarios, out, cache=True, cold_dir=None):
    """One ``hammerstein run`` in a fresh process: (wall, user, system) [s].

    Parameters
    ----------
    scenarios : list of str
        Scenario files.
    out : str
        Reports directory.
    cache : bool
        Use hammerstein's identification cache (else ``HAMMERSTEIN_CACHE_DIR=off``).
    cold_dir : str, optional
        An empty directory: numba's and hammerstein's caches are made there
        (a cold run: everything compiled and identified).

    Returns
    -------
    tuple of float
        Wall time, user and system CPU time of the process and its children [s].

    Raises
    ------
    RuntimeError
        If the run fails (its stderr in the message).
    """
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if not cache:
        env["HAMMERSTEIN_CACHE_DIR"] = "off"
    if cold_dir is not None:
        env["NUMBA_CACHE_DIR"] = os.path.join(cold_dir, "numba")
        if cache:
            env["HAMMERSTEIN_CACHE_DIR"] = os.path.join(cold_dir, "identifications")
    u0, s0 = _children_cpu()
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "hammerstein", "run", *scenarios, "--out", out, "-q"],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    u1, s1 = _children_cpu()
    if p.returncode != 0:
        raise RuntimeError(f"hammerstein run failed ({p.returncode}): {p.stderr.strip()[:500]}")
    return wall, u1 - u0, s1 - s0


def _cpu():
    t = os.times()
    return t.user + t.system


_JOBS = {}


def _timed_render_job(job):
    """``render_job`` with its CPU time logged (module level: the pool pickles it by name)."""
    c = _cpu()
    try:
        return _JOBS["draw"](job)
    finally:
        with open(_JOBS["log"], "a") as f:
            f.write(json.dumps([os.getpid(), job.function.__name__, _cpu() - c, _cpu()]) + "\n")


def _profile_child(log, out, scenarios):
    """The instrumented run of ``--profile`` (in the child process): write its phases to ``log``."""
    c0 = _cpu()
    from hammerstein import runner                 # what the run imports, before the first scenario
    from hammerstein.cli import run as _run  # noqa: F401
    from hammerstein.cli.main import main
    from hammerstein.report import render
    imports = _cpu() - c0
    spent, counts, depth = {}, {}, [0]

    def timed(function, key):
        def wrapper(*args, **kwargs):
            depth[0] += 1
            c = _cpu()
            try:
                return function(*args, **kwargs)
            finally:
                depth[0] -= 1
                spent[key] = spent.get(key, 0.0) + _cpu() - c
                counts[key] = counts.get(key, 0) + 1
        return wrapper

    runner.validate_scenario = timed(runner.validate_scenario, "validate")
    runner.resolve_scenario = timed(runner.resolve_scenario, "resolve (identifications loaded or run)")
    for name, kind in list(runner.SCENARIO_KINDS.items()):
        runner.SCENARIO_KINDS[name] = runner.ScenarioKind(
            timed(kind.simulate, "simulate (cases, metrics)"),
            timed(kind.write, "write (CSV, report.md, figure jobs handed over)"))
    _JOBS.update(draw=render.render_job, log=log + ".jobs")
    render.render_job = _timed_render_job
    c1 = _cpu()
    code = main(["run", *scenarios, "--out", out, "-q"])
    total = _cpu() - c1
    t = os.times()
    with open(log, "w") as f:
        json.dump({"code": code, "imports": imports, "run": total, "spent": spent, "counts": counts,
                   "children": t.children_user + t.children_system}, f)
    sys.stdout.flush()
    os._exit(0)              # as the console script: no interpreter teardown (atexit ran in main)


def profile(scenarios, out, cache=True):
    """Print where the CPU time of one warm run goes, per process (see the module doc).

    Parameters
    ----------
    scenarios : list of str
        Scenario files.
    out : str
        Reports directory.
    cache : bool
        Use hammerstein's identification cache.

    Raises
    ------
    RuntimeError
        If the run fails.
    """
    log = os.path.join(out, "profile.json")
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    if not cache:
        env["HAMMERSTEIN_CACHE_DIR"] = "off"
    load0 = os.getloadavg()[0]
    u0, s0 = _children_cpu()
    p = subprocess.run([sys.executable, __file__, "--profile-child", log, out, *scenarios],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    u1, s1 = _children_cpu()
    if p.returncode != 0 or not os.path.exists(log) or json.load(open(log))["code"] != 0:
        raise RuntimeError(f"profiled run failed ({p.returncode}): {p.stderr.strip()[-800:]}")
    with open(log) as f:
        data = json.load(f)
    jobs = []
    if os.path.exists(log + ".jobs"):
        with open(log + ".jobs") as f:
            jobs = [json.loads(line) for line in f]
    print(f"one warm run of {len(scenarios)} scenario(s): {u1 - u0 + s1 - s0:.2f} s CPU in all "
          f"(user + system); load average {load0:.2f} -> {os.getloadavg()[0]:.2f}")
    print(f"{'process':<10} {'what':<50} {'count':>5} {'CPU [s]':>8} {'each [ms]':>10}")
    main_total = data["imports"] + data["run"]
    print(f"{'main':<10} {'imports (of the run, before the first scenario)':<50} {1:>5} {data['imports']:>8.2f}")
    phases = sum(data["spent"].values())
    for key, cpu in data["spent"].items():
        n = data["counts"][key]
        print(f"{'main':<10} {key:<50} {n:>5} {cpu:>8.2f} {cpu / n * 1e3:>10.0f}")
    print(f"{'main':<10} {'the rest (CLI, renames, waiting on figures)':<50} {'':>5} "
          f"{data['run'] - phases:>8.2f}")
    start = (u1 - u0 + s1 - s0) - main_total - data["children"]
    print(f"{'main':<10} {'interpreter start-up and exit':<50} {'':>5} {start:>8.2f}")
    print(f"{'main':<10} {'total':<50} {'':>5} {main_total + start:>8.2f}")
    by_pid = {}
    for pid, function, cpu, _ in jobs:
        by_pid.setdefault(pid, {}).setdefault(function, []).append(cpu)
    for k, (pid, functions) in enumerate(sorted(by_pid.items())):
        for function, cpus in sorted(functions.items(), key=lambda kv: -sum(kv[1])):
            print(f"{f'worker {k + 1}':<10} {function:<50} {len(cpus):>5} {sum(cpus):>8.2f} "
                  f"{sum(cpus) / len(cpus) * 1e3:>10.0f}")
    in_jobs = sum(cpu for _, _, cpu, _ in jobs)
    last = {}
    for pid, _, _, at in jobs:
        last[pid] = max(last.get(pid, 0.0), at)
    print(f"{'workers':<10} {'figure jobs':<50} {len(jobs):>5} {in_jobs:>8.2f} "
          f"{(in_jobs / len(jobs) * 1e3 if jobs else 0.0):>10.0f}")
    print(f"{'workers':<10} {'beyond the jobs (start-up, hand-over, exit)':<50} {len(by_pid):>5} "
          f"{data['children'] - in_jobs:>8.2f}")


def main(argv=None):
    """Print one row per run: best wall, its CPU time, the target, the median and range of
    the CPU times of the repeats, the load average.

    Parameters
    ----------
    argv : list of str, optional
        ``--repeat N`` (default 3), ``--only default|paper``, ``--no-cache``,
        ``--profile``.

    Returns
    -------
    int
        0.
    """
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=sorted(RUNS))
    ap.add_argument("--no-cache", action="store_true",
                    help="identify in every run (HAMMERSTEIN_CACHE_DIR=off)")
    ap.add_argument("--cold", action="store_true",
                    help="every run on empty numba and identification caches (a first run)")
    ap.add_argument("--profile", action="store_true",
                    help="where the CPU goes per process in one warm run (of --only, default paper)")
    ap.add_argument("--profile-child", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.profile_child:
        log, out, *scenarios = args.profile_child
        _profile_child(log, out, scenarios)
        return 0
    if args.profile:
        scenarios = RUNS[args.only or "paper"][0]
        with tempfile.TemporaryDirectory(prefix="hammerstein-bench-") as tmp:
            time_run(scenarios, tmp, not args.no_cache)             # warm
            profile(scenarios, tmp, not args.no_cache)
        return 0
    names = [args.only] if args.only else list(RUNS)
    print(f"{'run':<13} {'best wall [s]':>13} {'user [s]':>9} {'sys [s]':>8} {'target [s]':>10}  "
          f"{'CPU median (min-max) [s]':>24}  load average before -> after")
    with tempfile.TemporaryDirectory(prefix="hammerstein-bench-") as tmp:
        for name in names:
            scenarios, target = RUNS[name]
            if args.cold:
                target = COLD_TARGETS.get(name, float("nan"))
            else:
                time_run(scenarios, tmp, not args.no_cache)  # warm: numba, identifications, files
            load0 = os.getloadavg()[0]
            runs = []
            for _ in range(max(1, args.repeat)):
                cold = tempfile.mkdtemp(dir=tmp) if args.cold else None
                runs.append(time_run(scenarios, tmp, not args.no_cache, cold))
            best = min(runs, key=lambda t: t[0])
            cpu = sorted(user + system for _, user, system in runs)
            load1 = os.getloadavg()[0]
            spread = f"{statistics.median(cpu):.2f} ({cpu[0]:.2f}-{cpu[-1]:.2f})"
            label = f"{name} cold" if args.cold else name
            print(f"{label:<13} {best[0]:>13.2f} {best[1]:>9.2f} {best[2]:>8.2f} {target:>10.1f}  "
                  f"{spread:>24}  {load0:.2f} -> {load1:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
