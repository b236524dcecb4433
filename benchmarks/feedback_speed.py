"""Closed-loop sweeps against open-loop sweeps: the same cases, wall and CPU time per case.

Run (from the repository root, kernels compiled once beforehand by any run)::

    python benchmarks/feedback_speed.py [--repeat 3]

Not a test. The cases are those of ``scenarios/realistic-feedback.toml``
(realistic-2dof, 15 and 40 µm circles at 10-100 Hz and the 40 x 40 µm raster
at 20 Hz, each with the identified and the preset-model feedforward; 18
cases, 179 200 samples). Open loop: the cases scenario's path
(:func:`hammerstein.scenario.sweeps.run_cases`: the compensator and the
plant fused in the batch kernel, cases over numba's threads). Closed loop:
what a feedback scenario does per case in mode ``both`` (the feedforward,
then the compiled closed-loop kernel with the PI + notch controllers, the
sensor and the amplifier; cases over two threads). Prints, per repetition,
the wall time, the process CPU time (all threads) and their ratio
closed / open, with the load average before and after: on a shared machine
the wall time follows the load, the CPU time much less.

Target: closed-loop sweeps <= 1.3x the open-loop ones.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hammerstein.compensation.hammerstein_compensator import fade_in  # noqa: E402
from hammerstein.scenario.execute import fade_samples  # noqa: E402
from hammerstein.scenario.feedback import _feedforward, build_loops  # noqa: E402
from hammerstein.scenario.resolve import resolve_scenario  # noqa: E402
from hammerstein.scenario.sweeps import run_cases  # noqa: E402
from hammerstein.scenario.validate import validate_scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def closed(cases, loop, jobs=2):
    """Every case in mode "both": feedforward, then the closed-loop kernel."""
    def one(c):
        fade = fade_samples(c) if c.compensator is not None else 0
        r = fade_in(c.signal, fade) if fade else c.signal
        ff, _ = _feedforward(c, r, fade)
        return loop.simulate(r, feedforward=ff, seed=0)
    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(one, cases))


def timed(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fb.toml"
        path.write_text((ROOT / "scenarios" / "realistic-feedback.toml").read_text("utf-8"),
                        encoding="utf-8")
        spec = validate_scenario(path)
        cases = resolve_scenario(spec.cases_spec).cases
    loop, _ = build_loops(spec.table, cases[0].plant)
    samples = sum(c.signal.shape[1] for c in cases)
    print(f"{len(cases)} cases, {samples} samples; load before {os.getloadavg()}")
    run_cases(cases[:2])                 # compile / load the kernels' cache
    closed(cases[:2], loop)
    for k in range(args.repeat):
        wo, co = timed(lambda: run_cases(cases))
        wc, cc = timed(lambda: closed(cases, loop))
        print(f"run {k}: open loop {wo:.2f} s wall, {co:.2f} s CPU ({1e6 * co / samples:.2f} "
              f"µs CPU/sample); closed loop {wc:.2f} s wall, {cc:.2f} s CPU "
              f"({1e6 * cc / samples:.2f} µs CPU/sample); closed/open wall {wc / wo:.2f}x, "
              f"CPU {cc / co:.2f}x")
    print(f"load after {os.getloadavg()}")


if __name__ == "__main__":
    main()
