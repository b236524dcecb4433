"""Tests of the regression gate: compare_metrics, baseline files, `hammerstein check`."""

from __future__ import annotations

import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

from hammerstein.scenario.regression import (BaselineError, compare_metrics, is_regression, merge_baseline,
                                    read_baseline, resolve_tolerances, summary_line,
                                    write_baseline)

ROOT = Path(__file__).resolve().parents[2]


def table(rows, scenario="s"):
    return pd.DataFrame([{"scenario": scenario, "case": c, "channel": ch, "metric": m,
                          "value": v, "unit": u} for c, ch, m, v, u in rows])


BASE = [
    ("sine", "x", "rms_error", 1.00, "µm"),
    ("sine", "x", "hysteresis_ratio", 10.0, "%"),
    ("sine", "y", "cross_coupling_peak_to_peak", 0.50, "µm"),
    ("open", "x", "peak_to_peak", 120.0, "µm"),
    ("sine", "ux", "peak_slew", 2.0e4, "V/s"),
]


def _with(rows, metric, value):
    return [(c, ch, m, value if m == metric else v, u) for c, ch, m, v, u in rows]


def _status(result, metric):
    return result.loc[result["metric"] == metric, "status"].item()


# -- compare_metrics -----------------------------------------------------------

@pytest.mark.parametrize("metric, value, expected", [
    # rms_error: rtol 5 % + atol 0.01 µm of 1.00 -> allowed 0.06 µm
    ("rms_error", 1.059, "ok"),
    ("rms_error", 1.061, "regressed"),
    ("rms_error", 0.939, "improved"),
    ("rms_error", 0.941, "ok"),
    # hysteresis_ratio: 5 % + 0.2 % points of 10 % -> 0.7 points
    ("hysteresis_ratio", 10.69, "ok"),
    ("hysteresis_ratio", 10.71, "regressed"),
    ("hysteresis_ratio", 9.2, "improved"),
    # cross-coupling larger = worse: 5 % of 0.5 + 0.01 = 0.035 µm
    ("cross_coupling_peak_to_peak", 0.536, "regressed"),
    ("cross_coupling_peak_to_peak", 0.40, "improved"),
    # neutral: 1 % of 120 + 0.01 = 1.21 µm either way
    ("peak_to_peak", 121.2, "ok"),
    ("peak_to_peak", 121.22, "regressed"),
    ("peak_to_peak", 118.78, "regressed"),
    ("rms_error", float("nan"), "regressed"),
    # a drive's fastest step: 5 % of 2e4 V/s, only a rise regresses
    ("peak_slew", 2.0999e4, "ok"),
    ("peak_slew", 2.1001e4, "regressed"),
    ("peak_slew", 1.5e4, "improved"),
])
def test_compare_status_by_tolerance_and_direction(metric, value, expected):
    result = compare_metrics(table(_with(BASE, metric, value)), table(BASE))
    assert _status(result, metric) == expected
    others = result[result["metric"] != metric]
    assert (others["status"] == "ok").all()
    assert is_regression(result).any() == (expected == "regressed")


def test_compare_unchanged_is_all_ok_with_zero_delta():
    result = compare_metrics(table(BASE), table(BASE))
    assert list(result["status"]) == ["ok"] * len(BASE)
    np.testing.assert_array_equal(result["delta"], 0.0)
    assert list(result["metric"]) == [r[2] for r in BASE]
    assert f"{len(BASE)} ok, 0 regressed" in summary_line(result) and summary_line(result).endswith("PASS")


def test_compare_reports_delta_and_relative_delta():
    result = compare_metrics(table(_with(BASE, "rms_error", 1.5)), table(BASE))
    row = result[result["metric"] == "rms_error"].iloc[0]
    assert row["baseline"] == 1.0 and row["current"] == 1.5
    assert row["delta"] == pytest.approx(0.5, abs=1e-15)
    assert row["rel_delta"] == pytest.approx(0.5, abs=1e-15)
    assert row["tolerance"] == pytest.approx(0.06, abs=1e-15)


def test_missing_metric_is_a_regression_and_new_is_not():
    current = table(BASE[1:] + [("sine", "x", "max_abs_error", 2.0, "µm")])
    result = compare_metrics(current, table(BASE))
    assert _status(result, "rms_error") == "missing"
    assert _status(result, "max_abs_error") == "new"
    assert math.isnan(result.loc[result["metric"] == "rms_error", "current"].item())
    assert is_regression(result).sum() == 1
    assert summary_line(result).endswith("FAIL")


