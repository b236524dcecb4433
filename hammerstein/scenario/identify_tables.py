"""Identification tables of scenario files: ``identify`` and ``identify_dynamics`` (checked, nothing run).

A compensator table (or an open-loop drive case that compares a model with
the plant) may name the model "identified at f Hz on this plant"::

    model = "identified"
    identify = { frequency = 50.0, amplitude = 10.0, periods = 3, n_hysterons = 15,
                 method = "least-squares", partition = "time", bounds = "monotone",
                 sensor = false, seed = 0 }

``model = "classical" | "preisach" | "auto"`` (default ``"classical"``) is
the class identified: a classical PI from sine records at ``frequency``
(the keys above), or a discrete Preisach model (30 levels per input) from
decreasing-amplitude sine records at that frequency (minor loops, as
``hammerstein excitation`` records them), or the one of the two with the
lower held-out minor-loop error (as ``hammerstein identify --model auto``).

With ``records = "excitation"`` the table runs ``hammerstein identify``'s
route on records that ``hammerstein excitation`` writes, played through the
plant (:data:`RECORDS_IDENTIFY_FIELDS`); with ``records = "files"`` on the
user's own measured records, named relative to the scenario::

    identify = { records = "files", hysteresis_records = ["meas/hysteresis-ux.csv"],
                 dynamics_records = ["meas/multisine-ux.csv"], time = "t",
                 inputs = ["ux"], outputs = ["x"] }

(:data:`FILES_IDENTIFY_FIELDS`: the files ``identify`` takes, with its
options and defaults; ``inputs`` and ``outputs`` default to the plant's
names, ``time`` to ``"t"`` unless ``sampling_period`` [s] is given
(:func:`record_time`); ``skip_rows``, ``input_unit``, ``output_unit`` and
``thresholds`` are ``identify --skip-rows``, ``--input-unit``,
``--output-unit`` and ``--thresholds r1,r2,...``; unlike ``identify``, the
scenario reads the records and thresholds in its plant's units,
:func:`hammerstein.io.unit_checks.unit_scale`). Both routes call the
pipeline ``identify`` calls.

Only ``frequency`` is required (:data:`IDENTIFY_FIELDS` lists the defaults);
``kind = "hammerstein"`` has its own defaults
(:data:`HAMMERSTEIN_IDENTIFY_DEFAULTS`) and an ``identify_dynamics`` table
(:data:`IDENTIFY_DYNAMICS_FIELDS`). The identification itself is
:mod:`hammerstein.scenario.identification`.
"""

from __future__ import annotations

import math
import re

from hammerstein.core.schema import closest, did_you_mean, nested_table
from hammerstein.exceptions import NestedInvalid
from hammerstein.identification.defaults import PREISACH_LEVELS, smoothing_option
from hammerstein.io.unit_checks import unit_scale
from hammerstein.signals.excitation import REVERSALS
from hammerstein.scenario.schema import (MAX_HYSTERONS, MAX_IDENTIFY_PERIODS, Field, Invalid, boolean,
                                         choice, integer, number, short_repr, string)

__all__ = [
    "IDENTIFY_FIELDS",
    "RECORDS_IDENTIFY_FIELDS",
    "FILES_IDENTIFY_FIELDS",
    "record_time",
    "record_units",
    "record_unit_problems",
    "files_table_words",
    "identify_table",
    "HAMMERSTEIN_IDENTIFY_DEFAULTS",
    "hammerstein_identify_table",
    "IDENTIFY_DYNAMICS_FIELDS",
    "identify_dynamics_table",
    "nyquist_problem",
    "comparison_spec",
    "dynamics_source",
    "preisach_smoothing",
]


def preisach_smoothing(v):
    """A table's ``preisach_smoothing``, checked: as ``identify --preisach-smoothing``.

    Parameters
    ----------
    v : str or float
        ``"auto"`` or the Preisach density's smoothing weight lambda >= 0 [-].

    Returns
    -------
    str or float
        ``"auto"`` or the weight.

    Raises
    ------
    Invalid
        Saying what was expected (the schema names the key).

    Examples
    --------
    >>> preisach_smoothing(3e-5), preisach_smoothing("auto")
    (3e-05, 'auto')
    """
    try:
        return smoothing_option(v)
    except ValueError as exc:
        raise Invalid(str(exc)) from None


