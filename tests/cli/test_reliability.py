"""Issue 13: never destroy what the project did not write, stop cleanly, bound every input.

Ownership of report directories (marker, ``--force``), safe single-file
writes (:func:`hammerstein.core.files.safe_write`: exclusive temporary file,
rename, symlink target written, special files refused, permissions kept),
bounded reads, stale temporaries, and SIGINT/SIGTERM through a real
subprocess.
"""

import errno
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.core import files
from hammerstein.core.files import FileLimitError, bounded_read_bytes, limit, safe_write, umask
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.io.presets import PresetError, load_model, save_model
from hammerstein.runner import MARKER, TMP_PREFIX, remove_stale_temporaries
from snapshots import tree_snapshot

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good" / "good-static.toml"
REPO = Path(__file__).resolve().parents[2]
IDENTIFY = [str(CORPUS / "data" / "good.csv"), "--time", "time_s", "--input", "u_V",
            "--output", "y_um", "--thresholds", "5"]


def _call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err.splitlines()


def _model():
    return MultivariablePI([[PrandtlIshlinskii([0.0, 2.0], [1.0, 0.5])]], ["u"], ["y"], [5.0])


# -- ownership of report directories -----------------------------------------------------
@pytest.mark.parametrize("kind", ["user-dir", "file", "symlink-dir", "symlink-dangling"])
def test_run_never_replaces_what_it_did_not_write(capsys, tmp_path, kind):
    out = tmp_path / "out"
    out.mkdir()
    target = out / "good-static"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("mine")
    if kind == "user-dir":
        target.mkdir()
        (target / "thesis.tex").write_text("precious")
    elif kind == "file":
        target.write_text("precious")
    elif kind == "symlink-dir":
        target.symlink_to(elsewhere)
    else:
        target.symlink_to(tmp_path / "nowhere")
    before = tree_snapshot(tmp_path)
    status, out_text, err = _call(capsys, "run", GOOD, "--out", out)
    assert status == 1 and out_text == "" and len(err) == 1
    assert str(target) in err[0] and "--force" in err[0]
    assert tree_snapshot(tmp_path) == before  # byte for byte, no temporary left


def test_run_replaces_its_own_or_empty_directories_and_force(capsys, tmp_path):
    out = tmp_path / "out"
    (out / "good-static").mkdir(parents=True)  # empty: replaced
    assert _call(capsys, "run", GOOD, "--out", out)[0] == 0
    marker = out / "good-static" / MARKER
    assert marker.read_text().startswith("hammerstein ")
    first = os.stat(out / "good-static" / "metrics.csv").st_ino
    # ownership, not figures, is under test from here on: skip drawing them
    assert _call(capsys, "run", GOOD, "--out", out, "--figures", "none")[0] == 0  # marked: replaced
    assert os.stat(out / "good-static" / "metrics.csv").st_ino != first
    marker.unlink()
    assert _call(capsys, "run", GOOD, "--out", out)[0] == 1  # no longer ours
    before = (out / "good-static" / "metrics.csv").read_bytes()
    status, text, _ = _call(capsys, "run", GOOD, "--out", out, "--force", "--figures", "none")
    assert status == 0 and marker.is_file()
    # --force never deletes what hammerstein did not write: the unmarked directory is moved aside
    kept = sorted(p.name for p in out.iterdir() if p.name != "good-static")
    assert len(kept) == 1 and kept[0].startswith("good-static.kept-")
    assert (out / kept[0] / "metrics.csv").read_bytes() == before
    assert f"held files hammerstein did not write or changed: --force moved it to {out / kept[0]}/" in text


def test_run_force_moves_a_users_tree_aside_and_deletes_nothing(capsys, tmp_path):
    """An outside check: ``run --force`` deleted ``out/<scenario>/sub/thesis.tex``, and a user's
    ``notes.txt`` in the project's own report. Both are now moved aside whole, byte for byte."""
    out = tmp_path / "out"
    (out / "good-static" / "sub").mkdir(parents=True)
    (out / "good-static" / "sub" / "thesis.tex").write_text("precious")
    before = {p.relative_to(out / "good-static"): v
              for p, v in tree_snapshot(out / "good-static").items()}
    assert _call(capsys, "run", GOOD, "--out", out, "--force", "--figures", "none")[0] == 0
    kept = [p for p in out.iterdir() if p.name.startswith("good-static.kept-")]
    assert len(kept) == 1
    assert {p.relative_to(kept[0]): v for p, v in tree_snapshot(kept[0]).items()} == before
    (out / "good-static" / "notes.txt").write_text("mine")     # beside the report's own files
    assert _call(capsys, "run", GOOD, "--out", out, "--figures", "none")[0] == 1
    assert _call(capsys, "run", GOOD, "--out", out, "--force", "--figures", "none")[0] == 0
    kept = [p for p in out.iterdir() if p.name.startswith("good-static.kept-")]
    assert len(kept) == 2 and not (out / "good-static" / "notes.txt").exists()
    assert sum((k / "notes.txt").is_file() for k in kept) == 1


