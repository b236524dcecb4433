"""Safe drives by default (issue 38, item 4): a duration of fade-in, the records' limits.

Expectations are closed-form properties of the drive file, checked on every
sample independently of the implementation: the first sample is the
amplifier's rest (0 V); no sample-to-sample step (the first counted from
rest) exceeds the slew rate times T, nor the settled drive's own largest
step (after the fade-in the header states and one period); every sample is
within the range; the fade-in is at least 20 ms. For every compensator kind
of ``compensate`` and every kind of reference: an inline circle that starts
at (r, 0), an inline raster, and the same circle as a CSV file (with and
without ``--period``), whose default fade was one sampling period before.
"""

import contextlib
import io
import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import tomllib

from hammerstein.cli._hardware import end_note
from hammerstein.cli.main import main
from hammerstein.models.amplifier import (amplifier_from_table, records_amplifier_table,
                                         records_hold_steps)
from hammerstein.compensation.drive import (drive_signal, hardware_drive, hardware_fade, keep_end,
                                            limit_start_up,
                                           keep_start, read_signals, settled_step, shape_drive)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.io.presets import load_plant, resolve_preset

T = 5e-5
RANGE = 5.0          # V: a 30 µm circle on rakotondrabe-2dof needs about 6 V: shaped
SLEW = 2.0e4         # V/s
KINDS = ["hammerstein", "multivariable", "diagonal", "per-axis", "static-gain"]
CIRCLE = '{ kind = "circle", radius = 30, frequency = 100, periods = 12 }'
RASTER = '{ kind = "raster", size = [40, 40], lines = 4, frequency = 50, outputs = ["x", "y"] }'


def _preset(tmp_path, amplifier=True):
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    if amplifier:
        text += (f'\n[amplifier]\nsource = "records"\nrange = [{-RANGE}, {RANGE}]\n'
                 f'slew_rate = {SLEW}\n')
    path = tmp_path / ("records.toml" if amplifier else "plain.toml")
    path.write_text(text)
    return path


def _circle_csv(tmp_path, n=2400, f=100.0, R=30.0):
    t = np.arange(n) * T
    path = tmp_path / "circle.csv"
    np.savetxt(path, np.column_stack([t, R * np.cos(2 * np.pi * f * t), R * np.sin(2 * np.pi * f * t)]),
               delimiter=",", header="t,x,y", comments="", fmt="%.12g")
    return path


