"""Monte-Carlo robustness study: wall, CPU time and peak memory; dask 1 vs 2 workers.

Run (from the repository root, kernels compiled once beforehand by any run)::

    python benchmarks/montecarlo.py                     # the 10 000-run study, in this process
    python benchmarks/montecarlo.py --no-local --dask --dask-plants 5000 --routes hand

Not a test. Part 1 runs a study of ``--plants`` mismatched plants (PI weights
5 %, cross-couplings 20 % lognormal, natural frequencies 3 % uniform, damping
20 %) x 20 frequencies (10 .. 400 Hz, 0.235 s of x-axis sine each: 4 700
samples per run, 47 M samples for 500 plants) in this process
(:func:`hammerstein.scenario.montecarlo.run_study`, chunks on numba's
threads) and prints the wall time, the CPU time of the process (all threads)
and its peak RSS. Part 2 (``--dask``) runs ``--dask-plants`` plants on 1 and
then 2 single-threaded dask workers, per route: ``hand`` starts ``dask
scheduler`` + ``dask worker`` processes as a user does (loopback only),
``local`` a LocalCluster. After a warm-up chunk on every worker (each
compiles, or loads numba's cache, once) it prints the throughput (cases/s),
the CPU time and peak RSS of every process, the workers' task compute time,
the client's CPU (and the part spent accumulating), the 2/1 ratio of the
throughput and of the cases per worker CPU-second, and checks the quantiles
are bit-identical to the local run. The last line (``SUMMARY``) is the one to
quote. The load average is printed before and after: on a shared machine the
wall time follows the load, the cases per CPU-second much less.

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
# it, before numpy is imported (the workers inherit it). With the per-plant ZOH done by
# scipy.linalg.expm, OpenBLAS's default threads on the busy 2-core machine took the
# 10 000-run study from 5.7 to 10.1 s of CPU; the ZOH is now closed-form (no BLAS), the
# setting stays for the few small BLAS calls left.
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
reference = {{ kind = "sine", output = "x", amplitude = 30.0, duration = {duration} }}
settle_periods = {settle}
[sweeps.vary]
weights = {{ relative_sd = 0.05 }}
cross_coupling = {{ relative_sd = 0.2, distribution = "lognormal" }}
natural_frequency = {{ relative_sd = 0.03, distribution = "uniform" }}
damping_ratio = {{ relative_sd = 0.2 }}
"""


def make_study(cases, folder, duration=0.235):
    """A built study of ``cases`` plants x 20 frequencies (``duration`` [s] per run)."""
    freqs = [round(float(f), 3) for f in np.geomspace(10.0, 400.0, 20)]
    path = Path(folder) / f"bench-{cases}-{duration}.toml"
    path.write_text(TEMPLATE.format(cases=cases, freqs=freqs, duration=duration,
                                settle=1 if duration >= 0.2 else 0))
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


