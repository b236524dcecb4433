"""Triangle, raster and file references: closed forms, geometry, resampling, validation.

Expectations are derived independently of the generators: the triangle from
``(2/pi) arcsin(sin(2 pi f t))`` and its slope/zero crossings, the open-loop
triangle drive on the static plant from a naive play loop and from the closed
form of each play on the monotone segments of a triangle, the raster from its
definition (one line per fast period, H/(lines-1) steps), the file reference
from a linear function that linear interpolation must reproduce exactly.
"""

import re
import textwrap

import numpy as np
import pytest

from hammerstein.signals import metrics as met
from hammerstein.signals import references as refs
from hammerstein.models.hysteresis import PrandtlIshlinskii
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.resolve import load_scenario
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.validate import validate_scenario

T = 5e-5  # s


# -- triangle -----------------------------------------------------------------------------
def test_triangle_closed_form_peak_slope_and_zero_crossings():
    A, f = 40.0, 25.0                        # 800 samples per period
    t, r = refs.triangle(T, ["x", "y"], "x", amplitude=A, frequency=f, periods=3)
    assert r.shape == (2, 2400) and not np.any(r[1])
    np.testing.assert_allclose(r[0], A * (2 / np.pi) * np.arcsin(np.sin(2 * np.pi * f * t)),
                               atol=1e-9)
    assert r[0].max() == pytest.approx(A, abs=1e-9) and r[0].min() == pytest.approx(-A, abs=1e-9)
    # slope 4 A f on the rising parts, -4 A f on the falling parts [µm/s]
    slope = np.diff(r[0]) / T
    assert set(np.round(np.abs(slope) / (4 * A * f), 9)) == {1.0}
    assert slope[0] > 0                      # 0 at t = 0, rising (the sine's convention)
    # zero crossings at multiples of half a period (every 400 samples)
    zeros = np.flatnonzero(np.abs(r[0]) < 1e-9)
    np.testing.assert_array_equal(zeros, np.arange(0, 2400, 400))


def test_triangle_phase_and_offset_follow_the_sine_convention():
    t, r = refs.triangle(T, ["x"], "x", amplitude=2.0, frequency=100.0, phase=90.0, offset=1.0,
                         duration=0.01)
    t2, s = refs.sine(T, ["x"], "x", amplitude=2.0, frequency=100.0, phase=90.0, offset=1.0,
                      duration=0.01)
    assert r[0, 0] == pytest.approx(3.0)     # the peak, where the sine is at its peak too
    # same sign as the sine everywhere (same phase convention)
    assert np.all(np.sign(np.round(r[0] - 1.0, 9)) == np.sign(np.round(s[0] - 1.0, 9)))


def test_triangle_drive_on_one_input_and_field_errors():
    t, u = refs.triangle_drive(T, ["ux", "uy"], "uy", amplitude=10.0, frequency=50.0, periods=1)
    assert u.shape == (2, 400) and not np.any(u[0]) and u[1].max() == pytest.approx(10.0)
    with pytest.raises(refs.SignalError, match="^frequency:"):
        refs.triangle_drive(T, ["ux"], "ux", amplitude=1.0, frequency=5000.0, periods=1)
    with pytest.raises(refs.SignalError, match="^input:"):
        refs.triangle_drive(T, ["ux"], "uz", amplitude=1.0, frequency=50.0, periods=1)


def _naive_play(u, r):
    z, out = 0.0, np.empty_like(u)
    for i, v in enumerate(u):
        z = max(v - r, min(v + r, z))
        out[i] = z
    return out


def _triangle_play_closed_form(u, r, A):
    """Play r on a 0-start rising triangle of amplitude A, segment by segment."""
    out = np.empty_like(u)
    rising = np.diff(u, prepend=u[0] - 1.0) > 0
    first = True
    top, bottom = max(A - r, 0.0), min(r - A, max(A - r, 0.0))
    for i, v in enumerate(u):
        if rising[i] and first:
            out[i] = max(v - r, 0.0)                 # first rise from the zero state
        elif not rising[i]:
            first = False
            out[i] = min(v + r, top)                 # falling from the peak A
        else:
            out[i] = max(v - r, bottom)              # rising from the trough -A
    return out


