"""The exported feedback controller (C99) equals the closed-loop kernel's voltages."""

import subprocess

import control
import numpy as np
import pytest
from conftest import CFLAGS, COMPILERS, needs_cc

from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
from hammerstein.compensation.feedback import (AmplifierLimits, FeedbackLoop, Sensor, design_axis,
                                       diagonal_controller)
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.models.plant import HammersteinPlant
from hammerstein.exceptions import ExportError
from hammerstein.export.feedback_c import export_feedback_c

T = 5e-5

HARNESS = r"""
#include <stdio.h>
#include "@NAME@.h"
int main(int argc, char **argv)
{
    double rm[2 * @NAME@_N_OUTPUTS], volt[@NAME@_N_INPUTS + 1];
    @NAME@_state s;
    FILE *in = fopen(argv[1], "rb"), *out = fopen(argv[2], "wb");
    if (!in || !out || argc < 3) return 3;
    @NAME@_init(&s);
    while (fread(rm, sizeof(double), 2 * @NAME@_N_OUTPUTS, in) == 2 * @NAME@_N_OUTPUTS) {
        int status = @NAME@_step(&s, rm, rm + @NAME@_N_OUTPUTS, volt);
        volt[@NAME@_N_INPUTS] = (double)status;
        fwrite(volt, sizeof(double), @NAME@_N_INPUTS + 1, out);
    }
    fclose(out);
    return 0;
}
"""


def _plant():
    ops = [[PrandtlIshlinskii(np.linspace(0, 8, 6), np.array([2.0, 0.8, 0.5, 0.3, 0.2, 0.1])),
            0.2],
           [None, PrandtlIshlinskii(np.linspace(0, 8, 6), np.array([1.8, 0.7, 0.5, 0.3, 0.2, 0.1]))]]
    model = MultivariablePI(ops, input_amplitude=[10.0, 10.0])
    w = 2 * np.pi * 450
    G = control.append(*[control.ss(control.tf([w * w], [1, 2 * 0.08 * w, w * w]))] * 2)
    return HammersteinPlant(model, T, control.sample_system(G, T, "zoh"))


def _run(code, r, meas, tmp_path):
    for fname, text in code.files().items():
        (tmp_path / fname).write_text(text)
    (tmp_path / "h.c").write_text(HARNESS.replace("@NAME@", code.name))
    sources = [str(tmp_path / f) for f in code.files() if f.endswith(".c")]
    exe = tmp_path / "h"
    res = subprocess.run([COMPILERS[0], *CFLAGS, "-o", str(exe), str(tmp_path / "h.c"), *sources,
                          "-lm"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    np.ascontiguousarray(np.vstack([r, meas]).T).tofile(tmp_path / "in.bin")
    subprocess.run([str(exe), str(tmp_path / "in.bin"), str(tmp_path / "out.bin")], check=True)
    return np.fromfile(tmp_path / "out.bin").reshape(-1, code.n_inputs + 1).T


@needs_cc
@pytest.mark.parametrize("anti_windup", ["back-calculation", "clamping"])
@pytest.mark.parametrize("with_ff", [False, True])
def test_c_step_gives_the_kernel_voltages(tmp_path, anti_windup, with_ff):
    plant = _plant()
    ctrl = diagonal_controller([design_axis("pi-notch", 5.0, 150.0, notch_hz=450.0),
                                design_axis("integral", 4.5, 60.0)], T)
    loop = FeedbackLoop(plant, ctrl, Sensor(0.05, 4000.0, 2), AmplifierLimits(-5.0, 5.0, 4e4),
                        anti_windup=anti_windup)
    t = np.arange(3000) * T
    r = np.vstack([25 * np.sin(2 * np.pi * 60 * t), 14 * np.cos(2 * np.pi * 60 * t) - 14])
    comp = InverseMultiplicativeCompensator(plant.hysteresis) if with_ff else None
    f = comp.simulate(r)[0] if with_ff else None
    res = loop.simulate(r, feedforward=f, seed=4)
    assert np.any(np.abs(res.inputs) >= 5.0 - 1e-12)          # the limits act
    code = export_feedback_c(loop, "fb", feedforward=comp)
    out = _run(code, r, res.measurements, tmp_path)
    assert np.max(np.abs(out[:-1] - res.inputs)) <= 1e-12 * np.max(np.abs(res.inputs))
    assert np.any(out[-1].astype(int) & 1)


def test_export_refuses_a_loop_without_controller():
    loop = FeedbackLoop(_plant(), None, Sensor(delay=1))
    with pytest.raises(ExportError, match="controller"):
        export_feedback_c(loop, "fb")
