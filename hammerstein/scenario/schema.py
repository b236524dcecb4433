"""Scenario files (TOML): the schema (key tables, field checkers, :func:`check_table`).

A scenario names a simulated actuator (``[plant]``), an optional feedforward
compensator (``[compensator]``) and one or more ``[[cases]]``, each an
open-loop voltage ``drive`` (characterisation, paper Fig. 5) or a
compensated ``reference`` trajectory (Fig. 8, 10-13). The full schema is in
the README.

A file is checked in two steps that both collect EVERY problem before
raising one :class:`ScenarioError` whose lines read ``file: key: message``:
:func:`hammerstein.scenario.validate.validate_scenario` (keys, types, units,
ranges, names, signals against Nyquist; what ``hammerstein validate`` runs)
and :func:`hammerstein.scenario.resolve.resolve_scenario` (identified models,
model files, compensators, stability maps; ``hammerstein run`` runs both).
This module holds what both use: the key tables, the field checkers and
:func:`check_table`.
"""

from __future__ import annotations

import difflib
import os
import re
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from hammerstein.core.numbers import is_number

from hammerstein.exceptions import Invalid, NestedInvalid, ScenarioError

__all__ = [
    "ScenarioError",
    "Field",
    "Invalid",
    "NestedInvalid",
    "check_table",
    "number",
    "integer",
    "string",
    "boolean",
    "choice",
    "name_list",
    "name_field",
    "MAX_NAME",
    "MAX_TEXT",
    "MAX_ITERATIONS",
    "MAX_CASES",
    "MAX_SWEEP_FREQUENCIES",
    "MAX_CASE_SAMPLES",
    "MAX_TOTAL_SAMPLES",
    "MAX_HYSTERONS",
    "MAX_IDENTIFY_PERIODS",
    "total_samples_budget",
]


# -- upper bounds (documented in the README, checked by validate) -------------------
#: Longest name (scenario, case, sweep, label): it becomes a file or directory name.
MAX_NAME = 100
#: Longest free text (title, description, preset or model path).
MAX_TEXT = 1000
#: Most fixed-point iterations per sample of a compensator.
MAX_ITERATIONS = 100
#: Most cases of a scenario (after expanding the sweeps).
MAX_CASES = 2000
#: Most hysterons per component of an identified model.
MAX_HYSTERONS = 100
#: Most periods of an identification experiment.
MAX_IDENTIFY_PERIODS = 1000
#: Most frequencies of one sweep.
MAX_SWEEP_FREQUENCIES = 200
#: Most samples of one case or identification experiment (100 s at 20 kHz).
MAX_CASE_SAMPLES = 2_000_000
#: Default total-samples budget of one scenario (all cases and identification
#: experiments); the environment variable ``HAMMERSTEIN_MAX_SAMPLES`` changes it.
MAX_TOTAL_SAMPLES = 5_000_000


def total_samples_budget():
    """The total-samples budget of one scenario.

    Returns
    -------
    int
        ``HAMMERSTEIN_MAX_SAMPLES`` when it is a positive integer, else
        :data:`MAX_TOTAL_SAMPLES`.
    """
    text = os.environ.get("HAMMERSTEIN_MAX_SAMPLES", "").strip()
    return int(text) if text.isascii() and text.isdigit() and int(text) > 0 else MAX_TOTAL_SAMPLES


# -- field checkers: value -> normalised value, or raise Invalid -------------------
def _is_number(v):
    return is_number(v)   # huge ints, subnormals, NaN and inf refused (core/numbers.py)


def number(unit, minimum=None, exclusive=True):
    """Checker of a finite number [unit], optionally ``> minimum`` (or ``>=``).

    Parameters
    ----------
    unit : str
        Unit named in the error message (``"µm"``, ``"Hz"``, ``"s"``, ``"V"``).
    minimum : float, optional
        Lower bound in the same unit; None for no bound.
    exclusive : bool
        Whether the bound is strict (``> minimum``) or not (``>= minimum``).

    Returns
    -------
    callable
        ``check(value) -> float``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not a finite number (a
        bool is not one) or violates the bound.
    """
    def check(v):
        bound = "" if minimum is None else f" {'>' if exclusive else '>='} {minimum:g}"
        if not _is_number(v) or (minimum is not None and (v <= minimum if exclusive else v < minimum)):
            raise Invalid(f"expected a number{bound} [{unit}], found {_short(v)}")
        return float(v)
    return check


def integer(minimum=0, maximum=None):
    """Checker of an integer ``>= minimum`` (and ``<= maximum`` when given).

    Parameters
    ----------
    minimum : int
        Smallest accepted value.
    maximum : int, optional
        Largest accepted value (an upper bound of validate, e.g.
        :data:`MAX_ITERATIONS`).

    Returns
    -------
    callable
        ``check(value) -> int``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not an int (a bool is
        not one) or is outside ``minimum..maximum``.
    """
    def check(v):
        if not isinstance(v, int) or isinstance(v, bool) or v < minimum:
            raise Invalid(f"expected an integer >= {minimum}, found {_short(v)}")
        if maximum is not None and v > maximum:
            raise Invalid(f"expected an integer {minimum}..{maximum}, found {_short(v)}")
        return v
    return check


