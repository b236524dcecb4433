"""Model and preset files (TOML).

A *model file* holds one ``[model]`` table: a multivariable PI model with its
inputs, outputs, identified input range, shared or per-component thresholds
and weights (or pure gains). A *preset* is a model file with a ``[preset]``
table (name, sampling period) and a ``[dynamics]`` table: a complete
simulated actuator. Identified models are saved in the same format, so the
compensator and the scenarios accept both. The schema is in the README.
A preset may also describe the hardware around the actuator: the amplifier
(``[amplifier]``, :mod:`hammerstein.models.amplifier`) and the position
sensor (``[sensor]``, :mod:`hammerstein.io.sensor`), both checked when the
plant is loaded, every problem of the two reported at once.

Length: one concept, the model and preset file formats (read, check, write,
for the model, the dynamics, the creep and the hardware tables); the tables'
own equations live in the modules they name.
"""

from __future__ import annotations

import tomllib
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import tomli_w

from hammerstein.core.files import (FileLimitError, bounded_read_text, confined_path,
                                    provenance_line, safe_write)
from hammerstein.models.dynamics import DynamicsError, bending_modes, discretize, sampled_bending_modes
from hammerstein.models.hysteresis import (HysteresisError, MultivariablePI, OutputMap,
                                         PrandtlIshlinskii)
from hammerstein.models.lti import continuous_system, state_space_dynamics
from hammerstein.models.plant import HammersteinPlant
from hammerstein.core.schema import (Field, Invalid, did_you_mean, is_number, known_kind, string,
                                     table_problems)
from hammerstein.core.numbers import MAX_MAGNITUDE, number_problem
from hammerstein.models.creep import creep_from_table
from hammerstein.models.preisach import MultivariableHysteresis, hysteresis_from_table, is_mixed_table
from hammerstein.core.lazy import lazy_module
from hammerstein.models.amplifier import amplifier_from_table, records_input_range
from hammerstein.exceptions import AmplifierError, DynamicsWarning, PresetError
from hammerstein.io.sensor import sensor_from_table

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = [
    "PresetError",
    "bundled_presets",
    "resolve_preset",
    "aliased_modes_warning",
    "read_toml",
    "load_creep",
    "records_sampling_period",
    "identified_from",
    "model_from_table",
    "model_to_table",
    "load_model",
    "save_model",
    "load_plant",
    "dynamics_from_table",
    "dynamics_to_table",
    "load_dynamics",
    "save_dynamics",
]


PRESET_DIR = resources.files("hammerstein") / "presets"

#: Keys of a model or preset file, per table (anything else is reported with the closest key;
#: the ``[model]`` keys are :data:`MODEL_KEYS`, ``kind = "state_space"`` dynamics A, B, C, D).
FILE_KEYS = ("model", "preset", "dynamics", "identification", "creep", "amplifier", "sensor")


def _any(v):
    return v


def _positive_time(v):
    if not (is_number(v) and v > 0):
        raise Invalid(f"expected a positive time [s], found {v!r}")
    return float(v)


#: Schemas (:class:`hammerstein.core.schema.Field`) of the tables of a model or preset file:
#: the file's top level, ``[preset]`` and ``[dynamics]`` per kind (its values are checked by
#: :func:`dynamics_from_table`; the ``[model]`` keys are :data:`MODEL_KEYS`).
FILE_FIELDS = {key: Field(_any) for key in FILE_KEYS}
PRESET_FIELDS = {"name": Field(string()), "description": Field(string()),
                 "sampling_period": Field(_positive_time, required=True)}
DYNAMICS_FIELDS = {
    "none": {"kind": Field(_any), "description": Field(_any)},
    "bending_modes": {"kind": Field(_any), "description": Field(_any),
                      "natural_frequency": Field(_any, required=True),
                      "damping_ratio": Field(_any, required=True)},
    "state_space": {"kind": Field(_any), "description": Field(_any),
                    **{k: Field(_any, required=k != "D") for k in "ABCD"}},
}


