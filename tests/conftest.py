"""Fixtures shared by the whole suite (one build of the bundled preset per session).

The bundled preset is the paper's 2-DOF piezocantilever: the de-garbled
multivariable PI of eq. (13) with (``preset_plant``) or without
(``static_plant``) the bending modes. Tests must not modify these objects.
"""

from __future__ import annotations

import os

# One OpenBLAS thread, as the CLI runs it (README "Performance"), set before numpy is
# imported: the identifications' least squares are small, and OpenBLAS threads spinning
# on a busy 2-core machine tripled their CPU time (tests/core/test_lti.py and
# tests/cli/test_identify_dynamics.py: 24-29 s of CPU with the default threads, 9-10 s
# with one). A value the user sets is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402

# The suite's own bytecode is cached (``__pycache__`` next to the package's and the test
# modules, as Python does by default) even where ``PYTHONDONTWRITEBYTECODE`` is set, as in
# some sandboxes: without it every run recompiles the package and pytest rewrites the
# assertions of every test module again, about 6 s of CPU before the first test. Set
# here, before the package and the test modules are imported; the CLI's own processes
# keep the user's setting (they read the files written here, they write none).
sys.dont_write_bytecode = False

import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from hammerstein import InverseMultiplicativeCompensator, load_plant  # noqa: E402
from hammerstein import simulation as sim  # noqa: E402
from hammerstein.cli.warmup import warm_up  # noqa: E402

#: the repository root (scenarios/, baselines/, tests/corpus/ live below it)
ROOT = Path(__file__).resolve().parents[1]

# Hermetic runs: no identification comes from (or goes to) the user's on-disk cache,
# in this process and in the CLI subprocesses the tests start. The cache's own tests
# point it at a temporary directory.
os.environ["HAMMERSTEIN_CACHE_DIR"] = "off"
# Scenario files may name files only under their own directory (core/files.py
# confined_path); the corpus reaches ../models and /dev/zero, and some tests name files
# of another temporary directory. The confinement's own tests remove this variable.
os.environ["HAMMERSTEIN_ALLOW_PATHS"] = os.pathsep.join(
    [str(ROOT / "tests" / "corpus"), "/dev", tempfile.gettempdir()])


@pytest.fixture(scope="session")
def repo_root():
    """The repository root directory."""
    return ROOT


@pytest.fixture
def no_figures():
    """A figure renderer that draws none: for runs whose report text and tables are checked.

    Pass it as ``run_scenario(..., renderer=no_figures)``; ``report.md`` then says
    that each figure was left out (what ``hammerstein run --figures none`` does).
    """
    from hammerstein.report.render import FigureRenderer

    with FigureRenderer(workers=0, select=lambda path: False) as renderer:
        yield renderer


@pytest.fixture(scope="session")
def static_plant():
    """The bundled preset without dynamics: the rate-independent 2x2 PI."""
    return load_plant("rakotondrabe-2dof", dynamics=False)