def test_new_divergence_is_a_regression():
    """A case that diverged where it did not: its metrics vanish, diverged_at_time appears."""
    current = table([r for r in BASE if r[0] != "sine"] + [("sine", "x+y", "diverged_at_time", 4e-4, "s")])
    result = compare_metrics(current, table(BASE))
    assert _status(result, "diverged_at_time") == "regressed"
    assert set(result.loc[result["case"] == "sine", "status"]) == {"missing", "regressed"}


def test_divergence_of_a_case_new_to_the_baseline_is_new():
    current = table(BASE + [("literal", "x+y", "diverged_at_time", 4e-4, "s")])
    assert _status(compare_metrics(current, table(BASE)), "diverged_at_time") == "new"


def test_divergence_time_moving_is_a_regression():
    base = table([("literal", "x+y", "diverged_at_time", 4e-4, "s")])
    same = compare_metrics(base, base)
    moved = compare_metrics(table([("literal", "x+y", "diverged_at_time", 8e-4, "s")]), base)
    assert same["status"].item() == "ok" and moved["status"].item() == "regressed"


def test_unit_change_is_a_regression():
    current = table([(c, ch, m, v, "mm" if m == "rms_error" else u) for c, ch, m, v, u in BASE])
    assert _status(compare_metrics(current, table(BASE)), "rms_error") == "regressed"


def test_scenarios_are_part_of_the_key():
    base = pd.concat([table(BASE, "a"), table(BASE, "b")])
    current = pd.concat([table(BASE, "a"), table(_with(BASE, "rms_error", 2.0), "b")])
    result = compare_metrics(current, base)
    bad = result[is_regression(result)]
    assert list(zip(bad["scenario"], bad["metric"])) == [("b", "rms_error")]


def test_tables_without_scenario_column_compare():
    plain = table(BASE).drop(columns="scenario")
    assert (compare_metrics(plain, plain)["status"] == "ok").all()


@pytest.mark.parametrize("overrides, rtol, status", [
    ({"rms_error": {"rtol": 0.2}}, None, "ok"),                  # 1.15 within 0.2 + 0.01
    ({"*": {"rtol": 0.2}}, None, "ok"),
    ({"*": {"rtol": 0.2}, "rms_error": {"rtol": 0.1}}, None, "regressed"),
    ({}, 0.2, "ok"),                                             # --rtol for every metric
    ({"rms_error": {"direction": "higher"}}, None, "improved"),
])
def test_tolerance_overrides(overrides, rtol, status):
    tol = resolve_tolerances(overrides, rtol=rtol)
    result = compare_metrics(table(_with(BASE, "rms_error", 1.15)), table(BASE), tol)
    assert _status(result, "rms_error") == status


@pytest.mark.parametrize("metric, rtol, atol, direction", [
    ("rms_error", 0.05, 0.01, "lower"),
    ("peak_to_peak", 0.01, 0.01, "neutral"),
    ("mean_abs_error", 0.05, 0.01, "lower"),              # unknown, named as an error
    ("max_abs_error_percent", 0.05, 0.2, "lower"),
    ("cross_coupling_rms", 0.05, 0.01, "lower"),
    ("spectral_radius", 0.05, 1e-9, "neutral"),           # unknown: neutral
    ("peak_slew", 0.05, 1e-9, "lower"),                   # a slower drive is no regression
    ("peak_input", 0.05, 1e-9, "neutral"),
])
def test_default_tolerances_by_metric_name(metric, rtol, atol, direction):
    tol = resolve_tolerances()(metric)
    assert (tol.rtol, tol.atol, tol.direction) == (rtol, atol, direction)


def test_dict_overrides_are_accepted_directly():
    result = compare_metrics(table(_with(BASE, "rms_error", 1.15)), table(BASE),
                             {"rms_error": {"atol": 0.2}})
    assert _status(result, "rms_error") == "ok"


@pytest.mark.parametrize("overrides, message", [
    ({"rms_error": {"rtol": -1}}, "rms_error.rtol"),
    ({"rms_error": {"rtl": 0.1}}, "rms_error.rtl: unknown field"),
    ({"rms_error": {"direction": "up"}}, "rms_error.direction"),
    ({"rms_error": 0.1}, "rms_error: expected a table"),
    ({"rms_error": {"atol": "big"}}, "expected a number"),
])
def test_invalid_tolerances_are_named(overrides, message):
    with pytest.raises(BaselineError, match=message):
        resolve_tolerances(overrides)


