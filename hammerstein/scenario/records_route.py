"""The records route of scenario identification: ``identify = { records = ... }``.

``records = "excitation"`` plays the records of ``hammerstein excitation`` through
the scenario's plant; ``records = "files"`` reads the user's measured records (the
files ``hammerstein identify`` takes). Both go through the pipeline of
``hammerstein identify``
(:func:`hammerstein.identification.identification_pipeline.identify_pipeline`) with
its options and defaults, and the preset it writes is read back as ``hammerstein
compensate`` reads it. Re-exported by :mod:`hammerstein.scenario.identification`.
"""

from __future__ import annotations

import hashlib
import tempfile
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from hammerstein.core.files import FileLimitError, bounded_read_bytes, confined_path
from hammerstein.core.lazy import lazy_module
from hammerstein.exceptions import HammersteinWarning, HysteresisError
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification.loop_orientation import clockwise_loop_warnings
from hammerstein.identification.sensors import Sensor
from hammerstein.io.datafiles import DataFileError, MultiRecord, read_records
from hammerstein.io.unit_checks import unit_warnings
from hammerstein.io.presets import load_model, load_plant, save_model
from hammerstein.models.amplifier import amplifier_from_table, records_amplifier_table
from hammerstein.models.dynamics import DynamicsError
from hammerstein.models.lti import check_delay_by_fit, estimate_measurement_delay
from hammerstein.models.plant import HammersteinPlant
from hammerstein.scenario.identification_cache import (IdentificationCache, plant_fingerprint,
                                                       spec_key)
from hammerstein.scenario.identify_tables import (files_table_words, identify_table, record_time,
                                                  record_unit_problems, record_units)
from hammerstein.scenario.schema import Invalid
from hammerstein.signals.excitation import excitation_set

identification_pipeline = lazy_module("hammerstein.identification.identification_pipeline")

__all__ = ["RecordsIdentification", "excitation_records", "file_records", "in_plant_units",
           "plant_unit_scales",
           "identified_from_records", "SENSOR_NOISE_RMS"]

#: RMS white noise of the simulated sensor of ``sensor = true`` [µm].
SENSOR_NOISE_RMS = 0.02


def _sensor(flag, seed):
    return Sensor(resolution=0.04, bandwidth_hz=2000.0, noise_rms=SENSOR_NOISE_RMS,
                  seed=seed) if flag else None


# -- the route of `hammerstein excitation` + `hammerstein identify` -------------------------
@dataclass
class RecordsIdentification:
    """What an ``identify = { records = "excitation", ... }`` table identified.

    Parameters
    ----------
    plant : hammerstein.models.plant.HammersteinPlant
        The identified actuator as ``hammerstein compensate`` loads it: the
        preset ``hammerstein identify`` writes (hysteresis of the chosen
        class, dynamics and creep when identified), read back.
    result : hammerstein.identification.identification_pipeline.IdentificationResult
        The pipeline's fit, dynamics and creep.
    preset_text : str
        The preset file's text.
    metadata : dict
        The ``[identification]`` table.
    """

    plant: Any
    result: Any
    preset_text: str
    metadata: dict


