"""The CLI end to end: every bundled scenario into a temporary directory,
report contents, the paper's numbers, exit codes and atomic output."""

import os
from pathlib import Path

import pandas as pd
import pytest

from hammerstein.cli.main import main
from hammerstein.io.presets import read_toml

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = sorted(p for p in (ROOT / "scenarios").rglob("*.toml")
                 if "presets" not in p.relative_to(ROOT / "scenarios").parts)   # preset files


@pytest.fixture
def reports(bundled_reports):
    """``hammerstein run`` of every bundled scenario (``BUNDLED``; tests/conftest.py runs the
    same list once per session, also for tests/report/test_every_figure.py)."""
    assert bundled_reports.paths == BUNDLED
    return bundled_reports.out, bundled_reports.status


def _metric(out, scenario, case, channel, metric):
    m = pd.read_csv(out / scenario / "metrics.csv")
    sel = m[(m.case == case) & (m.channel == channel) & (m.metric == metric)]
    assert len(sel) == 1, (scenario, case, channel, metric)
    return float(sel.value.iloc[0])


@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
def test_every_bundled_scenario_runs(reports):
    out, status = reports
    assert status == 0
    for path in BUNDLED:
        d = out / path.stem
        m = pd.read_csv(d / "metrics.csv")
        assert list(m.columns) == ["case", "channel", "metric", "value", "unit"]
        assert m.value.notna().all()
        assert (d / "report.md").is_file() and list(d.glob("*.png"))
        plant_cols = {"time_s", "ux_V", "uy_V", "x_um", "y_um"}
        if read_toml(path).get("kind", "cases") != "cases":  # e.g. a measured record
            plant_cols = {"time_s"}
        for case in m.case.unique():
            if not (d / f"timeseries-{case}.csv").exists() and (
                    list(d.glob("sweep-*.csv")) or list(d.glob("montecarlo-*.csv"))):
                continue  # sweep cases write sweep-<name>.csv, Monte-Carlo studies their quantiles
            ts = pd.read_csv(d / f"timeseries-{case}.csv")
            assert plant_cols <= set(ts.columns)
        text = (d / "report.md").read_text(encoding="utf-8")
        for png in d.glob("*.png"):
            assert f"]({png.name})" in text
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary dirs left


@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
@pytest.mark.parametrize("case, channel, metric, paper", [
    ("ux-50Hz-static", "x", "peak_to_peak", 2 * 58.0),
    ("uy-50Hz-static", "y", "peak_to_peak", 2 * 50.5),
    ("ux-50Hz-static", "x", "hysteresis_ratio", 17.0),
    ("uy-50Hz-static", "y", "hysteresis_ratio", 15.8),
    ("uy-50Hz-static", "x", "cross_coupling_peak_to_peak", 3.0),
    ("ux-50Hz-static", "y", "cross_coupling_peak_to_peak", 4.0),
])
def test_fig05_numbers_within_10_percent(reports, case, channel, metric, paper):
    out, _ = reports
    value = _metric(out, "fig05-characterization", case, channel, metric)
    assert value == pytest.approx(paper, rel=0.10)


@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
def test_fig05_rate_dependency_loops_widen_with_frequency(reports):
    out, _ = reports
    widths = [_metric(out, "fig05-characterization", f"ux-{f}Hz", "x", "hysteresis_width")
              for f in (50, 100, 150, 200)]
    assert widths == sorted(widths) and widths[-1] > 2 * widths[0]


@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
@pytest.mark.parametrize("case, direct, cross, cross_limit", [
    ("x-axis-static", "x", "y", 0.5),   # paper: (x_r, y) about ±0.25 µm
    ("y-axis-static", "y", "x", 0.4),   # paper: (y_r, x) about ±0.2 µm
])
def test_fig08_static_plant_is_linearised_and_decoupled(reports, case, direct, cross, cross_limit):
    out, _ = reports
    rms = _metric(out, "fig08-compensated-sine", case, direct, "rms_error")
    assert rms < 0.01 * 50.0
    assert _metric(out, "fig08-compensated-sine", case, cross,
                   "cross_coupling_peak_to_peak") < cross_limit


@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
def test_literal_law_reported_as_diverged(reports):
    out, _ = reports
    t = _metric(out, "literal-law-divergence", "literal-K-identity", "x+y", "diverged_at_time")
    assert 0 < t < 20 * 5e-5  # within twenty samples
    m = pd.read_csv(out / "literal-law-divergence" / "metrics.csv")
    assert set(m[m.case == "literal-K-identity"].metric) == {"diverged_at_time"}
    assert _metric(out, "literal-law-divergence", "normalised-K-secant", "x", "rms_error") < 0.5
    text = (out / "literal-law-divergence" / "report.md").read_text(encoding="utf-8")
    assert "DIVERGED at sample" in text


def test_failing_scenario_leaves_nothing_and_others_run(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[plant]\npreset = 'rakotondrabe-2dof'\n[[cases]]\nname = 'a'\n"
                   "drive = { kind = 'sine', input = 'ux', amplitude = -1.0, frequency = 50.0, "
                   "periods = 2 }\n", encoding="utf-8")
    out = tmp_path / "out"
    # the figures are not what this is about: none drawn
    status = main(["run", str(bad), str(ROOT / "scenarios" / "default.toml"), "--out", str(out),
                   "--figures", "none"])
    assert status == 1
    captured = capsys.readouterr()
    # default.toml's 50 Hz references on the Hammerstein plant warn (rate-independent compensator)
    err_lines = [l for l in captured.err.strip().splitlines() if not l.startswith("warning:")]
    assert len(err_lines) == 1 and "amplitude" in err_lines[0]
    assert sorted(p.name for p in out.iterdir()) == ["default"]
    assert "default" in captured.out


