"""Input-output map grids letter the panels they draw with no gap.

Regression: a drive on u_x alone drew panels (a) and (c), leaving the
reader looking for (b) and (d).
"""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hammerstein.report.figures import decorate_grid  # noqa: E402


def _letters(columns, p=2, m=2):
    fig, axes = plt.subplots(p, len(columns), squeeze=False)
    decorate_grid(fig, axes, [0] * m, ["u_x [V]", "u_y [V]"][:m], ["x [µm]", "y [µm]"][:p],
                  "maps", columns=columns)
    titles = [ax.get_title() for ax in np.ravel(axes)]
    plt.close(fig)
    return [t.split(")")[0] + ")" for t in titles], titles


def test_one_column_is_lettered_a_b():
    letters, titles = _letters([0])
    assert letters == ["(a)", "(b)"]
    assert "direct: x vs u_x" in titles[0] and "cross-coupling: y vs u_x" in titles[1]


def test_full_grid_keeps_the_papers_letters():
    letters, titles = _letters([0, 1])
    assert letters == ["(a)", "(b)", "(c)", "(d)"]
    assert "cross-coupling: x vs u_y" in titles[1]
