"""CPU time per ``NAME_step`` of exported C compensators, with a C timing harness.

Run: ``python benchmarks/export_speed.py [--opt O2] [--steps N] [--repeat R]
[--precision double|float] [--model FILE[:KIND[/INVERSION]] ...] [--python]`` from the repository root
(needs a C compiler, ``$CC`` or cc/gcc/clang).

Not a test. Each compensator is exported (:func:`hammerstein.export.export_c`),
compiled with ``-std=c99 -ffp-contract=off -O2`` (``--opt``) together with the harness below, and
stepped N times on a 150 Hz, 20 µm circle (4000 samples, cycled) after a warm-up.
Printed per case: the CPU time per step (``clock()``: the process's CPU time,
not time spent waiting for a core), best of R repeats, the same scaled to the
reference machine of issue 41 (on which ``python3 -c "exec('s = 0\\nfor i in
range(20_000_000): s += i')"`` takes 1.0 s of CPU; timed before and after, the
faster used), the state size and the load average.

Cases: the 4x4 classical PI with 100 play operators per input (the issue's
4x4x100), law with 1 and 3 iterations, the kinds :func:`choose_kind` picks for
it without and with (4x4 bending modes) dynamics, and its per-axis inverse; the bundled 2x2 Hammerstein compensator;
2x2 Preisach and generalised-PI models (exact inverse), and any model or preset
file given with ``--model FILE[:KIND[/INVERSION]]`` (e.g. one written by ``hammerstein
identify``; ``:hammerstein/stable`` for the stable inversion's look-ahead filter), built as
``hammerstein export`` builds it. Target: <= 2 µs per
step at -O2 for the 4x4x100 PI and the 2x2 identified models. With
``--python``, each compensator's Python ``simulate`` (the compiled kernels
``compensate`` runs) is also timed on the same reference, CPU ns per sample.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "export"))

from hammerstein import (InverseMultiplicativeCompensator, MultivariablePI,  # noqa: E402
                         PrandtlIshlinskii)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator  # noqa: E402
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator  # noqa: E402
from hammerstein.compensation.compensators import PerAxisInverseCompensator  # noqa: E402
from hammerstein.models.dynamics import sampled_bending_modes  # noqa: E402
from hammerstein.io.presets import load_plant  # noqa: E402
from hammerstein.export import export_c  # noqa: E402
from hammerstein.compensation.kind_choice import choose_kind  # noqa: E402
from hammerstein.export.build import compensator_from_source, load_source  # noqa: E402
from hammerstein.export.fmu import find_compiler  # noqa: E402

HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <math.h>
#include "@N@.h"

static @N@_real ref[@LEN@][@N@_N_OUTPUTS];

int main(int argc, char **argv)
{
    long steps = atol(argv[1]), repeat = atol(argv[2]), k, r;
    int i, l, flags = 0;
    double best_cpu = 1e30, sink = 0.0;
    @N@_real volt[@N@_N_INPUTS];
    static @N@_state s;
    for (i = 0; i < @LEN@; ++i) {          /* 150 Hz, 20 um circle from rest, T = 50 us */
        double ph = 2.0 * 3.14159265358979323846 * 150.0 * 5e-5 * i;
        for (l = 0; l < @N@_N_OUTPUTS; ++l) ref[i][l] = (@N@_real)(@SCALE@ * (l % 2 ? sin(ph) : 1.0 - cos(ph)));
    }
    @N@_init(&s);
    for (k = 0; k < steps / 10; ++k) flags |= @N@_step(&s, ref[k % @LEN@], volt);  /* warm-up */
    for (r = 0; r < repeat; ++r) {
        clock_t c0, c1;
        @N@_init(&s);
        c0 = clock();
        for (k = 0; k < steps; ++k) {
            flags |= @N@_step(&s, ref[k % @LEN@], volt);
            sink += (double)volt[0];
        }
        c1 = clock();
        {
            double cpu = (double)(c1 - c0) / CLOCKS_PER_SEC / (double)steps * 1e9;
            if (cpu < best_cpu) best_cpu = cpu;
        }
    }
    printf("%.1f %lu %d %g\n", best_cpu, (unsigned long)sizeof s, flags, sink);
    return 0;
}
"""


