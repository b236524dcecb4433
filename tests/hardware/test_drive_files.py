"""Drive signals and drive files: the scenario route's voltages, chunks, limits, refusals.

Expectations: the scenario route (``run_case`` of a resolved scenario and its
timeseries) computed independently of :func:`drive_signal`; chunked == whole;
the amplifier's limits as closed forms (a step from rest of V volts in one
sample is V / T volts per second).
"""

import contextlib
import io
import subprocess

import numpy as np
import pandas as pd
import pytest

from hammerstein.models.amplifier import amplifier_from_table
from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                           StaticGainCompensator, diagonal_compensator)
from hammerstein.cli.main import main
from hammerstein.compensation.drive import (FADE_DECAYS, MIN_FADE_S, DriveStream, drive_fade_samples,
                                            drive_signal, hardware_drive, hardware_fade, read_signals)
from hammerstein.compensation.drive_files import drive_input_names, fade_weight
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.exceptions import AmplifierError, CompensatorError
from hammerstein.runner import run_scenario
from hammerstein.scenario.execute import fade_samples, run_case
from hammerstein.scenario.resolve import load_scenario
from hammerstein.simulation import simulate_chain

T = 5e-5


def circle(n=3000, f=100.0, R=25.0):
    t = np.arange(n) * T
    return R * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def kinds(plant):
    m = plant.hysteresis
    return {
        "multivariable": InverseMultiplicativeCompensator(m),
        "diagonal": diagonal_compensator(m),
        "per-axis": PerAxisInverseCompensator(m),
        "static-gain": StaticGainCompensator(m),
        "hammerstein": HammersteinCompensator(m, plant.dynamics),
    }


KINDS = ["multivariable", "diagonal", "per-axis", "static-gain", "hammerstein"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("chunk", [1, 3, 250, 1999])
def test_chunked_equals_whole(preset_plant, kind, chunk):
    comp = kinds(preset_plant)[kind]
    # sample by sample: 700 samples (fade-in 200, look-ahead 200, 300 beyond both) instead of
    # 2000 pushes of one sample (0.6 s of CPU each kind); the other chunks run 2000 samples
    n = 700 if chunk == 1 else 2000
    yr = circle(n)
    whole = drive_signal(comp, yr, T, 200, fade_samples=200).inputs
    stream = DriveStream(comp, 200, 200)
    parts = [stream.push(yr[:, k:k + chunk]) for k in range(0, n, chunk)] + [stream.finish()]
    np.testing.assert_allclose(np.concatenate(parts, axis=1), whole, rtol=0, atol=1e-9)


SCENARIO = """
name = "route"
[plant]
preset = "{preset}"
dynamics = true
[compensator]
kind = "{kind}"
{extra}
[[cases]]
name = "c"
settle_periods = 2
reference = {{ kind = "circle", radius = 25.0, frequency = 100.0, periods = 6 }}
"""


@pytest.mark.parametrize("kind, extra", [("hammerstein", ""), ("hammerstein", 'inversion = "stable"'),
                                         ("multivariable", "fade_in = 0.01"),
                                         ("per-axis", "")])
def test_drive_reproduces_the_scenario_route(tmp_path, kind, extra, no_figures):
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.format(preset="rakotondrabe-2dof", kind=kind, extra=extra))
    case = load_scenario(p).cases[0]
    route = run_case(case).inputs
    T_ = case.plant.sampling_period
    d = drive_signal(case.compensator, case.signal, T_, case.period_samples, fade_samples(case))
    np.testing.assert_allclose(d.inputs, route, rtol=0, atol=1e-9)
    # the timeseries CSV of `hammerstein run` holds the same voltages (to its 6 digits)
    out = run_scenario(p, tmp_path / "out", renderer=no_figures)
    assert out.ok, out.error
    ts = pd.read_csv(out.out_dir / "timeseries-c.csv")
    np.testing.assert_allclose(ts[["ux_V", "uy_V"]].to_numpy().T, d.inputs, rtol=5e-6, atol=1e-9)


def test_simulate_chain_refuses_the_hammerstein_compensator_and_names_the_call(preset_plant):
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    with pytest.raises(CompensatorError, match=r"run_reference\(plant, reference.*drive_signal"):
        simulate_chain(comp, preset_plant, circle(400))
    res = comp.run_reference(preset_plant, circle(400), 200, 200)     # the right call still runs
    assert np.all(np.isfinite(res.outputs))