def _usage():
    """(CPU seconds, peak RSS MiB) of the calling process (run on dask workers)."""
    import resource as r
    u = r.getrusage(r.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime, u.ru_maxrss / 1024


def _warm(study):
    """First chunk on a worker: imports, numba cache load or compile; (wall, CPU) seconds."""
    w, c = time.perf_counter(), time.process_time()
    mc.run_chunk(study, 0, 1, parallel=False)
    return time.perf_counter() - w, time.process_time() - c


def _proc_usage(pid):
    """(CPU seconds, peak RSS MiB) of a process of this machine, from /proc."""
    stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    cpu = (int(stat[11]) + int(stat[12])) / os.sysconf("SC_CLK_TCK")
    hwm = [ln for ln in Path(f"/proc/{pid}/status").read_text().splitlines() if ln.startswith("VmHWM")]
    return cpu, int(hwm[0].split()[1]) / 1024


class HandCluster:
    """``dask scheduler`` + n ``dask worker --nthreads 1 --no-nanny`` processes, as a user starts them."""

    def __init__(self, n, folder):
        import subprocess
        dask = [sys.executable, "-m"]          # this interpreter's dask, loopback only
        self.file = Path(folder) / f"scheduler-{n}.json"
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1",
               "PYTHONPATH": str(ROOT)}
        log = open(Path(folder) / f"dask-{n}.log", "w")
        self.procs = [subprocess.Popen([*dask, "distributed.cli.dask_scheduler",
                                        "--scheduler-file", str(self.file), "--host", "127.0.0.1",
                                        "--port", "0", "--no-dashboard"], env=env,
                                       stdout=log, stderr=log)]
        t0 = time.perf_counter()
        while not self.file.exists() and time.perf_counter() - t0 < 60:
            time.sleep(0.1)
        for k in range(n):
            self.procs.append(subprocess.Popen(
                [*dask, "distributed.cli.dask_worker", "--scheduler-file", str(self.file),
                 "--host", "127.0.0.1", "--nthreads", "1",
                 "--no-nanny", "--no-dashboard", "--memory-limit", "0",
                 "--local-directory", str(Path(folder) / f"w{n}-{k}")],
                env=env, stdout=log, stderr=log))

    def usage(self):
        """{'scheduler': (cpu, rss), 'worker k': (cpu, rss)} from /proc."""
        return {("scheduler" if k == 0 else f"worker {k}"): _proc_usage(p.pid)
                for k, p in enumerate(self.procs)}

    def close(self):
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=30)
            except Exception:        # noqa: BLE001 - a stuck process: kill this one only
                p.kill()


def dask_run(route, n, study, folder):
    """Run ``study`` on n single-threaded workers; a dict of measurements."""
    from distributed import Client, LocalCluster, get_task_stream
    hand = cluster = None
    w00 = time.perf_counter()
    if route == "hand":
        hand = HandCluster(n, folder)
        client = Client(scheduler_file=str(hand.file), timeout="60s")
    else:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        client.wait_for_workers(n, timeout=120)
        start_up = time.perf_counter() - w00
        warm = client.run(_warm, study)                       # every worker compiles/loads once
        before = client.run(_usage)
        c0, w0 = time.process_time(), time.perf_counter()
        timings = {}
        with get_task_stream(client) as ts:
            res = mc.run_study(study, client=client, timings=timings)
        wall, client_cpu = time.perf_counter() - w0, time.process_time() - c0
        after = client.run(_usage)
        compute = {}
        for t in ts.data:
            for ss in t.get("startstops", []):
                if ss["action"] == "compute":
                    compute[t["worker"]] = compute.get(t["worker"], 0.0) + ss["stop"] - ss["start"]
        procs = hand.usage() if hand else {}
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
        if hand is not None:
            hand.close()
    workers = sorted(after)
    return dict(route=route, n=n, res=res, wall=wall, client_cpu=client_cpu, start_up=start_up,
                warm=[warm[w] for w in workers], timings=timings,
                worker_cpu=[after[w][0] - before[w][0] for w in workers],
                worker_rss=[after[w][1] for w in workers],
                compute=[compute.get(w, 0.0) for w in workers], procs=procs)


