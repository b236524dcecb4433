"""Run scenarios: validate, resolve, simulate every case, write the report.

The only module that imports both :mod:`hammerstein.scenario` and
:mod:`hammerstein.report`. ``run_scenario(path, out_dir)`` validates the
file (:func:`hammerstein.scenario.validate.validate_scenario`), resolves it
(:func:`hammerstein.scenario.resolve.resolve_scenario`: identified models,
compensators), simulates each case (:mod:`hammerstein.scenario.execute`,
sweep cases batched by :func:`hammerstein.scenario.sweeps.run_cases`),
computes the metrics and writes ``out_dir/<scenario name>/`` atomically: the report is built in a
temporary directory next to the target and renamed over it, so a failing
scenario leaves nothing behind.

Ownership: every report directory carries a :data:`MARKER` file
(``.hammerstein-report``: the version that wrote it, then ``manifest`` and
one ``file <relative path>`` line per file the report wrote). An existing
``out_dir/<name>`` is replaced only when it holds that marker and nothing its
manifest does not list (a marker without a manifest, from an older version:
anything), or is an empty directory; anything else (a user's directory, a
file, a symlink, a note added to a report) makes the scenario fail with one
line naming the path and ``--force`` (``force=True`` moves it aside, never deletes it). A
directory holding the scenario file or a file it names (by path, or a hard
link to it) is never replaced, with or without ``force``: the scenario fails
before simulating. Temporary directories are named ``.hammerstein-tmp.<pid>.*``
and hold the marker from their creation, so :func:`remove_stale_temporaries`
can remove those left by a killed run (older than the current run, their
process gone) and nothing else. Report directories get the user's umask
permissions. Warnings of the cases (a reference beyond
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

import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pandas as pd

from hammerstein.core.files import (deferred_signals, output_problem, owner_alive, owner_token,
                                    parse_owner, raise_if_interrupted, recorded_paths, release_owner,
                                    replace_directory,
                                    OutputError, safe_write, umask)
from hammerstein.core.numbers import magnitude_problem
from hammerstein.core._version import VERSION
from hammerstein.exceptions import HammersteinError
from hammerstein.report._ownership import MARKER as _MARKER
from hammerstein.report._ownership import input_problem, kept_name, ownership_problem, write_manifest
from hammerstein.report.identified import report_identified
from hammerstein.report.records import write_identification_report
from hammerstein.report.render import FigureJobs, FigureRenderer
from hammerstein.report.replication import GENERATED, foreign_outputs, write_readme
from hammerstein.report.scenario import metrics_frame, write_report
from hammerstein.report.montecarlo import write_montecarlo_report
from hammerstein.scenario.montecarlo import run_montecarlo_scenario
from hammerstein.scenario.feedback import run_feedback_scenario
from hammerstein.report.feedback_figures import write_feedback_report
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
    "start_scenario",
    "PendingScenario",
    "FigureRenderer",
    "run_scenarios",
    "run_pipelined",
    "replicate",
    "MARKER",
    "TMP_PREFIX",
    "remove_stale_temporaries",
]

#: File in every report directory: the project wrote it (``run`` may replace it).
MARKER = _MARKER
#: Prefix of the temporary directories of a run (``.hammerstein-tmp.<pid>.<random>``).
TMP_PREFIX = ".hammerstein-tmp."

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
        ``write(scenario, results, directory, jobs)`` fills the report
        directory; its figures go to ``jobs``
        (:class:`hammerstein.report.render.FigureJobs`), drawn by the
        runner's renderer before the directory is renamed into place.
    """

    simulate: Callable
    write: Callable


def _write_cases(scenario, results, directory, jobs):
    write_report(scenario, results, directory, jobs)
    report_identified(scenario, results, directory, jobs)