@pytest.mark.parametrize("kind", KINDS)
def test_no_kind_steps_beyond_the_slew_limit_without_its_reaction(preset_plant, kind):
    amp = amplifier_from_table({"range": [-10, 10], "slew_rate": 2e4}, ["ux", "uy"])
    comp = kinds(preset_plant)[kind]
    yr = circle(2000, f=50.0)
    d = drive_signal(comp, yr, T, 400, amplifier=amp, limits="error")   # default fade: passes
    assert d.fade_samples == 400 and d.problems == []
    assert np.all(np.abs(np.diff(np.concatenate([np.zeros((2, 1)), d.inputs], 1))) <= 2e4 * T)
    with pytest.raises(AmplifierError, match="slew rate of .* beyond the amplifier's 2e\\+04 V/s"):
        drive_signal(comp, yr, T, 400, fade_samples=0, amplifier=amp, limits="error")
    clipped = drive_signal(comp, yr, T, 400, fade_samples=0, amplifier=amp, limits="clip")
    steps = np.abs(np.diff(np.concatenate([np.zeros((2, 1)), clipped.inputs], 1)))
    assert clipped.problems and steps.max() <= 2e4 * T * (1 + 1e-9)
    assert clipped.peak_slew.max() > 2e4                            # measured on the command


AMP_PRESET = "\n[amplifier]\nrange = [-5.0, 5.0]\n"


def test_scenario_warns_once_per_input_and_saturates_the_plant(tmp_path, repo_root, no_figures):
    text = (repo_root / "hammerstein/presets/rakotondrabe-2dof.toml").read_text()
    (tmp_path / "amp.toml").write_text(text + AMP_PRESET)
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.format(preset="amp.toml", kind="multivariable", extra=""))
    case = load_scenario(p).cases[0]
    res = run_case(case)
    msgs = [w for w in res.warnings if "beyond the amplifier" in w]
    assert len(msgs) == 2 and all("[-5, 5] V" in w for w in msgs)
    assert {w.split()[1] for w in msgs} == {"ux", "uy"}
    assert np.max(np.abs(res.inputs)) <= 5.0
    y, _ = case.plant.simulate(np.clip(res.inputs, -5, 5))
    np.testing.assert_allclose(res.outputs, y, atol=1e-12)
    peaks = {(r["channel"], r["metric"]): r["value"] for r in res.metrics}
    assert peaks[("ux", "peak_input")] > 5.0                         # the command, not the clip
    p.write_text(SCENARIO.format(preset="amp.toml", kind="multivariable", extra='limits = "error"'))
    out = run_scenario(p, tmp_path / "out", renderer=no_figures)
    assert not out.ok and "input ux needs" in out.error and "[-5, 5] V" in out.error


def _cli(*args, cwd):
    """``hammerstein ARGS`` run in ``cwd`` by the CLI's ``main()`` in this process.

    These tests are about the files the commands read and write, not about the
    process (tests/cli covers that): in-process saves a Python start and the
    imports per command. Returns the status and the captured stdout/stderr.
    """
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


@pytest.mark.parametrize("decay, expected", [
    (None, None),            # no modes: the period / MIN_FADE_S rule alone
    (0.03, 2400),            # four decay times, 0.12 s at T = 50 µs
    (0.1, 3000),             # 0.4 s: at most half the 0.3 s record
])
def test_default_fade_lasts_four_decay_times_of_the_slowest_mode(preset_plant, decay, expected):
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    ref = circle(6000)
    base = hardware_drive(comp, ref, T, 200).fade_samples
    d = hardware_drive(comp, ref, T, 200, mode_decay=decay)
    assert base * T >= MIN_FADE_S and base < 2400
    if expected is None:
        assert d.fade_samples == base
    else:
        assert FADE_DECAYS == 4.0 and d.fade_samples == expected
        assert np.all(d.inputs[:, 0] == 0.0)
        np.testing.assert_allclose(d.reference, hardware_fade(ref, expected), atol=1e-12)


