"""Benchmark of the simulation core against python-control and a numpy loop.

Run: ``python benchmarks/benchmark.py [--quick]``

For the bundled preset (paper's 2x2 model, 15 hysterons per component, T =
50 µs, bending modes 310/290 Hz) it prints, in one run on this machine:

1. the multivariable PI forward model (compiled kernel): ns per hysteron
   update (p * m * n = 60 hysterons per sample) and samples per second;
2. the wall time of 1 s of the full compensator -> multivariable PI ->
   linear dynamics chain through the fused kernel, through python-control
   (``input_output_response`` of :func:`hammerstein.io.interop.chain_system`,
   run on a shorter record and scaled) and through the per-sample numpy
   loop (``backend='numpy'``), with the ratios;
3. the kernels' compile time, cold (empty temporary ``NUMBA_CACHE_DIR``) and
   cached (second process, same directory), and each kernel's cold compile
   time (the table behind the first run's "compiling ... about N s" line);
4. the wall time of a Fig. 9-like sweep: 4 models (the preset's weights
   perturbed by +-5 %, standing in for models identified at 50/100/150/200
   Hz) x 20 frequencies 10..420 Hz x 2 axes x 5 periods, compensator ->
   Hammerstein plant, in one batched kernel call (serial and parallel;
   ``benchmarks/batch.py`` measures the batch kernel alone on 1000 cases).

Targets (issue 5): forward <= 0.6 ns per hysteron update; chain >= 200x
faster than python-control and >= 50x faster than the numpy loop; sweep
< 2 s. Timings are best-of-repeats wall times; other processes on the
machine inflate them (the load average is printed).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

TARGETS = {"ns_per_update": 0.6, "vs_control": 200.0, "vs_numpy": 50.0, "sweep_s": 2.0}

_COMPILE_SNIPPET = r"""
import json, time, warnings
warnings.simplefilter("ignore")
import numpy as np
t0 = time.perf_counter()
import hammerstein as hs
from hammerstein import simulation as sim
t1 = time.perf_counter()
plant = hs.load_plant("rakotondrabe-2dof")
comp = hs.InverseMultiplicativeCompensator(plant.hysteresis)
u = np.zeros((2, 8))
steps = {"play_kernel": lambda: hs.play(u[0], [0.0, 1.0]),
         "pi_kernel": lambda: plant.hysteresis.simulate(u),
         "plant_kernel": lambda: plant.simulate(u),
         "chain_kernel": lambda: sim.simulate_chain(comp, plant, u),
         "chain_batch": lambda: sim.simulate_chain_batch(comp, plant, [u, u], parallel=True)}
each = {}
for name, first_call in steps.items():
    t = time.perf_counter()
    first_call()
    each[name] = time.perf_counter() - t
sim.simulate_chain_batch(comp, plant, [u, u], parallel=False)
print(json.dumps({"import_s": t1 - t0, "kernels_s": sum(each.values()), "each": each}))
"""


def best_of(fn, repeats, clock=time.perf_counter):
    best = np.inf
    for _ in range(repeats):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best


def compile_times():
    """Kernel compile time, cold then cached, in fresh processes."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "cached"):
            res = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET], env=env,
                                 capture_output=True, text=True, check=True)
            out[label] = json.loads(res.stdout.strip().splitlines()[-1])
    return out


