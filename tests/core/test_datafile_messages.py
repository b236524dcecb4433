"""Messages of both table readers (``identify``'s records, the signal files of ``evaluate``,
``compensate`` and ``learn``) on files a tester's loggers wrote.

Expectations written from the files themselves: a repeated or falling time stamp is shown
with the digits that tell the two stamps apart (the shortest text that reads back as the
same float); a file cut in the middle of its last line (a logger killed while writing) is
said to end there; a gzip-compressed CSV is named as such.
"""

import gzip

import numpy as np
import pytest

from hammerstein.compensation.drive_files import read_signals
from hammerstein.io.datafiles import DataFileError, read_records

T = 5e-5
N = 50


def _text(t=None):
    t = np.arange(N) * T if t is None else t
    u = np.sin(2 * np.pi * 200 * np.arange(N) * T)
    rows = ["t,ux,uy,x,y"] + [f"{float(a)!r},{b:.6f},0,{0.9 * b:.6f},{0.1 * b:.6f}"
                              for a, b in zip(t, u)]
    return "\n".join(rows) + "\n"


def _identify_read(path):
    return read_records(path, "ux,uy", "x,y", time="t")


def _evaluate_read(path):
    return read_signals(path, ["x", "y"], time="t", what="--measured")


READERS = {"identify": _identify_read, "evaluate": _evaluate_read}


@pytest.mark.parametrize("reader", READERS)
def test_a_time_stamp_that_does_not_increase_is_shown_exactly(reader, tmp_path):
    """A tester's log stamped 100.00000000000001 s then 100 s: the message said "100 s then
    100 s". Both stamps are now printed as their shortest round-trip text."""
    t = 99.9 + np.arange(N) * T
    t[10], t[11] = 100.00000000000001, 100.0
    path = tmp_path / "rec.csv"
    path.write_text(_text(t))
    with pytest.raises(DataFileError) as info:
        READERS[reader](path)
    assert "at data row 12 (100.00000000000001 s then 100.0 s)" in str(info.value)


@pytest.mark.parametrize("reader", READERS)
def test_a_last_line_cut_short_is_said(reader, tmp_path):
    """A logger killed mid-write: the last line holds 2 of 5 fields and no line end."""
    full = _text()
    cut = full[:full.rstrip("\n").rfind("\n") + 1] + "0.00245,0.12"
    assert cut.count("\n") == N and cut.rsplit("\n", 1)[1].count(",") == 1
    path = tmp_path / "rec.csv"
    path.write_text(cut)
    with pytest.raises(DataFileError) as info:
        READERS[reader](path)
    msg = str(info.value)
    assert f"data row {N}" in msg and "\n" not in msg
    assert "the file ends in the middle of that line" in msg and "cut short" in msg
    # the same short row with a line end and a complete row after it: not said to be cut
    path.write_text(cut + "\n" + full.rstrip("\n").rsplit("\n", 1)[1] + "\n")
    with pytest.raises(DataFileError) as info:
        READERS[reader](path)
    assert f"data row {N}" in str(info.value) and "cut short" not in str(info.value)


@pytest.mark.parametrize("reader", READERS)
def test_a_gzip_compressed_csv_is_named(reader, tmp_path):
    path = tmp_path / "rec.csv.gz"
    path.write_bytes(gzip.compress(_text().encode()))
    with pytest.raises(DataFileError) as info:
        READERS[reader](path)
    msg = str(info.value)
    assert "gzip-compressed" in msg and "decompress it first" in msg and "binary" not in msg


def test_a_large_file_s_time_column_is_checked_before_the_table_is_parsed(tmp_path,
                                                                          monkeypatch):
    """A tester's 10-minute measurement was refused for its time column after 75 s and 8 GB
    (the whole table parsed as text first). Above ``TIME_PRECHECK_BYTES`` the time column is
    parsed alone first: the table parse (here made to fail loudly) is never reached, and the
    message is the full reader's. A file the quick parse reads as fine is read as before."""
    import hammerstein.compensation.drive_files as drive_files

    def no_table(*args, **kwargs):
        raise AssertionError("the whole table was parsed before the time column was checked")
    t = np.arange(N) * T
    t[30] = t[29]
    path = tmp_path / "rec.csv"
    path.write_text("# logger 7\n" + _text(t))
    monkeypatch.setattr(drive_files, "TIME_PRECHECK_BYTES", 0)
    monkeypatch.setattr(drive_files, "signal_table", no_table)
    with pytest.raises(DataFileError) as info:
        _evaluate_read(path)
    assert (f"the time column 't' is not strictly increasing at data row 31 "
            f"({float(t[29])!r} s then {float(t[29])!r} s)") in str(info.value)
    monkeypatch.undo()
    monkeypatch.setattr(drive_files, "TIME_PRECHECK_BYTES", 0)
    path.write_text("# logger 7\n" + _text())
    got = _evaluate_read(path)
    np.testing.assert_array_equal(got[0], np.arange(N) * T)