def test_open_loop_triangle_on_static_plant_matches_independent_loops(tmp_path):
    A, f = 10.0, 25.0
    path = tmp_path / "tri.toml"
    path.write_text(textwrap.dedent(f"""
        name = "tri"
        [plant]
        preset = "rakotondrabe-2dof"
        dynamics = false
        [[cases]]
        name = "tri-ux"
        drive = {{ kind = "triangle", input = "ux", amplitude = {A}, frequency = {f}, periods = 2 }}
        """))
    case = load_scenario(path).cases[0]
    res = run_case(case)
    u = case.signal[0]
    model = case.plant.hysteresis
    expected = np.zeros_like(res.outputs)
    for l in range(model.n_outputs):
        comp = model.components[l][0]
        if isinstance(comp, PrandtlIshlinskii):
            naive = sum(w * _naive_play(u, r) for r, w in zip(comp.thresholds, comp.weights))
            closed = sum(w * _triangle_play_closed_form(u, r, A)
                         for r, w in zip(comp.thresholds, comp.weights))
            np.testing.assert_allclose(naive, closed, atol=1e-9)
            expected[l] = closed
        elif comp is not None:
            expected[l] = comp * u
    assert np.ptp(expected[0]) > 50.0           # a real loop, not zeros
    np.testing.assert_allclose(res.outputs, expected, atol=1e-8)
    ptp = {(r["channel"], r["metric"]): r["value"] for r in res.metrics}
    assert ptp[("x", "peak_to_peak")] == pytest.approx(np.ptp(expected[0][-800:]), abs=1e-8)


# -- raster -------------------------------------------------------------------------------
def test_raster_geometry_step():
    W, H, lines, f = 40.0, 30.0, 6, 50.0        # 400 samples per line
    t, r = refs.raster(T, [W, H], lines, f)
    assert r.shape == (2, lines * 400)
    assert r[0].min() == pytest.approx(0.0) and r[0].max() == pytest.approx(W)
    assert r[:, 0] == pytest.approx([0.0, 0.0])   # starts at rest at the origin
    line = refs.raster_line_index(t, f)
    np.testing.assert_array_equal(np.unique(line), np.arange(lines))
    for j in range(lines):                      # slow axis held on each line, H/(lines-1) apart
        np.testing.assert_allclose(r[1][line == j], j * H / (lines - 1), atol=1e-12)
    # fast axis: 0 at each line start, W half a line later, speed 2 W f
    np.testing.assert_allclose(r[0][::400], 0.0, atol=1e-9)
    np.testing.assert_allclose(r[0][200::400], W, atol=1e-9)
    np.testing.assert_allclose(np.abs(np.diff(r[0][:200])) / T, 2 * W * f, rtol=1e-9)


def test_raster_ramp_and_smoothing():
    W, H, lines, f = 40.0, 30.0, 5, 50.0
    t, r = refs.raster(T, [W, H], lines, f, slow="ramp")
    np.testing.assert_allclose(r[1], H * f * t / lines, atol=1e-12)
    assert np.all(np.diff(r[1]) > 0)
    s = 0.2                                    # corners rounded over 20 % of a period (80 samples)
    t, rs = refs.raster(T, [W, H], lines, f, smoothing=s)
    assert rs[0].min() == pytest.approx(0.0, abs=1e-9) and rs[0].max() == pytest.approx(W)
    # linear between the rounded turns: constant speed there, zero second difference
    mid = slice(45, 155)                        # more than s/2 = 40 samples from the turns
    assert np.max(np.abs(np.diff(rs[0][mid], 2))) < 1e-9
    # rounded: the speed changes by small steps, not by 4 W f T at once
    assert np.max(np.abs(np.diff(rs[0], 2))) < 0.1 * 4 * W * f * T
    # the slow-axis steps are spread too, and still reach every line
    line = refs.raster_line_index(t, f)
    for j in range(lines):
        centre = (line == j) & (np.abs(np.mod(f * t, 1.0) - 0.5) < 0.3)
        np.testing.assert_allclose(rs[1][centre], j * H / (lines - 1), atol=1e-12)
    assert np.max(np.abs(np.diff(rs[1]))) < 0.2 * H / (lines - 1)


