"""
Export a compensator as C99 code
================================

The compensator of a model becomes two dependency-free C99 files: every
parameter a ``static const`` table, no allocation, ``NAME_init(&state)``
once and ``NAME_step(&state, reference, voltage)`` once per sampling period.
The command line does the same with ``hammerstein export rakotondrabe-2dof
--target c --name piezo --out generated/``. When a C compiler is found, this
example compiles the code with a small test program, feeds it a circle and
compares its voltages with the Python compensator's.
"""

import shutil
import subprocess
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import hammerstein as hs

plant = hs.load_plant("rakotondrabe-2dof")
T = plant.sampling_period
compensator = hs.InverseMultiplicativeCompensator(plant.hysteresis, gain="midpoint")
code = hs.export_c(compensator, "piezo", T)
print(sorted(code.files()))
print("\n".join(line for line in code.header.splitlines()
                if line.startswith(("#define piezo_N_", "void piezo_init", "int piezo_step"))))

# %%
# Python's voltages for a 30 µm circle at 100 Hz, and the C code's.
t, reference = hs.circle(T, radius=30.0, frequency=100.0, periods=3)
u_python, _ = compensator.simulate(reference)

MAIN = r"""
#include <stdio.h>
#include "piezo.h"
int main(void)
{
    piezo_state s;
    double r[piezo_N_OUTPUTS], v[piezo_N_INPUTS];
    piezo_init(&s);
    while (fread(r, sizeof(double), piezo_N_OUTPUTS, stdin) == piezo_N_OUTPUTS) {
        piezo_step(&s, r, v);
        fwrite(v, sizeof(double), piezo_N_INPUTS, stdout);
    }
    return 0;
}
"""
cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
u_c = None
if cc:
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in {**code.files(), "main.c": MAIN}.items():
            Path(tmp, name).write_text(text)
        subprocess.run([cc, "-std=c99", "-O2", "-o", "piezo", "main.c", "piezo.c", "-lm"],
                       cwd=tmp, check=True)
        out = subprocess.run([str(Path(tmp, "piezo"))], input=reference.T.tobytes(),
                             capture_output=True, check=True).stdout
        u_c = np.frombuffer(out, dtype=float).reshape(-1, 2).T
    print(f"largest difference C - Python: {np.abs(u_c - u_python).max():.2e} V")
else:
    print("no C compiler found: only the Python voltages are drawn")

fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
for k, name in enumerate(plant.hysteresis.input_names):
    ax.plot(1e3 * t, u_python[k], lw=2, alpha=0.5, label=f"{name}, Python")
    if u_c is not None:
        ax.plot(1e3 * t, u_c[k], "k:", lw=1, label=f"{name}, C")
ax.set(xlabel="time [ms]", ylabel="voltage [V]",
       title="Compensator voltages for a 30 µm circle at 100 Hz")
ax.legend(ncol=2)
plt.show()