@pytest.mark.parametrize("kind", ["file", "symlink"])
def test_run_force_names_what_it_moved_aside(capsys, tmp_path, kind):
    """An outside check: a plain file at ``out/<scenario>`` moved aside by ``--force`` was said
    to have "held files hammerstein did not write". The note says what stood there."""
    out = tmp_path / "out"
    out.mkdir()
    target = out / "good-static"
    if kind == "file":
        target.write_text("precious")
    else:
        target.symlink_to(tmp_path / "nowhere")
    status, text, _ = _call(capsys, "run", GOOD, "--out", out, "--force", "--figures", "none")
    assert status == 0
    kept = [p for p in out.iterdir() if p.name.startswith("good-static.kept-")]
    assert len(kept) == 1 and (kept[0].is_symlink() if kind == "symlink" else
                               kept[0].read_text() == "precious")
    said = "was a symbolic link" if kind == "symlink" else "was a file hammerstein did not write"
    assert f"{said}: --force moved it to {kept[0]} (nothing deleted)" in text
    assert "held files" not in text


def test_run_keeps_a_report_file_edited_since_it_was_written(capsys, tmp_path):
    """The report's marker listed names only: ``report.md`` annotated by hand was replaced by
    the next ``run``. The marker keeps each file's SHA-256: the edited report stops ``run``
    (one line naming it); ``--force`` moves the directory aside with the notes in it."""
    out = tmp_path / "out"
    assert _call(capsys, "run", GOOD, "--out", out, "--figures", "none")[0] == 0
    marker = (out / "good-static" / MARKER).read_text()
    assert "sha256 " in marker and " metrics.csv\n" in marker
    assert _call(capsys, "run", GOOD, "--out", out, "--figures", "none")[0] == 0   # unchanged
    report = out / "good-static" / "report.md"
    report.write_text(report.read_text() + "\nmy notes\n")
    before = tree_snapshot(tmp_path)
    status, text, err = _call(capsys, "run", GOOD, "--out", out, "--figures", "none")
    assert status == 1 and text == "" and len(err) == 1
    assert "report.md (changed)" in err[0] and "changed since it wrote them" in err[0]
    assert tree_snapshot(tmp_path) == before
    assert _call(capsys, "run", GOOD, "--out", out, "--force", "--figures", "none")[0] == 0
    kept = [p for p in out.iterdir() if p.name.startswith("good-static.kept-")]
    assert len(kept) == 1 and (kept[0] / "report.md").read_text().endswith("my notes\n")


def test_report_directories_get_umask_permissions(capsys, tmp_path):
    assert _call(capsys, "run", GOOD, "--out", tmp_path, "--figures", "none")[0] == 0
    mode = stat.S_IMODE(os.stat(tmp_path / "good-static").st_mode)
    assert mode == 0o777 & ~umask()


def test_out_dir_problems_are_usage_errors(capsys, tmp_path):
    f = tmp_path / "f"
    f.write_text("x")
    for out in ("", f, f / "sub"):
        status, _, err = _call(capsys, "run", GOOD, "--out", out)
        assert status == 2 and len(err) == 1 and err[0].startswith("hammerstein run: error: --out:")
    assert f.read_text() == "x" and sorted(p.name for p in tmp_path.iterdir()) == ["f"]


#: each command's arguments but --out (its inputs need not exist: --out is checked first)
_COMMAND_ARGS = {"compensate": ["rakotondrabe-2dof", "--reference",
                                '{ kind = "circle", radius = 30, frequency = 100, periods = 20 }'],
                 "learn": ["rakotondrabe-2dof", "--reference", "r.csv", "--drive", "d.csv",
                           "--measured", "m.csv"],
                 "identify": ["r.csv", "--input", "1", "--output", "2", "--time", "0"],
                 "run": [str(GOOD)],
                 "excitation": ["--inputs", "ux", "--amplitude", "10", "--sampling-period",
                                "5e-5"]}


