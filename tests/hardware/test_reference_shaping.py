"""Reference shaping: a reference the drive cannot follow within the limits is shaped, not clipped."""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein.compensation.shaping_holds import hold_note
from hammerstein.compensation.shaping import (faster_than_mode, first_mode_hz, hann_average,
                                              limit_excess, mode_decay_s, shape_reference)
from hammerstein.models.amplifier import amplifier_from_table
from hammerstein.signals.references import raster


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


def _mode_inverse(f1, T):
    """The drive of an undamped bending mode at ``f1`` of unit static gain, inverted:
    ``u = x + x'' / (2 pi f1)^2`` (second difference over ``T^2``; the ends held)."""
    def run(x):
        x = np.asarray(x, dtype=float)
        pad = np.pad(x, ((0, 0), (1, 1)), mode="edge")
        return x + (pad[:, 2:] - 2 * x + pad[:, :-2]) / (2 * np.pi * f1 * T) ** 2
    return run


def test_every_turn_of_a_raster_is_band_limited_not_only_where_the_slow_axis_steps():
    """A 40 µm raster at 10 Hz reverses its fast axis within a sample at both ends; its sampled
    acceleration there (2 v / T) is below a sine at the 180 Hz mode of half its range, and only
    the turns where the slow axis stepped were smoothed: through the mode's inverse each other
    turn was a drive spike of 12 V against 0.08 V a sample on the lines. Expected from
    Bernstein's inequality, not from the shaping: a signal without content above f1 accelerates
    at most 2 pi f1 times its largest speed (sampled: 2 tan(pi f1 T) / T times it), at every turn;
    and the drive then steps at a far-end turn no more than at a turn where the slow axis steps."""
    T, f1, W, f, lines = 1e-4, 180.0, 40.0, 10.0, 6
    _, r = raster(T, [W, W], lines, f)
    lead = 200                                        # at rest at the origin first
    r = np.concatenate([np.zeros((2, lead)), r], axis=1)
    amp = amplifier_from_table({"range": [-1e3, 1e3]}, ["ux", "uy"])   # limits far away
    run = _mode_inverse(f1, T)
    s = shape_reference(run, r, amp, T, first_mode=f1)
    x, P = s.reference[0], int(round(1 / (f * T)))
    speed = np.max(np.abs(np.diff(r[0])))                          # 2 W f T a sample
    bound = 2 * np.tan(np.pi * f1 * T) * speed                     # a second difference [µm]
    acc = np.abs(np.diff(x, 2))                                    # acc[k - 1] at sample k
    ux = np.abs(np.diff(s.inputs[0]))
    w = P // 10
    far = [lead + j * P + P // 2 for j in range(lines)]            # x = W, the slow axis holds
    near = [lead + j * P for j in range(1, lines)]                 # x = 0, the slow axis steps
    for k in far + near:
        assert np.max(acc[k - w - 1:k + w]) <= bound, (k, np.max(acc[k - w - 1:k + w]) / bound)
    step_far = max(np.max(ux[k - w:k + w]) for k in far)
    step_near = max(np.max(ux[k - w:k + w]) for k in near)
    legs = np.max(ux[lead + P // 8:lead + 3 * P // 8])             # a trace's straight middle
    assert step_far <= 1.05 * step_near, (step_far, step_near)
    assert step_far <= 2 * legs, (step_far, legs)


@pytest.mark.parametrize("f", [10.0, 100.0, 179.0])
def test_a_circle_below_the_mode_faded_in_over_one_period_is_never_flagged(f):
    """The speed bound (2 pi f1 times the largest speed) holds for any sine below f1; a fade
    from an off-centre rest over a single period of the circle adds at most an eighth to its
    acceleration, within the bound's margin."""
    T, f1 = 1e-4, 180.0
    t = np.arange(6 * int(round(1 / (f * T)))) * T
    w = 0.5 - 0.5 * np.cos(np.pi * np.minimum(t * f, 1.0))
    rest = np.array([[6.5], [8.7]])
    c = 50.0 + 15.0 * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])
    assert not np.any(faster_than_mode(rest + w * (c - rest), f1, T))


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


T_STAIR, HOLD, MODE = 1e-4, 500, 258.5          # s, samples (50 ms), Hz: a user's 10 µm staircase
STAIR = np.r_[0.0, np.arange(10.0, 81.0, 10.0), np.arange(70.0, 9.0, -10.0)]


def _stair_amp():
    return amplifier_from_table({"range": [0.0, 150.0], "slew_rate": 15000.0}, ["u"])


def _jumping_drive(x):
    """A drive that jumps where the reference enters the model's reach (5 µm): 4 V plus a share
    of the reference's speed there. A wider window lowers the speed's share only, never the
    4 V: the jump's excess over one sample's 1.5 V slew step never halves."""
    x = np.asarray(x)[0]
    u = (1.0 + 0.008 * x) * x + (4.0 + 0.004 * np.abs(np.gradient(x)) / T_STAIR) * (x > 5.0)
    return u[None, :]


def test_a_staircase_is_not_smoothed_longer_than_its_holds_for_a_jump_no_window_removes():
    """Before, every doubling that lowered the jump's excess by a tenth was kept: the window grew
    to 1248 samples (125 ms, 32 periods of the mode, named "one period ..., doubled") against
    50 ms holds, and the shaped reference missed every level by 8.5 µm. A level is reached where
    the window no longer reaches either move: for a window no longer than half the hold, on at
    least a quarter of the hold."""
    r = np.repeat(STAIR, HOLD)[None, :]
    s = shape_reference(_jumping_drive, r, _stair_amp(), T_STAIR, first_mode=MODE)
    assert 0 < s.window_samples <= HOLD // 2
    for k in range(1, STAIR.size):
        hold = s.reference[0, k * HOLD:(k + 1) * HOLD]
        assert np.sum(np.abs(hold - STAIR[k]) < 1e-9 * 80) >= HOLD // 4, k
    text = s.notes[0]
    assert f"smoothed over {s.window_samples * T_STAIR * 1e3:.3g} ms" in text
    assert "left to the slew limit" in text and "0.0500-0.0500 s" in text   # the jump, named
    assert "doubled" not in text


def test_a_doubled_window_names_its_periods_of_the_mode():
    """Steps the slew rate alone limits: a 40 µm step at 3.6 V/µm is 144 V, and a Hann S-curve of
    L samples steps at most about 2 / L of it per sample, so 1.5 V per sample needs L >= 192:
    the 39-sample period of the 258.5 Hz mode doubled three times (312 samples, 8 periods)."""
    r = np.repeat([[0.0, 40.0, 0.0]], 2000, axis=1)
    s = shape_reference(lambda x: 3.6 * np.asarray(x), r, _stair_amp(), T_STAIR, first_mode=MODE)
    assert s.window_samples == 312
    assert float(limit_excess(_stair_amp(), s.inputs, T_STAIR).max()) == 0.0
    assert ("smoothed over 31.2 ms (8 periods of the first mode, damped frequency 258.5 Hz: one "
            "period, doubled 3 times") in s.notes[0]


def test_holds_shorter_than_the_smoothing_are_named():
    """3 ms holds under a 3.9 ms window (one period of the 258.5 Hz mode): the shaped reference
    cannot reach their levels, and the note says so with both durations."""
    levels = np.r_[0.0, 10.0, 20.0, 30.0, 20.0, 10.0]
    r = np.r_[np.zeros(200), np.repeat(levels[1:], 30), np.full(200, 10.0)][None, :]
    s = shape_reference(lambda x: 1.0 * np.asarray(x), r, _stair_amp(), T_STAIR, first_mode=MODE)
    hold = [n for n in s.notes if "smoothing window" in n]
    assert len(hold) == 1
    assert "holds of 3 ms" in hold[0] and "3.9 ms smoothing window" in hold[0]
    miss = float(hold[0].split("up to ")[1].split(" µm")[0])
    ends = 200 + 30 * np.arange(1, 5) - 1                          # the last sample of each hold
    assert miss == pytest.approx(float(np.max(np.abs(s.reference[0, ends] - r[0, ends]))), rel=1e-2)
    assert miss > 1.0


def test_a_scan_that_moves_every_sample_has_no_holds():
    # a raster's fast axis: every sample moves, one sample between two moves is no hold ("holds
    # of 0.05 ms (at ..., and 1208 more) are shorter than the 3.5 ms smoothing window")
    t = np.arange(4000) * 5e-5
    tri = 20 * (2 * np.abs((20 * t) % 1 - 0.5) * 2 - 1)                # 20 Hz triangle
    shaped = tri + 0.5 * np.sin(2 * np.pi * 20 * t)                     # turns rounded
    assert hold_note(tri[None], shaped[None], 70, 5e-5, ["x"]) == []
    # a staircase's 2 ms holds under a 3.5 ms window are named
    stair = np.repeat(np.arange(100.0), 40)[None]
    assert len(hold_note(stair, stair + 0.1, 70, 5e-5, ["x"])) == 1


def test_the_fade_ins_flat_tail_is_no_hold():
    """A staircase held 50 ms per level, faded in over its first 50 ms: the fade's last
    samples move by less than rounding before the first step, and were named "holds of
    0.15 ms ... shorter than the smoothing window" although every hold is 50 ms. Holds are
    judged after the fade-in; the true holds (50 ms, longer than the window) are not named."""
    from hammerstein.compensation.drive import hardware_fade
    from hammerstein.compensation.shaping import shape_reference
    from hammerstein.models.amplifier import amplifier_from_table
    F = 1000
    levels = np.repeat([0.0, 10.0, 25.0, 15.0, 5.0], 1000)[None, :]     # 50 ms at 20 kHz
    faded = hardware_fade(levels, F, rest=np.array([-3.0]))
    amp = amplifier_from_table({"range": [-10.0, 10.0], "slew_rate": 2000.0}, ["u"])

    def holds(fade_samples):
        s = shape_reference(lambda x: 0.4 * x, faded, amp, 5e-5, first_mode=420.0,
                            names=["x"], fade_samples=fade_samples)
        assert s.changed                   # the steps were shaped (a 2000 V/s slew)
        return [n for n in s.notes if "holds of" in n]
    assert holds(0) and "holds of 0.15 ms" in holds(0)[0]     # the fade's tail, as before
    assert holds(F) == []
