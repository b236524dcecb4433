"""Metrics against closed forms: ellipse and play-operator loops, errors."""

import numpy as np
import pytest

from hammerstein.signals import metrics as met
from hammerstein.models.hysteresis import play

P = 400  # samples per period


def _theta(periods=3):
    return 2 * np.pi * np.arange(periods * P) / P


@pytest.mark.parametrize("A, B, phi_deg", [(10.0, 50.0, 10.0), (1.0, 3.0, 30.0), (5.0, 2.0, 2.0)])
def test_hysteresis_width_of_an_ellipse(A, B, phi_deg):
    # u = A sin(th), y = B sin(th - phi): vertical chord at u=0 is the longest, 2 B sin(phi)
    th = _theta()
    u, y = A * np.sin(th), B * np.sin(th - np.deg2rad(phi_deg))
    assert met.hysteresis_width(u, y, P) == pytest.approx(2 * B * np.sin(np.deg2rad(phi_deg)),
                                                          rel=1e-3)


@pytest.mark.parametrize("r", [0.5, 2.0, 4.0])
def test_hysteresis_width_of_a_play_operator_is_twice_the_threshold(r):
    u = 10.0 * np.sin(_theta())
    y, _ = play(u, [r])
    assert met.hysteresis_width(u, y[0], P) == pytest.approx(2 * r, rel=1e-6)


def test_linear_map_has_no_hysteresis_and_peak_to_peak():
    u = 10.0 * np.sin(_theta())
    assert met.hysteresis_width(u, 3.0 * u, P) == pytest.approx(0.0, abs=1e-9)
    assert met.peak_to_peak(3.0 * u) == pytest.approx(60.0, rel=1e-9)


def test_hysteresis_width_needs_a_full_period():
    with pytest.raises(ValueError, match="period_samples"):
        met.hysteresis_width(np.zeros(10), np.zeros(10), P)


def test_euclidean_error_is_a_distance():
    r = np.array([[3.0, 0.0], [4.0, 1.0]])
    y = np.zeros((2, 2))
    np.testing.assert_allclose(met.euclidean_error(r, y), [5.0, 1.0])


def test_steady_window():
    assert met.steady_window(1200, 400, 1) == slice(400, 1200)
    with pytest.raises(ValueError, match="settle_periods"):
        met.steady_window(800, 400, 2)


def _as_dict(rows):
    return {(r["channel"], r["metric"]): r["value"] for r in rows}


def test_tracking_metrics_skip_the_transient_and_report_cross_coupling():
    th = _theta(3)
    ref = np.vstack([50.0 * np.sin(th), np.zeros_like(th)])
    out = ref.copy()
    out[0] += 0.3                      # constant error on x
    out[1] = 0.1 * np.sin(th)          # residual cross-coupling on y (0.2 p-p)
    out[:, :P] += 100.0                # a settling transient, excluded
    m = _as_dict(met.tracking_metrics(ref, out, ["x", "y"], P, settle_periods=1, scale=50.0,
                                      loop_channel=0))
    assert m[("x", "rms_error")] == pytest.approx(0.3, rel=1e-9)
    assert m[("x", "max_abs_error")] == pytest.approx(0.3, rel=1e-9)
    assert m[("y", "cross_coupling_peak_to_peak")] == pytest.approx(0.2, rel=1e-4)
    assert ("x", "cross_coupling_peak_to_peak") not in m
    assert m[("x", "hysteresis_width")] == pytest.approx(0.0, abs=1e-9)
    assert m[("x", "rms_error_percent")] == pytest.approx(0.6, rel=1e-9)
    ee = np.hypot(0.3, 0.1 * np.sin(th[P:]))
    assert m[("x+y", "max_euclidean_error")] == pytest.approx(ee.max(), rel=1e-9)
    assert m[("x+y", "rms_euclidean_error")] == pytest.approx(np.sqrt(np.mean(ee ** 2)), rel=1e-9)
    assert m[("x+y", "max_euclidean_error_percent")] == pytest.approx(100 * ee.max() / 50, rel=1e-9)


def test_open_loop_metrics_of_a_known_loop():
    th = _theta(2)
    u = np.vstack([10.0 * np.sin(th), np.zeros_like(th)])
    y = np.vstack([5.0 * np.sin(th - 0.2), 0.5 * np.sin(th)])
    m = _as_dict(met.open_loop_metrics(u, y, 0, ["x", "y"], P, settle_periods=1))
    assert m[("x", "peak_to_peak")] == pytest.approx(10.0, rel=1e-4)
    assert m[("x", "hysteresis_width")] == pytest.approx(10.0 * np.sin(0.2), rel=1e-3)
    assert m[("x", "hysteresis_ratio")] == pytest.approx(100 * np.sin(0.2), rel=1e-3)
    assert m[("y", "cross_coupling_peak_to_peak")] == pytest.approx(1.0, rel=1e-4)
    assert ("x", "cross_coupling_peak_to_peak") not in m
    assert {r["unit"] for r in met.open_loop_metrics(u, y, 0, ["x", "y"], P)} == {"µm", "%"}
