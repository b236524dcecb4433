"""The committed replication report's metrics are today's: every row the regression
baseline holds for a paper scenario, with its value.

Regression: the committed reports/paper/*/metrics.csv lacked the metrics added
since they were written (peak_input, peak_slew, ...). Regenerate them with
`hammerstein replicate`; `.ci/run` also runs it and compares the result
(`.ci/check_reports.py`).
"""

import math
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "reports" / "paper"
BASELINE = pd.read_csv(ROOT / "baselines" / "bundled.csv", comment="#")
REPORTS = sorted(p.parent for p in PAPER.glob("*/metrics.csv"))


@pytest.mark.parametrize("report", REPORTS, ids=lambda p: p.name)
def test_committed_metrics_match_the_baseline(report):
    base = BASELINE[BASELINE["scenario"] == report.name]
    if base.empty:
        pytest.skip(f"{report.name} is not in baselines/bundled.csv")
    ours = pd.read_csv(report / "metrics.csv", comment="#")
    key = ["case", "channel", "metric"]
    want = {tuple(r[k] for k in key): r["value"] for _, r in base.iterrows()}
    have = {tuple(r[k] for k in key): r["value"] for _, r in ours.iterrows()}
    missing = sorted(set(want) - set(have))
    assert missing == [], (f"{report.name}: {len(missing)} rows of the baseline missing, e.g. "
                           f"{missing[:3]}; run `hammerstein replicate`")
    moved = [k for k in want if not (math.isclose(have[k], want[k], rel_tol=0.05, abs_tol=0.01)
                                     or (math.isnan(have[k]) and math.isnan(want[k])))]
    assert moved == [], f"{report.name}: {moved[:3]} moved; run `hammerstein replicate`"