def _bounds(v):
    if v in ("none", "nonnegative", "monotone"):
        return v
    if (isinstance(v, list) and len(v) == 2
            and all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in v)
            and v[0] < v[1]):
        return [float(a) for a in v]
    hint = choice("none", "nonnegative", "monotone")
    try:
        hint(v)
    except Invalid as exc:
        raise Invalid(f"{exc}, or [lo, hi] weight bounds [µm/V]") from None
    return v


def _n_hysterons(v):
    if isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_HYSTERONS:
        return v
    if (isinstance(v, list) and v and all(isinstance(r, list) and r for r in v)
            and all(isinstance(a, int) and not isinstance(a, bool) and 1 <= a <= MAX_HYSTERONS
                    for r in v for a in r)):
        return v
    raise Invalid(f"expected an integer 1..{MAX_HYSTERONS} or a p x m table of them, "
                  f"found {short_repr(v)}")


def _reversals(v):
    if v == "standard":
        return [float(a) for a in REVERSALS]
    if (isinstance(v, list) and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                    and -1 < a < 1 for a in v) and len(set(v)) == len(v)):
        return [float(a) for a in v]
    raise Invalid(f"expected \"standard\" or a list of distinct fractions in (-1, 1) (the "
                  f"reversal points of the first-order reversal curves; [] for none), found "
                  f"{short_repr(v)}")


def _range(v):
    if (isinstance(v, list) and len(v) == 2 and all(isinstance(a, (int, float))
                                                    and not isinstance(a, bool) for a in v)
            and all(math.isfinite(a) for a in v) and v[0] < v[1]):
        return [float(a) for a in v]
    raise Invalid(f"expected [low, high] [V] with low < high (the amplifier's range, as "
                  f"excitation --range), found {short_repr(v)}")


def _components(v):
    """``"auto"``, ``"all"`` or ``"OUTPUT:INPUT=pi|gain|none,..."`` (the names are checked
    against the plant's when the scenario is resolved)."""
    text = string()(v)
    if text.strip() in ("auto", "all"):
        return text.strip()
    for part in text.split(","):
        name, _, kind = part.partition("=")
        out, colon, inp = name.partition(":")
        if not (colon and out.strip() and inp.strip() and kind.strip() in ("pi", "gain", "none")):
            raise Invalid(f"expected \"auto\", \"all\" or OUTPUT:INPUT=pi|gain|none entries "
                          f"separated by commas, found {short_repr(part.strip())}")
    return text


def _amplitude(v):
    if isinstance(v, list):
        return [number("V", 0)(a) for a in v]
    return number("V", 0)(v)


#: Schema of the ``identify`` table: key -> Field (checker, default).
IDENTIFY_FIELDS = {
    "frequency": Field(number("Hz", 0), required=True),
    "amplitude": Field(_amplitude),                       # default: plant's input_amplitude
    "periods": Field(integer(2, MAX_IDENTIFY_PERIODS), default=3),
    "n_hysterons": Field(_n_hysterons, default=15),
    "method": Field(choice("closed-form", "least-squares"), default="closed-form"),
    "partition": Field(choice("time", "input"), default="time"),
    "bounds": Field(_bounds, default="none"),
    "sensor": Field(boolean(), default=False),
    "seed": Field(integer(0), default=0),
    # absent = "classical" (the content keys of existing scenarios, and their results, unchanged)
    "model": Field(choice("classical", "preisach", "auto")),
}


def _train_fraction(v):
    if isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v <= 1:
        return float(v)
    raise Invalid(f"expected a fraction in (0, 1] (of each record trained on; the rest is held "
                  f"out), found {short_repr(v)}")


def _thresholds(v):
    """Explicit thresholds, as ``identify --thresholds r1,r2,...``: increasing, >= 0, at most
    :data:`MAX_HYSTERONS` of them [input unit]."""
    if (isinstance(v, list) and 0 < len(v) <= MAX_HYSTERONS
            and all(isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a)
                    for a in v)
            and v[0] >= 0 and all(b > a for a, b in zip(v, v[1:]))):
        return [float(a) for a in v]
    raise Invalid(f"expected a list of 1 to {MAX_HYSTERONS} increasing thresholds >= 0 [input "
                  f"unit] (as identify --thresholds r1,r2,...), found {short_repr(v)}")