#: Unit and hint of each numeric [dynamics] value (a unit written in a value, '420 Hz', is named).
DYNAMICS_NUMBERS = {"natural_frequency": ("a positive number [Hz] per output", ""),
                    "damping_ratio": ("a positive number per output",
                                      " (a ratio: 0.03 for 3 %)"),
                    **{k: ("a numeric matrix (list of rows)", "") for k in "ABCD"}}


def _non_number(value):
    """The first entry of ``value`` (a number or nested lists) that is not a real number, or None.

    Booleans are refused (``true`` is not 1 Hz), as are strings with a unit;
    nan and inf are numbers here (the dynamics' own checks name them).
    """
    if isinstance(value, list):
        for v in value:
            bad = _non_number(v)
            if bad is not None:
                return bad
        return None
    # nan, inf and the magnitudes: the dynamics' own checks name them
    return (value,) if number_problem(value) == "not a number" else None


def _dynamics_number_problem(table, source):
    """``source: dynamics.<key>: expected ..., found '420 Hz'`` for a non-numeric value, or None."""
    for key, (what, hint) in DYNAMICS_NUMBERS.items():
        if key in table:
            bad = _non_number(table[key])
            if bad is not None:
                return f"{source}: dynamics.{key}: expected {what}{hint}, found {bad[0]!r}"
    return None


def _table_problems(table, fields, where):
    """Problems of a table (:func:`hammerstein.core.schema.table_problems`), unknown keys first."""
    _, problems = table_problems(table, fields, where)
    return sorted(problems, key=lambda line: ": unknown key" not in line)


def bundled_presets():
    """Names and paths of the presets shipped with the package.

    Returns
    -------
    dict of str to pathlib.Path
    """
    return {Path(p.name).stem: Path(str(p)) for p in PRESET_DIR.iterdir()
            if p.name.endswith(".toml")}


def resolve_preset(name_or_path, base_dir=None):
    """Path of a preset given by bundled name or by file path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A bundled preset name (see :func:`bundled_presets`) or a TOML path,
        relative to ``base_dir`` when not absolute.
    base_dir : pathlib.Path, optional
        Directory of the file that names the preset.

    Returns
    -------
    pathlib.Path
        Path of the preset file.

    Raises
    ------
    PresetError
        If neither a bundled preset nor an existing file matches.
    """
    presets = bundled_presets()
    if str(name_or_path) in presets:
        return presets[str(name_or_path)]
    path = confined_path(str(name_or_path), base_dir, PresetError)  # under the scenario's directory
    if path.exists():  # read_toml refuses a directory or special file, naming it
        return path
    raise PresetError(
        f"{name_or_path}: not a bundled preset ({', '.join(sorted(presets))}) nor an existing "
        f"file{did_you_mean(name_or_path, presets)}")


def read_toml(path, what="TOML file"):
    """Parse a TOML file, with errors that name the file.

    The file must be a regular file of at most
    :func:`hammerstein.core.files.limit` ``("toml")`` bytes (4 MiB, environment
    variable ``HAMMERSTEIN_MAX_TOML_BYTES``), checked before reading.

    Parameters
    ----------
    path : str or pathlib.Path
        TOML file.
    what : str
        What the file should be ("scenario file", ...), for messages.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    PresetError
        If the file is missing, not a regular file, too large, unreadable,
        not UTF-8 or not valid TOML (including nesting too deep to parse).
    """
    path = Path(path)
    try:
        return tomllib.loads(bounded_read_text(path, "toml", what))
    except FileLimitError as exc:
        raise PresetError(str(exc)) from None
    except FileNotFoundError:
        raise PresetError(f"{path}: file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise PresetError(f"{path}: invalid TOML: {exc}") from None
    except RecursionError:  # the parser recurses once per level of [ or {
        raise PresetError(f"{path}: invalid TOML: arrays or inline tables nested too deeply") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8 text
        raise PresetError(f"{path}: invalid TOML: not UTF-8 text (byte {exc.start}: "
                          f"{exc.object[exc.start:exc.start + 1]!r})") from None
    except OSError as exc:
        raise PresetError(f"{path}: cannot read: {exc.strerror}") from None


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
        (:class:`~hammerstein.models.hysteresis.OutputMap`).
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
    if is_mixed_table(table):   # Preisach / generalised-PI / polynomial components: models/preisach.py
        try:
            return hysteresis_from_table(table, source)
        except HysteresisError as exc:
            raise PresetError(str(exc)) from None
    problems = _table_problems(table, {k: Field(_any) for k in MODEL_KEYS}, "model")
    for key in ("input_unit", "output_unit"):
        if key in table and not (isinstance(table[key], str) and table[key].strip()):
            problems.append(f"model.{key}: expected a unit name such as 'V' or 'µm', "
                            f"found {table[key]!r}")
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
                               output_offset=offset, output_map=maps)
    except HysteresisError as exc:
        raise PresetError(f"{source}: model: {exc}") from None