def perturbed_models(model, n_models=4, spread=0.05, seed=0):
    """Copies of a model with every weight scaled by 1 + U(-spread, spread)."""
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    rng = np.random.default_rng(seed)
    models = []
    for _ in range(n_models):
        rows = [[PrandtlIshlinskii(c.thresholds,
                                   c.weights * (1 + rng.uniform(-spread, spread, c.weights.size)))
                 if isinstance(c, PrandtlIshlinskii) else c for c in row]
                for row in model.components]
        models.append(MultivariablePI(rows, model.input_names, model.output_names,
                                      model.input_amplitude))
    return models


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="shorter records and fewer repeats (smoke run)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")

    import control
    import numba
    import hammerstein as hs
    from hammerstein import simulation as sim
    from hammerstein.io.interop import chain_system

    plant = hs.load_plant("rakotondrabe-2dof")
    model = plant.hysteresis
    T = plant.sampling_period
    n_hyst = model.n_hysterons
    reps = 3 if args.quick else 7
    print(f"hammerstein benchmark  preset rakotondrabe-2dof: {model.n_outputs}x{model.n_inputs}, "
          f"{n_hyst} hysterons, T = {T * 1e6:g} us")
    print(f"numba {numba.__version__} ({numba.get_num_threads()} threads), "
          f"python-control {control.__version__}, numpy {np.__version__}, "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")

    # 1. forward model -------------------------------------------------------
    N = 200_000 if args.quick else 1_000_000
    t = np.arange(N) * T
    U = np.vstack([10 * np.sin(2 * np.pi * 50 * t), 10 * np.sin(2 * np.pi * 70 * t + 1)])
    model.simulate(U[:, :100])
    dt = best_of(lambda: model.simulate(U), reps)
    ns = dt / (N * n_hyst) * 1e9
    ns_cpu = best_of(lambda: model.simulate(U), reps, time.thread_time) / (N * n_hyst) * 1e9
    print("\n1. forward model (multivariable PI, kernel)")
    print(f"   {N} samples in {dt * 1e3:.1f} ms: {ns:.3f} ns per hysteron update "
          f"(target <= {TARGETS['ns_per_update']}), {N / dt / 1e6:.1f} M samples/s "
          f"[thread CPU time: {ns_cpu:.3f} ns]")

    # 2. chain: kernel vs python-control vs numpy loop ---------------------------
    comp = hs.InverseMultiplicativeCompensator(model)
    n1 = int(round(1.0 / T))
    t = np.arange(n1) * T
    yr = np.vstack([40 * np.sin(2 * np.pi * 50 * t), 30 * np.sin(2 * np.pi * 80 * t)])
    sim.simulate_chain(comp, plant, yr[:, :100])
    t_kernel = best_of(lambda: sim.simulate_chain(comp, plant, yr), reps)
    n_ctrl = 400 if args.quick else 2000
    csys = chain_system(comp, plant)
    t0 = time.perf_counter()
    resp = control.input_output_response(csys, t[:n_ctrl], yr[:, :n_ctrl])
    t_ctrl = (time.perf_counter() - t0) * n1 / n_ctrl
    n_np = 2000 if args.quick else n1
    t0 = time.perf_counter()
    ref = sim.simulate_chain(comp, plant, yr[:, :n_np], backend="numpy")
    t_np = (time.perf_counter() - t0) * n1 / n_np
    got = sim.simulate_chain(comp, plant, yr)
    err_ctrl = np.max(np.abs(resp.outputs - got.outputs[:, :n_ctrl]))
    err_np = np.max(np.abs(ref.outputs - got.outputs[:, :n_np]))
    print("\n2. 1 s of compensator -> multivariable PI -> bending modes "
          f"({n1} samples)")
    print(f"   fused kernel      {t_kernel * 1e3:10.2f} ms")
    print(f"   python-control    {t_ctrl * 1e3:10.1f} ms  (measured on {n_ctrl} samples, scaled)"
          f"  ratio {t_ctrl / t_kernel:8.0f}x (target >= {TARGETS['vs_control']:.0f}x)"
          f"  max |dy| {err_ctrl:.1e} um")
    print(f"   numpy loop        {t_np * 1e3:10.1f} ms  (measured on {n_np} samples"
          f"{', scaled' if n_np < n1 else ''})"
          f"  ratio {t_np / t_kernel:8.0f}x (target >= {TARGETS['vs_numpy']:.0f}x)"
          f"  max |dy| {err_np:.1e} um")

    # 3. compile times --------------------------------------------------------
    ct = compile_times()
    print("\n3. kernel compile time (first calls of every kernel, fresh process)")
    print(f"   cold (empty NUMBA_CACHE_DIR) {ct['cold']['kernels_s']:6.2f} s;  "
          f"cached {ct['cached']['kernels_s']:6.2f} s;  (import hammerstein "
          f"{ct['cached']['import_s']:.2f} s)")
    print("   each kernel, cold (the first call; a run compiles only those it calls; "
          "hammerstein.simulation._compile.COMPILE_SECONDS):")
    print("   " + ", ".join(f"{k} {v:.2f} s" for k, v in ct["cold"]["each"].items()))

    # 4. Fig. 9-like sweep ----------------------------------------------------------
    models = perturbed_models(model)
    comps = [hs.InverseMultiplicativeCompensator(mdl) for mdl in models]
    freqs = np.linspace(10, 420, 20)
    cases, refs = [], []
    for c in comps:
        for f in freqs:
            n = int(round(5 / f / T))
            tt = np.arange(n) * T
            for axis in range(2):
                r = np.zeros((2, n))
                r[axis] = 40 * np.sin(2 * np.pi * f * tt)
                cases.append(c)
                refs.append(r)
    n_samples = sum(r.shape[1] for r in refs)
    sim.simulate_chain_batch(cases[:2], plant, [r[:, :50] for r in refs[:2]], parallel=True)
    sim.simulate_chain_batch(cases[:2], plant, [r[:, :50] for r in refs[:2]], parallel=False)
    t_ser = best_of(lambda: sim.simulate_chain_batch(cases, plant, refs, parallel=False), reps)
    t_par = best_of(lambda: sim.simulate_chain_batch(cases, plant, refs, parallel=True), reps)
    t0 = time.perf_counter()
    results = sim.simulate_chain_batch(cases, plant, refs)
    rms = np.array([np.sqrt(np.mean((res.outputs - r) ** 2, axis=1))
                    for res, r in zip(results, refs)])
    t_total = time.perf_counter() - t0
    print(f"\n4. Fig. 9-like sweep: {len(comps)} models x {freqs.size} frequencies "
          f"({freqs[0]:g}..{freqs[-1]:g} Hz) x 2 axes x 5 periods = {len(refs)} cases, "
          f"{n_samples} samples")
    print(f"   batched kernel serial {t_ser * 1e3:8.1f} ms, parallel {t_par * 1e3:8.1f} ms "
          f"({numba.get_num_threads()} threads, speed-up {t_ser / t_par:.2f}x); "
          f"with the RMS errors {t_total * 1e3:.1f} ms (target < {TARGETS['sweep_s']:g} s)")
    print(f"   RMS tracking error, direct axis: {rms[:, 0][0::2].min():.2f}..."
          f"{rms[:, 0][0::2].max():.2f} um (x), diverged cases: "
          f"{sum(r.diverged for r in results)}")

    print("\nsummary: " + json.dumps({
        "ns_per_hysteron_update": round(ns, 3), "forward_Msamples_per_s": round(N / dt / 1e6, 1),
        "chain_kernel_ms": round(t_kernel * 1e3, 2), "chain_control_ms": round(t_ctrl * 1e3, 1),
        "chain_numpy_ms": round(t_np * 1e3, 1),
        "ratio_control": round(t_ctrl / t_kernel), "ratio_numpy": round(t_np / t_kernel),
        "compile_cold_s": round(ct["cold"]["kernels_s"], 2),
        "compile_cached_s": round(ct["cached"]["kernels_s"], 2),
        "sweep_serial_ms": round(t_ser * 1e3, 1), "sweep_parallel_ms": round(t_par * 1e3, 1)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
