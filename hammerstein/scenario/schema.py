"""Scenario files (TOML): the key tables and the bounds of a scenario.

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
This module holds the key tables of a scenario file and its bounds; the
generic machinery (:class:`~hammerstein.core.schema.Field`, the checkers,
:func:`~hammerstein.core.schema.check_table`) is :mod:`hammerstein.core.schema`,
the keys of each reference and drive kind are their registry entries
(:data:`hammerstein.signals.references.REFERENCE_KINDS`,
:data:`hammerstein.signals.references.DRIVE_KINDS`), those of each compensator
kind :data:`hammerstein.scenario.registry.COMPENSATORS`.
"""

from __future__ import annotations

import os

from hammerstein.core.schema import (MAX_NAME, MAX_TEXT, NAME, Field, Invalid, NestedInvalid, boolean,
                                     check_table, choice, integer, kind_problem, known_kind,
                                     name_field,
                                     name_list, number, short_repr, string)
from hammerstein.core.numbers import MAX_HYSTERONS as _MAX_HYSTERONS
from hammerstein.core.numbers import MAX_ITERATIONS as _MAX_ITERATIONS
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
    "known_kind",
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
#: Most fixed-point iterations per sample of a compensator (the API's bound, core/numbers.py).
MAX_ITERATIONS = _MAX_ITERATIONS
#: Most cases of a scenario (after expanding the sweeps).
MAX_CASES = 2000
#: Most hysterons per component of an identified model.
MAX_HYSTERONS = _MAX_HYSTERONS
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