#: Keys of a ``[model]`` table.
MODEL_KEYS = ("inputs", "outputs", "input_unit", "output_unit", "input_amplitude",
              "thresholds", "output_offset", "components", "output_map")
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
    maps as ``output_map.<output>`` tables (``knots``, ``slopes``).

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
    if model.output_offset is not None:
        table["output_offset"] = [float(c) for c in model.output_offset]
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


def load_model(path):
    """Read the ``[model]`` table of a model or preset file.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    MultivariablePI
        A model identified from records (an ``[identification]`` table with
        ``sources``, written by ``hammerstein identify``) carries
        ``identified_from``, e.g. ``"records hysteresis-ux.csv,
        hysteresis-uy.csv (preset id.toml)"``, which the warnings quote.

    Raises
    ------
    PresetError
    """
    data = read_toml(path, "model file")
    if "model" not in data:
        raise PresetError(f"{path}: missing [model] table")
    problems = _table_problems(data, FILE_FIELDS, "")
    if problems:
        raise PresetError(f"{path}: " + "; ".join(problems))
    model = model_from_table(data["model"], str(path))
    origin = identified_from(data, path)
    if origin:
        try:
            model.identified_from = origin
        except AttributeError:          # a model class without instance attributes
            pass
    if isinstance(model, MultivariableHysteresis):   # the inputs it was identified on
        model.input_range = records_input_range(data.get("amplifier"), model.input_names)
    return model


def identified_from(data, path):
    """``"records A.csv, B.csv (preset NAME.toml)"`` for a file written by ``hammerstein identify``.

    Parameters
    ----------
    data : dict
        The parsed file.
    path : str or pathlib.Path
        The file.

    Returns
    -------
    str or None
        None when the file has no ``[identification]`` table with ``sources``.
    """
    ident = data.get("identification")
    sources = ident.get("sources") if isinstance(ident, dict) else None
    if not isinstance(sources, list) or not sources:
        return None
    return (f"records {', '.join(Path(str(s)).name for s in sources)} "
            f"(preset {Path(str(path)).name})")


def save_model(model, path, metadata=None, input_unit="V", output_unit="µm", extra=None):
    """Write a model file that :func:`load_model` and scenarios accept.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Any model class (classical or modified PI, Preisach, generalised PI,
        mixed), as ``identify`` writes it.
    path : str or pathlib.Path
        Destination ``.toml``, starting with the project's provenance line
        (:func:`hammerstein.core.files.provenance_line`); written atomically through an exclusive
        temporary file and a rename (:func:`hammerstein.core.files.safe_write`:
        a symlink's target is written, a replaced file keeps its permissions,
        a new one gets the umask's).
    metadata : dict, optional
        Stored as an ``[identification]`` table (method, frequency, fit
        metrics...).
    input_unit, output_unit : str
        Units stored in the ``[model]`` table.
    extra : dict, optional
        Further top-level tables (e.g. ``preset`` and ``dynamics`` of a
        preset file).

    Raises
    ------
    PresetError
        The target exists and is not a regular file (a directory, device...).
    OSError
        The directory cannot be created or written.
    """
    doc = {}
    if metadata:
        doc["identification"] = metadata
    doc.update(extra or {})
    doc["model"] = model_to_table(model, input_unit, output_unit)
    try:
        safe_write(path, provenance_line("identify") + tomli_w.dumps(doc), "model file")
    except FileLimitError as exc:
        raise PresetError(str(exc)) from None


