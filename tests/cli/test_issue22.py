"""Issue 22: reliability, second round (ownership by content, concurrency, hygiene, numbers).

Each test is one defect of the issue, named by its number.
"""

import os
import shutil
import threading
import time
from pathlib import Path

import pytest

from hammerstein.cli.main import main
from hammerstein.core import files
from hammerstein.runner import MARKER, TMP_PREFIX, remove_stale_temporaries, run_scenarios

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good" / "good-static.toml"
GOOD2 = CORPUS / "good" / "good-static-2.toml"


def _call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err.splitlines()


# -- 4. temporaries owned by a token, not by a PID ---------------------------------------
def _fake_temporary(out, token, age=3600.0):
    d = out / f"{TMP_PREFIX}2.deadbeef.x"
    d.mkdir(parents=True)
    (d / MARKER).write_text(f"hammerstein 0\nowner {token}\n")
    old = time.time() - age
    os.utime(d / MARKER, (old, old))
    return d


def _token(**change):
    fields = files.parse_owner(files.owner_token())
    files.release_owner(files.owner_token())
    fields.update(change)
    return " ".join(f"{k}={v}" for k, v in fields.items())


def test_4_other_pid_namespace_keeps_its_temporary(tmp_path):
    # pid 2 of another PID namespace: its liveness cannot be told here, so it stays
    d = _fake_temporary(tmp_path, _token(pidns="1", pid="2"))
    assert remove_stale_temporaries(tmp_path) == []
    assert d.is_dir()


def test_4_other_host_keeps_its_temporary(tmp_path):
    d = _fake_temporary(tmp_path, _token(host="elsewhere"))
    assert remove_stale_temporaries(tmp_path) == []
    assert d.is_dir()


def test_4_reused_pid_is_stale(tmp_path):
    # same namespace, the PID alive but started at another time: its owner is gone
    d = _fake_temporary(tmp_path, _token(pid=str(os.getppid()), start="1"))
    assert remove_stale_temporaries(tmp_path) == [d]
    assert not d.exists()


def test_4_live_call_of_this_process_is_kept_finished_one_removed(tmp_path):
    token = files.owner_token()
    d = _fake_temporary(tmp_path, token)
    assert files.owner_alive(token) is True
    assert remove_stale_temporaries(tmp_path) == []
    files.release_owner(token)
    assert files.owner_alive(token) is False
    assert remove_stale_temporaries(tmp_path) == [d]


def test_4_young_empty_temporary_is_kept(tmp_path):
    d = tmp_path / f"{TMP_PREFIX}{os.getpid()}.0.x"
    d.mkdir()
    old = time.time() - 1.0
    os.utime(d, (old, old))
    assert remove_stale_temporaries(tmp_path) == []
    os.utime(d, (old - 3600, old - 3600))
    assert remove_stale_temporaries(tmp_path) == [d]


@pytest.mark.figure_pool   # four threads: figures in the workers, as the CLI draws them
def test_4_two_threads_share_one_out_directory(tmp_path):
    # each thread's sweep of stale temporaries must not remove the other's live report
    out = tmp_path / "out"
    results, errors = {}, []

    def work(i, src):
        try:
            scen = tmp_path / f"s{i}.toml"
            text = src.read_text()
            scen.write_text(text.replace(f'name = "{src.stem}"', f'name = "x{i}"', 1))
            results[i] = run_scenarios([scen], out)
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i, GOOD if i % 2 else GOOD2)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert all(o.ok for r in results.values() for o in r), [o.error for r in results.values() for o in r]
    assert not [p for p in out.iterdir() if p.name.startswith(TMP_PREFIX)]


# -- 1. identify replaces only what carries the provenance mark ---------------------------
DATA = CORPUS / "data" / "good.csv"
IDENTIFY = [DATA, "--time", "time_s", "--input", "u_V", "--output", "y_um", "--thresholds", "5"]
REPO = Path(__file__).resolve().parents[2]