#: Schema of an ``identify`` table with ``records = "excitation"``: the records of
#: ``hammerstein excitation`` played through the plant, identified by the pipeline of
#: ``hammerstein identify`` (:func:`hammerstein.identification.identification_pipeline.identify_pipeline`)
#: with its options and defaults: every class (``model``), creep staircases (``creep``).
RECORDS_IDENTIFY_FIELDS = {
    "records": Field(choice("excitation", "files"), required=True),
    "amplitude": Field(_amplitude),                       # default: plant's input_amplitude
    "range": Field(_range),                               # instead: excitation --range
    "slew_rate": Field(number("V/s", 0)),                 # excitation --slew-rate
    "frequency": Field(number("Hz", 0), default=1.0),     # of the decreasing-amplitude sines
    "hold": Field(number("s", 0), default=2.0),           # of each staircase step
    "multisine_periods": Field(integer(2, MAX_IDENTIFY_PERIODS), default=4),
    # the hysteresis records' first-order reversal curves (hammerstein excitation --reversals;
    # "standard" for its standard points)
    "reversals": Field(_reversals, default=[]),
    "model": Field(choice("auto", "classical", "preisach", "generalized"), default="auto"),
    "method": Field(choice("least-squares", "closed-form"), default="least-squares"),
    "n_hysterons": Field(integer(1, MAX_HYSTERONS), default=15),
    "thresholds": Field(_thresholds),          # as --thresholds r1,r2,... (n_hysterons: N)
    "partition": Field(choice("auto", "time", "input"), default="auto"),
    "bounds": Field(choice("none", "nonnegative", "monotone"), default="none"),
    "components": Field(_components, default="auto"),
    "output_map": Field(choice("auto", "none", "deadzone"), default="auto"),
    "preisach_levels": Field(integer(2, 60), default=PREISACH_LEVELS),
    "preisach_smoothing": Field(preisach_smoothing, default="auto"),   # --preisach-smoothing
    "threshold_spacing": Field(choice("uniform", "power", "auto"), default="uniform"),
    "level_weighting": Field(choice("amplitude", "none"), default="amplitude"),
    "record_start": Field(choice("demagnetised", "rest"), default="demagnetised"),
    "hold_out": Field(choice("auto", "none"), default="auto"),   # as --hold-out
    "train_fraction": Field(_train_fraction),              # as --train-fraction
    "skip": Field(number("s", 0, exclusive=False)),        # as --skip (burn-in)
    "creep": Field(boolean(), default=False),              # identify the creep from staircases
    "creep_refits": Field(integer(0, 5)),                  # default: by class, as identify
    "order": Field(integer(1, 50)),                        # of G; default chosen on held-out data
    "max_order": Field(integer(1, 50)),
    "sensor": Field(boolean(), default=False),
    "seed": Field(integer(0), default=0),
}


def _file_list(v):
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(f, str) and f.strip() for f in v):
        raise Invalid(f"expected a file name or a non-empty list of file names (relative to "
                      f"the scenario), found {short_repr(v)}")
    return [f.strip() for f in v]


def _columns(v):
    if isinstance(v, str):
        v = [c.strip() for c in v.split(",")]
    if not isinstance(v, list) or not v or not all(isinstance(c, str) and c for c in v):
        raise Invalid(f"expected column names (a list or \"a,b\"), found {short_repr(v)}")
    return list(v)


def _unit(v):
    text = string()(v)
    if not text.strip():
        raise Invalid(f"expected a unit name such as 'V', 'mV', 'µm' or 'nm', found {text!r}")
    return text


def _delay(v):
    if v == "auto":
        return v
    if isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 10_000:
        return v
    raise Invalid(f"expected \"auto\" or a number of samples >= 0, found {short_repr(v)}")


#: Options of the identification pipeline shared by both records routes.
_PIPELINE_KEYS = ("model", "method", "n_hysterons", "thresholds", "partition", "bounds",
                  "components", "output_map", "preisach_levels", "preisach_smoothing",
                  "threshold_spacing",
                  "level_weighting",
                  "record_start", "creep_refits", "order", "max_order", "hold_out",
                  "train_fraction", "skip")

