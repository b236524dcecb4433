"""Checks on a data file's table before and after it is parsed: size and units.

Size: the rows of a file and the fields of its long lines are counted on
its bytes (numpy, a few MiB at a time: 0.2 s for 150 MB) before pandas parses it,
which takes about 30 bytes a cell and 1 KB and 30 µs a column, so that
the cell limit (``HAMMERSTEIN_MAX_DATA_CELLS``) bounds every reader's memory
and time, a file of one line of ten million fields included.

Data-acquisition programs name the unit of a column, in a row of units
under the header (``s,V,µm``) or in the column's name (``x_nm``,
``ux [mV]``). The records are read in seconds, volts and micrometres (or
the units ``identify --input-unit/--output-unit`` declare): a column in
another unit is refused, naming it, rather than read 1000 times off.
"""

from __future__ import annotations

import os
import re

import numpy as np

from hammerstein.core.files import escape

__all__ = ["unit_problem", "name_unit", "decimal_comma_hint", "max_cells", "max_columns", "wide_line", "check_size",
           "CELLS_ENV"]

#: Environment variable overriding :func:`max_cells`.
CELLS_ENV = "HAMMERSTEIN_MAX_DATA_CELLS"

#: Cells of the limit a column costs (pandas: about 1 KB and 30 µs a column).
CELLS_PER_COLUMN = 4000

#: Bytes of a file counted at a time.
_CHUNK = 1 << 22


def max_cells():
    """Largest number of cells (rows x columns) of a data file, checked before parsing.

    Default 40 million (a 20 kHz, 100 s record of 20 columns), so that the
    parsed table stays within a few GB whatever the file;
    ``HAMMERSTEIN_MAX_DATA_CELLS=N`` (a positive integer) overrides it.

    Returns
    -------
    int
    """
    text = os.environ.get(CELLS_ENV, "").strip()
    return int(text) if text.isascii() and text.isdigit() and int(text) > 0 else 40_000_000