def _png_without_mark(path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure()
    fig.savefig(path, format="png")
    plt.close(fig)


@pytest.mark.parametrize("option,make", [
    ("--out", lambda p: shutil.copy(REPO / "scenarios" / "presets" / "coupled-2dof.toml", p)),
    ("--out", lambda p: p.write_text("[model]\n# my hand-written model\n")),
    ("--metrics", lambda p: p.write_text("case,channel,metric,value,unit\nmine,x,y,1,um\n")),
    ("--plot", _png_without_mark),
])
def test_1_identify_keeps_hand_written_outputs(capsys, tmp_path, option, make):
    target = tmp_path / ("mine.png" if option == "--plot" else "mine.toml" if option == "--out"
                         else "mine.csv")
    make(target)
    before = target.read_bytes()
    extra = [] if option == "--out" else ["--out", tmp_path / "model.toml"]
    status, _, err = _call(capsys, "identify", *IDENTIFY, *extra, option, target)
    assert status == 2
    assert len(err) == 1 and "--force" in err[0] and "not written by" in err[0]
    assert target.read_bytes() == before
    assert not (tmp_path / "model.toml").exists()       # nothing written at all


def test_1_identify_replaces_its_own_outputs_and_force(capsys, tmp_path):
    out, met, png = tmp_path / "m.toml", tmp_path / "m.csv", tmp_path / "m.png"
    args = ["identify", *IDENTIFY, "--out", out, "--metrics", met, "--plot", png]
    assert _call(capsys, *args)[0] == 0
    for p in (out, met, png):
        assert files.carries_provenance(p), p
    assert _call(capsys, *args)[0] == 0               # its own files: replaced
    out.write_text("[model]\n")                        # now a file of the user's
    assert _call(capsys, *args)[0] == 2
    assert out.read_text() == "[model]\n"
    assert _call(capsys, *args, "--force")[0] == 0
    assert files.carries_provenance(out)


def test_1_identify_output_never_an_input(capsys, tmp_path):
    data = tmp_path / "d.csv"
    shutil.copy(DATA, data)
    before = data.read_bytes()
    status, _, err = _call(capsys, "identify", data, *IDENTIFY[1:], "--out", tmp_path / "m.toml",
                           "--metrics", data, "--force")
    assert status == 2 and "data files" in err[0]
    assert data.read_bytes() == before


def test_17_failed_write_leaves_no_output(capsys, tmp_path, monkeypatch):
    # the model write fails (disk full) after the figure was drawn: nothing stays
    import hammerstein.cli.identify as ident

    def full(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(ident, "_write_metrics", full)
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--out", tmp_path / "m.toml",
                           "--plot", tmp_path / "m.png", "--metrics", tmp_path / "m.csv")
    assert status == 1 and len(err) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == []


# -- 2. check --junit-xml ----------------------------------------------------------------
@pytest.fixture
def baseline(tmp_path, capsys):
    base = tmp_path / "base.csv"
    assert _call(capsys, "check", GOOD, "--baseline", base, "--update", "-q")[0] == 0
    return base


@pytest.mark.parametrize("content", ["my notes\n", "<?xml version='1.0'?>\n<testsuites/>\n"])
def test_2_junit_never_overwrites_a_foreign_file(capsys, tmp_path, baseline, content):
    notes = tmp_path / "notes.txt"
    notes.write_text(content)
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--junit-xml", notes)
    assert status == 2 and "--force" in err[0]
    assert notes.read_text() == content
    assert _call(capsys, "check", GOOD, "--baseline", baseline, "--junit-xml", notes,
                 "--force", "-q")[0] == 0
    assert files.carries_provenance(notes)
    assert _call(capsys, "check", GOOD, "--baseline", baseline, "--junit-xml", notes, "-q")[0] == 0


@pytest.mark.parametrize("which", ["baseline", "scenario"])
def test_2_junit_is_never_an_input(capsys, tmp_path, baseline, which):
    scen = tmp_path / "s.toml"
    shutil.copy(GOOD, scen)
    target = baseline if which == "baseline" else scen
    before = target.read_bytes()
    status, _, err = _call(capsys, "check", scen, "--baseline", baseline, "--junit-xml", target,
                           "--force")
    assert status == 2 and "input" in err[0]
    assert target.read_bytes() == before


def test_2_junit_inside_a_report_directory_is_refused_before_running(capsys, tmp_path,
                                                                     baseline, monkeypatch):
    """``--junit-xml OUT/<scenario>/report.md``: found only after the report was written, with
    "was replaced by a file hammerstein did not write" (hammerstein wrote it itself)."""
    import hammerstein.cli.check as check
    monkeypatch.setattr(check, "_check", lambda *a, **k: pytest.fail("ran the scenarios"))
    out = tmp_path / "kout"
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--out", out,
                           "--junit-xml", out / "good-static" / "report.md")
    assert status == 2 and len(err) == 1 and "report directory" in err[0]
    assert not out.exists()
    monkeypatch.undo()
    assert _call(capsys, "check", GOOD, "--baseline", baseline, "--out", out,
                 "--junit-xml", out / "junit.xml", "-q")[0] == 0     # beside the reports: fine


def test_2_junit_write_error_names_the_junit_file(capsys, tmp_path, baseline, monkeypatch):
    import hammerstein.cli.check as check

    def full(path, data, what="file"):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(check, "safe_write", full)
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--junit-xml",
                           tmp_path / "j.xml")
    assert status == 1 and "JUnit" in err[-1] and "baseline" not in err[-1]


def test_update_keeps_a_hand_written_baseline(capsys, tmp_path):
    base = tmp_path / "base.csv"
    text = "scenario,case,channel,metric,value,unit\nother,c,x,rms_error,1.0,µm\n"
    base.write_text(text)
    status, _, err = _call(capsys, "check", GOOD, "--baseline", base, "--update")
    assert status == 2 and "--force" in err[0]
    assert base.read_text() == text
    assert _call(capsys, "check", GOOD, "--baseline", base, "--update", "--force", "-q")[0] == 0
    kept = base.read_text()
    assert "other,c,x,rms_error,1.0" in kept and files.carries_provenance(base)


# -- 3. concurrent check --update of one baseline ------------------------------------------
# Two processes at the same time in the default suite (forked children of one interpreter:
# tests/cli/forked_cli.py); the slow job runs four fresh processes at once, as before.
def test_3_concurrent_updates_all_land(forked_cli):
    results, tmp = forked_cli
    n = sum(name.startswith("update-") for name in results)
    assert n >= 2
    runs = [results[f"update-{i}"] for i in range(n)]
    assert [r["status"] for r in runs] == [0] * n, [r["stderr"] for r in runs]
    from hammerstein.scenario.regression import read_baseline
    assert sorted(set(read_baseline(tmp / "base.csv")["scenario"])) == [f"c{i}" for i in range(n)]


@pytest.mark.slow
def test_3_concurrent_updates_all_land_fresh_processes(tmp_path):
    import subprocess
    import sys
    n = 4
    base = tmp_path / "base.csv"
    procs = []
    for i in range(n):
        scen = tmp_path / f"c{i}.toml"
        scen.write_text(GOOD.read_text().replace('name = "good-static"', f'name = "c{i}"', 1))
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "hammerstein", "check", str(scen), "--baseline", str(base),
             "--update", "-q"], stderr=subprocess.PIPE, text=True))
    errs = [p.communicate(timeout=600)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * n, errs
    from hammerstein.scenario.regression import read_baseline
    assert sorted(set(read_baseline(base)["scenario"])) == [f"c{i}" for i in range(n)]


# -- 14. baseline inf, misspelt tolerance metrics -------------------------------------------
def test_14_inf_in_baseline_is_an_error(capsys, tmp_path, baseline):
    lines = baseline.read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ",rms_error," in ln)
    lines[i] = ",".join(lines[i].split(",")[:4] + ["inf"] + lines[i].split(",")[5:])
    baseline.write_text("\n".join(lines) + "\n")
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline)
    assert status == 2 and len(err) == 1 and "finite" in err[0] and "rms_error" in err[0]


def test_14_misspelt_tolerance_metric_is_an_error(capsys, tmp_path, baseline):
    tol = tmp_path / "tol.toml"
    tol.write_text("[rms_eror]\nrtol = 0.5\n")
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--tolerances", tol)
    assert status == 2 and "rms_eror" in err[0] and "rms_error" in err[0]


# -- 8. SIGKILL / SIGHUP of a run: no orphan worker, no temporary -------------------------
def _start_run(tmp_path, scenarios):
    import subprocess
    import sys
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "hammerstein", "run", *map(str, scenarios),
                             "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:  # a report in progress
        if out.is_dir() and any(p.name.startswith(TMP_PREFIX) for p in out.iterdir()):
            break
        time.sleep(0.005)
    return proc, out


