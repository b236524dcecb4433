"""The XY panels keep equal scales without a box mostly empty around the trajectory.

``adjustable="datalim"`` kept the panel's tall box and stretched the data limits: a 40 x 30 µm
raster was drawn with y from -22 to 55 µm. A trajectory of moderate aspect now gets a box of
its own aspect; a line scan (aspect beyond the range) still stretches the limits, as a box that
thin would not read.
"""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from hammerstein.report.trajectories import trajectory_figure, xy_overlay  # noqa: E402


def _raster(height):
    t = np.arange(4000) * 1e-4
    x = 20 * (1 + np.sign(np.sin(2 * np.pi * 10 * t)) * (2 * np.abs(((10 * t) % 1) - 0.5)))
    y = height * t / t[-1]
    return t, np.vstack([x, y])


def _spans(ax):
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    return x1 - x0, y1 - y0


@pytest.mark.parametrize("height", [30.0, 40.0, 20.0])
def test_a_square_ish_trajectory_fills_its_panel(height):
    t, r = _raster(height)
    fig = trajectory_figure(t, r, r + 0.01, ["x", "y"], "raster", settle_time=0.01)
    fig.canvas.draw()
    ax = fig.axes[0]
    dx, dy = _spans(ax)
    assert dy <= 1.15 * height and dx <= 1.15 * 40.0          # limits within 15 % of the data
    bbox = ax.get_window_extent()
    assert bbox.height / bbox.width == pytest.approx(dy / dx, rel=0.02)   # equal scales


def test_a_line_scan_keeps_a_readable_box():
    from hammerstein.report.trajectories import BOX_ASPECT_RANGE
    t, r = _raster(1.0)                                       # 40 x 1 µm: beyond the range
    assert 1.0 / 40.0 < BOX_ASPECT_RANGE[0]
    fig = xy_overlay([{"label": "line", "reference": r, "outputs": r}], ["x", "y"], "line")
    fig.canvas.draw()
    bbox = fig.axes[0].get_window_extent()
    assert bbox.height / bbox.width > 0.5                      # not a sliver