# -- registry of scenario kinds: add entries here (and a validator in scenario.validate) ----
SCENARIO_KINDS: dict[str, ScenarioKind] = {
    "cases": ScenarioKind(run_scenario_cases, _write_cases),
    "identification": ScenarioKind(run_identification_scenario, write_identification_report),
    "monte-carlo": ScenarioKind(run_montecarlo_scenario, write_montecarlo_report),
    "feedback": ScenarioKind(run_feedback_scenario, write_feedback_report),
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
    cases : int or None
        The scenario's cases as ``validate`` counts them (a Monte-Carlo
        study's drawn plants); None when it did not run.
    kept : pathlib.Path or None
        Where ``--force`` moved an earlier ``DIR/<name>`` that held what
        hammerstein did not write (nothing of it deleted), else None.
    """

    name: str
    path: Path
    ok: bool
    error: str | None
    out_dir: Path | None
    metrics: pd.DataFrame
    warnings: list = field(default_factory=list)
    cases: int | None = None
    kept: Path | None = None


def _empty_metrics():
    return pd.DataFrame({c: pd.Series(dtype=float if c == "value" else object)
                         for c in METRIC_COLUMNS})


def _version():
    return VERSION


def _make_temporary(out_dir):
    """A new ``.hammerstein-tmp.<pid>.<nonce>.*`` directory holding the marker, umask permissions.

    The marker's second line is the owner token (:func:`hammerstein.core.files.owner_token`:
    host, PID namespace, PID, start time, a nonce), live until :func:`_release`.
    """
    token = owner_token()
    nonce = parse_owner(token)["nonce"]
    tmp = None
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f"{TMP_PREFIX}{os.getpid()}.{nonce}.", dir=out_dir))
        os.chmod(tmp, 0o777 & ~umask())
        safe_write(tmp / MARKER, f"hammerstein {_version()}\nowner {token}\n", "report marker")
    except BaseException:
        release_owner(token)
        if tmp is not None:       # a full disk: the marker not written, the directory empty
            shutil.rmtree(tmp, ignore_errors=True)
        raise
    _TOKENS[tmp] = token
    return tmp


_TOKENS = {}   # temporary directory -> owner token of this process


def _release(tmp):
    """The temporary ``tmp`` is gone or renamed: its token is no longer live."""
    token = _TOKENS.pop(tmp, None)
    if token is not None:
        release_owner(token)


def _rmtree(tmp):
    shutil.rmtree(tmp, ignore_errors=True)
    _release(tmp)


#: Age [s] after which an empty temporary (its process killed before it wrote its marker) is removed.
EMPTY_GRACE = 60.0


def _stale(p, marker, owned, before):
    """Whether the temporary ``p`` was left by a run that is over."""
    if not owned:  # killed between its creation and its marker: an empty directory, old enough
        return p.stat().st_mtime < min(before, time.time() - EMPTY_GRACE)
    text = marker.read_text(encoding="utf-8", errors="replace")[:4096]
    owner = next((ln[6:] for ln in text.splitlines() if ln.startswith("owner ")), None)
    if owner is not None:
        return owner_alive(owner) is False
    parts = p.name[len(TMP_PREFIX):].split(".", 1)   # an older version: its PID only
    pid = int(parts[0])
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
        return False
    except ProcessLookupError:
        return True
    except (PermissionError, OverflowError, OSError):
        return False


def remove_stale_temporaries(out_dir, before=None):
    """Remove temporary directories of killed runs in ``out_dir``.

    Only directories named ``.hammerstein-tmp.<pid>.*`` that hold the
    :data:`MARKER` file, whose marker is older than ``before`` (default now)
    and whose owner is certainly gone are removed: the owner token of the
    marker (:func:`hammerstein.core.files.owner_alive`: same host and PID
    namespace, its process exited or its PID reused, or a finished call of
    this process) - never judged by the PID alone, so runs in two PID
    namespaces or two threads of one process sharing ``out_dir`` keep their
    temporaries. An empty one (killed before writing its marker) is removed
    once older than :data:`EMPTY_GRACE` seconds.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        Reports directory (nothing happens when it does not exist).
    before : float, optional
        Start of the run [s since the epoch]; default now.

    Returns
    -------
    list of pathlib.Path
        The directories removed.
    """
    out_dir, before = Path(out_dir), time.time() if before is None else before
    removed = []
    try:
        entries = list(out_dir.iterdir()) if out_dir.is_dir() else []
    except OSError:
        return removed
    for p in entries:
        parts = p.name[len(TMP_PREFIX):].split(".", 1)
        if not p.name.startswith(TMP_PREFIX) or not parts[0].isdigit() or p in _TOKENS:
            continue
        marker = p / MARKER
        try:
            if p.is_symlink() or not p.is_dir() or marker.is_symlink():
                continue
            owned = marker.is_file()  # a directory named like the marker is not one
            when = marker.stat().st_mtime if owned else p.stat().st_mtime
            if when >= before or not _stale(p, marker, owned, before):
                continue
        except (OSError, ValueError):
            continue
        if owned:
            shutil.rmtree(p, ignore_errors=True)
        else:  # killed before its marker was written: removed only when empty
            try:
                os.rmdir(p)
            except OSError:
                continue
        removed.append(p)
    return removed


def _start_write(out_dir, writer):
    """A new temporary directory in ``out_dir`` filled by ``writer(tmp)`` (removed on error)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        with deferred_signals():  # the name of what is created is always known
            tmp = _make_temporary(out_dir)
        writer(tmp)
    except BaseException:
        if tmp is not None:
            _rmtree(tmp)
        raise
    return tmp