def _children(pid):
    kids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat_ = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat_.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(d.name))
    return kids


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_8_sigkill_of_a_run_ends_its_workers(forked_cli):
    # a `python -m hammerstein run` of two scenarios (tests/cli/conftest.py) SIGKILLed once its
    # figure workers exist: none of them outlives it (20 s allowed)
    run = forked_cli[0]["sigkill-workers"]
    if not run["signalled"]:
        pytest.skip("the run finished before its figure workers were seen")
    assert run["status"] == -9 and run["workers"]
    assert run["workers_alive"] == []


def test_8_sighup_is_an_interruption(forked_cli):
    import signal
    results, tmp = forked_cli
    run = results["sighup"]
    if not run["signalled"]:
        pytest.skip("the run finished before the signal arrived")
    assert run["status"] == 128 + signal.SIGHUP and run["stderr"] == "interrupted\n", run["stderr"]
    assert not [p for p in (tmp / "sighup").iterdir() if p.name.startswith(TMP_PREFIX)]


def test_8_sighup_under_nohup_is_ignored(forked_cli):
    """A run started under ``nohup`` (SIGHUP ignored) keeps ignoring the hang-up and completes."""
    results, tmp = forked_cli
    run = results["sighup-nohup"]
    assert run["status"] == 0 and "interrupted" not in run["stderr"], run["stderr"]
    assert (tmp / "sighup-nohup" / "good-static" / "report.md").is_file()


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_8_sigkill_of_a_piped_run_ends_its_workers(tmp_path):
    import signal
    import subprocess
    proc, _ = _start_run(tmp_path, [GOOD, GOOD2])
    deadline = time.time() + 60
    workers = []
    while time.time() < deadline and proc.poll() is None and not workers:
        workers = _children(proc.pid)
        time.sleep(0.01)
    if proc.poll() is not None:
        pytest.skip("the run finished before its figure workers were seen")
    proc.send_signal(signal.SIGKILL)
    try:   # the pipes close when every holder (the workers too) is gone
        proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:  # pragma: no cover - the defect
        for w in workers:
            os.kill(w, signal.SIGKILL)
        pytest.fail("figure workers outlived their parent, holding its stdout/stderr")
    time.sleep(0.2)
    alive = [w for w in workers if Path(f"/proc/{w}").exists()
             and " Z " not in Path(f"/proc/{w}/stat").read_text()]
    assert alive == []


# -- 12. a killed figure worker: the figures are drawn inline ----------------------------
def test_12_broken_pool_falls_back_to_inline(tmp_path):
    import signal
    import numpy as np
    from hammerstein.report.trajectories import divergence_figure
    from hammerstein.report.render import FigureJobs, FigureRenderer
    args = (np.zeros((2, 10)), ["u1", "u2"], 5, "test", "t")
    with FigureRenderer() as renderer:
        if renderer.workers < 1:                    # 0: no fork, figures drawn inline
            pytest.skip("no fork")
        first = FigureJobs(renderer)
        first.add(tmp_path / "a.png", divergence_figure, *args)
        first.wait()
        for pid in list(renderer._pool._processes):   # the OOM killer strikes
            os.kill(pid, signal.SIGKILL)
        time.sleep(0.5)
        jobs = [FigureJobs(renderer) for _ in range(3)]
        for i, j in enumerate(jobs):
            j.add(tmp_path / f"b{i}.png", divergence_figure, *args)   # identical figure
            j.add(tmp_path / f"c{i}.png", divergence_figure, *args[:3], "other", "t")
        for j in jobs:
            j.wait()
    for i in range(3):
        assert (tmp_path / f"b{i}.png").read_bytes()[:4] == b"\x89PNG"
        assert (tmp_path / f"c{i}.png").read_bytes()[:4] == b"\x89PNG"


# -- 10, 11. closed or full stdio, environment of the dependencies --------------------------
def _cli(args, **kw):
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "hammerstein", *map(str, args)],
                          capture_output=True, text=True, timeout=300, **kw)


@pytest.mark.parametrize("close", ["stdout", "stderr"])
@pytest.mark.parametrize("argv", ["validate", "list", "version"])
def test_10_closed_stdio_keeps_the_exit_status(forked_cli, argv, close):
    # a process whose fd 1 or 2 is closed before `python -m hammerstein` starts its command
    run = forked_cli[0][f"closed-{close}-{argv}"]
    assert run["status"] == 0
    assert "Traceback" not in ((run["stderr"] or "") + (run["stdout"] or ""))


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_10_full_stdout_is_an_error(forked_cli):
    run = forked_cli[0]["full-stdout"]
    assert run["status"] == 1
    lines = run["stderr"].splitlines()
    assert len(lines) == 1 and "cannot write the output" in lines[0]


# Variables read at the interpreter's or a dependency's start-up need a fresh process; the
# independent ones share it: two bad dependency variables (one note line each, the command
# still succeeds and draws its figure with Agg) and an ASCII stdout (13).
@pytest.mark.slow  # end-to-end; default pytest stays fast, .ci/run runs -m slow
def test_11_13_start_up_variables_in_one_fresh_process(tmp_path):
    env = {**os.environ, "NUMBA_NUM_THREADS": "x", "MPLBACKEND": "bogus",
           "PYTHONIOENCODING": "ascii"}
    proc = _cli(["identify", *IDENTIFY, "--out", tmp_path / "m.toml", "--plot", tmp_path / "m.png"],
                env=env)
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stdout                                   # 13: after writing, no failure
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"      # drawn although MPLBACKEND is bad
    lines = proc.stderr.splitlines()
    assert len(lines) == 2, lines
    for var, line in zip(("NUMBA_NUM_THREADS", "MPLBACKEND"), lines):
        assert var in line and "ignored" in line, line


@pytest.mark.parametrize("var,value", [("NUMBA_NUM_THREADS", "0"), ("NUMBA_NUM_THREADS", "x"),
                                       ("NUMBA_NUM_THREADS", "-3"), ("MPLBACKEND", "bogus")])
def test_11_bad_dependency_variables_are_removed_with_one_note(monkeypatch, capsys, var, value):
    import hammerstein.cli.main as cli
    monkeypatch.setenv(var, value)
    monkeypatch.setattr(cli, "_writable_dir", lambda p: True)
    notes = cli._prepare_environment()
    assert len(notes) == 1 and var in notes[0] and "ignored" in notes[0]
    assert var not in os.environ
    assert capsys.readouterr().err.splitlines() == notes