def test_bad_tables_are_rejected():
    with pytest.raises(BaselineError, match="missing column"):
        compare_metrics(table(BASE).drop(columns="unit"), table(BASE))
    with pytest.raises(BaselineError, match="duplicated metric"):
        compare_metrics(table(BASE + BASE[:1]), table(BASE))
    bad = table(BASE).astype({"value": object})
    bad.loc[0, "value"] = "abc"
    with pytest.raises(BaselineError, match="expected a number"):
        compare_metrics(bad, table(BASE))


# -- baseline files ------------------------------------------------------------

def test_baseline_round_trip_is_exact(tmp_path):
    rows = _with(BASE, "rms_error", 0.1 + 0.2)        # not representable in short decimal
    path = write_baseline(table(rows), tmp_path / "sub" / "b.csv")
    back = read_baseline(path)
    pd.testing.assert_frame_equal(back, table(rows), check_dtype=False)
    assert list(back.columns) == ["scenario", "case", "channel", "metric", "value", "unit"]
    assert not list(path.parent.glob(".*tmp"))


def test_merge_baseline_replaces_only_the_scenarios_run():
    old = pd.concat([table(BASE, "a"), table(BASE, "b")])
    new = table(_with(BASE[:2], "rms_error", 9.0), "b")
    merged = merge_baseline(old, new)
    assert len(merged) == len(BASE) + 2
    b = merged[merged["scenario"] == "b"]
    assert list(b["value"]) == [9.0, 10.0]
    assert (merged.loc[merged["scenario"] == "a", "value"].to_numpy() ==
            [r[3] for r in BASE]).all()


def test_merge_baseline_keeps_the_baseline_order():
    """--update rewrites a scenario where it stood and appends new ones: a baseline in
    version control changes by its changed rows only."""
    old = pd.concat([table(BASE, "z"), table(BASE, "a"), table(BASE, "m")])
    new = pd.concat([table(_with(BASE, "rms_error", 9.0), "a"), table(BASE, "new")])
    merged = merge_baseline(old, new)
    assert list(dict.fromkeys(merged["scenario"])) == ["z", "a", "m", "new"]
    unchanged = merged[merged["scenario"] != "a"].drop(columns="value")
    assert len(unchanged) == 3 * len(BASE)
    assert list(merged.loc[merged["scenario"] == "a", "metric"]) == [r[2] for r in BASE]
    same = merge_baseline(old, table(BASE, "m"))
    pd.testing.assert_frame_equal(same, old.reset_index(drop=True), check_dtype=False)


