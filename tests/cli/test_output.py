"""Quiet, useful output: grouped warnings, -q/-v, --version, readable reports, JUnit XML."""

import textwrap
import xml.etree.ElementTree as ET

import pandas as pd
import pytest

from hammerstein.cli.main import build_parser, main
from hammerstein.report.messages import group_warnings, message_template
from hammerstein.report.scenario import compensator_summary, signal_summary

_SCENARIO = """
name = "w"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
check = "warn"
[[cases]]
name = "a"
reference = { kind = "triangle", output = "x", amplitude = 150.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "b"
reference = { kind = "triangle", output = "x", amplitude = 160.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "c"
reference = { kind = "triangle", output = "x", amplitude = 170.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "d"
reference = { kind = "triangle", output = "x", amplitude = 180.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "open"
drive = { kind = "triangle", input = "ux", amplitude = 5.0, frequency = 50.0, periods = 2 }
"""


def test_group_warnings_by_template_with_ranges():
    pairs = [("s-10Hz", "gain: rho reaches 1.02 >= 1 (see docs/compensator.md)"),
             ("s-20Hz", "gain: rho reaches 1.03 >= 1 (see docs/compensator.md)"),
             ("s-20Hz", "gain: rho reaches 1.03 >= 1 (see docs/compensator.md)"),
             ("s-30Hz", "gain:  rho reaches 1.02 >= 1\n(see docs/compensator.md)"),
             ("other", "reference: beyond the range on y")]
    groups = group_warnings(pairs)
    assert [g.count for g in groups] == [3, 1]
    assert groups[0].cases == ["s-10Hz", "s-20Hz", "s-30Hz"]
    assert groups[0].message == "gain: rho reaches 1.02\u20131.03 >= 1 (see docs/compensator.md)"
    assert groups[0].line("f.toml") == f"f.toml: 3 cases (s-10Hz, s-20Hz, s-30Hz): {groups[0].message}"
    assert groups[0].line("f.toml", names=2).startswith("f.toml: 3 cases: gain")
    assert groups[1].line("f.toml") == "f.toml: other: reference: beyond the range on y"
    assert message_template("x 1.5e-3 y 2") == "x # y #"


@pytest.fixture
def scenario(tmp_path):
    path = tmp_path / "w.toml"
    path.write_text(_SCENARIO)
    return path


def test_run_prints_one_line_per_distinct_warning(scenario, tmp_path, capsys):
    assert main(["run", str(scenario), "--out", str(tmp_path / "r"), "--figures", "none"]) == 0
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"warning: {scenario}: 4 cases: reference: ")
    assert "150\u2013180 µm" in lines[0]
    # report.md and warnings.csv keep the detail per case
    w = pd.read_csv(tmp_path / "r" / "w" / "warnings.csv")
    assert sorted(w["case"]) == ["a", "b", "c", "d"]
    report = (tmp_path / "r" / "w" / "report.md").read_text()
    assert "160 µm" in report and "{'" not in report
    assert "triangle on x, 150 µm, 50 Hz, 2 periods" in report


def test_run_verbose_and_quiet(scenario, tmp_path, capsys):
    # what is printed, not the figures: none drawn
    assert main(["run", "-v", str(scenario), "--out", str(tmp_path / "r"), "--figures", "none"]) == 0
    out, err = capsys.readouterr()
    assert sum(line.startswith("warning:") for line in err.splitlines()) == 4
    assert "running" in err and " s" in out
    assert main(["run", "-q", str(scenario), "--out", str(tmp_path / "r"), "--figures", "none"]) == 0
    out, err = capsys.readouterr()
    assert out == "" and err == ""
    assert main(["run", "-q", "-v", str(scenario)]) == 2        # exclusive


