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

The ``[model]`` table of a classical PI is read and written by
:mod:`hammerstein.io.model_table` (re-exported here); the other tables' own
equations live in the modules they name.
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
from hammerstein.models.hysteresis import HysteresisError
from hammerstein.models.lti import continuous_system, state_space_dynamics
from hammerstein.models.plant import HammersteinPlant
from hammerstein.core.schema import Field, Invalid, did_you_mean, is_number, known_kind, string
from hammerstein.core.numbers import number_problem
from hammerstein.models.creep import creep_from_table
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.core.lazy import lazy_module
from hammerstein.models.amplifier import amplifier_from_table, records_input_range
from hammerstein.exceptions import AmplifierError, DynamicsWarning, PresetError
from hammerstein.io.sensor import sensor_from_table
from hammerstein.io.model_table import _any, _table_problems, model_from_table, model_to_table

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
    except FileNotFoundError:           # worded as a missing data file is
        raise PresetError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise PresetError(f"{path}: invalid TOML: {exc}") from None
    except RecursionError:  # the parser recurses once per level of [ or {
        raise PresetError(f"{path}: invalid TOML: arrays or inline tables nested too deeply") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8 text
        raise PresetError(f"{path}: invalid TOML: not UTF-8 text (byte {exc.start}: "
                          f"{exc.object[exc.start:exc.start + 1]!r})") from None
    except OSError as exc:
        raise PresetError(f"{path}: cannot read: {exc.strerror}") from None


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
        hysteresis-uy.csv (preset id.toml)"``, which the warnings quote;
        every model carries its ``[model]`` table's ``output_unit`` (µm by
        default), in which the compensators' reference messages give lengths.

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
    for name, value in (("identified_from", origin),
                        ("output_unit", str(data["model"].get("output_unit", "µm")))):
        if value:
            try:
                setattr(model, name, value)
            except AttributeError:      # a model class without instance attributes
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
        (:func:`hammerstein.core.files.provenance_line`, signed with the SHA-256 of the
        text below it, so that ``identify`` does not replace a model edited since, e.g. its
        ``[amplifier]`` widened by hand); written atomically through an exclusive
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
        body = tomli_w.dumps(doc)        # signed: a model edited by hand is not replaced
        safe_write(path, provenance_line("identify", body=body) + body, "model file")
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
        Bundled preset name or preset file, or a model file ``identify``
        wrote (no ``[preset]``: its records' sampling period,
        :func:`records_sampling_period`).
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
    if "preset" not in data and isinstance(data.get("model"), dict) \
            and isinstance(data.get("identification"), dict):
        # the model file identify wrote: the sampling period of its records, as compensate
        # reads it (a scenario's [plant] refused it: "preset.sampling_period: missing")
        try:
            meta = {"sampling_period": records_sampling_period(data, path), "name": path.stem}
        except PresetError as exc:     # its --sampling-period is the commands' option
            raise PresetError(f"{path}: preset.sampling_period: missing (required; "
                              f"{str(exc).removeprefix(f'{path}: ').split('; give')[0]})") from None
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
    plant.units = (str(data["model"].get("input_unit", "V")),
                   str(data["model"].get("output_unit", "µm")))   # checked by load_model
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
