"""Hostile checks of the outputs (issue 13 QA): what sits at or next to an output path.

Each test is a defect found by trying the commands as a hostile user would:
a user's directory that only looks like a stale temporary, a read-only or
looping target, and a replication directory holding a README or tables
``hammerstein replicate`` did not write.
"""

import os
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hammerstein.cli.main import main
from hammerstein.core.files import FileLimitError, safe_write
from hammerstein.report.replication import GENERATED, README_MARK, foreign_outputs
from hammerstein.runner import MARKER, TMP_PREFIX, remove_stale_temporaries
from snapshots import tree_snapshot

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good" / "good-static.toml"
IDENTIFY = [str(CORPUS / "data" / "good.csv"), "--time", "time_s", "--input", "u_V",
            "--output", "y_um", "--thresholds", "5"]


def _call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err.splitlines()


def _dead_pid():
    pid = 4_000_000
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return pid
        except PermissionError:
            pass
        pid += 1


def test_stale_cleanup_keeps_a_directory_whose_marker_is_a_directory(tmp_path):
    # a user's directory named like a temporary, holding a *directory* named like the marker:
    # not a report (the marker is a file), so nothing of it may go
    user = tmp_path / f"{TMP_PREFIX}{_dead_pid()}.mine"
    (user / MARKER).mkdir(parents=True)
    (user / "thesis.tex").write_text("precious")
    old = time.time() - 3600
    os.utime(user / MARKER, (old, old))
    os.utime(user, (old, old))
    before = tree_snapshot(tmp_path)
    assert remove_stale_temporaries(tmp_path) == []
    assert tree_snapshot(tmp_path) == before


def test_safe_write_refuses_a_read_only_target(tmp_path):
    target = tmp_path / "model.toml"
    target.write_text("mine")
    target.chmod(0o444)
    with pytest.raises(FileLimitError, match="read-only"):
        safe_write(target, "new")
    assert target.read_text() == "mine" and stat.S_IMODE(target.stat().st_mode) == 0o444
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.toml"]  # no temporary left


@pytest.mark.parametrize("option", ["--out", "--metrics", "--plot"])
def test_identify_refuses_a_read_only_target_even_with_force(capsys, tmp_path, option):
    target = tmp_path / "target"
    target.write_text("mine")
    target.chmod(0o444)
    outputs = {"--out": tmp_path / "m.toml", "--metrics": tmp_path / "m.csv", "--plot": tmp_path / "p.png"}
    outputs[option] = target
    args = [a for o, p in outputs.items() for a in (o, p)]
    before = tree_snapshot(tmp_path)
    status, _, err = _call(capsys, "identify", *IDENTIFY, *args, "--force")
    assert status == 2 and len(err) == 1
    assert err[0].startswith(f"hammerstein identify: error: {option}:") and "read-only" in err[0]
    assert tree_snapshot(tmp_path) == before


def test_identify_symlink_loop_is_a_usage_error(capsys, tmp_path):
    loop = tmp_path / "model.toml"
    loop.symlink_to(loop)
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--out", loop)
    assert status == 2 and len(err) == 1
    assert err[0].startswith("hammerstein identify: error: --out:") and "symbolic link" in err[0]
    assert "Error" not in err[0]
    assert os.readlink(loop) == str(loop) and sorted(p.name for p in tmp_path.iterdir()) == ["model.toml"]


def test_check_update_refuses_a_read_only_baseline(capsys, tmp_path):
    baseline = tmp_path / "b.csv"
    baseline.write_text("scenario,case,channel,metric,value,unit\n")
    baseline.chmod(0o444)
    before = tree_snapshot(tmp_path)
    status, _, err = _call(capsys, "check", GOOD, "--baseline", baseline, "--update")
    assert status == 2 and len(err) == 1 and "read-only" in err[0]
    assert err[0].startswith("hammerstein check: error:")
    assert tree_snapshot(tmp_path) == before


