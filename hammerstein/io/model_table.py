"""The ``[model]`` table of a model or preset file, for a classical multivariable PI.

:func:`model_from_table` reads one (every problem reported at once, naming its key) and
:func:`model_to_table` writes one; a table with Preisach, generalised-PI or polynomial
components is read by :func:`hammerstein.models.preisach.hysteresis_from_table`. Both are
re-exported by :mod:`hammerstein.io.presets`, the file formats around them.
"""

from __future__ import annotations

import numpy as np

from hammerstein.core.numbers import MAX_MAGNITUDE
from hammerstein.core.schema import Field, did_you_mean, table_problems
from hammerstein.exceptions import PresetError
from hammerstein.models.hysteresis import (HysteresisError, MultivariablePI, OutputMap,
                                         PrandtlIshlinskii)
from hammerstein.models.preisach import hysteresis_from_table, is_mixed_table

__all__ = ["model_from_table", "model_to_table", "MODEL_KEYS", "OUTPUT_MAP_KEYS",
           "COMPONENT_KEYS"]


def _any(v):
    return v


def _table_problems(table, fields, where):
    """Problems of a table (:func:`hammerstein.core.schema.table_problems`), unknown keys first."""
    _, problems = table_problems(table, fields, where)
    return sorted(problems, key=lambda line: ": unknown key" not in line)


def _huge_numbers(value, key, limit=MAX_MAGNITUDE):
    """Every number of a parsed TOML value whose magnitude exceeds ``limit``.

    Parameters
    ----------
    value : object
        A parsed TOML value (tables, arrays, numbers, strings).
    key : str
        Dotted key of ``value``, used to name each offending entry.
    limit : float
        Largest magnitude accepted (default :data:`~hammerstein.core.numbers.MAX_MAGNITUDE`,
        beyond which the squares of a sum overflow).

    Returns
    -------
    list of (str, float)
        ``(key, value)`` pairs, array entries named ``key[i]``; at most 5.

    Examples
    --------
    >>> _huge_numbers({"components": {"x": {"ux": {"weights": [1.0, 1e300]}}}}, "model")
    [('model.components.x.ux.weights[1]', 1e+300)]
    """
    found = []
    for k, v in _leaves(value, key):
        if len(found) == 5:
            break
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            try:
                x = float(v)
            except OverflowError:     # a TOML integer beyond the float range
                x = float("inf") if v > 0 else -float("inf")
            literal_nonfinite = isinstance(v, float) and not np.isfinite(x)
            if abs(x) > limit and not literal_nonfinite:   # nan/inf: the field's own check names them
                found.append((k, x))
    return found


def _booleans(value, key):
    """Keys (``model.components.x.ux.weights[0]``) of the booleans in a parsed table, at most 5.

    Python's ``True`` is the integer 1: a ``true`` written where a number is
    expected would silently be 1 (a weight, a gain, a threshold).

    Examples
    --------
    >>> _booleans({"components": {"x": {"ux": {"gain": True}}}}, "model")
    ['model.components.x.ux.gain']
    """
    found = [k for k, v in _leaves(value, key)
             if isinstance(v, bool) and not k.endswith(".signed")]   # a Preisach flag (models/preisach)
    return found[:5]


def _leaves(value, key):
    """``(key, value)`` of every value in a parsed table that is neither a table nor an array,
    in the file's order, named as ``model.components.x.ux.weights[0]``."""
    stack = [(key, value)]
    while stack:
        k, v = stack.pop()
        if isinstance(v, dict):
            stack.extend((f"{k}.{name}", item) for name, item in reversed(list(v.items())))
        elif isinstance(v, list):
            stack.extend((f"{k}[{i}]", item) for i, item in reversed(list(enumerate(v))))
        else:
            yield k, v


