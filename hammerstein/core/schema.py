"""The schema toolkit: :class:`Field`, field checkers, :func:`check_table`, :func:`did_you_mean`.

Every table read from a file is checked by the same machinery: scenario files
(:mod:`hammerstein.scenario.schema` holds their key tables), preset and model
files and dynamics files (:mod:`hammerstein.io.presets`), and the entries of
the kind registries (:data:`hammerstein.signals.references.REFERENCE_KINDS`,
:data:`hammerstein.scenario.registry.COMPENSATORS`). A checker is a callable
``value -> normalised value`` raising :class:`~hammerstein.exceptions.Invalid`
with what was expected; :func:`check_table` collects EVERY problem of a table
as ``file: key: message`` lines; :func:`did_you_mean` is the one place that
suggests the closest valid key or kind (``difflib``).

Examples
--------
>>> from hammerstein.core.schema import Field, check_table, number
>>> problems = []
>>> check_table({"frequncy": 5.0}, {"frequency": Field(number("Hz", 0), required=True)},
...             "reference", problems, "s.toml")
{}
>>> problems[0]
"s.toml: reference.frequncy: unknown key (did you mean 'frequency'?)"
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from typing import Any, Callable


from hammerstein.core.numbers import integer_problem
from hammerstein.core.numbers import is_number as _finite_number
from hammerstein.exceptions import Invalid, NestedInvalid

__all__ = [
    "closest",
    "Field",
    "Invalid",
    "NestedInvalid",
    "check_table",
    "table_problems",
    "nested_table",
    "did_you_mean",
    "kind_problem",
    "known_kind",
    "short_repr",
    "is_number",
    "number",
    "integer",
    "string",
    "boolean",
    "choice",
    "name_list",
    "name_field",
    "NAME",
    "MAX_NAME",
    "MAX_TEXT",
]

#: Longest name (scenario, case, sweep, label): it becomes a file or directory name.
MAX_NAME = 100
#: Longest free text (title, description, preset or model path).
MAX_TEXT = 1000


def did_you_mean(value, options):
    """`` (did you mean 'x'?)`` for the option closest to ``value``, or ``""``.

    Parameters
    ----------
    value : object
        What the file holds (a key or a kind); compared as ``str(value)``.
    options : iterable of str
        The valid keys or kinds.

    Returns
    -------
    str
        The hint with its leading space (difflib's closest match, cut-off
        0.6), or the empty string when nothing is close.

    Examples
    --------
    >>> did_you_mean("circel", ["sine", "circle"])
    " (did you mean 'circle'?)"
    >>> did_you_mean("zzz", ["sine"])
    ''
    """
    hint = closest(value, options)
    return f" (did you mean {hint!r}?)" if hint is not None else ""


def closest(value, options):
    """The option closest to ``value`` (difflib's, cut-off 0.6), or None.

    Parameters
    ----------
    value : object
        Compared as ``str(value)``.
    options : iterable of str

    Returns
    -------
    str or None

    Examples
    --------
    >>> closest("hamerstein", ["hammerstein", "multivariable"])
    'hammerstein'
    """
    hint = difflib.get_close_matches(str(value), [str(o) for o in options], n=1)
    return hint[0] if hint else None


# -- field checkers: value -> normalised value, or raise Invalid -------------------
def is_number(v):
    """Whether ``v`` is a finite int or float (a bool is not a number; see
    :func:`hammerstein.core.numbers.is_number`).

    Parameters
    ----------
    v : object

    Returns
    -------
    bool
    """
    return _finite_number(v)   # huge ints, subnormals, NaN and inf refused (core/numbers.py)


def number(unit, minimum=None, exclusive=True, maximum=None):
    """Checker of a finite number [unit], optionally ``> minimum`` (or ``>=``) and ``<= maximum``.

    Parameters
    ----------
    unit : str
        Unit named in the error message (``"µm"``, ``"Hz"``, ``"s"``, ``"V"``).
    minimum : float, optional
        Lower bound in the same unit; None for no bound.
    exclusive : bool
        Whether the bound is strict (``> minimum``) or not (``>= minimum``).
    maximum : float, optional
        Upper bound (``<= maximum``) in the same unit; None for no bound.

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
        bound += "" if maximum is None else f"{',' if bound else ''} <= {maximum:g}"
        if not is_number(v) or (minimum is not None and (v <= minimum if exclusive else v < minimum)) \
                or (maximum is not None and v > maximum):
            raise Invalid(f"expected a number{bound}{f' [{unit}]' if unit else ''}, "
                          f"found {short_repr(v)}")
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
        :data:`hammerstein.core.numbers.MAX_ITERATIONS`).

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
        if not isinstance(v, int) or isinstance(v, bool):   # a TOML value is a Python int
            bounds = f">= {minimum}" if maximum is None else f"{minimum}..{maximum}"
            raise Invalid(f"expected an integer {bounds}, found {short_repr(v)}")
        problem = integer_problem(v, minimum, maximum)   # the API's checker (core/numbers.py)
        if problem:
            raise Invalid(problem)
        return v
    return check