def test_compensate_writes_the_drive_and_refuses_what_the_amplifier_cannot(tmp_path, preset_plant,
                                                                          repo_root):
    ref = '{ kind = "circle", radius = 25, frequency = 100, periods = 6 }'
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "d.csv",
               "--predicted", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    t, u, T_ = read_signals(tmp_path / "d.csv", ["ux", "uy"])
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    # the scenario route's voltages of the reference faded in over the duration the header states
    # (the default's start-up may be slew-limited to the settled drive's largest step: with that
    # duration given, the drive is exactly the scenario route's)
    fade = drive_fade_samples(tmp_path / "d.csv")
    assert fade * T >= MIN_FADE_S and np.all(u[:, 0] == 0.0)
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "d1.csv",
               "--fade-in", str(fade * T), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    u = read_signals(tmp_path / "d1.csv", ["ux", "uy"])[1]
    d = drive_signal(comp, hardware_fade(circle(1200), fade), T, 200, fade_samples=0)
    np.testing.assert_allclose(u, d.inputs, rtol=0, atol=1e-12)       # full precision
    assert T_ == pytest.approx(T)
    # a CSV reference gives the same drive
    pd.DataFrame({"t": t, "x": circle(1200)[0], "y": circle(1200)[1]}).to_csv(tmp_path / "r.csv",
                                                                              index=False)
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", "r.csv", "--out", "d2.csv",
               "--fade-in", str(fade * T), "--period", "0.01", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    np.testing.assert_allclose(read_signals(tmp_path / "d2.csv", ["ux", "uy"])[1], d.inputs,
                               rtol=0, atol=1e-9)
    # beyond a +-5 V amplifier: one line, exit 1, nothing written
    text = (repo_root / "hammerstein/presets/rakotondrabe-2dof.toml").read_text()
    (tmp_path / "amp.toml").write_text(text + AMP_PRESET)
    res = _cli("compensate", "amp.toml", "--reference", ref, "--out", "d3.csv", cwd=tmp_path)
    assert res.returncode == 1 and res.stderr.count("\n") == 1, res.stderr
    assert "beyond the amplifier's range [-5, 5] V" in res.stderr and not (tmp_path / "d3.csv").exists()
    res = _cli("compensate", "amp.toml", "--reference", ref, "--out", "d3.csv", "--limits", "clip",
               cwd=tmp_path)
    assert res.returncode == 0 and np.max(np.abs(read_signals(tmp_path / "d3.csv",
                                                              ["ux", "uy"])[1])) <= 5.0
    # a file the project did not write is not replaced
    (tmp_path / "mine.csv").write_text("t,ux\n0,1\n")
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "mine.csv",
               cwd=tmp_path)
    assert res.returncode == 2 and "--force" in res.stderr
    assert (tmp_path / "mine.csv").read_text() == "t,ux\n0,1\n"


# The signal files' size and kind errors named the file twice ("--reference: sparse.csv:
# sparse.csv: 2 GiB ..."): once.
def test_a_signal_file_too_large_is_named_once(tmp_path, monkeypatch):
    from hammerstein.compensation.drive_files import read_signals
    from hammerstein.exceptions import DataFileError
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", "100")
    (tmp_path / "big.csv").write_text("t,x\n" + "0,0\n" * 100)
    with pytest.raises(DataFileError) as err:
        read_signals("big.csv", ["x"], what="--reference")
    assert str(err.value).startswith("--reference: big.csv: ")
    assert str(err.value).count("big.csv") == 1, str(err.value)


@pytest.mark.parametrize("outputs", [["x", "y", "z"], ["x", "y"], []])
def test_the_inputs_of_a_drive_file_are_never_its_aimed_or_predicted_columns(tmp_path, outputs):
    # a three-output drive judged on x, y: its z_predicted and z_shaped are no inputs (they
    # were reported as one, "z_predicted peak_input 0.116 V")
    path = tmp_path / "drive.csv"
    path.write_text("# hammerstein compensate drive: t [s]; ux, uy, uz [V]\n"
                    "t,ux,uy,uz,x_shaped,y_shaped,z_shaped,x_predicted,y_predicted,"
                    "z_predicted\n0,0,0,0,0,0,0,0,0,0\n")
    assert drive_input_names(path, outputs) == ["ux", "uy", "uz"]


@pytest.mark.parametrize("fade", [1313, 2000, 4875])
def test_the_fade_weights_are_the_documented_products_a_c_caller_repeats(fade):
    # docs/real-time.md: s2 = s * s; w = (s2 * s2) * (35 - 84 s + 70 s2 - 20 (s2 * s)), each
    # operation one IEEE double rounding as in C without contraction (Python floats are
    # C doubles), so a caller's weights, and its faded reference, equal hardware_fade's
    lead = fade // 10
    s = [(k - lead) / (fade - lead) for k in range(lead, fade)]
    own = []
    for x in s:
        x2 = x * x
        own.append((x2 * x2) * (35.0 - 84.0 * x + 70.0 * x2 - 20.0 * (x2 * x)))
    np.testing.assert_array_equal(fade_weight(np.array(s)), np.array(own))
    yr = np.vstack([np.linspace(3.0, 40.0, fade + 5), np.linspace(-7.0, 1.0, fade + 5)])
    rest = np.array([0.56, -1.65])
    faded = hardware_fade(yr, fade, rest)
    caller = yr.copy()
    caller[:, :lead] = rest[:, None]
    caller[:, lead:fade] = rest[:, None] + np.array(own) * (yr[:, lead:fade] - rest[:, None])
    np.testing.assert_array_equal(faded, caller)
