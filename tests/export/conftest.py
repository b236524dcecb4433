"""Compile exported C with the system compiler(s) and drive it through a small harness.

The harness (written here, not by the project) calls only what the generated
header documents: ``NAME_init``, ``NAME_step``, the ``NAME_N_*`` macros and
``NAME_state``. It reads the references as raw doubles (p per sample) from a
file and writes, per sample, the m voltages and the status (as a double).
With a split sample it copies the state struct into a fresh one there
(chunked runs must equal the whole run bit for bit). The interface is
``NAME_real`` (double or float): the doubles read are converted here.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off", "-O2"]

HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "@NAME@.h"

int main(int argc, char **argv)
{
    static double ref[@NAME@_N_OUTPUTS], volt[@NAME@_N_INPUTS + 1];
    @NAME@_real r[@NAME@_N_OUTPUTS], v[@NAME@_N_INPUTS];
    int i;
    @NAME@_state a, b, *s = &a;
    long k = 0, split = argc > 3 ? atol(argv[3]) : -1;
    FILE *in = fopen(argv[1], "rb"), *out = fopen(argv[2], "wb");
    if (!in || !out) return 3;
    @NAME@_init(&a);
    memset(&b, 0xff, sizeof b);          /* garbage until the copy */
    while (fread(ref, sizeof(double), @NAME@_N_OUTPUTS, in) == @NAME@_N_OUTPUTS) {
        int status;
        if (k == split) { memcpy(&b, &a, sizeof a); memset(&a, 0xff, sizeof a); s = &b; }
        for (i = 0; i < @NAME@_N_OUTPUTS; ++i) r[i] = (@NAME@_real)ref[i];
        status = @NAME@_step(s, r, v);
        for (i = 0; i < @NAME@_N_INPUTS; ++i) volt[i] = (double)v[i];
        volt[@NAME@_N_INPUTS] = (double)status;
        if (fwrite(volt, sizeof(double), @NAME@_N_INPUTS + 1, out) != @NAME@_N_INPUTS + 1) return 4;
        ++k;
    }
    fclose(out);
    printf("%lu\n", (unsigned long)sizeof(@NAME@_state));
    return 0;
}
"""


def compilers():
    """The C compilers found on this machine (cc/gcc and clang), without duplicates."""
    found = []
    for name in ("cc", "clang"):
        path = shutil.which(name)
        if path and os.path.realpath(path) not in [os.path.realpath(p) for p in found]:
            found.append(path)
    return found


COMPILERS = compilers()
needs_cc = pytest.mark.skipif(not COMPILERS, reason="no C compiler (cc, clang) on PATH: the "
                                                    "exported C cannot be compiled here")


class Harness:
    """A compiled harness around one exported compensator."""

    def __init__(self, code, workdir, compiler=None):
        self.code = code
        self.dir = Path(workdir)
        self.dir.mkdir(parents=True, exist_ok=True)
        for fname, text in code.files().items():
            (self.dir / fname).write_text(text)
        (self.dir / "harness.c").write_text(HARNESS.replace("@NAME@", code.name))
        self.exe = self.dir / "harness"
        cc = compiler or COMPILERS[0]
        cmd = [cc, *CFLAGS, "-o", str(self.exe), str(self.dir / "harness.c"),
               str(self.dir / f"{code.name}.c"), "-lm"]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode:
            raise AssertionError(f"{' '.join(cmd)} failed:\n{res.stderr}")

    def run(self, reference, split=None):
        """Voltages (m, N), status (N,) and sizeof(NAME_state) for a reference (p, N)."""
        r = np.ascontiguousarray(np.asarray(reference, dtype=float).T)
        src, dst = self.dir / "ref.bin", self.dir / "out.bin"
        r.tofile(src)
        args = [str(self.exe), str(src), str(dst)] + ([str(split)] if split is not None else [])
        res = subprocess.run(args, capture_output=True, text=True, check=True)
        out = np.fromfile(dst).reshape(-1, self.code.n_inputs + 1).T
        return out[:-1], out[-1].astype(int), int(res.stdout.strip())


@pytest.fixture
def harness(tmp_path):
    """``harness(code, compiler=None) -> Harness`` compiled in a temporary directory."""
    count = [0]

    def make(code, compiler=None):
        count[0] += 1
        return Harness(code, tmp_path / f"h{count[0]}", compiler)
    return make