def excitation_records(plant, spec, sensor=None):
    """The records of ``hammerstein excitation`` played through ``plant``, by kind.

    Parameters
    ----------
    plant : HammersteinPlant
    spec : dict
        Validated ``identify`` table with ``records = "excitation"``
        (:data:`~hammerstein.scenario.identify_tables.RECORDS_IDENTIFY_FIELDS`).
    sensor : hammerstein.identification.sensors.Sensor, optional
        Measures the outputs.

    Returns
    -------
    dict of str to list of MultiRecord
        ``hysteresis``, ``dynamics`` (the multisines of every input, then
        their held-out validation records) and ``creep`` (staircases).

    Raises
    ------
    IdentificationError
        An amplitude that does not fit the plant's inputs, or both ``amplitude`` and
        ``range``.
    """
    model = plant.hysteresis
    amp, centre = spec.get("amplitude"), 0.0
    if spec.get("range") is not None:          # as excitation --range: around its middle
        if amp is not None:
            raise IdentificationError("identify.amplitude, identify.range: expected one of "
                                      "them, found both")
        low, high = spec["range"]
        amp, centre = 0.5 * (high - low), 0.5 * (high + low)
    if amp is not None and np.size(amp) not in (1, model.n_inputs):
        raise IdentificationError(f"identify.amplitude: expected 1 or {model.n_inputs} values "
                                  f"(one per input of the plant), found {np.size(amp)}")
    if amp is None:
        if model.input_amplitude is None:
            raise IdentificationError("identify.amplitude: missing, and the plant model has no "
                                      "input_amplitude to default to")
        amp = np.asarray(model.input_amplitude, dtype=float)
    T = plant.sampling_period
    try:
        recs = excitation_set(list(model.input_names), amp, T, sine_frequency=spec["frequency"],
                              multisine_periods=spec["multisine_periods"], hold=spec["hold"],
                              seed=spec["seed"], reversals=spec["reversals"],
                              slew_rate=spec.get("slew_rate"), centre=centre)
    except ValueError as exc:
        raise IdentificationError(f"identify: {exc}") from None
    out = {"hysteresis": [], "multisine": [], "multisine-validation": [], "creep": []}
    for r in recs:
        y, _ = plant.simulate(r.u)
        if sensor is not None:
            y = sensor.measure(y, T)
        out[r.kind].append(MultiRecord(r.time, r.u, y, tuple(model.input_names),
                                       tuple(model.output_names), float(T), r.name))
    return {"hysteresis": out["hysteresis"], "dynamics": out["multisine"] + out["multisine-validation"],
            "creep": out["creep"]}


def file_records(plant, spec, base_dir=None):
    """The measured records an ``identify = { records = "files", ... }`` table names, by kind.

    Read as ``hammerstein identify`` reads its files
    (:func:`hammerstein.io.datafiles.read_records`: the ``time`` column, or
    the ``sampling_period`` [s] without one
    (:func:`~hammerstein.scenario.identify_tables.record_time`), the
    ``inputs`` and ``outputs`` columns, by default the plant's names, read in
    ``input_unit`` and ``output_unit`` after ``skip_rows`` preamble lines), each
    file confined to the scenario's directory; the outputs advanced by
    ``delay`` samples (``"auto"``: the estimate of ``identify --delay auto``
    from the dynamics records, 0 when there are none or it is refused, as
    ``identify`` takes it).

    Parameters
    ----------
    plant : HammersteinPlant
        Names the inputs and outputs.
    spec : dict
        Validated table
        (:data:`~hammerstein.scenario.identify_tables.FILES_IDENTIFY_FIELDS`).
    base_dir : pathlib.Path, optional
        The scenario's directory (relative file names).

    Returns
    -------
    records : dict of str to list of MultiRecord
        ``hysteresis``, ``dynamics``, ``creep``.
    delay : int
        The delay applied [samples].
    note : str or None
        Why an automatic delay was taken as 0.

    Raises
    ------
    IdentificationError
        A file that cannot be read (naming the key and the file), or
        ``inputs``/``outputs`` not one column per plant input/output.
    """
    model = plant.hysteresis
    ins = spec.get("inputs") or list(model.input_names)
    outs = spec.get("outputs") or list(model.output_names)
    for key, given, names in (("inputs", ins, model.input_names),
                              ("outputs", outs, model.output_names)):
        if len(given) != len(names):    # (validate says so first; an IndexError came later)
            raise IdentificationError(
                f"identify.{key}: {len(given)} column(s) {list(given)} for the plant's "
                f"{len(names)} {key} {list(names)}; expected one column per {key[:-1]}, in the "
                f"plant's order")
    out = {}
    for kind, key in (("hysteresis", "hysteresis_records"), ("dynamics", "dynamics_records"),
                      ("creep", "creep_records")):
        out[kind] = []
        for name in spec.get(key) or []:
            try:
                path = confined_path(name, base_dir, DataFileError)
                out[kind].append(read_records(
                    path, ins, outs, record_time(spec), spec.get("sampling_period"),
                    spec.get("skip_rows", 0), *record_units(spec, plant)))
            except (DataFileError, FileLimitError) as exc:
                raise IdentificationError(f"identify.{key}: {files_table_words(str(exc))}") from None
    delay, note = spec["delay"], None
    if delay == "auto":
        delay = 0
        if out["dynamics"]:
            T = out["dynamics"][0].sampling_period
            try:
                est = check_delay_by_fit(
                    [r.u for r in out["dynamics"]], [r.y for r in out["dynamics"]], T,
                    estimate_measurement_delay([r.u for r in out["dynamics"]],
                                               [r.y for r in out["dynamics"]], T))
            except DynamicsError as exc:
                raise IdentificationError(f"identify.delay: {exc}") from None
            if est.problem is None:
                delay = est.delay
            else:
                note = (f"identify (records = 'files'): the measurement delay could not be "
                        f"estimated ({est.problem}) and was taken as 0, as identify takes it")
    if delay:
        for kind in out:
            for i, r in enumerate(out[kind]):
                n = r.u.shape[1]
                if n <= 10 * delay:
                    raise IdentificationError(f"identify.delay: {r.source}: {n} samples; a delay "
                                              f"of {delay} needs more than {10 * delay}")
                out[kind][i] = replace(r, timepts=r.timepts[:n - delay], u=r.u[:, :n - delay],
                                       y=r.y[:, delay:])
    return out, int(delay), note


