"""Reading measured input/output records from delimited text files (pandas).

Real files come with or without a header, with comma, semicolon, tab or
space separators, sometimes with an empty leading index column (as the
shipped ``data/piezo-stack-150V-1Hz.csv``) or a row of units under the
header (``time,ux,x`` then ``s,V,µm``, as data-acquisition programs write
them: skipped). :func:`read_record` handles these
and turns every problem into a one-line :class:`DataFileError` that names the
file and what is wrong.

Length: the two table readers (records of ``identify``, signal files of the
other commands) share their checks and messages (encodings, separators,
units rows, ragged and cut-short rows, compressed files); kept together so
that both say the same words.
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.core.files import FileLimitError, bounded_read_bytes, escape
from hammerstein.core.numbers import MAX_MAGNITUDE
from hammerstein.exceptions import DataFileError
from hammerstein.io.table_checks import check_size, decimal_comma_hint, name_unit, unit_problem
from hammerstein.io.time_grid import gap_text, step_gaps, uniform_period
from hammerstein.io.table_checks import CELLS_ENV, max_cells  # noqa: F401 (their old home)

__all__ = ["DataFileError", "Record", "MultiRecord", "read_record", "read_records", "bundled_data",
           "decode_table", "signal_table", "numeric_column", "uniform_period"]

#: Fewest samples accepted in a record.
MIN_SAMPLES = 10


@dataclass(frozen=True)
class Record:
    """One measured single-input single-output record.

    Parameters
    ----------
    timepts : numpy.ndarray, shape (n_samples,)
        Time [s], uniform and increasing.
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    y : numpy.ndarray, shape (n_samples,)
        Output [µm].
    input_name, output_name : str
        Column names (``"column 2"`` style for files without a header).
    sampling_period : float
        Sampling period [s].
    source : str
        File the record was read from.
    """

    timepts: np.ndarray
    u: np.ndarray
    y: np.ndarray
    input_name: str
    output_name: str
    sampling_period: float
    source: str = ""

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return self.u.size


@dataclass(frozen=True)
class MultiRecord:
    """One measured multi-input multi-output record.

    Parameters
    ----------
    timepts : numpy.ndarray, shape (n_samples,)
        Time [s], uniform and increasing.
    u : numpy.ndarray, shape (m, n_samples)
        Inputs (in the input unit, e.g. V).
    y : numpy.ndarray, shape (p, n_samples)
        Outputs (in the output unit, e.g. µm).
    input_names, output_names : tuple of str
        Column names (``"column 2"`` style for files without a header).
    sampling_period : float
        Sampling period [s].
    source : str
        File the record was read from.
    """

    timepts: np.ndarray
    u: np.ndarray
    y: np.ndarray
    input_names: tuple
    output_names: tuple
    sampling_period: float
    source: str = ""

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return self.u.shape[1]

    @classmethod
    def from_record(cls, record):
        """The (1, n_samples) form of a single-input single-output :class:`Record`."""
        return cls(record.timepts, record.u[None, :], record.y[None, :], (record.input_name,),
                   (record.output_name,), record.sampling_period, record.source)


def column_list(text):
    """Column keys from ``"u1,u2"`` / ``"0,2"`` / a list: names or 0-based indices.

    Parameters
    ----------
    text : str or int or list or tuple
        Comma-separated names or indices (a name that is an integer, possibly
        negative, becomes an index), a single index, or a list/tuple of keys
        (returned as a list unchanged).

    Returns
    -------
    list of str or int
    """
    if isinstance(text, (list, tuple)):
        return list(text)
    if isinstance(text, (int, np.integer)):
        return [int(text)]
    parts = [c.strip() for c in str(text).split(",")]
    return [int(c) if c.lstrip("-").isdigit() else c for c in parts]


def bundled_data(name="piezo-stack-150V-1Hz.csv"):
    """Path of a data file shipped in ``hammerstein/data``.

    Parameters
    ----------
    name : str
        File name.

    Returns
    -------
    pathlib.Path
        Its path (not checked for existence).
    """
    return Path(__file__).resolve().parents[1] / "data" / name


def _is_number(text):
    try:
        float(text)
    except (TypeError, ValueError):
        return False
    return True


def _sniff_separator(sample):
    first = next((ln for ln in sample.splitlines() if ln.strip()), "")
    for sep in (",", ";", "\t"):
        if sep in first:
            return sep
    return r"\s+"


_COMMENT = re.compile(rb"(?m)^[ \t]*#[^\n]*(\n|$)")
_BLANK = re.compile(rb"(?m)^[ \t\r]*\n")
#: A blank line after the first one: the same lines as _BLANK, searched from the newlines
#: (a literal prefix the regex engine finds quickly, 7x faster on a 9 MB record).
_BLANK_AFTER = re.compile(rb"\n[ \t\r]*\n")

#: Longest excerpt of a cell or column name quoted in a message (characters).
CELL_EXCERPT = 60


def _utf16_without_bom(raw):
    """Whether ``raw`` looks like UTF-16 text without a byte-order mark (every other byte NUL)."""
    head = raw[:4096]
    if len(head) < 4:
        return False
    even, odd = head[0::2], head[1::2]
    return even.count(0) > 0.9 * len(even) or odd.count(0) > 0.9 * len(odd)


def decode_table(raw, path, what="data file", error=DataFileError):
    """The text of a delimited table from its bytes, or an error saying what the file is.

    UTF-8 (a byte-order mark dropped) and UTF-16 with a byte-order mark are
    text; UTF-16 without a mark and binary content (NUL bytes, more than
    1 % of invalid UTF-8) are refused, naming the file. Line endings are
    normalised (CR LF and CR alone become LF), so a file saved with
    classic-Mac line endings reads as its lines.

    Parameters
    ----------
    raw : bytes
        The file's content.
    path : str or pathlib.Path
        Named in messages.
    what : str
        What the file is (``"--reference"``), named in messages.
    error : type
        Exception class raised.

    Returns
    -------
    str

    Raises
    ------
    error
        ``"<what>: <path>: UTF-16 text without a byte-order mark; save it as
        UTF-8"`` or ``"... not a text table (binary content) ..."``.
    """
    where = f"{what}: {escape(path)}" if what else escape(path)
    _refuse_compressed(raw, where, error)
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):      # UTF-16 with a byte-order mark
        text = raw.decode("utf-16", errors="replace")
    else:
        if b"\x00" in raw:
            if _utf16_without_bom(raw):
                raise error(f"{where}: UTF-16 text without a byte-order mark; save it as UTF-8 "
                            f"(or UTF-16 with a byte-order mark)")
            raise error(f"{where}: not a text table (binary content: NUL bytes); expected "
                        f"delimited text such as CSV")
        text = raw.decode("utf-8-sig", errors="replace")
        if text.count("\ufffd") > 0.01 * len(text) + 1:
            raise error(f"{where}: not a text table (binary content: not UTF-8 text); expected "
                        f"delimited text such as CSV saved as UTF-8")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text


#: The first two bytes of a gzip file (RFC 1952).
GZIP_MAGIC = b"\x1f\x8b"
#: Said after a bad last row when the file does not end with a line end.
CUT_NOTE = ("; the file ends in the middle of that line, its last (cut short while being "
            "written?): remove the incomplete line")


def _refuse_compressed(raw, where, error):
    """Refuse a gzip-compressed file, saying so, before it is read as (binary) text."""
    if raw.startswith(GZIP_MAGIC):
        raise error(f"{where}: gzip-compressed (it starts with the gzip bytes 1f 8b); expected a "
                    f"text table: decompress it first (gunzip FILE) and give the .csv")


def _ends_cut(text):
    """Whether a table's text (or bytes) ends without a line end: its last line cut short."""
    end = text.rstrip(" \t" if isinstance(text, str) else b" \t")
    return bool(end) and not end.endswith("\n" if isinstance(text, str) else (b"\n", b"\r"))


