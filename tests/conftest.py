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