def dynamics_from_table(table, outputs, source="preset", build=True):
    """Continuous-time linear dynamics from a ``[dynamics]`` table, or None.

    ``kind = "bending_modes"`` with ``natural_frequency`` [Hz] and
    ``damping_ratio`` per output (decoupled, unit DC gain);
    ``kind = "state_space"`` with continuous-time matrices ``A`` (n x n)
    [1/s], ``B`` (n x p), ``C`` (p x n) and optional ``D`` (p x p) as arrays
    of arrays: inputs are the p PI outputs [µm], outputs the p displacements
    [µm] (e.g. identified by ``hammerstein identify --dynamics``);
    off-diagonal (dynamic cross-coupling) terms are allowed, the DC gain is
    whatever the matrices give (see
    :func:`hammerstein.models.lti.dc_gain`); ``kind = "none"`` for a static
    plant.

    Parameters
    ----------
    table : dict
        The parsed ``[dynamics]`` table.
    outputs : list of str
        Output names of the preset's PI model (p of them).
    source : str
        Prefix of error messages (file name).
    build : bool
        False: bending modes are returned as ``("bending_modes",
        natural_frequency, damping_ratio)`` (their keys checked) for
        :func:`hammerstein.models.dynamics.sampled_bending_modes` (no
        python-control; it checks the values).

    Returns
    -------
    control.StateSpace, tuple or None
        Continuous-time p x p system (None for ``kind = "none"``; a tuple
        for bending modes with ``build=False``).

    Raises
    ------
    PresetError
        Naming the key: ``dynamics.A: expected ...`` (shape, finiteness,
        stability of A, p = number of outputs).
    """
    if not isinstance(table, dict):
        raise PresetError(f"{source}: dynamics: expected a table")
    kind = table.get("kind", "none")
    if not known_kind(kind, DYNAMICS_FIELDS):
        raise PresetError(f"{source}: dynamics.kind: expected 'bending_modes', 'state_space' or "
                          f"'none', found {kind!r}{did_you_mean(kind, DYNAMICS_FIELDS)}")
    problems = _table_problems(table, DYNAMICS_FIELDS[kind], "dynamics")
    if problems:
        raise PresetError(f"{source}: " + "; ".join(problems))
    if kind == "none":
        return None
    problem = _dynamics_number_problem(table, source)
    if problem:
        raise PresetError(problem)
    if kind == "state_space":
        p = len(outputs)
        shapes = {}
        for key in ("A", "B", "C", "D"):
            if key in table:
                try:
                    shapes[key] = np.shape(np.array(table[key], dtype=float))
                except (TypeError, ValueError):
                    raise PresetError(f"{source}: dynamics.{key}: expected a numeric matrix "
                                      f"(list of rows)") from None
        if len(shapes["A"]) != 2 or shapes["A"][0] != shapes["A"][1] or shapes["A"][0] == 0:
            raise PresetError(f"{source}: dynamics.A: expected a non-empty square matrix (one row "
                              f"and one column per state), found shape {shapes['A']}")
        n = shapes["A"][0]
        expected = {"B": ((n, p), "one row per state of A, one column per PI output"),
                    "C": ((p, n), "one row per displacement, one column per state of A"),
                    "D": ((p, p), "one row per displacement, one column per PI output")}
        for key, shape in shapes.items():
            if key != "A" and shape != expected[key][0]:
                raise PresetError(f"{source}: dynamics.{key}: expected shape {expected[key][0]} "
                                  f"({expected[key][1]}; {p} outputs, {n} states), found {shape}")
        try:
            return state_space_dynamics(table["A"], table["B"], table["C"], table.get("D"),
                                        names=outputs)
        except DynamicsError as exc:
            raise PresetError(f"{source}: {exc}") from None
    for key in ("natural_frequency", "damping_ratio"):
        if len(np.atleast_1d(table[key])) != len(outputs):
            raise PresetError(f"{source}: dynamics.{key}: expected {len(outputs)} values, one per output")
    if not build:
        return ("bending_modes", table["natural_frequency"], table["damping_ratio"])
    try:
        return bending_modes(table["natural_frequency"], table["damping_ratio"], outputs)
    except DynamicsError as exc:
        raise PresetError(f"{source}: dynamics.{exc}") from None