def test_rerun_replaces_the_report_atomically(tmp_path):
    out = tmp_path / "out"
    default = str(ROOT / "scenarios" / "default.toml")
    # the first run only has to leave a report of ours to replace: no figures needed
    assert main(["run", default, "--out", str(out), "--figures", "none"]) == 0
    first = os.stat(out / "default" / "metrics.csv").st_ino    # a file the report wrote
    assert main(["run", default, "--out", str(out)]) == 0
    assert os.stat(out / "default" / "metrics.csv").st_ino != first       # written anew
    assert (out / "default" / "report.md").read_text().count("![") > 0    # with its figures
    assert sorted(p.name for p in out.iterdir()) == ["default"]


def test_validate_and_exit_codes(tmp_path, capsys):
    assert main(["validate", str(ROOT / "scenarios" / "default.toml")]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("[plant]\npresett = 'x'\n", encoding="utf-8")
    assert main(["validate", str(bad)]) == 1
    err = capsys.readouterr().err
    assert "presett: unknown key (did you mean 'preset'?)" in err
    assert "cases: missing (required)" in err
    assert main(["run"]) == 2          # usage error
    assert main(["no-such-command"]) == 2


def test_list_shows_presets_and_scenarios(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert main(["list"]) == 0
    text = capsys.readouterr().out
    assert "rakotondrabe-2dof" in text and "multivariable" in text
    assert "fig08-compensated-sine.toml" in text
    scenarios, _, others = text.partition("preset and dynamics files")
    assert "coupled-2dof.toml" in others and "coupled-2dof.toml" not in scenarios
    assert "fn+5.toml; dynamics only" in others


def test_list_reports_the_dc_gain_of_a_preset_file(capsys, monkeypatch):
    """coupled-2dof.toml says its G(0) is reported by `hammerstein list`: it is."""
    monkeypatch.chdir(ROOT)
    assert main(["list"]) == 0
    _, _, others = capsys.readouterr().out.partition("preset and dynamics files")
    line = next(ln for ln in others.splitlines() if "coupled-2dof.toml" in ln)
    assert "DC gain [[1.08, -0.06], [0.08, 0.94]]" in line      # B and C of the file


def test_help_imports_no_heavy_module():
    """`hammerstein --help` builds its parser without the numerical stack.

    The package's own ``__init__`` is bypassed (an empty package object), so
    this checks what the CLI itself imports.
    """
    import subprocess
    import sys
    code = (
        "import sys, types\n"
        f"pkg = types.ModuleType('hammerstein'); pkg.__path__ = [{str(ROOT / 'hammerstein')!r}]\n"
        "sys.modules['hammerstein'] = pkg\n"
        "from hammerstein.cli.main import main\n"
        "status = main(['--help'])\n"
        "heavy = sorted(m for m in ('pandas', 'matplotlib', 'numba', 'control', 'tqdm', 'scipy', 'numpy')"
        " if m in sys.modules)\n"
        "print(status, ','.join(heavy) or '-')\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    last = res.stdout.strip().splitlines()[-1]
    assert last == "0 -", last
    for name in ("run", "validate", "list", "identify", "check", "replicate"):
        assert name in res.stdout


def test_command_table_help_matches_each_command_parser():
    from hammerstein.cli.main import COMMANDS, build_parser
    parser = build_parser()  # every command in full
    sub = next(a for a in parser._actions if a.dest == "command")
    helps = {a.dest: a.help for a in sub._choices_actions}
    assert helps == {name: text for name, (_, text) in COMMANDS.items()}


@pytest.mark.parametrize("name, status, out, err", [
    ("validate-ok", 0, "default.toml", ""),
    ("validate-missing", 1, "", "no-such-file.toml"),
    ("usage", 2, "", "SCENARIO"),
])
def test_console_script_keeps_status_and_output(forked_cli, name, status, out, err):
    """`python -m hammerstein` (the console script's :func:`run`): same status and
    complete output although the process ends with os._exit (one process per
    command: tests/cli/conftest.py)."""
    res = forked_cli[0][f"console-{name}"]
    assert res["status"] == status, res["stderr"]
    assert out in res["stdout"] and res["stdout"].endswith("\n") == bool(res["stdout"])
    assert err in res["stderr"] and len(res["stderr"].splitlines()) == bool(err)


def test_closed_pipe_is_not_an_error_message(forked_cli):
    """`hammerstein list | head -c 10`: the reader leaves early; no error line."""
    res = forked_cli[0]["list-head"]
    assert res["status"] in (0, 1), res             # 1: `list` could not say everything
    assert "Error" not in res["stderr"] and "error" not in res["stderr"], res["stderr"]


@pytest.mark.parametrize("argv, command", [
    (["evaluate", "--reference", "r.csv", "--measured", "m.csv", "--out", "ev", "--force"], "evaluate"),
    (["list", "--figures"], "list"),
])
def test_an_unknown_option_is_the_commands_usage_error(capsys, argv, command):
    # it read "hammerstein: error: unrecognized arguments ... (see 'hammerstein --help')"
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"hammerstein {command}: error: unrecognized arguments")
    assert err[0].endswith(f"(see 'hammerstein {command} --help')")