#: Schema of an ``identify`` table with ``records = "files"``: the user's measured records
#: (the files ``hammerstein identify`` takes: the hysteresis records, the broadband records of
#: ``--dynamics-records``, the staircases of ``--creep-records``), identified by the same
#: pipeline with the same options and defaults.
FILES_IDENTIFY_FIELDS = {
    "records": Field(choice("files"), required=True),
    "hysteresis_records": Field(_file_list, required=True),
    "dynamics_records": Field(_file_list),       # as --dynamics --dynamics-records
    "creep_records": Field(_file_list),          # as --creep-records
    "time": Field(string()),                     # the time column; default "t" (none with
                                                 # sampling_period): see record_time
    "sampling_period": Field(number("s", 0, maximum=1e6)),   # as --sampling-period
    "skip_rows": Field(integer(0), default=0),   # as --skip-rows (a preamble's lines)
    # as --input-unit/--output-unit; read in the plant's units (records_route.in_plant_units);
    # default: the plant's (record_units)
    "input_unit": Field(_unit),
    "output_unit": Field(_unit),
    "inputs": Field(_columns),                   # default: the plant's input names
    "outputs": Field(_columns),                  # default: the plant's output names
    "delay": Field(_delay, default="auto"),      # as --delay (auto: from the dynamics records)
    **{k: RECORDS_IDENTIFY_FIELDS[k] for k in _PIPELINE_KEYS},
}


def record_time(spec):
    """The time column a files table reads: ``time``, else ``"t"``, else none.

    As ``identify --time`` and ``--sampling-period``: a table without
    ``time`` reads the column ``t``, unless it gives ``sampling_period``
    (records without a time column); with both, the time column is read and
    its step must agree with ``sampling_period``.

    Parameters
    ----------
    spec : dict
        A files ``identify`` table (checked or as written).

    Returns
    -------
    str or None

    Examples
    --------
    >>> record_time({}), record_time({"sampling_period": 1e-4}), record_time({"time": "s"})
    ('t', None, 's')
    """
    if spec.get("time") is not None:
        return spec["time"]
    return None if spec.get("sampling_period") is not None else "t"


def record_units(spec, plant=None):
    """The units a files table's records are in: ``input_unit`` and ``output_unit``, else the plant's.

    A table without them reads its records in its plant's units (those of the
    preset's ``[model]``, V and µm for every bundled preset): records in mV and
    nm for a plant in mV and nm (a model file ``identify`` wrote from them) are
    not converted. (A default of V and µm multiplied them by 1000: the model's
    error was 1000 times its outputs, without a word.)

    Parameters
    ----------
    spec : dict
        A files ``identify`` table (checked or as written).
    plant : HammersteinPlant or None
        Its ``units``; None (or none given): V and µm.

    Returns
    -------
    tuple of str
        ``(input unit, output unit)``.

    Examples
    --------
    >>> record_units({}), record_units({"output_unit": "nm"})
    (('V', 'µm'), ('V', 'nm'))
    """
    units = getattr(plant, "units", None) or ("V", "µm")
    return (spec.get("input_unit") or units[0], spec.get("output_unit") or units[1])


def record_unit_problems(spec, plant=None):
    """``identify.<unit key>: ...`` for each of a files table's units that does not convert to
    its plant's (:func:`hammerstein.io.unit_checks.unit_scale`), and the factors of those that do.

    Parameters
    ----------
    spec : dict
        A files ``identify`` table (checked or as written: a unit that is no string is
        left to the table's own check).
    plant : HammersteinPlant or None
        Its ``units``; None: V and µm.

    Returns
    -------
    scales : list of float or None
        Per role (input, output): the factor to the plant's unit; None where it does not
        convert or is no string.
    problems : list of str
        One line per unit that does not convert.

    Examples
    --------
    >>> record_unit_problems({"output_unit": "nm"})
    ([1.0, 0.001], [])
    """
    units = getattr(plant, "units", None) or ("V", "µm")
    scales, problems = [], []
    for key, given, to, role in zip(("input_unit", "output_unit"), record_units(spec, plant),
                                    units, ("input", "output")):
        scale = None
        if isinstance(given, str):
            try:
                scale = unit_scale(given, to, role)
            except ValueError as exc:
                problems.append(f"identify.{key}: {exc}")
        scales.append(scale)
    return scales, problems