def _compensate(args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", *map(str, args)])
    assert code == 0, err.getvalue()
    return out.getvalue() + err.getvalue()      # shaped: lines on stdout, note: lines on stderr


def _drive(path):
    text = Path(path).read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    rows = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    data = np.array([[float(v) for v in ln.split(",")] for ln in rows[1:]])
    return data[:, 1:3].T, fade, text


def _steps(u):
    return np.abs(np.diff(np.concatenate([np.zeros((u.shape[0], 1)), u], axis=1), axis=1))


def _reference(kind, tmp_path):
    if kind == "circle":
        return [CIRCLE], 200
    if kind == "raster":
        return [RASTER], 400
    csv = _circle_csv(tmp_path)
    if kind == "file":
        return [csv], 1
    return [csv, "--period", 0.01], 200


@pytest.mark.parametrize("ref", ["circle", "raster", "file", "file-period"])
@pytest.mark.parametrize("kind", KINDS)
def test_default_drive_is_safe_for_every_kind_and_reference(tmp_path, kind, ref):
    preset = _preset(tmp_path)
    reference, period = _reference(ref, tmp_path)
    out = tmp_path / "drive.csv"
    _compensate([preset, "--reference", *reference[:1], *reference[1:], "--kind", kind,
                 "--out", out])
    u, fade, text = _drive(out)
    steps = _steps(u)
    assert fade * T >= 0.02 - 1e-12                         # a duration, never one sample
    assert np.all(u[:, 0] == 0.0)                           # the first sample at rest
    assert np.max(steps) <= SLEW * T * (1 + 1e-9)           # never faster than the slew rate
    assert np.all(np.abs(u) <= RANGE * (1 + 1e-12))         # within the records' range
    settled = steps[:, fade + max(period, 1) + 1:].max(axis=1)
    assert np.all(steps.max(axis=1) <= settled * (1 + 1e-9))  # no step beyond the settled drive's
    assert "excluded from the metrics" in text


@pytest.mark.parametrize("kind", KINDS)
def test_file_reference_without_amplifier_fades_over_a_duration(tmp_path, kind):
    """The issue's case: a file reference starting at (r, 0) stepped rail to rail in one sample."""
    out = tmp_path / "drive.csv"
    _compensate([_preset(tmp_path, amplifier=False), "--reference", _circle_csv(tmp_path),
                 "--kind", kind, "--out", out])
    u, fade, _ = _drive(out)
    steps = _steps(u)
    assert fade * T >= 0.02 - 1e-12 and np.all(u[:, 0] == 0.0)
    settled = steps[:, fade + 1:].max(axis=1)
    assert np.all(steps.max(axis=1) <= settled * (1 + 1e-9))
    assert np.max(steps) < 0.5                              # V per sample (it was 16 V)


def test_a_circle_beyond_the_range_is_shaped_and_says_where(tmp_path):
    out = tmp_path / "drive.csv"
    printed = _compensate([_preset(tmp_path), "--reference", CIRCLE, "--kind", "multivariable",
                           "--out", out])
    u, _, text = _drive(out)
    assert "beyond the range [-5, 5] V by up to" in text and "shaped:" in printed
    assert re.search(r"\d\.\d{4}-\d\.\d{4} s", text)       # the time intervals
    assert np.isclose(np.max(np.abs(u)), RANGE)
    printed = _compensate([_preset(tmp_path), "--reference", RASTER, "--out", out])
    assert "reference shaped by up to" in printed and "smoothing = S" in printed
    u, _, text = _drive(out)
    assert np.max(np.abs(u)) <= RANGE + 1e-9                # the reference shaped, not the drive
    assert "x_shaped y_shaped [µm]" in text


def test_records_amplifier_table_is_the_records_range_and_largest_slew():
    recs = [SimpleNamespace(u=np.array([[0.0, 2.0, -3.0], [1.0, 1.0, 1.5]]), sampling_period=1e-3),
            SimpleNamespace(u=np.array([[4.0, 4.5], [0.0, -1.0]]), sampling_period=2e-3)]
    table = records_amplifier_table(recs, ["ux", "uy"])
    assert table["source"] == "records"
    assert table["ux"] == {"range": [-3.0, 4.5], "slew_rate": 5000.0}   # |-3 - 2| / 1 ms
    assert table["uy"] == {"range": [-1.0, 1.5], "slew_rate": 500.0}    # 0.5/1 ms, 1/2 ms
    amp = amplifier_from_table(table, ["ux", "uy"])
    assert amp.from_records and amp.channels[0].low == -3.0 and amp.channels[1].slew_rate == 500.0


@pytest.mark.parametrize("u, slew, kept", [
    # 0 V held, the sine started at -87 V in one sample: the step is not the records' slew
    ([0.0, 0.0, 0.0, -87.0, -86.0, -84.0, -81.0], 3000.0, True),
    # the same, switched off again into a final hold of 0 V
    ([0.0, 0.0, -87.0, -86.0, -84.0, -81.0, 0.0, 0.0], 3000.0, True),
    # moving from its first sample (no hold): every step counts
    ([0.0, -87.0, -86.0, -84.0, -81.0], 87000.0, False),
    # a step response is all the record does: its step is its slew
    ([0.0, 0.0, 0.0, 5.0, 5.0, 5.0], 5000.0, False),
])
def test_records_slew_leaves_out_a_step_out_of_or_into_a_hold(u, slew, kept):
    rec = SimpleNamespace(u=np.array([u]), sampling_period=1e-3)
    assert records_amplifier_table([rec], ["u"])["u"]["slew_rate"] == slew
    held = records_hold_steps([rec], ["u"])
    assert (held["u"][2] > slew) if kept else ("u" not in held or held["u"][2] <= slew)


def test_identify_names_the_bundled_records_start_up_step(tmp_path, capsys):
    data = Path(__file__).resolve().parents[2] / "hammerstein" / "data" / "piezo-stack-150V-1Hz.csv"
    out = tmp_path / "stack.toml"
    assert main(["identify", str(data), "--input", "2", "--output", "1", "--time", "0",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "step of -87.1 V at 3.257 s" in err
    slew = tomllib.loads(out.read_text())["amplifier"]["u"]["slew_rate"]
    assert 940.0 < slew < 945.0            # 150 V x 2 pi x 1 Hz, sampled at 5 kHz


def test_shape_drive_closed_form():
    amp = amplifier_from_table({"source": "records", "range": [-1.0, 1.0], "slew_rate": 100.0}, ["u"])
    u = np.array([[0.0, 0.5, 3.0, 3.0, 0.9, 0.0]])
    out, notes = shape_drive(amp, u, 1e-3)                   # 0.1 V per sample
    np.testing.assert_allclose(out[0], [0.0, 0.1, 0.2, 0.3, 0.4, 0.3])
    assert len(notes) == 1 and "beyond the range [-1, 1] V by up to 2 V" in notes[0]


def test_hardware_fade_rest_lead_and_keep_start():
    r = np.ones((2, 100)) * 7.0
    f = hardware_fade(r, 50, rest=[1.0, -1.0])
    np.testing.assert_array_equal(f[:, :6], [[1.0] * 6, [-1.0] * 6])   # a tenth at rest (5 + w(0))
    np.testing.assert_array_equal(f[:, 50:], r[:, 50:])
    assert np.all(np.diff(f[0]) >= 0)
    u = keep_start(np.zeros((1, 40)), np.ones((1, 40)), 10, 10)
    assert u[0, 0] == 0.0                                    # the previous drive's start: at rest
    np.testing.assert_array_equal(u[0, 20:], 1.0)            # the learnt drive from a period on
    b = 0.5 * (1 - np.cos(np.pi * np.arange(20) / 20))       # a raised cosine over fade + period
    np.testing.assert_allclose(u[0, :20], b, rtol=0, atol=1e-15)


def test_a_raster_start_up_is_shaped_not_slew_limited(tmp_path):
    """A raster whose line steps were shaped: its first step after the fade, which the settled
    drive never needs so fast, is shaped as well (not slew-limited afterwards), so the drive
    still follows a reference (the file's shaped one) everywhere after the fade."""
    out = tmp_path / "drive.csv"
    raster = ('{ kind = "raster", size = [20, 20], lines = 6, frequency = 50, '
              'outputs = ["x", "y"] }')
    printed = _compensate([_preset(tmp_path), "--reference", raster, "--out", out])
    u, fade, text = _drive(out)
    assert "reference shaped by up to" in printed
    assert "slew-limited to the settled drive's largest step" not in text
    steps = _steps(u)
    settled = steps[:, fade + 400 + 1:].max(axis=1)              # one 50 Hz line after the fade
    assert np.all(steps.max(axis=1) <= settled * (1 + 1e-6))


def test_evaluate_judges_against_the_shaped_reference_too(tmp_path):
    """A drive that follows a shaped reference: evaluate reports both references.

    The "measurement" is the drive file's shaped reference itself, so against
    it every error is 0 (closed form) while against the raw raster the error is
    the shaping's own deviation (the reference moved by up to several µm).
    """
    out = tmp_path / "drive.csv"
    _compensate([_preset(tmp_path), "--reference", RASTER, "--out", out])
    drive = pd.read_csv(out, comment="#")
    measured = tmp_path / "measured.csv"
    drive[["t", "x_shaped", "y_shaped"]].rename(columns={"x_shaped": "x", "y_shaped": "y"}).to_csv(
        measured, index=False)
    ev = tmp_path / "ev"
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["evaluate", "--reference", RASTER, "--measured", str(measured),
                     "--drive", str(out), "--out", str(ev)])
    assert code == 0, err.getvalue()
    m = pd.read_csv(ev / "metrics.csv").set_index(["case", "channel", "metric"])["value"]
    assert m[("shaped", "x+y", "max_euclidean_error")] == pytest.approx(0.0, abs=1e-6)
    assert m[("measured", "x+y", "max_euclidean_error")] > 1.0       # µm: the raster was shaped
    assert "Against the shaped reference" in (ev / "report.md").read_text()


def test_evaluate_without_shaped_columns_reports_the_reference_only(tmp_path):
    out = tmp_path / "drive.csv"
    _compensate([_preset(tmp_path, amplifier=False), "--reference", CIRCLE, "--out", out])
    assert "x_shaped" not in pd.read_csv(out, comment="#").columns
    measured = tmp_path / "measured.csv"
    t = np.arange(pd.read_csv(out, comment="#").shape[0]) * T
    pd.DataFrame({"t": t, "x": 30 * np.cos(2 * np.pi * 100 * t),
                  "y": 30 * np.sin(2 * np.pi * 100 * t)}).to_csv(measured, index=False)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["evaluate", "--reference", CIRCLE, "--measured", str(measured),
                     "--drive", str(out), "--out", str(tmp_path / "ev")]) == 0
    cases = set(pd.read_csv(tmp_path / "ev/metrics.csv")["case"])
    assert cases == {"measured"}


OUTSIDE_GPI = Path(__file__).parent / "data" / "outside-gpi-identified.toml"


@pytest.mark.parametrize("preset, frequency", [("outside", 20.0), ("bundled", 20.0),
                                               ("bundled", 50.0)])
def test_start_up_shaping_never_changes_the_settled_reference(tmp_path, preset, frequency):
    """What is judged (one period after the fade on) is the reference asked for: a start-up
    that steps faster than a slow circle's small settled steps is slew-limited, never answered
    by shaping the whole record (which left 21 % of a 15 µm circle at 20 Hz on an outside
    actuator)."""
    out = tmp_path / "drive.csv"
    circle = f'{{ kind = "circle", radius = 15, frequency = {frequency}, periods = 4 }}'
    model = OUTSIDE_GPI if preset == "outside" else _preset(tmp_path)
    _compensate([model, "--reference", circle, "--out", out])
    u, fade, text = _drive(out)
    rows = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    head = rows[0].split(",")
    if "x_shaped" in head:
        data = np.array([[float(v) for v in ln.split(",")] for ln in rows[1:]])
        t = data[:, 0]
        asked = 15.0 * np.vstack([np.cos(2 * np.pi * frequency * t), np.sin(2 * np.pi * frequency * t)])
        shaped = data[:, [head.index("x_shaped"), head.index("y_shaped")]].T
        P = int(round(1 / frequency / T))
        np.testing.assert_allclose(shaped[:, fade + P:], asked[:, fade + P:], atol=1e-6)
    assert np.all(u[:, 0] == 0.0)


def test_rest_output_with_creep_is_the_settled_rest():
    """At rest for long, the creep has added its whole step response to the model's rest
    output: ``s(inf) = d + sum w`` times it (the step response's limit, per output)."""
    from hammerstein.compensation.drive import rest_output
    from hammerstein.io.presets import load_plant
    plant = load_plant(OUTSIDE_GPI)
    bare = rest_output(plant.hysteresis)
    settled = rest_output(plant.hysteresis, plant.creep)
    assert np.all(bare != 0.0)                       # an identified sensor offset
    for l, c in enumerate(plant.creep):
        assert settled[l] == pytest.approx(bare[l] * c.step_response([1e12])[0], rel=1e-12)
    assert np.array_equal(rest_output(plant.hysteresis, [None] * len(bare)), bare)


def test_a_lengthened_fade_in_is_said_with_its_share_of_the_record(tmp_path):
    """A new user's raster lost a quarter of its lines to a fade-in doubled to its cap, and
    only the drive file's header said how long the fade was: the note says by how much it
    grew, its share of the record, and that it is the cap. (That raster's start-up stepped a
    relative 3.7e-5 more than its settled drive: within the tolerance, its fade is kept; this
    circle's start-up steps 1.6 % more.)"""
    preset = _preset(tmp_path)
    raster = '{ kind = "raster", size = [20, 20], lines = 8, frequency = 50, outputs = ["x", "y"] }'
    kept = _compensate([preset, "--reference", raster, "--out", tmp_path / "r.csv"])
    assert "fade-in was lengthened" not in kept and "slew-limited" not in kept
    short = '{ kind = "circle", radius = 30, frequency = 50, periods = 5 }'
    said = _compensate([preset, "--reference", short, "--out", tmp_path / "s.csv"])
    _, fade, text = _drive(tmp_path / "s.csv")
    n = len([ln for ln in text.splitlines() if ln and not ln.startswith("#")]) - 1
    assert fade == n // 4                                  # grown to the cap
    line = (f"note: the fade-in was lengthened from {0.02:.4g} s to {fade * T:.4g} s, "
            f"{100 * fade / n:.3g} % of the record, excluded from the metrics")
    assert line in said and "(a quarter of the record at most)" in said
    circle = _compensate([preset, "--reference", CIRCLE, "--out", tmp_path / "c.csv"])
    assert "fade-in was lengthened" not in circle                     # the default fade sufficed


def test_a_raster_faster_than_the_slew_keeps_its_fade():
    """A new user's 20 Hz triangle raster file (no period): its corners and line steps ask the
    inverse for steps beyond the records' slew, in the settled part as in the fade, and they are
    shaped in the reference. The fade was doubled against the slew rate to a quarter of the
    scan, which no fade can change; it stays at its default (four decay times of the mode
    here), and the settled drive is within the slew."""
    plant = load_plant("rakotondrabe-2dof", dynamics=True)
    comp = HammersteinCompensator(plant.hysteresis, plant.dynamics)
    n = int(round(32 / 20.0 / T))
    t = np.arange(n) * T
    phase = (t * 20.0) % 1.0
    r = np.vstack([-10.0 + 20.0 * np.where(phase < 0.5, 2 * phase, 2 - 2 * phase),
                   -10.0 + 20.0 * np.minimum((t * 20.0).astype(int), 31) / 31])
    slew = 3000.0
    raw = drive_signal(comp, hardware_fade(r, 2000, np.zeros(2)), T, None, fade_samples=0).inputs
    assert np.all(settled_step(raw, 2001) > slew * T)          # the reference's own steps
    amp = amplifier_from_table({"source": "records", "range": [-10.0, 10.0], "slew_rate": slew},
                               ["ux", "uy"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hardware_drive(comp, r, T, None, amplifier=amp, mode_decay=0.025)
    assert res.fade_samples == 2000 and not any("lengthened" in s for s in res.notes)
    assert any("reference shaped" in s for s in res.shaped)
    assert np.all(_steps(res.inputs).max(axis=1) <= slew * T * (1 + 1e-9))


@pytest.mark.parametrize("with_drive", [True, False])
def test_evaluate_without_the_drive_says_its_fade_is_counted(tmp_path, with_drive):
    # compensate's drive fades in; evaluate knows where only from the drive's header, so
    # without --drive it says that the metrics start after --settle-periods only
    out = tmp_path / "drive.csv"
    _compensate([_preset(tmp_path, amplifier=False), "--reference", CIRCLE, "--out", out])
    t = np.arange(pd.read_csv(out, comment="#").shape[0]) * T
    measured = tmp_path / "m.csv"
    pd.DataFrame({"t": t, "x": 30 * np.cos(2 * np.pi * 100 * t),
                  "y": 30 * np.sin(2 * np.pi * 100 * t)}).to_csv(measured, index=False)
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        assert main(["evaluate", "--reference", CIRCLE, "--measured", str(measured), "--out",
                     str(tmp_path / "ev"), *(["--drive", str(out)] if with_drive else [])]) == 0
    notes = [line for line in err.getvalue().splitlines() if line.startswith("note: no --drive")]
    assert len(notes) == (0 if with_drive else 1)


def test_the_drive_file_says_how_to_end_at_rest(tmp_path):
    # a circle's drive ends mid-turn, several volts from rest: its header gives the last
    # voltages and a ramp to rest no faster than the drive's own largest step
    out = tmp_path / "drive.csv"
    _compensate([_preset(tmp_path, amplifier=False), "--reference", CIRCLE, "--out", out])
    u, _, text = _drive(out)
    line = next(ln for ln in text.splitlines() if ln.startswith("# ends at "))
    last = u[:, -1]
    assert f"ux {last[0]:.4g} V, uy {last[1]:.4g} V" in line
    slew = np.max(np.abs(np.diff(u, axis=1)), axis=1)          # V per sample
    ramp = np.max(np.abs(last) / slew) * T
    assert f"in {ramp:.3g} s or more" in line and ramp > 10 * T


@pytest.mark.parametrize("change", [5.0, 0.3, 40.0])
def test_keep_end_keeps_a_constant_learnt_change_to_the_end(change):
    # a drive ending in a hold: a constant learnt change is the hold's, kept to the last sample
    # (blended back to the previous drive, a pick-and-place drive snapped back 1.9 V at the end)
    N = 4000
    prev = np.sin(np.linspace(0, 20, N))[None, :] * 0.001
    u = keep_end(prev, prev + change, [1.0])
    np.testing.assert_allclose(u, prev + change, rtol=0, atol=1e-12)


@pytest.mark.parametrize("change", [5.0, 0.3, 40.0])
def test_keep_end_holds_the_last_informed_change_over_an_uninformed_tail(change):
    # a learnt change c that falls to 0 over the last 5 samples (the update read past the
    # record's end) and wanders by 3 c over the 20 before: held at its value 8, 16, 32 ...
    # samples from the end, the first where it steps within the bound; the drive's steps
    # there are the previous drive's own
    N, bound = 4000, 1.0
    prev = np.sin(np.linspace(0, 20, N))[None, :] * 0.001
    d = np.full(N, change)
    d[-25:-5] = change * (1 + 3 * np.sin(np.arange(20)))
    d[-5:] = 0.0
    u = keep_end(prev, prev + d, [bound])
    n = 8
    while np.abs(d[N - n - 1] - d[N - n - 2]) > bound:
        n *= 2
    np.testing.assert_allclose(u[0, :N - n], prev[0, :N - n] + d[:N - n], rtol=0, atol=1e-12)
    np.testing.assert_allclose(u[0, N - n:], prev[0, N - n:] + d[N - n - 1], rtol=0, atol=1e-12)
    assert np.max(np.abs(np.diff(u[0, N - n - 1:] - prev[0, N - n - 1:]))) == 0.0


def test_a_learnt_raster_drive_ends_without_a_step(tmp_path):
    # the time-domain learning of a reference that does not repeat read past the record's end:
    # a user's learnt raster drive ended with 1.03 V steps on an input settled at 0.07 V
    out = tmp_path / "u0.csv"
    preset = _preset(tmp_path)          # the records' limits: the line steps are shaped
    _compensate([preset, "--reference", RASTER, "--out", out])
    t, u, _ = read_signals(out, ["ux", "uy"])
    y, _ = load_plant("rakotondrabe-2dof").simulate(1.05 * u)
    y = y + np.random.default_rng(3).normal(0, 0.02, y.shape)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(tmp_path / "y0.csv", index=False)
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["learn", str(preset), "--reference", RASTER,
                     "--drive", str(out), "--measured", str(tmp_path / "y0.csv"), "--out",
                     str(tmp_path / "u1.csv"), "--delay", "0"])
    assert code == 0, err.getvalue()
    _, u1, _ = read_signals(tmp_path / "u1.csv", ["ux", "uy"])
    steps = np.abs(np.diff(u1, axis=1))
    assert np.all(steps[:, -40:].max(axis=1) <= steps[:, :-40].max(axis=1) * (1 + 1e-9))
    # ends as the base drive plus the learnt change of the last informed sample (a hold keeps
    # its learnt voltage): never further from it than the largest learnt change elsewhere
    change = np.abs(u1 - u)
    assert np.all(change[:, -1] <= change[:, :-40].max(axis=1) * (1 + 1e-9))


def test_evaluate_draws_the_trajectory_of_three_outputs(tmp_path):
    # evaluate drew its figure only for exactly two outputs: a 3-axis stage got none, silently
    t = np.arange(4000) * T
    ref = np.vstack([30 * np.cos(2 * np.pi * 50 * t), 30 * np.sin(2 * np.pi * 50 * t),
                     5 * np.sin(2 * np.pi * 10 * t)])
    pd.DataFrame({"t": t, "x": ref[0], "y": ref[1], "z": ref[2]}).to_csv(tmp_path / "r.csv",
                                                                          index=False)
    y = ref + 0.05
    pd.DataFrame({"t": t, "x": y[0], "y": y[1], "z": y[2]}).to_csv(tmp_path / "m.csv", index=False)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["evaluate", "--reference", str(tmp_path / "r.csv"), "--period", "0.1",
                     "--measured", str(tmp_path / "m.csv"), "--out", str(tmp_path / "ev")]) == 0
    assert (tmp_path / "ev" / "trajectory-measured.png").stat().st_size > 10_000
    m = pd.read_csv(tmp_path / "ev" / "metrics.csv")
    row = m[(m["channel"] == "x+y+z") & (m["metric"] == "max_euclidean_error")]
    assert row["value"].item() == pytest.approx(0.05 * np.sqrt(3), rel=1e-6)


def test_a_held_axis_whose_start_up_outlasts_the_fade_is_named(tmp_path, monkeypatch):
    # x scans a triangle while y is held at 20 µm: the settled drive barely moves uy, so its
    # start-up (no step beyond the settled drive's: corrected in the reference, or
    # slew-limited) goes on after the fade; the metrics from the fade's end would include
    # it: compensate says so and how long. Today's start-up moves uy by 2.6e-4 V of 4.7 V
    # after the fade (below START_UP_MOVE, said in the header only); the note is tested
    # with a threshold below that move
    monkeypatch.setattr("hammerstein.compensation.drive.START_UP_MOVE", 1e-6)
    n = 8000
    t = np.arange(n) * T
    x = 20 * (2 * np.abs(((t * 25) % 1) - 0.5))            # a 25 Hz triangle, 0..20 µm
    ref = tmp_path / "held.csv"
    pd.DataFrame({"t": t, "x": x, "y": np.full(n, 20.0)}).to_csv(ref, index=False)
    printed = _compensate([_preset(tmp_path, amplifier=False), "--reference", ref, "--period",
                           "0.04", "--out", tmp_path / "d.csv"])
    _, fade, text = _drive(tmp_path / "d.csv")
    m = re.search(r"the (?:slew-limited start-up|start-up corrected in the reference) reaches "
                  r"the drive ([\d.]+) s after the start", text)
    assert m is not None, text
    late = float(m.group(1))
    assert late > fade * T and "--fade-in" in printed


@pytest.mark.parametrize("radius, frequency", [(15, 10), (30, 10), (15, 50)])
def test_a_start_up_limited_by_a_hair_gets_no_advice(tmp_path, radius, frequency):
    """Circles on the bundled realistic preset whose start-up steps 0.1-0.2 % beyond the
    settled drive are slew-limited, moving the drive by 1.5e-5 to 3.7e-4 V of 3.5-6 V (a few
    nm); each was advised a fade three times as long, or a longer record, as if a held
    axis's start-up of volts were after the fade. The move is said in the header only."""
    out = tmp_path / "d.csv"
    printed = _compensate(["realistic-2dof", "--reference",
                           f"{{ kind = \"circle\", radius = {radius}, frequency = {frequency}, "
                           f"periods = 8 }}", "--out", out])
    u, fade, text = _drive(out)
    assert "reaches the drive" not in printed + text
    assert "the start-up (the" in text           # the limit itself is still said
    settled = _steps(u[:, fade:]).max()
    assert _steps(u).max() <= settled * (1 + 1e-3)


def test_a_start_up_fade_longer_than_half_the_record_asks_for_a_longer_record(tmp_path,
                                                                               monkeypatch):
    # the same held axis on a record of 0.4 s: the fade the start-up needs would take most of
    # it (with the threshold of the test above)
    monkeypatch.setattr("hammerstein.compensation.drive.START_UP_MOVE", 1e-6)
    n = 8000
    t = np.arange(n) * T
    x = 20 * (2 * np.abs(((t * 25) % 1) - 0.5))
    ref = tmp_path / "held.csv"
    pd.DataFrame({"t": t, "x": x, "y": np.full(n, 20.0)}).to_csv(ref, index=False)
    printed = _compensate([_preset(tmp_path, amplifier=False), "--reference", ref, "--period",
                           "0.04", "--out", tmp_path / "d.csv"])
    m = re.search(r"a fade-in that long \(([\d.]+) s, .*\) would take ([\d.]+) % of the "
                  r"([\d.]+) s record: give a longer record \(more periods\)", printed)
    assert m is not None, printed
    advice, share, record = map(float, m.groups())
    assert record == pytest.approx(n * T) and advice > 0.5 * record
    assert share == pytest.approx(100 * advice / record, rel=1e-2)


@pytest.mark.parametrize("true_delay", [0, 3])
def test_evaluate_does_not_read_a_circles_period_as_the_delay(tmp_path, true_delay):
    # a 50 Hz circle evaluated with --period 0.1 (the 10 Hz period of the user's whole
    # trajectory): the search went to half of 0.1 s and read the circle's own period, 400
    # samples, as the delay
    t = np.arange(12000) * T
    ref = np.vstack([30 * np.cos(2 * np.pi * 50 * t), 30 * np.sin(2 * np.pi * 50 * t)])
    meas = np.concatenate([np.repeat(ref[:, :1], true_delay, axis=1),
                           ref[:, :ref.shape[1] - true_delay]], axis=1)
    meas = meas + np.random.default_rng(1).normal(0, 0.04, meas.shape)
    for name, sig in (("r.csv", ref), ("m.csv", meas)):
        pd.DataFrame({"t": t, "x": sig[0], "y": sig[1]}).to_csv(tmp_path / name, index=False)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["evaluate", "--reference", str(tmp_path / "r.csv"), "--period", "0.1",
                     "--measured", str(tmp_path / "m.csv"), "--out", str(tmp_path / "ev")]) == 0
    m = pd.read_csv(tmp_path / "ev" / "metrics.csv")
    assert m[m["metric"] == "delay_samples"]["value"].iloc[0] == true_delay


