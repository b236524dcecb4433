"""Time stamps rounded by a logger (float32, or printed to few digits) are a uniform record.

A 25 kHz logger that stamps in single precision writes ``np.float32(k * 4e-5)``:
past 8 s its steps vary by more than 1 % of the period, but every stamp stays
within half a float32 unit of ``k T``. Such a record is read at T = 4e-5 s
exactly, its samples as they are; a record with a missing sample is not.
"""

import numpy as np
import pandas as pd
import pytest

from hammerstein.compensation.drive_files import read_signals
from hammerstein.io.datafiles import DataFileError, read_record, uniform_period

T = 4e-5
N = 250_000                         # 10 s: float32 half-units up to 4.8e-7 s, 1.2 % of T


def _stamped(n=N, gap=None, dtype=np.float32):
    k = np.arange(n, dtype=float)
    if gap is not None:
        k[gap:] += 1.0             # one sample lost
    t = (k * T).astype(dtype).astype(float)
    u = 10 * np.sin(2 * np.pi * 3.0 * k * T)
    return t, u, 2.5 * u + 12.5


def _csv(path, t, u, z, time="t"):
    pd.DataFrame({time: t, "u": u, "z": z}).to_csv(path, index=False, float_format="%.9g")
    return path


def test_float32_stamps_are_off_by_more_than_a_percent_of_a_step():
    t, _, _ = _stamped()
    d = np.diff(t)
    assert np.max(np.abs(d - T)) > 0.01 * T                 # the old step test refused them
    assert np.max(np.abs(t - np.arange(N) * T)) <= 2.0 ** -24 * t[-1]


def test_the_period_is_the_grid_not_the_median_step():
    t, _, _ = _stamped()
    Tf, off, tol = uniform_period(t)
    assert Tf == T and np.max(np.abs(off)) <= tol
    assert abs(np.median(np.diff(t)) - T) > 1e-9          # the median step is biased


def test_a_record_with_float32_stamps_is_read_at_its_period(tmp_path):
    t, u, z = _stamped()
    rec = read_record(_csv(tmp_path / "r.csv", t, u, z), "u", "z", time="t")
    assert rec.sampling_period == T
    np.testing.assert_allclose(rec.u, u, rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("period", [None, T])
def test_signals_with_float32_stamps_are_taken_as_they_are(tmp_path, period):
    t, u, z = _stamped()
    path = _csv(tmp_path / "m.csv", t, u, z)
    grid, vals, Tf = read_signals(path, ["u", "z"], "t", None, period, "--measured")
    assert Tf == T and grid.size == N
    np.testing.assert_array_equal(grid, np.arange(N) * T)
    # the file's samples, not an interpolation between stamps off their sampling times
    np.testing.assert_allclose(vals, np.vstack([u, z]), rtol=0, atol=1e-8 * 40)


def test_a_lost_sample_is_still_refused(tmp_path):
    t, u, z = _stamped(20_000, gap=9_000, dtype=float)
    path = _csv(tmp_path / "g.csv", t, u, z, time="time_s")
    with pytest.raises(DataFileError, match=r"time column 'time_s' has 1 gap \(1 sample "
                                            r"missing\), the first at data row 9001"):
        read_record(path, "u", "z", time="time_s")
    with pytest.raises(DataFileError, match=r"has 1 gap \(\d samples? missing\)"):
        read_signals(path, ["u", "z"], "time_s", None, None, "--measured")


# A record starting far from 0 (t0 = 1234.5 s) was allowed single precision's rounding there
# (74 µs), which hid a dropped sample at 10 kHz; its stamps, written to the µs, show it.
@pytest.mark.parametrize("period, lost", [(1e-4, 1), (2e-5, 2)])
def test_a_lost_sample_far_from_zero_is_refused(tmp_path, period, lost):
    k = np.arange(100_000, dtype=float)
    k[50_000:] += lost
    t = 1234.5 + k * period
    u = np.sin(2 * np.pi * k * period)
    path = tmp_path / "g.csv"
    pd.DataFrame({"t": t, "u": u, "z": 2 * u}).to_csv(path, index=False, float_format="%.10g")
    with pytest.raises(DataFileError, match=rf"time column 't' has 1 gap \({lost} samples? "
                                            rf"missing\), the first at data row 50001"):
        read_record(path, "u", "z", time="t")
    with pytest.raises(DataFileError, match=r"has 1 gap \(\d samples? missing\)"):
        read_signals(path, ["u", "z"], "t", None, None, "--measured")


def test_uniform_stamps_far_from_zero_are_read(tmp_path):
    t = 1234.5 + np.arange(100_000) * 1e-4
    u = np.sin(2 * np.pi * t)
    path = tmp_path / "r.csv"
    pd.DataFrame({"t": t, "u": u, "z": 2 * u}).to_csv(path, index=False, float_format="%.10g")
    rec = read_record(path, "u", "z", time="t")
    assert rec.sampling_period == 1e-4 and rec.n_samples == 100_000


def test_float32_stamps_far_from_zero_keep_their_allowance():
    # 1 kHz float32 stamps from 1000 s: steps vary by a unit of 6.1e-5 s, 6 % of T
    t = (1000.0 + np.arange(20_000) * 1e-3).astype(np.float32).astype(float)
    Tf, off, tol = uniform_period(t)
    assert Tf == pytest.approx(1e-3) and np.max(np.abs(off)) <= tol


# A gap's message named an arbitrary gap (the last of 20), did not count them and gave an
# inferred period: it names the first, counts them and says what to do.
def test_gaps_are_counted_and_the_first_is_named(tmp_path):
    n = 20_000
    k = np.arange(n, dtype=float)
    for g in (5603, 9000, 15000, 19000):
        k[g:] += 1
    t = k * 1e-4
    path = tmp_path / "g.csv"
    pd.DataFrame({"t": t, "u": np.sin(k), "z": np.cos(k)}).to_csv(path, index=False,
                                                                  float_format="%.10g")
    words = ("has 4 gaps (4 samples missing), the first at data row 5604 (t = 0.5604 s, a step "
             "of 0.0002 s, 2 periods of 0.0001 s)")
    with pytest.raises(DataFileError) as err:
        read_record(path, "u", "z", time="t")
    assert f"{path}: time column 't' {words}: fill or resample the gaps" in str(err.value)
    assert "--sampling-period" in str(err.value)
    with pytest.raises(DataFileError) as err:
        read_signals(path, ["u", "z"], "t", None, None, "--measured")
    assert f"--measured: {path}: the time column 't' {words}; expected one sampling period" \
        in str(err.value)
