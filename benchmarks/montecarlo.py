"""Monte-Carlo robustness study: wall, CPU time and peak memory; dask 1 vs 2 workers.

Run: ``python benchmarks/montecarlo.py [--plants 500] [--dask-plants 100] [--no-dask]``
(from the repository root, kernels compiled once beforehand by any run).

Not a test. Part 1 runs a study of ``--plants`` mismatched plants (PI weights
5 %, cross-couplings 20 % lognormal, natural frequencies 3 % uniform, damping
20 %) x 20 frequencies (10 .. 400 Hz, 0.235 s of x-axis sine each: 4 700
samples per run, 47 M samples for 500 plants) in this process
(:func:`hammerstein.scenario.montecarlo.run_study`, the batch kernel on
numba's threads) and prints the wall time, the CPU time of the process (all
threads) and its peak RSS. Part 2 runs ``--dask-plants`` plants on a
``dask.distributed`` LocalCluster of 1 and then 2 single-threaded worker
processes (after a warm-up chunk on every worker: each compiles, or loads
numba's cache, once) and prints the throughput (runs/s) and the ratio, and
checks the quantiles are bit-identical to the local run. The load average is
printed before and after: on a shared machine the wall time follows the load.

Targets (2-core machine): 10 000 runs (500 plants x 20 frequencies) <= 10 s
wall and <= 1 GB peak memory; 2 dask workers >= 1.7x the one-worker
throughput.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

# As `hammerstein run` (hammerstein/cli/main.py): one OpenBLAS thread unless the user sets
# it, before numpy is imported (the LocalCluster workers inherit it). The per-plant ZOH
# (scipy.linalg.expm of a 6 x 6 matrix) with OpenBLAS's default threads on the busy 2-core
# machine took the 10 000-run study from 5.7 to 10.1 s of CPU (23.4 s wall instead of 10.4).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hammerstein.scenario import montecarlo as mc          # noqa: E402
from hammerstein.scenario.identification import ResolveContext  # noqa: E402
from hammerstein.scenario.registry import build_compensator  # noqa: E402
from hammerstein.scenario.validate import validate_scenario  # noqa: E402

TEMPLATE = """
name = "bench-mc"
seed = 3
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
[[sweeps]]
kind = "monte-carlo"
name = "mismatch"
cases = {cases}
frequencies = {freqs}
reference = {{ kind = "sine", output = "x", amplitude = 30.0, duration = 0.235 }}
settle_periods = 1
[sweeps.vary]
weights = {{ relative_sd = 0.05 }}
cross_coupling = {{ relative_sd = 0.2, distribution = "lognormal" }}
natural_frequency = {{ relative_sd = 0.03, distribution = "uniform" }}
damping_ratio = {{ relative_sd = 0.2 }}
"""


def make_study(cases, folder):
    """A built study of ``cases`` plants x 20 frequencies."""
    freqs = [round(float(f), 3) for f in np.geomspace(10.0, 400.0, 20)]
    path = Path(folder) / f"bench-{cases}.toml"
    path.write_text(TEMPLATE.format(cases=cases, freqs=freqs))
    sc = validate_scenario(path)
    study = sc.studies[0]
    study.compensator = build_compensator(sc.compensator_spec, study.plant, ResolveContext(folder))
    return study


def local(plants, folder):
    study = make_study(plants, folder)
    mc.run_chunk(study, 0, 1)                                 # compile / load the kernels
    samples = plants * sum(r.shape[1] for r in study.references)
    c0, w0 = time.process_time(), time.perf_counter()
    res = mc.run_study(study)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024   # Linux: KiB
    runs = plants * len(study.frequencies)
    print(f"local: {plants} plants x {len(study.frequencies)} frequencies = {runs} runs, "
          f"{samples / 1e6:.1f} M samples: {wall:.2f} s wall, {cpu:.2f} s CPU, "
          f"peak RSS {rss:.0f} MiB (targets <= 10 s, <= 1024 MiB); "
          f"{runs / wall:.0f} runs/s; quantiles {'exact' if res.exact else 'histogram'}")
    return res


def distributed_throughput(plants, folder):
    from distributed import Client, LocalCluster
    study = make_study(plants, folder)
    ref = mc.run_study(study)
    runs = plants * len(study.frequencies)
    rates = {}
    for n in (1, 2):
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            warm = make_study(n, folder)
            mc.run_study(warm, client=client, chunk=1)          # every worker compiles once
            w0 = time.perf_counter()
            res = mc.run_study(study, client=client)
            wall = time.perf_counter() - w0
        same = np.array_equal(res.quantiles, ref.quantiles) and np.array_equal(res.values, ref.values)
        rates[n] = runs / wall
        print(f"dask {n} worker(s): {runs} runs in {wall:.2f} s wall = {rates[n]:.0f} runs/s; "
              f"bit-identical to the local run: {same}")
    print(f"dask 2 / 1 workers throughput: {rates[2] / rates[1]:.2f}x (target >= 1.7x)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", type=int, default=500)
    ap.add_argument("--dask-plants", type=int, default=100)
    ap.add_argument("--no-dask", action="store_true")
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        local(args.plants, folder)
        if not args.no_dask:
            distributed_throughput(args.dask_plants, folder)
    print(f"load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
