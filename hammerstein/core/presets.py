"""Model and preset files (TOML).

A *model file* holds one ``[model]`` table: a multivariable PI model with its
inputs, outputs, identified input range, shared or per-component thresholds
and weights (or pure gains). A *preset* is a model file with a ``[preset]``
table (name, sampling period) and a ``[dynamics]`` table: a complete
simulated actuator. Identified models are saved in the same format, so the
compensator and the scenarios accept both. The schema is in the README.
"""

from __future__ import annotations

import difflib
import os
import tempfile
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import tomli_w

from hammerstein.core.dynamics import DynamicsError, bending_modes, discretize
from hammerstein.core.hysteresis import HysteresisError, MultivariablePI, PrandtlIshlinskii
from hammerstein.core.plant import HammersteinPlant
from hammerstein.exceptions import PresetError

__all__ = [
    "PresetError",
    "bundled_presets",
    "resolve_preset",
    "read_toml",
    "model_from_table",
    "model_to_table",
    "load_model",
    "save_model",
    "load_plant",
]


PRESET_DIR = resources.files("hammerstein") / "presets"


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
    path = Path(name_or_path)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if path.is_file():
        return path
    raise PresetError(
        f"{name_or_path}: not a bundled preset ({', '.join(sorted(presets))}) nor an existing file")


def read_toml(path):
    """Parse a TOML file, with errors that name the file.

    Parameters
    ----------
    path : str or pathlib.Path
        TOML file.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    PresetError
        If the file is missing, unreadable, not UTF-8 or not valid TOML.
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise PresetError(f"{path}: file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise PresetError(f"{path}: invalid TOML: {exc}") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8 text
        raise PresetError(f"{path}: invalid TOML: not UTF-8 text (byte {exc.start}: "
                          f"{exc.object[exc.start:exc.start + 1]!r})") from None
    except OSError as exc:
        raise PresetError(f"{path}: cannot read: {exc.strerror}") from None


def model_from_table(table, source="model"):
    """Build a :class:`MultivariablePI` from a parsed ``[model]`` table.

    Parameters
    ----------
    table : dict
        Keys ``inputs``, ``outputs`` (lists of names), optional
        ``input_amplitude`` [V], optional shared ``thresholds`` [V], and
        ``components.<output>.<input>`` tables with ``weights`` [µm/V] and
        optional ``thresholds`` [V], or ``gain`` [µm/V]. Components not
        listed are absent.
    source : str
        Prefix of error messages (file name).

    Returns
    -------
    MultivariablePI

    Raises
    ------
    PresetError
        Naming the key that is missing or wrong.
    """
    if not isinstance(table, dict):
        raise PresetError(f"{source}: model: expected a table")
    problems = [f"model.{key}: unknown key{_hint(key, MODEL_KEYS)}"
                for key in table if key not in MODEL_KEYS]
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
                problems += [f"{key}.{u}: unknown key{_hint(u, COMPONENT_KEYS)} (expected "
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
    if problems:
        raise PresetError(f"{source}: " + "; ".join(problems))
    try:
        return MultivariablePI(grid, input_names=inputs, output_names=outputs,
                               input_amplitude=table.get("input_amplitude"),
                               output_offset=offset)
    except HysteresisError as exc:
        raise PresetError(f"{source}: model: {exc}") from None


#: Keys of a ``[model]`` table.
MODEL_KEYS = ("inputs", "outputs", "input_unit", "output_unit", "input_amplitude",
              "thresholds", "output_offset", "components")
#: Keys of one ``[model.components.<output>.<input>]`` table.
COMPONENT_KEYS = ("weights", "thresholds", "gain")


def _hint(key, known):
    close = difflib.get_close_matches(str(key), known, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def model_to_table(model: MultivariablePI, input_unit="V", output_unit="µm"):
    """Inverse of :func:`model_from_table`: a TOML-ready dict.

    Thresholds shared by every hysteresis component are written once as
    ``thresholds``; otherwise each component carries its own. Pure gains are
    written as ``gain``, absent components are left out, a non-zero
    ``output_offset`` is written as a list (one value per output).

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
    return table


def load_model(path):
    """Read the ``[model]`` table of a model or preset file.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    MultivariablePI

    Raises
    ------
    PresetError
    """
    data = read_toml(path)
    if "model" not in data:
        raise PresetError(f"{path}: missing [model] table")
    return model_from_table(data["model"], str(path))


def save_model(model, path, metadata=None, input_unit="V", output_unit="µm", extra=None):
    """Write a model file that :func:`load_model` and scenarios accept.

    Parameters
    ----------
    model : MultivariablePI
    path : str or pathlib.Path
        Destination ``.toml``; written atomically (a unique temporary file
        next to it, then a rename).
    metadata : dict, optional
        Stored as an ``[identification]`` table (method, frequency, fit
        metrics...).
    input_unit, output_unit : str
        Units stored in the ``[model]`` table.
    extra : dict, optional
        Further top-level tables (e.g. ``preset`` and ``dynamics`` of a
        preset file).
    """
    path = Path(path)
    doc = {}
    if metadata:
        doc["identification"] = metadata
    doc.update(extra or {})
    doc["model"] = model_to_table(model, input_unit, output_unit)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    tmp = Path(name)
    try:
        with os.fdopen(fd, "wb") as fh:
            tomli_w.dump(doc, fh)
        os.chmod(tmp, 0o644)   # mkstemp makes it private; a model file is shared
        tmp.replace(path)
    except BaseException:  # no half-written model file left behind
        tmp.unlink(missing_ok=True)
        raise


