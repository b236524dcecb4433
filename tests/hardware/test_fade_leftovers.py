"""Fade-in leftovers: the default never outruns the slew limit; --fade-in 0 needs a reference at rest.

Expectations are independent of the implementation: the slew limit is
checked on every step of the voltages from the amplifier's rest (including
the first), for every kind, with a settle bound that would make the
fade far too short; a circle starting at x = R with
``--fade-in 0`` is refused with one line and nothing written, while a
sine starting at rest is accepted with ``--fade-in 0``.
"""

import contextlib
import io
import subprocess

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.io.presets import load_plant
from hammerstein.models.amplifier import amplifier_from_table
from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                           StaticGainCompensator, diagonal_compensator)
from hammerstein.compensation.drive import default_fade_samples, drive_signal, rest_output
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator

T = 5e-5


def _kinds(plant):
    m = plant.hysteresis
    return {"multivariable": InverseMultiplicativeCompensator(m), "diagonal": diagonal_compensator(m),
            "per-axis": PerAxisInverseCompensator(m), "static-gain": StaticGainCompensator(m),
            "hammerstein": HammersteinCompensator(m, plant.dynamics)}


def _circle(n, f, R):
    t = np.arange(n) * T
    return R * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def _steps(u, rest=0.0):
    return np.abs(np.diff(np.concatenate([np.full((u.shape[0], 1), rest), u], axis=1), axis=1))


@pytest.mark.parametrize("kind", ["multivariable", "diagonal", "per-axis", "static-gain", "hammerstein"])
def test_default_fade_never_steps_faster_than_the_slew_limit(preset_plant, kind):
    # a 25 µm circle at 20 Hz starts near 5 V and needs 2 pi 20 * 5 = 630 V/s; the metrics skip
    # only 10 samples, and a 10-sample fade would step about 5 * pi / 2 / 10 = 0.8 V per sample
    # (16000 V/s) on an amplifier of 4000 V/s: the default must be longer than the settle bound
    slew = 4000.0                                          # V/s
    amp = amplifier_from_table({"range": [-10, 10], "slew_rate": slew}, ["ux", "uy"])
    comp = _kinds(preset_plant)[kind]
    yr = _circle(6000, 20.0, 25.0)
    d = drive_signal(comp, yr, T, 1000, amplifier=amp, limits="error", settle_samples=10)
    assert d.fade_samples > 10 and d.problems == []
    assert np.max(_steps(d.commanded)) <= slew * T * (1 + 1e-9)     # every step, the first too


def test_scenario_default_fade_of_a_rate_independent_kind_holds_the_slew_limit(preset_plant):
    amp = amplifier_from_table({"range": [-10, 10], "slew_rate": 2000.0}, ["ux", "uy"])
    comp = InverseMultiplicativeCompensator(preset_plant.hysteresis)
    yr = _circle(6000, 20.0, 25.0)
    n = default_fade_samples(yr, 1000, 10, comp, amp, T)          # the scenarios' call
    k = np.arange(6000)
    u, _ = comp.simulate(yr * np.where(k < n, 0.5 * (1 - np.cos(np.pi * k / n)), 1.0))
    assert n > 10 and np.max(_steps(u)) <= 2000.0 * T * (1 + 1e-9)
    # without T (older callers): the settle bound, as before; without a slew rate: no fade
    assert default_fade_samples(yr, 1000, 10, comp, amp) == 10
    assert default_fade_samples(yr, 1000, 10, comp, None, T) == 0


def _cli(*args, cwd):
    """``hammerstein ARGS`` run in ``cwd`` by the CLI's ``main()`` in this process.

    The refusal is about the command's check, not the process (tests/cli
    covers exit codes of a real process): in-process saves a Python start
    and the imports. Returns the status and the captured stdout/stderr.
    """
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def test_compensate_fade_in_0_refuses_a_reference_not_at_rest(tmp_path):
    circle = '{ kind = "circle", radius = 25, frequency = 100, periods = 4 }'
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", circle, "--out", "d.csv",
               "--fade-in", "0", cwd=tmp_path)
    assert res.returncode == 1 and res.stderr.count("\n") == 1, res.stderr
    assert "--fade-in 0" in res.stderr and "x = 25 µm" in res.stderr and "not at rest" in res.stderr
    assert not (tmp_path / "d.csv").exists()
    sine = '{ kind = "sine", output = "x", amplitude = 20, frequency = 100, periods = 4 }'
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", sine, "--out", "s.csv",
               "--fade-in", "0", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "fade-in 0 samples" in (tmp_path / "s.csv").read_text()


