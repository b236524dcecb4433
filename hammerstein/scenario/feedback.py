"""Running a ``kind = "feedback"`` scenario: every reference case with feedforward, feedback, both.

:func:`build_controller` turns the validated ``[feedback]`` table
(:mod:`hammerstein.scenario.feedback_table`) into a discrete controller for
the scenario's plant (the designs by name take the axis' DC gain from the
linearised plant unless ``gain`` is given); :func:`run_feedback_scenario`
resolves the cases part (the feedforward compensators, identified as in a
cases scenario), checks the loop's stability with the hysteresis' slope
range as a sector, then runs each case in the compiled closed-loop kernel
(:class:`hammerstein.compensation.feedback.FeedbackLoop`) in the modes asked for,
the cases spread over threads (the kernel releases the GIL).
"""

from __future__ import annotations

import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.signals import metrics as met
from hammerstein.compensation.hammerstein_compensator import fade_in
from hammerstein.exceptions import CompensatorDivergence, FeedbackError, ScenarioError
from hammerstein.scenario.execute import fade_samples, signal_kind
from hammerstein.scenario.feedback_loops import (build_controller, build_loops, hardware_amplifier,
                                                 hardware_sensor)
from hammerstein.scenario.feedback_table import MODES, FeedbackScenario
from hammerstein.scenario.registry import compensator_kind
from hammerstein.scenario.resolve import resolve_scenario

control = lazy_module("control")  # lazy: loaded when a feedback scenario runs

__all__ = ["FeedbackCaseResult", "build_controller", "build_loops", "run_feedback_scenario",
           "loop_analysis", "MODE_LABELS", "hardware_sensor", "hardware_amplifier"]

#: how the report names the modes
MODE_LABELS = {"feedforward": "feedforward alone", "feedback": "feedback alone",
               "both": "feedforward + feedback"}


@dataclass
class FeedbackCaseResult:
    """One case in one mode.

    Parameters
    ----------
    name : str
        ``<case>.<mode>`` (the ``case`` column of metrics.csv).
    case : hammerstein.scenario.validate.CaseSpec
    mode : {'feedforward', 'feedback', 'both'}
    reference, outputs : numpy.ndarray, shape (p, n_samples)
        [µm] (outputs NaN when the feedforward diverged); the reference the
        loop tracked (faded in from rest where the case fades in).
    inputs : numpy.ndarray, shape (m, n_samples)
        Applied voltages [V].
    metrics : list of dict
        Rows ``{channel, metric, value, unit}``.
    warnings : list of str
    seconds : float
        Wall time of the loop's simulation [s].
    """

    name: str
    case: Any
    mode: str
    reference: np.ndarray
    outputs: np.ndarray
    inputs: np.ndarray
    metrics: list
    warnings: list = field(default_factory=list)
    seconds: float = 0.0


