"""Build the compensator to export from a preset or a model file, and write the files.

``hammerstein export`` resolves ``MODEL_OR_PRESET`` (a bundled preset name, a
preset file with ``[preset]`` and optionally ``[dynamics]`` / ``[amplifier]``,
or a model file with a ``[model]`` table), builds the compensator of the
requested kind with the same defaults as the scenario files
(``hammerstein.scenario.registry``), and writes the generated files only
where hammerstein wrote them before (:func:`check_owned`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator,
                                           PerAxisInverseCompensator, StaticGainCompensator,
                                           diagonal_compensator)
from hammerstein.core.files import (FileLimitError, all_or_nothing, bounded_read_bytes,
                                    output_problem, safe_write)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.compensation.mixed_compensators import MIXED_KINDS, mixed_compensator
from hammerstein.compensation.model_classes import kind_problem, model_class
from hammerstein.io.presets import (load_creep, load_dynamics, load_model, load_plant, read_toml,
                                    records_sampling_period, resolve_preset)
from hammerstein.exceptions import CompensatorError, DynamicsError, ExportError, PresetError
from hammerstein.export.c_code import AmplifierLimits
from hammerstein.export.fmu import fmu_owned

__all__ = ["KINDS", "REFUSED_KINDS", "ExportSource", "load_source",
           "compensator_from_source", "limits_from_table",
           "check_owned", "check_fmu_owned", "write_files"]

#: Exportable compensator kinds: name -> description.
KINDS = {
    "multivariable": "inverse multiplicative law of Theorem 4.1, normalised by K",
    "diagonal": "the same law on the direct transfers only",
    "per-axis": "per-axis analytic inverse PI of Kuhnen & Janocha",
    "static-gain": "U = K^-1 Yr, no hysteresis compensation",
    "hammerstein": "ZPETC inverse of the linear dynamics (and of the creep), then the "
                   "multivariable law (a classical PI) or the exact inverse (Preisach, "
                   "generalised PI)",
    "preisach-inverse": "exact per-sample inverse of a Preisach or generalised-PI model",
}


#: Compensator kinds of the scenario files that cannot be exported: name -> why.
REFUSED_KINDS = {
    "none": "there is no compensator to export",
}


@dataclass
class ExportSource:
    """What ``MODEL_OR_PRESET`` holds.

    Parameters
    ----------
    path : pathlib.Path
        The file read.
    name : str
        Preset name or file stem.
    model : MultivariablePI
        The hysteresis model.
    sampling_period : float or None
        ``[preset] sampling_period`` [s]; for a model file, the period of the
        records it was identified from (``[identification] sampling_period_s``),
        None when it gives none.
    dynamics : control.StateSpace or None
        The discretised linear dynamics of a preset (None without).
    amplifier : dict or None
        The file's ``[amplifier]`` table, if any.
    creep : list or None
        The file's ``[creep]`` (one entry per output), inverted with the
        dynamics by kind ``hammerstein``; None without.
    preset : bool
        The file is a preset (``[preset]``: an actuator), not a model file.
    units : tuple of str
        ``(input unit, output unit)`` of the file's ``[model]`` (``input_unit``,
        ``output_unit``; default ``("V", "µm")``): the drive's and the reference's, in
        which the command's lines give limits.
    """

    path: Path
    name: str
    model: object
    sampling_period: float | None
    dynamics: object
    amplifier: dict | None
    creep: list | None = None
    preset: bool = False
    units: tuple = ("V", "µm")


def load_source(model_or_preset):
    """Read a bundled preset, a preset file or a model file.

    Parameters
    ----------
    model_or_preset : str or pathlib.Path
        Bundled preset name or a TOML file path.

    Returns
    -------
    ExportSource

    Raises
    ------
    PresetError
        A missing, unreadable or malformed file (names it).
    """
    path = resolve_preset(model_or_preset)
    data = read_toml(path, "model or preset file")
    amplifier = data.get("amplifier")
    if amplifier is not None and not isinstance(amplifier, dict):
        raise PresetError(f"{path}: amplifier: expected a table")
    if "preset" in data:
        plant = load_plant(path)
        return ExportSource(path, plant.name, plant.hysteresis, plant.sampling_period,
                            plant.dynamics, amplifier, getattr(plant, "creep", None), True,
                            tuple(plant.units))
    model = load_model(path)
    creep = load_creep(path, model.output_names) if "creep" in data else None
    try:                 # the records' period, as compensate takes it (--sampling-period wins)
        period = records_sampling_period(data, path)
    except PresetError:
        period = None
    table = data.get("model") if isinstance(data.get("model"), dict) else {}
    units = (str(table.get("input_unit", "V")), str(table.get("output_unit", "µm")))
    return ExportSource(path, path.stem, model, period, None, amplifier, creep, units=units)


def limits_from_table(table, inputs, where="amplifier"):
    """Amplifier limits from a preset's ``[amplifier]`` table.

    The table of hammerstein's amplifier model: ``range = [min, max]`` [V],
    ``slew_rate`` [V/s] and ``bandwidth_hz`` for every input, and optional
    per-input sub-tables ``[amplifier.<input>]`` with the same keys that
    override them. ``bandwidth_hz`` is the amplifier's own low-pass, which
    acts in the hardware: it is not part of the exported code.

    Parameters
    ----------
    table : dict or None
        The ``[amplifier]`` table.
    inputs : list of str
        The model's input names (m).
    where : str
        Key prefix for messages.

    Returns
    -------
    AmplifierLimits or None
        None without a table.

    Raises
    ------
    ExportError
        On an unknown key or input, a range that is not ``[min, max]`` with
        ``min < max``, or a non-positive slew rate (the message names the key).
    """
    if table is None:
        return None
    keys = ("range", "slew_rate", "bandwidth_hz")
    m = len(inputs)
    lo, hi, slew = np.full(m, -np.inf), np.full(m, np.inf), np.full(m, np.inf)

    def apply(tab, idx, at):
        for key, value in tab.items():
            if key == "range":
                try:
                    a = np.asarray(value, dtype=float)
                except (TypeError, ValueError):
                    a = None
                if a is None or a.shape != (2,) or not np.all(np.isfinite(a)) or not a[0] < a[1]:
                    raise ExportError(f"{at}.range: expected [min, max] V with min < max, found {value!r}")
                lo[idx], hi[idx] = a
            elif key == "slew_rate":
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not (np.isfinite(value) and value > 0):
                    raise ExportError(f"{at}.slew_rate: expected a positive rate [V/s], found {value!r}")
                slew[idx] = float(value)
            elif key not in ("bandwidth_hz", "source"):   # source: where the limits come from
                raise ExportError(f"{at}.{key}: unknown key (expected {', '.join(keys)} or an input "
                                  f"name: {', '.join(inputs)})")

    if not isinstance(table, dict):
        raise ExportError(f"{where}: expected a table")
    apply({k: v for k, v in table.items() if not isinstance(v, dict)}, slice(None), where)
    for name, sub in table.items():
        if isinstance(sub, dict):
            if name not in inputs:
                raise ExportError(f"{where}.{name}: not an input of the model ({', '.join(inputs)})")
            apply(sub, inputs.index(name), f"{where}.{name}")
    return AmplifierLimits(lo, hi, slew)


def compensator_from_source(source, kind="multivariable", gain=None, iterations=None,
                            feedback="delay", cutoff_hz=None, inversion="zpetc",
                            sampling_period=None, check="error"):
    """The compensator of ``kind`` built on an export source, with the scenario defaults.

    A scenario's compensator table is built by
    :func:`hammerstein.scenario.registry.build_compensator` instead; this one
    takes what :func:`load_source` read (a preset or a model file) and the
    options of ``hammerstein export``.

    Parameters
    ----------
    source : ExportSource
        From :func:`load_source`.
    kind : str
        One of :data:`KINDS` (those of :data:`REFUSED_KINDS` are refused).
    gain : {'secant', 'midpoint', 'identity'}, optional
        Normalisation K (default 'secant', 'midpoint' for 'hammerstein').
    iterations : int, optional
        Fixed-point iterations per sample (default 1, 3 for 'hammerstein').
    feedback : {'delay', 'lowpass'}
        Feedback of the law.
    cutoff_hz : float, optional
        Cut-off of the low-pass feedback [Hz].
    inversion : str
        Inverse of the dynamics for 'hammerstein' (only 'zpetc' can be exported).
    sampling_period : float, optional
        [s]; default the preset's.
    check : {'error', 'warn', 'ignore'}
        Convergence check of the law.

    Returns
    -------
    (compensator, sampling_period) : (object, float)

    Raises
    ------
    ExportError
        An unknown or refused kind, ``preisach-inverse`` on a classical PI,
        a model file without ``sampling_period``, a Hammerstein compensator
        without dynamics, or the compensator's own construction errors (one
        line). Every model class is accepted: a classical PI gets the PI
        compensators, a Preisach / generalised-PI model the same kinds over
        its exact inverse or its forward operator
        (:func:`hammerstein.compensation.mixed_compensators.mixed_compensator`).
    """
    if isinstance(kind, str) and kind in REFUSED_KINDS:
        raise ExportError(f"kind: {kind!r} cannot be exported to C: {REFUSED_KINDS[kind]}")
    if not isinstance(kind, str) or kind not in KINDS:
        raise ExportError(f"kind: expected one of {', '.join(KINDS)}, found {kind!r}")
    classical = isinstance(source.model, MultivariablePI)
    T = sampling_period if sampling_period is not None else source.sampling_period
    if T is None:
        raise ExportError(f"sampling-period: {source.path} is a model file without a sampling "
                          f"period; give --sampling-period SECONDS")
    if kind != "hammerstein" and inversion not in (None, "zpetc"):
        raise ExportError(f"inversion: only used with kind 'hammerstein', found {inversion!r}")
    opts = {}
    if feedback != "delay":
        opts = {"feedback": feedback, "cutoff_hz": cutoff_hz, "sampling_period": T}
    elif cutoff_hz is not None:
        raise ExportError("cutoff-hz: only used with --feedback lowpass")
    try:
        problem = kind_problem(source.model, kind, has_dynamics=source.dynamics is not None,
                               among=KINDS, verb="export")
    except CompensatorError as exc:       # a model of no registered class
        raise ExportError(str(exc)) from None
    if problem:                  # the class registry decides, and names the kinds that export
        raise ExportError(problem)
    try:
        if kind == "preisach-inverse":
            if gain is not None or iterations is not None or feedback != "delay":
                raise ExportError("kind: 'preisach-inverse' takes no gain, iterations or feedback "
                                  "options")
            comp = model_class(source.model).exact_inverse(source.model)
        elif not classical and kind in MIXED_KINDS:
            if feedback != "delay":
                raise ExportError(f"feedback: only 'delay' over a {type(source.model).__name__}")
            comp = mixed_compensator(source.model, kind, gain=gain or "secant",
                                     iterations=iterations or 1, check=check)
        elif kind == "multivariable":
            comp = InverseMultiplicativeCompensator(source.model, gain=gain or "secant",
                                                    iterations=iterations or 1, check=check, **opts)
        elif kind == "diagonal":
            comp = diagonal_compensator(source.model, gain=gain or "secant",
                                        iterations=iterations or 1, check=check, **opts)
        elif kind in ("per-axis", "static-gain"):
            if gain is not None or iterations is not None or feedback != "delay":
                raise ExportError(f"kind: {kind!r} takes no gain, iterations or feedback options")
            comp = (PerAxisInverseCompensator if kind == "per-axis" else StaticGainCompensator)(source.model)
        else:
            if source.dynamics is None:
                raise ExportError(f"kind: 'hammerstein' needs linear dynamics; {source.path} has no "
                                  f"[dynamics] (a preset with bending modes or a state space)")
            if not classical and (gain is not None or iterations is not None
                                  or feedback != "delay" or cutoff_hz is not None):
                # its static part is the exact per-sample inverse: the options were ignored
                label = model_class(source.model).label
                raise ExportError(f"kind: 'hammerstein' over a {label} model inverts it exactly "
                                  f"per sample and takes no gain, iterations "
                                  f"or feedback options (the law's kinds over it: multivariable, "
                                  f"diagonal)")
            G = source.dynamics
            if sampling_period is not None and abs(float(G.dt) - float(T)) > 1e-12 * float(T):
                try:        # continuous dynamics sampled again at T, as compensate does
                    G = load_dynamics(source.path, list(source.model.output_names), float(T))
                except PresetError as exc:
                    raise ExportError(f"sampling-period: {exc}") from None
            comp = HammersteinCompensator(source.model, G, inversion=inversion or "zpetc",
                                          gain=gain or "midpoint", iterations=iterations or 3,
                                          check=check, feedback=feedback, cutoff_hz=cutoff_hz,
                                          sampling_period=T, creep=source.creep)
    except (CompensatorError, DynamicsError) as exc:
        raise ExportError(" ".join(str(exc).split())) from None
    return comp, float(T)


def check_owned(path, marker, force=False):
    """Refuse to replace a file hammerstein did not write.

    Parameters
    ----------
    path : pathlib.Path
        Target.
    marker : bytes
        What a file written by hammerstein starts with.
    force : bool
        Replace any regular file anyway.

    Raises
    ------
    ExportError
        The target exists and does not start with ``marker`` (without
        ``force``), or is not a regular file.
    """
    if not os.path.lexists(path):
        return
    if not Path(path).is_file():
        raise ExportError(f"{path}: exists and is not a regular file; expected a file to replace")
    if force:
        return
    try:
        head = bounded_read_bytes(path, "toml", "generated file")[:len(marker)]
    except (FileLimitError, OSError):
        head = b""
    if head != marker:
        raise ExportError(f"{path}: exists and was not written by hammerstein export; "
                          f"remove it, choose another --out or --name, or pass --force")


def check_fmu_owned(path, force=False):
    """Refuse to replace an FMU hammerstein export did not write.

    Parameters
    ----------
    path : str or pathlib.Path
        Target ``.fmu``.
    force : bool
        Replace any regular file anyway.

    Raises
    ------
    ExportError
        The target exists and is not a regular file, or (without ``force``)
        is not an FMU whose model description names hammerstein export as
        its generation tool.
    """
    if not os.path.lexists(path):
        return
    if not Path(path).is_file():
        raise ExportError(f"{path}: exists and is not a regular file; expected a file to replace")
    if not force and not fmu_owned(path):
        raise ExportError(f"{path}: exists and was not written by hammerstein export; "
                          f"remove it, choose another --out or --name, or pass --force")


def write_files(out_dir, files, marker, force=False):
    """Write generated files into a directory, each only where allowed.

    Every target is checked first (:func:`check_owned`), so a refusal writes
    nothing; each file is then written through an exclusive temporary file,
    and every temporary is renamed over its target only when all are written
    (:func:`hammerstein.core.files.all_or_nothing`): an error or an
    interruption leaves the old header and source together.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        Directory (created if missing).
    files : dict
        File name -> content (str or bytes).
    marker : bytes or dict
        Ownership marker of every file, or file name -> marker.
    force : bool
        Replace files hammerstein did not write.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ExportError
        A target that may not be replaced, or cannot be written.
    """
    out = Path(out_dir)
    marks = marker if isinstance(marker, dict) else {f: marker for f in files}
    for fname in files:
        problem = output_problem(out / fname, out)   # a link planted in DIR, an input: even with force
        if problem:
            raise ExportError(problem)
        check_owned(out / fname, marks[fname], force)
    written = []
    # the header and the source together, or neither: an interruption between the two renames
    # left a float header beside the double source of the export before, which compiled
    with all_or_nothing():
        for fname, data in files.items():
            try:
                written.append(safe_write(out / fname, data, "generated file", root=out))
            except FileLimitError as exc:     # the cause kept: a file's problem, not the kind's
                raise ExportError(str(exc)) from exc
            except OSError as exc:
                raise ExportError(f"{out / fname}: cannot write ({exc.strerror or exc})") from exc
    return written