@pytest.mark.parametrize("kwargs, field", [
    (dict(size=[40.0], lines=4, frequency=50.0), "size"),
    (dict(size=[40.0, -1.0], lines=4, frequency=50.0), "size[1]"),
    (dict(size=[40.0, 30.0], lines=1, frequency=50.0), "lines"),
    (dict(size=[40.0, 30.0], lines=4, frequency=50.0, slow="zigzag"), "slow"),
    (dict(size=[40.0, 30.0], lines=4, frequency=50.0, smoothing=0.7), "smoothing"),
    (dict(size=[40.0, 30.0], lines=4, frequency=9000.0), "frequency"),
])
def test_raster_errors_name_the_field(kwargs, field):
    with pytest.raises(refs.SignalError, match="^" + re.escape(field) + ":"):
        refs.raster(T, **kwargs)


def test_raster_line_metrics_per_line():
    line = np.repeat(np.arange(3), 4)
    ref = np.zeros((2, 12))
    out = np.zeros((2, 12))
    out[0, line == 1] = 3.0                     # line 2: |e| = 5 everywhere (3-4-5)
    out[1, line == 1] = 4.0
    out[0, 8] = 1.0                             # line 3: one sample off by 1
    rows = met.raster_line_metrics(ref, out, line)
    got = {(r["channel"], r["metric"]): r["value"] for r in rows}
    assert got[("line-1", "line_rms_error")] == 0.0
    assert got[("line-2", "line_rms_error")] == pytest.approx(5.0)
    assert got[("line-2", "line_max_error")] == pytest.approx(5.0)
    assert got[("line-3", "line_rms_error")] == pytest.approx(0.5)   # sqrt(1/4)
    assert got[("line-3", "line_max_error")] == pytest.approx(1.0)


# -- file references ----------------------------------------------------------------------
def _csv(path, times, cols):
    lines = ["time," + ",".join(cols)] + [
        ",".join([repr(float(t))] + [repr(float(v)) for v in vals])
        for t, vals in zip(times, zip(*cols.values()))]
    path.write_text("\n".join(lines) + "\n")


def test_file_reference_resampled_exactly_for_a_linear_trajectory(tmp_path):
    times = np.array([0.0, 0.0013, 0.004, 0.0071, 0.01])    # non-uniform
    _csv(tmp_path / "traj.csv", times, {"px": 3.0 + 1000.0 * times, "py": -2.0 * times})
    t, r = refs.from_file(T, ["x", "y"], "traj.csv", {"x": "px"}, base_dir=tmp_path)
    assert t.size == 201 and t[-1] == pytest.approx(0.01)
    np.testing.assert_allclose(r[0], 3.0 + 1000.0 * t, atol=1e-9)
    assert not np.any(r[1])                                   # y not given: zero
    t, r = refs.from_file(T, ["x", "y"], tmp_path / "traj.csv", {"y": "py"}, duration=0.005)
    assert t.size == 101
    np.testing.assert_allclose(r[1], -2.0 * t, atol=1e-12)