@pytest.mark.parametrize("command", ["compensate", "learn", "identify", "run", "excitation"])
def test_out_dash_is_not_a_file_named_dash(capsys, tmp_path, monkeypatch, command):
    # `compensate ... --out -` wrote a file named '-' (by convention, '-' is stdout)
    monkeypatch.chdir(tmp_path)
    status, _, err = _call(capsys, command, *_COMMAND_ARGS[command], "--out", "-")
    assert status == 2 and len(err) == 1 and "--out: '-' (standard output)" in err[0]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["compensate", "learn", "identify"])
def test_a_single_file_output_named_like_a_directory_is_refused(capsys, tmp_path, monkeypatch,
                                                                 command):
    # `compensate ... --out newdir/` wrote a regular file named newdir and said 'wrote newdir/'
    monkeypatch.chdir(tmp_path)
    status, _, err = _call(capsys, command, *_COMMAND_ARGS[command], "--out", "newdir/")
    assert status == 2 and len(err) == 1 and "newdir/ ends with a separator" in err[0]
    assert list(tmp_path.iterdir()) == []


# -- single files: safe_write ---------------------------------------------------------------
def test_safe_write_writes_a_symlinks_target_and_keeps_permissions(tmp_path):
    real = tmp_path / "real.toml"
    real.write_text("old")
    os.chmod(real, 0o640)
    link = tmp_path / "link.toml"
    link.symlink_to(real)
    user_tmp = tmp_path / "link.toml.tmp"
    user_tmp.write_text("the user's own")
    assert safe_write(link, b"new") == real
    assert link.is_symlink() and real.read_text() == "new"
    assert stat.S_IMODE(os.stat(real).st_mode) == 0o640
    assert user_tmp.read_text() == "the user's own"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.toml", "link.toml.tmp", "real.toml"]
    fresh = safe_write(tmp_path / "sub" / "new.toml", "x")
    assert stat.S_IMODE(os.stat(fresh).st_mode) == 0o666 & ~umask()


@pytest.mark.parametrize("special", ["/dev/null", "fifo", "dir"])
def test_safe_write_refuses_special_targets(tmp_path, special):
    if special == "fifo":
        target = tmp_path / "fifo"
        os.mkfifo(target)
    elif special == "dir":
        target = tmp_path / "d"
        target.mkdir()
    else:
        target = Path(special)
    with pytest.raises(FileLimitError, match="expected a file to replace"):
        safe_write(target, b"x")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    if special == "/dev/null":
        assert stat.S_ISCHR(os.stat(target).st_mode)


def test_safe_write_leaves_the_target_when_the_writer_fails(tmp_path):
    target = tmp_path / "b.csv"
    target.write_text("old")

    def writer(fh):
        fh.write(b"half")
        raise RuntimeError("disk full")
    with pytest.raises(RuntimeError):
        safe_write(target, writer)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["b.csv"]


def test_save_model_round_trip_through_a_symlink(tmp_path):
    real = tmp_path / "m.toml"
    real.write_text("")
    (tmp_path / "l.toml").symlink_to(real)
    save_model(_model(), tmp_path / "l.toml")
    assert load_model(real).input_names == ["u"] and (tmp_path / "l.toml").is_symlink()
    with pytest.raises(PresetError, match="is a directory"):
        save_model(_model(), tmp_path)


