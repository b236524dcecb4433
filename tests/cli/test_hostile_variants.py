"""Variants of the hostile property test (issue 22, item 8): the generated scenarios of
``test_hostile_properties`` run concurrently on one directory, with closed
stdout/stderr, on a full disk, and as a non-root user.

Asserted for every generated file, as in the property test: exit status 0,
1 or 2; no traceback; at most one ``error:`` line per scenario run; no
temporary left behind; nothing pre-existing changed. And per variant:

* concurrent: two runs (threads of one process) on one ``--out`` end as
  they would alone (a report with its marker, or one error line each);
* closed stdio: the exit status is that of the same command with open
  stdio;
* full disk: a failed write is one ``cannot write the report`` line and
  leaves no partial report;
* non-root: with an unwritable home and no ``NUMBA_CACHE_DIR``, validate
  ends as it does for root (skipped where no other user can run this
  interpreter, e.g. a Python installed under a private /root).
"""

import contextlib
import io
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hammerstein.cli.main import main
from hammerstein.runner import MARKER, TMP_PREFIX, run_scenarios
from snapshots import tree_snapshot
from test_hostile_properties import scenario

_SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                       HealthCheck.data_too_large,
                                                       HealthCheck.function_scoped_fixture])


def _temporaries(root):
    return [p for p in Path(root).rglob("*")
            if p.name.startswith(TMP_PREFIX) or p.name.endswith(".hammerstein-tmp")]


def _main_quiet(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main([str(a) for a in argv])
    return status, err.getvalue()


# -- concurrent runs on one directory -------------------------------------------------------
@settings(max_examples=4, **_SETTINGS)
@given(docs=st.lists(scenario(), min_size=2, max_size=2))
def test_concurrent_runs_on_one_directory(docs):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        out = root / "out"
        (out / "someone-else").mkdir(parents=True)
        (out / "someone-else" / "thesis.tex").write_text("precious")
        paths = []
        for i, doc in enumerate(docs):
            p = root / f"s{i}.toml"
            p.write_text(tomli_w.dumps(doc), encoding="utf-8")
            paths.append(p)
        results, crashes = {}, []

        def work(i):
            try:
                results[i] = run_scenarios([paths[i]], out)
            except BaseException as exc:   # pragma: no cover - reported below
                crashes.append(exc)
        threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert crashes == []
        assert (out / "someone-else" / "thesis.tex").read_text() == "precious"
        assert _temporaries(root) == []
        for i in range(2):
            (outcome,) = results[i]
            if outcome.ok:
                assert (outcome.out_dir / MARKER).is_file()
                assert (outcome.out_dir / "metrics.csv").is_file()
            else:
                assert outcome.error and "Traceback" not in outcome.error
                assert "unexpected" not in outcome.error, outcome.error


# -- closed stdout / stderr -------------------------------------------------------------------
def _cli(argv, close=None, **kw):
    def closer():
        if close is not None:
            os.close(close)
    return subprocess.run([sys.executable, "-m", "hammerstein", *map(str, argv)],
                          capture_output=close is None, text=True, timeout=300,
                          preexec_fn=closer, **kw)


@pytest.mark.slow
@settings(max_examples=4, **_SETTINGS)
@given(doc=scenario(), command=st.sampled_from(["validate", "run"]))
def test_closed_stdio_keeps_the_exit_status(doc, command):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "s.toml"
        path.write_text(tomli_w.dumps(doc), encoding="utf-8")
        extra = ["--out", root / "out-open"] if command == "run" else []
        reference = _cli([command, path, *extra])
        assert "Traceback" not in reference.stderr
        for fd in (1, 2):
            extra = ["--out", root / f"out-{fd}"] if command == "run" else []
            proc = _cli([command, path, *extra], close=fd, stdin=subprocess.DEVNULL,
                        stdout=None if fd == 1 else subprocess.DEVNULL,
                        stderr=None if fd == 2 else subprocess.PIPE)
            assert proc.returncode == reference.returncode, (fd, reference.stderr)
        assert _temporaries(root) == []


# -- full disk ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tiny_disk():
    """A 256 KiB tmpfs (root with CAP_SYS_ADMIN only): a report or two fill it."""
    d = Path(tempfile.mkdtemp(prefix="hammerstein-tiny-"))
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs",
                                            str(d)], capture_output=True).returncode:
        os.rmdir(d)
        pytest.skip("a small tmpfs needs root with CAP_SYS_ADMIN")
    yield d
    subprocess.run(["umount", str(d)], capture_output=True)
    os.rmdir(d)


@settings(max_examples=4, **_SETTINGS)
@given(doc=scenario())
def test_full_disk_leaves_no_partial_report(tiny_disk, doc):
    for p in tiny_disk.iterdir():      # each example starts from an empty small disk
        subprocess.run(["rm", "-rf", str(p)], check=True)
    ballast = tiny_disk / "ballast.bin"
    with open(ballast, "wb") as f:     # leave ~24 KiB: the metrics fit, the figures do not
        f.write(b"\0" * (232 * 1024))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_text(tomli_w.dumps(doc), encoding="utf-8")
        out = tiny_disk / "out"
        before = tree_snapshot(tiny_disk)
        status, err = _main_quiet(["run", path, "--out", out])
    lines = err.splitlines()
    assert status in (0, 1, 2) and "Traceback" not in err, lines
    errors = [ln for ln in lines if ln.startswith("error:")]
    assert len(errors) == (status == 1), lines
    assert not [ln for ln in errors if "unexpected" in ln], errors
    assert _temporaries(tiny_disk) == []
    after = tree_snapshot(tiny_disk)
    assert all(after.get(p) == info for p, info in before.items())
    new = [p for p in after if p not in before]
    if status != 0:
        assert [p for p in new if p != out] == [], new      # no partial report
    else:
        reports = [p for p in new if p.parent == out]
        assert all((r / MARKER).is_file() for r in reports if r.is_dir())


# -- non-root -------------------------------------------------------------------------------------
NOBODY = 65534


def _as_nobody(argv, cwd):
    def drop():
        os.setgid(NOBODY)
        os.setuid(NOBODY)
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env["HOME"] = "/nonexistent"
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, timeout=300,
                          preexec_fn=drop, env=env, cwd=cwd)


@pytest.fixture(scope="module")
def nobody_can_run():
    if os.geteuid() != 0:
        pytest.skip("switching to another user needs root")
    try:
        probe = _as_nobody(["-c", "import hammerstein"], "/")
    except PermissionError as exc:   # the interpreter itself (e.g. under a private /root)
        pytest.skip(f"user {NOBODY} cannot run {sys.executable} here ({exc.strerror})")
    if probe.returncode:
        pytest.skip(f"user {NOBODY} cannot run {sys.executable} here "
                    f"({probe.stderr.strip().splitlines()[-1:] or 'permission denied'})")


@pytest.mark.slow
@settings(max_examples=3, **_SETTINGS)
@given(doc=scenario())
def test_non_root_with_unwritable_home(nobody_can_run, doc):
    with tempfile.TemporaryDirectory() as tmp:
        os.chmod(tmp, 0o777)
        path = Path(tmp) / "s.toml"
        path.write_text(tomli_w.dumps(doc), encoding="utf-8")
        os.chmod(path, 0o644)
        root_status, _ = _main_quiet(["validate", path])
        proc = _as_nobody(["-m", "hammerstein", "validate", str(path)], tmp)
        assert "Traceback" not in proc.stderr and "no locator" not in proc.stderr
        assert proc.returncode == root_status, proc.stderr