def test_file_reference_refuses_extrapolation_and_names_the_key(tmp_path):
    times = np.array([0.001, 0.002, 0.003])
    _csv(tmp_path / "late.csv", times, {"px": times})
    with pytest.raises(refs.SignalError, match=r"^time: .*extrapolation"):
        refs.from_file(T, ["x"], "late.csv", {"x": "px"}, base_dir=tmp_path)
    _csv(tmp_path / "short.csv", np.array([0.0, 0.002]), {"px": [0.0, 1.0]})
    with pytest.raises(refs.SignalError, match=r"^duration: .*extrapolation"):
        refs.from_file(T, ["x"], "short.csv", {"x": "px"}, duration=0.01, base_dir=tmp_path)
    with pytest.raises(refs.SignalError, match=r"^columns.x: column 'qx' not in"):
        refs.from_file(T, ["x"], "short.csv", {"x": "qx"}, base_dir=tmp_path)
    with pytest.raises(refs.SignalError, match=r"^columns.z:"):
        refs.from_file(T, ["x"], "short.csv", {"z": "px"}, base_dir=tmp_path)
    with pytest.raises(refs.SignalError, match=r"^file: .*larger than"):
        refs.from_file(T, ["x"], "short.csv", {"x": "px"}, base_dir=tmp_path, max_bytes=10)
    with pytest.raises(refs.SignalError, match=r"^file: .*not found"):
        refs.from_file(T, ["x"], "none.csv", {"x": "px"}, base_dir=tmp_path)


# -- scenarios ----------------------------------------------------------------------------
_HEAD = """
name = "s"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
"""


def test_scenario_validation_names_every_bad_key(tmp_path):
    _csv(tmp_path / "traj.csv", np.array([0.0, 0.002]), {"px": [0.0, 1.0]})
    path = tmp_path / "bad.toml"
    path.write_text(_HEAD + textwrap.dedent("""
        [[cases]]
        name = "a"
        reference = { kind = "raster", outputs = ["x", "y"], size = [40.0, 30.0], lines = 1, frequency = 50.0, smoothing = 0.7, slowly = "step" }
        [[cases]]
        name = "b"
        reference = { kind = "raster", outputs = ["x", "x"], size = [40.0, 30.0], lines = 4, frequency = 50.0 }
        [[cases]]
        name = "c"
        reference = { kind = "file", file = "traj.csv", columns = { x = "px" }, duration = 1.0 }
        [[cases]]
        name = "d"
        reference = { kind = "triangle", output = "x", amplitude = -1.0, frequency = 50.0, periods = 2 }
        [[cases]]
        name = "e"
        drive = { kind = "triangel", input = "ux", amplitude = 1.0, frequency = 50.0, periods = 2 }
        """))
    with pytest.raises(ScenarioError) as exc:
        validate_scenario(path)
    text = "\n".join(exc.value.problems)
    for key in ("cases[0].reference.lines", "cases[0].reference.smoothing",
                "cases[0].reference.slowly", "cases[1].reference.outputs",
                "cases[2].reference.duration", "cases[3].reference.amplitude",
                "cases[4].drive.kind"):
        assert key in text, (key, text)
    assert "did you mean 'triangle'" in text


def test_scenario_with_file_and_raster_references_runs(tmp_path):
    times = np.linspace(0.0, 0.02, 41)
    _csv(tmp_path / "traj.csv", times, {"px": 20.0 * np.sin(2 * np.pi * 50 * times),
                                        "py": 10.0 * np.sin(2 * np.pi * 25 * times)})
    path = tmp_path / "ok.toml"
    path.write_text(_HEAD + textwrap.dedent("""
        [[cases]]
        name = "from-file"
        reference = { kind = "file", file = "traj.csv", columns = { x = "px", y = "py" } }
        [[cases]]
        name = "scan"
        reference = { kind = "raster", outputs = ["y", "x"], size = [20.0, 10.0], lines = 4, frequency = 50.0 }
        """))
    sc = load_scenario(path)
    f, scan = (run_case(c) for c in sc.cases)
    assert f.reference.shape == (2, 401)
    assert scan.reference[0].max() == pytest.approx(10.0)       # slow axis on x (row 0)
    assert scan.reference[1].max() == pytest.approx(20.0)       # fast axis on y (row 1)
    lines = sorted(r["channel"] for r in scan.metrics if r["metric"] == "line_rms_error")
    assert lines == ["line-1", "line-2", "line-3", "line-4"]
    # static plant with its own model: the compensator leaves a small error
    rms = {(r["channel"], r["metric"]): r["value"] for r in f.metrics}
    assert rms[("x", "rms_error")] < 0.05 * 20.0