def _first_line(raw, comment=True):
    """The first line of a table's bytes that is not blank (nor a ``#`` comment), as text."""
    head = raw[:1 << 16]
    text = (head.decode("utf-16", errors="replace") if head.startswith((b"\xff\xfe", b"\xfe\xff"))
            else head.decode("utf-8", errors="replace"))
    return next((ln for ln in text.splitlines()
                 if ln.strip() and not (comment and ln.lstrip().startswith("#"))), "")


class _Table:
    """A parsed signal table: the frame (string header) and its cleaned text (for messages)."""

    def __init__(self, frame, text, sep, path, what, error=DataFileError, units=None):
        self.frame, self.text, self.sep, self.path, self.what = frame, text, sep, path, what
        self.error = error
        #: ``{column: unit}`` of a units row under the header (dropped from the frame), or {}
        self.units = dict(units or {})
        #: whether the text ends in the middle of its last line (no line end)
        self.cut = _ends_cut(text)

    def cut_note(self, row):
        """:data:`CUT_NOTE` when data row ``row`` (0-based) is the last and cut short, else ""."""
        return CUT_NOTE if self.cut and row == len(self.frame) - 1 else ""

    def line_fields(self, row):
        """Number of fields of data row ``row`` (0-based) as written, or None."""
        skip = 2 + bool(self.units)
        lines = self.text.split("\n", row + skip)
        if len(lines) < row + skip:
            return None
        line = lines[row + skip - 1]
        return len(line.split()) if self.sep == r"\s+" else len(line.split(self.sep))