def short_repr(v, n=60):
    """``repr(v)`` cut to about ``n`` characters (a 2 MB string is not echoed back).

    Parameters
    ----------
    v : object
        Any value read from a file.
    n : int
        Most characters of the repr kept.

    Returns
    -------
    str
        The repr, or its first ``n`` characters and the total length.
    """
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
            raise Invalid(f"expected {what}, found {short_repr(v)}")
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
            extra = did_you_mean(v, options)
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


@dataclass
class Field:
    """One key of a table (scenario, preset, model or dynamics file, registry entry).

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
            extra = did_you_mean(key, schema) or f" (valid keys: {', '.join(schema)})"
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


def known_kind(kind, kinds):
    """Whether ``kind`` is one of ``kinds`` (False for a list or table: no TypeError).

    ``kind in kinds`` raises ``TypeError: unhashable type`` for a list or a
    table read from a file when ``kinds`` is a dict or a set; a file's
    ``kind = []`` is a problem to report with the others, not a crash.

    Parameters
    ----------
    kind : object
        The ``kind`` value read from the file.
    kinds : dict, set or sequence of str
        The known kinds.

    Returns
    -------
    bool

    Examples
    --------
    >>> known_kind(["sine"], {"sine": 1}), known_kind("sine", {"sine": 1})
    (False, True)
    """
    return isinstance(kind, str) and kind in kinds


def table_problems(table, schema, where=""):
    """:func:`check_table` without a file name: ``(clean, ["where.key: message", ...])``.

    Parameters
    ----------
    table : object
        Parsed TOML value expected to be a table.
    schema : dict of str to Field
    where : str
        Key path prefix (``"preset"``); empty for a top-level table.

    Returns
    -------
    clean : dict or None
        Normalised values (None if ``table`` is not a table).
    problems : list of str
        ``where.key: message`` per problem (the caller adds the file name).
    """
    lines = []
    clean = check_table(table, schema, where, lines, "")
    return clean, [line[2:] for line in lines]


def nested_table(value, fields, example, cross=None):
    """Checker body of a nested table: every problem at once, or the normalised table.

    Parameters
    ----------
    value : object
        Parsed TOML value (e.g. the ``identify`` table of a compensator).
    fields : dict of str to Field
        Its schema.
    example : str
        A valid table, named when ``value`` is no table (``"{ frequency = 50.0 }"``).
    cross : callable, optional
        ``cross(clean)`` yields ``"key: message"`` lines of checks across keys.

    Returns
    -------
    dict
        The table with defaults filled.

    Raises
    ------
    Invalid
        When ``value`` is not a table.
    NestedInvalid
        With every ``(key, message)`` problem.
    """
    clean, problems = table_problems(value, fields)
    if clean is None:
        raise Invalid(f"expected a table such as {example}, found {value!r}")
    problems += list(cross(clean)) if cross is not None else []
    if problems:
        raise NestedInvalid([tuple(p.split(": ", 1)) for p in problems])
    return clean