def plant_unit_scales(plant, spec):
    """The factors that take a files table's records to its plant's units.

    ``identify`` converts nothing: its model is in the records' units, and
    ``compensate`` takes references in them. A scenario drives its plant (in
    ``plant.units``, V and µm for every bundled preset) and compensates
    references in the plant's output unit, so a model identified in mV and nm
    was off by a factor of 1000 against a plant in V and µm (a 12 µm circle
    followed with a 126 000 % error): the records are read in the plant's units.

    Parameters
    ----------
    plant : HammersteinPlant
        The scenario's plant (``units``: input and output unit).
    spec : dict
        Validated files table (``input_unit``, ``output_unit``).

    Returns
    -------
    tuple of float
        ``(a, b)``: inputs times ``a`` and outputs times ``b`` are in the plant's units.

    Raises
    ------
    IdentificationError
        Units that differ from the plant's and do not convert
        (:func:`hammerstein.io.unit_checks.unit_scale`), named at the table's key.
    """
    scales, problems = record_unit_problems(spec, plant)
    if problems:
        raise IdentificationError("; ".join(problems))
    return tuple(scales)


def in_plant_units(records, scales):
    """Records multiplied by :func:`plant_unit_scales`' factors.

    Parameters
    ----------
    records : dict of str to list of MultiRecord
        As :func:`file_records` reads them (``u`` (m, n), ``y`` (p, n) in the table's units).
    scales : tuple of float
        ``(a, b)`` of :func:`plant_unit_scales`.

    Returns
    -------
    dict of str to list of MultiRecord
        ``u`` times ``a`` and ``y`` times ``b`` (the same objects for ``(1, 1)``).
    """
    a, b = scales
    if a == 1.0 and b == 1.0:
        return records
    return {kind: [replace(r, u=a * r.u, y=b * r.y) for r in recs]
            for kind, recs in records.items()}


def _files_digest(spec, base_dir):
    """Content hash of the files a ``records = "files"`` table names (its cache key)."""
    h = hashlib.sha256()
    for key in ("hysteresis_records", "dynamics_records", "creep_records"):
        for name in spec.get(key) or []:
            try:
                path = confined_path(name, base_dir, DataFileError)
                # bounded as every read: a 3 GiB record was read whole (52 s, 6.5 GB) before
                # read_records refused it
                h.update(str(path).encode() + b"\0" + bounded_read_bytes(path, "data", "record"))
            except (OSError, DataFileError, FileLimitError):
                h.update(name.encode())          # read_records names the problem
    return h.hexdigest()


