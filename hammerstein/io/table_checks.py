"""Checks on a data file's table before and after it is parsed: units.

Data-acquisition programs name the unit of a column, in a row of units
under the header (``s,V,µm``) or in the column's name (``x_nm``,
``ux [mV]``). The records are read in seconds, volts and micrometres (or
the units ``identify --input-unit/--output-unit`` declare): a column in
another unit is refused, naming it, rather than read 1000 times off.
"""

from __future__ import annotations

import re

from hammerstein.core.files import escape

__all__ = ["unit_problem", "name_unit"]

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