@pytest.mark.parametrize("content, message", [
    (None, "not found"),
    ("<dir>", "is a directory"),
    ("", "empty baseline"),
    ("case,channel,metric,value,unit\na,x,rms_error,1,µm\n", "missing column scenario"),
    ("scenario,case,channel,metric,value\ns,a,x,rms_error,1\n", "missing column.*unit"),
    ("scenario,case,channel,metric,value,unit\ns,a,x,rms_error,abc,µm\n", "expected a number"),
    ("scenario,case,channel,metric,value,unit\ns,a,x,rms_error,,µm\n", "expected a number"),
    ("scenario,case,channel,metric,value,unit\ns,a,x,m,1,µm\ns,a,x,m,2,µm\n", "duplicated"),
])
def test_bad_baseline_files_give_one_line_errors(tmp_path, content, message):
    path = tmp_path / "b.csv"
    if content == "<dir>":
        path.mkdir()
    elif content is not None:
        path.write_text(content, encoding="utf-8")
    with pytest.raises(BaselineError, match=message) as err:
        read_baseline(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


# -- hammerstein check, end to end ----------------------------------------------

DEFAULT = ROOT / "scenarios" / "default.toml"


def _check(*args):
    from hammerstein.cli.main import main
    return main(["check", *map(str, args)])


def _variant(tmp_path, name, **compensator):
    """default.toml copied to tmp_path with a changed [compensator] table."""
    with DEFAULT.open("rb") as fh:
        sc = tomllib.load(fh)
    sc["compensator"].update(compensator)
    path = tmp_path / name
    path.write_bytes(tomli_w.dumps(sc).encode())
    return path


@pytest.fixture(scope="module")
def default_baseline(tmp_path_factory):
    path = tmp_path_factory.mktemp("baseline") / "baseline.csv"
    assert _check(DEFAULT, "--baseline", path, "--update") == 0
    return path


def test_check_passes_on_the_unchanged_scenario(default_baseline, capsys, tmp_path):
    assert _check(DEFAULT, "--baseline", default_baseline, "--out", tmp_path) == 0
    out = capsys.readouterr().out
    assert "no metric moved" in out and out.strip().endswith("PASS")
    assert (tmp_path / "default" / "metrics.csv").is_file()
    baseline = read_baseline(default_baseline)
    assert set(baseline["scenario"]) == {"default"}
    assert set(baseline["case"]) == {"open-loop-ux-50Hz", "sine-x-50um-static", "circle-30um"}


def test_check_fails_on_a_degraded_compensator(default_baseline, capsys, tmp_path):
    """K twice the secant gains: the same scenario name and cases, errors grow about 3-7x."""
    degraded = _variant(tmp_path, "default.toml", gain=[[12.0, 0.0], [0.0, 12.0]])
    assert _check(degraded, "--baseline", default_baseline) == 1
    out = capsys.readouterr().out
    assert "regressed" in out and out.strip().endswith("FAIL")
    # a generous tolerance on every metric lets it pass again
    assert _check(degraded, "--baseline", default_baseline, "--rtol", "10") == 0


def test_check_fails_when_a_scenario_fails(default_baseline, capsys, tmp_path):
    """The literal law (K = I) is refused at construction (rho >= 1): a failed scenario."""
    literal = _variant(tmp_path, "default.toml", gain="identity")
    assert _check(literal, "--baseline", default_baseline) == 1
    assert "scenario failed" in capsys.readouterr().err


@pytest.mark.parametrize("setup, message", [
    ("missing", "baseline file not found"),
    ("malformed", "missing column scenario"),
    ("tolerances", "rms_error.rtol"),
    ("no-scenario", "scenario file not found"),
    ("out-is-file", "not a directory"),
])
def test_check_usage_errors_exit_2(tmp_path, capsys, setup, message):
    baseline = tmp_path / "baseline.csv"
    scenario = DEFAULT
    extra = []
    if setup == "malformed":
        baseline.write_text("case,channel,metric,value,unit\n", encoding="utf-8")
    elif setup == "tolerances":
        baseline.write_text("scenario,case,channel,metric,value,unit\n", encoding="utf-8")
        tol = tmp_path / "tol.toml"
        tol.write_text("[rms_error]\nrtol = -0.1\n", encoding="utf-8")
        extra = ["--tolerances", tol]
    elif setup == "no-scenario":
        baseline.write_text("scenario,case,channel,metric,value,unit\n", encoding="utf-8")
        scenario = tmp_path / "nope.toml"
    elif setup == "out-is-file":
        baseline.write_text("scenario,case,channel,metric,value,unit\n", encoding="utf-8")
        (tmp_path / "out").write_text("", encoding="utf-8")
        extra = ["--out", tmp_path / "out"]
    assert _check(scenario, "--baseline", baseline, *extra) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    if setup == "missing":
        assert not baseline.exists()


def test_update_replaces_only_the_scenarios_run(default_baseline, tmp_path):
    other = pd.DataFrame([{"scenario": "other", "case": "c", "channel": "x",
                           "metric": "rms_error", "value": 1.0, "unit": "µm"}])
    path = tmp_path / "b.csv"
    stale = read_baseline(default_baseline)
    stale.loc[stale["metric"] == "rms_error", "value"] = 123.0
    write_baseline(pd.concat([stale, other]), path)
    assert _check(DEFAULT, "--baseline", path, "--update") == 0
    updated = read_baseline(path)
    pd.testing.assert_frame_equal(
        updated[updated["scenario"] == "default"].reset_index(drop=True),
        read_baseline(default_baseline))
    assert updated[updated["scenario"] == "other"]["value"].tolist() == [1.0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.csv"]


def test_scenario_absent_from_the_baseline_is_new_not_a_failure(tmp_path, capsys):
    baseline = tmp_path / "b.csv"
    baseline.write_text("scenario,case,channel,metric,value,unit\n", encoding="utf-8")
    assert _check(DEFAULT, "--baseline", baseline) == 0
    out, err = capsys.readouterr()
    assert "note: scenario(s) not in" in err and "default" in err      # a note: on stderr
    assert " 0 ok," in out and out.strip().endswith("PASS")