def model_from_table(table, source="model"):
    """Build a :class:`MultivariablePI` from a parsed ``[model]`` table.

    Parameters
    ----------
    table : dict
        Keys ``inputs``, ``outputs`` (lists of names), optional
        ``input_amplitude`` [V], optional shared ``thresholds`` [V], and
        ``components.<output>.<input>`` tables with ``weights`` [µm/V] and
        optional ``thresholds`` [V], or ``gain`` [µm/V]. Components not
        listed are absent. Optional ``output_offset`` (one value per output)
        and ``output_map.<output>`` tables with ``knots`` (strictly
        increasing, output unit) and ``slopes`` (one more, positive): the
        static output map of the modified PI
        (:class:`~hammerstein.models.hysteresis.OutputMap`). Optional
        ``demagnetised`` and ``demagnetised_centre`` (one value per input [V]):
        the demagnetising cycle every input's plays start after
        (``MultivariablePI.demagnetised``). Optional ``input_centre`` (one
        value per input [V]): the identified input range is ``input_centre +-
        input_amplitude``.
    source : str
        Prefix of error messages (file name).

    Returns
    -------
    MultivariablePI

    Raises
    ------
    PresetError
        Naming the key that is missing or wrong, or a number beyond
        :data:`~hammerstein.core.numbers.MAX_MAGNITUDE` (e.g. a weight of
        1e300, whose outputs would overflow when simulated).
    """
    if not isinstance(table, dict):
        raise PresetError(f"{source}: model: expected a table")
    flags = _booleans(table, "model")
    if flags:       # a boolean where a number is expected would read as 0 or 1
        raise PresetError(f"{source}: " + "; ".join(f"{key}: expected a number, found a boolean"
                                                    for key in flags))
    huge = _huge_numbers(table, "model")
    if huge:
        raise PresetError(f"{source}: " + "; ".join(
            f"{key}: {value:.3g} is beyond the magnitude limit {MAX_MAGNITUDE:.0e}" for key, value in huge))
    units = [f"model.{key}: expected a unit name such as 'V' or 'µm', found {table[key]!r}"
             for key in ("input_unit", "output_unit")
             if key in table and not (isinstance(table[key], str) and table[key].strip())]
    if is_mixed_table(table):   # Preisach / generalised-PI / polynomial components: models/preisach.py
        if units:               # an empty unit would name learn's columns _um (unit_suffix)
            raise PresetError(f"{source}: " + "; ".join(units))
        try:
            return hysteresis_from_table(table, source)
        except HysteresisError as exc:
            raise PresetError(str(exc)) from None
    problems = _table_problems(table, {k: Field(_any) for k in MODEL_KEYS}, "model")
    problems += units
    inputs, outputs = table.get("inputs"), table.get("outputs")
    for key, val in (("inputs", inputs), ("outputs", outputs)):
        if not (isinstance(val, list) and val and all(isinstance(v, str) for v in val)):
            problems.append(f"model.{key}: expected a non-empty list of names")
    if problems:
        raise PresetError(f"{source}: " + "; ".join(problems))
    comps_table = table.get("components", {})
    if not isinstance(comps_table, dict):
        raise PresetError(f"{source}: model.components: expected a table of tables")
    shared_r = table.get("thresholds")
    grid = [[None] * len(inputs) for _ in outputs]
    for out_name, row in comps_table.items():
        if out_name not in outputs:
            problems.append(f"model.components.{out_name}: unknown output (outputs are {outputs})")
            continue
        for in_name, comp in row.items():
            key = f"model.components.{out_name}.{in_name}"
            if in_name not in inputs:
                problems.append(f"{key}: unknown input (inputs are {inputs})")
                continue
            if not isinstance(comp, dict):
                problems.append(f"{key}: expected a table with weights or gain")
                continue
            unknown = sorted(set(comp) - set(COMPONENT_KEYS))
            if unknown:
                problems += [f"{key}.{u}: unknown key{did_you_mean(u, COMPONENT_KEYS)} (expected "
                             f"weights with optional thresholds, or gain)" for u in unknown]
                continue
            try:
                if "gain" in comp:
                    if "weights" in comp:
                        raise HysteresisError("give either gain or weights, not both")
                    g = comp["gain"]
                    if not isinstance(g, (int, float)) or not np.isfinite(g):
                        raise HysteresisError(f"gain: expected a finite number, found {g!r}")
                    value = float(g)
                else:
                    r = comp.get("thresholds", shared_r)
                    if r is None:
                        raise HysteresisError("thresholds: none given here nor in model.thresholds")
                    if "weights" not in comp:
                        raise HysteresisError("weights: missing")
                    value = PrandtlIshlinskii(r, comp["weights"])
            except HysteresisError as exc:
                problems.append(f"{key}: {exc}")
                continue
            grid[outputs.index(out_name)][inputs.index(in_name)] = value
    offset = table.get("output_offset")
    if offset is not None and not (isinstance(offset, list) and len(offset) == len(outputs)
                                   and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                           and np.isfinite(v) for v in offset)):
        problems.append(f"model.output_offset: expected {len(outputs)} finite numbers, one per "
                        f"output, found {offset!r}")
    for key in ("demagnetised", "demagnetised_centre", "input_centre"):
        v = table.get(key)
        if v is not None and not (isinstance(v, list) and len(v) == len(inputs)
                                  and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                          and np.isfinite(x) for x in v)):
            problems.append(f"model.{key}: expected {len(inputs)} finite voltages [V], one per "
                            f"input, found {v!r}")
        elif key == "demagnetised" and v is not None and min(v) < 0:
            problems.append(f"model.demagnetised: expected the cycles' amplitudes >= 0 [V] "
                            f"(0: none), found {v!r}")
    if table.get("demagnetised_centre") is not None and table.get("demagnetised") is None:
        problems.append("model.demagnetised_centre: the centre of a demagnetising cycle needs "
                        "its amplitude, model.demagnetised (one value per input [V])")
    maps = None
    map_table = table.get("output_map")
    if map_table is not None:
        if not isinstance(map_table, dict):
            problems.append("model.output_map: expected a table of [model.output_map.<output>] "
                            "tables")
        else:
            maps = [None] * len(outputs)
            for out_name, entry in map_table.items():
                key = f"model.output_map.{out_name}"
                if out_name not in outputs:
                    problems.append(f"{key}: unknown output (outputs are {outputs})")
                    continue
                if not isinstance(entry, dict):
                    problems.append(f"{key}: expected a table with knots and slopes")
                    continue
                unknown = sorted(set(entry) - set(OUTPUT_MAP_KEYS))
                if unknown:
                    problems += [f"{key}.{u}: unknown key{did_you_mean(u, OUTPUT_MAP_KEYS)} (expected "
                                 f"knots and slopes)" for u in unknown]
                    continue
                try:
                    if "slopes" not in entry:
                        raise HysteresisError("slopes: missing")
                    vals = [entry.get("knots", []), entry["slopes"]]
                    if not all(isinstance(v, list) and all(
                            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
                            for v in vals):
                        raise HysteresisError("knots and slopes: expected lists of numbers")
                    maps[outputs.index(out_name)] = OutputMap(*vals)
                except HysteresisError as exc:
                    problems.append(f"{key}: {exc}")
    if problems:
        raise PresetError(f"{source}: " + "; ".join(problems))
    try:
        return MultivariablePI(grid, input_names=inputs, output_names=outputs,
                               input_amplitude=table.get("input_amplitude"),
                               output_offset=offset, output_map=maps,
                               demagnetised=table.get("demagnetised"),
                               demagnetised_centre=table.get("demagnetised_centre"),
                               input_centre=table.get("input_centre"))
    except HysteresisError as exc:
        raise PresetError(f"{source}: model: {exc}") from None


#: Keys of a ``[model]`` table.
MODEL_KEYS = ("inputs", "outputs", "input_unit", "output_unit", "input_amplitude",
              "thresholds", "output_offset", "components", "output_map", "demagnetised",
              "demagnetised_centre", "input_centre")
#: Keys of one ``[model.output_map.<output>]`` table.
OUTPUT_MAP_KEYS = ("knots", "slopes")
#: Keys of one ``[model.components.<output>.<input>]`` table.
COMPONENT_KEYS = ("weights", "thresholds", "gain")


def model_to_table(model: MultivariablePI, input_unit="V", output_unit="µm"):
    """Inverse of :func:`model_from_table`: a TOML-ready dict.

    Thresholds shared by every hysteresis component are written once as
    ``thresholds``; otherwise each component carries its own. Pure gains are
    written as ``gain``, absent components are left out, a non-zero
    ``output_offset`` is written as a list (one value per output), output
    maps as ``output_map.<output>`` tables (``knots``, ``slopes``), the
    demagnetising cycles the plays start after as ``demagnetised`` (and
    ``demagnetised_centre`` when not 0), one value per input [V].

    Parameters
    ----------
    model : MultivariablePI
        The model to write.
    input_unit, output_unit : str
        Unit names stored with the model (informative; the weights are in
        output unit per input unit).

    Returns
    -------
    dict
        ``[model]`` table of the preset format (see :func:`model_from_table`).
    """
    if not isinstance(model, MultivariablePI):      # mixed components (models/preisach.py)
        return model.to_table(str(input_unit), str(output_unit))
    table = {"inputs": list(model.input_names), "outputs": list(model.output_names),
             "input_unit": str(input_unit), "output_unit": str(output_unit)}
    if model.input_amplitude is not None:
        table["input_amplitude"] = [float(a) for a in model.input_amplitude]
    if model.input_centre is not None:     # the identified range: input_centre +- input_amplitude
        table["input_centre"] = [float(c) for c in model.input_centre]
    if model.output_offset is not None:
        table["output_offset"] = [float(c) for c in model.output_offset]
    if model.demagnetised is not None:      # where the plays start (after demagnetise.csv)
        table["demagnetised"] = [float(a) for a in model.demagnetised]
        if np.any(model.demagnetised_centre):
            table["demagnetised_centre"] = [float(c) for c in model.demagnetised_centre]
    pis = [c for row in model.components for c in row if isinstance(c, PrandtlIshlinskii)]
    shared = all(c.thresholds.shape == pis[0].thresholds.shape
                 and np.array_equal(c.thresholds, pis[0].thresholds) for c in pis)
    if shared:
        table["thresholds"] = [float(v) for v in pis[0].thresholds]
    comps = {}
    for l, out in enumerate(model.output_names):
        for k, inp in enumerate(model.input_names):
            c = model.components[l][k]
            if c is None:
                continue
            if isinstance(c, PrandtlIshlinskii):
                entry = {} if shared else {"thresholds": [float(v) for v in c.thresholds]}
                entry["weights"] = [float(v) for v in c.weights]
            else:
                entry = {"gain": float(c)}
            comps.setdefault(out, {})[inp] = entry
    table["components"] = comps
    if model.output_map is not None:
        table["output_map"] = {out: mp.to_table() for out, mp in zip(model.output_names,
                                                                     model.output_map)
                               if mp is not None}
    return table
