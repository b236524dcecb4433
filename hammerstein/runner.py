"""Run scenarios: simulate every case, compute metrics, write the report.

``run_scenario(path, out_dir)`` validates the file
(:func:`hammerstein.scenarios.load_scenario`), simulates each case (an
open-loop drive on the plant, or reference -> compensator -> plant with
:func:`hammerstein.simulation.simulate_chain`), computes the metrics and
writes ``out_dir/<scenario name>/`` atomically: the report is built in a
temporary directory next to the target and renamed over it, so a failing
scenario leaves nothing behind. Warnings of the cases (a reference beyond
the identified range, a convergence check set to ``"warn"``, ...) are listed
in ``report.md``, in ``warnings.csv`` (``case, message``; written only when
there are warnings) and in :attr:`ScenarioOutcome.warnings` (``hammerstein
run`` prints one ``warning:`` line each).

Compensators are built by :func:`build_compensator` from the registry
:data:`COMPENSATORS` (kind -> :class:`CompensatorKind`); add a kind by adding
an entry. A compensator is any object with ``.name`` and
``.simulate(reference (m, N), initial_state=None) -> (inputs (m, N), final_state)``.
"""

from __future__ import annotations

import shutil
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd

from hammerstein.core import metrics as met
from hammerstein.core.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                           StaticGainCompensator, diagonal_compensator)
from hammerstein.core.identification import IdentificationError
from hammerstein.scenario.identified import identified_model, identify_table, model_comparison, report_identified
from hammerstein.core.presets import load_model
from hammerstein.scenario.schema import Field, Invalid, ScenarioError, choice, integer, load_scenario, number, string
from hammerstein.simulation import simulate_chain

__all__ = [
    "CompensatorKind",
    "COMPENSATORS",
    "build_compensator",
    "resolve_model",
    "CaseResult",
    "ScenarioKind",
    "SCENARIO_KINDS",
    "ScenarioOutcome",
    "METRIC_COLUMNS",
    "run_case",
    "run_scenario",
    "run_scenarios",
]

#: Columns of metrics.csv and of ScenarioOutcome.metrics.
METRIC_COLUMNS = ["case", "channel", "metric", "value", "unit"]


@dataclass
class CompensatorKind:
    """An entry of the compensator registry.

    Attributes
    ----------
    build : callable
        ``build(spec: dict, plant, base_dir: Path) -> compensator or None``;
        ``spec`` is the validated ``[compensator]`` table (defaults filled).
    fields : dict of str to hammerstein.scenarios.Field
        The keys this kind accepts besides ``kind`` (validated by
        ``hammerstein validate``).
    description : str
        One line for ``hammerstein list`` and the README.
    """

    build: Callable[[dict, Any, Path], Any]
    fields: dict = field(default_factory=dict)
    description: str = ""


def resolve_model(spec_model, plant, base_dir, identify=None):
    """The multivariable PI model a compensator is built from.

    Parameters
    ----------
    spec_model : str
        ``"plant"`` (the plant's own PI model), ``"identified"`` (identified
        on ``plant`` by the ``identify`` table, :mod:`hammerstein.identified`)
        or a model/preset TOML path, relative to ``base_dir`` when not absolute.
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
    path = Path(spec_model)
    if not path.is_absolute():
        path = Path(base_dir) / path
    return load_model(path)


def _gain(v):
    if v in ("secant", "midpoint", "identity"):
        return v
    if isinstance(v, list) and v and all(isinstance(r, list) and len(r) == len(v) and
                                         all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                             and np.isfinite(a) for a in r) for r in v):
        return v
    raise Invalid(f"expected 'secant', 'midpoint', 'identity' or a square matrix [[..],[..]] of "
                  f"finite numbers [µm/V], found {v!r}")


def _build_none(spec, plant, base_dir):
    return None


def _build_multivariable(spec, plant, base_dir):
    model = resolve_model(spec.get("model", "plant"), plant, base_dir, spec.get("identify"))
    return InverseMultiplicativeCompensator(
        model, gain=spec.get("gain", "secant"), iterations=spec.get("iterations", 1),
        check=spec.get("check", "error"), **_feedback_options(spec, plant))


def _spec_model(spec, plant, base_dir):
    """The model of a compensator table (every kind resolves it like "multivariable")."""
    return resolve_model(spec.get("model", "plant"), plant, base_dir, spec.get("identify"))


def _feedback_options(spec, plant):
    """feedback = "lowpass" needs the cut-off [Hz] and the plant's sampling period [s]."""
    if spec.get("feedback", "delay") == "delay":
        return {}
    return {"feedback": spec["feedback"], "cutoff_hz": spec.get("cutoff_hz"),
            "sampling_period": plant.sampling_period}


def _build_diagonal(spec, plant, base_dir):
    return diagonal_compensator(
        _spec_model(spec, plant, base_dir), gain=spec.get("gain", "secant"),
        iterations=spec.get("iterations", 1), check=spec.get("check", "error"),
        **_feedback_options(spec, plant))