def test_compensate_reference_is_the_commands_drive(tmp_path):
    # the command's route from Python: the drive file's voltages, from the library call
    import hammerstein as hs
    out = tmp_path / "d.csv"
    _compensate([_preset(tmp_path), "--reference", CIRCLE, "--out", out])
    u_cli, fade, _ = _drive(out)
    plant = hs.load_plant(str(_preset(tmp_path)))
    _, r = hs.circle(plant.sampling_period, radius=30.0, frequency=100.0, periods=12)
    _, drive = hs.compensate_reference(plant, r, period_samples=200)
    assert drive.fade_samples == fade
    np.testing.assert_allclose(drive.inputs, u_cli, rtol=0, atol=1e-12)


def test_a_move_after_a_hold_is_judged_and_reaches_its_target(tmp_path):
    """A pick-and-place path: a hold away from rest for 30 ms, a smooth 50 ms move, a hold.
    On realistic-2dof the default fade covered the move (lengthened to a quarter of the
    record), so the hold after it bounded the start-up: the move was slew-limited to 8 V/s and
    the drive ended at 2.33 V of the 3.27 V the compensator asks (an outside user's stage:
    18 µm of a 18 µm move left). The fade now ends with the first hold; the move is judged,
    and the drive ends at the compensator's own final voltage."""
    t = np.arange(6000) * T
    s = np.clip((t - 0.03) / 0.05, 0.0, 1.0)
    move = s * s * s * (10 - 15 * s + 6 * s * s)              # a smooth 0 -> 1 (minimum jerk)
    path = tmp_path / "pnp.csv"
    np.savetxt(path, np.column_stack([t, 2.0 + 12.0 * move, 1.0 + 8.0 * move]), delimiter=",",
               header="t,x,y", comments="", fmt="%.12g")
    given = tmp_path / "given.csv"
    _compensate(["realistic-2dof", "--reference", path, "--out", given, "--fade-in", 0.025])
    u_given, _, _ = _drive(given)
    out = tmp_path / "default.csv"
    _compensate(["realistic-2dof", "--reference", path, "--out", out])
    u, fade, _ = _drive(out)
    assert 0.02 / T <= fade <= 600                              # within the 30 ms hold
    np.testing.assert_allclose(u[:, -1], u_given[:, -1], rtol=1e-4)  # the target reached
    steps = _steps(u)
    settled = steps[:, fade + 2:].max(axis=1)
    assert np.all(steps.max(axis=1) <= settled * (1 + 1e-9))   # and no step beyond the move's