def reference_loop():
    """CPU seconds of the issue's 20-million-iteration Python loop (the machine's speed)."""
    t0 = time.process_time()
    exec("s = 0\nfor i in range(20_000_000): s += i")
    return time.process_time() - t0


def pi_4x4(n=100, iterations=1):
    """4x4 classical PI, ``n`` play operators per input (shared thresholds), weak couplings."""
    rng = np.random.default_rng(0)
    r = np.linspace(0.0, 9.9, n)
    model = MultivariablePI([[PrandtlIshlinskii(r, np.abs(rng.normal(0.2 if i == j else 0.01, 0.01, n)))
                              for j in range(4)] for i in range(4)], input_amplitude=[10.0] * 4)
    return InverseMultiplicativeCompensator(model, iterations=iterations, check="ignore")


def pi_4x4_model(n=100):
    """The model of :func:`pi_4x4` (a 4x4 classical PI, ``n`` plays per input)."""
    return pi_4x4(n).model


def default_kind_4x4(n, T, dynamics):
    """(label, compensator) of the kind :func:`choose_kind` picks for the 4x4 PI, as exported.

    ``dynamics``: with 4x4 bending modes (310-340 Hz, damping 0.15, sampled
    at ``T``; the kind is then ``hammerstein``), else none.
    """
    model = pi_4x4_model(n)
    G = (sampled_bending_modes([310.0, 320.0, 330.0, 340.0], [0.15] * 4, None, T)
         if dynamics else None)
    choice = choose_kind(model, G is not None)
    gain = choice.options.get("gain")
    if choice.kind == "hammerstein":
        comp = HammersteinCompensator(model, G, gain=gain if gain is not None else "midpoint",
                                      check="ignore")
        it = comp.hysteresis_compensator.iterations
    elif choice.kind == "multivariable":
        comp = InverseMultiplicativeCompensator(model, gain=gain if gain is not None else "secant",
                                                iterations=1, check="ignore")
        it = 1
    else:
        comp = PerAxisInverseCompensator(model)
        it = None
    return (f"4x4x{n} PI default {'+ G ' if dynamics else ''}{choice.kind}"
            + (f" ({it} it.)" if it else "")), comp


