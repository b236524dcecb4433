"""The words of a scenario's report.md: it stands on its own and says only what is there.

Regressions found by reading the reports: no metric was defined in the report (only in
docs/metrics.md), the settling window of a case was not said, a sweep-only report
promised time series that were not written and had empty sections, titles read
``2\\-DOF \\(x\\)``, a sweep's 42 warnings were one bullet each with "1 case(s)", its
comparison table had rows and columns without a value, and the convergence warning
of a compensator that already used the midpoint gain advised the midpoint gain.
"""

import re

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.report.definitions import METRIC_WORDS, PAPER, definitions_lines

CASES = """
name = "words"
title = "A 2-DOF test (words-check) at 50-200 Hz"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
[[cases]]
name = "open-ux"
drive = { kind = "sine", input = "ux", amplitude = 5.0, frequency = 50.0, periods = 3 }
settle_periods = 2
[[cases]]
name = "circle"
reference = { kind = "circle", radius = 12.0, frequency = 50.0, periods = 3 }
settle_periods = 1.5
"""

SWEEP_ONLY = """
name = "sweeps-only"
title = "Sweep only"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[[sweeps]]
name = "s"
frequencies = [10.0, 50.0]
reference = { kind = "sine", output = ["x", "y"], amplitude = 50.0, periods = 3 }
settle_periods = 1
[sweeps.compensators]
mid = { kind = "multivariable", model = "identified", identify = { frequency = 150.0, amplitude = 10.0, periods = 3, n_hysterons = 15, method = "least-squares", partition = "time", bounds = "monotone", sensor = false }, gain = "midpoint", iterations = 1, check = "warn" }
pa = { kind = "per-axis" }
[[sweeps]]
name = "family"
reference = { kind = "circle", radius = 20.0, frequency = 50.0, periods = 3 }
[sweeps.compensators]
mv = { kind = "multivariable" }
pa = { kind = "per-axis" }
"""


def _run(tmp_path, text, name):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    return (tmp_path / "out" / name / "report.md").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def cases_md(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("cases"), CASES, "words")


@pytest.fixture(scope="module")
def sweep_md(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("sweep"), SWEEP_ONLY, "sweeps-only")


def test_title_reads_as_written(cases_md):
    assert cases_md.splitlines()[0] == "# A 2-DOF test (words-check) at 50-200 Hz"


def test_definitions_of_the_metrics_shown_only(cases_md):
    defs = cases_md.split("## Definitions", 1)[1].split("## Cases", 1)[0]
    for metric in ("hysteresis_width", "hysteresis_ratio", "max_euclidean_error_percent",
                   "peak_input", "peak_slew", "rms_error"):
        assert f"- `{metric}`:" in defs, metric
    assert "- `line_rms_error`" not in defs and "- `rms_error_percent`" not in defs
    # the percentage of a circle is of its radius (no sine or raster in this report)
    pct = next(ln for ln in defs.splitlines() if ln.startswith("- `max_euclidean_error_percent`"))
    assert "radius of a circle" in pct and "raster" not in pct and "sine" not in pct
    assert "from 0 V at rest" in defs          # peak_slew: the first step counted from rest
    assert "docs/metrics.md" not in cases_md
    assert cases_md.count(PAPER) == 1


def test_case_table_says_where_the_metrics_start(cases_md):
    part = cases_md.split("## Cases", 1)[1].split("##", 1)[0]
    rows = {ln.split("|")[1].strip(): ln for ln in part.splitlines() if ln.startswith("| ")}
    assert "metrics from" in rows["case"]
    # 2 periods of 50 Hz; 1.5 periods (round(1.5 x 400) samples x 50 µs = 30 ms)
    assert "2 periods: t ≥ 40 ms" in rows["open-ux"]
    assert "1.5 periods: t ≥ 30 ms" in rows["circle"]


def test_single_sine_figure_words_are_singular():
    from types import SimpleNamespace

    from hammerstein.report.scenario import _drive_summary

    one = [SimpleNamespace(spec=SimpleNamespace(signal_spec={"kind": "sine", "amplitude": 10.0,
                                                              "frequency": 50.0}))]
    assert _drive_summary(one) == "a 10 V sine at 50 Hz"
    assert _drive_summary(one * 2) == "10 V sines at 50 Hz"


