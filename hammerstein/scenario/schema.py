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

import os

from hammerstein.core.schema import (MAX_NAME, MAX_TEXT, NAME, Field, Invalid, NestedInvalid, boolean,
                                     check_table, choice, integer, is_number, kind_problem, name_field,
                                     name_list, number, short_repr, string)
from hammerstein.exceptions import ScenarioError

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
    "NAME",
    "kind_problem",
    "short_repr",
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
    return int(text) if text.isdigit() and int(text) > 0 else MAX_TOTAL_SAMPLES


# -- scenario-specific checkers (the generic ones: hammerstein.core.schema) ---------
def _amplitudes(v):
    if is_number(v) and v > 0:
        return float(v)
    if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a positive number or two [µm], found {v!r}")


def _frequency_pair(v):
    if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two positive frequencies [f_x, f_y] [Hz], found {v!r}")


def _extent_pair(v):
    if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two positive extents [fast, slow] [µm], found {v!r}")


def _fraction(upper):
    def check(v):
        if not is_number(v) or not 0 <= v <= upper:
            raise Invalid(f"expected a fraction of the period in [0, {upper:g}], found {v!r}")
        return float(v)
    return check


def _column_map(v):
    if isinstance(v, dict) and v and all(isinstance(c, str) and c for c in v.values()):
        return dict(v)
    raise Invalid(f"expected a table {{ <output> = \"<column>\" }} of column names, found {v!r}")


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
    "model": Field(string()),     # drives: a model compared with the plant (scenario.identification)
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
