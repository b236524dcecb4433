"""The reference a case's figures and time series show is the one the compensator tracked.

A case that fades in from rest follows ``fade_in(reference, fade)``: its time series,
trajectory figure and error panels show that reference, not the un-faded one it never
commanded; the metrics (on the settled window after the fade) are those of the
un-faded reference, unchanged.
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from hammerstein.compensation.hammerstein_compensator import fade_in  # noqa: E402
from hammerstein.report.scenario import timeseries_columns  # noqa: E402
from hammerstein.report.trajectories import trajectory_figure  # noqa: E402
from hammerstein.scenario.execute import fade_samples, run_case  # noqa: E402
from hammerstein.scenario.resolve import load_scenario  # noqa: E402
from hammerstein.signals import metrics as met  # noqa: E402

SCENARIO = """
name = "tracked"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[compensator]
kind = "hammerstein"
fade_in = 0.005
[[cases]]
name = "circle"
reference = { kind = "circle", radius = 20.0, frequency = 100.0, periods = 4 }
settle_periods = 2
"""


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    path = tmp_path_factory.mktemp("tracked") / "tracked.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    (case,) = load_scenario(path).cases
    return run_case(case)


def test_the_result_keeps_the_faded_reference_and_the_metrics_the_unfaded_one(result):
    case = result.spec
    fade = fade_samples(case)
    assert fade == 100
    np.testing.assert_array_equal(result.reference, fade_in(case.signal, fade))
    assert result.reference[0, 0] == 0.0 and case.signal[0, 0] == 20.0   # from rest
    names = list(case.plant.hysteresis.output_names)
    expected = met.tracking_metrics(case.signal, result.outputs, names, case.period_samples,
                                    case.settle_periods, scale=case.scale,
                                    loop_channel=case.loop_channel)
    got = {(r["channel"], r["metric"]): r["value"] for r in result.metrics}
    for row in expected:
        assert got[(row["channel"], row["metric"])] == row["value"]


def test_the_time_series_saves_the_tracked_reference(result):
    cols = timeseries_columns(result)
    np.testing.assert_array_equal(cols["x_ref_um"], result.reference[0])
    assert cols["x_ref_um"][0] == 0.0
    # the start-up error against what was commanded stays small (no 20 µm jump at t = 0)
    fade = fade_samples(result.spec)
    assert np.max(np.abs(cols["x_ref_um"][:fade] - cols["x_um"][:fade])) < 2.0


def test_trajectory_figure_shades_the_fade_in_apart_from_the_settling():
    t = np.arange(4000) * 5e-5
    r = fade_in(20 * np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 50 * t)]), 400)
    fig = trajectory_figure(t, r, r * 0.99, ["x", "y"], "t", settle_time=0.06,
                            inputs=r / 5, input_names=["ux", "uy"], fade_time=0.02)
    fig.canvas.draw()
    ax = [a for a in fig.axes if a.get_title().startswith("(b)")][0]
    spans = sorted((p.get_x(), p.get_x() + p.get_width(), p.get_facecolor()[:3])
                   for p in ax.patches)
    assert [(round(a, 6), round(b, 6)) for a, b, _ in spans] == [(0.0, 20.0), (20.0, 60.0)]
    assert spans[0][2] != spans[1][2]                  # two shades: fade-in, settling
    assert "fade-in" in ax.get_title()
    plt.close(fig)


def test_the_xy_reference_reads_where_its_periods_overlap():
    t = np.arange(4000) * 5e-5
    r = 20 * np.vstack([np.cos(2 * np.pi * 50 * t), np.sin(2 * np.pi * 50 * t)])
    fig = trajectory_figure(t, r, r * 0.99, ["x", "y"], "t", settle_time=0.02)
    ax = [a for a in fig.axes if a.get_title().startswith("(a)")][0]
    ref, out = ax.lines[:2]
    # dashes of many overlapping periods fill in and look solid: the reference is a band
    assert ref.get_linestyle() == "-" and ref.get_linewidth() >= 3 * out.get_linewidth()
    assert "band: reference" in ax.get_title()
    plt.close(fig)
