"""The batched sweep kernel: memory, serial vs 2-thread time, per-thread work.

Run: ``python benchmarks/batch.py [--cases 1000] [--repeat 7]`` (from the
repository root; ``NUMBA_NUM_THREADS`` unset or >= 2).

The batch is a Fig. 9-like sweep on the bundled preset (2x2 model, T = 50
µs, bending modes): 4 models (the preset's weights perturbed by +-5 %) x
``cases / 8`` frequencies spread over 10..420 Hz x 2 axes, 5 periods each,
compensator -> Hammerstein plant (``simulate_chain_batch``). Cases differ in
length 42x (10 Hz: 10 000 samples; 420 Hz: 238).

It prints, not asserting anything (speed targets are read, not tested):

1. memory: the bytes of the kernel's arguments (references, outputs, model
   and state arrays: ``nbytes``) against the bytes of the data itself
   (references, inputs and outputs of every case at its own length), and
   the tracemalloc peak of the whole ``simulate_chain_batch`` call;
2. the kernel's wall time (the compiled calls only, not the packing),
   serial then with 2 threads, best of ``--repeat``, with the process CPU
   time and the CPU time of each thread (Linux schedstat: what each
   thread computed, which other processes do not change; two busy threads
   show as a process CPU time about twice the wall time). On free cores the
   wall time of the 2-thread run is its busiest thread's CPU time, so
   ``serial CPU / busiest thread's CPU`` is the speed-up the kernel gets
   when the cores are its own;
3. the samples each thread ran: the 2-thread speed-up cannot exceed
   ``total / max(samples per thread)``.

The load average is printed: other engineers' processes on the 2 cores
inflate the wall times, and a 2-thread run then cannot reach 2x.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def sweep(n_cases=1000, periods=5, seed=0):
    """Compensators, plant and references of a Fig. 9-like sweep of about ``n_cases`` cases."""
    import hammerstein as hs

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from benchmark import perturbed_models

    plant = hs.load_plant("rakotondrabe-2dof")
    T = plant.sampling_period
    comps = [hs.InverseMultiplicativeCompensator(m, check="ignore")
             for m in perturbed_models(plant.hysteresis, seed=seed)]
    freqs = np.linspace(10, 420, max(1, n_cases // (2 * len(comps))))
    cases, refs = [], []
    for c in comps:
        for f in freqs:
            n = int(round(periods / f / T))
            t = np.arange(n) * T
            for axis in range(2):
                r = np.zeros((2, n))
                r[axis] = 40 * np.sin(2 * np.pi * f * t)
                cases.append(c)
                refs.append(r)
    return cases, plant, refs


class KernelSpy:
    """Wraps the batch kernel of ``hammerstein.simulation._kernels``: times and sizes each call.

    :meth:`summary` gives the last call's wall time, the process CPU time,
    the CPU time of each thread that ran (Linux ``/proc/self/task/*/schedstat``:
    what each thread computed, whatever else ran on the machine) and how
    long it waited for a core, the samples each thread ran (from the
    kernel's ``worker`` output), and the bytes of the kernel's arguments.
    (The kernels before the ragged batch, serial and parallel, are wrapped
    too, for a before/after run.)
    """

    NAMES = ("chain_batch_serial", "chain_batch_parallel", "chain_batch")

    def __init__(self):
        from hammerstein.simulation import _kernels
        self.module = _kernels
        self.saved = {n: getattr(_kernels, n) for n in self.NAMES if hasattr(_kernels, n)}
        self.calls = []
        self.lock = threading.Lock()

    def __enter__(self):
        for name, fn in self.saved.items():
            setattr(self.module, name, self._wrap(name, fn))
        self.c0 = time.process_time()
        return self

    def __exit__(self, *exc):
        self.cpu = time.process_time() - self.c0
        for name, fn in self.saved.items():
            setattr(self.module, name, fn)

    def _wrap(self, name, fn):
        def call(*args):
            s0 = thread_schedstat()
            t0 = time.perf_counter()
            out = fn(*args)
            t1 = time.perf_counter()
            s1 = thread_schedstat()
            busy = {tid: (s1[tid][0] - s0.get(tid, (0, 0))[0]) * 1e-9 for tid in s1}
            wait = {tid: (s1[tid][1] - s0.get(tid, (0, 0))[1]) * 1e-9 for tid in s1}
            ran = sorted((t for t in busy if busy[t] > 1e-3), key=lambda t: -busy[t])
            with self.lock:
                self.calls.append({"kernel": name, "start": t0, "end": t1,
                                   "thread_cpu": [busy[t] for t in ran],
                                   "thread_wait": [wait[t] for t in ran],
                                   "worker": args[-2] if name == "chain_batch" else None,
                                   "arg_bytes": _nbytes(args)})
            return out
        return call

    def summary(self, lengths):
        c = self.calls[-1]
        if c["worker"] is not None:
            w = np.asarray(c["worker"])
            samples = [int(lengths[w == k].sum()) for k in np.unique(w)]
        else:
            samples = [int(lengths.sum())]
        return {"kernel": c["kernel"], "wall": c["end"] - c["start"], "cpu": self.cpu,
                "thread_cpu": c["thread_cpu"], "thread_wait": c["thread_wait"],
                "thread_samples": sorted(samples, reverse=True), "arg_bytes": c["arg_bytes"]}


def thread_schedstat():
    """``{thread id: (ns on a CPU, ns waiting for one)}`` of this process (Linux schedstat)."""
    out = {}
    try:
        tids = os.listdir("/proc/self/task")
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/schedstat") as f:
                fields = f.read().split()
            out[tid] = (int(fields[0]), int(fields[1]))
        except (OSError, IndexError, ValueError):
            continue
    return out


def _nbytes(obj):
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if isinstance(obj, tuple):
        return sum(_nbytes(o) for o in obj)
    return 0


def balance(order, work, n_threads):
    """Work of each thread when ``order`` is cut into equal contiguous chunks."""
    chunks = np.array_split(np.asarray(order), n_threads)
    return [float(np.sum(work[c])) for c in chunks]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=1000, help="about this many cases (1000)")
    parser.add_argument("--repeat", type=int, default=7, help="best of this many calls (7)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")

    import numba
    from hammerstein import simulation as sim

    comps, plant, refs = sweep(args.cases)
    lengths = np.array([r.shape[1] for r in refs])
    n_threads = numba.config.NUMBA_NUM_THREADS
    print(f"batch benchmark: {len(refs)} cases, {lengths.sum()} samples "
          f"(lengths {lengths.min()}..{lengths.max()}), numba {numba.__version__}, "
          f"{n_threads} threads available, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores")

    # compile (or load) outside the measurements
    sim.simulate_chain_batch(comps[:2], plant, [r[:, :50] for r in refs[:2]], parallel=False)
    sim.simulate_chain_batch(comps[:2], plant, [r[:, :50] for r in refs[:2]], parallel=True)

    # 1. memory ------------------------------------------------------------------------
    m, p = 2, 2
    data_bytes = int(lengths.sum()) * (m + m + p) * 8        # references, inputs, outputs
    tracemalloc.start()
    with KernelSpy() as spy:
        results = sim.simulate_chain_batch(comps, plant, refs, parallel=False)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    arg_bytes = spy.summary(lengths)["arg_bytes"]
    del results, spy
    print("\n1. memory")
    print(f"   data (references, inputs, outputs at their own lengths) {data_bytes / 1e6:8.1f} MB")
    print(f"   kernel arguments (nbytes)                                {arg_bytes / 1e6:8.1f} MB")
    print(f"   tracemalloc peak of simulate_chain_batch                 {peak / 1e6:8.1f} MB")

    # 2. kernel time serial vs 2 threads -------------------------------------------------
    def kernel_times(parallel, threads):
        numba.set_num_threads(threads)
        runs = []
        for _ in range(args.repeat):
            with KernelSpy() as spy:
                sim.simulate_chain_batch(comps, plant, refs, parallel=parallel)
            runs.append(spy.summary(lengths))
        numba.set_num_threads(n_threads)
        best = min(runs, key=lambda r: r["wall"])
        # the busiest thread's CPU time: the wall time on free cores
        busiest = min(max(r["thread_cpu"]) for r in runs)
        return best, busiest

    threads2 = min(2, n_threads)
    ser, ser_busy = kernel_times(False, 1)
    par, par_busy = kernel_times(True, threads2)
    print(f"\n2. kernel time, best of {args.repeat} (wall; process CPU; CPU of each thread)")
    for label, r in (("serial   ", ser), (f"{threads2} threads", par)):
        print(f"   {label}  {r['wall'] * 1e3:8.1f} ms; CPU {r['cpu'] * 1e3:8.1f} ms "
              f"(CPU / wall {r['cpu'] / r['wall']:.2f}); threads "
              f"{', '.join(f'{t * 1e3:.1f}' for t in r['thread_cpu'])} ms, waited for a "
              f"core {sum(r['thread_wait']) * 1e3:.1f} ms")
    print(f"   speed-up     wall {ser['wall'] / par['wall']:.2f}x; serial CPU / busiest "
          f"thread's CPU {ser_busy / par_busy:.2f}x (the wall speed-up on {threads2} free cores)")
    print(f"   (CPU / wall below the number of threads: other processes had the cores; "
          f"load average now {os.getloadavg()[0]:.2f})")

    # 3. work per thread ----------------------------------------------------------------
    samples = par["thread_samples"]
    bound = sum(samples) / max(samples)
    print(f"\n3. samples run by each thread ({threads2} threads; every case has the same "
          f"model size): {', '.join(map(str, samples))}; the speed-up cannot exceed "
          f"{bound:.3f}x")

    print("\nsummary: " + json.dumps({
        "cases": len(refs), "samples": int(lengths.sum()),
        "data_MB": round(data_bytes / 1e6, 1), "kernel_args_MB": round(arg_bytes / 1e6, 1),
        "tracemalloc_peak_MB": round(peak / 1e6, 1),
        "serial_ms": round(ser["wall"] * 1e3, 1), "parallel_ms": round(par["wall"] * 1e3, 1),
        "speedup": round(ser["wall"] / par["wall"], 2),
        "speedup_cpu": round(ser_busy / par_busy, 2), "work_bound": round(bound, 3),
        "load": round(os.getloadavg()[0], 2)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