def dynamics_to_table(system):
    """A ``[dynamics]`` table (``kind = "state_space"``) of a continuous or discrete system.

    A discrete system is written as its continuous ZOH equivalent
    (:func:`hammerstein.models.lti.continuous_system`), so that
    :func:`load_dynamics` at the same sampling period gives it back.

    Parameters
    ----------
    system : control.StateSpace
        p x p system.

    Returns
    -------
    dict
        TOML-ready ``{"kind": "state_space", "A": [[..]], "B", "C", "D"}``.
    """
    mats = system
    if system.isdtime(strict=True):
        try:
            mats = continuous_system(system)
        except DynamicsError:              # e.g. a real pole at z <= 0: keep it discrete
            return {"kind": "discrete_state_space", "sampling_period": float(system.dt),
                    **{k: np.asarray(getattr(system, k), dtype=float).tolist() for k in "ABCD"}}
    return {"kind": "state_space",
            **{k: np.asarray(getattr(mats, k), dtype=float).tolist() for k in "ABCD"}}


def records_sampling_period(data, path):
    """The sampling period [s] of the records a model file was identified from.

    ``identify`` writes ``[identification] sampling_period_s``, one entry per
    record; a model file then needs no ``--sampling-period``.

    Parameters
    ----------
    data : dict
        The model file's TOML data.
    path : str or pathlib.Path
        The file, for messages.

    Returns
    -------
    float
        [s].

    Raises
    ------
    PresetError
        No such entry, a value that is not a positive finite number, or records sampled at
        different periods (the message asks for ``--sampling-period S``).
    """
    ident = data.get("identification") if isinstance(data, dict) else None
    periods = ident.get("sampling_period_s") if isinstance(ident, dict) else None
    periods = periods if isinstance(periods, list) else [periods]
    values = [float(v) for v in periods if isinstance(v, (int, float)) and not isinstance(v, bool)]
    if not values or len(values) != len(periods) or not all(np.isfinite(values)) \
            or min(values) <= 0:
        raise PresetError(f"{path}: the model file gives no sampling period ([identification] "
                          f"sampling_period_s, written by identify); give --sampling-period S")
    if max(values) > min(values) * (1 + 1e-9):
        shown = ", ".join(f"{v:g}" for v in sorted(set(values)))
        raise PresetError(f"{path}: the model's records were sampled at different periods "
                          f"({shown} s, [identification] sampling_period_s); give "
                          f"--sampling-period S")
    return values[0]


def load_creep(path, outputs):
    """The ``[creep]`` of a preset file, one entry per output, or None without creep.

    Parameters
    ----------
    path : str or pathlib.Path
        TOML file (e.g. written by ``hammerstein identify --creep-records``).
    outputs : list of str
        Output names of the plant (p).

    Returns
    -------
    list of (Creep or None) or None
        None when the file has no ``[creep]`` table or none of its outputs creeps.

    Raises
    ------
    PresetError
        A malformed ``[creep]`` table (names the key).
    """
    data = read_toml(path)
    creeps = _creep(data.get("creep"), list(outputs), path)
    return creeps if creeps is not None and any(c is not None for c in creeps) else None