def test_identify_writes_a_symlinks_target_and_keeps_its_mode(capsys, tmp_path):
    real = tmp_path / "real.toml"
    save_model(_model(), real)  # a model file: identify may replace it
    os.chmod(real, 0o600)
    (tmp_path / "m.toml").symlink_to(real)
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--out", tmp_path / "m.toml")
    assert (status, err) == (0, [])
    assert (tmp_path / "m.toml").is_symlink() and "u_V" in real.read_text()
    assert stat.S_IMODE(os.stat(real).st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml", "real.toml"]


def test_check_update_keeps_the_baselines_permissions(capsys, tmp_path):
    baseline = tmp_path / "b.csv"
    assert _call(capsys, "check", CORPUS / "good" / "good-static-2.toml", "--baseline", baseline,
                 "--update")[0] == 0
    os.chmod(baseline, 0o604)
    assert _call(capsys, "check", CORPUS / "good" / "good-static-2.toml", "--baseline", baseline,
                 "--update")[0] == 0
    assert stat.S_IMODE(os.stat(baseline).st_mode) == 0o604
    assert [p.name for p in tmp_path.iterdir()] == ["b.csv"]


# -- bounded reads ----------------------------------------------------------------------------
def test_reads_are_bounded(tmp_path, monkeypatch):
    big = tmp_path / "big.toml"
    big.write_bytes(b"# " + b"x" * 2000 + b"\n")
    monkeypatch.setenv("HAMMERSTEIN_MAX_TOML_BYTES", "1000")
    assert limit("toml") == 1000
    with pytest.raises(FileLimitError, match="larger than the limit of 1000 bytes.*"
                                             "HAMMERSTEIN_MAX_TOML_BYTES"):
        bounded_read_bytes(big)
    monkeypatch.setenv("HAMMERSTEIN_MAX_TOML_BYTES", "junk")
    assert limit("toml") == 4 * 2**20 and bounded_read_bytes(big) == big.read_bytes()
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(FileLimitError, match="not a regular file"):
        bounded_read_bytes(fifo)  # and it does not block waiting for a writer


@pytest.mark.parametrize("command", ["run", "validate"])
def test_special_scenario_files_fail_at_once(capsys, tmp_path, command):
    fifo = tmp_path / "s.toml"
    os.mkfifo(fifo)
    extra = ["--out", tmp_path / "out"] if command == "run" else []
    for path in ("/dev/zero", fifo, tmp_path):
        status, _, err = _call(capsys, command, path, *extra)
        assert status == 1 and len(err) == 1 and f"{path}: " in err[0]
        assert "not a regular file" in err[0] or "is a directory" in err[0]
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())


def test_data_file_limit_is_overridable(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", "100")
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--out", tmp_path / "m.toml")
    assert status == 1 and "HAMMERSTEIN_MAX_DATA_BYTES" in err[0]
    assert not (tmp_path / "m.toml").exists()


# -- stale temporaries ----------------------------------------------------------------------------
def _dead_pid():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_stale_temporaries_of_killed_runs_are_removed_and_nothing_else(tmp_path):
    old = time.time() - 3600
    stale = tmp_path / f"{TMP_PREFIX}{_dead_pid()}.abc"
    stale.mkdir()
    (stale / MARKER).write_text("hammerstein")
    (stale / "metrics.csv").write_text("x")
    os.utime(stale / MARKER, (old, old))
    unmarked = tmp_path / f"{TMP_PREFIX}{_dead_pid()}.def"  # not ours: no marker, not empty
    unmarked.mkdir()
    (unmarked / "notes.txt").write_text("mine")
    empty = tmp_path / f"{TMP_PREFIX}{_dead_pid()}.xyz"  # killed before the marker: empty
    empty.mkdir()
    os.utime(empty, (old, old))
    alive = tmp_path / f"{TMP_PREFIX}{os.getppid()}.ghi"   # a live process: still working
    alive.mkdir()
    (alive / MARKER).write_text("hammerstein")
    os.utime(alive / MARKER, (old, old))
    fresh = tmp_path / f"{TMP_PREFIX}{_dead_pid()}.jkl"     # newer than the run
    fresh.mkdir()
    (fresh / MARKER).write_text("hammerstein")
    user = tmp_path / ".hammerstein-tmp.notes"
    user.write_text("mine")
    removed = remove_stale_temporaries(tmp_path, before=time.time() - 60)
    assert sorted(removed) == sorted([stale, empty])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        p.name for p in (unmarked, alive, fresh, user))


