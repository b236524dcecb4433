"""Record files of a scenario's ``identify = { records = "files", ... }`` table, checked before anything is read whole.

Part of step 1 (:mod:`hammerstein.scenario.validate`): each file named is
there, a regular file within the size limit, and holds the columns the table
names (``time``, ``inputs`` and ``outputs``, by default the plant's names)
at its opening, as :func:`hammerstein.scenario.records_route.file_records`
will read it.
"""

from __future__ import annotations

import re
from pathlib import Path

from hammerstein.core.files import confined_path, escape, file_limit_problem
from hammerstein.io.record_columns import record_column_problems
from hammerstein.io.presets import PresetError
from hammerstein.scenario.identify_tables import (FILES_IDENTIFY_FIELDS, files_table_words,
                                                  record_time, record_unit_problems,
                                                  record_units)
from hammerstein.scenario.schema import Invalid

__all__ = ["record_file_problems", "record_keys"]

#: The keys of a files table that name the records' columns.
_COLUMN_KEYS = ("time", "inputs", "outputs")

#: The keys of a files table that say how its records are read (identify's --sampling-period,
#: --skip-rows, --input-unit, --output-unit).
_READING_KEYS = ("sampling_period", "skip_rows", "input_unit", "output_unit")

#: A unit the units row gives a signal column (the column's unit key names it).
_UNIT_ROW = re.compile(r"^(input|output) column .*: the units row says '([^']*)'")

#: The hint of a header that looks like a preamble's line (the skip_rows key names it).
_PREAMBLE = "(a preamble before the table?"


#: The key of a files table that sets the column a record's problem names.
_COLUMN_KEY = re.compile(r"^(?:no (input|output|time) column|(input|output|time) column "
                         r"|(input) and output are the same column|column .* named twice)")


def _files_text(names):
    shown = ", ".join(names[:3])
    return shown + (f" and {len(names) - 3} more records" if len(names) > 3 else "")


def record_keys(identify):
    """The keys of a files ``identify`` table that failed its check which still name its records.

    A mistake elsewhere in the table (a misspelt ``model``, a bad ``n_hysterons``)
    leaves the records and their columns knowable: the ``*_records`` keys, and
    ``time``, ``inputs`` and ``outputs`` that pass their own checks, are kept.
    A ``time`` that fails its check is kept as None (its column is not looked
    for, nor the default ``'t'``).

    Parameters
    ----------
    identify : dict
        The ``identify`` table as written (``records = "files"``).

    Returns
    -------
    (dict, bool)
        The table for :func:`record_file_problems`, and whether its input and
        output columns are known (False when ``inputs`` or ``outputs`` is
        written but wrong: then only whether each file is there is checked).

    Examples
    --------
    >>> record_keys({"records": "files", "hysteresis_records": "h.csv", "model": "preisch",
    ...              "time": 3, "inputs": "ux,uy"})
    ({'hysteresis_records': ['h.csv'], 'time': None, 'inputs': ['ux', 'uy']}, True)
    """
    kept = {k: [v] if isinstance(v, str) else v for k, v in identify.items()
            if isinstance(v, (str, list)) and str(k).endswith("_records")}
    known = True
    for key in _COLUMN_KEYS + _READING_KEYS:
        if key not in identify:
            continue
        try:
            kept[key] = FILES_IDENTIFY_FIELDS[key].check(identify[key])
        except Invalid:     # reported by the table's check; its column is not known
            if key in ("time", "sampling_period"):
                kept["time"] = None     # a time column meant, or none: not looked for
            else:
                known = False           # the table is not known where it starts, nor its units
    return kept, known