def _build_per_axis(spec, plant, base_dir):
    return PerAxisInverseCompensator(_spec_model(spec, plant, base_dir))


def _build_static_gain(spec, plant, base_dir):
    return StaticGainCompensator(_spec_model(spec, plant, base_dir))


# -- registry of compensator kinds: add entries here ---------------------------------
COMPENSATORS: dict[str, CompensatorKind] = {
    "none": CompensatorKind(_build_none, {}, "no compensator (open-loop drives only)"),
    "multivariable": CompensatorKind(
        _build_multivariable,
        {"model": Field(string(), default="plant"),
         "identify": Field(identify_table),
         "gain": Field(_gain, default="secant"),
         "iterations": Field(integer(1), default=1),
         "check": Field(choice("error", "warn", "ignore"), default="error"),
         "feedback": Field(choice("delay", "lowpass")),  # default: the one-sample delay
         "cutoff_hz": Field(number("Hz", 0))},
        "inverse multiplicative compensator of Theorem 4.1, normalised by K (NOTES §4)"),
}
_MODEL_KEYS = ("model", "identify")  # the model fields every kind shares with "multivariable"
COMPENSATORS["diagonal"] = CompensatorKind(
    _build_diagonal, dict(COMPENSATORS["multivariable"].fields),
    "the multivariable law on the direct transfers only (cross-couplings left)")
COMPENSATORS["per-axis"] = CompensatorKind(
    _build_per_axis, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "per-axis analytic inverse PI of Kuhnen & Janocha, direct transfers only (NOTES §5)")
COMPENSATORS["static-gain"] = CompensatorKind(
    _build_static_gain, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "no hysteresis compensation: U = K^-1 Yr, K the direct secant gains (reference)")


def build_compensator(spec, plant, base_dir):
    """Build the compensator of a ``[compensator]`` table.

    Parameters
    ----------
    spec : dict
        Validated table; ``kind`` selects the :data:`COMPENSATORS` entry
        (default ``"none"``).
    plant : HammersteinPlant
        The simulated plant (its PI model is ``model = "plant"``).
    base_dir : pathlib.Path
        Directory of the scenario file (relative model paths).

    Returns
    -------
    object or None
        A compensator, or None for ``kind = "none"``.

    Raises
    ------
    ValueError
        Unknown kind; or the builder's own errors (CompensatorError,
        PresetError), e.g. a law refused by the convergence check.
    """
    kind = spec.get("kind", "none")
    if kind not in COMPENSATORS:
        raise ValueError(f"kind: expected one of {', '.join(COMPENSATORS)}, found {kind!r}")
    return COMPENSATORS[kind].build(spec, plant, Path(base_dir))