@pytest.mark.slow
@pytest.mark.parametrize("var,value", [("NUMBA_NUM_THREADS", "0"), ("NUMBA_NUM_THREADS", "x"),
                                       ("MPLBACKEND", "bogus")])
def test_11_bad_dependency_variables_are_one_line(tmp_path, var, value):
    # figures only where the variable is matplotlib's (numba's are read by the kernels)
    figures = [] if var == "MPLBACKEND" else ["--figures", "none"]
    proc = _cli(["run", GOOD, "--out", tmp_path, "-q", *figures], env={**os.environ, var: value})
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and var in lines[0] and "ignored" in lines[0]


def test_11_unwritable_numba_cache_falls_back(tmp_path, monkeypatch, capsys):
    import hammerstein.cli.main as cli
    monkeypatch.setattr(cli, "_writable_dir", lambda p: False)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    notes = cli._prepare_environment()
    assert len(notes) == 1 and "no writable cache" in notes[0]
    where = Path(os.environ.pop("NUMBA_CACHE_DIR"))
    assert where.is_dir() and where.parent == tmp_path and (where.stat().st_mode & 0o077) == 0


@pytest.mark.slow
def test_13_ascii_stdout_does_not_fail_after_writing(tmp_path):
    proc = _cli(["identify", *IDENTIFY, "--out", tmp_path / "m.toml"],
                env={**os.environ, "PYTHONIOENCODING": "ascii"})
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stdout


# -- 7. terminal escapes, NUL and newlines in user strings ----------------------------------
EVIL = "evil\x1b]0;pwned\x07\x1b[2J\nerror: forged"


def _raw_control(text):
    return [c for c in text if not c.isprintable() and c not in "\n\t"]


@pytest.mark.parametrize("command", ["validate", "run"])
def test_7_file_names_are_escaped(capsys, tmp_path, command):
    scen = tmp_path / f"{EVIL}.toml"
    shutil.copy(GOOD, scen)
    extra = ["--out", tmp_path / "out", "-v"] if command == "run" else []
    status, out, err = _call(capsys, command, scen, *extra)
    assert status == 0
    status_lines = out.splitlines() + err
    assert _raw_control(out + "\n".join(err)) == []
    assert not any(line.startswith("error: forged") for line in status_lines)
    assert any("\\x1b]0;pwned\\x07" in line for line in status_lines)


def test_7_bad_file_name_error_is_escaped(capsys, tmp_path):
    scen = tmp_path / f"{EVIL}.toml"
    scen.write_text("not = [toml")
    status, out, err = _call(capsys, "validate", scen)
    assert status == 1 and len(err) == 1 and _raw_control(err[0]) == []


def test_7_title_is_escaped_in_report_md(capsys, tmp_path):
    scen = tmp_path / "t.toml"
    scen.write_text('title = "\\u001b[2J<script>alert(1)</script> *bold*"\n' + GOOD.read_text())
    assert _call(capsys, "run", scen, "--out", tmp_path, "-q")[0] == 0
    first = (tmp_path / "good-static" / "report.md").read_text(encoding="utf-8").splitlines()[0]
    assert "<script>" not in first and "\x1b" not in first and "*bold*" not in first
    assert first.startswith("# ") and "alert" in first


def test_18_huge_message_is_bounded(capsys):
    from hammerstein.cli._common import MAX_LINE, print_err
    print_err("error: " + "x" * 2_000_000)
    err = capsys.readouterr().err
    assert len(err) < MAX_LINE + 100 and "more characters" in err


# -- 6. paths of scenario files confined to the scenario's directory ---------------------
SECRET = "s3cret-first-line-do-not-echo"


@pytest.fixture
def outside(tmp_path, monkeypatch):
    monkeypatch.delenv(files.ALLOW_ENV, raising=False)
    home = tmp_path / "scenario-dir"
    home.mkdir()
    secret = tmp_path / "secret.csv"
    secret.write_text(f"{SECRET},b\n1,2\n")
    return home, secret


def _identification(home, file_value):
    scen = home / "s.toml"
    scen.write_text(f'kind = "identification"\n[data]\nfile = "{file_value}"\ninput = "u"\n'
                    f'output = "y"\nsampling_period = 1e-3\n')
    return scen


@pytest.mark.parametrize("how", ["absolute", "dotdot", "bundled", "symlink"])
def test_6_files_outside_the_scenario_directory_are_refused(capsys, outside, how):
    home, secret = outside
    value = {"absolute": str(secret), "dotdot": "../secret.csv",
             "bundled": "bundled:../../../" + str(secret), "symlink": "link.csv"}[how]
    if how == "symlink":
        (home / "link.csv").symlink_to(secret)
    scen = _identification(home, value)
    for command in (["validate", scen], ["run", scen, "--out", home / "out"]):
        status, out, err = _call(capsys, *command)
        assert status == 1 and len(err) == 1, err
        assert SECRET not in err[0] + out
        assert ("outside the scenario's directory" in err[0] or "bundled:<file name>" in err[0])


def test_6_allowed_directory_is_read(capsys, outside, monkeypatch):
    home, secret = outside
    monkeypatch.setenv(files.ALLOW_ENV, str(secret.parent))
    status, _, err = _call(capsys, "validate", _identification(home, str(secret)))
    assert "outside the scenario" not in " ".join(err)


@pytest.mark.parametrize("key,value", [("model", "/etc/passwd"), ("model", "../m.toml")])
def test_6_model_paths_are_confined(capsys, outside, key, value):
    home, _ = outside
    scen = home / "m.toml"
    scen.write_text('[plant]\npreset = "rakotondrabe-2dof"\ndynamics = false\n'
                    f'[compensator]\nkind = "multivariable"\n{key} = "{value}"\n'
                    '[[cases]]\nname = "x"\nreference = { kind = "sine", output = "x", '
                    'amplitude = 50.0, frequency = 50.0, periods = 3 }\n')
    status, _, err = _call(capsys, "validate", scen)
    assert status == 1 and "outside the scenario's directory" in err[0]
    assert "root:" not in err[0]


@pytest.mark.parametrize("value,fragment", [("a\\u0000b.csv", "NUL"),
                                            ("x" * 1001, "at most 1000"),
                                            ("d/" + "y" * 300 + ".csv", "at most 255")])
def test_13_bad_paths_are_one_line(capsys, outside, value, fragment):
    home, _ = outside
    status, _, err = _call(capsys, "validate", _identification(home, value))
    assert status == 1 and len(err) == 1 and fragment in err[0] and "unexpected" not in err[0]


