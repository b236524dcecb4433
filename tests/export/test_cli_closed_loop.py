"""``hammerstein export --closed-loop``: the [feedback] controller with the compensator as
feedforward, compiled with -Werror against its documented header, equals the Python closed
loop (:class:`hammerstein.compensation.feedback.FeedbackLoop`) sample by sample."""

from __future__ import annotations

import re
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import CFLAGS, COMPILERS, Harness, needs_cc
from test_c_equivalence import python_voltages, rel_error

from hammerstein.cli.main import main
from hammerstein.export import export_c
from hammerstein.export.build import compensator_from_source, load_source
from hammerstein.export.fmu import platform_folder
from hammerstein.io.presets import load_plant, read_toml
from hammerstein.scenario.feedback import build_loops
from hammerstein.scenario.feedback_table import check_feedback_table

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "realistic-feedback.toml"

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
        if (fwrite(volt, sizeof(double), @NAME@_N_INPUTS + 1, out) != @NAME@_N_INPUTS + 1) return 4;
    }
    fclose(out);
    return 0;
}
"""


def _export(tmp_path, capsys, kind):
    out = tmp_path / "gen"
    code = main(["export", "realistic-2dof", "--target", "c", "--out", str(out), "--kind", kind,
                 "--name", "loop", "--closed-loop", str(SCENARIO)])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    return out, stdout


def _compile(out):
    (out / "h.c").write_text(HARNESS.replace("@NAME@", "loop"))
    sources = sorted(str(f) for f in out.glob("*.c"))
    res = subprocess.run([COMPILERS[0], *CFLAGS, "-o", str(out / "h"), *sources, "-lm"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return out / "h"


def _run(exe, r, meas):
    d = exe.parent
    np.ascontiguousarray(np.vstack([r, meas]).T).tofile(d / "in.bin")
    subprocess.run([str(exe), str(d / "in.bin"), str(d / "out.bin")], check=True)
    out = np.fromfile(d / "out.bin").reshape(-1, 3).T
    return out[:-1], out[-1].astype(int)


def _loop():
    problems = []
    table = check_feedback_table(read_toml(SCENARIO, "scenario")["feedback"], "feedback", problems)
    assert not problems
    return build_loops(table, load_plant("realistic-2dof"))[0]


def _reference(n=3000, radius=15.0, hz=100.0):
    t = np.arange(n) * 5e-5
    w = 2 * np.pi * hz
    return np.vstack([radius * (1 - np.cos(w * t)), radius * np.sin(w * t) * (1 - np.exp(-t / 2e-3))])


@needs_cc
@pytest.mark.parametrize("kind", ["hammerstein", "preisach-inverse", "none"])
def test_closed_loop_c_equals_the_python_loop(tmp_path, capsys, kind):
    out, stdout = _export(tmp_path, capsys, kind)
    names = {Path(line.split()[-1]).name for line in stdout.splitlines()}
    assert {"loop.h", "loop.c"} <= names and (kind == "none") == ("loop_ff.h" not in names)
    exe = _compile(out)
    yr = _reference()
    loop = _loop()
    P = 0
    f = None
    if kind != "none":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            comp, T = compensator_from_source(load_source("realistic-2dof"), kind)
        P = int(getattr(comp, "preview_samples", 0))
        f = python_voltages(comp, yr)                # call k gets yr[:, k]
        f_c = Harness(export_c(comp, "ff", T), tmp_path / "ff").run(yr)[0]
        if kind == "hammerstein":
            # the ZPETC inverse runs as the same state space in Python and C (it ran in Python
            # as FIR taps plus an IIR part: 3.9e-11 of the voltages apart on this preset). The
            # loop itself is compared with the C feedforward's voltages.
            assert rel_error(f_c, f) <= 1e-12
            f = f_c
        else:
            assert rel_error(f_c, f) <= 1e-12
    # the controller is given the reference P samples after the feedforward (kept in the state,
    # where the feedforward rests until then: the C's NAME_init)
    rest = np.zeros(2) if f is None else np.asarray(export_c(comp, "ff", T).rest_reference)
    assert P == 0 or np.all(np.abs(rest) > 0.1)        # a rest away from 0 µm: the test can fail
    r_loop = np.hstack([np.repeat(rest[:, None], P, axis=1), yr[:, :yr.shape[1] - P]])
    res = loop.simulate(r_loop, feedforward=f, seed=3)
    u_c, status = _run(exe, yr, res.measurements)
    assert rel_error(u_c, res.inputs) <= 1e-12
    assert np.any(status & 1) == bool(np.any(np.abs(res.inputs) >= 10.0 - 1e-12))


@needs_cc
def test_closed_loop_flags_and_skips_non_finite_references(tmp_path, capsys):
    out, _ = _export(tmp_path, capsys, "preisach-inverse")
    exe = _compile(out)
    yr = _reference(400)
    meas = 0.9 * yr
    yr_bad = yr.copy()
    yr_bad[0, 100] = np.nan
    yr_bad[1, 250] = 1e306          # a glitch beyond ten times the model's range, skipped as NaN
    yr_bad[0, 300] = -np.inf
    u, status = _run(exe, yr_bad, meas)
    for k in (100, 250, 300):
        assert status[k] == 4, k
        np.testing.assert_array_equal(u[:, k], u[:, k - 1])      # held
    # the skipped samples left the state untouched: the rest equals a run without them
    keep = np.setdiff1d(np.arange(400), [100, 250, 300])
    u_ref, _ = _run(exe, yr[:, keep], meas[:, keep])
    np.testing.assert_array_equal(u[:, keep], u_ref)


@needs_cc
def test_closed_loop_glitch_measurement_keeps_the_feedforward_in_time(tmp_path, capsys):
    """A NaN or glitch measurement skips the feedback only: the feedforward (a ZPETC inverse
    with a preview) steps on, and the voltage is the new feedforward plus the controller's
    held part. Skipping the feedforward's step too shifted its preview by a sample: the
    inverse then saw a jump of the reference, volts in one sample."""
    out, _ = _export(tmp_path, capsys, "hammerstein")
    exe = _compile(out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp, T = compensator_from_source(load_source("realistic-2dof"), "hammerstein")
    yr = _reference(1500)
    f = Harness(export_c(comp, "ff", T), tmp_path / "ff").run(yr)[0]
    u_clean, _ = _run(exe, yr, yr)                  # measured as asked: the controller idles
    meas = yr.copy()
    meas[1, 700] = np.nan
    meas[0, 1000] = -1e200                          # beyond ten times the model's range
    u, status = _run(exe, yr, meas)
    for k in (700, 1000):
        assert status[k] & 4, k
        held = np.clip(f[:, k] + u[:, k - 1] - f[:, k - 1], -10.0, 10.0)
        np.testing.assert_allclose(u[:, k], held, rtol=0, atol=1e-12)
    assert np.all(status[:700] & 4 == 0)
    # no jump: the largest sample-to-sample step stays that of the run without a glitch
    step_clean = np.max(np.abs(np.diff(u_clean[:, 400:], axis=1)))
    step = np.max(np.abs(np.diff(u[:, 400:], axis=1)))
    assert step <= 1.5 * step_clean, (step, step_clean)


def test_closed_loop_without_a_feedback_table_is_one_line(tmp_path, capsys):
    code = main(["export", "realistic-2dof", "--target", "c", "--out", str(tmp_path / "o"),
                 "--closed-loop"])
    _, err = capsys.readouterr()
    assert code == 1 and len(err.strip().splitlines()) == 1 and "[feedback]" in err
    assert not (tmp_path / "o").exists()


def test_closed_loop_float_is_a_usage_error(tmp_path, capsys):
    code = main(["export", "realistic-2dof", "--target", "c", "--out", str(tmp_path / "o"),
                 "--precision", "float", "--closed-loop", str(SCENARIO)])
    _, err = capsys.readouterr()
    assert code == 2 and "--closed-loop" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


@needs_cc
def test_closed_loop_fmu_equals_the_python_loop(tmp_path, capsys):
    """The FMU of the loop: reference and measurement inputs, voltages and status outputs;
    simulated with fmpy it gives the Python closed loop's voltages."""
    fmpy = pytest.importorskip("fmpy", reason="fmpy (extra [export]) is needed to simulate the FMU")
    from fmpy.validation import validate_fmu
    if platform_folder() is None:
        pytest.skip("unknown platform for an FMU binary")
    out = tmp_path / "gen"
    assert main(["export", "realistic-2dof", "--target", "fmu", "--out", str(out), "--kind",
                 "preisach-inverse", "--name", "loop", "--closed-loop", str(SCENARIO)]) == 0
    capsys.readouterr()
    path = out / "loop.fmu"
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    names = [v.name for v in md.modelVariables]
    assert names == ["reference_x", "reference_y", "measurement_x", "measurement_y",
                     "voltage_ux", "voltage_uy", "status"]
    # the reference starts where the feedforward rests (the model's output at 0 V; this kind
    # does not invert the creep) and the measurement at the plant's rest, creep included: an
    # input left at its start value commands no step (both started at 0 µm: -3.35 / +2.25 V)
    from hammerstein.compensation.drive import rest_output
    plant = load_plant("realistic-2dof")
    starts = [float(v.start) for v in md.modelVariables[:4]]
    np.testing.assert_allclose(starts[:2], rest_output(plant.hysteresis), rtol=1e-12)
    np.testing.assert_allclose(starts[2:], rest_output(plant.hysteresis, plant.creep), rtol=1e-12)
    yr = _reference(1500)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp, _ = compensator_from_source(load_source("realistic-2dof"), "preisach-inverse")
    res = _loop().simulate(yr, feedforward=python_voltages(comp, yr), seed=5)
    n = yr.shape[1]
    sig = np.zeros(n, dtype=[("time", float)] + [(nm, float) for nm in names[:4]])
    sig["time"] = np.arange(n) * 5e-5
    for nm, row in zip(names[:4], np.vstack([yr, res.measurements])):
        sig[nm] = row
    sim = fmpy.simulate_fmu(str(path), start_time=0.0, stop_time=n * 5e-5, step_size=5e-5,
                            output_interval=5e-5, input=sig, output=names[4:])
    u = np.vstack([sim[o] for o in names[4:6]])[:, 1:n + 1]
    assert rel_error(u, res.inputs) <= 1e-12