@dataclass
class CaseResult:
    """Simulation and metrics of one case.

    Attributes
    ----------
    spec : CaseSpec
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V] (NaN after a divergence).
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm] (NaN after a divergence).
    reference : numpy.ndarray or None, shape (p, n_samples)
        [µm]; None for drives.
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
    case : hammerstein.scenarios.CaseSpec

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
        y, _ = plant.simulate(case.signal)
        rows = met.open_loop_metrics(case.signal, y, case.driven_input, names,
                                     case.period_samples, case.settle_periods)
        ym = None
        if case.model is not None:  # model vs plant (Fig. 6, 7)
            ym, more = model_comparison(case, y)
            rows += more
        return CaseResult(case, case.signal, y, None, None, rows, caught, ym)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        res = simulate_chain(case.compensator, plant, case.signal)
    caught += [str(w.message) for w in rec]
    return chain_result(case, res, caught)


def chain_result(case, res, caught):
    """CaseResult of a compensated case from its simulated chain (ChainResult)."""
    plant = case.plant
    names = list(plant.hysteresis.output_names)
    if res.diverged:
        t = float(res.divergence.sample * plant.sampling_period)
        rows = [{"channel": "+".join(names), "metric": "diverged_at_time", "value": t,
                 "unit": met.UNITS["diverged_at_time"]}]
    else:
        rows = met.tracking_metrics(case.signal, res.outputs, names, case.period_samples,
                                    case.settle_periods, scale=case.scale,
                                    loop_channel=case.loop_channel)
    return CaseResult(case, res.inputs, res.outputs, case.signal, res.divergence, rows, caught)


@dataclass
class ScenarioKind:
    """An entry of the scenario-kind registry (top-level ``kind`` of a file).

    Attributes
    ----------
    load : callable
        ``load(path, data) -> scenario`` (``data`` the parsed TOML); raises
        ScenarioError listing every problem. The scenario has ``name`` and
        ``cases``.
    simulate : callable
        ``simulate(scenario) -> results``, each with ``name`` and
        ``metrics`` (rows ``{channel, metric, value, unit}``).
    write : callable
        ``write(scenario, results, directory)`` fills the report directory.
    """

    load: Callable
    simulate: Callable
    write: Callable


def _write_cases(scenario, results, directory):
    from hammerstein.report.scenario import write_report
    write_report(scenario, results, directory)
    report_identified(scenario, results, directory)


def _lazy(entry):
    def call(*args):
        import importlib
        module, func = entry.split(":")
        return getattr(importlib.import_module(module), func)(*args)
    return call


# -- registry of scenario kinds: add entries here ("cases" is load_scenario's own) ----
SCENARIO_KINDS: dict[str, ScenarioKind] = {
    "cases": ScenarioKind(load_scenario, _lazy("hammerstein.scenario.sweeps:run_scenario_cases"), _write_cases),
    "identification": ScenarioKind(
        _lazy("hammerstein.scenario.records:load_identification_scenario"),
        _lazy("hammerstein.scenario.records:run_identification_scenario"),
        _lazy("hammerstein.scenario.records:write_identification_report")),
}


@dataclass
class ScenarioOutcome:
    """What happened to one scenario file.

    Attributes
    ----------
    name : str
        Scenario name (the file stem when the file could not be read).
    path : pathlib.Path
    ok : bool
    error : str or None
        The problems, one per line, when not ok.
    out_dir : pathlib.Path or None
        ``DIR/<name>/`` when written.
    metrics : pandas.DataFrame
        Columns ``case, channel, metric, value, unit`` (empty when not ok).
    warnings : list of (str, str)
        ``(case, message)`` of every distinct warning of the cases (range,
        convergence, ...), also in ``report.md`` and ``warnings.csv``.
    """

    name: str
    path: Path
    ok: bool
    error: str | None
    out_dir: Path | None
    metrics: pd.DataFrame
    warnings: list = field(default_factory=list)


def _empty_metrics():
    return pd.DataFrame({c: pd.Series(dtype=float if c == "value" else object)
                         for c in METRIC_COLUMNS})


def _atomic_write(out_dir, name, writer):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".tmp", dir=out_dir))
    target = out_dir / name
    try:
        writer(tmp)
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".old", dir=out_dir))
            target.rename(old / "previous")
            tmp.rename(target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            tmp.rename(target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return target


def _case_warnings(results):
    """Distinct ``(case, message)`` pairs of the results' warnings, in order."""
    pairs = [(str(getattr(r, "name", "")), " ".join(str(w).split()))
             for r in results for w in getattr(r, "warnings", None) or []]
    return list(dict.fromkeys(pairs))


def _write_warnings(pairs, directory):
    """``warnings.csv`` (columns ``case, message``) when there are warnings."""
    if pairs:
        pd.DataFrame(pairs, columns=["case", "message"]).to_csv(
            Path(directory) / "warnings.csv", index=False)


def run_scenario(path, out_dir, taken=None):
    """Validate, simulate and write the report of one scenario.

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.
    out_dir : str or pathlib.Path
        Reports directory; the report goes to ``out_dir/<scenario name>/``.
    taken : dict of str to pathlib.Path, optional
        Report names already written in this run (by :func:`run_scenarios`):
        a scenario whose name is taken fails instead of overwriting the
        other scenario's report.

    Returns
    -------
    ScenarioOutcome
        Never raises for a bad scenario or a failed simulation: ``ok`` is
        False and ``error`` says why; nothing is written then.
    """
    from hammerstein.report.scenario import metrics_frame
    path = Path(path)
    name = path.stem
    try:
        scenario = load_scenario(path)  # dispatches on the top-level kind
        name = scenario.name
        if taken is not None and name in taken:
            raise ScenarioError([
                f"{path}: name: {name!r} is also the name of {taken[name]} in this run; "
                f"give each scenario its own name (its report directory)"])
        kind = SCENARIO_KINDS[getattr(scenario, "kind", "cases")]
        results = kind.simulate(scenario)
        frame = metrics_frame(results)
        caught = _case_warnings(results)

        def write(d):
            kind.write(scenario, results, d)
            _write_warnings(caught, d)
        target = _atomic_write(out_dir, name, write)
    except ScenarioError as exc:
        return ScenarioOutcome(name, path, False, str(exc), None, _empty_metrics())
    except Exception as exc:  # a failed scenario must not stop the others
        return ScenarioOutcome(name, path, False, f"{path}: {type(exc).__name__}: {exc}",
                               None, _empty_metrics())
    return ScenarioOutcome(name, path, True, None, target, frame, caught)


def run_scenarios(paths, out_dir):
    """Run several scenarios; a failure does not stop the others.

    Parameters
    ----------
    paths : iterable of str or pathlib.Path
    out_dir : str or pathlib.Path

    Returns
    -------
    list of ScenarioOutcome
        In the order of ``paths``.
    """
    taken, outcomes = {}, []
    for p in paths:
        outcome = run_scenario(p, out_dir, taken)
        if outcome.ok:
            taken[outcome.name] = outcome.path
        outcomes.append(outcome)
    return outcomes
