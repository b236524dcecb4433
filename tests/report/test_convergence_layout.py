"""The convergence figure of learn: every series visible, the legend on no data, labels said."""

import io

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from figure_checks import figure_problems  # noqa: E402

from hammerstein.report.figures import save  # noqa: E402
from hammerstein.report.ilc_figure import convergence_figure  # noqa: E402

EUCLID = "max Euclidean error ||Y_r - Y|| (settled)"


def test_every_series_is_visible_and_the_legend_covers_no_data():
    """Regression: x max (0.19 µm) was drawn exactly under the Euclidean max (0.19 µm) of
    the one trial, and the legend covered the top of the axes."""
    k = np.array([0])
    mx, rms = np.array([[0.1899], [0.1482]]), np.array([[0.0523], [0.0417]])
    fig = convergence_figure(k, mx, rms, ["x", "y"], "iterative learning control "
                             "(hammerstein learn): tracking error per trial", 30.0,
                             euclidean=np.array([0.1899]), judged=np.array([0.088]))
    save(fig, io.BytesIO())
    assert figure_problems(fig) == []
    ax = fig.axes[0]
    points = {ln.get_label(): ln.get_xydata()[0] for ln in ax.get_lines()}
    assert len(points) == 6
    px = {label: ax.transData.transform(xy) for label, xy in points.items()}
    euclid, xmax = px[EUCLID], px["x: max |x_r - x|"]
    assert abs(euclid[0] - xmax[0]) >= 8          # side by side, not one under the other
    (legend,) = fig.legends
    assert legend.get_window_extent().y1 <= ax.get_window_extent().y0   # under the axes