@pytest.mark.parametrize("slew, warned", [(60.0, True), (SLEW, False)])
def test_a_reference_shaped_far_from_the_one_asked_is_a_warning(tmp_path, slew, warned):
    """Limits taken from quasi-static records (63 V/s) shaped a 10 µm circle at 20 Hz to
    0.67 µm, said by one `shaped:` line on stdout and exit 0. Shaped by more than half of
    its half-span, the drive is refused by default and written with --limits warn."""
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    text += f'\n[amplifier]\nsource = "records"\nrange = [-10.0, 10.0]\nslew_rate = {slew}\n'
    preset = tmp_path / "slow.toml"
    preset.write_text(text)
    ref = '{ kind = "circle", radius = 10, frequency = 20, periods = 6 }'
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--reference", ref,
                     "--out", str(tmp_path / "default.csv")])
    assert code == (1 if warned else 0), err.getvalue()
    assert (tmp_path / "default.csv").exists() == (not warned)       # nothing written
    if warned:
        (line,) = err.getvalue().splitlines()
        assert line.startswith("hammerstein compensate: error: the drive would follow less "
                               "than half of the reference, nothing written")
        assert "60 V/s" in line and "--limits warn" in line
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--reference", ref,
                     "--out", str(tmp_path / "d.csv"), "--limits", "warn"])
    assert code == 0
    lines = [ln for ln in err.getvalue().splitlines()
             if ln.startswith("warning: ") and "% of its half-span" in ln]
    assert bool(lines) == warned
    if warned:
        assert lines[0].startswith("warning: ") and "60 V/s" in lines[0] and "[amplifier]" in lines[0]
        assert "lower its frequency or its size" in lines[0]      # the slew, not the range
        assert "edge of the range" not in lines[0]


