"""Run scenarios: validate, resolve, simulate every case, write the report.

The only module that imports both :mod:`hammerstein.scenario` and
:mod:`hammerstein.report`. ``run_scenario(path, out_dir)`` validates the
file (:func:`hammerstein.scenario.validate.validate_scenario`), resolves it
(:func:`hammerstein.scenario.resolve.resolve_scenario`: identified models,
compensators), simulates each case (:mod:`hammerstein.scenario.execute`,
sweep cases batched by :func:`hammerstein.scenario.sweeps.run_cases`),
computes the metrics and writes ``out_dir/<scenario name>/`` atomically: the report is built in a
temporary directory next to the target and renamed over it, so a failing
scenario leaves nothing behind. Warnings of the cases (a reference beyond
the identified range, a convergence check set to ``"warn"``, ...) are listed
in ``report.md``, in ``warnings.csv`` (``case, message``; written only when
there are warnings) and in :attr:`ScenarioOutcome.warnings` (``hammerstein
run`` prints one ``warning:`` line each).

The top-level ``kind`` of a file selects an entry of :data:`SCENARIO_KINDS`
(how to simulate and report it; its validation is
:data:`hammerstein.scenario.validate.VALIDATORS`). :func:`replicate` runs
the paper's scenarios and writes the replication README
(:mod:`hammerstein.report.replication`).
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pandas as pd

from hammerstein.report.identified import report_identified
from hammerstein.report.records import write_identification_report
from hammerstein.report.replication import write_readme
from hammerstein.report.scenario import metrics_frame, write_report
from hammerstein.scenario.records import run_identification_scenario
from hammerstein.scenario.resolve import resolve_scenario
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.sweeps import run_scenario_cases
from hammerstein.scenario.validate import validate_scenario

__all__ = [
    "ScenarioKind",
    "SCENARIO_KINDS",
    "ScenarioOutcome",
    "METRIC_COLUMNS",
    "run_scenario",
    "run_scenarios",
    "replicate",
]

#: Columns of metrics.csv and of ScenarioOutcome.metrics.
METRIC_COLUMNS = ["case", "channel", "metric", "value", "unit"]


@dataclass
class ScenarioKind:
    """An entry of the scenario-kind registry (top-level ``kind`` of a file).

    Parameters
    ----------
    simulate : callable
        ``simulate(scenario) -> results`` (``scenario`` validated and
        resolved), each result with ``name``, ``metrics`` (rows ``{channel,
        metric, value, unit}``) and ``warnings``.
    write : callable
        ``write(scenario, results, directory)`` fills the report directory.
    """

    simulate: Callable
    write: Callable


def _write_cases(scenario, results, directory):
    write_report(scenario, results, directory)
    report_identified(scenario, results, directory)


# -- registry of scenario kinds: add entries here (and a validator in scenario.validate) ----
SCENARIO_KINDS: dict[str, ScenarioKind] = {
    "cases": ScenarioKind(run_scenario_cases, _write_cases),
    "identification": ScenarioKind(run_identification_scenario, write_identification_report),
}


@dataclass
class ScenarioOutcome:
    """What happened to one scenario file.

    Parameters
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

    Raises
    ------
    ScenarioError
        Never propagates: raised internally when the scenario's name is in
        ``taken``, then caught like every other exception and reported in
        the outcome's ``error``.
    """
    path = Path(path)
    name = path.stem
    try:
        spec = validate_scenario(path)  # dispatches on the top-level kind
        name = spec.name
        if taken is not None and name in taken:
            raise ScenarioError([
                f"{path}: name: {name!r} is also the name of {taken[name]} in this run; "
                f"give each scenario its own name (its report directory)"])
        scenario = resolve_scenario(spec)
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


def replicate(scenarios="scenarios/paper", out="reports/paper"):
    """Run every paper scenario and write the replication README.

    Parameters
    ----------
    scenarios : str or pathlib.Path
        Directory of scenario ``*.toml`` files.
    out : str or pathlib.Path
        Output directory: ``<out>/<scenario>/`` reports and ``<out>/README.md``
        (:func:`hammerstein.report.replication.write_readme`).

    Returns
    -------
    list of ScenarioOutcome

    Raises
    ------
    FileNotFoundError
        If ``scenarios`` holds no ``*.toml`` file.
    """
    files = sorted(Path(scenarios).glob("*.toml"))
    if not files:
        raise FileNotFoundError(f"scenarios: no *.toml scenario under {scenarios}")
    out = Path(out)
    outcomes = [run_scenario(f, out) for f in files]
    write_readme(out, outcomes)
    return outcomes