def _pipeline_options(spec, name, scales=(1.0, 1.0), output_unit="µm"):
    """The pipeline's options of a validated records table, as ``identify`` gives them.

    Parameters
    ----------
    spec : dict
        Validated ``identify`` table (either records route).
    name : str
        Name of the identified dynamics.

    Returns
    -------
    PipelineOptions
        ``thresholds`` (a files table's explicit list) as ``identify --thresholds
        r1,r2,...`` passes them: their count as ``n``, an array [input unit].
    """
    thresholds = spec.get("thresholds")
    if thresholds is not None:     # in the records' input unit, read in the plant's
        thresholds = np.asarray(thresholds, dtype=float) * scales[0]
    return identification_pipeline.PipelineOptions(
        method=spec["method"], n=spec["n_hysterons"] if thresholds is None else thresholds.size,
        thresholds=thresholds, partition=spec["partition"],
        bounds=spec["bounds"], components=spec["components"], model=spec["model"],
        threshold_spacing=spec["threshold_spacing"], level_weighting=spec["level_weighting"],
        record_start=spec["record_start"], preisach_levels=spec["preisach_levels"],
        preisach_smoothing=spec["preisach_smoothing"], output_map=spec["output_map"], order=spec.get("order"), max_order=spec.get("max_order"),
        creep_refits=spec.get("creep_refits"), hold_out=spec["hold_out"],
        train_fraction=spec.get("train_fraction"), skip=spec.get("skip"),
        output_unit=output_unit, name=name)


def identified_from_records(plant, spec, dynamics, cache=None, base_dir=None):
    """The actuator identified from excitation records, as ``identify`` + ``compensate`` see it.

    The records of :func:`excitation_records` go through
    :func:`hammerstein.identification.identification_pipeline.identify_pipeline` with the
    table's options (those of ``hammerstein identify``), the dynamics from the
    multisines when ``dynamics``, the creep from the staircases when
    ``spec["creep"]``; the preset it writes is read back
    (:func:`hammerstein.io.presets.load_plant`), so the compensator is built
    from what ``hammerstein compensate`` would read. Cached in memory per
    plant, table and ``dynamics``.

    Parameters
    ----------
    plant : HammersteinPlant
        The (simulated) actuator.
    spec : dict
        ``identify`` table with ``records = "excitation"``.
    dynamics : bool
        Identify G too (from the multisines). With ``records = "files"`` G is
        identified from its ``dynamics_records`` whenever it names some, as
        ``identify --dynamics`` does, whatever the kind.
    cache : IdentificationCache, optional
    base_dir : pathlib.Path, optional
        The scenario's directory: the files of ``records = "files"``.

    Returns
    -------
    RecordsIdentification

    Raises
    ------
    IdentificationError
    """
    try:
        spec = identify_table(spec)
    except Invalid as exc:
        raise IdentificationError(f"identify: {exc}") from None
    cache = IdentificationCache() if cache is None else cache
    files = spec["records"] == "files"
    key = ((_files_digest(spec, base_dir) if files else plant_fingerprint(plant)),
           spec_key(spec), bool(dynamics), tuple(plant.hysteresis.input_names),
           tuple(plant.hysteresis.output_names),
           tuple(getattr(plant, "units", ("V", "µm"))))    # the files are read in them
    return cache.get("records", key,
                     lambda: _identify_from_records(plant, spec, dynamics, base_dir),
                     load=None, dump=None)


