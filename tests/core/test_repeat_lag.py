"""A periodic reference whose period is not a whole number of samples is continued exactly.

150 Hz at 50 kHz is 333.3 samples: the record repeats 3 periods (1000 samples)
earlier, not 333. The ZPETC preview and the stable inversion read that
continuation past the record's end; the drive of a record cut at sample N
must then equal the first N samples of the drive of a longer record (the
preview sees the true future), where a quadratic extrapolation left the last
samples chattering.
"""

import warnings

import numpy as np
import pytest

from hammerstein.compensation._repeat import MAX_PERIODS, kept_samples, record_period, repeat_lag
from hammerstein.compensation.drive import (DriveStream, _compensate, _periodic_tail, drive_signal,
                                            hardware_drive)
from hammerstein.compensation.hammerstein_compensator import (HammersteinCompensator, continuation,
                                                              continuations)

T = 5e-5          # 20 kHz: 150 Hz is 133.3 samples, repeating after 3 periods (400 samples)


def circle(n, f=150.0, R=25.0, growth=0.0):
    t = np.arange(n) * T
    a = R * (1.0 + growth * t)
    return a * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


@pytest.mark.parametrize("f, P, lag", [(150.0, 133, 400),       # 400/3 samples
                                       (100.0, 200, 200),       # a whole number: one period
                                       (70.0, 286, 2000),       # 2000/7
                                       (130.0, 154, 2000)])     # 2000/13
def test_the_lag_is_the_first_whole_multiple_of_the_period(f, P, lag):
    assert round(1.0 / (f * T)) == P
    r = circle(6000, f)
    assert repeat_lag(r, P, 5) == lag
    # the continuation is the sampled circle itself, past the end
    np.testing.assert_allclose(continuation(r, 12, P), circle(6012, f)[:, 6000:], rtol=0,
                               atol=1e-9)


def test_no_lag_without_repetition():
    spiral = circle(6000, growth=5.0)
    assert repeat_lag(spiral, 133, 5) is None
    assert repeat_lag(circle(6000), None, 5) is None
    assert repeat_lag(circle(300), 133, 5) is None        # less than the 3 periods it needs
    # continued by the quadratic through the last three samples, as before
    k = np.arange(1, 4)
    a, b, c = spiral[:, -3], spiral[:, -2], spiral[:, -1]
    quad = c[:, None] + np.outer(c - b, k) + np.outer((c - 2 * b + a) / 2.0, k * (k + 1))
    np.testing.assert_allclose(continuation(spiral, 3, 133), quad, rtol=1e-12)


def test_several_records_continue_as_each_alone():
    recs = [circle(6000), circle(5000, 70.0), circle(6000, growth=5.0), circle(300)]
    periods = [133, 286, 133, 133]
    for one, many in zip([continuation(r, 7, p) for r, p in zip(recs, periods)],
                         continuations(recs, 7, periods)):
        np.testing.assert_array_equal(one, many)


def test_a_stream_keeps_enough_for_the_longest_lag():
    assert kept_samples(133) >= MAX_PERIODS * 133.5
    assert kept_samples(None) == 3


@pytest.mark.parametrize("inversion", ["zpetc", "stable"])
def test_a_cut_record_drives_as_the_longer_one(preset_plant, inversion):
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics,
                                  inversion=inversion)
    n, extra = 4000 + 57, 2400          # cut 57 samples past a whole number of periods
    cut = drive_signal(comp, circle(n), T, 133, fade_samples=400).inputs
    longer = drive_signal(comp, circle(n + extra), T, 133, fade_samples=400).inputs
    scale = np.abs(longer).max()
    np.testing.assert_allclose(cut, longer[:, :n], rtol=0, atol=1e-9 * scale)


def test_a_cut_record_streams_as_the_longer_one(preset_plant):
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    n = 4057
    stream = DriveStream(comp, 400, 133)
    parts = [stream.push(circle(n)[:, k:k + 250]) for k in range(0, n, 250)] + [stream.finish()]
    longer = drive_signal(comp, circle(n + 2400), T, 133, fade_samples=400).inputs
    np.testing.assert_allclose(np.concatenate(parts, axis=1), longer[:, :n], rtol=0,
                               atol=1e-9 * np.abs(longer).max())