def _finish_write(out_dir, name, tmp, force=False, jobs=None, inputs=()):
    """Wait for the figure ``jobs`` writing into ``tmp``, then rename ``tmp`` to ``out_dir/name``.

    The marker gets the manifest of the files written. ``tmp`` is removed on
    any error (after the jobs stopped writing into it); ``inputs`` (files
    the scenario read) are never replaced. An earlier report of the project's
    own is deleted; with ``force``, a ``out_dir/name`` that holds anything
    hammerstein did not write (a user's directory, notes in a report) is
    renamed beside it (:func:`hammerstein.report._ownership.kept_name`), never deleted.

    Returns
    -------
    target : pathlib.Path
    kept : pathlib.Path or None
        Where the earlier ``out_dir/name`` was moved, when it was not all ours.
    """
    target = Path(out_dir) / name
    old = kept = None
    try:
        try:
            if jobs is not None:
                jobs.wait()
        except BaseException:
            jobs.cancel()
            raise
        problem = ownership_problem(target, force, inputs)  # again: it may have appeared meanwhile
        if problem:
            raise ScenarioError([problem])
        foreign = (force and os.path.lexists(target)
                   and ownership_problem(target, False, inputs) is not None)
        write_manifest(tmp, _version(), _TOKENS.get(tmp))
        with deferred_signals():  # the swap is never left half done
            if foreign:           # what hammerstein did not write is moved aside, never deleted
                kept = kept_name(target)
            elif os.path.lexists(target):
                old = _make_temporary(out_dir)
            replace_directory(tmp, target, old, kept)
            _release(tmp)
    except BaseException:
        if tmp is not None:
            _rmtree(tmp)
        raise
    finally:
        if old is not None:
            _rmtree(old)
    return target, kept


def _case_warnings(results):
    """Distinct ``(case, message)`` pairs of the results' warnings, in order."""
    pairs = [(str(getattr(r, "name", "")), " ".join(str(w).split()))
             for r in results for w in getattr(r, "warnings", None) or []]
    return list(dict.fromkeys(pairs))


def _write_warnings(pairs, directory):
    """``warnings.csv`` (columns ``case, message``) when there are warnings."""
    if pairs:
        safe_write(Path(directory) / "warnings.csv",
                   pd.DataFrame(pairs, columns=["case", "message"]).to_csv(index=False),
                   "warnings file")


#: Signals of a case result checked for overflow: attribute, what it is, unit.
_SIGNALS_CHECKED = (("outputs", "simulated outputs", "µm"), ("inputs", "compensator voltages", "V"),
                    ("model_outputs", "model outputs", "µm"), ("reference", "reference", "µm"))


def overflow_problem(results):
    """Why the simulated cases cannot be reported (an overflow), or None.

    A case whose outputs, voltages or reference reach a magnitude beyond
    :data:`hammerstein.core.numbers.MAX_MAGNITUDE` (or infinity), or a
    metric that is infinite, would write ``rms_error = inf`` and figures
    with no scale: the scenario is refused instead, naming the first case
    and quantity. NaN (after a divergence) is not an overflow.

    Parameters
    ----------
    results : list
        Case results (:class:`hammerstein.scenario.execute.CaseResult` or
        any object with ``name``, ``metrics`` and signal arrays).

    Returns
    -------
    str or None
        ``"case 'open': simulated outputs: 3.04e+301 µm at index (0, 5) is
        beyond the limit 1e+150"``.
    """
    if not isinstance(results, (list, tuple)):
        return None
    for r in results:
        name = getattr(r, "name", None)
        if not isinstance(name, str):
            continue
        for attr, what, unit in _SIGNALS_CHECKED:
            a = getattr(r, attr, None)
            if a is None or not hasattr(a, "dtype") or a.dtype.kind not in "fiu":
                continue
            problem = magnitude_problem(a, unit)
            if problem:
                return f"case {name!r}: {what}: {problem}"
        for row in getattr(r, "metrics", None) or ():
            v = row.get("value") if isinstance(row, dict) else None
            if isinstance(v, float) and v in (float("inf"), float("-inf")):
                return (f"case {name!r}: metric {row.get('metric')} of {row.get('channel')} is "
                        f"infinite (the signals overflow)")
    return None