def _short(v, n=60):
    """``repr(v)`` cut to about ``n`` characters (a 2 MB string is not echoed back)."""
    text = repr(v)
    return text if len(text) <= n else f"{text[:n]}... ({len(text)} characters)"


def string(pattern=None, what="a string", max_length=MAX_TEXT):
    """Checker of a string of at most ``max_length`` characters, optionally matching a pattern.

    Parameters
    ----------
    pattern : str, optional
        Regular expression the whole string must match (``re.fullmatch``);
        None accepts any string.
    what : str
        Description of the expected value, used in the error message.
    max_length : int
        Most characters accepted (:data:`MAX_TEXT` by default).

    Returns
    -------
    callable
        ``check(value) -> str``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not a string is longer than
        ``max_length`` or does not match ``pattern``.
    """
    def check(v):
        if isinstance(v, str) and len(v) > max_length:
            raise Invalid(f"expected at most {max_length} characters, found {len(v)}")
        if not isinstance(v, str) or (pattern is not None and not re.fullmatch(pattern, v)):
            raise Invalid(f"expected {what}, found {_short(v)}")
        return v
    return check


def boolean():
    """Checker of ``true`` / ``false``.

    Returns
    -------
    callable
        ``check(value) -> bool``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not a bool.
    """
    def check(v):
        if not isinstance(v, bool):
            raise Invalid(f"expected true or false, found {v!r}")
        return v
    return check