def test_sweep_only_report_has_no_empty_sections_nor_missing_files(sweep_md, tmp_path):
    assert "## Cases" not in sweep_md and "(sweep cases only" not in sweep_md
    assert "## Figures" not in sweep_md
    assert "timeseries-" not in sweep_md
    headings = [i for i, ln in enumerate(sweep_md.splitlines()) if ln.startswith("#")]
    lines = sweep_md.splitlines()
    for a, b in zip(headings, headings[1:]):
        assert any(s.strip() for s in lines[a + 1:b]), lines[a]


def test_sweep_warnings_grouped_and_convergence_advice_fits(sweep_md):
    warn = sweep_md.split("Warnings:", 1)[1].split("##", 1)[0]
    bullets = [ln for ln in warn.splitlines() if ln.startswith("- ")]
    assert "case(s)" not in sweep_md
    rho = [b for b in bullets if "rho(I - K^-1 J)" in b]
    assert len(rho) == 1, bullets
    assert "compensator mid" in rho[0] and "gain='midpoint'" in rho[0]
    assert "gain='midpoint' minimises" not in rho[0]
    assert len(bullets) == len({re.sub(r"[\d.]+", "#", b) for b in bullets})


def test_comparison_table_without_empty_rows_or_columns(sweep_md):
    part = sweep_md.split("## Sweep `family`", 1)[1].split("##", 1)[0]
    table = [ln for ln in part.splitlines() if ln.startswith("|")]
    head = [c.strip() for c in table[0].strip("|").split("|")]
    assert "axis" not in head
    body = [[c.strip() for c in ln.strip("|").split("|")] for ln in table[2:]]
    assert {r[head.index("channel")] for r in body} == {"x", "y", "x+y"}
    for j, name in enumerate(head):
        assert any(r[j] for r in body), name


def test_definitions_words_of_every_scale():
    lines = definitions_lines(["max_euclidean_error_percent"],
                              {"max_euclidean_error_percent": ["raster"]}, paper=False)
    text = "\n".join(lines)
    assert "whole size (not half of it)" in text
    assert set(METRIC_WORDS) >= {"line_rms_error", "line_max_error", "peak_input", "peak_slew"}


def test_order_words_list_every_candidate_and_the_reduction():
    from types import SimpleNamespace

    from hammerstein.report.identified import order_words

    fixed = SimpleNamespace(order_=6, candidate_order_=8, orders_=np.array([8]),
                            validation_fit_=np.array([99.76]),
                            candidates_=[{"order": 8, "dropped": ["near-cancelled mode at 58 Hz",
                                                                  "near-cancelled mode at 227 Hz"]}])
    words = order_words(fixed)
    assert words.startswith("order 6: candidate order 8 (the one order tried), with 2 states removed")
    assert "8: 99.76 %" in words
    tried = SimpleNamespace(order_=2, candidate_order_=2, orders_=np.array([1, 2, 3]),
                            validation_fit_=np.array([50.0, 99.0, np.nan]),
                            candidates_=[{"order": 3, "rejected": "unstable"}])
    words = order_words(tried)
    assert words == ("order 2; held-out (validation) fit by candidate order: 1: 50.00 %, "
                     "2: 99.00 %, 3: rejected (unstable)")


LONG_CASE = """
name = "long"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[[cases]]
name = "slow-ux"
drive = { kind = "sine", input = "ux", amplitude = 5.0, frequency = 1.0, periods = 12 }
"""


def test_time_series_keep_every_sample_time_of_a_long_case(tmp_path):
    """A 12 s case at the preset's sampling period: every time stamp of its time series is
    its own and equal to the case's time to 1e-9 s, and the drive is the case's to 1e-8
    of its amplitude (6 significant digits wrote 10.0001 s for two samples)."""
    import pandas as pd
    from hammerstein.io.presets import load_plant
    _run(tmp_path, LONG_CASE, "long")
    frame = pd.read_csv(tmp_path / "out" / "long" / "timeseries-slow-ux.csv")
    T = load_plant("rakotondrabe-2dof", dynamics=False).sampling_period
    t = frame["time_s"].to_numpy()
    assert t[-1] > 11.0 and np.all(np.diff(t) > 0.5 * T)
    assert np.max(np.abs(t - T * np.arange(t.size))) < 1e-9
    ux = frame["ux_V"].to_numpy()
    assert np.max(np.abs(ux - 5.0 * np.sin(2 * np.pi * t))) < 5e-8 * 5.0