def aliased_modes_warning(table, sampling_period, source):
    """Warn (:class:`DynamicsWarning`) of the modes of a ``[dynamics]`` table at or above Nyquist.

    Sampled at ``T``, a mode at or above ``1 / (2 T)`` is aliased to a lower
    frequency: the simulated plant no longer has it, and a compensator
    inverting it inverts a mode the samples cannot carry.

    Parameters
    ----------
    table : dict
        A checked ``[dynamics]`` table (``bending_modes``: its
        ``natural_frequency``; ``state_space``: the oscillating eigenvalues
        of ``A``, at ``|lambda| / (2 pi)``).
    sampling_period : float
        T [s] the dynamics are discretised at.
    source : str
        The file, at the front of the message.

    Returns
    -------
    str or None
        The warning's message (also emitted), or None.
    """
    nyquist = 0.5 / float(sampling_period)
    if table.get("kind", "none") == "bending_modes":
        key, freqs = "natural_frequency", np.atleast_1d(np.asarray(table["natural_frequency"], float))
    elif table.get("kind") == "state_space":
        lam = np.linalg.eigvals(np.asarray(table["A"], dtype=float))
        key, freqs = "A", np.abs(lam[lam.imag > 0]) / (2 * np.pi)
    else:
        return None
    above = freqs[freqs >= nyquist]
    if not above.size:
        return None
    modes = ", ".join(f"{f:g}" for f in above)
    message = (f"{source}: dynamics.{key}: the mode{'s' if above.size > 1 else ''} at {modes} Hz "
               f"{'are' if above.size > 1 else 'is'} at or above the Nyquist frequency "
               f"{nyquist:g} Hz of the sampling period {float(sampling_period):g} s: aliased when "
               f"sampled (the plant does not have {'them' if above.size > 1 else 'it'} at that "
               f"frequency, and {'their' if above.size > 1 else 'its'} inverse is meaningless); "
               f"sample faster or check the value")
    warnings.warn(message, DynamicsWarning, stacklevel=3)
    return message


def load_dynamics(path, outputs, sampling_period):
    """The discrete linear dynamics G of a dynamics or preset file.

    Parameters
    ----------
    path : str or pathlib.Path
        TOML file with a ``[dynamics]`` table (a preset, or a file written
        by :func:`save_dynamics`).
    outputs : list of str
        Output names of the plant (p).
    sampling_period : float
        T [s] of the plant; the continuous dynamics are discretised (ZOH) at it.

    Returns
    -------
    control.StateSpace
        Discrete p x p system.

    Raises
    ------
    PresetError
        Missing file, no ``[dynamics]`` table, ``kind = "none"``, wrong size.
    """
    data = read_toml(path)
    if "dynamics" not in data:
        raise PresetError(f"{path}: missing [dynamics] table")
    table = data["dynamics"]
    if isinstance(table, dict) and table.get("kind") == "discrete_state_space":
        dt = table.get("sampling_period")
        if not isinstance(dt, (int, float)) or not np.isclose(dt, sampling_period):
            raise PresetError(f"{path}: dynamics.sampling_period: expected the plant's "
                              f"{sampling_period:g} s for discrete dynamics, found {dt!r}")
        try:
            sysc = state_space_dynamics(-np.eye(len(table["A"])), table["B"], table["C"],
                                        table.get("D"), names=outputs)   # shapes and finiteness
        except (DynamicsError, KeyError, TypeError) as exc:
            raise PresetError(f"{path}: {exc}") from None
        A = np.asarray(table["A"], dtype=float)
        if np.max(np.abs(np.linalg.eigvals(A))) >= 1:
            raise PresetError(f"{path}: dynamics.A: expected a stable discrete system (|z| < 1)")
        return control.ss(A, sysc.B, sysc.C, sysc.D, dt=float(dt))
    cont = dynamics_from_table(data["dynamics"], list(outputs), str(path))
    if cont is None:
        raise PresetError(f"{path}: dynamics.kind: 'none' has no dynamics to invert")
    aliased_modes_warning(data["dynamics"], sampling_period, str(path))
    return discretize(cont, float(sampling_period))


def save_dynamics(system, path, metadata=None):
    """Write a dynamics file (``[dynamics] kind = "state_space"``) that :func:`load_dynamics` reads.

    Parameters
    ----------
    system : control.StateSpace
        p x p system (a discrete one is saved as its continuous ZOH equivalent).
    path : str or pathlib.Path
        Destination, written atomically through an exclusive temporary file
        and a rename (:func:`hammerstein.core.files.safe_write`).
    metadata : dict, optional
        Stored as an ``[identification]`` table.

    Raises
    ------
    PresetError
        The target exists and is not a regular file, or is read-only.
    OSError
        The directory cannot be created or written.
    """
    doc = {"identification": metadata} if metadata else {}
    doc["dynamics"] = dynamics_to_table(system)
    try:
        safe_write(path, tomli_w.dumps(doc), "dynamics file")
    except FileLimitError as exc:
        raise PresetError(str(exc)) from None


