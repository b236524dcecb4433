"""Replication README from a small synthetic metrics set (no simulation)."""

import re

import numpy as np
import pandas as pd
import pytest

from hammerstein.report.replication import (FIG09, FIG10, PAPER_NUMBERS, family_comparison, fig09_trends,
                                     paper_comparison, read_metrics, write_readme)

SCALE = 1.5  # synthetic "ours" = SCALE x paper (paper 0: 0.7)


def _synthetic(root):
    rows = {}
    for n in PAPER_NUMBERS:
        value = (SCALE * n["paper"] if n["paper"] else 0.7) / n["factor"]
        rows.setdefault(n["scenario"], []).append(
            {"case": n["case"], "channel": n["channel"], "metric": n["metric"], "value": value, "unit": n["unit"]})
    for label, k in (("mv1", 1.0), ("static-gain", 4.0)):
        for ch, me, v in (("x+y", "max_euclidean_error", 2.0), ("x", "rms_error", 1.0)):
            rows[FIG10].append({"case": f"family-circle-50um-{label}", "channel": ch, "metric": me,
                                "value": k * v, "unit": "µm"})
    for label, k in (("mv-50Hz", 1.0), ("per-axis-50Hz", 5.0), ("static-gain-50Hz", 5.0)):
        for f in (10.0, 50.0, 200.0):
            for axis in "xy":
                for ch in "xy":
                    v = (f / 50.0 if axis == ch else k * 0.2)
                    rows.setdefault(FIG09, []).append({"case": f"rms-{label}-{axis}-{f:g}Hz", "channel": ch,
                                                       "metric": "rms_error", "value": v, "unit": "µm"})
    for scen, r in rows.items():
        (root / scen).mkdir(parents=True)
        pd.DataFrame(r).to_csv(root / scen / "metrics.csv", index=False)


def test_paper_comparison_ratios(tmp_path):
    _synthetic(tmp_path)
    comp = paper_comparison(read_metrics(tmp_path))
    assert len(comp) == len(PAPER_NUMBERS)
    nonzero = np.array([n["paper"] != 0 for n in PAPER_NUMBERS])
    np.testing.assert_allclose(comp["ratio"][nonzero], SCALE, rtol=1e-12)
    assert comp["ratio"][~nonzero].isna().all()
    np.testing.assert_allclose(comp["ours"][~nonzero], 0.7, rtol=1e-12)


def test_readme_lists_every_paper_number_with_its_ratio(tmp_path):
    _synthetic(tmp_path)
    text = write_readme(tmp_path).read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line.startswith("| Fig.")]
    for n in PAPER_NUMBERS:
        text_md = n["text"].replace("|", "\\|")
        match = [r for r in rows if f"| {n['quantity']} | {n['setting']} | {text_md} |" in r]
        assert len(match) >= 1, n
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", match[0].strip("|"))]
        if n["paper"]:
            assert float(cells[6]) == pytest.approx(SCALE, rel=1e-3)
    for paper in ("17 %", "15.8 %", "±1.5 µm", "±2 µm", "±0.2 µm", "±0.25 µm", "\\|ε\\| ≈ 2 µm", "2 %"):
        assert paper in text
    assert "docs/compensator.md" in text and "docs/metrics.md" in text and "docs/hammerstein-plant.md" in text
    assert "NOTES" not in text
    assert (tmp_path / "paper-numbers.csv").is_file()


def test_family_and_fig09_trend_tables(tmp_path):
    _synthetic(tmp_path)
    m = read_metrics(tmp_path)
    fam = family_comparison(m).set_index("compensator")
    assert fam.loc["static-gain", "max_euclidean_um"] == pytest.approx(4 * fam.loc["mv1", "max_euclidean_um"])
    t = fig09_trends(m).set_index(["compensator", "transfer"])
    assert t.loc[("mv-50Hz", "direct x"), "rise_200_over_50"] == pytest.approx(4.0)
    assert t.loc[("per-axis-50Hz", "cross y_r->x"), "rms_50Hz"] == pytest.approx(
        5 * t.loc[("mv-50Hz", "cross y_r->x"), "rms_50Hz"])
    text = write_readme(tmp_path).read_text(encoding="utf-8")
    assert "cuts it 5x below the baseline" in text