#: ``identify``'s options in the words of reading a record, and the files table's keys.
_OPTION_KEYS = ((re.compile(r"--skip-rows (\w+)"), r"identify.skip_rows = \1"),
                (re.compile(r"--sampling-period(?: S\b)?"), "identify.sampling_period"),
                (re.compile(r"--input-unit\b"), "identify.input_unit"),
                (re.compile(r"--output-unit\b"), "identify.output_unit"))


def files_table_words(text):
    """A message about reading a record, with ``identify``'s options named as the files table's keys.

    The reading of a record (:func:`hammerstein.io.datafiles.read_records`,
    :func:`hammerstein.io.unit_checks.unit_warnings`) names the command's
    options in its hints (``--skip-rows N``, ``--sampling-period``,
    ``--output-unit``); a scenario's files table sets them with its keys.

    Parameters
    ----------
    text : str

    Returns
    -------
    str

    Examples
    --------
    >>> files_table_words("skip them with --skip-rows 3, or give --sampling-period S")
    'skip them with identify.skip_rows = 3, or give identify.sampling_period'
    """
    for pattern, key in _OPTION_KEYS:
        text = pattern.sub(key, text)
    return text


def identify_table(value):
    """Field checker of an ``identify`` table (all problems at once).

    With ``records = "excitation"`` the table is checked against
    :data:`RECORDS_IDENTIFY_FIELDS` (the options of ``hammerstein identify``),
    with ``records = "files"`` (measured records) against
    :data:`FILES_IDENTIFY_FIELDS`.

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled (``amplitude`` stays absent when not
        given: the plant model's ``input_amplitude`` is used; ``n_hysterons``
        when ``thresholds`` are given: their length is the count).

    Raises
    ------
    NestedInvalid
        Listing ``(key, message)`` for every problem (unknown keys with the
        closest valid key, missing ``frequency``, bad values).
    """
    def cross(clean):
        if clean.get("bounds", "none") != "none" and clean.get("method") != "least-squares" \
                and clean.get("model", "classical") == "classical":
            yield "bounds: only used by method = 'least-squares'"

    def cross_pipeline(clean, creep):
        """The combinations ``hammerstein identify`` refuses (its usage errors), by key."""
        if clean.get("bounds", "none") != "none" and clean.get("method") == "closed-form":
            yield "bounds: only used by method = 'least-squares'"
        if clean.get("output_map") == "deadzone" and clean.get("method") == "closed-form":
            yield "output_map: 'deadzone' only used by method = 'least-squares'"
        if clean.get("model") in ("preisach", "generalized") and clean.get("method") == "closed-form":
            yield (f"method: model = '{clean['model']}' is fitted by least squares; leave out "
                   f"method = 'closed-form'")
        if "order" in clean and "max_order" in clean:
            yield "order: give order or max_order, not both"
        if clean.get("train_fraction") is not None and clean.get("hold_out") == "none":
            yield "train_fraction: give train_fraction or hold_out = 'none', not both"
        # identify's one --thresholds takes a count or a list: any count written beside a list
        # (15 as well, which was ignored without a word); a validated table with a list holds
        # no count (_count_or_list), so that validating it again finds none
        if "thresholds" in clean and isinstance(value, dict) and "n_hysterons" in value:
            yield ("thresholds: give n_hysterons (a count) or thresholds (a list), not both "
                   "(identify --thresholds takes one of them)")
        # a count equal to the default (15) is what a table validated before holds (the route
        # validates it again), and what identify's --thresholds 15 is: not a count given
        count = isinstance(value, dict) and value.get("n_hysterons", 15) != 15
        for key, given in (("thresholds", "thresholds" in clean), ("n_hysterons", count)):
            if given and clean.get("model") in ("preisach", "generalized"):
                # fitted into the classical PI alone: with another class, ignored
                yield (f"{key}: only used by model = 'classical' or 'auto' (the classical "
                       f"PI's hysterons), found model = '{clean['model']}'"
                       + (" (its grid: preisach_levels)" if clean["model"] == "preisach"
                          else " (its plays: threshold_spacing)"))
        if clean.get("creep_refits") is not None and not creep:
            yield ("creep_refits: only used with creep_records" if clean.get("records") == "files"
                   else "creep_refits: only used with creep = true")

    if isinstance(value, dict) and value.get("records") not in (None, "files", "excitation") \
            and (closest(value["records"], ["excitation", "files"]) == "files"
                 or any(str(k).endswith("_records") for k in value)):
        # a misspelt "files": the rest checked as a files table, not called unknown key by key
        try:
            choice("excitation", "files")(value["records"])
        except Invalid as exc:
            problems = [("records", str(exc))]
        try:
            identify_table({**value, "records": "files"})
        except NestedInvalid as exc:
            problems += exc.problems
        raise NestedInvalid(problems)
    if isinstance(value, dict) and value.get("records") == "files":
        def cross_files(clean):
            yield from cross_pipeline(clean, bool(clean.get("creep_records")))
            for key in ("order", "max_order"):
                if key in clean and not clean.get("dynamics_records"):
                    yield f"{key}: only used with dynamics_records"

        return _count_or_list(nested_table(value, FILES_IDENTIFY_FIELDS,
                                           '{ records = "files", hysteresis_records = [...] }',
                                           cross_files))
    if isinstance(value, dict) and "records" in value:
        def cross_records(clean):
            yield from cross_pipeline(clean, clean.get("creep"))
            if clean.get("amplitude") is not None and clean.get("range") is not None:
                yield "amplitude: give amplitude or range (excitation --range), not both"

        return _count_or_list(nested_table(value, RECORDS_IDENTIFY_FIELDS,
                                           '{ records = "excitation" }', cross_records))
    try:
        return nested_table(value, IDENTIFY_FIELDS, "{ frequency = 50.0 }", cross)
    except NestedInvalid as exc:
        # a misspelt `records` selects the sine route, whose keys do not hold it: "recrods"
        # was met with "did you mean 'periods'?"
        problems = []
        for key, msg in exc.problems:
            hint = did_you_mean(key, ["records"]) if msg.startswith("unknown key") else ""
            problems.append((key, f"unknown key{hint} (the route of `hammerstein identify` on "
                                  f"excitation records)" if hint else msg))
        raise NestedInvalid(problems) from None


