"""Reference shaping: a reference the drive cannot follow within the limits is shaped, not clipped."""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein.compensation.shaping import (first_mode_hz, hann_average, limit_excess,
                                              mode_decay_s, shape_reference)
from hammerstein.models.amplifier import amplifier_from_table


def _amp(low=-10.0, high=10.0, slew=1.0):
    return amplifier_from_table({"range": [low, high], "slew_rate": slew}, ["u"])


def test_hann_average_keeps_constants_and_ramps():
    """A symmetric kernel of unit sum: constants and straight lines pass unchanged (no lag)."""
    k = np.arange(200.0)
    ramp = np.vstack([3.0 + 0.25 * k, np.full(200, -2.0)])
    out = hann_average(ramp, 21)
    assert np.allclose(out[:, 10:-10], ramp[:, 10:-10], atol=1e-12)
    assert np.allclose(out[1], -2.0)


def test_limit_excess_closed_form():
    amp = _amp(-1.0, 1.0, 2.0)                                   # 2 V/s at T = 0.5 s: 1 V/sample
    e = limit_excess(amp, [[0.5, 2.5, 1.0, 1.0]], 0.5)
    # 0: within; 1: 1.5 V beyond the range + a 2 V step (1 V over); 2: a 1.5 V step (0.5 over)
    assert e.tolist() == pytest.approx([0.0, 2.5, 0.5, 0.0])


def test_first_mode_of_two_modes_and_a_lag():
    T = 1e-4
    blocks = []
    for f in (700.0, 300.0):
        z = np.exp(T * (-30.0 + 2j * np.pi * f))
        blocks.append([[z.real, -z.imag], [z.imag, z.real]])
    A = np.zeros((5, 5))
    A[:2, :2], A[2:4, 2:4], A[4, 4] = blocks[0], blocks[1], np.exp(-T / 0.1)
    assert first_mode_hz(A, T) == pytest.approx(300.0, rel=1e-12)
    assert first_mode_hz(np.zeros((0, 0)), T) is None
    assert first_mode_hz([[0.9]], T) is None


def test_mode_decay_is_one_over_zeta_omega_of_the_slowest_mode_and_ignores_real_poles():
    """tau = 1 / (zeta omega_n): modes at 700 Hz (zeta 0.05) and 300 Hz (zeta 0.02), a 0.1 s lag."""
    T = 5e-5
    blocks, taus = [], []
    for f, zeta in ((700.0, 0.05), (300.0, 0.02)):
        w = 2 * np.pi * f
        s = -zeta * w + 1j * w * np.sqrt(1 - zeta ** 2)
        z = np.exp(T * s)
        blocks.append([[z.real, -z.imag], [z.imag, z.real]])
        taus.append(1.0 / (zeta * w))
    A = np.zeros((5, 5))
    A[:2, :2], A[2:4, 2:4], A[4, 4] = blocks[0], blocks[1], np.exp(-T / 0.1)
    assert mode_decay_s(A, T) == pytest.approx(max(taus), rel=1e-9)      # 26.5 ms, not the lag's
    assert mode_decay_s(A[:2, :2], T) == pytest.approx(taus[0], rel=1e-9)
    assert mode_decay_s(np.zeros((0, 0)), T) is None
    assert mode_decay_s([[0.9]], T) is None                              # a lag is not a mode
    assert mode_decay_s([[0.0, -1.0], [1.0, 0.0]], T) == np.inf         # undamped


def _pair(f, zeta, T):
    """The discrete 2 x 2 block of a pole pair at natural frequency f [Hz], damping zeta."""
    w = 2 * np.pi * f
    z = np.exp(T * (-zeta * w + 1j * w * np.sqrt(1 - zeta ** 2)))
    return [[z.real, -z.imag], [z.imag, z.real]]


