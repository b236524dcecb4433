"""A table of numbers is read as floats: the same values bit for bit, a bounded memory.

``signal_table`` reads a table whose every cell is a finite number as float64
columns (``_float_frame``), 8 bytes a cell, where it had held every cell as a
Python string (about 60 bytes each, 1.5 GB for a record of 3e6 rows and 5
columns). The values ``numeric_column`` returns must not change: they are
compared bit for bit with the text reading they replaced.
"""

import io
import tracemalloc

import numpy as np
import pandas as pd
import pytest

from hammerstein.io.datafiles import numeric_column, signal_table


def _old_values(text, col):
    """The reading before: every cell a string, ``pd.to_numeric`` of the stripped cell."""
    frame = pd.read_csv(io.StringIO(text), dtype=str, skipinitialspace=True,
                        keep_default_na=False)
    return pd.to_numeric(frame[col].astype(str).str.strip(), errors="coerce").to_numpy(float)


@pytest.mark.parametrize("fmt", ["%.17g", "%.9g", "%.3e", "%.12f", "%d"])
def test_same_floats_bit_for_bit(fmt):
    rng = np.random.default_rng(7)
    v = rng.standard_normal(20_000) * 10.0 ** rng.integers(-40, 40, 20_000)
    if fmt == "%d":
        v = np.round(v.clip(-1e15, 1e15))
    t = np.arange(v.size) * 5e-5
    text = "t,x\n" + "\n".join(f"{float(a)!r}, {fmt % b}" for a, b in zip(t, v)) + "\n"
    table = signal_table(text.encode(), "rec.csv")
    assert all(dtype == np.float64 for dtype in table.frame.dtypes)
    for col in ("t", "x"):
        new = numeric_column(table, col, unit="s" if col == "t" else "µm")
        assert np.array_equal(new.view(np.int64), _old_values(text, col).view(np.int64))


@pytest.mark.parametrize("cell", ["True", "nan", "inf", "", "1.5.2", "abc", "1e400"])
def test_other_cells_still_read_as_text(cell):
    """Anything but finite numbers keeps the reading cell by cell (and its messages)."""
    text = f"t,x\n0,1\n5e-05,{cell}\n1e-4,2\n"
    table = signal_table(text.encode(), "rec.csv")
    assert table.frame["x"].dtype != np.float64


def test_reading_a_long_record_is_bounded():
    """200 000 rows x 5 columns (15 MB of text): the reading peaks below 6 times the text.

    Reading every cell as a string peaked at about 15 times the text (the
    strings, 4 bytes a character in ``io.StringIO``).
    """
    n = 200_000
    t = np.arange(n) * 5e-5
    body = np.column_stack([t, np.sin(t), np.cos(t), np.sin(2 * t), np.cos(2 * t)])
    buf = io.StringIO()
    np.savetxt(buf, body, delimiter=",", fmt="%.17g", header="t,ux,uy,x,y", comments="")
    raw = buf.getvalue().encode()
    tracemalloc.start()
    try:
        table = signal_table(raw, "long.csv")
        x = numeric_column(table, "x")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert x.shape == (n,)
    assert peak < 6 * len(raw), (peak / len(raw))