def distributed_throughput(plants, folder, routes, check_local, counts=(1, 2), duration=0.235):
    """Same study on 1 and 2 workers per route; throughput, ratio, CPU, RSS; bit-identity."""
    import pickle
    study = make_study(plants, folder, duration)
    runs = plants * len(study.frequencies)
    blob = pickle.dumps(study)
    t = time.perf_counter()
    pickle.loads(blob)
    print(f"study: {runs} cases ({plants} plants x {len(study.frequencies)} frequencies), "
          f"{runs * sum(r.shape[1] for r in study.references) / len(study.frequencies) / 1e6:.0f} "
          f"M samples; pickled {len(blob) / 1e6:.2f} MB, unpickled in "
          f"{(time.perf_counter() - t) * 1e3:.0f} ms; auto chunk for 1 / 2 workers: "
          f"{mc.auto_chunk(study, 1)} / {mc.auto_chunk(study, 2)} plants")
    ref = None
    if check_local:
        mc.run_chunk(study, 0, 1)
        c0, w0 = time.process_time(), time.perf_counter()
        ref = mc.run_study(study)
        print(f"local reference: {time.perf_counter() - w0:.1f} s wall, "
              f"{time.process_time() - c0:.1f} s CPU")
    got, summary = {}, []
    for route in routes:
        for n in counts:
            r = dask_run(route, n, study, folder)
            got[route, n] = r
            same = []
            if ref is not None:
                same.append(np.array_equal(r["res"].quantiles, ref.quantiles)
                            and np.array_equal(r["res"].diverged, ref.diverged)
                            and (ref.values is None or np.array_equal(r["res"].values, ref.values)))
            first = next(iter(got.values()))["res"]
            same.append(np.array_equal(r["res"].quantiles, first.quantiles))
            wcpu = sum(r["worker_cpu"])
            tm = r["timings"]
            print(f"dask {route} {n} worker(s): {runs / r['wall']:.0f} cases/s ({r['wall']:.1f} s wall; "
                  f"start-up {r['start_up']:.1f} s, first chunk per worker "
                  f"{', '.join(f'{w:.1f} s wall/{c:.1f} s CPU' for w, c in r['warm'])}); "
                  f"{tm['tasks']} tasks of {tm['chunk']} plants; worker CPU "
                  f"{' + '.join(f'{c:.1f}' for c in r['worker_cpu'])} s "
                  f"(task compute {' + '.join(f'{c:.1f}' for c in r['compute'])} s wall), "
                  f"{runs / max(wcpu, 1e-9):.0f} cases per worker CPU-second; client CPU "
                  f"{r['client_cpu']:.2f} s (accumulating {tm['accumulate']:.3f} s); peak RSS workers "
                  f"{', '.join(f'{m:.0f}' for m in r['worker_rss'])} MiB"
                  + (f", scheduler {r['procs']['scheduler'][0]:.1f} s CPU, "
                     f"{r['procs']['scheduler'][1]:.0f} MiB" if r["procs"] else "")
                  + f"; bit-identical: {all(same)}; load {os.getloadavg()[0]:.1f}")
        if (route, 1) not in got or (route, 2) not in got:
            summary.append(f"{route}: no 2/1 ratio (worker counts {', '.join(map(str, counts))})")
            continue
        one, two = got[route, 1], got[route, 2]
        ratio = one["wall"] / two["wall"]
        per_cpu = (runs / sum(two["worker_cpu"])) / (runs / sum(one["worker_cpu"]))
        summary.append(f"{route}: 2/1 workers throughput {ratio:.2f}x (target >= 1.7x), "
                       f"cases per worker CPU-second 2/1 {per_cpu:.2f}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"SUMMARY montecarlo --dask {runs} cases: " + "; ".join(summary)
          + f"; client peak RSS {rss:.0f} MiB; load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", type=int, default=500, help="plants of the local study")
    ap.add_argument("--no-local", action="store_true", help="skip the local study")
    ap.add_argument("--dask", action="store_true", help="run the dask comparison")
    ap.add_argument("--dask-plants", type=int, default=1000,
                    help="plants of the dask study (x 20 frequencies = cases)")
    ap.add_argument("--routes", default="hand,local",
                    help="hand (dask scheduler + dask worker processes), local (LocalCluster)")
    ap.add_argument("--workers", default="1,2", help="worker counts to run, e.g. 1,2 or 2")
    ap.add_argument("--duration", type=float, default=0.235,
                    help="seconds of sine per run of the dask study (0.235: 4 700 samples)")
    ap.add_argument("--no-check", action="store_true",
                    help="do not run the dask study locally to compare bit for bit")
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        if not args.no_local:
            local(args.plants, folder)
        if args.dask:
            distributed_throughput(args.dask_plants, folder, args.routes.split(","),
                                   not args.no_check, [int(n) for n in args.workers.split(",")],
                                   args.duration)
    print(f"load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