def test_version(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    import hammerstein
    assert out.strip() == f"hammerstein {hammerstein.__version__}"


def test_summaries_show_only_what_applies():
    ident = {"frequency": 50.0, "amplitude": 10.0, "n_hysterons": 15, "method": "least-squares"}
    plant = compensator_summary({"kind": "multivariable", "model": "plant", "identify": ident,
                                 "gain": "secant", "iterations": 1, "check": "error",
                                 "cutoff_hz": 500.0})
    assert plant == "multivariable: plant model, secant gain, 1 iteration"
    idd = compensator_summary({"kind": "multivariable", "model": "identified", "identify": ident,
                               "gain": "midpoint", "iterations": 2, "feedback": "lowpass",
                               "cutoff_hz": 500.0, "check": "warn"})
    assert "identified at 50 Hz, 10 V (15 hysterons, least-squares)" in idd
    assert "low-pass feedback at 500 Hz" in idd and "2 iterations" in idd
    assert compensator_summary({"kind": "per-axis", "model": "plant"}) == "per-axis: plant model"
    assert signal_summary("reference", {"kind": "sine", "output": "x", "amplitude": 50.0,
                                        "frequency": 50.0, "periods": 5}) \
        == "sine on x, 50 µm, 50 Hz, 5 periods"
    assert signal_summary("drive", {"kind": "triangle", "input": "ux", "amplitude": 10.0,
                                    "frequency": 25.0, "phase": 90.0, "duration": 0.2}) \
        == "triangle on ux, 10 V, 25 Hz, phase 90 °, 0.2 s"
    text = signal_summary("reference", {"kind": "raster", "outputs": ["x", "y"],
                                        "size": [40.0, 30.0], "lines": 12, "frequency": 25.0,
                                        "slow": "step", "smoothing": 0.1})
    assert "40 × 30 µm" in text and "12 lines" in text and "{" not in text


def _baseline(tmp_path, scenario, capsys):
    base = tmp_path / "base.csv"
    assert main(["check", str(scenario), "--baseline", str(base), "--update"]) == 0
    capsys.readouterr()
    return base


def test_check_junit_xml_pass_and_failure(scenario, tmp_path, capsys):
    base = _baseline(tmp_path, scenario, capsys)
    junit = tmp_path / "junit.xml"
    assert main(["check", str(scenario), "--baseline", str(base), "--junit-xml", str(junit),
                 "-q"]) == 0
    assert capsys.readouterr().out == ""                        # quiet: nothing on a pass
    root = ET.parse(junit).getroot()
    cases = root.findall(".//testcase")
    assert [c.get("name") for c in cases] == ["w"]
    assert cases[0].find("failure") is None and root.get("failures") == "0"
    # make two metrics regress: the baseline says the errors were smaller
    frame = pd.read_csv(base, keep_default_na=False, comment="#")
    hit = (frame["case"] == "a") & (frame["metric"] == "rms_error") & (frame["channel"] == "x")
    hit |= (frame["case"] == "open") & (frame["metric"] == "peak_to_peak") & (frame["channel"] == "x")
    old = frame.loc[hit, "value"].astype(float).tolist()
    frame.loc[hit, "value"] = [v / 10 for v in old]
    frame.to_csv(base, index=False)
    # a second scenario that fails to run is an <error>
    bad = tmp_path / "bad.toml"
    bad.write_text(_SCENARIO.replace('name = "w"', 'name = "bad"').replace("triangle", "triangel"))
    assert main(["check", str(scenario), str(bad), "--baseline", str(base),
                 "--junit-xml", str(junit)]) == 1
    root = ET.parse(junit).getroot()
    suite = root.find("testsuite")
    assert suite.get("tests") == "2" and suite.get("failures") == "1" and suite.get("errors") == "1"
    w, b = suite.findall("testcase")
    fail = w.find("failure")
    assert "rms_error of a/x" in fail.get("message") and "peak_to_peak of open/x" in fail.get("message")
    assert f"baseline {old[0] / 10:.6g} -> current {old[0]:.6g}" in fail.text \
        or f"baseline {old[1] / 10:.6g} -> current {old[1]:.6g}" in fail.text
    assert b.find("error") is not None and "triangel" in b.find("error").text


def test_group_warnings_folds_quoted_names_into_a_list():
    """The dynamics warning of each rate-independent kind in a sweep: one line, every kind."""
    msg = ("compensator kind = {!r} is rate independent: at {} Hz the plant's linear dynamics "
           "(first resonance 290 Hz) change the response by {} %, which it does not compensate")
    pairs = [("a", msg.format("multivariable", 50, 8.5)), ("b", msg.format("per-axis", 50, 8.5)),
             ("c", msg.format("static-gain", 420, 334.5)), ("d", msg.format("per-axis", 50, 8.5))]
    (group,) = group_warnings(pairs)
    assert group.cases == ["a", "b", "c", "d"]
    assert group.message == msg.format("multivariable", 50, 8.5).replace(
        "'multivariable'", "'multivariable'/'per-axis'/'static-gain'").replace(
        "50 Hz", "50\u2013420 Hz").replace("8.5 %", "8.5\u2013334.5 %")
    # the digits of a quoted name stay in the name; names and numbers never mix
    assert message_template("kind = 'mv-50Hz' at 50 Hz") == "kind = '?' at # Hz"
    assert len(group_warnings([("a", "x 'one' 2"), ("b", "x 3 'two'")])) == 2


@pytest.mark.parametrize("values, merged", [
    (("-0.7448", "-0.7531"), "ux needs -0.7531 to -0.7448 V"),
    (("0.5", "0.7"), "ux needs 0.5\u20130.7 V"),
])
def test_merged_negative_numbers_keep_their_signs(values, merged):
    """Folded warnings show a range of negative numbers with both signs, lowest first (it
    read "-0.7448–0.7531", as if from -0.74 to +0.75); K^-1's minus stays text."""
    from hammerstein.report.messages import group_warnings
    groups = group_warnings([(f"c{i}", f"ux needs {v} V") for i, v in enumerate(values)])
    assert [g.message for g in groups] == [merged]
    groups = group_warnings([("a", "rho(I - K^-1 J) reaches 1.02"),
                             ("b", "rho(I - K^-1 J) reaches 1.03")])
    assert groups[0].message == "rho(I - K^-1 J) reaches 1.02\u20131.03"


def test_check_prints_warnings_with_v_only_one_line_per_distinct_warning(scenario, tmp_path,
                                                                         capsys):
    # the gate's default prints the metrics that moved and the summary; -v adds the warnings,
    # grouped as run's default groups them (its help said "not one line per distinct warning")
    base = tmp_path / "b.csv"
    assert main(["check", str(scenario), "--baseline", str(base), "--update"]) == 0
    capsys.readouterr()
    assert main(["check", str(scenario), "--baseline", str(base)]) == 0
    assert "warning:" not in capsys.readouterr().err
    assert main(["check", "-v", str(scenario), "--baseline", str(base)]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(lines) == 1 and lines[0].startswith(f"warning: {scenario}: 4 cases: reference: ")
    p = build_parser("check")
    text = " ".join(p._subparsers._group_actions[0].choices["check"].format_help().split())
    assert "one line per distinct warning" in text and "not one line per" not in text


def test_one_case_is_one_case_and_list_checks_its_directory(tmp_path, capsys):
    one = tmp_path / "one.toml"
    one.write_text(_SCENARIO.split("[[cases]]")[0] + "[[cases]]" + _SCENARIO.split("[[cases]]")[1])
    assert main(["validate", str(one)]) == 0
    assert capsys.readouterr().out.strip().endswith("ok (1 case)")
    assert main(["run", str(one), "--out", str(tmp_path / "r"), "--figures", "none"]) == 0
    assert "(1 case)" in capsys.readouterr().out
    # a --scenarios directory that is not there is named, not listed as "none found"
    assert main(["list", "--scenarios", str(tmp_path / "missing")]) == 1
    out, err = capsys.readouterr()
    assert out == "" and err.strip() == (f"hammerstein list: error: --scenarios: "
                                         f"{tmp_path / 'missing'}: no such directory")
    assert main(["list"]) == 0 and "-0.0" not in capsys.readouterr().out.split("compensator")[0]