def test_a_reference_held_back_by_the_range_is_told_so_not_to_record_faster(tmp_path):
    # a 40 µm circle behind a +-3 V range (the records' slew far above what it needs): the
    # warning said "records slower than the reference understate the amplifier", which
    # cannot help; it names the input at the edge of the range and the size or center
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    text += '\n[amplifier]\nsource = "records"\nrange = [-3.0, 3.0]\nslew_rate = 1e6\n'
    preset = tmp_path / "narrow.toml"
    preset.write_text(text)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--reference",
                     '{ kind = "circle", radius = 40, frequency = 20, periods = 6 }',
                     "--out", str(tmp_path / "d.csv")])
    assert code == 0, err.getvalue()
    (line,) = [ln for ln in err.getvalue().splitlines() if "% of its half-span" in ln]
    assert "The drive sits at the edge of the range on ux, uy" in line
    assert "make it smaller or move its center" in line and "faster records" not in line
    u, _, _ = _drive(tmp_path / "d.csv")
    assert 2.9 <= np.abs(u).max() <= 3.0         # within the range, at its edge


STEPS_HOLD = 2000                             # 0.1 s at T = 5e-5 s


def _compensate_steps(tmp_path, limits):
    """``compensate`` of a 5-level step-and-hold reference (x, and y = x / 2) behind an
    ``[amplifier]`` table from the records (``limits``); (exit code, stdout, stderr, x)."""
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    text += f'\n[amplifier]\nsource = "records"\n{limits}\n'
    preset = tmp_path / "limits.toml"
    preset.write_text(text)
    x = np.repeat([0.0, 10.0, -5.0, 12.0, 3.0], STEPS_HOLD)
    t = np.arange(x.size) * T
    ref = tmp_path / "steps.csv"
    pd.DataFrame({"t": t, "x": x, "y": 0.5 * x}).to_csv(ref, index=False)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--reference", str(ref),
                     "--out", str(tmp_path / "d.csv")])
    return code, out, err, x


