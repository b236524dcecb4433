"""Sweep figures: log axes labelled above the largest point, alike on every panel; titles that
name the signal and its size, the compensator and the window of the metric.

Regression: realistic-2dof's sweep-sine.png had its largest points (0.107 µm) above the last
label (0.1), a panel spanning 0.012-0.020 µm labelled in another style than the others, and
the title "RMS error vs frequency" alone.
"""

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from figure_checks import figure_problems  # noqa: E402

from hammerstein.report.figures import LOG_TICK_SETS, readable_log_ticks  # noqa: E402
from hammerstein.report.sweeps import sweep_figure, sweep_subject  # noqa: E402
from hammerstein.scenario.sweeps import SweepSpec  # noqa: E402

# realistic-2dof's sweep-sine values per panel [µm]
PANELS = {("x", "x"): [0.0327, 0.0197, 0.0256, 0.0558, 0.107],
          ("x", "y"): [0.0122, 0.0129, 0.0203, 0.0159, 0.0187],
          ("y", "x"): [0.0163, 0.0177, 0.0212, 0.0311, 0.0165],
          ("y", "y"): [0.0451, 0.0272, 0.0203, 0.0494, 0.0822]}
FREQS = [10.0, 50.0, 100.0, 200.0, 300.0]


def _table():
    rows, cases = [], []
    for axis in ("x", "y"):
        for f in FREQS:
            cases.append({"case": f"{axis}-{f:g}", "frequency_hz": f, "compensator": "-",
                          "axis": axis})
    for (ch, axis), values in PANELS.items():
        for f, v in zip(FREQS, values):
            rows.append({"frequency_hz": f, "compensator": "-", "axis": axis, "channel": ch,
                         "rms_error": v})
    spec = SweepSpec(name="sine", mode="reference", metric="rms_error", frequencies=FREQS,
                     labels=[None], axes=["x", "y"], cases=cases)
    return pd.DataFrame(rows), spec


def test_every_point_lies_between_labelled_ticks_in_plain_numbers():
    table, spec = _table()
    fig = sweep_figure(table, spec, ["x", "y"], "t")
    fig.canvas.draw()
    assert figure_problems(fig) == []
    for ax in fig.axes:
        (line,) = ax.lines
        y = line.get_ydata()
        lo, hi = ax.get_ylim()
        ticks = [t for t in ax.get_yticks() if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
        assert len(ticks) >= 3 and len(labels) == len(ticks)
        assert min(ticks) <= y.min() and max(ticks) >= y.max()    # no point beyond a label
        assert all("10^" not in s and "times" not in s and "$" not in s for s in labels)
        assert np.log10(hi / lo) <= 2.0 * np.log10(y.max() / y.min())   # no wasted decade
    plt.close(fig)


@pytest.mark.parametrize("values, expected", [([0.0197, 0.107], [0.01, 0.02, 0.05, 0.1, 0.2]),
                                              ([0.0122, 0.0203], [0.012, 0.015, 0.02, 0.025])])
def test_readable_log_ticks(values, expected):
    fig, ax = plt.subplots()
    ax.set_yscale("log")
    ax.plot([0, 1], values)
    np.testing.assert_allclose(readable_log_ticks(ax, values), expected)
    assert ax.get_ylim() == pytest.approx((expected[0], expected[-1]))
    assert LOG_TICK_SETS[0] == (1.0, 2.0, 5.0)
    plt.close(fig)


def test_the_title_names_the_signal_size_compensator_and_window():
    _, spec = _table()
    case = SimpleNamespace(signal_spec={"kind": "sine", "amplitude": 30.0, "periods": 8},
                           settle_periods=6, compensator_spec={"kind": "multivariable",
                                                               "model": "plant"})
    results = [SimpleNamespace(name="x-10", spec=case)]
    subject = sweep_subject(spec, results)
    assert subject.startswith("sine, amplitude 30 µm; multivariable compensator")
    assert subject.endswith("over the last 2 of 8 periods")
    several = SweepSpec(name="s", mode="reference", metric="rms_error", frequencies=FREQS,
                        labels=["a", "b", "c"], axes=["x"], cases=spec.cases)
    assert "3 compensators" in sweep_subject(several, results)


def test_long_names_over_many_decades_fit_the_figure_and_do_not_overlap():
    """A tester's sweep: eight compensators named by 50-70 characters, one following its own
    model to 1e-12 µm beside others at 0.3-20 µm. The legend (three columns) was cut on both
    sides of the 5.9 in figure, and 1, 2, 5 labelled every one of 13 decades (40 overlapping
    labels)."""
    labels = [f"case-{j}" for j in range(8)]
    names = {lab: f"hammerstein, identified from measured records ({lab}-{'x' * 30})"
             for lab in labels}
    rows, cases = [], []
    for f in FREQS:
        cases.append({"case": f"x-{f:g}", "frequency_hz": f, "compensator": "-", "axis": "x"})
        for j, lab in enumerate(labels):
            v = 2e-12 if j == 5 else 0.3 * (j + 1) * (1 + f / 100)
            rows.append({"frequency_hz": f, "compensator": lab, "axis": "x", "channel": "x",
                         "rms_error": v})
    spec = SweepSpec(name="f", mode="reference", metric="rms_error", frequencies=FREQS,
                     labels=labels, axes=["x"], cases=cases)
    fig = sweep_figure(pd.DataFrame(rows), spec, ["x"], "t", names=names)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    width = fig.bbox.width
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    assert box.x0 >= 0 and box.x1 <= width                       # nothing cut
    (ax,) = fig.axes
    texts = [t for t in ax.get_yticklabels() if t.get_text()]
    boxes = sorted((t.get_window_extent(renderer) for t in texts), key=lambda b: b.y0)
    assert 3 <= len(texts) <= 12
    assert all(a.y1 <= b.y0 for a, b in zip(boxes, boxes[1:]))   # no two labels overlap
    lo, hi = ax.get_ylim()
    assert lo <= 2e-12 and hi >= 0.3 * 8 * 3                      # every point inside
    plt.close(fig)