def dynamics_from_table(table, outputs, source="preset"):
    """Continuous-time linear dynamics from a ``[dynamics]`` table, or None.

    ``kind = "bending_modes"`` with ``natural_frequency`` [Hz] and
    ``damping_ratio`` per output; ``kind = "state_space"`` with continuous
    matrices ``A`` (n, n) [1/s], ``B`` (n, p), ``C`` (p, n), ``D`` (p, p)
    (p inputs: the PI outputs, p outputs: the displacements; e.g. identified
    by ``hammerstein identify --dynamics``); ``kind = "none"`` for a static
    plant.

    Parameters
    ----------
    table : dict
        The parsed ``[dynamics]`` TOML table.
    outputs : sequence of str
        Output names, p of them: one mode per output, and the names given to
        the system's inputs and outputs.
    source : str
        File name used as the prefix of error messages.

    Returns
    -------
    control.StateSpace or None
        Continuous-time system with p inputs [µm] and p outputs [µm]
        (2p states for bending modes), or None for ``kind = "none"``.

    Raises
    ------
    PresetError
        On an unknown ``kind``, a missing or unknown key, a value count that
        is not one per output, a matrix of the wrong shape or with non-finite
        entries, or invalid modal parameters.
    """
    kind = table.get("kind", "none")
    if kind == "none":
        return None
    if kind == "state_space":
        return _state_space(table, outputs, source)
    if kind != "bending_modes":
        raise PresetError(f"{source}: dynamics.kind: expected 'bending_modes', 'state_space' or "
                          f"'none', found {kind!r}")
    for key in ("natural_frequency", "damping_ratio"):
        if key not in table:
            raise PresetError(f"{source}: dynamics.{key}: missing")
        if len(np.atleast_1d(table[key])) != len(outputs):
            raise PresetError(f"{source}: dynamics.{key}: expected {len(outputs)} values, one per output")
    try:
        return bending_modes(table["natural_frequency"], table["damping_ratio"], outputs)
    except DynamicsError as exc:
        raise PresetError(f"{source}: dynamics.{exc}") from None


def _state_space(table, outputs, source):
    import control
    unknown = sorted(set(table) - {"kind", "A", "B", "C", "D"})
    if unknown:
        raise PresetError(f"{source}: dynamics.{unknown[0]}: unknown key"
                          f"{_hint(unknown[0], ('A', 'B', 'C', 'D'))}")
    p = len(outputs)
    mats = {}
    for key in ("A", "B", "C", "D"):
        if key not in table:
            if key == "D":
                mats[key] = np.zeros((p, p))
                continue
            raise PresetError(f"{source}: dynamics.{key}: missing (kind = 'state_space')")
        try:
            arr = np.array(table[key], dtype=float)
        except (TypeError, ValueError):
            raise PresetError(f"{source}: dynamics.{key}: expected a matrix (list of rows)") from None
        if arr.ndim != 2 or not np.all(np.isfinite(arr)):
            raise PresetError(f"{source}: dynamics.{key}: expected a finite matrix (list of rows)")
        mats[key] = arr
    n = mats["A"].shape[0]
    expected = {"A": (n, n), "B": (n, p), "C": (p, n), "D": (p, p)}
    for key, shape in expected.items():
        if mats[key].shape != shape:
            raise PresetError(f"{source}: dynamics.{key}: expected shape {shape} for {p} outputs "
                              f"and {n} states, found {mats[key].shape}")
    return control.ss(mats["A"], mats["B"], mats["C"], mats["D"],
                      inputs=[f"{o}_h" for o in outputs], outputs=list(outputs),
                      name="state_space")


def load_plant(preset, dynamics=True, base_dir=None):
    """Build the simulated actuator of a preset.

    Parameters
    ----------
    preset : str or pathlib.Path
        Bundled preset name or preset file.
    dynamics : bool
        ``True`` for the Hammerstein plant (PI + discretised linear
        dynamics, ZOH with python-control); ``False`` for the static PI.
    base_dir : pathlib.Path, optional
        Directory that relative paths are resolved from.

    Returns
    -------
    HammersteinPlant

    Raises
    ------
    PresetError
    """
    path = resolve_preset(preset, base_dir)
    data = read_toml(path)
    meta = data.get("preset", {})
    if "sampling_period" not in meta:
        raise PresetError(f"{path}: preset.sampling_period: missing (seconds)")
    T = meta["sampling_period"]
    if not isinstance(T, (int, float)) or not T > 0:
        raise PresetError(f"{path}: preset.sampling_period: expected a positive time [s], found {T!r}")
    model = load_model(path)
    lin = None
    if dynamics:
        cont = dynamics_from_table(data.get("dynamics", {}), model.output_names, str(path))
        lin = discretize(cont, float(T)) if cont is not None else None
    name = meta.get("name", path.stem)
    return HammersteinPlant(model, float(T), lin, name=name)
