"""The trajectory figure's error panels keep their y-labels clear of their ticks and neighbours.

Errors of a few 1e-4 µm (a compensator that matches its model) drew ticks
such as ``0.0004`` wider than the space the fixed layout leaves between the
panels: matplotlib pushed the y-label left, over the time-domain panel.
Below 0.1 µm the errors are drawn in nm, below 1e-4 µm in a power of ten of
µm written in the unit.
"""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from hammerstein.report.trajectories import _error_unit, trajectory_figure


def _figure(size):
    t = np.arange(4000) * 5e-5
    r = np.vstack([10 * np.cos(2 * np.pi * 50 * t), 10 * np.sin(2 * np.pi * 50 * t)])
    e = np.vstack([size * np.sin(2 * np.pi * 150 * t) + 3 * size * np.exp(-t / 0.01),
                   size * np.cos(2 * np.pi * 250 * t)])
    return trajectory_figure(t, r, r - e, ["x", "y"], "errors", settle_time=0.05,
                             inputs=r / 3, input_names=["ux", "uy"]), e


@pytest.mark.parametrize("peak, scale, unit", [(0.5, 1.0, "µm"), (0.1, 1.0, "µm"),
                                               (0.0999, 1e3, "nm"), (3e-4, 1e3, "nm"),
                                               (1e-4, 1e3, "nm"), (3e-10, 1e10, "1e-10 µm"),
                                               (0.0, 1.0, "µm")])
def test_error_unit_keeps_the_peak_between_one_tenth_and_a_thousand(peak, scale, unit):
    assert _error_unit(np.array([[0.0, -peak], [np.nan, peak / 2]])) == (scale, unit)


@pytest.mark.parametrize("size, unit", [(0.3, "µm"), (3e-4, "nm"), (3e-10, "1e-10 µm")])
def test_error_panels_y_labels_cover_neither_ticks_nor_other_panels(size, unit):
    fig, e = _figure(size)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    panels = [ax for ax in fig.axes if ax.get_ylabel().endswith(f"[{unit}]")
              and ("error" in ax.get_ylabel() or "||" in ax.get_ylabel())]
    assert len(panels) == 2                       # (c) per axis and (e) Euclidean
    scale = _error_unit(e[:, 1000:])[0]
    drawn = panels[0].get_lines()[0].get_ydata()
    assert np.nanmax(np.abs(drawn)) == pytest.approx(np.max(np.abs(e[0])) * scale, rel=0.05)
    for ax in panels:
        label = ax.yaxis.label.get_window_extent(renderer)
        for tick in ax.get_yticklabels():
            if tick.get_text():
                assert not tick.get_window_extent(renderer).overlaps(label), tick.get_text()
        for other in fig.axes:                    # pushed left by wide ticks, into panel (b)/(d)
            if other is not ax:
                assert not other.get_window_extent(renderer).overlaps(label), ax.get_ylabel()
    assert "µm" in panels[0].get_title() or "nm" in panels[0].get_title()   # the peak's note
