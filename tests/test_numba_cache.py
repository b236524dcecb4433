"""numba's compiled kernels go to the user's cache directory, never the source tree."""

import os
import subprocess
import sys
from pathlib import Path

from hammerstein._cache import numba_cache_dir

ROOT = Path(__file__).resolve().parents[1]


def test_default_is_the_users_cache_directory(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert numba_cache_dir() == str(tmp_path / ".cache" / "hammerstein" / "numba")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert numba_cache_dir() == str(tmp_path / "xdg" / "hammerstein" / "numba")
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/not/allowed")
    assert numba_cache_dir() == str(tmp_path / ".cache" / "hammerstein" / "numba")


def test_the_users_own_setting_wins(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert numba_cache_dir() == str(tmp_path / "mine")


def test_loading_the_kernels_sets_numba_to_the_user_cache(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env["HOME"] = str(tmp_path)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    code = ("import hammerstein.simulation, numba.core.config as c; print(c.CACHE_DIR)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=120, check=True).stdout.strip()
    assert out == str(tmp_path / ".cache" / "hammerstein" / "numba")


def test_every_command_sets_numba_to_the_user_cache_before_its_module_loads_numba(tmp_path):
    # warmup's module imports numba at its top, before hammerstein.simulation: numba read
    # NUMBA_CACHE_DIR unset and cached the kernels in the package's __pycache__, which later
    # runs (with the user's cache) never saw
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env["HOME"] = str(tmp_path)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    code = ("import contextlib, io\n"
            "from hammerstein.cli.main import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    main(['warmup', '--help'])\n"
            "import numba.core.config as c; print(c.CACHE_DIR)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=120, check=True).stdout.strip()
    assert out == str(tmp_path / ".cache" / "hammerstein" / "numba")


def test_commands_other_than_run_and_check_announce_a_compilation():
    # compensate on a cold cache waited 10 s without a word; run, check and warmup say it
    # their own way (-q / -v, per workload)
    import hammerstein.simulation  # noqa: F401  (the kernels loaded, as by any such command)
    from hammerstein.cli import main as cli_main
    from hammerstein.simulation import _compile
    try:
        for command, announced in (("compensate", True), ("learn", True), ("run", False),
                                   ("warmup", False)):
            _compile.announce_compiles(None)
            cli_main._announce_compiles(command)
            assert (_compile._PROCESS["listener"] is not None) == announced, command
    finally:
        _compile.announce_compiles(None)