def _message(path, exc):
    """One failure message without exception class names (kept only for an unexpected bug)."""
    if isinstance(exc, OSError):
        if isinstance(exc, HammersteinError):      # safe_write's line names the file already
            return f"{path}: cannot write the report: {exc}"
        where = f" {exc.filename}:" if getattr(exc, "filename", None) else ""
        return (f"{path}: cannot write the report:{where} {exc.strerror or exc}; nothing was "
                f"written")
    if isinstance(exc, (ValueError, ArithmeticError)) or type(exc).__module__.startswith("hammerstein"):
        return f"{path}: {exc}"
    return f"{path}: unexpected {type(exc).__name__}: {exc}"


class PendingScenario:
    """A scenario simulated and written to its temporary directory, its figures still drawing.

    Made by :func:`start_scenario`; :meth:`finish` waits for the figures and
    renames the report into place (or returns the failure).

    Parameters
    ----------
    outcome : ScenarioOutcome
        The outcome when the report is in place (or the failure).
    tmp : pathlib.Path or None
        The temporary directory (None when the scenario already failed).
    jobs : hammerstein.report.render.FigureJobs or None
    force : bool
    out_dir : pathlib.Path or None
        The reports directory.
    inputs : sequence of pathlib.Path
        The scenario file and the files it names: the report never replaces
        a directory holding one.
    """

    def __init__(self, outcome, tmp=None, jobs=None, force=False, out_dir=None, inputs=()):
        self.outcome, self._tmp, self._jobs, self._force = outcome, tmp, jobs, force
        self._out_dir, self._inputs = out_dir, tuple(inputs)

    @property
    def name(self):
        """The scenario's name (its report directory)."""
        return self.outcome.name

    def done(self):
        """Whether :meth:`finish` would not wait.

        Returns
        -------
        bool
            True when the figures are drawn or there is nothing to wait for.
        """
        return self._tmp is None or self._jobs is None or self._jobs.done()

    def finish(self):
        """Wait for the figures and rename the report into place.

        Returns
        -------
        ScenarioOutcome
            Not ok (nothing written) when a figure failed or the target
            cannot be replaced.
        """
        if self._tmp is None:
            return self.outcome
        o, tmp, self._tmp = self.outcome, self._tmp, None
        try:
            target, kept = _finish_write(self._out_dir, o.name, tmp, self._force, self._jobs,
                                         self._inputs)
        except ScenarioError as exc:
            self.outcome = ScenarioOutcome(o.name, o.path, False, str(exc), None, _empty_metrics())
        except Exception as exc:  # a failed figure (in a worker too) is the scenario's error
            raise_if_interrupted()
            self.outcome = ScenarioOutcome(o.name, o.path, False, _message(o.path, exc), None,
                                           _empty_metrics())
        else:
            self.outcome = ScenarioOutcome(o.name, o.path, True, None, target, o.metrics, o.warnings,
                                           o.cases, kept)
        return self.outcome

    def abandon(self, wait=True):
        """Cancel the figures and remove the temporary directory (on an interruption).

        Parameters
        ----------
        wait : bool
            Wait for the figures being drawn first; False once the
            renderer is closed (its workers have exited).
        """
        if self._tmp is not None:
            tmp, self._tmp = self._tmp, None
            try:
                if self._jobs is not None:
                    self._jobs.cancel(wait)
            finally:
                _rmtree(tmp)