def cases(files):
    """(label, compensator, sampling period, reference amplitude [µm]) of every case."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bundled = load_plant("rakotondrabe-2dof")
        T = bundled.sampling_period
        yield "4x4x100 PI multivariable (1 it.)", pi_4x4(100, 1), T, 20.0
        yield "4x4x100 PI multivariable (3 it.)", pi_4x4(100, 3), T, 20.0
        for dynamics in (False, True):       # the kinds picked when the user names none
            label, comp = default_kind_4x4(100, T, dynamics)
            yield label, comp, T, 20.0
        yield "4x4x100 PI per-axis", PerAxisInverseCompensator(pi_4x4_model(100)), T, 20.0
        yield "2x2 bundled hammerstein (3 it.)", HammersteinCompensator(bundled.hysteresis,
                                                                        bundled.dynamics), T, 20.0
        from test_exact_export import gpi_model, preisach_model   # the test suite's 2x2 models
        yield "2x2 Preisach exact inverse", PreisachInverseCompensator(preisach_model()), T, 12.0
        yield "2x2 generalised PI exact inverse", PreisachInverseCompensator(gpi_model()), T, 12.0
        for spec in files:
            path, _, kind = spec.partition(":")
            kind, _, inversion = kind.partition("/")
            source = load_source(path)
            kind = kind or choose_kind(source.model, source.dynamics is not None).kind
            comp, Tm = compensator_from_source(source, kind, check="ignore",
                                               inversion=inversion or None)
            yield (f"{Path(path).parent.name}/{Path(path).stem} {kind}"
                   + (f" {inversion}" if inversion else "")), comp, Tm, 12.0


def python_ns(comp, T, scale, steps, repeat):
    """CPU ns per sample of ``comp.simulate`` on the harness's reference (150 Hz circle from
    rest, ``min(steps, 40000)`` samples), best of ``repeat``, after a short compiling call."""
    k = np.arange(min(steps, 40_000))
    ph = 2.0 * np.pi * 150.0 * 5e-5 * k
    p = comp.model.n_outputs
    yr = np.array([scale * (np.sin(ph) if l % 2 else 1.0 - np.cos(ph)) for l in range(p)])
    comp.simulate(yr[:, :10])
    best = np.inf
    for _ in range(repeat):
        t0 = time.process_time()
        comp.simulate(yr)
        best = min(best, time.process_time() - t0)
    return 1e9 * best / yr.shape[1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--opt", default="O2", help="optimisation level (O2, O3, Os)")
    ap.add_argument("--precision", choices=["double", "float"], default="double")
    ap.add_argument("--model", action="append", default=[], metavar="FILE[:KIND]")
    ap.add_argument("--python", action="store_true",
                    help="also time the Python compensator (its compiled kernels, what "
                         "`compensate` runs) on the same reference, CPU ns per sample")
    args = ap.parse_args()
    cc = find_compiler()
    if cc is None:
        sys.exit("benchmarks/export_speed.py: no C compiler found (set CC)")
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    ref0 = reference_loop()
    print(f"compiler: {version}; -std=c99 -ffp-contract=off -{args.opt}; {args.precision}; {args.steps} steps, best "
          f"of {args.repeat}; load {' '.join(f'{x:.2f}' for x in os.getloadavg())} on "
          f"{os.cpu_count()} cores; reference loop {ref0:.2f} s CPU")
    rows = []
    with tempfile.TemporaryDirectory(prefix="hammerstein-speed-") as tmp:
        tmp = Path(tmp)
        for i, (label, comp, T, scale) in enumerate(cases(args.model)):
            name = f"s{i}"
            code = export_c(comp, name, T, precision=args.precision)
            for fname, text in code.files().items():
                (tmp / fname).write_text(text)
            (tmp / f"{name}_main.c").write_text(HARNESS.replace("@N@", name).replace("@LEN@", "4000")
                                                .replace("@SCALE@", repr(scale)))
            flags = ["-std=c99", "-ffp-contract=off", f"-{args.opt}", "-I", str(tmp)]
            subprocess.run([cc, *flags, "-o", str(tmp / name), str(tmp / f"{name}_main.c"),
                            str(tmp / f"{name}.c"), "-lm"], check=True)
            out = subprocess.run([str(tmp / name), str(args.steps), str(args.repeat)],
                                 capture_output=True, text=True, check=True).stdout.split()
            rows.append((label, float(out[0]), int(out[1]), int(out[2]), code.state_reals,
                         python_ns(comp, T, scale, args.steps, args.repeat) if args.python
                         else None))
    ref1 = reference_loop()
    scale = 1.0 / min(ref0, ref1)
    print(f"{'compensator':44s} {'CPU ns/step':>11s} {'scaled ns':>9s} {'state B':>8s} {'reals':>6s}"
          + (f" {'Python ns':>10s}" if args.python else ""))
    for label, cpu, size, status, reals, py in rows:
        note = "" if status == 0 else f"  (status bits {status})"
        print(f"{label:44s} {cpu:11.1f} {cpu * scale:9.1f} {size:8d} {reals:6d}"
              + (f" {py:10.0f}" if py is not None else "") + note)
    print(f"reference loop after: {ref1:.2f} s CPU (scaled = raw / {min(ref0, ref1):.2f}); load "
          f"after {' '.join(f'{x:.2f}' for x in os.getloadavg())}; target 2000 ns per step")


if __name__ == "__main__":
    main()
