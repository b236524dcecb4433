"""Identified models in scenarios: ``model = "identified"`` with an ``identify`` table.

A compensator table (or an open-loop drive case that compares a model with
the plant) may name the model "identified at f Hz on this plant"::

    model = "identified"
    identify = { frequency = 50.0, amplitude = 10.0, periods = 3, n_hysterons = 15,
                 method = "least-squares", partition = "time", bounds = "monotone",
                 sensor = false, seed = 0 }

Only ``frequency`` is required (:data:`IDENTIFY_FIELDS` lists the defaults).
The model is identified on the case's own plant (same preset and dynamics
setting) by the characterisation experiment of Section 3.3, Steps 1-4: a
sine on each input in turn, all outputs recorded
(:func:`hammerstein.sensors.characterize`), then
:class:`hammerstein.identification.MultivariableIdentifier`. Identified
models are cached in-process on (plant content, identify table), so a
scenario with many cases identifies each model once, and on disk
(:mod:`hammerstein.scenario.diskcache`), so a later run does not identify them
again; they are saved into
the report directory as ``models/identified-<f>Hz-<method>.toml``
(:func:`hammerstein.presets.save_model`; loadable by ``model = "path"``).

``sensor = true`` measures the outputs through the inductive sensor model of
docs/identification.md (IBS ECL202): 40 nm quantisation, first-order 2 kHz bandwidth, and
white noise of :data:`SENSOR_NOISE_RMS` = 0.02 µm RMS (half a quantisation
step; the paper does not state the noise) drawn with ``seed``.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from hammerstein.core.dynamics import DynamicsError
from hammerstein.core.files import confined_path
from hammerstein.core.identification import IdentificationError, MultivariableIdentifier
from hammerstein.core.lti import (DynamicsIdentifier, excitation, hammerstein_records,
                                  modal_parameters)
from hammerstein.core.presets import (PresetError, load_dynamics, load_model, model_from_table,
                                      model_to_table, save_dynamics, save_model)
from hammerstein.core.sensors import Sensor, characterize, identification_metadata
from hammerstein.exceptions import NestedInvalid
from hammerstein.core.lazy import lazy_module
from hammerstein.scenario import diskcache
from hammerstein.scenario.schema import (MAX_HYSTERONS, MAX_IDENTIFY_PERIODS, Field, Invalid, _short,
                                         boolean, check_table, choice,
                                         integer, number)

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = [
    "IDENTIFY_FIELDS",
    "SENSOR_NOISE_RMS",
    "NestedInvalid",
    "identify_table",
    "identified_model",
    "nyquist_problem",
    "model_file_name",
    "clear_cache",
    "save_identified_models",
    "resolve_model",
    "comparison_spec",
    "resolve_comparison_model",
    "comparison_model",
    "HAMMERSTEIN_IDENTIFY_DEFAULTS",
    "hammerstein_identify_table",
    "IDENTIFY_DYNAMICS_FIELDS",
    "identify_dynamics_table",
    "identified_hammerstein",
    "resolve_dynamics",
    "save_identified_dynamics",
    "flat_frequency",
]

#: White-noise RMS [µm] of the ECL202 sensor model used by ``sensor = true``.
SENSOR_NOISE_RMS = 0.02


def _bounds(v):
    if v in ("none", "nonnegative", "monotone"):
        return v
    if (isinstance(v, list) and len(v) == 2
            and all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in v)
            and v[0] < v[1]):
        return [float(a) for a in v]
    hint = choice("none", "nonnegative", "monotone")
    try:
        hint(v)
    except Invalid as exc:
        raise Invalid(f"{exc}, or [lo, hi] weight bounds [µm/V]") from None
    return v


def _n_hysterons(v):
    if isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_HYSTERONS:
        return v
    if (isinstance(v, list) and v and all(isinstance(r, list) and r for r in v)
            and all(isinstance(a, int) and not isinstance(a, bool) and 1 <= a <= MAX_HYSTERONS
                    for r in v for a in r)):
        return v
    raise Invalid(f"expected an integer 1..{MAX_HYSTERONS} or a p x m table of them, "
                  f"found {_short(v)}")


def _amplitude(v):
    if isinstance(v, list):
        return [number("V", 0)(a) for a in v]
    return number("V", 0)(v)


#: Schema of the ``identify`` table: key -> Field (checker, default).
IDENTIFY_FIELDS = {
    "frequency": Field(number("Hz", 0), required=True),
    "amplitude": Field(_amplitude),                       # default: plant's input_amplitude
    "periods": Field(integer(2, MAX_IDENTIFY_PERIODS), default=3),
    "n_hysterons": Field(_n_hysterons, default=15),
    "method": Field(choice("closed-form", "least-squares"), default="closed-form"),
    "partition": Field(choice("time", "input"), default="time"),
    "bounds": Field(_bounds, default="none"),
    "sensor": Field(boolean(), default=False),
    "seed": Field(integer(0), default=0),
}


def identify_table(value):
    """Field checker of an ``identify`` table (all problems at once).

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled (``amplitude`` stays absent when not
        given: the plant model's ``input_amplitude`` is used).

    Raises
    ------
    NestedInvalid
        Listing ``(key, message)`` for every problem (unknown keys with the
        closest valid key, missing ``frequency``, bad values).
    """
    def cross(clean):
        if clean.get("bounds", "none") != "none" and clean.get("method") != "least-squares":
            yield "bounds: only used by method = 'least-squares'"

    return _nested_table(value, IDENTIFY_FIELDS, "{ frequency = 50.0 }", cross)


def _nested_table(value, fields, example, cross):
    """Check a nested table against ``fields``, then ``cross(clean)``'s "key: message" lines.

    Raises ``Invalid`` when ``value`` is no table (naming ``example``) and
    ``NestedInvalid`` with every ``(key, message)`` problem at once.
    """
    problems = []
    clean = check_table(value, fields, "", problems, "")
    if clean is None:
        raise Invalid(f"expected a table such as {example}, found {value!r}")
    problems += [f": {line}" for line in cross(clean)]
    if problems:  # check_table lines read ": key: message" with an empty source
        raise NestedInvalid([tuple(p[2:].split(": ", 1)) for p in problems])
    return clean


# -- identification with an in-process cache ------------------------------------------
_CACHE: dict = {}


def clear_cache():
    """Forget every identified model and dynamics of this process (tests).

    The on-disk cache (:mod:`hammerstein.scenario.diskcache`) is kept.
    """
    _CACHE.clear()
    _HCACHE.clear()


def _model_table(model):
    """``model_to_table(model)`` when it gives the same model back, else None (not cached)."""
    table = model_to_table(model)
    try:
        same = model_to_table(model_from_table(table)) == table
    except PresetError:
        same = False
    return table if same else None


def _from_disk(kind, key, build):
    """``build(value)`` of the on-disk entry of ``(kind, key)``; None if absent or unusable."""
    value = diskcache.load(kind, key)
    if value is None:
        return None
    try:
        return build(value)
    except (KeyError, TypeError, ValueError, PresetError, DynamicsError):
        return None     # an entry of an older shape: identify again


def _to_disk(kind, key, value):
    """Store ``value`` unless its model table did not round-trip (``value["model"]`` None)."""
    if value["model"] is not None:
        diskcache.store(kind, key, value)


def _plant_fingerprint(plant):
    """Content hash of a plant: PI model table, sampling period, dynamics matrices."""
    h = hashlib.sha1(repr(model_to_table(plant.hysteresis)).encode())
    h.update(repr(float(plant.sampling_period)).encode())
    if not plant.is_static:  # the matrices: no python-control needed
        for mat in plant.matrices:
            h.update(np.ascontiguousarray(mat, dtype=float).tobytes())
    else:
        h.update(b"static")
    return h.hexdigest()


def _freeze(v):
    return tuple(_freeze(a) for a in v) if isinstance(v, list) else v


def _spec_key(spec):
    return tuple(sorted((k, _freeze(v)) for k, v in spec.items()))


def nyquist_problem(spec, plant):
    """``identify.frequency: ...`` when the excitation of ``spec`` is not below the plant's Nyquist frequency.

    Parameters
    ----------
    spec : dict
        Validated ``identify`` table (:func:`identify_table`).
    plant : HammersteinPlant

    Returns
    -------
    str or None
        The problem, or None when ``frequency < 1 / (2 T)``.
    """
    f, nyquist = spec["frequency"], 0.5 / plant.sampling_period
    if f >= nyquist:
        return f"identify.frequency: {f:g} Hz is beyond the Nyquist frequency {nyquist:g} Hz of the plant"
    return None


def identified_model(plant, spec):
    """The model identified on ``plant`` by the ``identify`` table ``spec`` (cached).

    Parameters
    ----------
    plant : HammersteinPlant
        The case's plant (its preset and dynamics setting).
    spec : dict
        ``identify`` table (validated by :func:`identify_table` or raw; it is
        validated again here).

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
    key = (_plant_fingerprint(plant), _spec_key(spec))
    if key in _CACHE:
        return _CACHE[key]
    stored = _from_disk("pi", key, lambda v: (model_from_table(v["model"]), v["meta"]))
    if stored is not None:
        _CACHE[key] = stored
        return stored
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
    sensor = Sensor(resolution=0.04, bandwidth_hz=2000.0, noise_rms=SENSOR_NOISE_RMS,
                    seed=spec["seed"]) if spec["sensor"] else None
    records = characterize(plant, amp, f, spec["periods"], sensor)
    options = {"partition": spec["partition"]}
    if spec["method"] == "least-squares":
        options["bounds"] = None if spec["bounds"] == "none" else spec["bounds"]
    fit_options = {"skip": "auto"} if spec["method"] == "least-squares" else None
    ident = MultivariableIdentifier(spec["method"], spec["n_hysterons"], **options)
    try:
        ident.fit(records, model.input_names, model.output_names,
                  fit_options=fit_options)
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
    _CACHE[key] = (ident.model_, meta)
    _to_disk("pi", key, {"model": _model_table(ident.model_), "meta": meta})
    return _CACHE[key]


def model_file_name(spec):
    """``identified-<frequency>Hz-<method>.toml`` of an ``identify`` table.

    Parameters
    ----------
    spec : dict
        The ``identify`` table: ``frequency`` [Hz] and, optionally,
        ``method`` (default ``"closed-form"``).

    Returns
    -------
    str
        The file name, frequency formatted with ``:g``.
    """
    return f"identified-{spec['frequency']:g}Hz-{spec.get('method', 'closed-form')}.toml"


def _used_specs(scenario):
    """[(case name, role, plant, identify spec)] of the identified models of a scenario."""
    used = []
    for case in scenario.cases:
        comp = case.compensator_spec or {}
        if (case.mode == "reference" and comp.get("model") == "identified" and "identify" in comp
                and comp.get("kind") != "hammerstein"):     # see save_identified_dynamics
            used.append((case.name, "compensator", case.plant, comp["identify"]))
        mspec = getattr(case, "model_spec", None) or {}
        if mspec.get("model") == "identified" and "identify" in mspec:
            used.append((case.name, "comparison", case.plant, mspec["identify"]))
    return used


def save_identified_models(scenario, directory):
    """Save every identified model a scenario used into ``directory/models/``.

    File names are :func:`model_file_name`; a second, different model with
    the same name gets the plant label (``-static`` / ``-hammerstein``), then
    ``-2``, ``-3``... before ``.toml``. Models come from the cache
    (identified while loading).

    Parameters
    ----------
    scenario : hammerstein.scenarios.Scenario
    directory : pathlib.Path
        The report directory being written.

    Returns
    -------
    list of dict
        One row per case and role: ``case``, ``role`` ('compensator' or
        'comparison'), ``file`` (relative to ``directory``), ``plant``.
    """
    directory = Path(directory)
    files, names, rows = {}, set(), []
    for case_name, role, plant, spec in _used_specs(scenario):
        model, meta = identified_model(plant, spec)
        key = (_plant_fingerprint(plant), _spec_key(identify_table(spec)))
        if key not in files:
            base = model_file_name(spec)[:-len(".toml")]
            label = "hammerstein" if not plant.is_static else "static"
            name, i = f"{base}.toml", 1
            if name in names:
                name = f"{base}-{label}.toml"
            while name in names:
                i += 1
                name = f"{base}-{label}-{i}.toml"
            names.add(name)
            files[key] = f"models/{name}"
            save_model(model, directory / files[key], meta)
        rows.append({"case": case_name, "role": role, "file": files[key], "plant": meta["plant"]})
    return rows


# -- models of compensators and model-vs-plant comparisons (paper Fig. 6, 7) ---------
def resolve_model(spec_model, plant, base_dir, identify=None):
    """The multivariable PI model a compensator (or a comparison) is built from.

    Parameters
    ----------
    spec_model : str
        ``"plant"`` (the plant's own PI model), ``"identified"`` (identified
        on ``plant`` by the ``identify`` table, :func:`identified_model`) or a
        model/preset TOML path, relative to ``base_dir`` when not absolute.
    plant : HammersteinPlant
    base_dir : pathlib.Path
    identify : dict, optional
        The ``identify`` table (required with ``"identified"``).

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
    if spec_model in (None, "plant"):
        return plant.hysteresis
    if spec_model == "identified":
        if identify is None:
            raise IdentificationError("identify: missing (required with model = 'identified'), "
                                      "e.g. identify = { frequency = 50.0 }")
        return identified_model(plant, identify)[0]
    return load_model(confined_path(spec_model, base_dir, PresetError))


def comparison_spec(case, mode):
    """Check the ``model`` / ``identify`` keys of a case (no model is loaded or identified).

    Parameters
    ----------
    case : dict
        The raw ``[[cases]]`` table: ``model`` ("identified", "plant" or a
        model file path) and, with "identified", ``identify``
        (:data:`IDENTIFY_FIELDS`).
    mode : {'drive', 'reference'}
        Only drives may name a comparison model.

    Returns
    -------
    dict
        ``{"model": ..., "identify": validated table}`` (``identify`` only
        with "identified").

    Raises
    ------
    ValueError
        One ``key: message`` per line (unknown ``identify`` keys with hints,
        a reference case, a missing table).
    """
    name = case.get("model")
    lines = []
    if mode != "drive":
        lines.append("model: a model is compared with the plant in open-loop drive cases only; "
                     "the compensator's model is compensator.model")
    if not isinstance(name, str):
        lines.append(f"model: expected 'identified', 'plant' or a model file path, found {name!r}"
                     if "model" in case else
                     "identify: only used with model = 'identified' (add model = \"identified\")")
    spec = {"model": name}
    if name == "identified":
        if "identify" not in case:
            lines.append("identify: missing (required with model = 'identified'), "
                         "e.g. identify = { frequency = 50.0 }")
        else:
            try:
                spec["identify"] = identify_table(case["identify"])
            except Invalid as exc:
                lines += [f"identify.{k}: {m}" for k, m in getattr(exc, "problems", [])] \
                    or [f"identify: {exc}"]
    elif "identify" in case and isinstance(name, str):
        lines.append(f"identify: only used with model = 'identified', found model = {name!r}")
    if lines:
        raise ValueError("\n".join(lines))
    return spec


def resolve_comparison_model(spec, plant, base_dir):
    """The comparison model of a checked ``spec`` (:func:`comparison_spec`), on ``plant``.

    Parameters
    ----------
    spec : dict
        ``{"model": ..., "identify": ...}``.
    plant : HammersteinPlant
        The case's plant (an "identified" model is identified on it).
    base_dir : pathlib.Path
        Directory of the scenario file (relative model paths).

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
        model = resolve_model(spec["model"], plant, base_dir, spec.get("identify"))
    except (IdentificationError, PresetError) as exc:
        raise ValueError(f"model: {exc}") from None
    ref = plant.hysteresis
    if (model.n_inputs, model.n_outputs) != (ref.n_inputs, ref.n_outputs):
        raise ValueError(f"model: expected a {ref.n_outputs}x{ref.n_inputs} model like the plant's, "
                         f"found {model.n_outputs}x{model.n_inputs}")
    return model


def comparison_model(case, mode, plant, base_dir):
    """The model an open-loop drive case compares with its plant.

    Parameters
    ----------
    case : dict
        The raw ``[[cases]]`` table: ``model`` ("identified", "plant" or a
        model file path relative to ``base_dir``) and, with "identified",
        ``identify`` (:data:`IDENTIFY_FIELDS`).
    mode : {'drive', 'reference'}
        Only drives may name a comparison model.
    plant : HammersteinPlant
        The case's plant (the model is identified on it).
    base_dir : pathlib.Path

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
    if plant is None:
        raise ValueError("")
    return resolve_comparison_model(spec, plant, base_dir), spec


# -- the Hammerstein compensator: PI and linear dynamics identified in two stages -------
#: ``identify`` defaults of ``kind = "hammerstein"``: least squares with monotone direct
#: transfers on 40 hysterons (time partition: dense near the reversals) and 5 periods (the
#: sensor noise averages out; the static error at small radii is the lever once G is
#: inverted). Any key given in the scenario overrides these.
HAMMERSTEIN_IDENTIFY_DEFAULTS = {"method": "least-squares", "bounds": "monotone",
                                 "partition": "time", "n_hysterons": 40, "periods": 5}


def hammerstein_identify_table(value):
    """Field checker of the ``identify`` table of ``kind = "hammerstein"``.

    As :func:`identify_table`, with :data:`HAMMERSTEIN_IDENTIFY_DEFAULTS`
    for the keys not given.

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled.

    Raises
    ------
    NestedInvalid
        As :func:`identify_table`.
    """
    if isinstance(value, dict):
        value = {**HAMMERSTEIN_IDENTIFY_DEFAULTS, **value}
    return identify_table(value)


def _band(v):
    if (isinstance(v, list) and len(v) == 2 and all(isinstance(a, (int, float))
                                                    and not isinstance(a, bool) for a in v)
            and 0 < v[0] < v[1]):
        return [float(a) for a in v]
    raise Invalid(f"expected [f_min, f_max] in Hz with 0 < f_min < f_max, found {v!r}")


#: Schema of the ``identify_dynamics`` table (defaults: 8 V random-phase multisines on
#: each input in turn, 20 Hz-1 kHz, 8 periods of 50 ms, order chosen from the data).
IDENTIFY_DYNAMICS_FIELDS = {
    "excitation": Field(choice("multisine"), default="multisine"),
    "amplitude": Field(number("V", 0), default=8.0),
    "band": Field(_band, default=[20.0, 1000.0]),
    "period": Field(number("s", 0), default=0.05),
    "periods": Field(integer(2, MAX_IDENTIFY_PERIODS), default=8),
    "order": Field(integer(1, 50)),                    # default: chosen by held-out fit
    "max_order": Field(integer(1, 50), default=8),
    "sensor": Field(boolean()),                        # default: as identify.sensor
    "seed": Field(integer(0), default=1),
}


def identify_dynamics_table(value):
    """Field checker of an ``identify_dynamics`` table (every key optional).

    Parameters
    ----------
    value : object
        Parsed TOML value.

    Returns
    -------
    dict
        The table with defaults filled (``order`` and ``sensor`` stay absent
        when not given: chosen from the data, and as ``identify.sensor``).

    Raises
    ------
    NestedInvalid
        Listing ``(key, message)`` for every problem.
    """
    def cross(clean):
        if "order" in clean and clean["order"] > clean["max_order"]:
            yield "order: expected <= max_order"

    return _nested_table(value, IDENTIFY_DYNAMICS_FIELDS,
                         "{ amplitude = 8.0, band = [20.0, 1000.0] }", cross)


def _sensor(flag, seed):
    return Sensor(resolution=0.04, bandwidth_hz=2000.0, noise_rms=SENSOR_NOISE_RMS,
                  seed=seed) if flag else None


def _fit_dynamics(plant, model, dspec, sensor_flag):
    """DynamicsIdentifier fitted on broadband records of ``plant`` with inputs Gamma_model(U)."""
    sensor = _sensor(sensor_flag, dspec["seed"] + 1000)
    lo, hi = dspec["band"]
    _, volts = excitation(plant.sampling_period, plant.hysteresis.n_inputs, dspec["amplitude"],
                          f_max=hi, f_min=lo, period=dspec["period"], periods=dspec["periods"],
                          seed=dspec["seed"])
    ins, outs = hammerstein_records(plant, model, volts, sensor)
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


_HCACHE: dict = {}


def identified_hammerstein(plant, identify, identify_dynamics=None, model=None):
    """PI and linear dynamics of a Hammerstein actuator, identified in two stages (cached).

    1. the PI is identified as for ``kind = "multivariable"``
       (:func:`identified_model`) at ``min(F, 2 Hz)``, F = ``identify.frequency``;
    2. G is identified from broadband multisine records, inputs
       ``Gamma_PI(U)`` (:class:`hammerstein.core.lti.DynamicsIdentifier`:
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
        ``identify_dynamics`` table (:data:`IDENTIFY_DYNAMICS_FIELDS`).
    model : MultivariablePI, optional
        A PI model not to identify.

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
    sensor_flag = dspec.get("sensor", bool((identify or {}).get("sensor", False)))
    key = (_plant_fingerprint(plant), _spec_key(identify or {}), _spec_key(dspec),
           None if model is None else repr(model_to_table(model)), sensor_flag)
    if key in _HCACHE:
        return _HCACHE[key]
    given = model

    def build(v):
        ident = DynamicsIdentifier.from_dict(v["ident"], sensor=_sensor(sensor_flag,
                                                                        dspec["seed"] + 1000))
        return (given if given is not None else model_from_table(v["model"]), v["meta"], ident,
                v["dmeta"])

    stored = _from_disk("hammerstein", key, build)
    if stored is not None:
        _HCACHE[key] = stored
        return stored
    meta = None
    if model is None:                       # stage 1: quasi-static PI, then G
        spec = identify_table(identify)
        F = spec["frequency"]
        model, meta = identified_model(plant, {**spec, "frequency": min(F, FIRST_STAGE_HZ)})
        ident = _fit_dynamics(plant, model, dspec, sensor_flag)
        f_flat = flat_frequency(ident.system_)
        f_pi = min(F, max(f_flat, 0.01))
        if f_pi != min(F, FIRST_STAGE_HZ):   # stage 2: PI where G is flat (at F if it is), G again
            model, meta = identified_model(plant, {**spec, "frequency": f_pi})
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
    _HCACHE[key] = (model, meta, ident, dmeta)
    _to_disk("hammerstein", key, {"model": _model_table(model) if given is None else {},
                                  "meta": meta, "ident": ident.to_dict(), "dmeta": dmeta})
    return _HCACHE[key]


def resolve_dynamics(spec, plant, base_dir, model=None):
    """The discrete G a ``kind = "hammerstein"`` compensator inverts, and its PI model.

    Parameters
    ----------
    spec : dict
        Validated compensator table: ``model``, ``identify``, ``dynamics``
        (``"plant"``, ``"identified"`` or a dynamics/preset file path),
        ``identify_dynamics``.
    plant : HammersteinPlant
    base_dir : pathlib.Path
    model : MultivariablePI, optional
        Already resolved PI model (``model`` other than "identified").

    Returns
    -------
    pi : MultivariablePI
    G : control.StateSpace
        Discrete, ``dt`` = the plant's sampling period.

    Raises
    ------
    IdentificationError, PresetError
    """
    dyn = spec.get("dynamics") or ("identified" if spec.get("model") == "identified" else "plant")
    if dyn == "identified":
        ident_pi = spec.get("model") == "identified"
        pi, _, ident, _ = identified_hammerstein(plant, spec.get("identify") if ident_pi else None,
                                                 spec.get("identify_dynamics"),
                                                 None if ident_pi else model)
        return pi, ident.system_
    if dyn == "plant":
        if plant.dynamics is None:
            raise IdentificationError("dynamics: the plant is static (no dynamics); "
                                      "a Hammerstein compensator needs dynamics")
        G = plant.dynamics
    else:
        path = confined_path(dyn, base_dir, PresetError)
        G = load_dynamics(path, plant.hysteresis.output_names, plant.sampling_period)
    if model is None and spec.get("model") == "identified":
        # as with identified dynamics: the PI is characterised where this G is flat
        ispec = identify_table(spec.get("identify"))
        f_pi = min(ispec["frequency"], max(flat_frequency(G), 0.01))
        return identified_model(plant, {**ispec, "frequency": f_pi})[0], G
    pi = model if model is not None else resolve_model(spec.get("model", "plant"), plant, base_dir,
                                                       spec.get("identify"))
    return pi, G


def _dynamics_specs(scenario):
    """[(case name, plant, compensator spec)] of the cases whose G is identified."""
    used = []
    for case in scenario.cases:
        comp = case.compensator_spec or {}
        dyn = comp.get("dynamics") or ("identified" if comp.get("model") == "identified" else "plant")
        if case.mode == "reference" and comp.get("kind") == "hammerstein" and dyn == "identified":
            used.append((case.name, case.plant, comp))
    return used


def save_identified_dynamics(scenario, directory):
    """Save the PI models and dynamics that ``kind = "hammerstein"`` cases identified.

    Files ``models/hammerstein-<i>-pi.toml`` (model file) and
    ``models/hammerstein-<i>-dynamics.toml`` (``[dynamics] kind =
    "state_space"``, continuous ZOH equivalent: loadable by ``dynamics =
    "<file>"``), one pair per distinct identification (from the cache).

    Parameters
    ----------
    scenario : hammerstein.scenario.resolve.Scenario
    directory : pathlib.Path

    Returns
    -------
    list of dict
        One per distinct identification: ``cases``, ``pi_file``,
        ``dynamics_file``, ``identifier`` (DynamicsIdentifier), ``plant``
        (HammersteinPlant), ``metadata`` (of the dynamics).
    """
    directory = Path(directory)
    out, index = [], {}
    for name, plant, comp in _dynamics_specs(scenario):
        ident_pi = comp.get("model") == "identified"
        model = None if ident_pi else resolve_model(comp.get("model", "plant"), plant,
                                                     scenario.path.parent, comp.get("identify"))
        pi, pmeta, ident, dmeta = identified_hammerstein(
            plant, comp.get("identify") if ident_pi else None, comp.get("identify_dynamics"), model)
        key = id(ident)
        if key not in index:
            i = len(out) + 1
            row = {"cases": [], "pi_file": None, "dynamics_file": f"models/hammerstein-{i}-dynamics.toml",
                   "identifier": ident, "plant": plant, "metadata": dmeta}
            if ident_pi:
                row["pi_file"] = f"models/hammerstein-{i}-pi.toml"
                save_model(pi, directory / row["pi_file"], pmeta)
            save_dynamics(ident.system_, directory / row["dynamics_file"], dmeta)
            index[key] = row
            out.append(row)
        index[key]["cases"].append(name)
    return out