# -- interruption through a real process ------------------------------------------------------------
def _interrupt(tmp_path, sig, argv, marked=False):
    """Run a command and send it ``sig`` once its temporary report exists (with ``marked``:
    once that temporary holds its owner marker, i.e. the run is writing its report)."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "hammerstein", *map(str, argv), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:  # wait for the report in progress
        tmps = [p for p in out.iterdir() if p.name.startswith(TMP_PREFIX)] if out.is_dir() else []
        if tmps and (not marked or any((p / ".hammerstein-report").is_file() for p in tmps)):
            break
        time.sleep(0.005)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    return proc.returncode, stdout, stderr, out


def test_sigterm_ends_the_run_in_one_line(forked_cli):
    # a `python -m hammerstein run` process (tests/cli/conftest.py) sent SIGTERM while its
    # report is being written
    results, tmp = forked_cli
    run = results["sigterm"]
    if not run["signalled"]:
        pytest.skip("the run finished before the signal arrived")
    assert run["status"] == 143 and run["stderr"] == "interrupted\n", run["stderr"]
    assert not [p for p in (tmp / "sigterm").iterdir() if p.name.startswith(TMP_PREFIX)]


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_ends_the_run_in_one_line(tmp_path, sig, code):
    status, stdout, stderr, out = _interrupt(tmp_path, sig, ["run", GOOD])
    if status == 0:
        pytest.skip("the run finished before the signal arrived")
    assert status == code and stderr == "interrupted\n", stderr
    assert not [p for p in out.iterdir() if p.name.startswith(TMP_PREFIX)]


@pytest.mark.slow
def test_sigkill_leaves_a_temporary_that_the_next_run_removes(tmp_path):
    # killed once its report is being written (an unmarked, empty temporary of a process killed
    # between mkdtemp and its marker is left for EMPTY_GRACE seconds: it may be another's)
    status, _, _, out = _interrupt(tmp_path, signal.SIGKILL, ["run", GOOD], marked=True)
    assert status == -signal.SIGKILL
    left = [p for p in out.iterdir() if p.name.startswith(TMP_PREFIX)]
    assert left  # killed while writing: nothing could clean up
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.run([sys.executable, "-m", "hammerstein", "run", str(GOOD), "--out", str(out)],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in out.iterdir()) == ["good-static"]


def test_an_error_a_signal_caused_is_reported_as_the_interruption(capsys, monkeypatch):
    # a signal that cut an import short left a half-initialised module: the ImportError (in
    # the parser's imports, outside the handler's try) or AttributeError (inside a scenario)
    # that follows printed a traceback, or blamed the scenario with exit 1
    from hammerstein.cli import main as cli_main
    from hammerstein.core import files

    def cut_import(command=None):
        files._CRITICAL["received"] = signal.SIGINT
        raise ImportError("cannot import name 'identify_records'")

    monkeypatch.setattr(cli_main, "build_parser", cut_import)
    assert main(["run", str(GOOD)]) == 130
    out, err = capsys.readouterr()
    assert err == "interrupted\n" and out == ""
    # without a signal the same error is a bug, said in one line
    monkeypatch.setattr(cli_main, "build_parser",
                        lambda command=None: (_ for _ in ()).throw(ImportError("x")))
    with pytest.raises(ImportError):
        main(["run", str(GOOD)])


def test_a_scenario_error_after_a_signal_ends_the_run_as_interrupted(capsys, monkeypatch,
                                                                     tmp_path):
    from hammerstein import runner
    from hammerstein.core import files

    def half_imported(*args, **kwargs):
        files._CRITICAL["received"] = signal.SIGTERM
        raise AttributeError("module 'scipy.linalg' has no attribute 'expm'")

    monkeypatch.setattr(runner.SCENARIO_KINDS["cases"], "simulate", half_imported)
    assert main(["run", str(GOOD), "--out", str(tmp_path / "r")]) == 143
    assert capsys.readouterr().err == "interrupted\n"


def test_an_interruption_python_cannot_raise_is_not_printed():
    # a signal handled in a finaliser: "Exception ignored in ... _Interrupted: 2" and a traceback
    from hammerstein.cli.main import _quiet_interrupt_hook
    from hammerstein.core.files import _Interrupted
    seen = []
    hook = _quiet_interrupt_hook(seen.append)
    hook(SimpleNamespace(exc_value=_Interrupted(2)))
    other = SimpleNamespace(exc_value=ValueError("kept"))
    hook(other)
    assert seen == [other]


@pytest.mark.slow
def test_ctrl_c_during_the_start_up_imports_is_one_line(tmp_path):
    # SIGINT at 0.2..2 s after the start of `run` lands in the imports, the parser, the first
    # scenario: always "interrupted" (exit 130) or a finished run, never a traceback or exit 1
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    for k, delay in enumerate(np.linspace(0.2, 2.0, 10)):
        p = subprocess.Popen([sys.executable, "-m", "hammerstein", "run", str(GOOD), "--out",
                              str(tmp_path / f"r{k}")], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True, env=env)
        time.sleep(delay)
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=120)
        assert (p.returncode, err) == (130, "interrupted\n") or p.returncode == 0, (delay, err)


@pytest.mark.slow  # a process whose stdout reader goes away
def test_a_stdout_reader_that_goes_away_does_not_change_the_exit_status(tmp_path):
    # `hammerstein run ... | head -c 0` under `set -o pipefail`: exit 1 and no word, though the
    # report was written (and with several scenarios, the later ones were never run)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = tmp_path / "r"
    second = GOOD.with_name("good-static-2.toml")
    script = (f'set -o pipefail; "{sys.executable}" -m hammerstein run "{GOOD}" "{second}" '
              f'--out "{out}" | head -c 0')
    run = subprocess.run(["bash", "-c", script], capture_output=True, text=True, env=env,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr and "BrokenPipe" not in run.stderr
    assert (out / "good-static" / "report.md").is_file()
    assert len([p for p in out.iterdir() if (p / "report.md").is_file()]) == 2   # both ran
    lst = subprocess.run(["bash", "-c", f'set -o pipefail; "{sys.executable}" -m hammerstein '
                                        f'list | head -1'],
                         capture_output=True, text=True, env=env, timeout=300)
    assert (lst.returncode, lst.stdout, lst.stderr) == (0, "presets:\n", "")


def test_a_killed_writers_old_temporaries_are_removed_by_the_next_write(tmp_path):
    # SIGKILL between the temporary and the rename left megabytes of .NAME.<hex>.hammerstein-tmp
    # that no later run removed; only this target's, only old ones, only the user's own
    import time as _time
    from hammerstein.core.files import STALE_TMP_S, TMP_SUFFIX
    old = tmp_path / f".drive.csv.0123456789ab{TMP_SUFFIX}"
    fresh = tmp_path / f".drive.csv.ba9876543210{TMP_SUFFIX}"      # a live writer's
    other = tmp_path / f".other.csv.0123456789ab{TMP_SUFFIX}"      # another target's
    mine = tmp_path / ".drive.csv.notatemporary.hammerstein-tmp"   # not our pattern
    for p in (old, fresh, other, mine):
        p.write_text("x")
    then = _time.time() - STALE_TMP_S - 60
    for p in (old, other, mine):
        os.utime(p, (then, then))
    safe_write(tmp_path / "drive.csv", "t,u\n0,0\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["drive.csv", fresh.name, other.name, mine.name])


def test_a_read_only_file_system_is_named_not_chmod(tmp_path, monkeypatch):
    from hammerstein.core import files
    target = tmp_path / "d.csv"
    target.write_text("x")
    monkeypatch.setattr(files.os, "access", lambda *a, **k: False)   # as on a read-only mount
    monkeypatch.setattr(files, "_read_only_mount", lambda path: True)
    with pytest.raises(FileLimitError, match="read-only file system; choose another path"):
        safe_write(target, "y")
    monkeypatch.setattr(files, "_read_only_mount", lambda path: False)
    with pytest.raises(FileLimitError, match=r"chmod u\+w"):
        safe_write(target, "y")


_POOL_SCRIPT = """
import sys, time
import hammerstein.cli.main as m
from hammerstein.identification.concurrent_fits import fit_concurrently

