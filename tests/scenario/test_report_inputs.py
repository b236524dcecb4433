"""A report directory the runner replaces never holds an input, nor a file it did not write.

Regressions of a new user's file-contract check (item 1): ``run``, ``check --out`` and
``replicate`` replaced a marked report directory holding the scenario being run (or a data
file it names, or a user's notes), deleting them. Now a directory holding an input is refused
before any simulation, with or without ``--force``; the marker lists the files the report
wrote (a manifest) and a marked directory holding other files is replaced only with
``--force``; a marker without a manifest (an older report) is replaced as before.
"""

import contextlib
import io
import os
import shutil
from pathlib import Path

import pytest

from hammerstein.cli.main import main
from hammerstein.core.files import reset_guard
from hammerstein.runner import MARKER, run_pipelined

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good" / "good-static.toml"
IDENT = CORPUS / "good" / "good-identification.toml"


def _tree(path):
    """Every file under ``path`` with its bytes, links not followed."""
    out = {}
    for d, dirs, names in os.walk(path):
        for n in dirs + names:
            p = os.path.join(d, n)
            out[os.path.relpath(p, path)] = (None if os.path.isdir(p) or os.path.islink(p)
                                             else Path(p).read_bytes())
    return out


def _run(paths, out, force=False):
    return run_pipelined(paths, out, force, figures=lambda p: False)


def _cli(*args):
    reset_guard()
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    reset_guard()
    return code, out.getvalue(), [ln for ln in err.getvalue().splitlines()
                                  if not ln.startswith("compiling")]


def _marked_report(tmp_path, name="good-static"):
    """An older report directory ``rep/<name>`` (a marker without a manifest)."""
    report = tmp_path / "rep" / name
    report.mkdir(parents=True)
    (report / MARKER).write_text("hammerstein 0.1.0\n")
    return report


def _scenario_in_report(tmp_path):
    """The good scenario copied into the report directory its run would replace."""
    scenario = _marked_report(tmp_path) / "s.toml"
    shutil.copy(GOOD, scenario)
    return scenario


@pytest.mark.parametrize("force", [False, True])
def test_the_scenario_inside_the_report_it_replaces_is_refused(tmp_path, force):
    scenario = _scenario_in_report(tmp_path)
    before = _tree(tmp_path)
    [outcome] = _run([scenario], tmp_path / "rep", force)
    assert not outcome.ok and str(scenario) in outcome.error and len(outcome.error.splitlines()) == 1
    assert "which this scenario reads" in outcome.error
    assert _tree(tmp_path) == before              # the scenario is still there, nothing written


def test_run_cli_refuses_its_own_scenario_in_the_report(tmp_path):
    scenario = _scenario_in_report(tmp_path)
    before = _tree(tmp_path)
    code, out, err = _cli("run", scenario, "--out", tmp_path / "rep", "--figures", "none", "--force")
    assert code == 1 and out == "" and len(err) == 1 and str(scenario) in err[0], err
    assert "Traceback" not in err[0]
    assert _tree(tmp_path) == before


def test_a_hard_link_to_the_scenario_inside_the_report_is_refused(tmp_path):
    scenario = tmp_path / "s.toml"
    shutil.copy(GOOD, scenario)
    os.link(scenario, _marked_report(tmp_path) / "kept.toml")
    before = _tree(tmp_path)
    [outcome] = _run([scenario], tmp_path / "rep", force=True)
    assert not outcome.ok and "kept.toml" in outcome.error and "hard link" in outcome.error
    assert _tree(tmp_path) == before


def test_a_data_file_the_scenario_names_inside_the_report_is_refused(tmp_path):
    report = _marked_report(tmp_path, "good-identification")
    shutil.copy(CORPUS / "data" / "good.csv", report / "good.csv")
    scenario = tmp_path / "s.toml"
    scenario.write_text(IDENT.read_text().replace('"../data/good.csv"',
                                                  '"rep/good-identification/good.csv"'))
    before = _tree(tmp_path)
    [outcome] = _run([scenario], tmp_path / "rep", force=True)
    assert not outcome.ok and "good.csv" in outcome.error and "reads" in outcome.error, outcome.error
    assert _tree(tmp_path) == before


def test_the_manifest_protects_files_added_to_a_report(tmp_path):
    out = tmp_path / "rep"
    [first] = _run([GOOD], out)
    assert first.ok
    marker = (out / "good-static" / MARKER).read_text().splitlines()
    assert "manifest" in marker and "file metrics.csv" in marker and "file report.md" in marker
    notes = out / "good-static" / "notes.txt"
    notes.write_text("my notes")
    before = _tree(tmp_path)
    [second] = _run([GOOD], out)
    assert not second.ok and "notes.txt" in second.error and "--force" in second.error
    assert _tree(tmp_path) == before
    [forced] = _run([GOOD], out, force=True)
    assert forced.ok and not notes.exists()
    [again] = _run([GOOD], out)              # a fresh report: replaced as before
    assert again.ok


def test_a_marker_without_manifest_is_replaced_as_before(tmp_path):
    out = tmp_path / "rep"
    report = out / "good-static"
    report.mkdir(parents=True)
    (report / MARKER).write_text("hammerstein 0.1.0\n")     # an older report
    (report / "metrics.csv").write_text("stale")
    [outcome] = _run([GOOD], out)
    assert outcome.ok and (report / "metrics.csv").read_text() != "stale"