# -- 15. a numeric header name is a name before an index ----------------------------------
def test_15_numeric_header_names_are_names(tmp_path):
    import numpy as np
    from hammerstein.io.datafiles import read_records
    t = np.arange(200) * 1e-3
    u = 5 * np.sin(2 * np.pi * 5 * t)
    y = 2 * u + 1
    path = tmp_path / "d.csv"
    path.write_text("time,2,1\n" + "".join(f"{a:.17g},{c:.17g},{b:.17g}\n" for a, b, c in zip(t, u, y)))
    rec = read_records(path, "1", "2", "time", None)
    np.testing.assert_array_equal(rec.u[0], u)        # the column named "1", not index 1
    np.testing.assert_array_equal(rec.y[0], y)


# -- 9, 18. memory bounded by the limits; limits and their messages -------------------------
def test_9_cells_are_checked_before_parsing(tmp_path, monkeypatch):
    from hammerstein.io.datafiles import DataFileError, read_records
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_CELLS", "100")
    path = tmp_path / "d.csv"
    path.write_text("t,u,y\n" + "".join(f"{i},{i % 7},{i % 5}\n" for i in range(50)))
    with pytest.raises(DataFileError, match=r"51 rows x 3 columns = 153 cells .* HAMMERSTEIN_MAX_DATA_CELLS"):
        read_records(path, "u", "y", "t", None)


def test_9_total_bytes_budget_across_files(capsys, tmp_path, monkeypatch):
    data = [tmp_path / f"d{i}.csv" for i in range(3)]
    for d in data:
        shutil.copy(DATA, d)
    monkeypatch.setenv("HAMMERSTEIN_MAX_TOTAL_BYTES", str(2 * DATA.stat().st_size + 10))
    status, _, err = _call(capsys, "identify", *data, *IDENTIFY[1:], "--out", tmp_path / "m.toml")
    assert status == 1 and len(err) == 1 and "HAMMERSTEIN_MAX_TOTAL_BYTES" in err[0]
    assert str(data[2]) in err[0]
    monkeypatch.delenv("HAMMERSTEIN_MAX_TOTAL_BYTES")
    assert _call(capsys, "identify", *data, *IDENTIFY[1:], "--out", tmp_path / "m.toml")[0] == 0


