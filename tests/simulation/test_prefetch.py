"""The chain kernel compiled ahead in a helper process (``prefetch``).

What makes it work is that the helper compiles the *same* signature the
runs use: checked here on the types numba gives to the arguments of every
chain run (plain, iterated, low-pass, pre-filtered Hammerstein, with and
without a plant, through a scenario), then end to end on an empty cache
(slow: it compiles).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest

from hammerstein import (HammersteinCompensator, InverseMultiplicativeCompensator, load_plant,
                         simulate_chain)
from hammerstein.cli import main as cli_main
from hammerstein.simulation import _compile
from hammerstein.simulation import _kernels as kernels
from hammerstein.simulation._prefetch import chain_kernel_arguments

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.filterwarnings("ignore::hammerstein.exceptions.RangeWarning")


@pytest.fixture
def chain_calls(monkeypatch):
    """The arguments of every chain_kernel call made in the test."""
    calls, real = [], kernels.chain_kernel

    def recorder(*args):
        calls.append(args)
        return real(*args)
    monkeypatch.setattr(kernels, "chain_kernel", recorder)
    return calls


def _types(args):
    return tuple(numba.typeof(a) for a in args)


def _compensators(plant):
    model, dyn = plant.hysteresis, plant.dynamics
    return {
        "delay": InverseMultiplicativeCompensator(model, check="ignore"),
        "iterations": InverseMultiplicativeCompensator(model, iterations=3, check="ignore"),
        "lowpass": InverseMultiplicativeCompensator(model, check="ignore", feedback="lowpass",
                                                    cutoff_hz=500.0,
                                                    sampling_period=plant.sampling_period),
        "hammerstein": HammersteinCompensator(model, dyn, check="ignore"),
        "hammerstein-stable": HammersteinCompensator(model, dyn, inversion="stable",
                                                     check="ignore"),
    }


@pytest.mark.parametrize("kind", ["delay", "iterations", "lowpass", "hammerstein",
                                  "hammerstein-stable"])
@pytest.mark.parametrize("with_plant", [False, True])
def test_the_helper_compiles_the_signature_of_every_chain_run(chain_calls, kind, with_plant):
    plant = load_plant("rakotondrabe-2dof")
    comp = _compensators(plant)[kind]
    t = np.arange(400) * plant.sampling_period
    yr = 10.0 * np.vstack([np.sin(2 * np.pi * 50 * t), np.cos(2 * np.pi * 50 * t)])
    if with_plant:
        if kind.startswith("hammerstein"):
            comp.run_reference(plant, yr, period_samples=400, fade_samples=200)
        else:
            simulate_chain(comp, plant, yr)
    else:
        comp.simulate(yr)
    assert chain_calls, "the run did not go through the chain kernel"
    expected = _types(chain_kernel_arguments())
    # the helper compiles the kernel without pre-filter and closed-form law (plan and slopes,
    # arguments 4 and 5, None), as the default run calls it; the ZPETC law passes its
    # pre-filter's plan, a 2 x 2 law with 3 iterations its closed-form table: the other
    # specialisations, compiled on their first use. Every other argument is typed as the
    # helper's.
    prefiltered = kind == "hammerstein"
    closed = kind in ("iterations", "hammerstein", "hammerstein-stable")
    for args in chain_calls:
        got = _types(args)
        assert got[:4] + got[6:] == expected[:4] + expected[6:]
        assert (got[4] != expected[4]) == prefiltered
        if prefiltered:
            assert isinstance(args[4], tuple) and len(args[4]) == 13
        assert got[5] == (numba.typeof(np.zeros((2, 3))) if closed else expected[5])
        if kind == "hammerstein":    # the helper's other variant, chosen for such scenarios
            assert got == _types(chain_kernel_arguments("hammerstein"))


@pytest.mark.parametrize("name, hammerstein", [
    ("default.toml", False), ("hammerstein-trajectories.toml", True),
    ("hammerstein-robustness.toml", True)])
def test_the_cli_asks_the_helper_for_the_hammerstein_kernel_when_a_scenario_names_the_kind(
        name, hammerstein):
    assert cli_main._mentions_hammerstein(str(ROOT / "scenarios" / name)) is hammerstein


def test_the_hint_reads_no_further_than_its_limit_and_never_fails(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("x" * 100 + '\n[compensator]\nkind = "hammerstein"\n', encoding="utf-8")
    assert cli_main._mentions_hammerstein(str(path))
    assert not cli_main._mentions_hammerstein(str(path), limit=100)
    assert not cli_main._mentions_hammerstein(str(tmp_path / "absent.toml"))
    assert not cli_main._mentions_hammerstein(str(tmp_path))          # a directory


def test_the_helper_compiles_the_signature_of_a_scenario_run(chain_calls, tmp_path):
    # through the scenario engine: identifications (cached or not), the default scenario
    assert cli_main.main(["run", str(ROOT / "scenarios" / "default.toml"), "--out",
                          str(tmp_path / "r"), "--figures", "none", "-q"]) == 0
    assert chain_calls
    expected = _types(chain_kernel_arguments())
    assert {_types(args) for args in chain_calls} == {expected}


def test_no_helper_when_the_kernel_is_compiled_or_cached():
    _compile._stop_prefetch()            # a helper an earlier in-process run left (cold cache)
    kernels.chain_kernel(*chain_kernel_arguments())          # compiled (or loaded) here
    assert _compile.prefetch() is False
    assert _compile._PREFETCH["process"] is None
    _compile.await_prefetch()                                # nothing to wait for


@pytest.mark.parametrize("argv, started", [
    (["run", "scenarios/default.toml"], ["default"]),
    (["check", "scenarios/default.toml", "--baseline", "b.csv"], ["default"]),
    (["run", "scenarios/default.toml", "scenarios/hammerstein-robustness.toml"], ["hammerstein"]),
    (["run", "missing.toml"], []),                 # nothing to run: no helper
    (["run", "scenarios/default.toml", "--help"], []),
    (["validate", "scenarios/default.toml"], []),  # simulates nothing
    (["list"], []),
])
def test_the_cli_starts_the_helper_only_for_runs_of_existing_files(monkeypatch, argv, started):
    monkeypatch.chdir(ROOT)
    calls = []
    monkeypatch.setattr(_compile, "prefetch", lambda variant: calls.append(variant) or False)
    cli_main._prefetch_kernels(cli_main._command(argv), argv)
    assert calls == started


def test_a_helper_still_running_at_exit_is_stopped(monkeypatch):
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    monkeypatch.setitem(_compile._PREFETCH, "process", sleeper)
    _compile._stop_prefetch()
    assert sleeper.poll() is not None
    assert _compile._PREFETCH["process"] is None


def test_a_helper_that_fails_leaves_the_run_to_compile(monkeypatch):
    failing = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    monkeypatch.setitem(_compile._PREFETCH, "process", failing)
    _compile.await_prefetch()
    assert failing.returncode == 3 and _compile._PREFETCH["process"] is None
    plant = load_plant("rakotondrabe-2dof", dynamics=False)
    yr = np.zeros((2, 10))
    res = simulate_chain(InverseMultiplicativeCompensator(plant.hysteresis, check="ignore"),
                         plant, yr)
    assert not res.diverged


@pytest.mark.slow
def test_on_an_empty_cache_the_run_loads_the_kernel_the_helper_compiled(tmp_path):
    script = textwrap.dedent("""
        import sys
        import numpy as np
        from numba.core.event import install_recorder
        from hammerstein import InverseMultiplicativeCompensator, load_plant, simulate_chain
        from hammerstein.simulation import _compile, _kernels
        assert _compile.prefetch() is True
        assert _compile.prefetch() is False              # one helper per process
        with install_recorder("numba:compile") as rec:
            plant = load_plant("rakotondrabe-2dof")
            comp = InverseMultiplicativeCompensator(plant.hysteresis, check="ignore")
            res = simulate_chain(comp, plant, np.zeros((2, 50)))
        compiled = {ev.data["dispatcher"].py_func.__name__ for _, ev in rec.buffer}
        assert "chain_kernel" not in compiled, compiled
        assert "plant_kernel" not in compiled, compiled  # not run by a chain
        assert not res.diverged
        print("ok")
    """)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]
    # the CLI: one notice on stderr, the report written, nothing else said
    proc = subprocess.run([sys.executable, "-m", "hammerstein", "run", "scenarios/default.toml",
                           "--out", str(tmp_path / "r")], cwd=ROOT, capture_output=True,
                          text=True, timeout=600,
                          env=dict(env, NUMBA_CACHE_DIR=str(tmp_path / "numba2"),
                                   HAMMERSTEIN_CACHE_DIR=str(tmp_path / "h")))
    assert proc.returncode == 0, proc.stderr[-2000:]
    notices = [line for line in proc.stderr.splitlines() if line.startswith("compiling")]
    assert notices == ["compiling the simulation kernels once, about 4 s "
                       "(numba caches them for later runs)"]
    assert (tmp_path / "r" / "default" / "metrics.csv").is_file()


def test_a_helper_whose_parent_has_gone_compiles_nothing(tmp_path):
    # the pid given (1) is not its parent's: it stops before compiling (exit 1, cache untouched)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    proc = subprocess.run([sys.executable, "-m", "hammerstein.simulation._prefetch", "1"],
                          env=env, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert not (tmp_path / "numba").exists() or not any((tmp_path / "numba").rglob("*.nbi"))


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_a_run_killed_by_sigkill_leaves_no_helper(tmp_path):
    import signal
    import time
    script = ("import time\nfrom hammerstein.simulation import _compile\n"
              "assert _compile.prefetch()\nprint(_compile._PREFETCH['process'].pid, flush=True)\n"
              "time.sleep(60)\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    parent = subprocess.Popen([sys.executable, "-c", script], env=env, stdout=subprocess.PIPE,
                              text=True)
    helper = int(parent.stdout.readline())
    time.sleep(1.5)             # the helper has imported numba and is compiling
    parent.send_signal(signal.SIGKILL)
    parent.wait(timeout=20)
    # gone at once: compiling takes it 4-5 s, so alive after 2 s means it outlived the run
    deadline = time.monotonic() + 2
    while time.monotonic() < deadline and Path(f"/proc/{helper}").exists() \
            and " Z " not in Path(f"/proc/{helper}/stat").read_text():
        time.sleep(0.05)
    alive = Path(f"/proc/{helper}").exists() and " Z " not in Path(f"/proc/{helper}/stat").read_text()
    assert not alive


def test_the_helper_is_announced_when_the_run_waits_for_it(monkeypatch):
    # announced as the front end started, a run that stopped on its file's first problem
    # was told "compiling the simulation kernels once, about 8 s" on every try
    told = []
    helper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(0.5)"])
    monkeypatch.setitem(_compile._PREFETCH, "process", helper)
    monkeypatch.setitem(_compile._PREFETCH, "estimate", 7.6)
    try:
        _compile.announce_compiles(told.append)
        assert told == []
        _compile.await_prefetch()
        assert told == ["compiling the simulation kernels once, about 8 s "
                        "(numba caches them for later runs)"]
        assert helper.returncode == 0 and _compile._PREFETCH["process"] is None
        _compile.await_prefetch()             # nothing to wait for: nothing said
        assert len(told) == 1
    finally:
        _compile.announce_compiles(None)


def test_a_run_that_stops_on_its_file_says_nothing_of_compiling(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[plant]\npreset = "rakotondrabe-2dof"\n[[cases]]\nname = "c"\n'
                   'reference = { kind = "circel", radius = 5.0, frequency = 10.0 }\n')
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               HAMMERSTEIN_CACHE_DIR=str(tmp_path / "h"))
    proc = subprocess.run([sys.executable, "-m", "hammerstein", "run", str(bad), "--out",
                           str(tmp_path / "r")], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, env=env)
    assert proc.returncode == 1
    assert proc.stderr.splitlines() == [
        next(ln for ln in proc.stderr.splitlines() if "reference.kind" in ln)], proc.stderr
