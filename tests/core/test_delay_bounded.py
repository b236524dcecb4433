"""The delay estimate's work is bounded on long records.

A tester's 5-10 minute multisines at 20 kHz (6 M samples) made `identify --delay auto`
ask for 4 TiB: its Welch segments grew with the record (2^20 samples), and the search's
phase table is the delay grid (a quarter of a segment each way, in quarter samples) times
the frequency lines. Here 300 000 samples (segments of 2^16 before: a 34 GB table).
"""

import tracemalloc

import numpy as np
import pytest
import scipy.signal

from hammerstein.models._lti_delay import MAX_NPERSEG, estimate_measurement_delay, frf_h1


@pytest.mark.slow
def test_a_long_record_gives_its_delay_within_a_bounded_memory():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((1, 300_000))
    y = np.roll(scipy.signal.lfilter([0.0, 0.1], [1.0, -0.9], u), 3)   # ZOH lag, 3 samples
    tracemalloc.start()
    try:
        found = estimate_measurement_delay([u], [y], 5e-5)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert found.delay == 3 and found.problem is None
    assert peak < 100 * 2**20, peak / 2**20


def test_the_default_segment_is_capped():
    u = np.random.default_rng(1).standard_normal((1, 8 * MAX_NPERSEG))
    f, _ = frf_h1([u], [u], 1e-4)
    assert f.size == MAX_NPERSEG // 2            # one-sided lines without 0


def test_identify_names_a_record_over_the_limit_before_reading_any(tmp_path, monkeypatch,
                                                                    capsys):
    """With --delay auto the dynamics records were read and the delay estimated first: the
    tester's hysteresis record over the limit was named after 36 s (or never, the estimate
    running out of memory)."""
    from hammerstein.cli.main import main
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", "4000")
    big, small = tmp_path / "h.csv", tmp_path / "m.csv"
    big.write_text("t,ux,x\n" + "".join(f"{k * 1e-4:.4f},0,0\n" for k in range(600)))
    # the dynamics record is read first for the delay: a bad cell there was named first
    small.write_text("t,ux,x\n" + "".join(f"{k * 1e-4:.4f},0,0\n" for k in range(20))
                     + "0.0020,oops,0\n")
    code = main(["identify", str(big), "--inputs", "ux", "--outputs", "x", "--time", "t",
                 "--dynamics", "--dynamics-records", str(small), "--out",
                 str(tmp_path / "p.toml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1
    assert f"{big}: " in err[0] and "larger than the limit" in err[0]