def start_scenario(path, out_dir, taken=None, force=False, renderer=None):
    """Validate and simulate one scenario, write its report to a temporary directory.

    The figures are handed to ``renderer`` (drawn while the caller goes on);
    :meth:`PendingScenario.finish` waits for them and renames the report
    into place.

    Parameters
    ----------
    path : str or pathlib.Path
        Scenario TOML file.
    out_dir : str or pathlib.Path
        Reports directory.
    taken : dict of str to pathlib.Path, optional
        Report names already used in this run (see :func:`run_scenario`).
    force : bool
        See :func:`run_scenario`.
    renderer : hammerstein.report.render.FigureRenderer, optional
        Draws the figures; default: drawn here, before returning.

    Returns
    -------
    PendingScenario
        Never raises for a bad scenario or a failed simulation.

    Raises
    ------
    ScenarioError
        Never propagates: raised internally when the name is in ``taken``
        and caught like every other exception (the outcome's ``error``).
    """
    path = Path(path)
    name = path.stem
    inputs = [path]        # the scenario and every file it names: never inside the replaced report
    try:
        with recorded_paths() as named:
            spec = validate_scenario(path)  # dispatches on the top-level kind
            inputs += named
            name = spec.name
            if taken is not None and name in taken:
                raise ScenarioError([
                    f"{path}: name: {name!r} is also the name of {taken[name]} in this run; "
                    f"give each scenario its own name (its report directory)"])
            target = Path(out_dir) / name
            problem = ownership_problem(target, force, inputs)
            if problem:  # before simulating: nothing of the user's is replaced
                raise ScenarioError([f"{path}: {problem}"])
            scenario = resolve_scenario(spec)
            kind = SCENARIO_KINDS[getattr(scenario, "kind", "cases")]
            results = kind.simulate(scenario)
            inputs = [path] + named
        problem = overflow_problem(results) or input_problem(target, inputs)
        if problem:  # an overflowing case, a file read meanwhile: nothing written, one line
            raise ScenarioError([f"{path}: {problem}"])
        frame = metrics_frame(results)
        caught = _case_warnings(results)
        jobs = FigureJobs(renderer)

        def write(d):
            try:
                kind.write(scenario, results, d, jobs)
                _write_warnings(caught, d)
            except OutputError as exc:   # named where the report goes, not its temporary place
                raise OutputError(str(exc).replace(str(d), str(Path(out_dir) / name))) from None
        tmp = _start_write(out_dir, write)
    except ScenarioError as exc:
        return PendingScenario(ScenarioOutcome(name, path, False, str(exc), None, _empty_metrics()))
    except Exception as exc:  # a failed scenario must not stop the others
        raise_if_interrupted()    # unless a signal caused it (a module it imported half done)
        return PendingScenario(ScenarioOutcome(name, path, False, _message(path, exc), None,
                                               _empty_metrics()))
    return PendingScenario(ScenarioOutcome(name, path, True, None, Path(out_dir) / name, frame,
                                           caught, len(scenario.cases)), tmp, jobs, force,
                           Path(out_dir), dict.fromkeys(inputs))


