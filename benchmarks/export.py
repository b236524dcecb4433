"""Cost of the exported C compensators: ns per ``NAME_step``, state size, code size.

Run: ``python benchmarks/export.py [--steps N] [--repeat R] [--precision double|float]``
(from the repository root; needs a C compiler, ``$CC`` or cc/gcc/clang).

Not a test. For each compensator (every exportable kind on the bundled preset,
the Hammerstein compensator on the coupled preset, and a worst case of 100
hysterons per component) it exports the C code, compiles it with
``-std=c99 -O2`` together with a timing harness written here, and runs
``NAME_step`` N times on a 150 Hz, 20 µm circle (4000 samples, cycled) after
a warm-up. It prints the CPU time per step (``clock()``: the process's CPU
time, which does not count waiting for a core), best of R repeats, the wall
time per step of that repeat, ``sizeof(NAME_state)``, and the code size
(text + data of the compiled ``NAME.c`` object, from ``size``), with the load
average before and after.

Targets (issue 19): ``step`` <= 2 µs per sample for the bundled 2x2
Hammerstein compensator (a 25x margin on the 50 µs sampling period), state
<= 4 kB.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hammerstein import (InverseMultiplicativeCompensator, MultivariablePI,  # noqa: E402
                         PerAxisInverseCompensator, PrandtlIshlinskii, StaticGainCompensator,
                         diagonal_compensator)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator  # noqa: E402
from hammerstein.io.presets import load_plant  # noqa: E402
from hammerstein.export import export_c  # noqa: E402
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
    double best_cpu = 1e30, best_wall = 0.0, sink = 0.0;
    @N@_real volt[@N@_N_INPUTS];
    static @N@_state s;
    for (i = 0; i < @LEN@; ++i) {          /* 150 Hz, 20 um circle from rest, T = 50 us */
        double ph = 2.0 * 3.14159265358979323846 * 150.0 * 5e-5 * i;
        for (l = 0; l < @N@_N_OUTPUTS; ++l) ref[i][l] = 0.0;
        ref[i][0] = (@N@_real)(20.0 * (1.0 - cos(ph)));
        if (@N@_N_OUTPUTS > 1) ref[i][1 % @N@_N_OUTPUTS] = (@N@_real)(20.0 * sin(ph));
    }
    @N@_init(&s);
    for (k = 0; k < steps / 10; ++k) flags |= @N@_step(&s, ref[k % @LEN@], volt);  /* warm-up */
    for (r = 0; r < repeat; ++r) {
        struct timespec w0, w1;
        clock_t c0, c1;
        @N@_init(&s);
        clock_gettime(CLOCK_MONOTONIC, &w0);
        c0 = clock();
        for (k = 0; k < steps; ++k) {
            flags |= @N@_step(&s, ref[k % @LEN@], volt);
            sink += (double)volt[0];
        }
        c1 = clock();
        clock_gettime(CLOCK_MONOTONIC, &w1);
        {
            double cpu = (double)(c1 - c0) / CLOCKS_PER_SEC / steps * 1e9;
            double wall = ((w1.tv_sec - w0.tv_sec) + 1e-9 * (w1.tv_nsec - w0.tv_nsec)) / steps * 1e9;
            if (cpu < best_cpu) { best_cpu = cpu; best_wall = wall; }
        }
    }
    printf("%.1f %.1f %lu %d %g\n", best_cpu, best_wall, (unsigned long)sizeof s, flags, sink);
    return 0;
}
"""


def cases():
    """(label, compensator, sampling period) of every benchmarked export."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bundled = load_plant("rakotondrabe-2dof")
        coupled = load_plant(ROOT / "scenarios" / "presets" / "coupled-2dof.toml")
        m = bundled.hysteresis
        T = bundled.sampling_period
        rng = np.random.default_rng(0)
        r = np.linspace(0.0, 9.9, 100)
        big = MultivariablePI([[PrandtlIshlinskii(r, np.abs(rng.normal(0.2 if i == j else 0.01, 0.01, 100)))
                                for j in range(2)] for i in range(2)], input_amplitude=[10.0, 10.0])
        yield "rakotondrabe-2dof hammerstein (zpetc, 3 it.)", HammersteinCompensator(m, bundled.dynamics), T
        yield "rakotondrabe-2dof multivariable (1 it.)", InverseMultiplicativeCompensator(m), T
        yield "rakotondrabe-2dof multivariable (3 it.)", InverseMultiplicativeCompensator(m, iterations=3), T
        yield "rakotondrabe-2dof diagonal", diagonal_compensator(m), T
        yield "rakotondrabe-2dof per-axis", PerAxisInverseCompensator(m), T
        yield "rakotondrabe-2dof static-gain", StaticGainCompensator(m), T
        yield "coupled-2dof hammerstein (zpetc, 3 it.)", HammersteinCompensator(coupled.hysteresis,
                                                                              coupled.dynamics), T
        yield "2x2 x 100 hysterons multivariable (3 it.)", InverseMultiplicativeCompensator(
            big, iterations=3, check="ignore"), T


def code_size(obj):
    """text + data bytes of an object file (``size``), or its file size without ``size``."""
    tool = shutil.which("size")
    if tool:
        out = subprocess.run([tool, str(obj)], capture_output=True, text=True).stdout.splitlines()
        if len(out) >= 2:
            text, data = out[1].split()[:2]
            return int(text) + int(data)
    return obj.stat().st_size


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--precision", choices=["double", "float"], default="double")
    args = ap.parse_args()
    cc = find_compiler()
    if cc is None:
        sys.exit("benchmarks/export.py: no C compiler found (set CC)")
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    print(f"compiler: {version}; -std=c99 -O2; {args.precision}; {args.steps} steps, best of "
          f"{args.repeat}; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on "
          f"{os.cpu_count()} cores")
    print(f"{'compensator':45s} {'CPU ns/step':>11s} {'wall ns':>8s} {'state B':>8s} {'code B':>7s}")
    with tempfile.TemporaryDirectory(prefix="hammerstein-bench-") as tmp:
        tmp = Path(tmp)
        for i, (label, comp, T) in enumerate(cases()):
            name = f"b{i}"
            code = export_c(comp, name, T, precision=args.precision)
            for fname, text in code.files().items():
                (tmp / fname).write_text(text)
            (tmp / f"{name}_main.c").write_text(HARNESS.replace("@N@", name).replace("@LEN@", "4000"))
            flags = ["-std=c99", "-O2", "-I", str(tmp)]
            subprocess.run([cc, *flags, "-c", "-o", str(tmp / f"{name}.o"), str(tmp / f"{name}.c")],
                           check=True)
            subprocess.run([cc, *flags, "-D_POSIX_C_SOURCE=199309L", "-o", str(tmp / name),
                            str(tmp / f"{name}_main.c"), str(tmp / f"{name}.o"), "-lm"], check=True)
            out = subprocess.run([str(tmp / name), str(args.steps), str(args.repeat)],
                                 capture_output=True, text=True, check=True).stdout.split()
            cpu, wall, size, status = float(out[0]), float(out[1]), int(out[2]), int(out[3])
            note = "" if status == 0 else f"  (status bits {status})"
            print(f"{label:45s} {cpu:11.1f} {wall:8.1f} {size:8d} {code_size(tmp / f'{name}.o'):7d}{note}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; budget: the "
          f"sampling period 50 µs = 50000 ns per step")


if __name__ == "__main__":
    main()