def signal_table(raw, path, what="data file", error=DataFileError, comment=True):
    """A delimited table with a header row, parsed robustly, or one clear error line.

    The shared reader of the signal CSV files (drive, measured and reference
    files of ``compensate``, ``evaluate``, ``learn`` and a scenario's
    ``reference = { kind = "file" }``): encodings and line endings as
    :func:`decode_table`; ``#`` comment lines and blank lines skipped;
    separator ``,`` ``;`` tab or whitespace; an empty file, a header
    without data rows and ragged rows (more fields than the header) are
    named as such; cells of any length are parsed and quoted in messages
    at most :data:`CELL_EXCERPT` characters long.

    Parameters
    ----------
    raw : bytes
        The file's content.
    path : str or pathlib.Path
        Named in messages.
    what : str
        What the file is, named in messages.
    error : type
        Exception class raised.
    comment : bool
        Whether lines starting with ``#`` are comments.

    Returns
    -------
    _Table
        ``.frame`` (pandas.DataFrame, column names stripped strings, cells
        as parsed), to be read with :func:`numeric_column`.

    Raises
    ------
    error
    """
    where = f"{what}: {escape(path)}" if what else escape(path)
    _refuse_compressed(raw, where, error)
    check_size(raw, _sniff_separator(_first_line(raw, comment)), where, error)
    text = decode_table(raw, path, what, error)
    if comment and "#" in text:
        text = re.sub(r"(?m)^[ \t]*#[^\n]*(\n|$)", "", text)
    if re.search(r"(?m)^[ \t]*\n", text):
        text = re.sub(r"(?m)^[ \t]*\n", "", text)
    text = text.lstrip("\n")
    if not text.strip():
        raise error(f"{where}: the file is empty; expected a header row (e.g. t,x,y) and data rows")
    # the header and the second line by position: no copy of the rest of the text
    end = text.find("\n")
    first = text if end < 0 else text[:end]
    if end < 0 or _NOT_BLANK.search(text, end + 1) is None:
        raise error(f"{where}: a header row and no data rows; expected at least two rows of "
                    f"samples under the header")
    end2 = text.find("\n", end + 1)
    second = text[end + 1:] if end2 < 0 else text[end + 1:end2]
    sep = _sniff_separator(first)
    # bytes, not io.StringIO: its buffer holds 4 bytes a character
    data = text.encode("utf-8")
    frame = _float_frame(data, sep)
    try:
        if frame is None:        # a cell that is not a finite number: every cell as text
            frame = pd.read_csv(io.BytesIO(data), sep=sep, engine="c", dtype=str,
                                skipinitialspace=True, keep_default_na=False)
    except (pd.errors.ParserError, ValueError, MemoryError) as exc:
        msg = " ".join(str(exc).split())
        m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", msg)
        if m:
            raise error(f"{where}: ragged rows: line {m.group(2)} has {m.group(3)} fields, the "
                        f"header has {m.group(1)}; expected the same number of fields on every "
                        f"row{_PREAMBLE_HINT if int(m.group(2)) <= PREAMBLE_LINES else ''}") from None
        raise error(f"{where}: not a readable CSV table ({escape(msg, 200)})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    del data
    units = {}
    if len(frame) > 1 and _units_row(second, sep):     # a units row (s,V,µm): checked by column
        row = next(csv.reader([second], delimiter=sep)) if sep != r"\s+" else second.split()
        units = {c: str(u).strip() for c, u in zip(frame.columns, row)}
        frame = frame.iloc[1:].reset_index(drop=True)
    names = next(csv.reader([first], delimiter=sep)) if sep != r"\s+" else first.split()
    _refuse_repeated_names(names, where, error)
    table = _Table(frame, text, sep, path, what, error, units)
    short = _short_row(table)
    if short is not None:      # a short row is read as empty cells, in any column: refused
        raise error(f"{where}: ragged rows: data row {short[0] + 1} has {short[1]} fields, the "
                    f"header has {frame.shape[1]}; expected the same number of fields on every "
                    f"row{table.cut_note(short[0])}")
    return table


#: a character that is not white space (the search for a data row after the header)
_NOT_BLANK = re.compile(r"\S")


def _float_frame(data, sep):
    """The table of ``data`` with every cell a float64, or None when a cell is not a finite number.

    The fast reading of a table of numbers: 8 bytes a cell instead of a
    Python string each (about 60 bytes), 1.5 GB less for a record of
    3e6 rows and 5 columns. pandas' C parser reads each cell with the same
    conversion as :func:`pandas.to_numeric` of the stripped text (its
    ``precise_xstrtod``), so :func:`numeric_column` returns the same
    floats bit for bit (``tests/core/test_float_tables.py``). Anything else
    (a units row, a text column, an empty, boolean, NaN or infinite cell, a
    short or ragged row) returns None: the table is then read as text and
    judged cell by cell as before, with the same messages.

    Parameters
    ----------
    data : bytes
        The table's cleaned text (header row first), UTF-8.
    sep : str
        The separator (``","``, ``";"``, ``"\\t"`` or ``r"\\s+"``).

    Returns
    -------
    pandas.DataFrame or None
        Shape (n_rows, n_columns), float64 columns named as in the header.
    """
    try:
        frame = pd.read_csv(io.BytesIO(data), sep=sep, engine="c", dtype=np.float64,
                            skipinitialspace=True, na_filter=False)
    except (pd.errors.ParserError, ValueError, TypeError, OverflowError, MemoryError):
        return None
    if not all(dtype == np.float64 for dtype in frame.dtypes) or \
            not all(np.isfinite(frame[c].to_numpy()).all() for c in frame.columns):
        return None
    return frame


def _refuse_repeated_names(names, where, error):
    """Raise ``error`` when the header names a column twice (pandas would read ``x.1``)."""
    seen, twice = set(), []
    for name in (str(n).strip() for n in names):
        if name in seen and name not in twice:
            twice.append(name)
        seen.add(name)
    if twice:       # pandas renames the second 'x' to 'x.1': one column read, the other not
        shown = ", ".join(escape(repr(n), CELL_EXCERPT) for n in twice[:5])
        raise error(f"{where}: the column name{'s' if len(twice) > 1 else ''} {shown} "
                    f"{'appear' if len(twice) > 1 else 'appears'} more than once in the header; "
                    f"expected each column named once")


def _short_row(table):
    """The first data row with fewer fields than the header, as (row, fields), or None.

    pandas fills a short row's missing cells with empty ones: only the rows whose last
    cell is empty are looked at, on the text as written.
    """
    frame = table.frame
    if frame.shape[1] < 2 or (frame.dtypes == np.float64).all():   # numbers: no short row
        return None
    empty = np.flatnonzero((frame.iloc[:, -1].astype(str).str.strip() == "").to_numpy())
    if not empty.size:
        return None
    lines = table.text.split("\n")
    skip = 1 + bool(table.units)
    for row in empty:
        if row + skip >= len(lines):
            break
        line = lines[row + skip]
        n = len(line.split()) if table.sep == r"\s+" else len(line.split(table.sep))
        if n < frame.shape[1]:
            return int(row), n
    return None


_MISSING = ("", "nan", "na", "n/a", "null", "none")


def numeric_column(table, col, label=None, unit=("s", "V", "µm")):
    """The float values of column ``col`` of a :func:`signal_table`, or one clear error.

    Every cell must be a real, finite number (``True``/``False`` are not
    numbers, nor are ``nan``, ``inf`` or an empty cell) of magnitude at
    most :data:`~hammerstein.core.numbers.MAX_MAGNITUDE`; a data row with
    fewer fields than the header is reported as a ragged row. A column
    whose cell of the units row, or (but for a time column) whose name
    (``x_nm``), gives another unit than ``unit`` is refused.

    Parameters
    ----------
    table : _Table
    col : str
        Column name.
    label : str, optional
        What the column is for (``"the time [s]"``), named when it is missing.
    unit : str or tuple of str
        The unit(s) the column is read in: ``"s"`` for a time column.

    Returns
    -------
    numpy.ndarray, shape (n_rows,)

    Raises
    ------
    DataFileError (or the table's error class)
        Naming the file, the column and the data row.
    """
    error = table.error
    where = f"{table.what}: {escape(table.path)}" if table.what else escape(table.path)
    frame = table.frame
    if col not in frame.columns:
        names = ", ".join(escape(c, CELL_EXCERPT) for c in list(frame.columns)[:20])
        more = f", ... ({frame.shape[1] - 20} more)" if frame.shape[1] > 20 else ""
        raise error(f"{where}: no column {escape(repr(col), CELL_EXCERPT)}"
                            f"{' for ' + label if label else ''} (columns: {names}{more}; map "
                            f"another name with --input-columns/--output-columns NAME=COLUMN or --time COLUMN)")
    time = unit == "s"
    problem = unit_problem(where, "time" if time else "", col, table.units.get(col, ""), unit)
    found = None if time else name_unit(col, unit)
    if problem is None and found:
        shown = " or ".join((unit,) if isinstance(unit, str) else unit)
        problem = (f"{where}: column {escape(repr(col), CELL_EXCERPT)} is named in {found}, "
                   f"and signals are read in {shown}: convert the column to {shown}")
    if problem:
        raise error(problem)
    if frame[col].dtype == np.float64:     # read as numbers (_float_frame): every one finite
        v = frame[col].to_numpy(dtype=float)
        bad = np.zeros(0, dtype=bool)
    else:
        cells = frame[col].fillna("").astype(str).str.strip()
        v = pd.to_numeric(cells, errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(v)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        cell = cells.iloc[row]
        n = table.line_fields(row) if cell == "" else None
        if n is not None and n < frame.shape[1]:
            raise error(f"{where}: ragged rows: data row {row + 1} has {n} fields, the "
                                f"header has {frame.shape[1]}; expected the same number of "
                                f"fields on every row{table.cut_note(row)}")
        if cell.lower() in ("true", "false"):
            what = f"a boolean {cell!r}, not a number"
        elif cell.lower() in _MISSING:
            what = "an empty or NaN cell"
        elif np.isinf(v[row]):
            what = f"an infinite value {escape(repr(cell), CELL_EXCERPT)}"
        else:
            what = f"a non-numeric cell {escape(repr(cell), CELL_EXCERPT)}"
        raise error(f"{where}: column {escape(repr(col), CELL_EXCERPT)}: {what} on data "
                            f"row {row + 1}; expected finite numbers{decimal_comma_hint(cell)}"
                            f"{table.cut_note(row)}")
    big = np.flatnonzero(np.abs(v) > MAX_MAGNITUDE)
    if big.size:
        raise error(f"{where}: column {escape(repr(col), CELL_EXCERPT)}: value "
                            f"{v[big[0]]:.3g} on data row {int(big[0]) + 1} is beyond the limit "
                            f"{MAX_MAGNITUDE:.0e}")
    return v


def _units_row(line, sep):
    """Whether the line under a header is a row of units: text cells only, no number."""
    try:
        row = next(csv.reader([line], delimiter=sep)) if sep != r"\s+" else line.split()
    except (csv.Error, StopIteration):
        return False
    cells = [c.strip() for c in row if c.strip()]
    return bool(cells) and not any(_is_number(c) or decimal_comma_hint(c) for c in cells)


#: Bytes of a record's opening read to check its columns
#: (:func:`hammerstein.io.record_columns.record_column_problem`).
HEAD_BYTES = 1 << 16


def _read_table(path, skip_rows=0, head=False):
    """The parsed table of a data file and whether it has a header row.

    ``head``: only the file's first :data:`HEAD_BYTES` bytes (after the
    preamble's ``skip_rows`` lines), cut at their last complete line: the
    header, the units row and the first data rows.
    """
    try:
        raw = bounded_read_bytes(path, "data", "data file",
                                 head=HEAD_BYTES * 4 if head else None)
    except FileLimitError as exc:
        raise DataFileError(str(exc)) from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    _refuse_compressed(raw, escape(path), DataFileError)
    if skip_rows:   # a preamble (instrument, date, rate ...) before the table: dropped as lines
        raw = b"".join(raw.splitlines(keepends=True)[int(skip_rows):])
    if head and len(raw) > HEAD_BYTES:  # complete lines only: a cut row is not the file's
        raw = raw[:raw.rfind(b"\n", 0, HEAD_BYTES) + 1] or raw[:HEAD_BYTES]
    top = raw[:1 << 16]        # the lines as --skip-rows counts them, for a preamble's hint
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):  # UTF-16 with a byte-order mark
        raw = raw.decode("utf-16", errors="replace").encode("utf-8")
    raw = raw.removeprefix(b"\xef\xbb\xbf")
    # parsed as bytes: a str of the file (and pandas' StringIO, 4 bytes a character) would
    # multiply the memory of a large record
    bad = len(raw) - len(raw.decode("utf-8", errors="ignore").encode("utf-8"))
    if b"\x00" in raw and _utf16_without_bom(raw):
        raise DataFileError(f"{path}: UTF-16 text without a byte-order mark; save it as UTF-8 "
                            f"(or UTF-16 with a byte-order mark)")
    if b"\x00" in raw or bad > 0.01 * len(raw) + 1:
        raise DataFileError(f"{path}: not a text table (binary content); expected delimited "
                            f"text such as CSV")
    if b"#" in raw:  # comment lines (not a '#' inside a line)
        raw = _COMMENT.sub(b"", raw)
    if _BLANK.match(raw) or _BLANK_AFTER.search(raw):
        raw = _BLANK.sub(b"", raw)
    raw = raw.lstrip(b"\r\n")
    if not raw.strip():
        raise DataFileError(f"{path}: the file is empty")
    cut = _ends_cut(raw) and not head
    head = raw[:1 << 16].decode("utf-8", errors="replace").splitlines()
    sep = _sniff_separator("\n".join(head[:5]))
    try:
        first = next(csv.reader([head[0]], delimiter=sep)) if sep != r"\s+" else head[0].split()
    except csv.Error as exc:
        raise DataFileError(f"{path}: cannot parse the first line ({escape(exc, 100)})") from None
    cells = [c.strip() for c in first if c.strip()]
    header = any(not _is_number(c) for c in cells)
    if header:      # identify read the first of two 'ux' columns without a word
        _refuse_repeated_names(first, escape(path), DataFileError)
    # a units row under the header, as data-acquisition programs write it
    # ("s,V,µm", "[s];[V];[um]"): every cell text, none a number; skipped
    units = header and len(head) > 1 and _units_row(head[1], sep)
    unit_of = {}
    if units:   # each column's unit, checked when the column is read (_column)
        row = next(csv.reader([head[1]], delimiter=sep)) if sep != r"\s+" else head[1].split()
        unit_of = {c.strip(): u.strip() for c, u in zip(first, row)}
    check_size(raw, sep, path, DataFileError)       # rows x the widest line, before parsing
    try:
        with warnings.catch_warnings():
            # a text cell in a long file: pandas' "Columns (1) have mixed types. Specify dtype
            # option" reached the user, naming options no command has; the cell itself is named
            # when its column is read (_column)
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            frame = pd.read_csv(io.BytesIO(raw), sep=sep, header=0 if header else None,
                                skiprows=[1] if units else None,
                                engine="c", skipinitialspace=True, encoding="utf-8",
                                encoding_errors="replace")
    except (pd.errors.ParserError, ValueError, MemoryError) as exc:
        reason = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", reason)
        if m:
            line = int(m.group(2))
            n = _preamble_rows(top) if line <= PREAMBLE_LINES else None
            hint = ("" if line > PREAMBLE_LINES else
                    f" (a preamble of {n} line{'s' if n > 1 else ''} before the table? skip "
                    f"them with --skip-rows {int(skip_rows) + n}, or start them with '#')"
                    if n else " (a preamble before the table? skip its lines with --skip-rows "
                              "N, or start them with '#')")
            raise DataFileError(f"{escape(path)}: ragged rows: line {line} has {m.group(3)} "
                                f"fields, the first row has {m.group(1)}; expected the same "
                                f"number of fields on every row{hint}") from None
        raise DataFileError(f"{path}: cannot parse the table ({escape(reason, 200)})") from None
    del raw
    if header:
        frame.columns = [str(c).strip() for c in frame.columns]
    else:
        frame.columns = list(range(frame.shape[1]))
    # drop an empty leading index column (all cells empty)
    if frame.shape[1] > 1 and frame.iloc[:, 0].isna().all():
        frame = frame.iloc[:, 1:]
        if not header:
            frame.columns = list(range(frame.shape[1]))
    frame.attrs["units"] = unit_of
    frame.attrs["cut"] = cut
    if _preamble_hint(frame):   # a header that reads as a preamble line: how many to skip
        n = _preamble_rows(top)
        frame.attrs["preamble_rows"] = int(skip_rows) + n if n else None
    return frame, header


#: The unit each role's columns are read in (``identify --input-unit/--output-unit`` change
#: the inputs' and outputs').
UNITS = {"time": "s", "input": "V", "output": "µm"}


def _unit_check(frame, name, role, path, units):
    """Refuse a column whose units row or name gives another unit than its role's."""
    expected = (units or UNITS)[role]
    stated = frame.attrs.get("units", {}).get(str(name))
    problem = unit_problem(path, role, name, stated, expected) if stated is not None else None
    if problem is None and role != "time":
        found = name_unit(name, expected)
        if found:
            problem = (f"{path}: {role} column {escape(repr(str(name)), 60)} is named in "
                       f"{found}, and {role}s are read in {expected}: convert the column to "
                       f"{expected}")
    if problem:
        raise DataFileError(problem)


def _column(frame, header, key, role, path, units=None):
    names = [str(c) for c in frame.columns]
    shown = [f"{i}:{escape(n, 40)}" if header else str(i) for i, n in enumerate(names[:20])]
    available = ", ".join(shown) + (f", ... ({len(names) - 20} more)" if len(names) > 20 else "")
    path = escape(path)
    if header and isinstance(key, (int, np.integer)) and str(key) in names:
        key = str(key)   # the header has a column of that name: a name, not an index
    if isinstance(key, str) and key.strip().lstrip("-").isdigit() and not (header and key in names):
        key = int(key)   # a column index, unless the header has a column of that name
    if isinstance(key, (int, np.integer)):
        if not 0 <= key < frame.shape[1]:
            raise DataFileError(
                f"{path}: {role} column {key} out of range; available columns: {available}")
        col = frame.iloc[:, int(key)]
        name = names[int(key)] if header else f"column {int(key)}"
    else:
        if key not in names:
            raise DataFileError(
                f"{path}: no {role} column named {escape(repr(key), 60)}; available columns: "
                f"{available}{_preamble_hint(frame)}")
        col = frame[key]
        name = str(key)
    if header:
        _unit_check(frame, name, role, path, units)
    if pd.api.types.is_bool_dtype(col):
        raise DataFileError(f"{path}: {role} column {escape(repr(name), CELL_EXCERPT)}: boolean "
                            f"cells (True/False), not numbers")
    values = pd.to_numeric(col, errors="coerce")
    bad = values.isna()
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        cell = col.iloc[row]
        what = (f"non-numeric or empty cell {escape(repr(str(cell).strip()), CELL_EXCERPT)}" if isinstance(cell, str) and cell.strip()
                and cell.strip().lower() not in ("nan", "na", "n/a", "null", "none")
                else "non-numeric or empty cell (empty or NaN)")
        cut = CUT_NOTE if frame.attrs.get("cut") and row == len(frame) - 1 else ""
        raise DataFileError(f"{path}: {role} column {name!r}: {what} at data row {row + 1}"
                            f"{decimal_comma_hint(cell)}{cut}")
    arr = values.to_numpy(dtype=float)
    big = np.flatnonzero(np.abs(arr) > MAX_MAGNITUDE)   # inf (or 1.8e308) included
    if big.size:    # the squares of the fit would overflow (core/numbers.py)
        v = arr[big[0]]
        what = "infinite values" if np.isinf(v) else f"value {v:.3g}"
        raise DataFileError(f"{path}: {role} column {name!r}: {what} at data row {big[0] + 1} "
                            f"{'' if np.isinf(v) else f'is beyond the limit {MAX_MAGNITUDE:.0e}'}"
                            .rstrip())
    return arr, name


def _preamble_rows(top):
    """The lines before a table whose rows all have one number of fields, or None.

    The smallest n (1 to :data:`PREAMBLE_LINES`) such that the lines from the n-th on
    (comments and blank lines aside, as the reader drops them) have one number of fields,
    at least 2, under the separator sniffed on them: the ``--skip-rows`` that reads the
    table (a 10-line instrument preamble: 10; a pandas "line 6" is only the first line
    that differs from the first, no bound on the preamble's length).

    Parameters
    ----------
    top : bytes
        The file's first bytes, after the rows already skipped.

    Returns
    -------
    int or None
    """
    lines = top.decode("utf-8", errors="replace").splitlines()
    if _ends_cut(top):
        lines = lines[:-1]                       # the last line read may be cut short
    for n in range(1, min(PREAMBLE_LINES, len(lines) - 1) + 1):
        rest = [ln for ln in lines[n:n + 200] if ln.strip() and not ln.lstrip().startswith("#")]
        if len(rest) < 2:
            return None
        sep = _sniff_separator("\n".join(rest[:5]))
        try:
            counts = {len(ln.split()) if sep == r"\s+" else len(next(csv.reader([ln],
                                                                                delimiter=sep)))
                      for ln in rest}
        except csv.Error:
            continue
        if len(counts) == 1 and counts.pop() >= 2:
            return n
    return None


def _preamble_hint(frame):
    """A hint when the header read looks like a preamble line (``Instrument: Tek MSO``)."""
    names = [str(c) for c in frame.columns]
    if any(n.rstrip().endswith(":") for n in names[:3]) or frame.shape[1] < 2:
        n = frame.attrs.get("preamble_rows")
        if n:
            return (f" (a preamble before the table? skip it with --skip-rows {n}, or start "
                    f"its lines with '#')")
        return (" (a preamble before the table? skip its lines with --skip-rows N, or start "
                "them with '#')")
    return ""


#: A ragged row within this many lines of the top is named as a possible preamble.
PREAMBLE_LINES = 20
_PREAMBLE_HINT = (" (a preamble before the header? start its lines with '#', which are "
                  "comments)")

#: A time column named in another unit than seconds (``time_ms``, ``t [us]``, ``t(µs)``).
_TIME_UNIT_NAME = re.compile(r"(^|[_\s(\[/-])(ms|msec|us|usec|µs|μs|ns|min|h)([)\]]?\s*)$",
                             re.IGNORECASE)


def _time_column(frame, header, time, path):
    """The time column (n_samples,) [s] and its name: read in seconds, increasing; else DataFileError."""
    t, tname = _column(frame, header, time, "time", path)
    unit = _TIME_UNIT_NAME.search(str(tname))
    if unit:
        raise DataFileError(
            f"{path}: time column {tname!r} is named in {unit.group(2)}, and times are read "
            f"in seconds: convert the column to seconds, or give the sampling period [s] "
            f"instead of a time column (--sampling-period)")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0])
        raise DataFileError(
            f"{path}: time column {tname!r} is not increasing at data row {i + 2} "
            f"({float(t[i])!r} s then {float(t[i + 1])!r} s)")
    return t, tname