def test_steps_smoothed_below_the_first_mode_are_not_blamed_on_the_limits(tmp_path):
    # a step-and-hold reference (holds of 0.1 s) behind limits far beyond what it needs
    # (+-1000 V, 1e9 V/s): its steps are smoothed over a period of the 310 Hz mode whatever
    # the limits, and the warning said the limits measured on the records held it back and
    # to widen them
    code, out, err, _ = _compensate_steps(tmp_path, "range = [-1000.0, 1000.0]\nslew_rate = 1e9")
    assert code == 0, err.getvalue()
    assert "% of its half-span" not in err.getvalue()
    shaped = [ln for ln in out.getvalue().splitlines() + err.getvalue().splitlines()
              if ln.startswith("shaped:")]
    assert shaped and all("first mode" in ln and "left the limits" not in ln for ln in shaped)


@pytest.mark.parametrize("flip, first, sensor", [
    (False, "-0.05", False),     # one weight written wrong: the actuator's loops still rise
    (True, "-", True),           # every weight negated: a sensor of inverted sign
    ("zero", "0;", False),       # a loop that starts flat (identify wrote it before it bounded w_1)
])
def test_a_direct_transfer_with_a_falling_first_slope_is_named(tmp_path, flip, first, sensor):
    # a hand-written model with w_1 = -0.05 um/V on x <- ux: the default kind warned of a
    # gain the user never chose, then blamed the amplifier's slew rate; a model identified
    # from a reversed sensor (its loops fall everywhere) was refused in the model's terms only,
    # where identify had named the sensor
    import copy

    from hammerstein.io.presets import save_model
    from hammerstein.models.hysteresis import PrandtlIshlinskii

    model = copy.deepcopy(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis)
    op = model.components[0][0]
    weights = np.array(op.weights, dtype=float)
    if flip == "zero":
        weights[0] = 0.0
    elif flip:
        weights = -weights
    else:
        weights[0] = -0.05
    model.components[0][0] = PrandtlIshlinskii(op.thresholds, weights)
    save_model(model, tmp_path / "falling.toml")
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["compensate", str(tmp_path / "falling.toml"), "--sampling-period", str(T),
                     "--reference", '{ kind = "circle", radius = 5, frequency = 20, periods = 4 }',
                     "--out", str(tmp_path / "d.csv")])
    assert code == 1 and not (tmp_path / "d.csv").exists()
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1, lines
    assert "direct transfer x <- ux: weights: the first weight" in lines[0]
    assert f"is {first}" in lines[0]
    assert ("a sensor of inverted sign? invert the x column" in lines[0]) == sensor
    assert ("would not move while ux turns" in lines[0]) == (flip == "zero")
    assert ("would move the wrong way" in lines[0]) == (flip != "zero")
    assert ("--bounds monotone" in lines[0]) == (not sensor)   # (monotone keeps a falling one)


def test_a_file_circle_beyond_the_reach_is_shaped_as_with_its_period(tmp_path):
    """A 30 µm circle file beyond a 5 V range's reach, given without --period, was averaged
    over 14 ms (1.4 of its periods) and shaped to 21 % of its size, where with --period it
    is limited to the reach (83 %). The window now stops at half of the fundamental found
    from the file: both shaped references reach the same size."""
    preset, csv = _preset(tmp_path), _circle_csv(tmp_path)
    sizes = {}
    for name, extra in (("found", []), ("given", ["--period", 0.01])):
        out = tmp_path / f"{name}.csv"
        _compensate([preset, "--reference", csv, *extra, "--out", out, "--limits", "warn"])
        d = pd.read_csv(out, comment="#")
        last = d.iloc[-800:]                                  # the last four periods
        sizes[name] = np.hypot(last["x_shaped"], last["y_shaped"]).mean()
    assert sizes["given"] > 20.0                              # the reach: 22-25 µm
    assert abs(sizes["found"] - sizes["given"]) <= 0.05 * sizes["given"]


@pytest.mark.parametrize("last, low, at_rest", [([0.0], None, True), ([0.0, 150.0], None, False),
                                                ([5.0], 5.0, True), ([1e-3], None, False),
                                                ([0.0], 5.0, False)])
def test_a_drive_that_ends_on_the_rest_voltages_is_said_to_end_at_rest(last, low, at_rest):
    # a unipolar stack's staircase drive ending on 0 V read "ends at u 0 V (the reference's
    # last sample, not at rest): hold it, then ramp every input to rest"
    names = [f"u{i}" for i in range(len(last))]
    u = np.linspace(np.full(len(last), 40.0), last, 50).T
    amp = None if low is None else amplifier_from_table(
        {n: {"range": [low, 150.0]} for n in names}, names)     # rests at 5 V, its range's end
    line = end_note(u, T, names, amp)
    assert ("every input at rest" in line) == at_rest
    assert ("ramp every input to rest" in line) == (not at_rest)