def _count_or_list(clean):
    """A validated records table without the default count beside a thresholds list.

    The list's length is the count (as identify's ``--thresholds r1,r2,...``); the default
    ``n_hysterons`` left beside it would be taken, on validating the table again, for a
    count written beside the list.
    """
    if "thresholds" in clean:
        clean.pop("n_hysterons", None)
    return clean


def nyquist_problem(spec, plant):
    """``identify.frequency: ...`` when the excitation of ``spec`` is not below the plant's Nyquist frequency.

    Parameters
    ----------
    spec : dict
        Validated ``identify`` table (:func:`identify_table`).
    plant : HammersteinPlant

    Returns
    -------
    str or None
        The problem, or None when ``frequency < 1 / (2 T)``.
    """
    f, nyquist = spec["frequency"], 0.5 / plant.sampling_period
    if f >= nyquist:
        return f"identify.frequency: {f:g} Hz is beyond the Nyquist frequency {nyquist:g} Hz of the plant"
    return None


def comparison_spec(case, mode):
    """Check the ``model`` / ``identify`` keys of a case (no model is loaded or identified).

    Parameters
    ----------
    case : dict
        The raw ``[[cases]]`` table: ``model`` ("identified", "plant" or a
        model file path) and, with "identified", ``identify``
        (:data:`IDENTIFY_FIELDS`).
    mode : {'drive', 'reference'}
        Only drives may name a comparison model.

    Returns
    -------
    dict
        ``{"model": ..., "identify": validated table}`` (``identify`` only
        with "identified").

    Raises
    ------
    ValueError
        One ``key: message`` per line (unknown ``identify`` keys with hints,
        a reference case, a missing table).
    """
    name = case.get("model")
    lines = []
    if mode != "drive":
        lines.append("model: a model is compared with the plant in open-loop drive cases only; "
                     "the compensator's model is compensator.model")
    if not isinstance(name, str):
        lines.append(f"model: expected 'identified', 'plant' or a model file path, found {name!r}"
                     if "model" in case else
                     "identify: only used with model = 'identified' (add model = \"identified\")")
    spec = {"model": name}
    if name == "identified":
        if "identify" not in case:
            lines.append("identify: missing (required with model = 'identified'), "
                         "e.g. identify = { frequency = 50.0 }")
        else:
            try:
                spec["identify"] = identify_table(case["identify"])
            except Invalid as exc:
                lines += [f"identify.{k}: {m}" for k, m in getattr(exc, "problems", [])] \
                    or [f"identify: {exc}"]
    elif "identify" in case and isinstance(name, str):
        lines.append(f"identify: only used with model = 'identified', found model = {name!r}")
    if lines:
        raise ValueError("\n".join(lines))
    return spec