def test_fade_in_0_needs_the_models_output_at_0_V_not_0_um(tmp_path):
    """realistic-2dof's asymmetric Preisach loops rest at (-1.754, 0.7235) um at 0 V: with
    --fade-in 0, a sine from 0 um is refused (its drive would start at the voltage of 0 um,
    a step from rest), a reference held at the rest output for its first 100 samples is taken
    and its drive starts at 0 V."""
    plant = load_plant("realistic-2dof")
    rest = rest_output(plant.hysteresis, plant.creep)
    assert np.all(np.abs(rest) > 0.5)
    sine = '{ kind = "sine", output = "x", amplitude = 5, frequency = 100, periods = 4 }'
    res = _cli("compensate", "realistic-2dof", "--reference", sine, "--out", "d.csv",
               "--fade-in", "0", cwd=tmp_path)
    assert res.returncode == 1 and res.stderr.count("\n") == 1, res.stderr
    assert "not at rest" in res.stderr and f"x = {rest[0]:.7g} µm" in res.stderr, res.stderr
    assert not (tmp_path / "d.csv").exists()
    t = np.arange(800) * plant.sampling_period
    move = 2.5 * (1 - np.cos(2 * np.pi * 100 * np.maximum(t - 100 * plant.sampling_period, 0)))
    ref = np.vstack([rest[0] + move, np.full(t.size, rest[1])])
    np.savetxt(tmp_path / "ref.csv", np.vstack([t, ref]).T, delimiter=",", header="t,x,y",
               comments="")
    res = _cli("compensate", "realistic-2dof", "--reference", "ref.csv", "--period", "0.01",
               "--out", "s.csv", "--fade-in", "0", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    rows = [line for line in (tmp_path / "s.csv").read_text().splitlines()
            if not line.startswith("#")]
    assert rows[0] == "t,ux,uy"
    first = np.array(rows[1].split(","), dtype=float)
    assert np.all(np.abs(first[1:]) < 1e-9), first           # the root's tolerance, not a step


def test_the_laws_dynamics_inverse_starts_at_rest_in_the_frame_it_filters():
    """Over a classical PI with an offset c and an output map S, the law's kernel and its C
    filter S^-1(Yr - c). A reference held at the model's output at 0 V, Gamma(0), is 0 in that
    frame, so every voltage is 0: the inverse's preview and state at rest are taken in that frame
    too (they were taken on Yr itself, and the drive started with +-1 V spikes)."""
    from hammerstein.models.hysteresis import MultivariablePI, OutputMap, PrandtlIshlinskii
    model = MultivariablePI(
        [[PrandtlIshlinskii([0.0, 1.0, 2.0, 4.0], [1.0, 0.5, 0.25, 0.2]), 0.1],
         [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.1, 1.0, 3.0], [0.8, 0.4, 0.3])]],
        input_amplitude=[10.0, 10.0], output_offset=[0.5, -1.0],
        output_map=[OutputMap([5.0, 12.0], [1.0, 0.8, 0.6]), OutputMap([], [1.2])])
    comp = HammersteinCompensator(model, load_plant("rakotondrabe-2dof").dynamics)
    assert comp.preview_samples > 0 and not comp.exact_static
    y0 = rest_output(model)
    assert np.all(np.abs(y0) > 0.4)
    ref = np.repeat(y0[:, None], 400, axis=1)
    u = drive_signal(comp, ref, 5e-5, None, 0).inputs
    assert np.max(np.abs(u)) < 1e-12, np.max(np.abs(u))