@pytest.mark.parametrize("left, slew_words", [("slew rate", True), ("range", False)])
def test_a_drive_held_inside_the_slew_by_the_margins_is_told_the_slew(left, slew_words):
    """The range stage scales a reference a few % inside the limit it left, so a slew-bound
    drive can peak at 0.96 of the slew: a 30 µm circle at 80 Hz behind 2000 V/s (1918-1931
    V/s, shaped by 75 % of its half-span) was told the range held it back, to widen the
    range (which changed nothing), and written. The shaping's words say which limit."""
    from types import SimpleNamespace
    from hammerstein.cli.compensate import _shrink_warning
    from hammerstein.models.amplifier import amplifier_from_table
    T = 5e-5
    amp = amplifier_from_table({"source": "records", "range": [-10.0, 10.0],
                                "slew_rate": 2000.0}, ["ux", "uy"])
    assert amp.from_records
    t = np.arange(2000) * T
    asked = 30.0 * np.vstack([np.cos(2 * np.pi * 80 * t), np.sin(2 * np.pi * 80 * t)])
    got = 0.25 * asked                            # shaped by 75 % of the half-span
    step = 0.96 * 2000.0 * T                      # 0.96 of the slew per sample, at 5.9 V
    u = np.vstack([np.clip(np.cumsum(np.where(np.sin(2 * np.pi * 80 * t) > 0, step, -step)),
                           -5.9, 5.9)] * 2)
    plant = SimpleNamespace(amplifier=amp, sampling_period=T,
                            hysteresis=SimpleNamespace(output_names=["x", "y"]))
    drive = SimpleNamespace(limited=True, range_limited=left != "slew rate", reference=got,
                            inputs=u, fade_samples=0,
                            shaped=[f"x: reference shaped by up to 22.5 µm (limited to the "
                                    f"output the drive reaches within the {left} (the model's "
                                    f"prediction for the drive limited to it, 5 % inside it))"])
    text, refuse = _shrink_warning(plant, SimpleNamespace(signal=asked), drive)
    assert ("slews faster than the records did" in text) == slew_words
    assert refuse == slew_words                   # 75 % > SHRINK_REFUSE: refused by default
    assert ("asks more than the records' range reaches" in text) == (not slew_words)


def test_a_staircase_whose_steps_alone_are_shaped_is_not_told_it_is_held_back(tmp_path):
    # a slew limit shapes each step of a staircase by its whole height on a few samples, its
    # levels all reached: a user's 5-level staircase was told it was shaped by 99 % of its
    # half-span and that the range held it back. Judged on a quarter of the samples, the
    # steps are not the reference held back; a circle shaped on every sample still is
    code, out, err, x = _compensate_steps(tmp_path, "range = [-10.0, 10.0]\nslew_rate = 2000.0")
    n = STEPS_HOLD
    assert code == 0, err.getvalue()
    assert "reference shaped" in out.getvalue()           # the steps were shaped ...
    assert "% of its half-span" not in err.getvalue()     # ... and that is all
    u, _, _ = _drive(tmp_path / "d.csv")
    d = pd.read_csv(tmp_path / "d.csv", comment="#")
    k = np.arange(len(d))
    held = (k % n > 0.3 * n) & (k % n < 0.7 * n) & (k >= n)     # mid-hold: levels reached
    assert np.max(np.abs(d["x_shaped"].to_numpy()[held] - x[: len(d)][held])) < 0.05


def test_a_start_up_corrected_in_the_reference_writes_the_reference_the_drive_follows(tmp_path):
    """A held axis's start-up corrected in the reference (and nothing else shaped; coupled-2dof,
    y held at 40 µm beside a 50 Hz x swing): the drive file had no <output>_shaped columns, so
    the exported C fed the faded reference the docs describe was 7.9 V off on the held input
    of an outside check's three-axis stage. The columns are now written whenever the
    reference was changed, and they are the reference the drive is the compensator's for
    (the Python route's)."""
    from hammerstein.cli._hardware import load_actuator, load_reference
    from hammerstein.scenario.hardware_route import compensate_reference
    preset = Path(__file__).resolve().parents[2] / "scenarios" / "presets" / "coupled-2dof.toml"
    plant = load_actuator(str(preset))
    n = int(round(8 / 50 / plant.sampling_period))
    t = np.arange(n) * plant.sampling_period
    ref = tmp_path / "held.csv"
    pd.DataFrame({"t": t, "x": 10 * np.cos(2 * np.pi * 50 * t), "y": np.full(n, 40.0)}).to_csv(
        ref, index=False)
    _compensate([preset, "--reference", ref, "--period", "0.02", "--out", tmp_path / "d.csv"])
    text = (tmp_path / "d.csv").read_text()
    assert "start-up corrected in the reference" in text and "reference shaped" not in text
    rows = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    assert rows[0].split(",")[-2:] == ["x_shaped", "y_shaped"]
    shaped = np.array([[float(v) for v in ln.split(",")[-2:]] for ln in rows[1:]]).T
    reference = load_reference(str(ref), plant, "t", None, 0.02)
    _, drive = compensate_reference(plant, reference.signal, reference.period_samples)
    np.testing.assert_allclose(shaped, drive.reference, rtol=1e-12, atol=1e-9)
    assert np.abs(shaped - reference.signal).max() > 1.0     # the held y's start-up: 2.47 µm


def test_shaping_trials_do_not_repeat_range_warnings_of_values_never_asked(tmp_path):
    """A classical PI with an output map identified on an outside stage (kept in data/),
    the multiplicative law on a +-10 µm sine at 400 Hz, which its drive misses: the
    shaping's trial references, blended towards what a clipped drive reaches, left the
    model's range, and each printed "beyond the range the model was identified on (x: 84.71
    µm > 27.63 µm ...)", five lines of values the reference never had, before the one-line
    error. Only the error is printed now; a reference that is beyond the range is still
    named once, with its own value."""
    preset = Path(__file__).parent / "data" / "outside-classical-deadzone.toml"
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--kind", "multivariable", "--reference",
                     '{ kind = "sine", output = "x", amplitude = 10, frequency = 400, '
                     'periods = 20 }', "--out", str(tmp_path / "d.csv")])
    # (the law solves the hysteresis model, 4.7 %; the preset's modes it leaves out do not)
    assert code == 1 and "leaves out the model's linear dynamics" in err.getvalue()
    assert "identified on" not in err.getvalue(), err.getvalue()
    assert not (tmp_path / "d.csv").exists()
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["compensate", str(preset), "--kind", "multivariable", "--reference",
                     '{ kind = "sine", output = "x", amplitude = 40, frequency = 10, '
                     'periods = 4 }', "--out", str(tmp_path / "d.csv")])
    assert code == 0
    assert err.getvalue().count("beyond the range the model was identified on") == 1


@pytest.mark.parametrize("kind, said", [
    ("per-axis", "kind 'per-axis' leaves out the model's cross-couplings by design"),
    ("diagonal", "kind 'diagonal' leaves out the model's cross-couplings by design"),
])
def test_a_kind_that_leaves_the_couplings_is_told_so_not_to_slow_down(kind, said):
    """A per-axis or diagonal drive on a strongly coupled model misses by the couplings it
    leaves: the note said "make the reference smaller or slower", which does not help (an
    outside stage: 12.5 % on a 5 µm 5 Hz circle, 11.8 % on a 20 µm 50 Hz one)."""
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    from hammerstein.models.plant import HammersteinPlant
    from hammerstein.scenario.hardware_route import compensate_reference
    pi = PrandtlIshlinskii([0.0, 1.0, 3.0], [1.0, 0.3, 0.2])
    model = MultivariablePI([[pi, 0.3], [0.3, pi]], input_names=["ux", "uy"],
                            output_names=["x", "y"], input_amplitude=[10.0, 10.0])
    plant = HammersteinPlant(model, T)
    t = np.arange(8000) * T
    ref = np.vstack([5 * np.cos(2 * np.pi * 5 * t), 5 * np.sin(2 * np.pi * 5 * t)])
    _, drive = compensate_reference(plant, ref, 4000, kind=kind, limits="warn",
                                    check="ignore" if kind == "diagonal" else None)
    text = " ".join(drive.notes)
    assert said in text and "smaller or slower" not in text, text
    assert "the multivariable law or the default kind" in text