@pytest.mark.parametrize("zeta, is_mode", [(0.05, True), (0.7, True), (0.71, False), (0.998, False)])
def test_a_pole_pair_without_resonance_is_not_a_bending_mode(zeta, is_mode):
    """|G| of a second-order pair peaks above its static gain only for zeta < 1 / sqrt(2):
    a pair at 88 Hz damped at 0.998 (damped frequency 5.6 Hz) is a lag, and the first mode
    is then the 520 Hz one, as its decay time is."""
    T = 5e-5
    w = np.logspace(0, 4, 4001) * 2 * np.pi                     # the closed form's own peak
    gain = 1.0 / np.abs(1.0 - (w / (2 * np.pi * 88.0)) ** 2 + 2j * zeta * w / (2 * np.pi * 88.0))
    assert (gain.max() > 1.0 + 1e-9) == is_mode
    A = np.zeros((4, 4))
    A[:2, :2], A[2:, 2:] = _pair(88.0, zeta, T), _pair(520.0, 0.05, T)
    damped = 88.0 * np.sqrt(1 - zeta ** 2)
    assert first_mode_hz(A, T) == pytest.approx(damped if is_mode else 520.0 * np.sqrt(1 - 0.05 ** 2),
                                                rel=1e-9)
    slowest = 1.0 / (zeta * 2 * np.pi * 88.0) if is_mode else 0.0
    assert mode_decay_s(A, T) == pytest.approx(max(slowest, 1.0 / (0.05 * 2 * np.pi * 520.0)),
                                               rel=1e-9)


def test_a_step_beyond_the_slew_rate_becomes_an_s_curve_within_it():
    """A unit-gain 'compensator' behind a 1 V/sample slew limit: a 6 V step is spread."""
    amp = _amp(slew=1.0)
    r = np.concatenate([np.zeros(40), np.full(60, 6.0)])[None, :]
    s = shape_reference(lambda x: x, r, amp, 1.0)
    assert limit_excess(amp, s.inputs, 1.0).max() == 0.0        # the drive within the slew rate
    assert np.all(np.diff(s.reference[0]) >= -1e-12)             # still monotone: an S-curve
    assert s.reference[0, 0] == 0.0 and s.reference[0, -1] == 6.0
    far = np.r_[0:40 - 2 * s.window_samples, 40 + 2 * s.window_samples:100]
    assert np.array_equal(s.reference[0, far], r[0, far])       # unchanged away from the step
    assert len(s.notes) == 1 and "reference shaped by up to" in s.notes[0]


def test_a_reference_within_the_limits_is_not_touched():
    amp = _amp(slew=10.0)
    r = np.sin(np.linspace(0, 6, 300))[None, :]
    s = shape_reference(lambda x: 2.0 * x, r, amp, 1.0)
    assert s.reference is not None and np.array_equal(s.reference, r) and not s.changed


def test_a_range_the_amplifier_does_not_reach_is_limited_to_what_it_reaches():
    """Model y = u, range +-1 V: a reference to 1.5 is limited to the reachable 1.0 (or inside)."""
    amp = _amp(-1.0, 1.0, slew=100.0)
    t = np.linspace(0, 1, 400)
    r = (1.5 * np.sin(2 * np.pi * 2 * t) * np.minimum(t / 0.2, 1.0))[None, :]
    s = shape_reference(lambda x: x, r, amp, 1.0, predict=lambda u: u)
    assert s.range_limited and limit_excess(amp, s.inputs, 1.0).max() == 0.0
    assert np.max(np.abs(s.reference)) <= 1.0 + 1e-12
    assert "the output the drive reaches within the range (" in s.notes[0]


def test_a_periodic_reference_beyond_the_slew_rate_is_shaped_alike_in_every_period():
    """Model y = u (range +-10 V, slew 0.05 V/sample): a sine of 1 V at 40 samples per period
    slews up to 2 pi / 40 = 0.157 V/sample. Shaped with its period given, the last period is
    the one before (a drive reads a periodic reference past its end as its earlier periods),
    its drive is within the slew rate like the others, and the note names the slew rate, not
    the range, which the drive never left."""
    amp = _amp(-10.0, 10.0, slew=0.05)
    P, n = 40, 400
    k = np.arange(n)
    r = (np.sin(2 * np.pi * k / P) * np.minimum(k / (2.0 * P), 1.0))[None, :]
    s = shape_reference(lambda x: x, r, amp, 1.0, predict=lambda u: u, period_samples=P)
    assert s.changed and limit_excess(amp, s.inputs, 1.0).max() == 0.0
    np.testing.assert_array_equal(s.reference[:, n - P:], s.reference[:, n - 2 * P:n - P])
    assert np.abs(s.inputs[:, n - P:]).max() <= np.abs(s.inputs[:, n - 3 * P:n - P]).max() + 1e-12
    assert "within the slew rate" in s.notes[0] and "range" not in s.notes[0]


