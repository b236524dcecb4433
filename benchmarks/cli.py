"""Wall and CPU time of the warm CLI runs a user feels.

Run: ``python benchmarks/cli.py [--repeat N] [--only default|paper] [--no-cache]``
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

Targets (2-core machine, warm): ``run scenarios/paper/*.toml`` <= 8 s wall;
``run scenarios/default.toml`` <= 2 s wall.
"""

from __future__ import annotations

import argparse
import glob
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


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime, r.ru_stime


def time_run(scenarios, out, cache=True):
    """One ``hammerstein run`` in a fresh process: (wall, user, system) [s].

    Parameters
    ----------
    scenarios : list of str
        Scenario files.
    out : str
        Reports directory.
    cache : bool
        Use hammerstein's identification cache (else ``HAMMERSTEIN_CACHE_DIR=off``).

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
    u0, s0 = _children_cpu()
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "hammerstein", "run", *scenarios, "--out", out, "-q"],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    u1, s1 = _children_cpu()
    if p.returncode != 0:
        raise RuntimeError(f"hammerstein run failed ({p.returncode}): {p.stderr.strip()[:500]}")
    return wall, u1 - u0, s1 - s0


def main(argv=None):
    """Print one row per run: best wall, its CPU time, the target, the median and range of
    the CPU times of the repeats, the load average.

    Parameters
    ----------
    argv : list of str, optional
        ``--repeat N`` (default 3), ``--only default|paper``, ``--no-cache``.

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
    args = ap.parse_args(argv)
    names = [args.only] if args.only else list(RUNS)
    print(f"{'run':<8} {'best wall [s]':>13} {'user [s]':>9} {'sys [s]':>8} {'target [s]':>10}  "
          f"{'CPU median (min-max) [s]':>24}  load average before -> after")
    with tempfile.TemporaryDirectory(prefix="hammerstein-bench-") as tmp:
        for name in names:
            scenarios, target = RUNS[name]
            time_run(scenarios, tmp, not args.no_cache)  # warm: numba, identifications, files
            load0 = os.getloadavg()[0]
            runs = [time_run(scenarios, tmp, not args.no_cache) for _ in range(max(1, args.repeat))]
            best = min(runs, key=lambda t: t[0])
            cpu = sorted(user + system for _, user, system in runs)
            load1 = os.getloadavg()[0]
            spread = f"{statistics.median(cpu):.2f} ({cpu[0]:.2f}-{cpu[-1]:.2f})"
            print(f"{name:<8} {best[0]:>13.2f} {best[1]:>9.2f} {best[2]:>8.2f} {target:>10.1f}  "
                  f"{spread:>24}  {load0:.2f} -> {load1:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
