"""Benchmark of the chain with the Hammerstein compensator (not a test).

Run: ``PYTHONPATH=$PWD python benchmarks/hammerstein_compensator.py [--seconds S]``

For the bundled preset (T = 50 µs) and the coupled state-space preset, with
the true models (identification is not timed), it prints the wall time of S
seconds (default 1 s = 20 000 samples) of a 30 µm, 200 Hz circle through

1. the ZPETC inverse of G alone (``ZPETCInverse.filter``, numpy: FIR taps
   plus the acceptable-mode recursion);
2. the whole chain ``G^-1 -> Gamma^c (3 iterations) -> plant`` with the ZPETC
   inverse as the kernel's reference pre-filter, the hysteresis compensator and
   the plant fused in one compiled loop
   (:meth:`HammersteinCompensator.chain`);
3. the rate-independent chain alone (InverseMultiplicativeCompensator, 3
   iterations, fused) for comparison;

as best of 5 runs after a warm-up (compile) run, with the real-time factor
(simulated seconds per wall second). Other processes inflate the numbers;
the load average is printed.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.io.presets import load_plant
from hammerstein.simulation import simulate_chain


def best(fn, repeats=5):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print(f"load average: {os.getloadavg()}")
    for preset in ("rakotondrabe-2dof", "scenarios/presets/coupled-2dof.toml"):
        plant = load_plant(preset)
        T = plant.sampling_period
        n = int(round(args.seconds / T))
        t = np.arange(n) * T
        yr = 30.0 * np.vstack([np.cos(2 * np.pi * 200 * t), np.sin(2 * np.pi * 200 * t)])
        comp = HammersteinCompensator(plant.hysteresis, plant.dynamics, iterations=3)
        lead, s0, _ = comp.start(yr, 100, 200)
        fs0 = s0[comp.hysteresis_compensator.n_states:]
        t_inv = best(lambda: comp.inverse.filter(lead, fs0))
        t_chain = best(lambda: comp.chain(plant, lead, s0))
        pic = InverseMultiplicativeCompensator(plant.hysteresis, iterations=3)
        t_pi = best(lambda: simulate_chain(pic, plant, yr))
        print(f"{plant.name}: {n} samples, preview P = {comp.preview_samples}, "
              f"filter states {comp.n_filter_states}")
        for label, dt in (("ZPETC inverse alone", t_inv), ("Hammerstein chain (fused: ZPETC, PI law, plant)", t_chain),
                          ("rate-independent chain (fused)", t_pi)):
            print(f"  {label:40s} {dt * 1e3:8.2f} ms   {args.seconds / dt:8.1f}x real time   "
                  f"{dt / n * 1e9:7.1f} ns/sample")


if __name__ == "__main__":
    main()