def loop_analysis(loop, n_frequencies=400):
    """What the report says about a loop: designs, margins, stability, S, T, noise.

    Parameters
    ----------
    loop : FeedbackLoop
    n_frequencies : int
        Points of the frequency responses (1 Hz to Nyquist, log spaced).

    Returns
    -------
    dict
        ``descriptions``, ``margins`` (per axis), ``stability``
        (:meth:`FeedbackLoop.stability_check`), ``noise_nm`` (per axis RMS
        position noise [nm]), ``linear_stable``, ``frequency_hz``, ``S``,
        ``T``, ``N`` (magnitudes per axis, arrays (p, n)), ``outputs``.
    """
    T = loop.plant.sampling_period
    f = np.logspace(0, np.log10(0.5 / T), n_frequencies)
    z = np.exp(2j * np.pi * f * T)
    S, Tc, N = loop.closed_loop()
    mags = {}
    for key, sys in (("S", S), ("T", Tc), ("N", N)):
        resp = sys(z, squeeze=False)
        mags[key] = np.abs(np.array([resp[l, l] for l in range(loop.p)]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        margins = loop.margins()
    return {"descriptions": list(loop.controller.descriptions), "margins": margins,
            "stability": loop.stability_check(),
            "linear_stable": bool(np.all(np.abs(control.poles(S)) < 1)),
            "noise_nm": (loop.noise_to_position() * 1e3).tolist(), "frequency_hz": f,
            "outputs": list(loop.plant.hysteresis.output_names), **mags}


def _limits(*values):
    """Amplifier limits for the report: a scalar (or [low, high]) when every input agrees."""
    arrs = [np.atleast_1d(np.asarray(v, float)) for v in values]
    if all(np.all(a == a[0]) for a in arrs):
        out = [float(a[0]) for a in arrs]
    else:
        out = [a.tolist() for a in arrs]
    out = ["unlimited" if isinstance(v, float) and not np.isfinite(v) else v for v in out]
    return out if len(out) > 1 else out[0]


def _feedforward(case, r_loop, fade):
    """The feedforward voltages of a case (zeros without a compensator), or the divergence."""
    plant = case.plant
    comp = case.compensator
    m = plant.hysteresis.n_inputs
    if comp is None:
        return np.zeros((m, r_loop.shape[1])), None
    try:
        if compensator_kind(case.compensator_spec).look_ahead:
            res = comp.run_reference(plant, case.signal, case.period_samples, fade)
            if res.diverged:
                return None, res.divergence
            return res.inputs, None
        u, _ = comp.simulate(r_loop)
        return u, None
    except CompensatorDivergence as exc:
        return None, exc


def _metrics(case, y, a):
    names = list(case.plant.hysteresis.output_names)
    rows = met.tracking_metrics(case.signal, y, names, case.period_samples, case.settle_periods,
                                scale=case.scale, loop_channel=case.loop_channel)
    entry = signal_kind(case)
    if entry.metrics is not None:
        rows += entry.metrics(case.time, case.signal_spec, case.signal, y)
    for k, name in enumerate(case.plant.hysteresis.input_names):
        rows.append({"channel": name, "metric": "peak_input", "value": float(np.max(np.abs(a[k]))),
                     "unit": "V"})
    return rows


def _run_one(case, mode, loops, ff, divergence, r_loop, seed):
    loop_fb, loop_ff = loops
    p, n = case.signal.shape
    if mode != "feedback" and ff is None:
        t = float(divergence.sample * case.plant.sampling_period) if divergence else 0.0
        nan = np.full((p, n), np.nan)
        rows = [{"channel": "+".join(case.plant.hysteresis.output_names),
                 "metric": "diverged_at_time", "value": t, "unit": "s"}]
        return FeedbackCaseResult(f"{case.name}.{mode}", case, mode, case.signal, nan,
                                  np.full((case.plant.hysteresis.n_inputs, n), np.nan), rows,
                                  [f"the feedforward diverged: {divergence}"])
    f = np.zeros((case.plant.hysteresis.n_inputs, n)) if mode == "feedback" else ff
    loop = loop_ff if mode == "feedforward" else loop_fb
    t0 = time.perf_counter()
    res = loop.simulate(r_loop, feedforward=f, seed=seed)
    dt = time.perf_counter() - t0
    return FeedbackCaseResult(f"{case.name}.{mode}", case, mode, r_loop, res.outputs,
                              res.inputs, _metrics(case, res.outputs, res.inputs), [], dt)


def run_feedback_scenario(scenario: FeedbackScenario, jobs=2):
    """Resolve the cases, check the loop, run every case in every mode (the runner's kind).

    Parameters
    ----------
    scenario : FeedbackScenario
        Validated (:func:`hammerstein.scenario.feedback_table.validate_feedback`).
    jobs : int
        Threads running the cases.

    Returns
    -------
    list of FeedbackCaseResult
        Case by case, in the order of :data:`MODES`. The loop analysis
        (:func:`loop_analysis`) and the timings are stored on the scenario
        (``scenario.analysis``, ``scenario.timing``).

    Raises
    ------
    ScenarioError
        When the controller cannot be built, a case is a drive, or the
        linearised loop is unstable (nothing is simulated).
    """
    resolved = resolve_scenario(scenario.cases_spec)
    cases = resolved.cases
    where = f"{scenario.path}: feedback"
    drives = [c.name for c in cases if c.mode != "reference"]
    if drives:
        raise ScenarioError([f"{scenario.path}: cases: a feedback scenario runs references; "
                             f"{', '.join(drives)} are drives"])
    loops = {}
    for c in cases:
        if id(c.plant) not in loops:
            try:
                loops[id(c.plant)] = build_loops(scenario.table, c.plant)
            except FeedbackError as exc:
                raise ScenarioError([f"{where}: {exc}"]) from None
    first = loops[id(cases[0].plant)][0]
    analysis = loop_analysis(first)
    plant0 = cases[0].plant
    analysis["sensor"] = hardware_sensor(scenario.table, plant0)
    amp = first.amplifier
    analysis["amplifier"] = {} if amp is None else {
        "range": _limits(amp.low, amp.high), "slew_rate": _limits(amp.slew_rate)}
    scenario.analysis = analysis
    if not analysis["linear_stable"]:
        raise ScenarioError([f"{where}: the linearised loop (hysteresis at its secant gains) is "
                             f"unstable; {analysis['stability']['summary']}"])
    modes = [m for m in MODES if m in scenario.table.get("modes", MODES)]
    tasks = []
    for i, c in enumerate(cases):
        fade = fade_samples(c) if c.compensator is not None else 0
        r_loop = fade_in(c.signal, fade) if fade else c.signal
        ff, div = _feedforward(c, r_loop, fade) if ("feedforward" in modes or "both" in modes) \
            else (None, None)
        for mode in modes:
            tasks.append((c, mode, loops[id(c.plant)], ff, div, r_loop, scenario.seed + i))
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max(1, int(jobs))) as pool:
        results = list(pool.map(lambda a: _run_one(*a), tasks))
    wall = time.perf_counter() - t0
    samples = sum(r.case.signal.shape[1] for r in results)
    # per sample, the median over the runs: the first run of a cold cache includes numba's
    # compile (104 µs per sample against 2.5 µs measured on a 3000-sample case)
    per_sample = [r.seconds / max(r.case.signal.shape[1], 1) for r in results]
    scenario.timing = {"wall_s": wall, "samples": samples,
                       "kernel_s": sum(r.seconds for r in results),
                       "kernel_s_per_sample": float(np.median(per_sample)) if per_sample else 0.0}
    for c in cases:
        for r in results:
            if r.case is c:
                r.warnings = list(c.warnings) + r.warnings
    return results