#: ``identify`` defaults of ``kind = "hammerstein"``: least squares with monotone direct
#: transfers on 40 hysterons (time partition: dense near the reversals) and 5 periods (the
#: sensor noise averages out; the static error at small radii is the lever once G is
#: inverted). Any key given in the scenario overrides these.
HAMMERSTEIN_IDENTIFY_DEFAULTS = {"method": "least-squares", "bounds": "monotone",
                                 "partition": "time", "n_hysterons": 40, "periods": 5}


def hammerstein_identify_table(value):
    """Field checker of the ``identify`` table of ``kind = "hammerstein"``.

    As :func:`identify_table`, with :data:`HAMMERSTEIN_IDENTIFY_DEFAULTS`
    for the keys not given.

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled.

    Raises
    ------
    NestedInvalid
        As :func:`identify_table`.
    """
    if isinstance(value, dict) and "records" not in value:   # records: identify's own defaults
        value = {**HAMMERSTEIN_IDENTIFY_DEFAULTS, **value}
    return identify_table(value)


def _band(v):
    if (isinstance(v, list) and len(v) == 2 and all(isinstance(a, (int, float))
                                                    and not isinstance(a, bool) for a in v)
            and 0 < v[0] < v[1]):
        return [float(a) for a in v]
    raise Invalid(f"expected [f_min, f_max] in Hz with 0 < f_min < f_max, found {v!r}")


#: Schema of the ``identify_dynamics`` table (defaults: 8 V random-phase multisines on
#: each input in turn, 20 Hz-1 kHz, 8 periods of 50 ms, order chosen from the data).
IDENTIFY_DYNAMICS_FIELDS = {
    "excitation": Field(choice("multisine"), default="multisine"),
    "amplitude": Field(number("V", 0), default=8.0),
    "band": Field(_band, default=[20.0, 1000.0]),
    "period": Field(number("s", 0), default=0.05),
    "periods": Field(integer(2, MAX_IDENTIFY_PERIODS), default=8),
    "order": Field(integer(1, 50)),                    # default: chosen by held-out fit
    "max_order": Field(integer(1, 50), default=8),
    "sensor": Field(boolean()),                        # default: as identify.sensor
    "seed": Field(integer(0), default=1),
}


def identify_dynamics_table(value):
    """Field checker of an ``identify_dynamics`` table (every key optional).

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled (``order`` and ``sensor`` stay absent
        when not given: chosen from the data, and as ``identify.sensor``).

    Raises
    ------
    NestedInvalid
        Listing ``(key, message)`` for every problem.
    """
    def cross(clean):
        if "order" in clean and clean["order"] > clean["max_order"]:
            yield "order: expected <= max_order"

    return nested_table(value, IDENTIFY_DYNAMICS_FIELDS,
                         "{ amplitude = 8.0, band = [20.0, 1000.0] }", cross)



def dynamics_source(spec):
    """Where the G of a ``kind = "hammerstein"`` compensator table comes from.

    Parameters
    ----------
    spec : dict
        The (validated) compensator table.

    Returns
    -------
    str
        ``spec["dynamics"]`` when given, else ``"identified"`` with
        ``model = "identified"`` and ``"plant"`` (the plant's true dynamics)
        otherwise.
    """
    return spec.get("dynamics") or ("identified" if spec.get("model") == "identified" else "plant")