def slow(k):
    time.sleep(60 if k == 1 else 0)     # one worker busy, the other idle, waiting for work
    return k

def fake(argv):
    print("started", flush=True)
    fit_concurrently({"a": (slow, (1,), {}), "b": (slow, (2,), {})}, workers=2)
    return 0

m._main = fake
m.run([])
"""


@pytest.mark.skipif(not hasattr(os, "killpg"), reason="process groups")
def test_ctrl_c_to_the_process_group_during_concurrent_fits_is_one_line(tmp_path):
    # a terminal's Ctrl-C (and timeout's) reaches every process of the group: each worker of
    # identify's fits printed 'Process ForkProcess-2: Traceback ... _Interrupted: 2', and the
    # signal sent again cut the exit handlers short ('Exception ignored in atexit callback')
    script = tmp_path / "pool.py"
    script.write_text(_POOL_SCRIPT)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)
    assert proc.stdout.readline() == "started\n"
    time.sleep(1.5)                         # the workers are sleeping in their calls
    os.killpg(proc.pid, signal.SIGINT)      # as a terminal sends it
    time.sleep(0.05)
    try:
        os.killpg(proc.pid, signal.SIGINT)  # and again (timeout signals child, then group)
    except ProcessLookupError:
        pass
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 130 and stderr == "interrupted\n", stderr
    time.sleep(0.5)
    with pytest.raises(ProcessLookupError):  # no worker left behind
        os.killpg(proc.pid, 0)


@pytest.mark.parametrize("twice", [["r.csv", "r.csv"], ["r.csv", "./sub/../r.csv"],
                                   ["r.csv", "hard.csv"]])
def test_identify_refuses_the_same_record_twice(capsys, tmp_path, monkeypatch, twice):
    # the same record twice: numpy's overflow warnings leaked, then 'input uy never excited'
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "r.csv").write_text("t,ux,uy,x,y\n0,0,0,0,0\n1e-4,1,0,1,0\n")
    os.link(tmp_path / "r.csv", tmp_path / "hard.csv")
    status, _, err = _call(capsys, "identify", *twice, "--inputs", "ux,uy", "--outputs", "x,y",
                           "--time", "t", "--out", "m.toml")
    assert status == 2 and len(err) == 1 and "the same file given twice" in err[0]
    assert not (tmp_path / "m.toml").exists()


def test_identify_names_an_input_no_record_excites_in_one_line(capfd, tmp_path, monkeypatch):
    # hysteresis-ux.csv alone for ux, uy: numpy's 'overflow encountered in power' leaked
    # from the fitting workers (fd 2: capfd) before "input 'uy': never excited"
    from hammerstein.signals.excitation import excitation_set
    from hysteresis_records import write
    monkeypatch.chdir(tmp_path)
    r = np.linspace(0.0, 90.0, 6)
    act = MultivariablePI([[PrandtlIshlinskii(r, [0.5, 0.15, 0.1, 0.05, 0.03, 0.01]), None],
                           [None, PrandtlIshlinskii(r, [0.4, 0.12, 0.08, 0.05, 0.03, 0.01])]],
                          ["ux", "uy"], ["x", "y"])
    rec = next(e for e in excitation_set(["ux", "uy"], 100.0, 1e-3, centre=[50.0, 50.0],
                                         multisine_periods=1) if e.name == "hysteresis-ux")
    assert np.ptp(rec.u[0]) > 0 and np.ptp(rec.u[1]) == 0       # ux excited, uy still
    y = act.simulate(rec.u)[0] + 0.01 * np.random.default_rng(1).standard_normal(rec.u.shape)
    write(tmp_path / "hysteresis-ux.csv", rec.time, rec.u, y)
    status, _, err = _call(capfd, "identify", "hysteresis-ux.csv", "--inputs", "ux,uy",
                           "--outputs", "x,y", "--time", "t", "--out", "m.toml")
    assert status == 1 and len(err) == 1, err
    value = rec.u[1][0]
    assert err[0].startswith(f"error: hysteresis-ux.csv: input 'uy': the input is constant "
                             f"({value:g}) in every record given") and "hysteresis-uy.csv" in err[0]
    assert not (tmp_path / "m.toml").exists()


def test_learn_refuses_its_drive_given_as_the_measurement(capsys, tmp_path, monkeypatch):
    # --measured drive.csv with --output-columns x=x_shaped: the learning read the drive's own
    # target as the response ("RMS 0 µm (0 %)") and wrote a new drive, exit 0
    monkeypatch.chdir(tmp_path)
    ref = '{ kind = "circle", radius = 30, frequency = 100, periods = 20 }'
    assert _call(capsys, "compensate", "rakotondrabe-2dof", "--reference", ref, "--out",
                 "d.csv")[0] == 0
    os.link(tmp_path / "d.csv", tmp_path / "same.csv")
    for measured in ("d.csv", "./same.csv"):
        status, _, err = _call(capsys, "learn", "rakotondrabe-2dof", "--reference", ref,
                               "--drive", "d.csv", "--measured", measured, "--output-columns",
                               "x=x_shaped,y=y_shaped", "--out", "next.csv")
        assert status == 2 and len(err) == 1 and "is the --drive file itself" in err[0]
    assert not (tmp_path / "next.csv").exists()


def test_a_threads_error_after_a_signal_is_dropped_and_before_it_is_not():
    """The fits' pool manager thread failed on the pipes of the workers Ctrl-C stopped and
    printed 'Exception in thread Thread-1: Traceback ...' after 'interrupted' (once in a
    loaded CI run). Once a signal ends the command a thread's error is dropped; before
    any, it reaches the previous hook."""
    import hammerstein.cli.main as cli_main
    seen = []
    hook = cli_main._quiet_thread_hook(seen.append)
    flagged = cli_main._SIGNALLED[0]
    try:
        cli_main._SIGNALLED[0] = False
        hook("before")
        cli_main._SIGNALLED[0] = True
        hook("after")
    finally:
        cli_main._SIGNALLED[0] = flagged
    assert seen == ["before"]


def test_a_write_the_system_refuses_is_one_line_naming_the_file(capsys, tmp_path, monkeypatch):
    """An outside check: under /sys (root gets EACCES/EPERM only at the write) ``compensate``
    printed ``[Errno 13] Permission denied: '/sys/.x.csv.<hex>.hammerstein-tmp' (kind
    hammerstein, the default for this model; ...)``, ``evaluate`` and ``learn --history`` the
    bare errno text. The refusal is simulated here at the same two calls."""
    real_open = os.open

    def refusing_open(name, flags, *args):
        if str(name).endswith(files.TMP_SUFFIX):
            raise PermissionError(errno.EACCES, "Permission denied", str(name))
        return real_open(name, flags, *args)

    monkeypatch.setattr(files.os, "open", refusing_open)
    status, _, err = _call(capsys, "compensate", "rakotondrabe-2dof", "--reference",
                           '{ kind = "circle", radius = 10, frequency = 20, periods = 5 }',
                           "--out", tmp_path / "x.csv")
    assert status == 1 and err == [f"hammerstein compensate: error: {tmp_path / 'x.csv'}: cannot "
                                   f"write the drive file (Permission denied); nothing was "
                                   f"written"]
    monkeypatch.setattr(files.os, "open", real_open)
    real_mkdir = Path.mkdir

    def refusing_mkdir(self, *args, **kwargs):
        if self.name == "refused":
            raise PermissionError(errno.EPERM, "Operation not permitted", str(self))
        return real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", refusing_mkdir)
    with pytest.raises(files.OutputError, match=r"^--history: .*refused: cannot create the "
                                                r"directory \(Operation not permitted\); nothing"):
        files.make_directory(tmp_path / "refused", "--history")
    with pytest.raises(files.OutputError, match=r"refused/a\.csv: cannot write the drive file "
                                                r"\(cannot create its directory"):
        safe_write(tmp_path / "refused" / "a.csv", "x", "drive file")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_check_out_force_moves_a_users_report_directory_aside(capsys, tmp_path):
    """An outside check: ``check --out kz`` refused kz/<scenario> naming --force, and ``check
    --force`` did not apply to the reports. It does now, as run's: moved aside, never deleted."""
    baseline = tmp_path / "base.csv"
    assert _call(capsys, "check", GOOD, "--update", "--baseline", baseline)[0] == 0
    (tmp_path / "kz" / "good-static").mkdir(parents=True)
    (tmp_path / "kz" / "good-static" / "notes.txt").write_text("mine")
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--out", tmp_path / "kz")
    assert status == 1 and any("--force" in line for line in err)
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--out", tmp_path / "kz",
                           "--force")
    kept = [p for p in (tmp_path / "kz").iterdir() if p.name.startswith("good-static.kept-")]
    assert status == 0 and len(kept) == 1 and (kept[0] / "notes.txt").read_text() == "mine"
    assert any(line.startswith("note: the earlier") and str(kept[0]) in line for line in err)


def test_a_report_whose_marker_cannot_be_written_leaves_no_temporary(capsys, tmp_path,
                                                                     monkeypatch):
    """An outside check: on a full disk `run` left `.hammerstein-tmp.*` behind (its marker
    not written), which the docs say only a killed run leaves."""
    import hammerstein.runner as runner

    def full(path, *args, **kwargs):
        raise files.OutputError(f"{path}: cannot write the report marker (No space left on "
                                f"device); nothing was written")

    monkeypatch.setattr(runner, "safe_write", full)
    status, _, err = _call(capsys, "run", GOOD, "--out", tmp_path / "rr", "--figures", "none")
    assert status == 1 and len(err) == 1 and "No space left on device" in err[0]
    assert err[0].count("cannot write") == 2 and "nothing was written" in err[0]
    assert list((tmp_path / "rr").iterdir()) == []