def run_scenario(path, out_dir, taken=None, force=False, renderer=None):
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
    force : bool
        Replace ``out_dir/<name>`` even when the project did not write it
        (default: only a directory with the :data:`MARKER` file, or an
        empty one, is replaced).
    renderer : hammerstein.report.render.FigureRenderer, optional
        Draws the figures (default: in this process).

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

    Examples
    --------
    A 10 V, 50 Hz sine on u_x of the static plant: its x loop spans
    ``2 sum_i w_i (A - r_i)`` = 116.8 µm peak to peak (the closed form of the
    PI's peak output, docs/operators.md).

    >>> import pathlib, tempfile
    >>> from hammerstein import run_scenario
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "tiny.toml").write_text('''
    ... [plant]
    ... preset = "rakotondrabe-2dof"
    ... dynamics = false
    ... [[cases]]
    ... name = "open-loop"
    ... drive = { kind = "sine", input = "ux", amplitude = 10.0, frequency = 50.0, periods = 2 }
    ... ''')
    >>> outcome = run_scenario(folder / "tiny.toml", folder / "reports")
    >>> outcome.ok, outcome.out_dir.name
    (True, 'tiny')
    >>> m = outcome.metrics
    >>> row = (m.case == "open-loop") & (m.channel == "x") & (m.metric == "peak_to_peak")
    >>> print(f"{m[row].value.item():.1f} µm")
    116.8 µm
    """
    pending = start_scenario(path, out_dir, taken, force, renderer)
    try:
        return pending.finish()
    except BaseException:
        pending.abandon()
        raise


def run_pipelined(paths, out_dir, force=False, on_outcome=None, on_start=None, figures=None):
    """Run scenarios in order, drawing the figures of one while the next simulates.

    Figures go to a :class:`hammerstein.report.render.FigureRenderer`
    (:data:`hammerstein.report.render.WORKERS` worker processes); each report is renamed into place once its figures
    are drawn, in the order of ``paths``. An interruption cancels the
    figures and removes every temporary directory of the run.

    Parameters
    ----------
    paths : iterable of str or pathlib.Path
    out_dir : str or pathlib.Path
    force : bool
        See :func:`run_scenario`.
    on_outcome : callable, optional
        ``on_outcome(path, outcome)`` as each scenario finishes (in order).
    on_start : callable, optional
        ``on_start(path)`` before each scenario starts.
    figures : callable, optional
        ``figures(png_path) -> bool``: draw only these figures (see
        :func:`hammerstein.report.render.figure_selection`); all by default.

    Returns
    -------
    list of ScenarioOutcome
        In the order of ``paths``.
    """
    taken, pending, outcomes = {}, [], []

    def finish_ready(block):
        while pending and (block or pending[0][1].done()):
            p, job = pending.pop(0)
            outcome = job.finish()
            if not outcome.ok and taken.get(outcome.name) == outcome.path:
                del taken[outcome.name]  # its figures failed: the name is free again
            outcomes.append(outcome)
            if on_outcome is not None:
                on_outcome(p, outcome)

    renderer = FigureRenderer(select=figures)
    try:
        for p in paths:
            if on_start is not None:
                on_start(p)
            job = start_scenario(p, out_dir, taken, force, renderer)
            if job.outcome.ok:  # the name is reserved while its figures are drawn
                taken[job.name] = job.outcome.path
            pending.append((p, job))
            finish_ready(block=False)
        finish_ready(block=True)
    except BaseException:
        renderer.close(cancel=True)  # its workers have exited: nothing writes any more
        for _, job in pending:
            job.abandon(wait=False)
        raise
    renderer.close()
    return outcomes


def run_scenarios(paths, out_dir, force=False):
    """Run several scenarios; a failure does not stop the others.

    Stale temporary directories of killed runs in ``out_dir`` are removed
    first (:func:`remove_stale_temporaries`).

    Parameters
    ----------
    paths : iterable of str or pathlib.Path
    out_dir : str or pathlib.Path
    force : bool
        See :func:`run_scenario`.

    Returns
    -------
    list of ScenarioOutcome
        In the order of ``paths``.
    """
    remove_stale_temporaries(out_dir)
    return run_pipelined(paths, out_dir, force)


def replicate(scenarios="scenarios/paper", out="reports/paper", force=False):
    """Run every paper scenario and write the replication README.

    Parameters
    ----------
    scenarios : str or pathlib.Path
        Directory of scenario ``*.toml`` files.
    out : str or pathlib.Path
        Output directory: ``<out>/<scenario>/`` reports and ``<out>/README.md``
        (:func:`hammerstein.report.replication.write_readme`).
    force : bool
        Replace ``<out>/README.md`` and the other files of the README (and
        report directories) even when hammerstein did not write them; by
        default they are checked before anything runs.

    Returns
    -------
    list of ScenarioOutcome

    Raises
    ------
    FileNotFoundError
        If ``scenarios`` holds no ``*.toml`` file.
    FileExistsError
        A file the README step would replace was not written by ``hammerstein
        replicate`` (:func:`hammerstein.report.replication.foreign_outputs`)
        and ``force`` is False, or cannot be written at all (a symbolic
        link out of ``out``, with or without ``force``); nothing has run.
    """
    files = sorted(Path(scenarios).glob("*.toml"))
    if not files:
        raise FileNotFoundError(f"scenarios: no *.toml scenario under {scenarios}")
    out = Path(out)
    problems = [] if force else foreign_outputs(out)
    forced = []      # refused even with force: --force is no remedy to name for them
    # a file of the README that cannot be written (a link out of --out, a bad name) is refused
    # before anything runs, even with force: never a half-written replication
    for name in GENERATED:
        p = out / name
        problem = output_problem(p, out) or (
            f"{p}: exists and is not a regular file" if force and os.path.lexists(p)
            and not p.is_file() else None)
        forced += [problem] if problem and problem not in forced + problems else []
    if problems or forced:
        first = (problems + forced)[0]
        more = len(problems) + len(forced) - 1
        fix = ("move it away or choose another --out" if forced and not problems else
               "move it away, choose another --out, or use --force to replace it")
        raise FileExistsError(f"{first}{f' (and {more} more)' if more else ''}; {fix}")
    remove_stale_temporaries(out)
    outcomes = run_pipelined(files, out, force)
    write_readme(out, outcomes)
    return outcomes