def test_13_field_over_128_kib_is_one_line(capsys, tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("t" * 200_000 + ",u_V,y_um\n1,2,3\n")
    status, _, err = _call(capsys, "identify", path, "--sampling-period", "1e-3", "--input", "u_V",
                           "--output", "y_um", "--out", tmp_path / "m.toml")
    assert status == 1 and len(err) == 1 and "unexpected" not in err[0]
    assert len(err[0]) < 3000


@pytest.mark.parametrize("value", ["\u00b2", "0", "-5", "1e3"])
def test_18_bad_limit_overrides_are_ignored(monkeypatch, value):
    monkeypatch.setenv("HAMMERSTEIN_MAX_TOML_BYTES", value)
    assert files.limit("toml") == 4 * 2**20


def test_18_limit_message_never_equal_sizes(tmp_path, monkeypatch):
    path = tmp_path / "big.toml"
    path.write_bytes(b"#" * (4 * 2**20 + 1))
    with pytest.raises(files.FileLimitError) as info:
        files.bounded_read_bytes(path, "toml", "scenario file")
    assert "4194305 bytes" in str(info.value)


# -- 13, 16. numbers: huge ints, subnormals; API arrays checked like the CLI ------------------
@pytest.mark.parametrize("value,problem", [
    (10**400, "beyond the float range"), (-(10**400), "beyond the float range"),
    (5e-324, "subnormal"), (float("inf"), "not finite"), (float("nan"), "not finite"),
    (True, "not a number"), ("1", "not a number"), (1 + 0j, "not a number"),
    (0, None), (2**63, None), (1e-300, None), (-3.5, None)])
def test_13_number_problem(value, problem):
    from hammerstein.core.numbers import number_problem
    assert number_problem(value) == problem


@pytest.mark.parametrize("value", ["1" + "0" * 400, "5e-324"])
def test_13_huge_or_subnormal_frequency_is_one_line(capsys, tmp_path, value):
    scen = tmp_path / "s.toml"
    scen.write_text(GOOD.read_text().replace("frequency = 50.0", f"frequency = {value}"))
    status, _, err = _call(capsys, "validate", scen)
    assert status == 1 and err and all("frequency" in e and "unexpected" not in e for e in err)
    assert all(len(e) < 400 for e in err)


def _record(**change):
    import numpy as np
    from hammerstein.io.datafiles import MultiRecord
    t = np.arange(2000) * 1e-3
    u = 5 * np.sin(2 * np.pi * 2 * t)[None, :]
    fields = dict(timepts=t, u=u, y=2 * u, input_names=("u",), output_names=("y",),
                  sampling_period=1e-3, source="api")
    fields.update(change)
    return MultiRecord(**fields)


@pytest.mark.parametrize("change,fragment", [
    ("nan", "non-finite value nan"), ("complex", "complex"), ("short-y", "samples, expected"),
    ("nan-T", "sampling_period")])
def test_16_identify_records_checks_its_arrays(change, fragment):
    import numpy as np
    from hammerstein.identification.record_identification import identify_records
    from hammerstein.exceptions import IdentificationError
    good = _record()
    rec = {"nan": lambda: _record(y=np.where(np.arange(2000) == 77, np.nan, good.y)),
           "complex": lambda: _record(u=good.u + 1j),
           "short-y": lambda: _record(y=good.y[:, :-3]),
           "nan-T": lambda: _record(sampling_period=float("nan"))}[change]()
    with pytest.raises(IdentificationError, match=fragment):
        identify_records([rec], n_hysterons=5)


# -- 16. iterations and other integers through the API: the scenario files' bound ---------
def _static_model():
    from hammerstein.io.presets import load_plant
    return load_plant("rakotondrabe-2dof", dynamics=False).hysteresis


@pytest.mark.parametrize("value,fragment", [
    (10 ** 9, "iterations: expected an integer 1..100, found 1000000000"),
    (10 ** 400, "found an integer of 401 digits"),
    (101, "1..100"),
    (0, "iterations: expected an integer 1..100, found 0"),
    (2.0, "expected an integer 1..100, found 2.0"),
    (True, "expected an integer 1..100, found True"),
])
def test_16_api_iterations_are_capped_like_the_scenario_files(value, fragment):
    from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    from hammerstein.exceptions import CompensatorError
    with pytest.raises(CompensatorError, match="^iterations: ") as info:
        InverseMultiplicativeCompensator(_static_model(), iterations=value)
    assert fragment in str(info.value) and len(str(info.value)) < 120


def test_16_api_bound_equals_the_scenario_bound():
    from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    from hammerstein.core.numbers import MAX_ITERATIONS
    from hammerstein.scenario.schema import MAX_ITERATIONS as SCENARIO_MAX
    import numpy as np
    assert MAX_ITERATIONS == SCENARIO_MAX
    comp = InverseMultiplicativeCompensator(_static_model(), iterations=np.int64(MAX_ITERATIONS))
    assert comp.iterations == MAX_ITERATIONS and type(comp.iterations) is int


def test_16_ilc_iterations_are_capped():
    from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    from hammerstein.compensation.ilc import LearningCompensator
    from hammerstein.exceptions import CompensatorError
    start = InverseMultiplicativeCompensator(_static_model())
    with pytest.raises(CompensatorError, match=r"^iterations: expected an integer 1\.\.100"):
        LearningCompensator(start, 1e-4, iterations=10 ** 9)


def test_16_export_iterations_are_capped(capsys, tmp_path):
    status, _, err = _call(capsys, "export", "rakotondrabe-2dof", "--target", "c", "--out", tmp_path / "o",
                           "--iterations", str(10 ** 9))
    assert status == 2 and len(err) == 1
    assert "--iterations: expected an integer 1..100, found 1000000000" in err[0]
    assert not (tmp_path / "o").exists()


# -- 15. outputs that overflow: refused with one line, nothing written ----------------------
def _huge_preset(directory, scale):
    # the 1x1 corpus preset with its weights scaled: outputs of ~scale µm
    text = (CORPUS / "models" / "preset-static.toml").read_text()
    text = text.replace("weights = [1.0, 0.5, 0.2]",
                        f"weights = [{1.0 * scale!r}, {0.5 * scale!r}, {0.2 * scale!r}]")
    (directory / "huge.toml").write_text(text)


@pytest.mark.parametrize("scale", [1e300, 1e160])
def test_15_huge_weights_are_refused_on_loading(capsys, tmp_path, scale):
    # a weight beyond 1e150 is refused when the preset is read, its key named
    _huge_preset(tmp_path, scale)
    scen = tmp_path / "s.toml"
    scen.write_text('[plant]\npreset = "huge.toml"\ndynamics = false\n[compensator]\nkind = "none"\n'
                    '[[cases]]\nname = "open"\ndrive = { kind = "sine", input = "ux", amplitude = 10.0, '
                    'frequency = 50.0, periods = 2 }\n')
    status, out, err = _call(capsys, "run", scen, "--out", tmp_path / "out")
    assert status == 1 and len(err) == 1, err
    assert f"model.components.x.ux.weights[0]: {scale:.3g} is beyond the magnitude limit 1e+150" in err[0]
    assert not (tmp_path / "out" / "s").exists()


@pytest.mark.parametrize("scale", [1e149, 5e149])
def test_15_overflowing_outputs_are_refused(capsys, tmp_path, scale):
    # weights under the limit whose outputs (about 10 V x the weight sum) are beyond it
    _huge_preset(tmp_path, scale)
    scen = tmp_path / "s.toml"
    scen.write_text('[plant]\npreset = "huge.toml"\ndynamics = false\n[compensator]\nkind = "none"\n'
                    '[[cases]]\nname = "open"\ndrive = { kind = "sine", input = "ux", amplitude = 10.0, '
                    'frequency = 50.0, periods = 2 }\n')
    status, out, err = _call(capsys, "run", scen, "--out", tmp_path / "out")
    assert status == 1 and len(err) == 1, err
    assert "case 'open': simulated outputs:" in err[0] and "beyond the limit 1e+150" in err[0]
    assert not (tmp_path / "out" / "s").exists()
    assert "DLASCL" not in out


def test_15_moderate_outputs_still_run(capsys, tmp_path):
    # 1e140 µm is absurd but computable: the bound is the float range, not physics
    _huge_preset(tmp_path, 1e140)
    scen = tmp_path / "s.toml"
    scen.write_text('[plant]\npreset = "huge.toml"\ndynamics = false\n[compensator]\nkind = "none"\n'
                    '[[cases]]\nname = "open"\ndrive = { kind = "sine", input = "ux", amplitude = 10.0, '
                    'frequency = 50.0, periods = 2 }\n')
    status, _, err = _call(capsys, "run", scen, "--out", tmp_path / "out")
    assert status == 0, err
    import pandas as pd
    frame = pd.read_csv(tmp_path / "out" / "s" / "metrics.csv")
    assert np_isfinite_all(frame["value"])


def np_isfinite_all(values):
    import numpy as np
    return bool(np.all(np.isfinite(np.asarray(values, dtype=float))))


@pytest.mark.parametrize("value", ["1e300", "-3e151", "1.8e308"])
def test_15_data_values_beyond_the_limit_are_one_line(capsys, tmp_path, value):
    lines = DATA.read_text().splitlines()
    row = lines[5].split(",")
    row[2] = value
    lines[5] = ",".join(row)
    data = tmp_path / "d.csv"
    data.write_text("\n".join(lines) + "\n")
    status, out, err = _call(capsys, "identify", data, "--time", "time_s", "--input", "u_V",
                             "--output", "y_um", "--out", tmp_path / "m.toml")
    assert status == 1 and len(err) == 1, err
    assert "output column 'y_um'" in err[0] and "data row 5" in err[0]
    assert "beyond the limit" in err[0] or "infinite" in err[0]
    assert not (tmp_path / "m.toml").exists()


def test_15_api_arrays_beyond_the_limit():
    import numpy as np
    from hammerstein.core.numbers import check_array
    with pytest.raises(ValueError, match=r"^u: -2e\+300 at index \(1, 3\) is beyond the limit 1e\+150$"):
        check_array(np.where(np.arange(8).reshape(2, 4) == 7, -2e300, 1.0), "u")
    assert check_array([1e149], "u")[0] == 1e149


def test_15_dynamics_fit_refuses_overflowing_records_before_lapack(capfd):
    # LAPACK printed "** On entry to DLASCL" on stdout and spun for minutes on such records
    import numpy as np
    from hammerstein.models.lti import DynamicsIdentifier
    from hammerstein.exceptions import DynamicsError
    rng = np.random.default_rng(1)
    u = rng.standard_normal((1, 400))
    y = np.convolve(u[0], [0.0, 0.5, 0.25])[:400][None, :] * 1e300
    with pytest.raises(DynamicsError, match=r"records\[0\]: outputs: .* is beyond the limit 1e\+150"):
        DynamicsIdentifier(order=2).fit(u, y, 1e-3)
    out, err = capfd.readouterr()
    assert "DLASCL" not in out + err


# -- 11. a numba cache that cannot be written is not a report-write failure -----------------
@pytest.mark.parametrize("code", ["ENOSPC", "EDQUOT", "EROFS"])
def test_11_cache_write_failure_runs_from_memory(monkeypatch, code):
    import errno
    import numba
    import numpy as np
    from numba.core import caching
    from hammerstein.simulation import _compile

    def full(self, key, data):
        raise OSError(getattr(errno, code), os.strerror(getattr(errno, code)))
    monkeypatch.setattr(caching.IndexDataCacheFile, "save", full)
    monkeypatch.setitem(_compile._GUARD, "failed", None)
    notes = []
    _compile.guard_cache_writes(notes.append)
    monkeypatch.setitem(_compile._GUARD, "notify", notes.append)

    @numba.njit(cache=True)
    def triple(x):          # a kernel compiled (and cached) here for the first time
        return 3.0 * x

    @numba.njit(cache=True)
    def quadruple(x):
        return 4.0 * x
    assert triple(np.float64(2.0)) == 6.0 and quadruple(np.float64(2.0)) == 8.0
    assert len(notes) == 1, notes     # one line, not one per kernel
    assert notes[0].startswith("note: cannot write the compiled-kernel cache")
    assert os.strerror(getattr(errno, code)) in notes[0] and "\n" not in notes[0]


def test_11_other_cache_errors_still_propagate(monkeypatch):
    import numba
    import numpy as np
    from numba.core import caching
    from hammerstein.simulation import _compile

    def broken(self, key, data):
        raise OSError(5, "Input/output error")      # EIO: not a full or read-only cache
    monkeypatch.setattr(caching.IndexDataCacheFile, "save", broken)
    monkeypatch.setitem(_compile._GUARD, "failed", None)
    _compile.guard_cache_writes(lambda m: None)

    @numba.njit(cache=True)
    def quintuple(x):
        return 5.0 * x
    with pytest.raises(OSError, match="Input/output"):
        quintuple(np.float64(1.0))


@pytest.mark.slow
def test_11_full_tmpfs_numba_cache_is_one_note(tmp_path):
    # a real full disk: a 64 KiB tmpfs as NUMBA_CACHE_DIR (root only; skipped elsewhere)
    import subprocess
    cache = tmp_path / "cache"
    cache.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs",
                                            str(cache)], capture_output=True).returncode:
        pytest.skip("mounting a tmpfs needs root (CAP_SYS_ADMIN)")
    try:
        proc = _cli(["run", GOOD, "--out", tmp_path / "out"],
                    env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    finally:
        subprocess.run(["umount", str(cache)], capture_output=True)
    err = proc.stderr.splitlines()
    assert proc.returncode == 0, err
    notes = [e for e in err if "compiled-kernel cache" in e]
    assert len(notes) == 1 and "No space left on device" in notes[0]
    assert not [e for e in err if "cannot write the report" in e]
    assert (tmp_path / "out" / "good-static" / "metrics.csv").is_file()


# -- 5. cache entries with zero or negative weights: re-validated, ignored with one note ----
CACHE_SPEC = {"frequency": 50.0, "amplitude": 10.0, "periods": 2, "n_hysterons": 8,
              "method": "least-squares", "partition": "time", "bounds": "monotone"}


@pytest.fixture
def cache_notes(tmp_path, monkeypatch):
    from hammerstein.scenario import diskcache
    monkeypatch.setenv(diskcache.ENV, str(tmp_path / "cache"))
    notes = []
    diskcache.set_reporter(notes.append)
    diskcache._REPORT["said"].clear()
    yield notes
    diskcache.set_reporter(None)


@pytest.mark.parametrize("damage", ["zero", "negative-first", "negative-later", "all-zero"])
def test_5_cache_entry_with_bad_weights_is_ignored(cache_notes, static_plant, damage):
    import json
    from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    from hammerstein.io.presets import model_to_table
    from hammerstein.scenario import diskcache
    from hammerstein.scenario import identification as identified
    model, _ = identified.identified_model(static_plant, CACHE_SPEC)
    table = model_to_table(model)
    (entry,) = diskcache.cache_dir().iterdir()
    data = json.loads(entry.read_text())
    out = next(iter(data["value"]["model"]["components"]))
    inp = next(iter(data["value"]["model"]["components"][out]))
    direct = data["value"]["model"]["components"][out][inp]
    w = direct["weights"]
    direct["weights"] = {"zero": [0.0] + w[1:], "negative-first": [-abs(w[0])] + w[1:],
                         "negative-later": w[:1] + [-2 * sum(w)] + w[2:],
                         "all-zero": [0.0] * len(w)}[damage]
    data["digest"] = diskcache._value_digest(data["value"])     # written by this user's process
    entry.write_text(json.dumps(data))
    before = entry.read_bytes()
    again, _ = identified.identified_model(static_plant, CACHE_SPEC)
    assert model_to_table(again) == table                      # identified again
    InverseMultiplicativeCompensator(again)                     # and usable
    assert len(cache_notes) == 1, cache_notes
    assert cache_notes[0].startswith("note: identification cache entry ignored: ")
    assert entry.name in cache_notes[0] and "is not positive" in cache_notes[0]
    assert entry.read_bytes() == before                         # nothing deleted or rewritten


def test_5_cached_model_problem_closed_forms():
    from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
    from hammerstein.scenario.identification_cache import cached_model_problem

    def model(w):
        return MultivariablePI([[PrandtlIshlinskii([0.0, 1.0, 2.0], w)]], input_amplitude=[5.0])
    monotone = ((("bounds", "monotone"),),)
    assert cached_model_problem(model([1.0, -0.5, 0.2]), monotone) is None      # S = 1, .5, .7
    assert "S_3 = -0.2" in cached_model_problem(model([1.0, -0.5, -0.7]), monotone)
    assert cached_model_problem(model([1.0, -0.5, -0.7]), ((("bounds", "none"),),)) is None
    assert "S_1 = 0" in cached_model_problem(model([0.0, 0.5, 0.2]), ())


# -- 18. files with a UTF-8 byte-order mark read like those without, by every command ---------
BOM = b"\xef\xbb\xbf"


def _bom_inputs(d, bom):
    import numpy as np
    d.mkdir()
    t = np.arange(2000) * 5e-5
    ref = "t,x,y\n" + "".join(f"{float(a)!r},{float(20 * np.sin(2 * np.pi * 50 * a))!r},"
                                 f"{float(10 * np.sin(2 * np.pi * 50 * a + 1))!r}\n" for a in t)
    meas = "t,x,y\n" + "".join(f"{float(a)!r},{float(18 * np.sin(2 * np.pi * 50 * a))!r},"
                                  f"{float(11 * np.sin(2 * np.pi * 50 * a + 1))!r}\n" for a in t)
    drive = "t,ux,uy\n" + "".join(f"{float(a)!r},{float(4 * np.sin(2 * np.pi * 50 * a))!r},"
                                     f"{float(3 * np.sin(2 * np.pi * 50 * a + 1))!r}\n" for a in t)
    texts = {"ref.csv": ref, "meas.csv": meas, "drive.csv": drive, "data.csv": DATA.read_text(),
             "model.toml": (CORPUS / "models" / "preset-static.toml").read_text(),
             "s.toml": GOOD.read_text().replace('name = "good-static"', 'name = "s"')}
    for name, text in texts.items():
        (d / name).write_bytes((BOM if bom else b"") + text.encode())


@pytest.mark.parametrize("argv,output", [
    (["validate", "s.toml"], None),
    (["run", "s.toml", "--out", "out", "--figures", "none"], "out/s/metrics.csv"),
    (["identify", "data.csv", "--time", "time_s", "--input", "u_V", "--output", "y_um",
      "--thresholds", "5", "--out", "m.toml"], "m.toml"),
    (["export", "model.toml", "--target", "c", "--out", "exp", "--no-binary"], "exp/static_1x1_per_axis.c"),
    (["compensate", "rakotondrabe-2dof", "--reference", "ref.csv", "--out", "u.csv"], "u.csv"),
    (["evaluate", "--reference", "ref.csv", "--measured", "meas.csv", "--outputs", "x=x,y=y",
      "--out", "ev"], "ev/metrics.csv"),
    (["learn", "rakotondrabe-2dof", "--reference", "ref.csv", "--drive", "drive.csv",
      "--measured", "meas.csv", "--outputs", "x=x,y=y", "--out", "u1.csv"], "u1.csv"),
])
def test_18_byte_order_mark_is_not_content(capsys, tmp_path, monkeypatch, argv, output):
    results = {}
    for bom in (False, True):
        d = tmp_path / ("bom" if bom else "plain")
        _bom_inputs(d, bom)
        monkeypatch.chdir(d)
        status, out, err = _call(capsys, *argv)
        assert status == 0, err
        results[bom] = (d / output).read_bytes() if output else out
    assert results[True] == results[False]


# -- 18. library warnings and log records: one line each, naming the file, printed once ------
def test_18_stray_warnings_name_the_input_file_once(capsys, monkeypatch):
    import warnings as warnings_
    from hammerstein.cli import identify

    def noisy(args):
        for _ in range(5):   # an overflow inside a loop: printed once
            warnings_.warn("overflow encountered in square", RuntimeWarning)
        warnings_.warn("Polyfit may be poorly\nconditioned", UserWarning)
        return 0
    monkeypatch.setattr(identify, "_handler", noisy)
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--out", "m.toml")
    assert status == 0
    assert err == [f"warning: {DATA}: overflow encountered in square",
                   f"warning: {DATA}: Polyfit may be poorly conditioned"]


def test_18_library_log_records_are_one_line(capsys, monkeypatch):
    import logging
    from hammerstein.cli import listing
    monkeypatch.setattr(logging.getLogger(), "handlers", [])   # as outside pytest

    def noisy(args):
        logging.getLogger("matplotlib").warning("mkdir -p failed for path %s:\n%s", "/x/.config",
                                                "[Errno 13] Permission denied")
        logging.getLogger("matplotlib").info("not shown: below WARNING")
        return 0
    monkeypatch.setattr(listing, "handler", noisy)
    status, _, err = _call(capsys, "list")
    assert status == 0
    assert err == ["warning: hammerstein list: matplotlib: mkdir -p failed for path /x/.config: "
                   "[Errno 13] Permission denied"]
    assert logging.getLogger().handlers == []     # the handler lives only during the command


# -- the column options of the signal-file commands: one definition -------------------------
def test_column_options_are_one_definition():
    from hammerstein.cli.main import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices

    def options(command):
        return {a.option_strings[0]: (a.dest, a.metavar, a.default, a.required, a.nargs)
                for a in sub[command]._actions if a.option_strings
                and a.option_strings[0] in ("--time", "--input-columns", "--output-columns")}
    expected = {"--time": ("time", "COL", "t", False, None),
                "--input-columns": ("inputs", "NAME=COL,...", None, False, None),
                "--output-columns": ("outputs", "NAME=COL,...", None, False, None)}
    for command in ("compensate", "learn", "evaluate"):
        assert options(command) == expected, command


@pytest.mark.parametrize("option", ["--measured", "--reference"])
def test_15_signal_files_beyond_the_limit_are_one_line(capsys, tmp_path, monkeypatch, option):
    # evaluate wrote "max Euclidean error inf" from a measured column of 1e300 µm
    _bom_inputs(tmp_path / "d", False)
    monkeypatch.chdir(tmp_path / "d")
    name = "meas.csv" if option == "--measured" else "ref.csv"
    lines = Path(name).read_text().splitlines()
    cells = lines[3].split(",")
    cells[1] = "3e300"
    lines[3] = ",".join(cells)
    Path(name).write_text("\n".join(lines) + "\n")
    status, _, err = _call(capsys, "evaluate", "--reference", "ref.csv", "--measured", "meas.csv",
                           "--outputs", "x=x,y=y", "--out", "ev")
    assert status == 1 and len(err) == 1, err
    assert "column 'x': value 3e+300 on data row 3 is beyond the limit 1e+150" in err[0]
    assert not Path("ev").exists()
