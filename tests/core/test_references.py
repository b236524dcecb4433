"""References and drives: closed-form values, lengths, and field-named errors."""

import re

import numpy as np
import pytest

from hammerstein.signals import references as refs

T = 5e-5  # s, the paper's sampling period


def test_sine_values_length_and_other_channels_zero():
    t, r = refs.sine(T, ["x", "y"], "y", amplitude=50.0, frequency=50.0, periods=3)
    assert t.shape == (1200,) and r.shape == (2, 1200)  # 400 samples per period
    np.testing.assert_allclose(t[1] - t[0], T, rtol=0, atol=1e-15)
    assert not np.any(r[0])
    # quarter period: 100 samples at 50 Hz / 20 kHz -> peak
    assert r[1, 100] == pytest.approx(50.0, abs=1e-9)
    np.testing.assert_allclose(r[1], 50.0 * np.sin(2 * np.pi * 50.0 * t), atol=1e-12)


def test_sine_phase_offset_and_duration():
    t, r = refs.sine(T, ["x"], "x", amplitude=2.0, frequency=100.0, phase=90.0, offset=1.0,
                     duration=0.01)
    assert t.size == 200
    assert r[0, 0] == pytest.approx(3.0, abs=1e-12)  # offset + amplitude cos(0)


def test_sine_drive_on_one_input():
    t, u = refs.sine_drive(T, ["ux", "uy"], "ux", amplitude=10.0, frequency=50.0, periods=1)
    assert u.shape == (2, 400)
    assert u[0].max() == pytest.approx(10.0, abs=1e-9) and not np.any(u[1])


def test_circle_has_constant_radius_and_starts_on_x():
    t, r = refs.circle(T, radius=30.0, frequency=50.0, periods=2)
    np.testing.assert_allclose(np.hypot(r[0], r[1]), 30.0, rtol=1e-12)
    np.testing.assert_allclose(r[:, 0], [30.0, 0.0], atol=1e-12)


def test_spiral_radius_constant_then_exponential_decay():
    R, f, tau = 50.0, 50.0, 0.02
    t, r = refs.spiral(T, radius=R, frequency=f, tau=tau, duration=0.1, circle_periods=2)
    rad = np.hypot(r[0], r[1])
    t0 = 2 / f
    np.testing.assert_allclose(rad[t <= t0], R, rtol=1e-12)
    late = t > t0
    np.testing.assert_allclose(rad[late], R * np.exp(-(t[late] - t0) / tau), rtol=1e-10)


@pytest.mark.parametrize("fx, fy, period", [(50.0, 100.0 / 3.0, 0.06), (40.0, 30.0, 0.1),
                                            (50.0, 50.0, 0.02)])
def test_lissajous_common_period_and_closure(fx, fy, period):
    assert refs.lissajous_period(fx, fy) == pytest.approx(period, rel=1e-9)
    t, r = refs.lissajous(T, amplitude=[50.0, 40.0], frequencies=[fx, fy], periods=1)
    assert t.size == round(period / T)
    np.testing.assert_allclose(r[0], 50.0 * np.cos(2 * np.pi * fx * t), atol=1e-9)
    np.testing.assert_allclose(r[1], 40.0 * np.sin(2 * np.pi * fy * t), atol=1e-9)
    # the next sample after one common period is the first sample again
    tp = t.size * T
    assert 50.0 * np.cos(2 * np.pi * fx * tp) == pytest.approx(r[0, 0], abs=1e-6)
    assert 40.0 * np.sin(2 * np.pi * fy * tp) == pytest.approx(r[1, 0], abs=1e-6)


@pytest.mark.parametrize("call, field", [
    (lambda: refs.sine(T, ["x", "y"], "x", 50.0, 1e4, periods=1), "frequency"),      # Nyquist
    (lambda: refs.sine(T, ["x", "y"], "x", 50.0, 3000.0, periods=1), "frequency"),   # < 8 samples
    (lambda: refs.sine(T, ["x", "y"], "x", -1.0, 50.0, periods=1), "amplitude"),
    (lambda: refs.sine(T, ["x", "y"], "x", 0.0, 50.0, periods=1), "amplitude"),
    (lambda: refs.sine(T, ["x", "y"], "z", 1.0, 50.0, periods=1), "output"),
    (lambda: refs.sine(T, ["x", "y"], "x", 1.0, 50.0, periods=1, duration=1.0), "periods/duration"),
    (lambda: refs.sine(T, ["x", "y"], "x", 1.0, 50.0), "periods/duration"),
    (lambda: refs.sine_drive(T, ["ux"], "ux", 10.0, 50.0, periods=-2), "periods"),
    (lambda: refs.circle(T, 0.0, 50.0, periods=1), "radius"),
    (lambda: refs.spiral(T, 50.0, 50.0, tau=0.0, duration=0.1), "tau"),
    (lambda: refs.lissajous(T, 50.0, [50.0, 1e4], periods=1), "frequencies[1]"),
    (lambda: refs.lissajous(T, 50.0, [50.0, 50.0 / np.pi], periods=1), "frequencies"),
])
def test_errors_name_the_field(call, field):
    with pytest.raises(refs.SignalError, match="^" + re.escape(field) + ":"):
        call()