@pytest.mark.parametrize("inversion", ["zpetc", "stable"])
def test_a_record_corrected_early_is_continued_by_its_own_periods(preset_plant, inversion):
    # a start-up corrected (or shaped) over most of the record hides every lag repeat_lag
    # tests (133..4256 samples here): the record as written no longer repeats, but it ends as
    # the periodic reference does, whose periods follow its end
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics,
                                  inversion=inversion)
    n = 4057
    r = circle(n)
    ref = r.copy()
    ref[:, :3700] *= np.sin(np.pi * np.arange(3700) / 7400) ** 2     # from rest, early
    assert repeat_lag(ref, 133, 1) is None and repeat_lag(r, 133, 1) == 400
    longer = _compensate(comp, np.concatenate([ref, circle(n + 2400)[:, n:]], axis=1), 133,
                         0)[0][:, :n]
    ext = _periodic_tail(ref, r, 133, comp.preview_samples or 1)
    got = _compensate(comp, ext, 133, 0)[0][:, :n]
    scale = np.abs(longer).max()
    np.testing.assert_allclose(got, longer, rtol=0, atol=1e-9 * scale)
    # continued by the quadratic extrapolation instead, the last samples were off
    with warnings.catch_warnings():        # the extrapolation leaves the model's range
        warnings.simplefilter("ignore")
        old = _compensate(comp, ref, 133, 0)[0]
    assert np.abs(old - longer)[:, -20:].max() > 1e-3 * scale
    # nothing to add where the record repeats, or does not end as the reference does
    assert _periodic_tail(r, r, 133, 5) is r
    assert _periodic_tail(0.9 * r, r, 133, 5).shape == r.shape


def _spiral(n, turns=8.0, R=20.0):
    """One constant-velocity spiral from the centre out, ``n`` samples [µm]."""
    s = np.sqrt(np.arange(n) / n)
    return R * s * np.vstack([np.cos(2 * np.pi * turns * s), np.sin(2 * np.pi * turns * s)])


@pytest.mark.parametrize("record, period", [
    (circle(6000), 400),                                   # 150 Hz at 20 kHz: 3 periods
    (np.tile(_spiral(1500), 4), 1500),                     # a pattern held four times
    (np.tile(_spiral(1500), 4)[:, :5000], 1500),           # cut within its fourth
    (_spiral(6000), None),                                 # once: no repeat
    (circle(6000, growth=5.0), None),                      # a growing circle
    (np.tile(_spiral(4000), 1)[:, :4000], None),
    (np.hstack([np.tile(_spiral(500), 3), np.full((2, 400), 3.0)]), None),   # ends on a hold
    (np.hstack([np.full((2, 400), 3.0), np.tile(_spiral(500), 3)]), None),   # repeats at its end only
])
def test_the_period_of_a_record_is_where_the_whole_record_repeats(record, period):
    assert record_period(record) == period
    if period is not None:       # independently: the record equals itself one lag later
        np.testing.assert_allclose(record[:, period:], record[:, :-period], rtol=0, atol=1e-9)


def test_a_file_pattern_held_several_times_ends_without_a_jump(preset_plant):
    # a pattern file without --period: its end was continued by a quadratic extrapolation,
    # which a spiral's fast turns near its centre throw volts off (2 V in one sample, the
    # settled drive 0.23 V); continued by its own repeat, its last steps are the settled ones
    comp = HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics)
    pattern = _spiral(1500, turns=6.0, R=20.0)
    ref = np.tile(pattern, 3)
    drive = hardware_drive(comp, ref, T).inputs
    steps = np.abs(np.diff(drive, axis=1))
    settled = steps[:, 1600:-200].max(axis=1)
    assert np.all(steps[:, -200:].max(axis=1) <= settled * (1 + 1e-6))
    # the same drive as for the record continued by a fourth repeat, cut
    longer = hardware_drive(comp, np.tile(pattern, 4), T).inputs[:, :ref.shape[1]]
    np.testing.assert_allclose(drive[:, :-1], longer[:, :ref.shape[1] - 1], rtol=0,
                               atol=1e-9 * np.abs(longer).max())