# -- replicate: OUT/README.md and its tables -------------------------------------------------
def test_foreign_outputs_of_a_replication_directory(tmp_path):
    assert foreign_outputs(tmp_path / "missing") == [] and foreign_outputs(tmp_path) == []
    (tmp_path / "README.md").write_text("# my notes\n")
    (tmp_path / "paper-numbers.csv").write_text("a,b\n")
    problems = foreign_outputs(tmp_path)
    assert len(problems) == 2 and all("not written by hammerstein replicate" in p for p in problems)
    (tmp_path / "README.md").write_text(f"# Replication\n\n{README_MARK} from ...\n")
    assert foreign_outputs(tmp_path) == []  # written by replicate: its tables too
    os.mkfifo(tmp_path / "fig07-trends.csv")
    assert foreign_outputs(tmp_path) == [f"{tmp_path / 'fig07-trends.csv'}: exists and is not "
                                         f"a regular file"]


@pytest.mark.parametrize("kind", ["user-readme", "fifo-table", "readme-to-devnull"])
def test_replicate_never_replaces_a_readme_it_did_not_write(capsys, tmp_path, kind):
    scenarios = tmp_path / "scenarios"
    scenarios.mkdir()
    (scenarios / "good-static.toml").write_bytes(GOOD.read_bytes())
    out = tmp_path / "out"
    out.mkdir()
    if kind == "user-readme":
        (out / "README.md").write_text("# my thesis notes\n")
    elif kind == "fifo-table":  # a FIFO would block a plain write forever
        (out / "README.md").write_text(f"{README_MARK}\n")
        os.mkfifo(out / "paper-numbers.csv")
    else:
        (out / "README.md").symlink_to(os.devnull)
    before = tree_snapshot(tmp_path)
    status, stdout, err = _call(capsys, "replicate", "--scenarios", scenarios, "--out", out)
    assert status == 2 and stdout == "" and len(err) == 1, err
    assert err[0].startswith("hammerstein replicate: error:") and "--force" in err[0]
    assert tree_snapshot(tmp_path) == before  # nothing ran, nothing written


@pytest.mark.slow
def test_replicate_replaces_its_own_readme_and_force_replaces_a_users(capsys, tmp_path):
    scenarios = tmp_path / "scenarios"
    scenarios.mkdir()
    (scenarios / "good-static.toml").write_bytes(GOOD.read_bytes())
    out = tmp_path / "out"
    out.mkdir()
    (out / "README.md").write_text("# my thesis notes\n")
    (out / "README.md").chmod(0o640)
    assert _call(capsys, "replicate", "--scenarios", scenarios, "--out", out, "--force")[0] == 0
    text = (out / "README.md").read_text()
    assert README_MARK in text and stat.S_IMODE((out / "README.md").stat().st_mode) == 0o640
    status, stdout, err = _call(capsys, "replicate", "--scenarios", scenarios, "--out", out)
    assert status == 0, err  # its own README: replaced without --force
    # stdout names every file written beside the README, as it is on disk
    beside = [n for n in GENERATED if n != "README.md" and (out / n).is_file()]
    assert beside and stdout.splitlines()[-1] == (f"wrote {out / 'README.md'} and, beside it, "
                                                  f"{', '.join(beside)}")
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != "good-static"]


# -- limits overridden by the environment -----------------------------------------------------
def test_a_limit_override_that_is_not_a_number_is_named(capsys, tmp_path, monkeypatch):
    # HAMMERSTEIN_MAX_SAMPLES=abc was ignored silently: the message said "raise
    # HAMMERSTEIN_MAX_SAMPLES" to a user who believed they had
    monkeypatch.setenv("HAMMERSTEIN_MAX_SAMPLES", "abc")
    scenario = tmp_path / "s.toml"
    text = GOOD.read_text().replace("periods = 2", "periods = 4000")  # 1.6e6 samples a case
    scenario.write_text(text + text[text.index("[[cases]]"):].replace('name = "', 'name = "more-'))
    status, _, err = _call(capsys, "validate", scenario)
    assert status == 1 and any("HAMMERSTEIN_MAX_SAMPLES" in e and "'abc' is not a positive integer"
                               in e for e in err), err
    monkeypatch.setenv("HAMMERSTEIN_MAX_TOML_BYTES", "4k")
    big = tmp_path / "big.toml"
    big.write_text(GOOD.read_text() + "#" * (5 * 2**20))
    status, _, err = _call(capsys, "validate", big)
    assert status == 1 and len(err) == 1
    assert "HAMMERSTEIN_MAX_TOML_BYTES=BYTES" in err[0] and "'4k' is not a positive integer" in err[0]


