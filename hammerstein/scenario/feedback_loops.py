"""The loop of a ``[feedback]`` table: its controller, sensor and amplifier for a plant.

:func:`build_controller` turns a validated ``[feedback]`` table
(:mod:`hammerstein.scenario.feedback_table`) into a discrete controller for
a plant (the designs by name take the axis' DC gain from the linearised
plant unless ``gain`` is given); :func:`build_loops` adds the sensor and the
amplifier, the preset's hardware (``[sensor]``, ``[amplifier]``) unless the
table overrides it. Used by the feedback scenarios
(:mod:`hammerstein.scenario.feedback`, which re-exports these names) and by
the Monte-Carlo studies with feedback.
"""

from __future__ import annotations

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.compensation.feedback import (AmplifierLimits, FeedbackLoop, Sensor, controller_from_lti,
                                       design_axis, diagonal_controller, linearised_plant,
                                       mixsyn_controller, with_internal_model)
from hammerstein.exceptions import FeedbackError

control = lazy_module("control")  # lazy: loaded when a loop is built

__all__ = ["build_controller", "build_loops", "hardware_sensor", "hardware_amplifier"]


def _lti(t, T):
    dt = T if t.get("discrete", False) else 0
    if t["kind"] == "transfer-function":
        return control.tf(t["num"], t["den"], dt)
    D = np.atleast_2d(np.asarray(t["D"], float))
    A = np.array(t.get("A", []), float)
    n = A.shape[0] if A.size else 0
    B = np.asarray(t["B"], float).reshape(n, D.shape[1]) if n else np.zeros((0, D.shape[1]))
    C = np.asarray(t["C"], float).reshape(D.shape[0], n) if n else np.zeros((D.shape[0], 0))
    return control.ss(A if n else np.zeros((0, 0)), B, C, D, dt)


def build_controller(table, plant):
    """The discrete controller of a validated ``[feedback]`` table for a plant.

    Parameters
    ----------
    table : dict
        Validated (:func:`hammerstein.scenario.feedback_table.check_feedback_table`).
    plant : HammersteinPlant

    Returns
    -------
    hammerstein.compensation.feedback.Controller

    Raises
    ------
    FeedbackError
        When a design or the discretisation fails (e.g. ``mixsyn`` without slycot).

    Notes
    -----
    An axis designed by name with ``internal_model_hz`` gets resonant
    elements at those frequencies
    (:func:`hammerstein.compensation.feedback.with_internal_model`), their
    phase leads and gains computed on the loop without them, with the
    table's (or the preset's) sensor.
    """
    T = plant.sampling_period
    method = table.get("method", "tustin")
    names = list(plant.hysteresis.output_names)
    P = linearised_plant(plant)
    dc = np.real(np.atleast_2d(P(1.0)))
    if table.get("mimo") is not None:
        t = table["mimo"]
        if t["kind"] == "mixsyn":
            return mixsyn_controller(P, T, t["bandwidth_hz"], t.get("max_sensitivity", 2.0),
                                     t.get("effort", 0.1), method)
        return controller_from_lti(_lti(t, T), T, method, description="state space (MIMO)")
    designs, models = [], {}
    for l, name in enumerate(names):
        t = dict(table["axes"][name])
        kind = t.pop("kind")
        if kind in ("transfer-function", "state-space"):
            designs.append(_lti(t | {"kind": kind}, T))
            continue
        if "internal_model_hz" in t:
            models[l] = (t.pop("internal_model_hz"), t.pop("internal_model_decay", 2.0))
        gain = t.pop("gain", float(dc[l, l]))
        try:
            designs.append(design_axis(kind, gain, **t))
        except TypeError as exc:  # an option another kind takes
            raise FeedbackError(f"axes.{name}: {exc}") from None
    if not models:
        return diagonal_controller(designs, T, method)
    # internal models: phase leads and gains from the loop without them (its sensor included)
    s = hardware_sensor(table, plant)
    L = FeedbackLoop(plant, diagonal_controller(designs, T, method),
                     Sensor(0.0, s.get("bandwidth_hz"), s.get("delay", 0))).loop_transfer()
    for l, (freqs, decay) in models.items():
        try:
            designs[l] = with_internal_model(designs[l], lambda z, l=l: L(z)[l, l], T, freqs,
                                             decay)
        except FeedbackError as exc:
            raise FeedbackError(f"axes.{names[l]}.{exc}") from None
    return diagonal_controller(designs, T, method)


def hardware_sensor(table, plant):
    """The loop's sensor: the preset's ``[sensor]``, each key overridden by ``[feedback] sensor``.

    Parameters
    ----------
    table : dict
        Validated ``[feedback]`` table.
    plant : HammersteinPlant
        Its ``sensor`` (:func:`hammerstein.io.presets.load_plant`), when any.

    Returns
    -------
    dict
        ``noise_nm`` [nm RMS], ``bandwidth_hz`` [Hz], ``delay`` [samples], the keys set.
    """
    return {**(getattr(plant, "sensor", None) or {}), **table.get("sensor", {})}


def hardware_amplifier(table, plant):
    """The loop's amplifier limits: ``[feedback] amplifier``, else the preset's ``[amplifier]``.

    The preset's limits are taken per input (range and slew rate; its
    bandwidth is not modelled in the loop) unless they were measured on the
    identification records (a region, not the amplifier's own limits).

    Parameters
    ----------
    table : dict
        Validated ``[feedback]`` table.
    plant : HammersteinPlant

    Returns
    -------
    hammerstein.compensation.feedback.AmplifierLimits or None
        None: no limits.
    """
    a = table.get("amplifier", {})
    if a:
        rng = a.get("range")
        return AmplifierLimits(rng[0] if rng else -np.inf, rng[1] if rng else np.inf,
                               a.get("slew_rate", np.inf))
    hw = getattr(plant, "amplifier", None)
    if hw is None or hw.from_records:
        return None
    ch = hw.channels
    return AmplifierLimits(np.array([c.low for c in ch]), np.array([c.high for c in ch]),
                           np.array([c.slew_rate for c in ch]))


def build_loops(table, plant):
    """The closed loop and the feedforward-alone loop (no controller) of a table.

    Parameters
    ----------
    table : dict
        Validated ``[feedback]`` table.
    plant : HammersteinPlant

    Returns
    -------
    (FeedbackLoop, FeedbackLoop)
        With the controller; without (the same amplifier, no sensor in the loop).
    """
    s = hardware_sensor(table, plant)
    sensor = Sensor(s.get("noise_nm", 0.0) * 1e-3, s.get("bandwidth_hz"), s.get("delay", 0))
    amp = hardware_amplifier(table, plant)
    ctrl = build_controller(table, plant)
    aw, tt = table.get("anti_windup", "back-calculation"), table.get("tracking_time")
    return (FeedbackLoop(plant, ctrl, sensor, amp, aw, tt),
            FeedbackLoop(plant, None, Sensor(0.0, None, max(sensor.delay, 1)), amp, "none"))
