"""The delay ``evaluate`` reports: exact on a known inserted delay.

The "measured" records are made here, outside the project: the reference
itself, or the response of an actuator defined in this file (play-operator
hysteresis written out naively, 4 % cross-coupling and a 1.1 kHz bending
mode through scipy.signal.lfilter), with 40 nm RMS sensor noise, then delayed
by d samples (the first d samples held at the record's first value). The
estimate must be d for the reference itself, and move by exactly d for the
actuator's response (whose own phase lag is part of what it measures).
"""

import numpy as np
import pytest
import scipy.signal

from hammerstein.cli.evaluate import evaluate
from hammerstein.compensation.ilc import estimate_delay
from hammerstein.signals.references import circle, raster

T = 5e-5
DELAYS = range(0, 21)


def _reference(kind, frequency):
    if kind == "circle":
        _, r = circle(T, 20.0, frequency, periods=6)
    else:
        _, r = raster(T, [40.0, 40.0], 6, frequency, smoothing=0.1)
    return r, int(round(1 / (frequency * T)))


def _delayed(y, d):
    return np.concatenate([np.repeat(y[:, :1], d, axis=1), y[:, :y.shape[1] - d]], axis=1)


def _actuator(r):
    """An actuator outside the project: y = G (M u + hysteresis), u the reference [µm as V]."""
    u = 0.9 * r
    out = np.empty_like(u)
    for ch in range(u.shape[0]):                      # play operators, threshold 2 µm, weight 0.1
        state, h = 0.0, np.empty(u.shape[1])
        for t, v in enumerate(u[ch]):
            state = max(v - 2.0, min(v + 2.0, state))
            h[t] = state
        out[ch] = u[ch] + 0.1 * h
    out = np.array([[1.0, 0.04], [0.04, 1.0]]) @ out
    w = 2 * np.pi * 1100.0                            # bending mode, damping 0.1, unit DC gain
    b, a = scipy.signal.cont2discrete(([w * w], [1.0, 0.2 * w, w * w]), T, method="zoh")[:2]
    return scipy.signal.lfilter(np.ravel(b), a, out, axis=1)


@pytest.mark.parametrize("kind", ["circle", "raster"])
@pytest.mark.parametrize("frequency", [10.0, 50.0, 200.0])
def test_evaluate_finds_an_inserted_delay_exactly(kind, frequency):
    r, P = _reference(kind, frequency)
    noise = np.random.default_rng(int(frequency)).normal(0.0, 0.04, r.shape)
    for d in DELAYS:
        _, delay, _, _ = evaluate(r, _delayed(r + noise, d), P, T, ["x", "y"])
        assert delay == d, (kind, frequency, d)


@pytest.mark.parametrize("kind", ["circle", "raster"])
@pytest.mark.parametrize("frequency", [10.0, 50.0, 200.0])
def test_an_inserted_delay_moves_the_estimate_by_exactly_itself(kind, frequency):
    r, P = _reference(kind, frequency)
    y = _actuator(r) + np.random.default_rng(7).normal(0.0, 0.04, r.shape)
    lag = max(P // 2, 50)
    own = estimate_delay(r, y, lag)
    assert abs(own) < 40                # the actuator's own lag at the fundamental, a few samples
    for d in DELAYS:
        assert estimate_delay(r, _delayed(y, d), lag) == own + d, (kind, frequency, d)


def test_the_overlap_does_not_bias_a_slow_circle():
    """The plain sum over the overlap n - |k| found a 10 Hz circle's 10-sample delay 2 short."""
    _, r = circle(T, 30.0, 10.0, periods=12)
    y = _delayed(r, 10)
    n, L = r.shape[1], 1000
    plain = [np.sum(r[:, :n - k] * y[:, k:]) for k in range(L + 1)]
    assert int(np.argmax(plain)) < 10                  # the bias this estimator removes
    assert estimate_delay(r, y, L) == 10


@pytest.mark.parametrize("reference, measured, lag, expected", [
    (np.ones((2, 100)), np.ones((2, 100)), 10, 0),                # constant: no delay to see
    (np.sin(np.arange(300) / 5.0)[None], np.sin((np.arange(300) + 3) / 5.0)[None], 10, -3),
])
def test_edge_cases(reference, measured, lag, expected):
    assert estimate_delay(reference, measured, lag) == expected