def _timepts(frame, header, time, sampling_period, path):
    """Time points (n_samples,) [s] and sampling period [s] of a parsed table.

    From the ``time`` column (increasing, on a uniform grid within its stamps'
    rounding, :func:`uniform_period`; agreeing with ``sampling_period`` when both
    are given) or from ``sampling_period``; :class:`DataFileError` otherwise.
    """
    if time is not None:
        t, tname = _time_column(frame, header, time, path)
        dt = np.diff(t)
        T, off, tol = uniform_period(t)
        gaps = step_gaps(t)
        if gaps.size:
            raise DataFileError(
                f"{path}: time column {tname!r} has {gap_text(t, gaps)}: fill or resample the "
                f"gaps (if no sample is missing and only the stamps are wrong, give "
                f"--sampling-period instead of the time column)")
        if np.max(np.abs(off)) > tol:
            i = int(np.argmax(np.abs(dt - T)))
            raise DataFileError(
                f"{path}: time column {tname!r} is not uniformly sampled: step {dt[i]:g} s at "
                f"data row {i + 2}, and a time {np.max(np.abs(off)):.3g} s off the grid of "
                f"{T:g} s, more than its stamps' rounding ({tol:.2g} s): resample a record with "
                f"a gap or a changing rate (if only its stamps are coarse, give the sampling "
                f"period instead of the time column)")
        t = t[0] + np.arange(t.size) * T      # the samples' times, not their rounded stamps
        if sampling_period is not None and not np.isclose(sampling_period, T, rtol=0.01):
            raise DataFileError(
                f"{path}: sampling period {sampling_period:g} s disagrees with the time "
                f"column step {T:g} s")
    else:
        if sampling_period is None:
            raise DataFileError(f"{path}: give a time column or a sampling period [s]")
        if not (np.isfinite(sampling_period) and sampling_period > 0):
            raise DataFileError(
                f"{path}: sampling period: expected a positive time [s], found {sampling_period!r}")
        T = float(sampling_period)
        t = np.arange(frame.shape[0]) * T
    return t, T