# -- huge numbers on the identify command line ------------------------------------------------
@pytest.mark.parametrize("extra, expected", [
    (["--thresholds", "99999999999999999999"], "--thresholds: expected 1 <= N <= 100"),
    (["--thresholds", ",".join(str(i) for i in range(101))], "--thresholds: expected at most 100"),
])
def test_identify_huge_threshold_counts_are_usage_errors(capsys, tmp_path, extra, expected):
    # was "unexpected ValueError: Maximum allowed size exceeded" (exit 1)
    args = [a for a in IDENTIFY if a not in ("--thresholds", "5")]
    status, _, err = _call(capsys, "identify", *args, *extra, "--out", tmp_path / "m.toml")
    assert status == 2 and len(err) == 1 and expected in err[0], err
    assert list(tmp_path.iterdir()) == []


def test_identify_huge_skip_is_a_one_line_error(capsys, tmp_path):
    # --skip 1e308 s over a 1 ms sampling period was "unexpected OverflowError" (exit 1)
    status, _, err = _call(capsys, "identify", *IDENTIFY, "--skip", "1e308", "--out", tmp_path / "m.toml")
    assert status == 1 and len(err) == 1 and "burn-in shorter than the record" in err[0], err
    assert "1e+308 s" in err[0] and "Error" not in err[0]
    assert list(tmp_path.iterdir()) == []


def test_deeply_nested_tolerance_and_model_files_are_one_line_errors(tmp_path):
    # the TOML parser recursed into RecursionError ("unexpected RecursionError" in the CLI)
    from hammerstein.io.presets import PresetError, read_toml
    from hammerstein.scenario.regression import BaselineError, load_tolerances
    nested = tmp_path / "nested.toml"
    nested.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(BaselineError, match="nested too deeply"):
        load_tolerances(nested)
    with pytest.raises(PresetError, match="nested too deeply"):
        read_toml(nested)


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_FSIZE as on the lab's Linux hosts")
def test_a_report_that_cannot_be_written_is_named_where_it_was_to_go(tmp_path):
    """Under a file-size limit `run` named the report's temporary directory
    (`.hammerstein-tmp.<pid>...`), a place the user never asked for; it names the report's
    own place now, and leaves nothing in --out."""
    import resource
    default = Path(__file__).resolve().parents[2] / "scenarios" / "default.toml"

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (40 * 1024, 40 * 1024))
    res = subprocess.run([sys.executable, "-m", "hammerstein", "run", str(default), "--out",
                          "out", "-q"], cwd=tmp_path, capture_output=True, text=True,
                         preexec_fn=limited, timeout=600)
    assert res.returncode == 1, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert "cannot write the report: out/default/" in lines[0], lines[0]
    assert ".hammerstein-tmp" not in lines[0]
    assert list((tmp_path / "out").iterdir()) == []


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_FSIZE as on the lab's Linux hosts")
@pytest.mark.parametrize("limit_kb", [4, 14])
def test_an_fmu_that_cannot_be_built_is_named_as_the_users(tmp_path, limit_kb):
    """Under a file-size limit `export --target fmu` named the temporary build directory
    (`/tmp/hammerstein-fmu-.../NAME.h: cannot write the C source`), a place the user never
    asked for; it now says the FMU's binary cannot be built, why, and that --no-binary
    writes the sources only, and leaves nothing in --out. At 4 KB the sources do not fit;
    at 14 KB they do and the compiler is killed writing its object (no message of its own)."""
    import resource
    from hammerstein.export.fmu import find_compiler
    if find_compiler() is None:
        pytest.skip("no C compiler: no binary is built")

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_kb * 1024, limit_kb * 1024))
    res = subprocess.run([sys.executable, "-m", "hammerstein", "export", "rakotondrabe-2dof",
                          "--target", "fmu", "--out", "out"], cwd=tmp_path, capture_output=True,
                         text=True, preexec_fn=limited, timeout=600)
    lines = [ln for ln in res.stderr.splitlines() if not ln.startswith("note:")]
    assert res.returncode == 1, res.stderr
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert "hammerstein-fmu-" not in lines[0], lines[0]
    if limit_kb == 4:
        assert "binary cannot be built" in lines[0] and "--no-binary" in lines[0], lines[0]
    else:   # another compiler's object may fit, and then the archive is what cannot be written
        assert ("compiler" in lines[0] and "--no-binary" in lines[0]) or "out/" in lines[0], \
            lines[0]
    assert not (tmp_path / "out").exists() or list((tmp_path / "out").iterdir()) == []
