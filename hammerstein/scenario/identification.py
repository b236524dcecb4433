"""Identification in scenarios: the models and dynamics that ``model = "identified"`` names.

The model is identified on the case's own plant (same preset and dynamics
setting) by the characterisation experiment of Section 3.3, Steps 1-4: a
sine on each input in turn, all outputs recorded
(:func:`hammerstein.identification.sensors.characterize`), then
:class:`hammerstein.identification.identification.MultivariableIdentifier`
(:func:`identified_model`). ``kind = "hammerstein"`` identifies the PI and
the linear dynamics G in two stages (:func:`identified_hammerstein`).

Everything is identified through the :class:`ResolveContext` of the case
being resolved: its :class:`~hammerstein.scenario.identification_cache.IdentificationCache`
(one per run, backed by the on-disk cache) identifies each model once, and
its ``identified`` list receives an :class:`IdentifiedModel` or
:class:`IdentifiedDynamics` record per identification the case uses. The
records travel with the case (``CaseSpec.identified``) into the results, from
which the report saves the model files
(:mod:`hammerstein.report.model_files`).

``sensor = true`` measures the outputs through the inductive sensor model of
docs/identification.md (IBS ECL202): 40 nm quantisation, first-order 2 kHz
bandwidth, and white noise of :data:`SENSOR_NOISE_RMS` = 0.02 µm RMS (half a
quantisation step; the paper does not state the noise) drawn with ``seed``.

Length: the identification of every model class a scenario's table can ask
for (classical PI, Preisach, generalised PI, dynamics, creep) resolves through
one cache and one record type; a module per class would duplicate the
table checks and the cache keys.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.models.dynamics import DynamicsError
from hammerstein.core.files import confined_path
from hammerstein.io.datafiles import MultiRecord
from hammerstein.signals.excitation import hysteresis_excitation
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.identification.defaults import PREISACH_LEVELS
from hammerstein.identification.identification import IdentificationError, MultivariableIdentifier
from hammerstein.core.lazy import lazy_module
from hammerstein.models.lti import DynamicsIdentifier, excitation, hammerstein_records, modal_parameters
from hammerstein.io.presets import (PresetError, load_dynamics, load_model, model_from_table,
                                      model_to_table)
from hammerstein.identification.sensors import characterize, identification_metadata
from hammerstein.scenario.identification_cache import (IdentificationCache, plant_fingerprint,
                                                       round_trip_table, spec_key)
from hammerstein.scenario.identify_tables import (comparison_spec, dynamics_source, identify_dynamics_table,
                                                  identify_table, nyquist_problem)
from hammerstein.scenario.records_route import (SENSOR_NOISE_RMS, RecordsIdentification,
                                                _sensor, excitation_records, file_records,
                                                identified_from_records)
from hammerstein.scenario.schema import Invalid

# lazy: scipy.optimize, only for identify.model = "preisach" / "auto"
preisach_identification = lazy_module("hammerstein.identification.preisach_identification")
record_identification = lazy_module("hammerstein.identification.record_identification")
identification_pipeline = lazy_module("hammerstein.identification.identification_pipeline")
control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = [
    "SENSOR_NOISE_RMS",
    "FLAT_TOLERANCE",
    "FIRST_STAGE_HZ",
    "ResolveContext",
    "IdentifiedModel",
    "IdentifiedDynamics",
    "identified_model",
    "identified_hammerstein",
    "identified_from_records",
    "excitation_records",
    "file_records",
    "RecordsIdentification",
    "flat_frequency",
    "resolve_model",
    "resolve_dynamics",
    "resolve_comparison_model",
    "comparison_model",
]



@dataclass
class IdentifiedModel:
    """A PI model a case identified (``model = "identified"``).

    ``kind`` (class attribute) is ``"pi"``.

    Parameters
    ----------
    role : {'compensator', 'comparison'}
        What the case uses it for.
    plant : hammerstein.models.plant.HammersteinPlant
        The plant it was identified on.
    identify : dict
        The validated ``identify`` table.
    model : hammerstein.models.hysteresis.MultivariablePI
    metadata : dict
        The ``[identification]`` table saved with the model.
    key : tuple
        Content key (plant fingerprint, identify table): equal keys, same model.
    preset_text : str or None
        A ``records`` table's identification: the preset ``hammerstein
        identify`` writes (``[model]``, ``[creep]``, ``[amplifier]``...), saved as
        the report's model file; None for the sine route (``[model]`` only).
    """

    kind: ClassVar[str] = "pi"
    role: str
    plant: Any
    identify: dict
    model: Any
    metadata: dict
    key: tuple
    preset_text: str | None = None


@dataclass
class IdentifiedDynamics:
    """The PI and linear dynamics G a ``kind = "hammerstein"`` case identified.

    ``kind`` (class attribute) is ``"hammerstein"``.

    Parameters
    ----------
    plant : hammerstein.models.plant.HammersteinPlant
    pi : hammerstein.models.hysteresis.MultivariablePI
    pi_metadata : dict or None
        None when the PI was given (``model = "plant"`` or a file), not identified.
    identifier : hammerstein.models.lti.DynamicsIdentifier
        Fitted (``system_``: discrete p x p G, ``order_``, ``validation_fit_``...).
    metadata : dict
        ``[identification]`` table of the dynamics file.
    key : tuple
        Content key of the identification.
    preset_text : str or None
        A ``records`` table's identification: the preset ``hammerstein
        identify`` writes (``[model]``, ``[dynamics]``, ``[creep]``,
        ``[amplifier]``), the one the compensator was read from; None otherwise.
    summary : dict or None
        A ``records`` table's identification: the dynamics summary of
        ``identify`` (``candidate_order``, ``chosen_on``, ``candidates``: every
        order of the search, which the creep's refit does not repeat); None
        otherwise.
    """

    kind: ClassVar[str] = "hammerstein"
    plant: Any
    pi: Any
    pi_metadata: dict | None
    identifier: Any
    metadata: dict
    key: tuple
    preset_text: str | None = None
    summary: dict | None = None


@dataclass
class ResolveContext:
    """What a compensator builder or a model resolver needs besides its table and plant.

    Parameters
    ----------
    base_dir : pathlib.Path
        Directory of the scenario file (relative model and dynamics paths).
    cache : IdentificationCache
        The identifications of this run.
    identified : list
        Receives an :class:`IdentifiedModel` / :class:`IdentifiedDynamics`
        per identification used (the case's record).
    """

    base_dir: Path
    cache: IdentificationCache = field(default_factory=IdentificationCache)
    identified: list = field(default_factory=list)

    def for_case(self):
        """A context sharing this one's directory and cache, with an empty record.

        Returns
        -------
        ResolveContext
        """
        return ResolveContext(self.base_dir, self.cache, [])


def _context(context):
    """A path (former call style) or None becomes a ResolveContext."""
    if isinstance(context, ResolveContext):
        return context
    return ResolveContext(Path(context) if context is not None else Path("."))


def identified_model(plant, spec, cache=None, base_dir=None):
    """The model identified on ``plant`` by the ``identify`` table ``spec`` (cached).

    Parameters
    ----------
    plant : HammersteinPlant
        The case's plant (its preset and dynamics setting).
    spec : dict
        ``identify`` table (validated by
        :func:`hammerstein.scenario.identify_tables.identify_table` or raw;
        it is validated again here).
    cache : IdentificationCache, optional
        The run's cache; default: a new one (only the on-disk cache is shared).
    base_dir : pathlib.Path, optional
        The scenario's directory (the files of ``records = "files"``).

    Returns
    -------
    model : MultivariablePI
        Inputs/outputs named as the plant's, ``input_amplitude`` the
        excitation amplitudes [V].
    metadata : dict
        The ``[identification]`` table saved with the model (method,
        frequency_hz, amplitude_V, fit_rms_um, plant...).

    Raises
    ------
    IdentificationError
        If the table is invalid or the identification fails (e.g. a
        frequency beyond Nyquist, a closed form on too short a record).
    """
    try:
        spec = identify_table(spec)
    except Invalid as exc:
        raise IdentificationError(f"identify: {exc}") from None
    cache = IdentificationCache() if cache is None else cache
    if "records" in spec:      # the pipeline of `hammerstein identify` on excitation records
        found = identified_from_records(plant, spec, False, cache, base_dir)
        return found.plant.hysteresis, found.metadata
    return cache.get("pi", _pi_key(plant, spec), lambda: _identify_pi(plant, spec),
                     load=lambda v: (model_from_table(v["model"]), v["meta"]),
                     dump=lambda v: _stored(round_trip_table(v[0]), meta=v[1]))


def _pi_key(plant, spec):
    return (plant_fingerprint(plant), spec_key(spec))


def _stored(table, **rest):
    """The disk form of an entry, or None when its model table does not round-trip."""
    return None if table is None else {"model": table, **rest}


def _identify_records(plant, spec, amp, sensor):
    """A Preisach model (``model = "preisach"``) or the better class (``"auto"``) from
    the hysteresis records of ``hammerstein excitation`` (decreasing-amplitude sines) of each
    input in turn, at the identify frequency, as ``hammerstein identify`` does."""
    model = plant.hysteresis
    T, f = plant.sampling_period, spec["frequency"]
    records = []
    for k in range(model.n_inputs):
        try:
            t, uk = hysteresis_excitation(T, float(amp[k]), frequency=f)
        except ValueError as exc:
            raise IdentificationError(f"identify (model = {spec['model']!r} at {f:g} Hz): {exc}") from None
        u = np.zeros((model.n_inputs, t.size))
        u[k] = uk
        y, _ = plant.simulate(u)
        if sensor is not None:
            y = sensor.measure(y, T)
        records.append(MultiRecord(t, u, y, tuple(model.input_names), tuple(model.output_names),
                                   float(T), f"decreasing sine on {model.input_names[k]}"))
    names = (list(model.input_names), list(model.output_names))
    fits = {}
    try:
        # played from the plant's own initial state, without the demagnetising cycle: the
        # model starts from the ideal demagnetised state, as the bundled Preisach plants do
        fits["preisach"] = preisach_identification.identify_preisach_records(
            records, PREISACH_LEVELS, "auto", "auto", "auto", None, None, *names,
            record_start="rest")
        if spec["model"] == "auto":
            bounds = None if spec["bounds"] == "none" else spec["bounds"]
            fits["classical"] = record_identification.identify_records(
                records, spec["method"], spec["n_hysterons"], None, "auto", bounds, "auto", "auto",
                None, None, *names)
    except (IdentificationError, HysteresisError) as exc:
        raise IdentificationError(f"identify (model = {spec['model']!r} at {f:g} Hz): {exc}") from None
    scores = {}
    for key, fit in fits.items():
        score = fit.minor_loop_error
        scores[key] = float("inf") if score is None else score
    chosen = min(fits, key=lambda key: (scores[key], key != "preisach"))
    meta = {"method": chosen, "model": spec["model"], "frequency_hz": float(f),
            "amplitude_V": [float(a) for a in amp], "records": "decreasing-amplitude sines",
            "held_out_minor_loop_rms_percent": {k: v for k, v in scores.items() if np.isfinite(v)},
            "sampling_period_s": float(T),
            "plant": f"{plant.name} ({'hammerstein' if not plant.is_static else 'static'})",
            "sensor": None if sensor is None else {
                "resolution_um": sensor.resolution, "bandwidth_hz": sensor.bandwidth_hz,
                "noise_rms_um": sensor.noise_rms, "seed": spec["seed"]}}
    if meta["sensor"] is None:
        del meta["sensor"]
    return fits[chosen].model, meta


def _identify_pi(plant, spec):
    model = plant.hysteresis
    f = spec["frequency"]
    problem = nyquist_problem(spec, plant)
    if problem:
        raise IdentificationError(problem)
    amp = spec.get("amplitude")
    if amp is None:
        if model.input_amplitude is None:
            raise IdentificationError("identify.amplitude: missing, and the plant model has no "
                                      "input_amplitude to default to")
        amp = np.asarray(model.input_amplitude, dtype=float)
    amp = np.broadcast_to(np.asarray(amp, dtype=float), (model.n_inputs,)).copy() \
        if np.ndim(amp) == 0 else np.asarray(amp, dtype=float)
    if amp.shape != (model.n_inputs,):
        raise IdentificationError(f"identify.amplitude: expected one value or {model.n_inputs} "
                                  f"[V], found {spec.get('amplitude')!r}")
    sensor = _sensor(spec["sensor"], spec["seed"])
    if spec.get("model", "classical") != "classical":
        return _identify_records(plant, spec, amp, sensor)
    records = characterize(plant, amp, f, spec["periods"], sensor)
    options = {"partition": spec["partition"]}
    if spec["method"] == "least-squares":
        options["bounds"] = None if spec["bounds"] == "none" else spec["bounds"]
    fit_options = {"skip": "auto"} if spec["method"] == "least-squares" else None
    ident = MultivariableIdentifier(spec["method"], spec["n_hysterons"], **options)
    try:
        ident.fit(records, model.input_names, model.output_names, fit_options=fit_options)
    except IdentificationError as exc:
        raise IdentificationError(f"identify (at {f:g} Hz): {exc}") from None
    meta = identification_metadata(
        ident, frequency_hz=float(f), amplitude_V=amp.tolist(), periods=spec["periods"],
        partition=spec["partition"], bounds=str(spec["bounds"]),
        sampling_period_s=float(plant.sampling_period),
        plant=f"{plant.name} ({'hammerstein' if not plant.is_static else 'static'})",
        sensor=None if sensor is None else {
            "resolution_um": sensor.resolution, "bandwidth_hz": sensor.bandwidth_hz,
            "noise_rms_um": sensor.noise_rms, "seed": spec["seed"]})
    return ident.model_, meta


def resolve_model(spec_model, plant, context, identify=None, role="compensator"):
    """The multivariable PI model a compensator (or a comparison) is built from.

    Parameters
    ----------
    spec_model : str
        ``"plant"`` (the plant's own PI model), ``"identified"`` (identified
        on ``plant`` by the ``identify`` table, :func:`identified_model`) or a
        model/preset TOML path, relative to the scenario's directory when not
        absolute.
    plant : HammersteinPlant
    context : ResolveContext or pathlib.Path
        The case's context (a directory: a context of its own).
    identify : dict, optional
        The ``identify`` table (required with ``"identified"``).
    role : {'compensator', 'comparison'}
        Recorded with an identified model.

    Returns
    -------
    MultivariablePI

    Raises
    ------
    PresetError
        If the model file is missing or invalid.
    IdentificationError
        If ``identify`` is missing or the identification fails.
    """
    context = _context(context)
    if spec_model in (None, "plant"):
        return plant.hysteresis
    if spec_model == "identified":
        if identify is None:
            raise IdentificationError("identify: missing (required with model = 'identified'), "
                                      "e.g. identify = { frequency = 50.0 }")
        model, meta = identified_model(plant, identify, context.cache, context.base_dir)
        spec = identify_table(identify)
        text = None
        if "records" in spec:    # its file is identify's preset: [creep] and [amplifier] kept
            text = identified_from_records(plant, spec, False, context.cache,
                                           context.base_dir).preset_text
        context.identified.append(IdentifiedModel(role, plant, spec, model, meta,
                                                  _pi_key(plant, spec), text))
        return model
    return load_model(confined_path(spec_model, context.base_dir, PresetError))


def resolve_comparison_model(spec, plant, context):
    """The comparison model of a checked ``spec`` (:func:`comparison_spec`), on ``plant``.

    Parameters
    ----------
    spec : dict
        ``{"model": ..., "identify": ...}``.
    plant : HammersteinPlant
        The case's plant (an "identified" model is identified on it).
    context : ResolveContext or pathlib.Path
        The case's context, or the scenario's directory.

    Returns
    -------
    MultivariablePI
        With the plant's numbers of inputs and outputs.

    Raises
    ------
    ValueError
        ``model: message`` for a failed identification, an unreadable model
        file or a model of the wrong size.
    """
    try:
        model = resolve_model(spec["model"], plant, context, spec.get("identify"), role="comparison")
    except (IdentificationError, PresetError) as exc:
        raise ValueError(f"model: {exc}") from None
    ref = plant.hysteresis
    if (model.n_inputs, model.n_outputs) != (ref.n_inputs, ref.n_outputs):
        raise ValueError(f"model: expected a {ref.n_outputs}x{ref.n_inputs} model like the plant's, "
                         f"found {model.n_outputs}x{model.n_inputs}")
    return model


def comparison_model(case, mode, plant, context):
    """The model an open-loop drive case compares with its plant.

    Parameters
    ----------
    case : dict
        The raw ``[[cases]]`` table: ``model`` ("identified", "plant" or a
        model file path relative to the scenario's directory) and, with
        "identified", ``identify``
        (:data:`hammerstein.scenario.identify_tables.IDENTIFY_FIELDS`).
    mode : {'drive', 'reference'}
        Only drives may name a comparison model.
    plant : HammersteinPlant
        The case's plant (the model is identified on it).
    context : ResolveContext or pathlib.Path

    Returns
    -------
    model : MultivariablePI
        With the plant's numbers of inputs and outputs.
    spec : dict
        ``{"model": ..., "identify": validated table}`` (``identify`` only
        with "identified").

    Raises
    ------
    ValueError
        One ``key: message`` per line (unknown ``identify`` keys with hints,
        a reference case, a missing table, a failed identification, a model
        of the wrong size); PresetError for an unreadable model file.
    """
    spec = comparison_spec(case, mode)
    return resolve_comparison_model(spec, plant, context), spec


# -- the Hammerstein compensator: PI and linear dynamics identified in two stages -------
def _fit_dynamics(plant, model, dspec, sensor_flag):
    """DynamicsIdentifier fitted on broadband records of ``plant`` with inputs Gamma_model(U)."""
    sensor = _sensor(sensor_flag, dspec["seed"] + 1000)
    lo, hi = dspec["band"]
    _, volts = excitation(plant.sampling_period, plant.hysteresis.n_inputs, dspec["amplitude"],
                          f_max=hi, f_min=lo, period=dspec["period"], periods=dspec["periods"],
                          seed=dspec["seed"])
    if isinstance(model, MultivariablePI):
        ins, outs = hammerstein_records(plant, model, volts, sensor)
    else:                 # a Preisach model (identify.model = "preisach"): its own simulate
        ins, outs = [], []
        for u in volts:
            y, _ = plant.simulate(u)
            outs.append(y if sensor is None else sensor.measure(y, plant.sampling_period))
            ins.append(model.simulate(u)[0])
    try:
        return DynamicsIdentifier(order=dspec.get("order"), max_order=dspec["max_order"],
                                  sensor=sensor).fit(ins, outs, plant.sampling_period)
    except DynamicsError as exc:
        raise IdentificationError(f"identify_dynamics: {exc}") from None


#: Largest deviation ``max |G(f) G(0)^-1 - I|`` of the identified dynamics at which the PI
#: may be characterised (the dynamics then add < 0.2 % of gain or phase to the loops).
FLAT_TOLERANCE = 0.002
#: Frequency of the first-stage PI characterisation [Hz] (quasi-static for modes >= 100 Hz).
FIRST_STAGE_HZ = 2.0


def flat_frequency(system, tolerance=FLAT_TOLERANCE, f_max=None):
    """Highest frequency below which the dynamics are flat: ``|G(f) G(0)^-1 - I|_2 <= tolerance``.

    Parameters
    ----------
    system : control.StateSpace
        Discrete p x p G.
    tolerance : float
        [-].
    f_max : float, optional
        Upper end of the search [Hz]; default 0.45 / T.

    Returns
    -------
    float
        [Hz] (on a log grid of 400 points from 0.01 Hz).
    """
    f = np.logspace(-2, np.log10(f_max or 0.45 / system.dt), 400)
    Gw = np.asarray(control.frequency_response(system, 2 * np.pi * f).complex).reshape(
        system.noutputs, system.ninputs, f.size)
    G0inv = np.linalg.inv(np.real(Gw[:, :, 0]))
    dev = np.array([np.linalg.norm(Gw[:, :, k] @ G0inv - np.eye(system.noutputs), 2)
                    for k in range(f.size)])
    bad = np.nonzero(dev > tolerance)[0]
    return float(f[-1] if bad.size == 0 else f[max(bad[0] - 1, 0)])


def _hammerstein_key(plant, identify, dspec, model, sensor_flag):
    return (plant_fingerprint(plant), spec_key(identify or {}), spec_key(dspec),
            None if model is None else repr(model_to_table(model)), sensor_flag)


def identified_hammerstein(plant, identify, identify_dynamics=None, model=None, cache=None):
    """PI and linear dynamics of a Hammerstein actuator, identified in two stages (cached).

    1. the PI is identified as for ``kind = "multivariable"``
       (:func:`identified_model`) at ``min(F, 2 Hz)``, F = ``identify.frequency``;
    2. G is identified from broadband multisine records, inputs
       ``Gamma_PI(U)`` (:class:`hammerstein.models.lti.DynamicsIdentifier`:
       order by held-out fit, the sensor low-pass kept out);
    3. the PI characterisation frequency is ``min(F, f_flat)``, ``f_flat``
       the highest frequency where the identified G is flat
       (:func:`flat_frequency`: ``|G(f) G(0)^-1 - I| <= 0.2 %``); at a
       higher F the loops would carry the dynamics' lag and gain (which G^-1
       already compensates). When that frequency differs from the first
       stage's, the PI is identified there and G again with it.

    The first stage characterises the PI at ``min(F, 2 Hz)``: quasi-static
    for bending modes of 100 Hz and more, with the noise averaged over the
    ``periods`` periods.

    With ``model`` given (``model = "plant"`` or a file), only G is identified.

    Parameters
    ----------
    plant : HammersteinPlant
    identify : dict or None
        The compensator's ``identify`` table (validated).
    identify_dynamics : dict, optional
        ``identify_dynamics`` table
        (:data:`hammerstein.scenario.identify_tables.IDENTIFY_DYNAMICS_FIELDS`).
    model : MultivariablePI, optional
        A PI model not to identify.
    cache : IdentificationCache, optional
        The run's cache; default: a new one (only the on-disk cache is shared).

    Returns
    -------
    pi : MultivariablePI
    pi_metadata : dict or None
    dynamics : DynamicsIdentifier
        Fitted (``system_``, ``order_``, ``validation_fit_``...).
    dynamics_metadata : dict
        ``[identification]`` table of the dynamics file.

    Raises
    ------
    IdentificationError
    """
    try:
        dspec = identify_dynamics_table(identify_dynamics or {})
    except Invalid as exc:
        raise IdentificationError(f"identify_dynamics: {exc}") from None
    if plant.is_static:
        raise IdentificationError("dynamics: the plant is static (plant.dynamics = false): "
                                  "there are no dynamics to identify; use dynamics = \"plant\"")
    cache = IdentificationCache() if cache is None else cache
    sensor_flag = dspec.get("sensor", bool((identify or {}).get("sensor", False)))
    given = model

    def load(v):
        ident = DynamicsIdentifier.from_dict(v["ident"], sensor=_sensor(sensor_flag,
                                                                        dspec["seed"] + 1000))
        return (given if given is not None else model_from_table(v["model"]), v["meta"], ident,
                v["dmeta"])

    def dump(value):
        pi, meta, ident, dmeta = value
        table = round_trip_table(pi) if given is None else {}
        return _stored(table, meta=meta, ident=ident.to_dict(), dmeta=dmeta)

    return cache.get("hammerstein", _hammerstein_key(plant, identify, dspec, model, sensor_flag),
                     lambda: _identify_hammerstein(plant, identify, dspec, given, sensor_flag, cache),
                     load=load, dump=dump)


def _identify_hammerstein(plant, identify, dspec, model, sensor_flag, cache):
    meta = None
    if model is None:                       # stage 1: quasi-static PI, then G
        spec = identify_table(identify)
        F = spec["frequency"]
        model, meta = identified_model(plant, {**spec, "frequency": min(F, FIRST_STAGE_HZ)}, cache)
        ident = _fit_dynamics(plant, model, dspec, sensor_flag)
        f_flat = flat_frequency(ident.system_)
        f_pi = min(F, max(f_flat, 0.01))
        if f_pi != min(F, FIRST_STAGE_HZ):   # stage 2: PI where G is flat (at F if it is), G again
            model, meta = identified_model(plant, {**spec, "frequency": f_pi}, cache)
            ident = _fit_dynamics(plant, model, dspec, sensor_flag)
        meta = {**meta, "requested_frequency_hz": float(F), "flat_frequency_hz": f_flat,
                "note": "PI characterised at min(F, flat frequency of the identified G)"}
    else:
        ident = _fit_dynamics(plant, model, dspec, sensor_flag)
    fn, zeta = modal_parameters(ident.system_)
    dmeta = {"method": "subspace (PO-MOESP, nfoursid), order by held-out fit",
             "order": int(ident.order_),
             "validation_fit_percent": [float(v) for v in np.nan_to_num(ident.validation_fit_)],
             "fit_percent": [float(v) for v in ident.fit_percent_],
             "natural_frequency_hz": [float(v) for v in fn],
             "damping_ratio": [float(v) for v in zeta],
             "excitation": {k: v for k, v in dspec.items()},
             "sensor": bool(sensor_flag),
             "sampling_period_s": float(plant.sampling_period),
             "plant": plant.name}
    return model, meta, ident, dmeta


def resolve_dynamics(spec, plant, context, model=None):
    """The discrete G a ``kind = "hammerstein"`` compensator inverts, and its PI model.

    Parameters
    ----------
    spec : dict
        Validated compensator table: ``model``, ``identify``, ``dynamics``
        (``"plant"``, ``"identified"`` or a dynamics/preset file path),
        ``identify_dynamics``.
    plant : HammersteinPlant
    context : ResolveContext or pathlib.Path
        The case's context (identified dynamics are recorded in it).
    model : MultivariablePI, optional
        Already resolved PI model (``model`` other than "identified").

    Returns
    -------
    pi : MultivariablePI
    G : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        Discrete, ``dt`` = the plant's sampling period (the plant's own
        dynamics as a ``SampledSystem``).

    Raises
    ------
    IdentificationError, PresetError
    """
    context = _context(context)
    dyn = dynamics_source(spec)
    if dyn == "identified" and spec.get("model") == "identified" and \
            "records" in (spec.get("identify") or {}):   # the route of identify + compensate
        found = identified_from_records(plant, spec["identify"], True, context.cache,
                                        context.base_dir)
        if found.plant.is_static:
            raise IdentificationError(
                f"identify (records = '{spec['identify']['records']}'): no dynamics identified"
                + ("; give dynamics_records (the broadband records of identify "
                   "--dynamics-records)" if spec["identify"]["records"] == "files" else ""))
        ispec = identify_table(spec["identify"])
        ident = found.result.dynamics.identifier
        fn, zeta = modal_parameters(ident.system_)
        files = ispec["records"] == "files"
        dmeta = {"method": "subspace (PO-MOESP), order by held-out fit: the pipeline of "
                           "hammerstein identify on "
                           + ("the measured dynamics_records" if files else
                              "the multisines of hammerstein excitation"),
                 "order": int(ident.order_),
                 "validation_fit_percent": [float(v) for v in np.nan_to_num(ident.validation_fit_)],
                 "fit_percent": [float(v) for v in ident.fit_percent_],
                 "natural_frequency_hz": [float(v) for v in fn],
                 "damping_ratio": [float(v) for v in zeta],
                 "sensor": bool(ispec.get("sensor", False)),
                 "sampling_period_s": float(plant.sampling_period), "plant": plant.name}
        context.identified.append(IdentifiedDynamics(
            plant, found.plant.hysteresis, found.metadata, ident, dmeta,
            (plant_fingerprint(plant), spec_key(ispec), True), found.preset_text,
            found.result.dynamics.summary))
        return found.plant.hysteresis, found.plant.sampled_dynamics
    if dyn == "identified":
        ident_pi = spec.get("model") == "identified"
        identify = spec.get("identify") if ident_pi else None
        given = None if ident_pi else model
        pi, pmeta, ident, dmeta = identified_hammerstein(plant, identify, spec.get("identify_dynamics"),
                                                         given, context.cache)
        dspec = identify_dynamics_table(spec.get("identify_dynamics") or {})
        sensor_flag = dspec.get("sensor", bool((identify or {}).get("sensor", False)))
        context.identified.append(IdentifiedDynamics(
            plant, pi, pmeta, ident, dmeta, _hammerstein_key(plant, identify, dspec, given, sensor_flag)))
        return pi, ident.system_
    if dyn == "plant":
        G = plant.sampled_dynamics       # inverted without python-control (see ZPETCInverse)
        if G is None:
            raise IdentificationError("dynamics: the plant is static (no dynamics); "
                                      "a Hammerstein compensator needs dynamics")
    else:
        path = confined_path(dyn, context.base_dir, PresetError)
        G = load_dynamics(path, plant.hysteresis.output_names, plant.sampling_period)
    if model is None and spec.get("model") == "identified":
        # as with identified dynamics: the PI is characterised where this G is flat
        ispec = identify_table(spec.get("identify"))
        f_pi = min(ispec["frequency"],
                   max(flat_frequency(G.to_control() if hasattr(G, "to_control") else G), 0.01))
        return identified_model(plant, {**ispec, "frequency": f_pi}, context.cache)[0], G
    pi = model if model is not None else resolve_model(spec.get("model", "plant"), plant, context,
                                                       spec.get("identify"))
    return pi, G