def test_eight_samples_per_period_is_accepted():
    t, r = refs.sine(T, ["x"], "x", 1.0, 1.0 / (8 * T), periods=1)
    assert t.size == 8


@pytest.mark.parametrize("kind, table", [
    ("circle", {"radius": 10.0, "frequency": 50.0, "periods": 2}),
    ("lissajous", {"amplitude": 10.0, "frequencies": [50.0, 100.0], "periods": 1}),
    ("spiral", {"radius": 10.0, "frequency": 50.0, "tau": 0.01, "duration": 0.05}),
])
def test_a_centre_moves_a_planar_reference(kind, table):
    """``center = [x, y]``: the same signal, moved (a unipolar stage's circle lies around
    the middle of its travel, not around 0)."""
    kind_ = refs.REFERENCE_KINDS[kind]
    base = kind_.generate(dict(table), 1e-4, ["x", "y", "z"], None)[1]
    moved = kind_.generate({**table, "center": [50.0, 40.0]}, 1e-4, ["x", "y", "z"], None)[1]
    np.testing.assert_allclose(moved[:2] - base[:2], [[50.0], [40.0]] * np.ones_like(base[:2]),
                               atol=1e-12)
    np.testing.assert_array_equal(moved[2], base[2])


def test_a_centred_raster_spans_its_size_around_the_centre():
    table = {"outputs": ["x", "y"], "size": [40.0, 20.0], "lines": 4, "frequency": 20.0,
             "slow": "step", "smoothing": 0.0}
    kind = refs.REFERENCE_KINDS["raster"]
    sig = kind.generate({**table, "center": [50.0, 50.0]}, 1e-4, ["x", "y"], None)[1]
    assert sig[0].min() == pytest.approx(30.0) and sig[0].max() == pytest.approx(70.0)
    assert sig[1].min() == pytest.approx(40.0) and sig[1].max() == pytest.approx(60.0)


@pytest.mark.parametrize("fn, args", [
    ("circle", (1e-4, 10.0, 50.0, 0.0, 2)),
    ("spiral", (1e-4, 10.0, 50.0, 0.01, 0.05)),
    ("lissajous", (1e-4, [10.0, 5.0], [50.0, 100.0], 0.0, 1)),
    ("raster", (1e-4, [40.0, 20.0], 4, 20.0)),
])
def test_the_python_functions_take_a_centre(fn, args):
    """``center=(x, y)`` in Python as in a table: the same figure, moved; a raster's
    rectangle is centred there and starts at its corner."""
    import hammerstein
    f = getattr(hammerstein, fn)
    _, base = f(*args)
    _, moved = f(*args, center=(50.0, -40.0))
    shift = np.array([[50.0], [-40.0]])
    if fn == "raster":      # [0, W] x [0, H] moved so that (50, -40) is its centre
        shift = shift - np.array([[20.0], [10.0]])
        assert moved[:, 0] == pytest.approx([30.0, -50.0])
    np.testing.assert_allclose(moved - base, shift * np.ones_like(base), atol=1e-12)
    with pytest.raises(refs.SignalError, match=r"center: expected two finite numbers"):
        f(*args, center=(1.0, float("nan")))


@pytest.mark.parametrize("kind, table", [
    ("circle", {"radius": 10.0, "frequency": 50.0, "periods": 2}),
    ("raster", {"outputs": ["x", "y"], "size": [40.0, 20.0], "lines": 4, "frequency": 20.0,
                "slow": "step", "smoothing": 0.0}),
])
def test_a_full_centre_holds_the_outputs_outside_the_figure(kind, table):
    """A three-axis stage: ``center = [x, y, z]`` places the figure at (x, y) and holds z
    there; z stayed at 0 µm, below a unipolar stage's rest, and the reach note's advice of a
    three-value centre was refused."""
    entry = refs.REFERENCE_KINDS[kind]
    names = ["x", "y", "z"]
    two = entry.generate({**table, "center": [50.0, 40.0]}, 1e-4, names, None)[1]
    full = entry.generate({**table, "center": [50.0, 40.0, 12.5]}, 1e-4, names, None)[1]
    np.testing.assert_array_equal(full[:2], two[:2])
    np.testing.assert_array_equal(full[2], np.full(full.shape[1], 12.5))
    with pytest.raises(refs.SignalError, match="center: expected two values"):
        entry.generate({**table, "center": [1.0, 2.0, 3.0, 4.0]}, 1e-4, names, None)