def _units(input_unit, output_unit):
    return {"time": "s", "input": input_unit or "V", "output": output_unit or "µm"}


def read_record(path, input, output, time=None, sampling_period=None, skip_rows=0,
                input_unit="V", output_unit="µm"):
    """Read a single-input single-output record from a delimited text file.

    Parameters
    ----------
    path : str or pathlib.Path
        CSV / text file: a regular file of at most 256 MiB
        (``HAMMERSTEIN_MAX_DATA_BYTES`` raises the limit), checked before
        reading. A header is detected when a cell of the first
        non-comment line is not a number; separators ``,`` ``;`` tab or
        whitespace are detected; lines starting with ``#`` are ignored; an
        empty leading index column is dropped.
    input, output : str or int
        Input [V] and output [µm] columns, by header name or 0-based index
        (after dropping an empty index column).
    time : str or int, optional
        Time column [s]; must be increasing and uniform (within 1 % of the
        period, or a float32 stamp's rounding: :func:`uniform_period`).
    sampling_period : float, optional
        Sampling period [s] when there is no time column.
    skip_rows : int
        Lines of a preamble before the table (an instrument's header block),
        dropped before anything is parsed; a units row under the table's
        header needs none (it is recognised).
    input_unit, output_unit : str
        The units the inputs and outputs are read in. A column whose cell
        of the units row, or whose name (``x_nm``, ``ux [mV]``), says
        another unit is refused, naming it: it is not converted.

    Returns
    -------
    Record

    Raises
    ------
    DataFileError
        Missing or empty file, unparsable table, missing or misnamed column
        (the available ones are listed), non-numeric, empty, NaN or infinite
        cells, binary content, non-increasing or non-uniform time, fewer than 10 samples, neither ``time`` nor
        ``sampling_period``, or both disagreeing.
    """
    path = Path(path)
    if not path.exists():
        raise DataFileError(f"{path}: no such file")
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory, expected a data file")
    frame, header = _read_table(path, skip_rows)
    if frame.shape[0] < MIN_SAMPLES:
        raise DataFileError(
            f"{path}: too short, expected at least {MIN_SAMPLES} samples, found {frame.shape[0]}")
    units = _units(input_unit, output_unit)
    u, uname = _column(frame, header, input, "input", path, units)
    y, yname = _column(frame, header, output, "output", path, units)
    if uname == yname:
        raise DataFileError(
            f"{path}: input and output are the same column {uname!r}; name two different columns")
    t, T = _timepts(frame, header, time, sampling_period, path)
    return Record(t, u, y, uname, yname, T, str(path))