def _identify_from_records(plant, spec, dynamics, base_dir=None):
    model = plant.hysteresis
    names = (list(model.input_names), list(model.output_names))
    files = spec["records"] == "files"
    where = f"identify (records = '{spec['records']}')"
    units = getattr(plant, "units", ("V", "µm"))
    scales = (1.0, 1.0)
    if files:
        try:
            scales = plant_unit_scales(plant, spec)      # before a file is read
        except IdentificationError as exc:
            raise IdentificationError(f"{where}: {exc}") from None
        recs, delay, note = file_records(plant, spec, base_dir)
        if note:
            warnings.warn(note, HammersteinWarning, stacklevel=2)
        every = [r for kind in ("hysteresis", "dynamics", "creep") for r in recs[kind]]
        # identify's unit checks (a time column in ms read as s, an output in nm as µm):
        # the scenario read the same files without a word
        given = record_units(spec, plant)
        for line in unit_warnings(every, names[1], given[1], record_time(spec),
                                  names[0], given[0], converted=True):
            warnings.warn(f"{where}: {files_table_words(line)}", HammersteinWarning, stacklevel=2)
        recs = in_plant_units(recs, scales)
        for line in clockwise_loop_warnings(recs["hysteresis"], *names):   # as identify warns
            warnings.warn(f"{where}: {line}", HammersteinWarning, stacklevel=2)
        # the files a table names are identified as `identify --dynamics --dynamics-records`
        # does, whatever kind uses them: for a rate-independent kind the creep was fitted
        # without G and the amplifier's slew taken from the hysteresis records alone (125.7
        # V/s against 3.46e5), another preset and drive than identify + compensate
        dynamics = bool(recs["dynamics"])
        creep = bool(recs["creep"])
    else:
        recs = excitation_records(plant, spec, _sensor(spec["sensor"], spec["seed"]))
        creep = spec["creep"]
    try:
        result = identification_pipeline.identify_pipeline(
            recs["hysteresis"], _pipeline_options(spec, "identified", scales, units[1]), names,
            recs["dynamics"] if dynamics else None, recs["creep"] if creep else None)
    except (IdentificationError, HysteresisError, DynamicsError) as exc:
        raise IdentificationError(f"{where}: {exc}") from None
    loops = identification_pipeline.minor_loop_warning(result.fit, *names)   # as identify warns
    if loops:
        warnings.warn(f"{where}: {loops}", HammersteinWarning, stacklevel=2)
    poor = (None if result.dynamics is None
            else identification_pipeline.dynamics_fit_warning(result.dynamics.summary,
                                                              result.dynamics.conditions))
    if poor:
        warnings.warn(f"{where}: {poor}", HammersteinWarning, stacklevel=2)
    gain = (None if result.dynamics is None
            else identification_pipeline.static_gain_warning(result.dynamics.summary, *names[::-1]))
    if gain:
        warnings.warn(f"{where}: {gain}", HammersteinWarning, stacklevel=2)
    meta = {"method": result.fit.method, "model": spec["model"], "records":
            ("measured files: " + ", ".join(r.source for k in ("hysteresis", "dynamics", "creep")
                                             for r in recs[k]))
            if files else "hammerstein excitation, played through the plant",
            "sampling_period_s": float(recs["hysteresis"][0].sampling_period if files
                                       else plant.sampling_period),
            "plant": f"{plant.name} ({'hammerstein' if not plant.is_static else 'static'})",
            **result.fit.record()}      # the partition, held-out windows and errors identify writes
    if files:
        meta["input_columns"] = ",".join(recs["hysteresis"][0].input_names)
        meta["output_columns"] = ",".join(recs["hysteresis"][0].output_names)
        meta["input_unit"], meta["output_unit"] = units      # as identify writes them
        if scales != (1.0, 1.0):
            meta["converted_from_units"] = ", ".join(given)
        # as identify: a delay given (0 included) or estimated from the dynamics records is
        # kept; none written otherwise (learn --delay auto then estimates its own: a 0 written
        # for hysteresis records alone was taken as a known delay)
        estimated = bool(recs["dynamics"]) and note is None
        if spec["delay"] != "auto" or estimated:
            meta["measurement_delay_samples"] = delay
    if result.dynamics is not None:
        meta["dynamics"] = result.dynamics.summary
    if result.creep is not None:
        meta["creep"] = result.creep.summary()
    extra = dict(result.tables() or {})
    # as identify: drives stay within what the records spanned (the excitation's records
    # simulated here too: the same preset and drive as identify + compensate on them)
    extra["amplifier"] = records_amplifier_table(
        recs["hysteresis"] + (recs["dynamics"] if dynamics else []) + (recs["creep"] if creep else []),
        list(model.input_names))
    with tempfile.TemporaryDirectory() as tmp:   # what `identify` writes, read as `compensate` does
        path = Path(tmp) / "identified.toml"
        # in the plant's units (a files table's records converted on reading)
        save_model(result.model, path, meta, *units, extra=extra)
        text = path.read_text(encoding="utf-8")
        if "[preset]" in text:
            identified = load_plant(path)
        else:
            identified = HammersteinPlant(load_model(path), float(plant.sampling_period),
                                          name="identified")
            identified.amplifier = amplifier_from_table(extra["amplifier"],
                                                        list(model.input_names), str(path))
    return RecordsIdentification(identified, result, text, meta)


# -- models of compensators and model-vs-plant comparisons (paper Fig. 6, 7) ---------
