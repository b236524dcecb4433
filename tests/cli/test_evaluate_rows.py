"""``evaluate``'s time series is written block by block: the same bytes, a bounded memory.

``timeseries-measured.csv`` had been formatted whole (a Python float per value and
the whole text at once: 1.2 GB for 3e6 samples of 8 columns); ``write_rows``
writes 20 000 rows at a time.
"""

import io

import numpy as np

from hammerstein.cli.evaluate import write_rows
from memory_trace import traced_write


def _whole(head, cols):
    """The formatting before: one ``%.9g`` format per row over the whole table."""
    data = np.column_stack(cols)
    row = ",".join(["%.9g"] * data.shape[1])
    body = "\n".join(row % tuple(values) for values in data.tolist())
    return (",".join(head) + "\n" + body + "\n").encode("utf-8")


def test_same_bytes_across_blocks():
    rng = np.random.default_rng(3)
    n = 45_001                       # two full blocks and one row
    cols = [np.arange(n) * 5e-5] + [rng.standard_normal(n) * 10.0 ** k for k in (-3, 0, 4)]
    cols[1][7] = np.nan
    head = ["time_s", "x_ref_um", "x_um", "ux_V"]
    fh = io.BytesIO()
    write_rows(fh, head, cols)
    assert fh.getvalue() == _whole(head, cols)


def test_memory_is_a_blocks():
    """200 000 rows x 8 columns (about 15 MB of text): under 12 MB traced (a block: its
    floats and text; the whole table took over 100 MB)."""
    n = 200_000
    cols = [np.arange(n) * 5e-5] + [np.sin(np.arange(n) * (k + 1) * 1e-3) for k in range(7)]
    _, size, peak = traced_write(lambda sink: write_rows(sink, [f"c{k}" for k in range(8)], cols))
    assert size > 10_000_000
    assert peak < 12_000_000, peak
