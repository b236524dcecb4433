"""Execution of resolved cases: simulation and metrics of one case.

:func:`run_case` simulates a resolved case (an open-loop drive on the plant,
optionally against a comparison model, or reference -> compensator -> plant
with :func:`hammerstein.simulation.simulate_chain`) and computes its metrics
(:mod:`hammerstein.signals.metrics`); :func:`chain_result` turns an already
simulated chain (e.g. from the batch kernel,
:func:`hammerstein.scenario.sweeps.run_cases`) into the same
:class:`CaseResult`. A compensator divergence is a result, not an exception.
A reference case on an identified or hardware-like plant
(:func:`starts_as_hardware`) runs the drive ``hammerstein compensate``
writes (:func:`hammerstein.scenario.hardware_route.start_drive`: faded in
from the model's rest output), its metrics after the fade-in.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from hammerstein.signals import metrics as met
from hammerstein.models.amplifier import drive_metrics
from hammerstein.compensation.drive import (FADE_DECAYS, MIN_FADE_S, apply_amplifier,
                                           default_fade_samples)
from hammerstein.compensation.hammerstein_compensator import fade_in
from hammerstein.signals.references import DRIVE_KINDS, REFERENCE_KINDS
from hammerstein.exceptions import CompensatorDivergence
from hammerstein.scenario.hardware_route import (compensator_plant, hardware_start, start_drive,
                                                 unfollowed_problem)
from hammerstein.scenario.registry import compensator_kind
from hammerstein.simulation import ChainResult, simulate_chain

__all__ = ["CaseResult", "run_case", "chain_result", "model_comparison", "fade_samples", "signal_kind",
           "runs_alone", "drive_rows", "starts_as_hardware"]


@dataclass
class CaseResult:
    """Simulation and metrics of one case.

    Parameters
    ----------
    spec : hammerstein.scenario.validate.CaseSpec
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V] (NaN after a divergence).
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm] (NaN after a divergence).
    reference : numpy.ndarray or None, shape (p, n_samples)
        The reference the compensator tracked [µm]: the case's reference
        faded in from rest over :func:`fade_samples` where the case fades in
        (the metrics, on the settled window after the fade, use the case's
        reference, the same values there); None for drives.
    divergence : CompensatorDivergence or None
    metrics : list of dict
        Rows ``{channel, metric, value, unit}``.
    warnings : list of str
    model_outputs : numpy.ndarray or None, shape (p, n_samples)
        Drives with a comparison model: the model's displacements [µm].
    """

    spec: Any
    inputs: np.ndarray
    outputs: np.ndarray
    reference: np.ndarray | None
    divergence: Any
    metrics: list
    warnings: list
    model_outputs: np.ndarray | None = None

    @property
    def name(self):
        return self.spec.name

    @property
    def diverged_at(self):
        """Time of the divergence [s], or None."""
        if self.divergence is None:
            return None
        return float(self.divergence.sample * self.spec.plant.sampling_period)


def run_case(case):
    """Simulate one resolved case and compute its metrics.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
        Resolved (:func:`hammerstein.scenario.resolve.resolve_scenario`).

    Returns
    -------
    CaseResult
        A compensator divergence is a result (metric ``diverged_at_time``
        [s]), not an exception.
    """
    plant = case.plant
    names = list(plant.hysteresis.output_names)
    caught = list(case.warnings)
    if case.mode == "drive":
        u = case.signal
        amp = getattr(plant, "amplifier", None)
        if amp is not None:     # the drive through the plant's amplifier, as a compensator's
            with warnings.catch_warnings(record=True) as rec:
                warnings.simplefilter("always")
                amp.check(u, plant.sampling_period, "warn", f"{case.where}.drive")
            caught += [str(w.message) for w in rec]
            u, _ = amp.apply(u, plant.sampling_period)
        y, _ = plant.simulate(u)
        rows = met.open_loop_metrics(u, y, case.driven_input, names,
                                     case.period_samples, case.settle_periods)
        ym = None
        if case.model is not None:  # model vs plant (Fig. 6, 7)
            ym, more = model_comparison(case, y, u)
            rows += more
        return CaseResult(case, u, y, None, None, rows, caught, ym)
    if starts_as_hardware(case):
        return _hardware_case(case, caught)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        fade = fade_samples(case)
        tracked = fade_in(case.signal, fade) if fade else case.signal   # what the chain follows
        if compensator_kind(case.compensator_spec).look_ahead:   # e.g. an inverse of G: it
            res = case.compensator.run_reference(plant, case.signal, case.period_samples, fade)
        else:                                                    # fades in the same way
            res = simulate_chain(case.compensator, plant, tracked)
        commanded = res.inputs
        res = _through_amplifier(case, res)
    caught += [str(w.message) for w in rec]
    result = chain_result(case, res, caught, commanded, tracked)
    if hasattr(case.compensator, "history_rows") and not res.diverged:   # kind "ilc"
        result.metrics += case.compensator.history_rows(list(plant.hysteresis.output_names))
        result.warnings += [f"ILC: {n}" for n in getattr(case.compensator, "notes", [])]
    return result


def starts_as_hardware(case):
    """True when a reference case starts as ``hammerstein compensate`` starts its drive.

    A compensated reference case (any kind but ``ilc``) on a plant of
    :func:`hammerstein.models.plant.hardware_start` (an amplifier,
    or a model whose output at 0 V is not 0 µm): its drive is
    :func:`hammerstein.scenario.hardware_route.start_drive`'s, faded in from
    the model's rest output over the hardware commands' duration.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec

    Returns
    -------
    bool
    """
    return (case.mode == "reference" and case.compensator is not None
            and case.compensator_spec.get("kind") != "ilc" and hardware_start(case.plant))


def _hardware_case(case, caught):
    """A case of :func:`starts_as_hardware`: the drive ``compensate`` writes, then the plant.

    The metrics skip the settling periods or the fade-in, whichever is longer
    (a note says so when it is the fade-in); the drive's shaping notes go to
    the case's notes.
    """
    plant = case.plant
    T = plant.sampling_period
    P = case.period_samples if case.period_samples > 1 else None
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        try:
            drive = start_drive(compensator_plant(plant, case.compensator), case.compensator,
                                case.signal, P,
                                case.compensator_spec.get("fade_in"),
                                getattr(case.compensator, "limits", None) or "warn",
                                key="compensator.fade_in")
        except CompensatorDivergence as exc:
            nan = np.full((plant.hysteresis.n_inputs, case.signal.shape[1]), np.nan)
            res = ChainResult(nan, np.full(case.signal.shape, np.nan), None, None, exc)
            return chain_result(case, res, caught + [str(w.message) for w in rec])
    caught += [str(w.message) for w in rec]
    problem = unfollowed_problem(plant, drive)
    if problem:
        caught.append(problem)
    fade = int(drive.fade_samples)
    case.start_fade = fade
    y = plant.simulate(apply_amplifier(plant.amplifier, drive.inputs, T), plant.rest_state())[0]
    res = ChainResult(np.asarray(drive.inputs, dtype=float), y, None, None)
    settle = case.settle_periods
    if fade >= y.shape[1] - max(case.period_samples, 1) and fade > settle * case.period_samples:
        P1 = max(case.period_samples, 1)
        # the metrics start at the fade's end: without a period after it, steady_window told
        # "settle_periods: 5.97 periods ... leave nothing" of a case whose settle_periods was 3
        raise ValueError(
            f"{case.name}: the drive's fade-in, {fade * T:.4g} s ({fade} samples, as compensate "
            f"fades it: at least one period, {MIN_FADE_S:g} s and {FADE_DECAYS:g} decay times of the "
            f"slowest bending mode, longer for a start-up the settled drive would not take), "
            f"leaves less than one period of the "
            f"{y.shape[1]}-sample reference to judge; give the reference more periods (at least "
            f"{int(np.ceil((max(fade, MIN_FADE_S / T) + P1) / P1))}) "
            f"or a shorter compensator.fade_in [s]")
    if fade > settle * case.period_samples:
        settle = fade / case.period_samples
        case.notes.append(f"the drive fades in over {fade * T:.4g} s, as compensate's (from the "
                          f"model's rest output): the metrics start at its end, after "
                          f"{settle:.3g} periods instead of the {case.settle_periods:g} "
                          f"settling periods")
    case.notes.extend(n.replace("--fade-in", "compensator.fade_in")
                      for n in list(drive.shaped) + list(drive.notes))
    return chain_result(case, res, caught, drive.commanded, drive.reference, settle)


def _through_amplifier(case, res):
    """The chain with the plant's amplifier: limits checked (``compensator.limits``), then
    the commanded voltages clipped, slew-limited and filtered before the plant."""
    amp = getattr(case.plant, "amplifier", None)
    if amp is None or res.diverged:
        return res
    T = case.plant.sampling_period
    amp.check(res.inputs, T, getattr(case.compensator, "limits", None) or "warn")
    applied, _ = amp.apply(res.inputs, T)
    if np.array_equal(applied, res.inputs):
        return res
    y, p_final = case.plant.simulate(applied)
    return ChainResult(applied, y, res.compensator_state, p_final)


def runs_alone(case):
    """True when a reference case cannot run in the batch kernel (fade-in, amplifier).

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec

    Returns
    -------
    bool
    """
    return (getattr(case.plant, "amplifier", None) is not None or starts_as_hardware(case)
            or fade_samples(case) > 0)


def drive_rows(case, inputs):
    """``peak_input`` [V] and ``peak_slew`` [V/s] rows per input of a drive (from rest).

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
    inputs : numpy.ndarray, shape (m, n_samples)
        Commanded voltages [V].

    Returns
    -------
    list of dict
        Rows ``{channel, metric, value, unit}``, channel = the input's name.
    """
    peak, slew = drive_metrics(inputs, case.plant.sampling_period)
    rows = []
    for i, name in enumerate(case.plant.hysteresis.input_names):
        rows.append({"channel": name, "metric": "peak_input", "value": float(peak[i]),
                     "unit": "V"})
        rows.append({"channel": name, "metric": "peak_slew", "value": float(slew[i]),
                     "unit": "V/s"})
    return rows


def signal_kind(case):
    """The registry entry of a case's drive or reference.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec

    Returns
    -------
    hammerstein.signals.references.ReferenceKind
        From :data:`hammerstein.signals.references.DRIVE_KINDS` (drives) or
        :data:`hammerstein.signals.references.REFERENCE_KINDS`.
    """
    kinds = DRIVE_KINDS if case.mode == "drive" else REFERENCE_KINDS
    return kinds[case.signal_spec["kind"]]


def fade_samples(case):
    """Fade-in of the reference of a compensator kind that fades in [samples].

    The compensator table's ``fade_in`` [s] when given, else one period of
    the reference, at most the ``settle_periods`` the metrics skip. A kind
    without the ``fades_in`` capability
    (:class:`hammerstein.scenario.registry.CompensatorKind`) fades in only
    when the reference does not start at rest and the plant's amplifier has
    a slew rate (:func:`hammerstein.compensation.drive.default_fade_samples`).

    A case of :func:`starts_as_hardware` that has run fades in as its drive
    did (``case.start_fade``).

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
        A resolved reference case.

    Returns
    -------
    int
        Fade-in length [samples].
    """
    if getattr(case, "start_fade", None) is not None:
        return int(case.start_fade)
    T = case.plant.sampling_period
    given = case.compensator_spec.get("fade_in")
    settle = int(case.settle_periods * case.period_samples)
    if given is not None:
        return int(round(given / T))
    if not compensator_kind(case.compensator_spec).fades_in:
        return default_fade_samples(case.signal, case.period_samples, settle, case.compensator,
                                    getattr(case.plant, "amplifier", None), T)
    return int(min(case.period_samples, settle))


def chain_result(case, res, caught, commanded=None, tracked=None, settle_periods=None):
    """CaseResult of a compensated case from its simulated chain (ChainResult).

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
        The compensated case; ``case.signal`` is its reference [µm], shape
        (p, n_samples).
    res : hammerstein.simulation.ChainResult
        The compensator -> plant simulation of the case: inputs [V], shape
        (m, n_samples), and outputs [µm], shape (p, n_samples).
    caught : list of str
        Warning messages of the case (kept in the result).
    commanded : numpy.ndarray, shape (m, n_samples), optional
        The compensator's voltages before the amplifier [V] (default
        ``res.inputs``): their ``peak_input`` and ``peak_slew`` are reported.
    tracked : numpy.ndarray, shape (p, n_samples), optional
        The reference the chain followed [µm], e.g. ``case.signal`` faded in
        from rest (default ``case.signal``): kept as the result's
        ``reference`` (figures, time series); the metrics use ``case.signal``.
    settle_periods : float, optional
        The periods the metrics skip (default ``case.settle_periods``; a
        longer fade-in's, :func:`starts_as_hardware`).

    Returns
    -------
    CaseResult
        With the tracking metrics
        (:func:`hammerstein.signals.metrics.tracking_metrics`), or the single
        ``diverged_at_time`` [s] row when the compensator diverged.
    """
    plant = case.plant
    names = list(plant.hysteresis.output_names)
    if res.diverged:
        t = float(res.divergence.sample * plant.sampling_period)
        rows = [{"channel": "+".join(names), "metric": "diverged_at_time", "value": t,
                 "unit": met.UNITS["diverged_at_time"]}]
    else:
        settle = case.settle_periods if settle_periods is None else settle_periods
        rows = met.tracking_metrics(case.signal, res.outputs, names, case.period_samples,
                                    settle, scale=case.scale,
                                    loop_channel=case.loop_channel)
        entry = signal_kind(case)
        if entry.metrics is not None:  # e.g. per scan line
            rows += entry.metrics(case.time, case.signal_spec, case.signal, res.outputs)
        rows += drive_rows(case, res.inputs if commanded is None else commanded)
    reference = case.signal if tracked is None else tracked
    return CaseResult(case, res.inputs, res.outputs, reference, res.divergence, rows, caught)


def model_comparison(case, plant_outputs, inputs=None):
    """Simulate a drive case's comparison model and compare it with the plant.

    The model (rate-independent PI, no dynamics) is driven by the case's
    voltages from zero play states, like the plant.

    Parameters
    ----------
    case : hammerstein.scenario.validate.CaseSpec
        A drive case with ``case.model``.
    plant_outputs : numpy.ndarray, shape (p, n_samples)
        The plant's displacements [µm].
    inputs : numpy.ndarray, shape (m, n_samples), optional
        The voltages that reached the plant [V] (its amplifier applied);
        default the case's drive.

    Returns
    -------
    model_outputs : numpy.ndarray, shape (p, n_samples)
        [µm].
    rows : list of dict
        Per output channel, over the steady window after ``settle_periods``:
        ``model_rms_error`` (the paper's RMS_error_model, Section 5.3) and
        ``model_max_abs_error`` of plant minus model [µm].
    """
    ym, _ = case.model.simulate(case.signal if inputs is None else inputs)
    y = np.asarray(plant_outputs, dtype=float)
    win = met.steady_window(y.shape[1], case.period_samples, case.settle_periods)
    e = y[:, win] - ym[:, win]
    rows = []
    for l, name in enumerate(case.plant.hysteresis.output_names):
        rows.append({"channel": name, "metric": "model_rms_error",
                     "value": float(np.sqrt(np.mean(e[l] ** 2))), "unit": "µm"})
        rows.append({"channel": name, "metric": "model_max_abs_error",
                     "value": float(np.max(np.abs(e[l]))), "unit": "µm"})
    return ym, rows