def read_records(path, inputs, outputs, time=None, sampling_period=None, skip_rows=0,
                 input_unit="V", output_unit="µm"):
    """Read a multi-input multi-output record from a delimited text file.

    The file format rules are those of :func:`read_record`.

    Parameters
    ----------
    path : str or pathlib.Path
    inputs, outputs : str, int or list
        Input and output columns: names or 0-based indices, as a list or as
        one comma-separated string (``"u1,u2"``).
    time : str or int, optional
        Time column [s]; increasing and uniform.
    sampling_period : float, optional
        Sampling period [s] when there is no time column.
    skip_rows : int
        Lines of a preamble before the table (an instrument's header block),
        dropped before anything is parsed; a units row under the table's
        header needs none (it is recognised).
    input_unit, output_unit : str
        The units the inputs and outputs are read in (:func:`read_record`).

    Returns
    -------
    MultiRecord

    Raises
    ------
    DataFileError
        As :func:`read_record`; also for a column named twice or used both as
        input and output, or an empty column list.
    """
    ins, outs = column_list(inputs), column_list(outputs)
    if not ins or not outs or any(c == "" for c in ins + outs):
        raise DataFileError(f"{path}: expected at least one input and one output column, "
                            f"found inputs {inputs!r}, outputs {outputs!r}")
    path = Path(path)
    if not path.exists():
        raise DataFileError(f"{path}: no such file")
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory, expected a data file")
    frame, header = _read_table(path, skip_rows)
    if frame.shape[0] < MIN_SAMPLES:
        raise DataFileError(
            f"{path}: too short, expected at least {MIN_SAMPLES} samples, found {frame.shape[0]}")
    u, unames, y, ynames = _signal_columns(frame, header, ins, outs, path,
                                           _units(input_unit, output_unit))
    t, T = _timepts(frame, header, time, sampling_period, path)
    return MultiRecord(t, np.array(u), np.array(y), tuple(unames), tuple(ynames), T, str(path))


def _signal_columns(frame, header, ins, outs, path, units):
    """The input and output columns of a parsed table: values and names, or DataFileError."""
    u, unames = zip(*[_column(frame, header, c, "input", path, units) for c in ins])
    y, ynames = zip(*[_column(frame, header, c, "output", path, units) for c in outs])
    _named_once(unames, ynames, path)
    return u, unames, y, ynames


def _named_once(unames, ynames, path):
    """DataFileError when a column is both an input and an output, or named twice."""
    both = [n for n in unames if n in ynames]
    if both:
        raise DataFileError(
            f"{path}: input and output are the same column {both[0]!r}; name two different columns")
    names = list(unames) + list(ynames)
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DataFileError(f"{path}: column {dup[0]!r} named twice among the inputs and outputs; "
                            f"name each column once")
