"""Figure helpers: decimation keeps what a figure shows, grids drop undriven inputs."""

import numpy as np
import pytest

from hammerstein.report import figures as plots


def test_decimate_keeps_extremes_and_bounds_points():
    rng = np.random.default_rng(0)
    t = np.arange(100_000) * 1e-5
    y = np.sin(2 * np.pi * 37 * t) + 0.1 * rng.standard_normal(t.size)
    td, yd = plots.decimate(t, y, max_points=2000)
    assert td.size <= 2002
    assert yd.max() == y.max() and yd.min() == y.min()       # global extremes kept exactly
    assert np.all(np.diff(td) > 0)                            # time order kept
    # every kept point is a sample of the original line
    idx = np.searchsorted(t, td)
    np.testing.assert_array_equal(y[idx], yd)
    # per bin of 100 samples the min and max survive: the envelope is exact
    for k in (0, 317, 999):
        sl = slice(k * 100, (k + 1) * 100)
        inside = (td >= t[sl][0]) & (td <= t[sl][-1])
        assert yd[inside].max() == y[sl].max() and yd[inside].min() == y[sl].min()


def test_decimate_short_line_unchanged_and_nan_breaks_kept():
    t = np.arange(500.0)
    y = np.cos(t)
    td, yd = plots.decimate(t, y)
    np.testing.assert_array_equal(yd, y)
    y = np.r_[np.sin(np.arange(5000.0)), np.full(5000, np.nan)]
    _, yd = plots.decimate(np.arange(10_000.0), y, max_points=200)
    assert np.isnan(yd).any() and np.nanmax(yd) == np.nanmax(y)


def test_decimate_path_keeps_loop_extremes():
    th = np.linspace(0, 40 * np.pi, 50_001)
    x, y = 10 * np.sin(th), 58 * np.sin(th + 0.3)
    xd, yd = plots.decimate_path(x, y, max_points=2000)
    assert xd.size <= 2002
    assert xd.max() == x.max() and yd.min() == y.min()


@pytest.mark.parametrize("columns, n_axes", [([0], 2), ([1], 2), ([0, 1], 4)])
def test_loop_grid_drops_undriven_columns(columns, n_axes):
    u = 10 * np.sin(np.linspace(0, 2 * np.pi, 401))
    curves = [{"label": f"c{k}", "column": k, "x": u, "outputs": np.vstack([u, 0.1 * u])}
              for k in columns]
    fig = plots.loop_grid(curves, ["ux [V]", "uy [V]"], ["x [µm]", "y [µm]"], "maps")
    titles = [ax.get_title() for ax in fig.axes]
    assert len(fig.axes) == n_axes
    # the panels drawn are lettered in turn: (a), (b) for one column, (a)-(d) for both
    letters = sorted(t.split(")")[0] + ")" for t in titles)
    assert letters == ["(a)", "(b)", "(c)", "(d)"][:n_axes]
    plots.plt.close(fig)


def test_legend_on_top_leaves_the_data_below_the_legend(tmp_path):
    fig, ax = plots.plt.subplots(figsize=(5, 4))
    plots.fixed_layout(fig)
    y = np.linspace(-1, 1, 50)
    for i in range(6):
        ax.plot(y, y + 0.01 * i, label=f"curve {i}")
    leg = plots.legend_on_top(ax, 6, ncol=2)
    fig.canvas.draw()
    box = leg.get_window_extent()
    top_of_data = ax.transData.transform((0.0, 1.05))[1]
    assert box.y0 >= top_of_data - 1.0                        # pixels: legend above every curve
    plots.save(fig, tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 0


# -- the Monte-Carlo quantile figure: labels readable on log axes ------------------------
@pytest.mark.parametrize("lo, hi", [(0.27, 0.45), (0.6, 25.0), (1.2e4, 8e4)])
def test_quantile_figure_axis_labels_clear_the_tick_labels(lo, hi):
    """Log axes spanning less than a decade label minor ticks; the "[µm]" label must stay
    left of every tick label of its axes and inside the figure (it touched them before)."""
    import matplotlib.pyplot as plt
    import pandas as pd
    from hammerstein.report.montecarlo import quantile_figure
    freqs = [10.0, 50.0, 100.0, 200.0]
    rows = []
    for ch, met in [("x", "rms_error"), ("y", "max_abs_error"), ("x+y", "rms_euclidean_error")]:
        for j, f in enumerate(freqs):
            q = lo * (hi / lo) ** (np.array([0.0, 0.5, 0.8, 1.0]) * (j + 1) / len(freqs))
            rows.append({"frequency_hz": f, "channel": ch, "metric": met,
                         "p50": q[0], "p95": q[1], "p99": q[2], "max": q[3]})
    fig = quantile_figure(pd.DataFrame(rows), "t")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    for ax in [a for a in fig.axes if a.get_visible()]:
        assert ax.get_yscale() == "log"
        label = ax.yaxis.label.get_window_extent(renderer)
        lo_y, hi_y = ax.get_ylim()
        ticks = [t.get_window_extent(renderer) for t in
                 ax.get_yticklabels() + ax.get_yticklabels(minor=True)
                 if t.get_text() and lo_y <= t.get_position()[1] <= hi_y]   # those drawn
        assert ticks                                          # the axis carries numbers
        assert label.x1 < min(b.x0 for b in ticks)            # left of them, not touching
        assert page.x0 <= label.x0 and label.x1 <= page.x1    # not cut by the figure edge
        for other in fig.axes:                                # not on a neighbour's panel
            if other is not ax and other.get_visible():
                assert not label.overlaps(other.get_window_extent(renderer))
    plt.close(fig)


@pytest.mark.parametrize("p99_is_max", [False, True])
def test_quantile_figure_names_each_metric_and_says_when_p99_is_the_largest_case(p99_is_max):
    """An outside check: the y axes read only "[µm]" (the metric in the panel title), and with
    20 cases the P99 line lay hidden under MAX's."""
    import pandas as pd
    from hammerstein.report.montecarlo import quantile_figure
    rows = []
    for ch, met in [("x", "rms_error"), ("x+y", "max_euclidean_error")]:
        for f in (20.0, 100.0):
            rows.append({"frequency_hz": f, "channel": ch, "metric": met, "p50": 1.0,
                         "p95": 2.0, "p99": 4.0 if p99_is_max else 3.0, "max": 4.0})
    fig = quantile_figure(pd.DataFrame(rows), "t")
    axes = [a for a in fig.axes if a.get_visible()]
    assert [a.get_ylabel() for a in axes] == ["rms error [µm]", "max euclidean error [µm]"]
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert labels == (["P50", "P95", "MAX = P99"] if p99_is_max else ["P50", "P95", "P99", "MAX"])
    assert len(axes[0].get_lines()) == len(labels)