@needs_cc
def test_closed_loop_states_the_size_the_caller_allocates_and_guards_its_pair(tmp_path, capsys):
    """`export --closed-loop` printed the feedforward's state (sizeof(loop_ff_state)) as
    the state: the caller allocates loop_state, which holds it. The loop's header states
    its size as the compensator's does, and its .c refuses another run's header."""
    out, stdout = _export(tmp_path, capsys, "hammerstein")
    header = (out / "loop.h").read_text()
    for macro in ("loop_STATE_BYTES sizeof(loop_state)", "loop_STATE_REALS", "loop_BUILD_ID"):
        assert f"#define {macro}" in header
    said = [line for line in stdout.splitlines() if line.startswith("state:")]
    assert said and "(sizeof(loop_state))" in said[0], stdout
    before_padding = int(re.search(r", (\d+) B before padding", said[0]).group(1))
    probe = out / "size.c"
    probe.write_text('#include <stdio.h>\n#include "loop.h"\nint main(void) { printf("%lu %d\\n", '
                     '(unsigned long)sizeof(loop_state), loop_STATE_REALS); return 0; }\n')
    exe = out / "size"
    subprocess.run([COMPILERS[0], *CFLAGS, "-I", str(out), "-o", str(exe), str(probe)], check=True)
    size, reals = (int(v) for v in subprocess.run([str(exe)], capture_output=True, text=True,
                                                   check=True).stdout.split())
    assert before_padding <= size < before_padding + 64          # the padding only
    assert reals * 8 < size
    # the pair's fingerprint: another run's header (here one byte of code changed) is refused
    (out / "loop.h").write_text(header.replace("#define loop_BUILD_ID 0x", "#define loop_BUILD_ID 0x1"))
    res = subprocess.run([COMPILERS[0], *CFLAGS, "-c", "-o", str(out / "l.o"), str(out / "loop.c")],
                         capture_output=True, text=True)
    assert res.returncode != 0 and "is not the header exported with this loop.c" in res.stderr


def test_a_scenario_of_another_plant_is_named_when_its_controller_is_designed_here(tmp_path,
                                                                                    capsys):
    """The [feedback] table's named designs take the exported model's gains and modes: a
    scenario whose [plant] is another stage gets one warning line saying so; the
    scenario's own stage gets none."""
    text = SCENARIO.read_text()
    assert 'preset = "realistic-2dof"' in text
    other = tmp_path / "other.toml"
    other.write_text(text.replace('preset = "realistic-2dof"', 'preset = "rakotondrabe-2dof"', 1))
    for scenario, said in ((SCENARIO, False), (other, True)):
        code = main(["export", "realistic-2dof", "--out", str(tmp_path / scenario.stem),
                     "--kind", "none", "--no-binary", "--closed-loop", str(scenario)])
        err = capsys.readouterr().err
        assert code == 0, err
        lines = [line for line in err.splitlines() if "designed here on realistic-2dof" in line]
        assert len(lines) == int(said) and (not said or "rakotondrabe-2dof" in lines[0]), err