def max_columns():
    """Largest number of columns (fields of a line) of a data file: one per 4000 cells of the limit.

    10 000 with the default :func:`max_cells`: parsing a column costs pandas
    about 1 KB and 30 µs whatever its rows (a line of a million fields took
    28 s and 1.1 GB); at least 100, at most the cell limit.

    Returns
    -------
    int
    """
    cap = max_cells()
    return min(cap, max(100, cap // CELLS_PER_COLUMN))


def _fields(line, sep):
    """Fields of one line (bytes): separators plus one, or whitespace-separated tokens."""
    return len(line.split()) if sep is None else line.count(sep) + 1


def wide_line(raw, sep, most):
    """The first line of a table's bytes with more than ``most`` fields, counted without parsing.

    A line's byte length bounds its fields (separators plus one, a quoted
    separator counted: an upper bound; tokens for whitespace), so only the
    lines long enough to hold more than ``most`` are counted, a few MiB at a
    time (0.2 s for a 150 MB file whose lines are all short).

    Parameters
    ----------
    raw : bytes
        The table (UTF-8 or ASCII; LF or CR LF line ends).
    sep : str
        ``","``, ``";"``, ``"\\t"`` or ``r"\\s+"`` (whitespace).
    most : int
        Fields allowed on a line.

    Returns
    -------
    tuple of int or None
        ``(line, fields)``: the line's 1-based number and its fields; None when
        no line has more than ``most`` fields.

    Examples
    --------
    >>> wide_line(b"t,x\\n0,1\\n0,1,2,3\\n", ",", 2)
    (3, 4)
    >>> wide_line(b"t  x\\n 0 1", r"\\s+", 2) is None
    True
    """
    code = None if sep == r"\s+" else sep.encode()
    data = np.frombuffer(raw, dtype=np.uint8)
    # a line of B bytes holds at most B + 1 fields (B // 2 + 1 tokens): longer ones are counted
    longest = most - 1 if code is not None else 2 * most
    lines, start = 0, 0          # lines before the chunk; the byte where its first line starts
    for chunk in range(0, data.size, _CHUNK):
        ends = np.flatnonzero(data[chunk:chunk + _CHUNK] == 10) + chunk
        if ends.size == 0 and chunk + _CHUNK < data.size:
            continue             # the line goes on: counted where it ends
        if chunk + _CHUNK >= data.size and (data.size == 0 or data[-1] != 10):
            ends = np.append(ends, data.size)           # a last line without its line end
        starts = np.empty_like(ends)
        starts[:1] = start
        starts[1:] = ends[:-1] + 1
        long = np.flatnonzero(ends - starts > longest)
        if long.size > 256:      # many: the separators (token starts) of the chunk counted
            seg = data[starts[0]:ends[-1]]
            if code is not None:
                marks = np.flatnonzero(seg == code[0])
            else:
                space = (seg == 32) | (seg == 9) | (seg == 13) | (seg == 10)
                marks = np.flatnonzero(~space & np.concatenate(([True], space[:-1])))
            marks += starts[0]
            fields = (np.searchsorted(marks, ends) - np.searchsorted(marks, starts)
                      + (code is not None))
            long = np.flatnonzero(fields > most)[:1]
        for k in long:
            n = _fields(raw[starts[k]:ends[k]], code)
            if n > most:
                return lines + int(k) + 1, n
        lines += ends.size
        start = int(ends[-1]) + 1 if ends.size else start
    return None


def check_size(raw, sep, where, error):
    """Refuse a table of more columns or cells than the limits, before it is parsed.

    Parameters
    ----------
    raw : bytes
        The table.
    sep : str
        Its separator (:func:`wide_line`).
    where : str
        The file, as named in messages.
    error : type
        Exception class raised.

    Returns
    -------
    lines : int
        The table's lines.

    Raises
    ------
    error
        ``"<where>: line L has N fields, more than the limit of M columns ..."`` or
        ``"<where>: R rows x N columns (line L) = C cells is more than the
        limit of M cells (raise it with HAMMERSTEIN_MAX_DATA_CELLS=N)"``.
    """
    lines = raw.count(b"\n") + (bool(raw) and not raw.endswith(b"\n"))
    cap, cols = max_cells(), max_columns()
    wide = wide_line(raw, sep, min(cols, cap // max(lines, 1)))
    if wide is None:
        return lines
    line, fields = wide
    if fields > cols:
        raise error(f"{where}: line {line} has {fields} fields, more than the limit of {cols} "
                    f"columns (one per {CELLS_PER_COLUMN} cells of the limit of {cap} cells; "
                    f"raise it with {CELLS_ENV}=N)")
    at = "" if line <= 1 else f" (line {line})"
    raise error(f"{where}: {lines} rows x {fields} columns{at} = {lines * fields} cells is "
                f"more than the limit of {cap} cells (raise it with {CELLS_ENV}=N)")

#: Spellings of each unit a record is read in (compared case-insensitively, brackets dropped).
_SAME = {
    "s": ("s", "sec", "secs", "second", "seconds"),
    "V": ("v", "volt", "volts"),
    "µm": ("µm", "μm", "um", "micron", "microns", "micrometer", "micrometers", "micrometre",
           "micrometres"),
}

#: Units written in a signal column's name (``x_nm``, ``ux [mV]``): the unit after a
#: separator at the end of the name (a time column's: ``datafiles._TIME_UNIT_NAME``). A bare ``m`` only in brackets (``x [m]``; ``x_m`` is
#: often "x measured").
_NAME_UNIT = re.compile(
    r"(?:^|[_\s/-])(mv|kv|uv|µv|μv|nm|mm|cm)\s*$"
    r"|[(\[]\s*(mv|kv|uv|µv|μv|nm|mm|cm|m|v|µm|μm|um)\s*[)\]]\s*$",
    re.IGNORECASE)

_ROLE_WORD = {"time": "times", "input": "inputs", "output": "outputs"}


def _clean(unit):
    """A unit as written, without surrounding brackets and blanks."""
    return str(unit).strip().strip("[](){}").strip()


def _is(unit, expected):
    """Whether ``unit`` is a spelling of ``expected``."""
    u = _clean(unit)
    spellings = _SAME.get(expected, (expected,))
    return u.casefold() in {s.casefold() for s in spellings} or u == expected


def unit_problem(where, role, name, unit, expected):
    """Why a column whose units row says ``unit`` cannot be read as ``expected``, or None.

    Parameters
    ----------
    where : str
        The file, as named in messages.
    role : str
        ``"time"``, ``"input"`` or ``"output"`` (``""`` for a signal of a
        drive or measured file, which may be either).
    name : str
        The column's name.
    unit : str
        The column's cell of the units row (an empty cell or ``-`` states no unit).
    expected : str or tuple of str
        The unit the column is read in (``"s"``, ``"V"``, ``"µm"``), or the
        units it may be in.

    Returns
    -------
    str or None
        One line naming the file, the column, the unit found and the one
        expected.

    Examples
    --------
    >>> unit_problem("r.csv", "time", "t", "ms", "s")
    "r.csv: time column 't': the units row says 'ms', and times are read in s: convert the column to s (or give --sampling-period instead of a time column)"
    >>> unit_problem("r.csv", "output", "x", "[um]", "µm") is None
    True
    """
    u = _clean(unit)
    wanted = (expected,) if isinstance(expected, str) else tuple(expected)
    if u in ("", "-") or any(_is(u, e) for e in wanted):
        return None
    shown = " or ".join(wanted)
    what = _ROLE_WORD.get(role, "signals")
    hint = (" (or give --sampling-period instead of a time column)" if role == "time" else "")
    label = f"{role} column" if role else "column"
    return (f"{where}: {label} {escape(repr(str(name)), 60)}: the units row says "
            f"{escape(repr(u), 30)}, and {what} are read in {shown}: convert the column to "
            f"{shown}{hint}")


def name_unit(name, expected):
    """The unit a column's name ends with (``x_nm`` -> ``nm``) when it is not ``expected``.

    Parameters
    ----------
    name : str
        The column's name.
    expected : str or tuple of str
        The unit(s) the column is read in.

    Returns
    -------
    str or None
        The unit written in the name, or None (no unit, or the expected one).

    Examples
    --------
    >>> name_unit("x_nm", "µm"), name_unit("ux [mV]", "V"), name_unit("x_m", "µm")
    ('nm', 'mV', None)
    """
    m = _NAME_UNIT.search(str(name))
    if not m:
        return None
    unit = m.group(1) or m.group(2)
    wanted = (expected,) if isinstance(expected, str) else tuple(expected)
    return None if any(_is(unit, e) for e in wanted) else unit


_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")


def decimal_comma_hint(cell):
    """A hint for a cell written with a decimal comma (``0,00628``), else ``""``.

    Parameters
    ----------
    cell : object
        The cell that is not a number.

    Returns
    -------
    str

    Examples
    --------
    >>> decimal_comma_hint("-0,0258")
    " (looks like a decimal comma; write '.' decimals)"
    >>> decimal_comma_hint("abc")
    ''
    """
    return (" (looks like a decimal comma; write '.' decimals)"
            if isinstance(cell, str) and _DECIMAL_COMMA.match(cell.strip()) else "")
