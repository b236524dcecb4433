"""Tables shared by the reports: long metrics, GitHub markdown tables, time-series CSV files."""

from __future__ import annotations

import csv
import io
import os
import re

import numpy as np
import pandas as pd

from hammerstein.core.files import safe_write

__all__ = ["COLUMNS", "metrics_frame", "markdown_table", "write_signals_csv", "CSV_CHUNK_ROWS"]

#: Rows formatted per string operation by :func:`write_signals_csv`.
CSV_CHUNK_ROWS = 20000
_NAN_FIELD = re.compile(r"(?<![^,\n])nan(?![^,\r\n])")

#: Columns of ``metrics.csv``.
COLUMNS = ["case", "channel", "metric", "value", "unit"]


def metrics_frame(results):
    """Long-format metrics of all cases.

    Parameters
    ----------
    results : list
        Results with ``name`` and ``metrics`` (rows ``{channel, metric,
        value, unit}``), e.g. :class:`hammerstein.scenario.execute.CaseResult`.

    Returns
    -------
    pandas.DataFrame
        Columns ``case, channel, metric, value, unit``.
    """
    rows = [{"case": r.name, **row} for r in results for row in r.metrics]
    return pd.DataFrame(rows, columns=COLUMNS)


def markdown_table(frame, floatfmt="{:.4g}"):
    """A pandas DataFrame as a GitHub markdown table (no extra dependency).

    Parameters
    ----------
    frame : pandas.DataFrame
        The table; its index is not written.
    floatfmt : str
        ``str.format`` pattern of the float cells; NaN cells are left empty.

    Returns
    -------
    str
        Header, separator and one line per row, joined by newlines (no
        trailing newline).
    """
    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return "" if np.isnan(v) else floatfmt.format(v)
        return str(v)
    head = "| " + " | ".join(map(str, frame.columns)) + " |"
    sep = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([head, sep, *body])


def write_signals_csv(path, columns, float_format="%.6g"):
    """Write float columns as CSV, byte for byte what ``DataFrame.to_csv`` writes, faster.

    ``pandas.DataFrame(columns).to_csv(path, index=False,
    float_format=float_format)`` formats every value with a Python call
    (about 1 µs a value: 0.35 s for the time series of the paper run); this
    formats a block of rows with one ``%`` operation on a row template. NaN
    is written as an empty field, as pandas does (``na_rep=""``). Columns
    that are not 1-D float arrays of one length, or a single column, are
    written by pandas itself.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file (written, or overwritten, as ``to_csv`` does).
    columns : dict of str to array_like
        Column name -> values, shape (n_rows,) each, in column order.
    float_format : str
        ``%``-format of a value, e.g. ``"%.6g"``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "t.csv"
    >>> write_signals_csv(path, {"time_s": np.array([0.0, 5e-05]),
    ...                          "x_um": np.array([1.0 / 3.0, np.nan])})
    >>> print(path.read_text(), end="")
    time_s,x_um
    0,0.333333
    5e-05,
    """
    names = [str(k) for k in columns]
    arrays = [np.asarray(v) for v in columns.values()]
    n = arrays[0].shape[0] if arrays and arrays[0].ndim == 1 else -1
    if (len(arrays) < 2 or n < 0 or any(a.ndim != 1 or a.shape[0] != n or a.dtype != np.float64
                                        for a in arrays)):
        safe_write(path, pd.DataFrame(columns).to_csv(index=False, float_format=float_format),
                   "CSV file")
        return
    sep = os.linesep
    head = io.StringIO()
    csv.writer(head, lineterminator=sep).writerow(names)   # quoted as pandas quotes them
    table = np.column_stack(arrays)
    row = ",".join([float_format] * len(arrays)) + sep

    def write(fh):
        fh.write(head.getvalue().encode("utf-8"))
        for start in range(0, n, CSV_CHUNK_ROWS):
            block = table[start:start + CSV_CHUNK_ROWS]
            text = (row * block.shape[0]) % tuple(block.ravel().tolist())
            if np.isnan(block).any():
                text = _NAN_FIELD.sub("", text)
            fh.write(text.encode("utf-8"))
    safe_write(path, write, "CSV file")