@pytest.fixture(scope="session")
def preset_plant():
    """The bundled preset with its bending modes: the Hammerstein actuator."""
    return load_plant("rakotondrabe-2dof", dynamics=True)


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Compile (or load from numba's cache) every simulation kernel once, up front.

    On a fresh clone numba's cache is empty and the CLI announces each compilation
    with one stderr line ("compiling the simulation kernels once, ..."). Tests that
    count stderr lines would otherwise see that line in whichever test happens to
    compile first; compiling here, outside any CLI run, keeps them deterministic.
    """
    warm_up()      # what `hammerstein warmup` compiles: every kernel the commands reach
    plant = load_plant("rakotondrabe-2dof", dynamics=True)
    static = load_plant("rakotondrabe-2dof", dynamics=False)
    model = plant.hysteresis
    u = np.zeros((model.n_inputs, 8))
    sim.simulate_plays(np.zeros(8), np.array([0.0, 0.5]), np.zeros(2))
    sim.simulate_hysteresis(model, u)
    sim.simulate_plant(plant, u)
    comp = InverseMultiplicativeCompensator(model)
    yr = np.zeros((model.n_outputs, 8))
    sim.simulate_compensator(comp, yr)
    sim.simulate_chain(comp, plant, yr)
    sim.simulate_chain(comp, static, yr)
    for parallel in (False, True):
        sim.simulate_chain_batch([comp, comp], [plant, static], [yr, yr], parallel=parallel)


# Figures of the runs the tests start in this process (``main(["run", ...])``,
# ``run_scenarios``, ``check --out``) are drawn inline, not in the runner's pool of forked
# workers: the same figure functions write the same PNGs (tests/report/test_render.py
# compares pool and inline files byte for byte), without forking this large process for
# every run (about 0.2 s of CPU per run). The pool itself is still what runs for the
# tests marked ``figure_pool`` (the runner's pool: pipelined figures, a worker's error,
# concurrent runs), for the slow end-to-end runs of every bundled scenario (``slow``:
# every report's figure jobs pickled and drawn in the workers) and in every ``python -m
# hammerstein`` subprocess.
_RUNNER_FIGURES = {"pool": True}


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    # before the first test of each file and its module's fixtures (see
    # _freeze_long_lived_objects below): what the previous files imported (matplotlib,
    # scipy.signal, dask, ...) stays loaded
    if item.path != _FROZEN_AT["file"]:
        _FROZEN_AT["file"] = item.path
        _freeze_long_lived_objects()
    # before the item's fixtures (a module-scoped fixture may run the CLI for it)
    _RUNNER_FIGURES["pool"] = any(item.get_closest_marker(name) is not None
                                  for name in ("figure_pool", "slow"))


@pytest.fixture(scope="session", autouse=True)
def _runner_figures_inline():
    """Make the runner's :class:`FigureRenderer` inline unless the test wants the pool."""
    import hammerstein.runner as runner

    pooled = runner.FigureRenderer

    def renderer(*args, **kwargs):
        if not _RUNNER_FIGURES["pool"]:
            kwargs.setdefault("workers", 0)
        return pooled(*args, **kwargs)

    runner.FigureRenderer = renderer
    yield
    runner.FigureRenderer = pooled


# ---------------------------------------------------------------------------------------
# ``--cpu-report N``: CPU time (user + system) of each test, its fixtures' setup and
# teardown included, of this process and of every child process it waited for
# (``getrusage(RUSAGE_SELF)`` + ``getrusage(RUSAGE_CHILDREN)``: CLI subprocesses, figure
# workers, compilers). Prints the N most expensive tests and files, the CPU spent before
# the first test (interpreter start-up, imports, collection) and the total. A measuring
# aid for keeping the default suite cheap (README "Performance and python-control");
# session-scoped fixtures are charged to the first test that uses them.
# ---------------------------------------------------------------------------------------

def _cpu_seconds():
    """User + system CPU seconds of this process and its waited-for children."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime)


def pytest_addoption(parser):
    parser.addoption(
        "--cpu-report", type=int, default=0, metavar="N",
        help="print the N tests and test files that took the most CPU time "
             "(user + system, child processes included)")
    parser.addoption(
        "--cpu-report-csv", default=None, metavar="PATH",
        help="with --cpu-report: also write every test's CPU time to PATH (CSV: test, "
             "this process s, child processes s)")


def pytest_configure(config):
    config._cpu_report = {} if config.getoption("cpu_report") else None


# The cyclic garbage collector: a full collection walks every tracked object of this
# process, and the suite's process holds several hundred thousand long-lived ones (numpy,
# scipy, pandas, matplotlib, numba, hypothesis, the collected test items, the session's
# fixtures), loaded once and never garbage. Each test's own cycles (figures, models,
# reports) trigger a full collection every few tests, 0.15-0.35 s each: about 10 s of CPU
# of the default suite went into walking the same long-lived objects again (measured with
# ``gc.callbacks``: 30 full collections, 9.7 s). After collection and at the start of
# each test file, the objects alive then are moved to the collector's permanent
# generation (``gc.freeze()``, what the figure workers of hammerstein/report/render.py
# do): they are the modules imported so far and the session's fixtures, which live until
# the end anyway; what the tests create after that is collected as before (garbage in
# the suite's process: 11.6 -> 4.3 s of CPU, same load). ``gc.collect()`` first, so that
# no garbage is frozen.
def _freeze_long_lived_objects():
    import gc

    gc.collect()
    gc.freeze()


_FROZEN_AT = {"file": None}


def pytest_collection_finish(session):
    _freeze_long_lived_objects()
    if session.config._cpu_report is not None:
        session.config._cpu_before_tests = _cpu_seconds()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    report = item.config._cpu_report
    if report is None:
        return (yield)
    own0, kids0 = _cpu_seconds()
    try:
        return (yield)
    finally:
        own1, kids1 = _cpu_seconds()
        report[item.nodeid] = (own1 - own0, kids1 - kids0)


def pytest_terminal_summary(terminalreporter, config):
    report = config._cpu_report
    if report is None:
        return
    n = config.getoption("cpu_report")
    write = terminalreporter.write_line
    own, kids = _cpu_seconds()
    start_own, start_kids = getattr(config, "_cpu_before_tests", (0.0, 0.0))
    tests_own = sum(o for o, _ in report.values())
    tests_kids = sum(k for _, k in report.values())
    terminalreporter.section(f"CPU time (user + system), {len(report)} tests")
    write(f"total {own + kids:8.2f} s (this process {own:.2f} s, child processes "
          f"{kids:.2f} s)")
    write(f"before the first test (start-up, imports, collection) "
          f"{start_own + start_kids:8.2f} s")
    write(f"tests {tests_own + tests_kids:8.2f} s (child processes {tests_kids:.2f} s)")
    files = {}
    for nodeid, (o, k) in report.items():
        o_f, k_f, c_f = files.get(nodeid.split("::")[0], (0.0, 0.0, 0))
        files[nodeid.split("::")[0]] = (o_f + o, k_f + k, c_f + 1)
    write(f"-- {n} most expensive files: CPU s (child processes s), tests")
    for name, (o, k, c) in sorted(files.items(), key=lambda kv: -sum(kv[1][:2]))[:n]:
        write(f"{o + k:8.2f} ({k:6.2f}) {c:5d}  {name}")
    write(f"-- {n} most expensive tests: CPU s (child processes s)")
    for nodeid, (o, k) in sorted(report.items(), key=lambda kv: -sum(kv[1]))[:n]:
        write(f"{o + k:8.2f} ({k:6.2f})  {nodeid}")
    path = config.getoption("cpu_report_csv")
    if path:
        import csv

        with open(path, "x", newline="", encoding="utf-8") as f:   # never overwrites
            rows = csv.writer(f)
            rows.writerow(["test", "self_s", "children_s"])
            rows.writerows([k, f"{o:.4f}", f"{c:.4f}"] for k, (o, c) in report.items())


# ---------------------------------------------------------------------------------------
# Every bundled scenario, run once per session for the slow tests that read its reports:
# tests/cli/test_cli.py (the CLI end to end: exit status, every report's files, the
# paper's numbers) and tests/report/test_every_figure.py (every figure of every report
# shows its data). Each of them ran all bundled scenarios on its own before, with the
# same identifications: about 250 s of CPU each, most of it the identifications of the
# realistic scenarios. One `hammerstein run` of them all (the CLI, figures drawn in the
# runner's pool of worker processes, as test_cli checks) serves both: every figure job is
# also drawn here from a pickled copy of the job (what the pool's workers receive) and
# checked on its Figure and its PNG (tests/report/figure_checks.py), as test_every_figure
# did with its CheckingRenderer. A session fixture is per xdist worker: the tests using it
# carry ``xdist_group("bundled-reports")``, and .ci/run runs the slow tests with
# ``--dist loadgroup`` so that they share one run (see pytest_xdist_make_scheduler below).
# ---------------------------------------------------------------------------------------
#: nodeid prefixes of the tests of each xdist group (the ``xdist_group`` marks' tests)
XDIST_GROUPS = {
    "bundled-reports": tuple(f"tests/cli/test_cli.py::{name}" for name in (
        "test_every_bundled_scenario_runs", "test_fig05_numbers_within_10_percent[",
        "test_fig05_rate_dependency_loops_widen_with_frequency",
        "test_fig08_static_plant_is_linearised_and_decoupled[",
        "test_literal_law_reported_as_diverged")) + (
        "tests/report/test_every_figure.py::"
        "test_every_figure_of_every_bundled_report_shows_its_data[",),
    # the slow tests reading tests/cli/conftest.py's forked_cli (one interpreter's forked runs)
    "forked-cli": tuple(f"tests/cli/{name}" for name in (
        "test_cli.py::test_console_script_keeps_status_and_output",
        "test_cli.py::test_closed_pipe_is_not_an_error_message",
        "test_malformed.py::test_real_stderr_through_python_m",
        "test_reliability.py::test_sigterm_ends_the_run_in_one_line",
        "test_issue22.py::test_3_concurrent_updates_all_land",
        "test_issue22.py::test_8_sigkill_of_a_run_ends_its_workers",
        "test_issue22.py::test_8_sighup_is_an_interruption",
        "test_issue22.py::test_8_sighup_under_nohup_is_ignored",
        "test_issue22.py::test_10_closed_stdio_keeps_the_exit_status",
        "test_issue22.py::test_10_full_stdout_is_an_error")),
}


@pytest.hookimpl(optionalhook=True)   # pytest-xdist's hook (the test extra installs it)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup`` that keeps each of :data:`XDIST_GROUPS` on one worker.

    pytest-xdist's own loadgroup finds a test's group in the ``@group`` suffix it appends
    to the test's ``_nodeid`` on the worker; since pytest 9 a node's id is not read from
    ``_nodeid`` any more, the suffix never reaches the controller and the group's tests
    were spread over the workers (measured with pytest 9.2, pytest-xdist 3.8: each worker
    ran the bundled scenarios' fixture). Here the controller knows the groups by their
    nodeids. Other ``--dist`` modes are pytest-xdist's own.
    """
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            for group, prefixes in XDIST_GROUPS.items():
                if nodeid.startswith(prefixes):
                    return group
            return nodeid            # every other test on its own, as with --dist load

    return GroupScheduling(config, log)


BUNDLED = sorted(p for p in (ROOT / "scenarios").rglob("*.toml")
                 if "presets" not in p.relative_to(ROOT / "scenarios").parts)   # preset files


def _figure_checks():
    """tests/report/figure_checks.py, imported under its own name (as its test files do)."""
    import importlib.util

    if "figure_checks" not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            "figure_checks", ROOT / "tests" / "report" / "figure_checks.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules["figure_checks"] = module
        spec.loader.exec_module(module)
    return sys.modules["figure_checks"]


class BundledReports:
    """What :func:`bundled_reports` ran.

    Attributes
    ----------
    paths : list of pathlib.Path
        The scenario files run (``BUNDLED``).
    out : pathlib.Path
        The reports directory (``out/<scenario name>/``).
    status : int
        The exit status of ``hammerstein run`` (its errors went to the stderr of the
        first test using the fixture).
    figures : dict of pathlib.Path to CheckedFigures
        Per scenario file, the figures its report handed to the renderer.
    """

    def __init__(self, paths, out, status, figures):
        self.paths, self.out, self.status, self.figures = paths, out, status, figures


class CheckedFigures:
    """The figure jobs of one scenario: their PNG names and what the checks found."""

    def __init__(self):
        self.names, self.problems = [], []


class _CheckingTee:
    """A figure renderer that checks every job here, then hands it to the runner's renderer."""

    def __init__(self, inner, current, figures):
        self._inner, self._current, self._figures = inner, current, figures

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def selects(self, path):
        return getattr(self._inner, "selects", lambda p: True)(path)

    def submit(self, jobs):
        import io
        import pickle

        from hammerstein.report.figures import save

        checks = _figure_checks()
        record = self._figures.setdefault(self._current["path"], CheckedFigures())
        for job in jobs:
            copy = pickle.loads(pickle.dumps(job))    # as a pool worker receives it
            record.names.append(copy.path.name)
            try:
                fig = copy.function(*copy.args, **copy.kwargs)
                buffer = io.BytesIO()
                save(fig, buffer)                       # drawn: the limits are final
                record.problems += checks.figure_problems(fig, copy.path.name)
                buffer.seek(0)
                record.problems += [f"{copy.path.name}: {p}"
                                    for p in checks.png_problems(buffer)]
            except Exception as exc:  # the problem is the message
                record.problems.append(f"{copy.path.name}: drawing it raised {exc!r}")
        return self._inner.submit(jobs)


@pytest.fixture(scope="session")
def bundled_reports(tmp_path_factory):
    """``hammerstein run`` of every bundled scenario into one directory (see above).

    Returns
    -------
    BundledReports
    """
    import hammerstein.runner as runner
    from hammerstein.cli.main import main

    out = tmp_path_factory.mktemp("reports")
    current, figures = {"path": None}, {}
    made, started = runner.FigureRenderer, runner.start_scenario

    def renderer(*args, **kwargs):
        return _CheckingTee(made(*args, **kwargs), current, figures)

    def start(path, *args, **kwargs):          # the figure jobs a scenario hands over are
        current["path"] = Path(path).resolve()  # submitted while it starts
        return started(path, *args, **kwargs)

    runner.FigureRenderer, runner.start_scenario = renderer, start
    try:
        status = main(["run", *map(str, BUNDLED), "--out", str(out)])
    finally:
        runner.FigureRenderer, runner.start_scenario = made, started
    return BundledReports(list(BUNDLED), out, status, figures)
