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

Part 2 (``--montecarlo N``): a Monte-Carlo study of N drawn plants
(rakotondrabe-2dof, PI weights 15 %, cross-couplings 30 % lognormal; 5 and
20 Hz sines of 20 µm, 15 000 samples per plant) without and with a
``[feedback]`` loop (integral, 60 Hz crossover on both axes, 10 nm sensor
noise), each run through :func:`hammerstein.scenario.montecarlo.run_study`
as ``hammerstein run`` does; prints the CPU time per drawn plant both ways
and their ratio.

Target: closed-loop sweeps and studies <= 1.3x the open-loop ones.
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
    ap.add_argument("--montecarlo", type=int, default=0, help="plants of part 2 (0: skip)")
    ap.add_argument("--only-montecarlo", action="store_true", help="skip part 1")
    args = ap.parse_args(argv)
    if args.only_montecarlo:
        print(f"load before {os.getloadavg()}")
        montecarlo(args.montecarlo or 400, args.repeat)
        print(f"load after {os.getloadavg()}")
        return
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
    if args.montecarlo:
        montecarlo(args.montecarlo, args.repeat)
    print(f"load after {os.getloadavg()}")


STUDY = """
name = "mcfb"
seed = 5
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
[[sweeps]]
kind = "monte-carlo"
name = "mm"
cases = {cases}
frequencies = [5.0, 20.0]
reference = {{ kind = "sine", output = "x", amplitude = 20.0, periods = 3 }}
settle_periods = 2
[sweeps.vary]
weights = {{ relative_sd = 0.15 }}
cross_coupling = {{ relative_sd = 0.3, distribution = "lognormal" }}
"""

FEEDBACK = """
[feedback]
sensor = { noise_nm = 10.0, delay = 1 }
amplifier = { range = [-100.0, 100.0] }
[feedback.axes.x]
kind = "integral"
crossover_hz = 60.0
[feedback.axes.y]
kind = "integral"
crossover_hz = 60.0
"""


def montecarlo(cases, repeat):
    """Part 2: the same study without and with feedback, CPU time per drawn plant."""
    from hammerstein.scenario.montecarlo import run_montecarlo_scenario
    with tempfile.TemporaryDirectory() as tmp:
        specs = {}
        for label, extra in (("open", ""), ("closed", FEEDBACK)):
            path = Path(tmp) / f"{label}.toml"
            path.write_text(STUDY.format(cases=cases) + extra, encoding="utf-8")
            specs[label] = path
        for label in specs:                           # warm-up: kernels, python-control
            run_montecarlo_scenario(validate_scenario(specs[label]))
        for k in range(repeat):
            cpu = {}
            for label in specs:
                spec = validate_scenario(specs[label])
                w, c = timed(lambda: run_montecarlo_scenario(spec))
                cpu[label] = c
                print(f"study {k} {label}: {w:.2f} s wall, {c:.2f} s CPU, "
                      f"{1e3 * c / cases:.2f} ms CPU per plant")
            print(f"study {k}: closed/open CPU {cpu['closed'] / cpu['open']:.2f}x")


if __name__ == "__main__":
    main()