def _fast_circle_notes(kind):
    """The notes of ``kind``'s drive on the bundled preset (bending modes), a 30 µm circle
    at 400 Hz, as one line."""
    from hammerstein.io.presets import load_plant
    from hammerstein.scenario.hardware_route import compensate_reference
    plant = load_plant("rakotondrabe-2dof")
    t = np.arange(8000) * plant.sampling_period
    f = 400.0
    ref = 30 * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])
    _, drive = compensate_reference(plant, ref, int(round(1 / (f * plant.sampling_period))),
                                    kind=kind, limits="warn")
    return " ".join(drive.notes)


def test_a_kind_that_leaves_the_dynamics_says_so_too():
    """The per-axis inverse on a preset with bending modes, a 30 µm circle at 400 Hz: the
    drive misses by the couplings and by the modes it does not invert (a new user's
    identified stage: 17.6 % at 100 Hz below a 311 Hz mode). The note blamed the couplings
    alone and pointed to the multivariable law, which inverts no dynamics either."""
    text = _fast_circle_notes("per-axis")
    assert ("kind 'per-axis' leaves out the model's cross-couplings and the model's linear "
            "dynamics (bending modes, lags) by design") in text, text
    assert "the default kind (--kind left out) compensates them all" in text
    assert "multivariable law" not in text


def test_the_law_on_a_plant_with_modes_is_told_it_leaves_them_not_that_it_fails():
    """Kind multivariable on a preset with bending modes, a 30 µm circle at 400 Hz: the
    note said "the compensator does not solve the model there; make the reference smaller
    or slower" (an outside stage's 12.5 % miss at 50 Hz, 0.6 % through its hysteresis
    alone). It now names the dynamics the kind leaves out and what the drive misses through
    the hysteresis model alone, which the law solves."""
    import re

    text = _fast_circle_notes("multivariable")
    assert ("kind 'multivariable' leaves out the model's linear dynamics (bending modes, "
            "lags) by design") in text, text
    assert "smaller or slower" not in text and "does not solve" not in text
    whole = float(re.search(r"\(([\d.]+) % of its half-span\)", text).group(1))
    alone = float(re.search(r"hysteresis model alone the drive misses by ([\d.e-]+) %",
                            text).group(1))
    assert whole > 10.0 > alone, text       # below the warning level: the law solves it


def test_a_kind_that_leaves_the_creep_of_a_plant_without_modes_names_no_modes():
    """A reviewer's: a plant with creep and no dynamics (is_static is False for it) was told
    its bending modes were left out."""
    from hammerstein.models.creep import Creep
    from hammerstein.models.plant import HammersteinPlant
    from hammerstein.io.presets import load_plant
    from hammerstein.scenario.hardware_route import compensate_reference
    repo = Path(__file__).resolve().parents[2]
    base = load_plant(repo / "scenarios" / "presets" / "coupled-2dof.toml", False)
    plant = HammersteinPlant(base.hysteresis, base.sampling_period, None,
                             creep=[Creep([0.01, 0.1], [0.3, 0.2]), None])
    t = np.arange(10000) * plant.sampling_period
    ref = 30 * np.vstack([np.cos(2 * np.pi * 20 * t), np.sin(2 * np.pi * 20 * t)])
    _, drive = compensate_reference(plant, ref, int(round(1 / (20 * plant.sampling_period))),
                                    kind="per-axis", limits="warn")
    text = " ".join(drive.notes)
    assert "leaves out the model's cross-couplings and the creep by design" in text, text
    assert "bending modes" not in text


def test_the_default_kind_on_creep_without_dynamics_is_not_sent_to_the_default_kind():
    """A reviewer's: the default kind on a plant with creep and no dynamics (the
    multivariable law) was told it leaves the creep out and that "the default kind
    compensates them all". It is now told that no kind inverts creep without dynamics."""
    from hammerstein.models.creep import Creep
    from hammerstein.models.plant import HammersteinPlant
    from hammerstein.io.presets import load_plant
    from hammerstein.scenario.hardware_route import compensate_reference
    repo = Path(__file__).resolve().parents[2]
    base = load_plant(repo / "scenarios" / "presets" / "coupled-2dof.toml", False)
    plant = HammersteinPlant(base.hysteresis, base.sampling_period, None,
                             creep=[Creep([0.01, 0.1], [0.3, 0.2]), Creep([0.01], [0.3])])
    t = np.arange(10000) * plant.sampling_period
    ref = 30 * np.vstack([np.cos(2 * np.pi * 20 * t), np.sin(2 * np.pi * 20 * t)])
    _, drive = compensate_reference(plant, ref, int(round(1 / (20 * plant.sampling_period))),
                                    limits="warn")
    text = " ".join(drive.notes)
    assert "leaves out the creep by design" in text, text
    assert "no kind inverts creep without the dynamics" in text
    assert "compensates them all" not in text


def test_the_start_up_note_counts_the_samples_that_moved_and_says_where():
    """An outside check: the note said 9 samples differ from the compensator's where one did
    (the limiter's running sum leaves 1e-16 V on the others), "after the fade-in" of a sample
    inside it. It counts the samples moved beyond rounding and names the first."""
    k = np.arange(600)
    u = 3 * np.sin(2 * np.pi * k / 100 + 0.3) * np.minimum(k / 100, 1)
    u[60] += 0.5                       # one sample, inside the 100-sample fade-in
    limited, notes = limit_start_up(u[None, :], 100, 100, sampling_period=1e-4)
    moved = np.abs(limited[0] - u)
    assert np.count_nonzero(moved) > np.count_nonzero(moved > 1e-9)     # rounding elsewhere
    assert len(notes) == 1
    assert (f"at {np.count_nonzero(moved > 1e-9)} sample(s), from sample 60 (t = 0.006 s)"
            in notes[0])
    assert "the start-up (the 0.01 s fade-in and one period)" in notes[0]


@pytest.mark.parametrize("radius, said", [(300, True), (30, False)])
def test_a_drive_beyond_the_models_inputs_is_said(tmp_path, radius, said):
    """An outside check: on a bundled preset (no amplifier), a 300 µm circle's drive peaked at
    31 and 39 V for a model identified within +-10 V, and compensate said nothing."""
    out = tmp_path / "d.csv"
    printed = _compensate(["rakotondrabe-2dof", "--reference",
                           f"{{ kind = \"circle\", radius = {radius}, frequency = 100, "
                           f"periods = 20 }}", "--out", out])
    u, _, text = _drive(out)
    beyond = bool(np.any(np.abs(u) > 10.0))
    assert beyond == said
    line = "the drive leaves the inputs the model was identified on"
    assert (line in printed and line in text) == said
    if said:
        assert f"ux {u[0].min():.4g}..{u[0].max():.4g} V against -10..10 V" in printed