def test_samples_at_rest_before_the_reference_moves_stay_at_rest():
    amp = _amp(slew=0.5)
    r = np.concatenate([np.zeros(10), np.full(50, 4.0)])[None, :]
    s = shape_reference(lambda x: x, r, amp, 1.0)
    assert s.changed and np.all(s.reference[0, :5] == 0.0)


def test_a_step_faster_than_the_first_mode_is_band_limited_even_within_the_limits():
    """Limits far away: a 2 µm step is still smoothed over one period of the 500 Hz mode
    (20 samples at 10 kHz), a 100 Hz sine (below the mode) is not touched."""
    T, f1 = 1e-4, 500.0
    amp = _amp(-100.0, 100.0, slew=1e9)
    step = np.concatenate([np.zeros(50), np.full(150, 2.0)])[None, :]
    s = shape_reference(lambda x: x, step, amp, T, first_mode=f1)
    assert s.changed and s.window_samples == 20 and "first mode" in s.notes[0]
    assert np.all(np.diff(s.reference[0]) >= -1e-12)            # monotone S-curve
    assert np.max(np.abs(np.diff(s.reference[0]))) < 2.0 / 5     # spread over many samples
    assert np.array_equal(s.reference[0, 100:], step[0, 100:])   # unchanged a window away
    t = np.arange(400) * T
    sine = (np.sin(2 * np.pi * 100 * t) * np.minimum(t / 0.01, 1.0))[None, :]
    assert not shape_reference(lambda x: x, sine, amp, T, first_mode=f1).changed


def test_a_circle_at_or_above_the_first_mode_keeps_its_size():
    """Its fundamental is no transient to band-limit: averaging it over the capped window (half
    its period) shrank a 10 µm circle at a 299 Hz mode to 8.26 µm, and learn converged there."""
    T, mode = 1e-4, 200.0
    amp = amplifier_from_table({"range": [-100.0, 100.0]}, ["ux", "uy"])
    t = np.arange(2000) * T
    fade = 0.5 - 0.5 * np.cos(np.pi * np.minimum(t / 0.05, 1.0))    # a raised cosine, as compensate's
    for f in (200.0, 250.0):                  # 50 and 40 samples a period
        circle = 10.0 * np.vstack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
        circle *= fade                        # faded in from rest
        P = int(round(1.0 / (f * T)))
        s = shape_reference(lambda x: x, circle, amp, T, first_mode=mode, period_samples=P)
        assert np.array_equal(s.reference, circle), f
        assert not s.notes, s.notes
    # a triangle at 250 Hz keeps being smoothed at its corners, where it accelerates more than
    # any sine at its fundamental: the corners only, its straight parts left as they were
    P = 40
    tri = 10.0 * (2.0 * np.abs(2.0 * ((np.arange(2000) / P) % 1.0) - 1.0) - 1.0)[None]
    tri = np.vstack([tri, tri]) * fade
    s = shape_reference(lambda x: x, tri, amp, T, first_mode=mode, period_samples=P)
    delta = np.max(np.abs(s.reference - tri), axis=0)[1000:]      # settled, fade done
    k = np.arange(1000, 2000) % (P // 2)
    assert np.min(delta[k == 0]) > 0.5                          # the corners rounded
    assert np.max(delta[k == P // 4]) <= 1e-9                   # a ramp's middle: its own average
    assert "half the reference's period, less than one period of the mode" in s.notes[0]