def load_plant(preset, dynamics=True, base_dir=None):
    """Build the simulated actuator of a preset.

    Parameters
    ----------
    preset : str or pathlib.Path
        Bundled preset name or preset file.
    dynamics : bool
        ``True`` for the Hammerstein plant (hysteresis, creep when the preset
        has a ``[creep]`` table, discretised linear dynamics); ``False`` for
        the static (rate-independent) hysteresis alone, without creep.
    base_dir : pathlib.Path, optional
        Directory that relative paths are resolved from.

    Returns
    -------
    HammersteinPlant
        With ``amplifier`` (:class:`hammerstein.models.amplifier.Amplifier`
        or None) and ``sensor`` (the checked ``[sensor]`` table, a dict, or
        None) from the preset's hardware tables.

    Raises
    ------
    PresetError
        A problem of the file; the ``[amplifier]`` and ``[sensor]`` tables'
        problems are listed together, each naming its key.
    """
    path = resolve_preset(preset, base_dir)
    data = read_toml(path, "preset file")
    meta = data.get("preset", {})
    dyn = data.get("dynamics", {})
    if not isinstance(meta, dict) or not isinstance(dyn, dict):
        raise PresetError(f"{path}: {'preset' if not isinstance(meta, dict) else 'dynamics'}: "
                          f"expected a table")
    problems = _table_problems(meta, PRESET_FIELDS, "preset")
    fields = DYNAMICS_FIELDS["state_space" if dyn.get("kind") == "state_space" else "bending_modes"]
    problems += [q for q in _table_problems(dyn, fields, "dynamics") if ": unknown key" in q]
    problems.sort(key=lambda line: ": unknown key" not in line)
    if problems:
        raise PresetError(f"{path}: " + "; ".join(problems))
    T = meta["sampling_period"]
    model = load_model(path)
    lin = None
    if dynamics:
        cont = dynamics_from_table(dyn, model.output_names, str(path), build=False)
        if isinstance(cont, tuple):  # bending modes: sampled without python-control
            try:
                lin = sampled_bending_modes(*cont[1:], model.output_names, float(T))
            except DynamicsError as exc:
                raise PresetError(f"{path}: dynamics.{exc}") from None
        elif cont is not None:
            lin = discretize(cont, float(T))
        if cont is not None:
            aliased_modes_warning(dyn, T, str(path))
    name = meta.get("name", path.stem)
    creep = _creep(data.get("creep"), model.output_names, path)   # checked in both cases
    plant = HammersteinPlant(model, float(T), lin, name=name, creep=creep if dynamics else None)
    problems = []                      # the hardware: amplifier and sensor, reported together
    try:                               # hammerstein.models.amplifier
        plant.amplifier = amplifier_from_table(data.get("amplifier"), model.input_names, str(path))
    except AmplifierError as exc:
        problems.append(str(exc))
    try:                               # hammerstein.io.sensor
        plant.sensor = sensor_from_table(data.get("sensor"), str(path))
    except PresetError as exc:
        problems.append(str(exc))
    if problems:
        raise PresetError("; ".join(problems))
    return plant


def _creep(table, outputs, path):
    """The ``[creep.<output>]`` tables of a preset (models/creep.py), one entry per output."""
    if table is None:
        return None
    if not isinstance(table, dict):
        raise PresetError(f"{path}: creep: expected a table of [creep.<output>] tables")
    unknown = [k for k in table if k not in outputs]
    if unknown:
        raise PresetError(f"{path}: creep.{unknown[0]}: unknown output (outputs are {outputs})")
    try:
        return [creep_from_table(table[o], f"creep.{o}") if o in table else None for o in outputs]
    except HysteresisError as exc:
        raise PresetError(f"{path}: {exc}") from None