def record_file_problems(identify, base, plant):
    """``identify.<key>: ...`` for each file of a ``records = "files"`` table that is not there.

    A file that is there has its opening read for the columns the table names
    (``time``, ``inputs`` and ``outputs``, by default the plant's names), as
    :func:`~hammerstein.scenario.records_route.file_records` will read them:
    a column problem is named at the key that sets the column, once for all
    the files it holds in (a misspelt output name is one line, not one per
    record). ``inputs`` and ``outputs`` are counted against the plant's.

    Parameters
    ----------
    identify : dict
        The ``identify`` table (checked by
        :func:`hammerstein.scenario.identify_tables.identify_table`, or the
        record keys alone of one that failed that check).
    base : pathlib.Path
        The scenario's directory (relative file names).
    plant : HammersteinPlant or None
        Names the default columns, counts ``inputs`` and ``outputs`` and has the
        units the records are read in (``input_unit`` and ``output_unit`` must
        be those or convert to them, :func:`hammerstein.io.unit_checks.unit_scale`);
        None: only whether each file is there.

    Returns
    -------
    list of str
        ``identify.<key>: message`` per problem, nothing read beyond each
        file's opening (:func:`hammerstein.io.record_columns.record_column_problems`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> base = pathlib.Path(tempfile.mkdtemp())
    >>> record_file_problems({"hysteresis_records": ["gone.csv"]}, base, None)
    ["identify.hysteresis_records: gone.csv: no such file (relative to the scenario's directory)"]
    """
    model = getattr(plant, "hysteresis", None)
    plant_names = {} if model is None else {"inputs": list(model.input_names),
                                            "outputs": list(model.output_names)}
    problems = []
    for key, names in plant_names.items():
        given = identify.get(key)
        if given and len(given) != len(names):
            problems.append(f"identify.{key}: {len(given)} column(s) {given} for the plant's "
                            f"{len(names)} {key} {names}; expected one column per "
                            f"{key[:-1]}, in the plant's order")
    if plant is not None:              # read in the plant's units: these must convert
        problems += record_unit_problems(identify, plant)[1]
    ins = identify.get("inputs") or plant_names.get("inputs")
    outs = identify.get("outputs") or plant_names.get("outputs")
    # a column count that differs from the plant's still has its columns looked for
    check_columns = bool(ins and outs)
    # as file_records reads them: "t" unless given, none with a sampling period alone
    # (None kept: a time key that failed its own check)
    time = identify["time"] if "time" in identify else record_time(identify)
    columns = {}        # (key, problem without the file) -> the files it holds in
    for key in ("hysteresis_records", "dynamics_records", "creep_records"):
        for name in identify.get(key) or []:
            if not isinstance(name, str):
                continue        # reported by the table's check
            try:
                path = confined_path(name, base, PresetError)
            except PresetError as exc:
                problems.append(f"identify.{key}: {exc}")
                continue
            if not Path(path).exists():
                problems.append(f"identify.{key}: {name}: no such file (relative to the "
                                f"scenario's directory)")
                continue
            # a FIFO, a directory, a record beyond the size limit: named before anything is read
            problem = file_limit_problem(path, "data", "record")
            if problem is not None or not check_columns:
                problems.extend([f"identify.{key}: {problem}"] if problem else [])
                continue
            # every column problem of the file, each named at the key that sets its column
            preamble = False
            for problem in record_column_problems(path, ins, outs, time,
                                                  identify.get("skip_rows", 0),
                                                  *record_units(identify, plant)):
                rest = files_table_words(problem.removeprefix(f"{escape(str(path))}: "))
                role = _COLUMN_KEY.match(rest)
                if not role:
                    problems.append(f"identify.{key}: {files_table_words(problem)}")
                    continue
                role = next(r for r in role.groups() if r) if any(role.groups()) else "input"
                setting = "time" if role == "time" else f"{role}s"
                unit = _UNIT_ROW.match(rest)
                if unit:            # read in another unit: declared by the unit's key
                    setting = f"{unit.group(1)}_unit"
                    rest += f", or declare it: identify.{setting} = '{unit.group(2)}'"
                elif _PREAMBLE in rest:   # a preamble read as the header: once per file
                    if preamble:
                        continue
                    setting, preamble = "skip_rows", True
                files = columns.setdefault((setting, rest), [])
                if name not in files:       # a file given as two kinds of record
                    files.append(name)
    for (setting, rest), names in columns.items():
        default = ("" if identify.get(setting) not in (None, "t") or setting.endswith(
                       ("_unit", "_rows")) else
                   " (identify.time is 't' unless given; records without a time column: "
                   "identify.sampling_period [s])" if setting == "time" else
                   f" (identify.{setting} not given: the plant's {setting[:-1]} names were read)")
        problems.append(f"identify.{setting}: {_files_text(names)}: {rest}{default}")
    return problems