def choice(*options):
    """Checker of one string among ``options``.

    Parameters
    ----------
    *options : str
        The accepted values.

    Returns
    -------
    callable
        ``check(value) -> value``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not one of ``options``;
        the message suggests the closest option (difflib).
    """
    def check(v):
        if v not in options:
            hint = difflib.get_close_matches(str(v), options, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise Invalid(f"expected one of {', '.join(map(repr, options))}, found {v!r}{extra}")
        return v
    return check


def name_list(count):
    """Checker of a list of ``count`` strings.

    Parameters
    ----------
    count : int
        Required length of the list.

    Returns
    -------
    callable
        ``check(value) -> list of str``.

    Raises
    ------
    Invalid
        From the returned checker, when the value is not a list of exactly
        ``count`` strings.
    """
    def check(v):
        if not (isinstance(v, list) and len(v) == count and all(isinstance(s, str) for s in v)):
            raise Invalid(f"expected a list of {count} names, found {v!r}")
        return v
    return check


def _amplitudes(v):
    if _is_number(v) and v > 0:
        return float(v)
    if isinstance(v, list) and len(v) == 2 and all(_is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a positive number or two [µm], found {v!r}")


def _frequency_pair(v):
    if isinstance(v, list) and len(v) == 2 and all(_is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two positive frequencies [f_x, f_y] [Hz], found {v!r}")


def _extent_pair(v):
    if isinstance(v, list) and len(v) == 2 and all(_is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two positive extents [fast, slow] [µm], found {v!r}")


def _fraction(upper):
    def check(v):
        if not _is_number(v) or not 0 <= v <= upper:
            raise Invalid(f"expected a fraction of the period in [0, {upper:g}], found {v!r}")
        return float(v)
    return check


def _column_map(v):
    if isinstance(v, dict) and v and all(isinstance(c, str) and c for c in v.values()):
        return dict(v)
    raise Invalid(f"expected a table {{ <output> = \"<column>\" }} of column names, found {v!r}")


@dataclass
class Field:
    """One key of a scenario table.

    Parameters
    ----------
    check : callable
        ``value -> normalised value``; raises :class:`Invalid`.
    required : bool
        Whether the key must be present.
    default : object
        Value when absent (not checked).
    """

    check: Callable[[Any], Any]
    required: bool = False
    default: Any = None


NAME = r"[A-Za-z0-9][A-Za-z0-9._-]*"
_NAME_WHAT = "a name of letters, digits, '.', '_' or '-'"


def name_field():
    """Checker of a name usable as a file name (:data:`NAME`, at most :data:`MAX_NAME` characters).

    Returns
    -------
    callable
        ``check(value) -> str``, raising :class:`Invalid`.
    """
    return string(NAME, _NAME_WHAT, MAX_NAME)

TOP = {
    "name": Field(name_field()),
    "title": Field(string(max_length=200)),
    "description": Field(string()),
    "seed": Field(integer(0), default=0),
    "kind": Field(choice("cases")),  # other kinds: hammerstein.scenario.validate.VALIDATORS
    "plant": Field(lambda v: v, required=True),
    "compensator": Field(lambda v: v),
    "cases": Field(lambda v: v),          # required unless [[sweeps]] are given
    "sweeps": Field(lambda v: v),         # hammerstein.scenario.sweeps: expanded into cases
    "stability_map": Field(lambda v: v),  # hammerstein.scenario.sweeps.check_stability_table
}
PLANT = {
    "preset": Field(string(), required=True),
    "dynamics": Field(boolean(), default=True),
}
CASE = {
    "name": Field(name_field(), required=True),
    "description": Field(string()),
    "reference": Field(lambda v: v),
    "drive": Field(lambda v: v),
    "plant": Field(lambda v: v),
    "compensator": Field(lambda v: v),
    "settle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
    "model": Field(string()),     # drives: a model compared with the plant (scenario.identified)
    "identify": Field(lambda v: v),
}
_PHASE = Field(number("deg"), default=0.0)
_LENGTH = {"periods": Field(number("periods", 0)), "duration": Field(number("s", 0))}
_SINE_REFERENCE = {"output": Field(string(), required=True),
                   "amplitude": Field(number("µm", 0), required=True),
                   "frequency": Field(number("Hz", 0), required=True),
                   "phase": _PHASE, "offset": Field(number("µm"), default=0.0), **_LENGTH}
REFERENCES = {
    "sine": _SINE_REFERENCE,
    "triangle": dict(_SINE_REFERENCE),  # hammerstein.core.references.triangle
    "circle": {"radius": Field(number("µm", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
    "spiral": {"radius": Field(number("µm", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "tau": Field(number("s", 0), required=True),
               "duration": Field(number("s", 0), required=True),
               "circle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
               "phase": _PHASE, "outputs": Field(name_list(2))},
    "lissajous": {"amplitude": Field(_amplitudes, required=True),
                  "frequencies": Field(_frequency_pair, required=True),
                  "phase": _PHASE, "outputs": Field(name_list(2)), **_LENGTH},
    "raster": {"outputs": Field(name_list(2), required=True),     # [fast, slow]
               "size": Field(_extent_pair, required=True),
               "lines": Field(integer(2), required=True),
               "frequency": Field(number("Hz", 0), required=True),  # fast axis (line rate)
               "slow": Field(choice("step", "ramp"), default="step"),
               "smoothing": Field(_fraction(0.5), default=0.0)},
    "file": {"file": Field(string(), required=True),
             "time": Field(string(), default="time"),
             "columns": Field(_column_map, required=True),
             "duration": Field(number("s", 0)),
             "period": Field(number("s", 0))},   # what settle_periods counts (default: T)
}
_SINE_DRIVE = {"input": Field(string(), required=True),
               "amplitude": Field(number("V", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "phase": _PHASE, "offset": Field(number("V"), default=0.0), **_LENGTH}
DRIVES = {
    "sine": _SINE_DRIVE,
    "triangle": dict(_SINE_DRIVE),  # hammerstein.core.references.triangle_drive
}


def check_table(table, schema, where, problems, source):
    """Check a table against a schema, appending problems; return clean dict.

    Unknown keys are reported with the closest valid key (difflib); missing
    required keys and invalid values are reported; defaults are filled in.

    Parameters
    ----------
    table : object
        Parsed TOML value expected to be a table.
    schema : dict of str to Field
    where : str
        Key path prefix (``cases[0].reference``).
    problems : list of str
        Receives ``source: key: message`` lines.
    source : str
        File name.

    Returns
    -------
    dict or None
        Normalised values (None if ``table`` is not a table).
    """
    pre = f"{where}." if where else ""
    if not isinstance(table, dict):
        problems.append(f"{source}: {where}: expected a table, found {table!r}")
        return None
    out = {}
    for key, value in table.items():
        if key not in schema:
            hint = difflib.get_close_matches(key, list(schema), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f" (valid keys: {', '.join(schema)})"
            problems.append(f"{source}: {pre}{key}: unknown key{extra}")
            continue
        try:
            out[key] = schema[key].check(value)
        except Invalid as exc:  # a nested table may report several (subkey, message)
            for sub, msg in getattr(exc, "problems", None) or [(None, str(exc))]:
                problems.append(f"{source}: {pre}{key}{'.' + sub if sub else ''}: {msg}")
    for key, fld in schema.items():
        if key not in table:
            if fld.required:
                problems.append(f"{source}: {pre}{key}: missing (required)")
            elif fld.default is not None:
                out[key] = fld.default
    return out


def kind_problem(kind, kinds):
    """The message of an unknown ``kind`` among ``kinds`` (with the closest one), or [].

    Parameters
    ----------
    kind : object
        The ``kind`` value read from the file.
    kinds : iterable of str
        The known kinds.

    Returns
    -------
    list of str
        One message when ``kind`` is unknown, else empty.
    """
    try:
        choice(*kinds)(kind)
    except Invalid as exc:
        return [str(exc)]
    return []
