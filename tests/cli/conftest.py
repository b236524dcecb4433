"""``forked_cli``: the process-level CLI tests' ``python -m hammerstein`` runs, in one go.

Each job below is a separate process (a forked child of ``forked_cli.py``,
which imports the numerical stack once instead of once per process: about
1-2 s of CPU saved per process); the tests look their result up by name.
"""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hammerstein.runner import TMP_PREFIX

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
GOOD = HERE.parent / "corpus" / "good"
SCENARIOS = HERE.parent / "corpus" / "scenarios"

#: Commands of the closed-stdio test (tests/cli/test_issue22.py::test_10_closed_stdio...).
CLOSED_STDIO_ARGV = {"validate": ["validate", str(GOOD / "good-static.toml")], "list": ["list"],
                     "version": ["--version"]}

#: Commands of tests/cli/test_cli.py::test_console_script_keeps_status_and_output.
CONSOLE_ARGV = {"validate-ok": ["validate", "scenarios/default.toml"],
                "validate-missing": ["validate", "no-such-file.toml"],
                "usage": ["run"]}

#: Processes updating one baseline at the same time (test_issue22.py::test_3_...).
CONCURRENT_UPDATES = 2


def _jobs(tmp):
    jobs = {}
    for name, argv in CLOSED_STDIO_ARGV.items():
        for stream in ("stdout", "stderr"):
            jobs[f"closed-{stream}-{name}"] = {"argv": argv, stream: "closed"}
    jobs["full-stdout"] = {"argv": ["validate", str(GOOD / "good-static.toml")], "stdout": "full"}
    for name, argv in CONSOLE_ARGV.items():
        jobs[f"console-{name}"] = {"argv": argv, "cwd": str(ROOT)}
    jobs["list-head"] = {"argv": ["list"], "stdout": "head", "cwd": str(ROOT)}
    good = (GOOD / "good-static.toml").read_text()
    for i in range(CONCURRENT_UPDATES):
        scen = tmp / f"c{i}.toml"
        scen.write_text(good.replace('name = "good-static"', f'name = "c{i}"', 1))
        jobs[f"update-{i}"] = {"argv": ["check", str(scen), "--baseline", str(tmp / "base.csv"),
                                        "--update", "-q"], "group": "updates"}
    jobs["real-stderr"] = {
        "argv": ["run", str(GOOD / "good-static-2.toml"),
                 str(SCENARIOS / "unknown-reference-key.toml"),
                 str(GOOD / "warn-out-of-range.toml"), "--out", str(tmp / "real-stderr"),
                 "--figures", "none"],
        "warnings": "default"}
    # signals once a report is in progress (test_issue22.py::test_8_*, test_reliability.py)
    for name, sig, scenarios, workers in (("sighup", signal.SIGHUP, [GOOD / "good-static.toml"], False),
                                          ("sigterm", signal.SIGTERM, [GOOD / "good-static.toml"], False),
                                          ("sigkill-workers", signal.SIGKILL,
                                           [GOOD / "good-static.toml", GOOD / "good-static-2.toml"], True)):
        out = tmp / name
        jobs[name] = {"argv": ["run", *map(str, scenarios), "--out", str(out)], "signal": int(sig),
                      "out": str(out), "prefix": TMP_PREFIX, "workers": workers}
    # started under nohup (SIGHUP ignored): the hang-up does not interrupt the run
    out = tmp / "sighup-nohup"
    jobs["sighup-nohup"] = {"argv": ["run", str(GOOD / "good-static.toml"), "--out", str(out),
                                     "--figures", "none"],
                            "signal": int(signal.SIGHUP), "ignored": True, "out": str(out),
                            "prefix": TMP_PREFIX, "workers": False}
    return jobs


@pytest.hookimpl(tryfirst=True)      # before ``-m`` deselects by the marks
def pytest_collection_modifyitems(config, items):
    """The tests of real ``python -m hammerstein`` processes (signals, closed and full
    standard streams, concurrent runs: :func:`forked_cli`) are slow end-to-end runs,
    about 3 s of CPU per xdist worker for the fixture alone: marked ``slow``, run by
    ``.ci/run`` on one worker (``tests/conftest.py``'s ``XDIST_GROUPS``)."""
    for item in items:
        if "forked_cli" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def forked_cli(tmp_path_factory):
    """Results of the jobs of :func:`_jobs`, by name: ``(dict(status, stdout, stderr), tmp)``."""
    if not hasattr(os, "fork"):
        pytest.skip("needs os.fork (the processes are forked children of one interpreter)")
    tmp = tmp_path_factory.mktemp("forked-cli")
    jobs = _jobs(tmp)
    names = list(jobs)
    res = subprocess.run([sys.executable, str(HERE / "forked_cli.py")],
                         input=json.dumps([jobs[n] for n in names]), capture_output=True,
                         text=True, timeout=600, cwd=ROOT)
    assert res.returncode == 0, res.stderr
    results = json.loads(res.stdout.strip().splitlines()[-1])
    return dict(zip(names, results)), tmp
