"""save() skips the label placement of axes without a label: the pixels must not change.

Reference: the same figure drawn by matplotlib alone (automatic placement of
every label). Shared columns and rows, labels on some axes only.
"""

import io

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hammerstein.report import figures


def _figure(sharex, sharey):
    fig = Figure(figsize=(6, 4), dpi=figures.DPI)
    axes = fig.subplots(3, 2, sharex=sharex, sharey=sharey, squeeze=False)
    t = np.linspace(0.0, 1.0, 200)
    for i, ax in enumerate(axes.flat):
        ax.plot(t, np.sin(2 * np.pi * (i + 1) * t) * 10.0 ** i)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")                 # x labels on the bottom row only
    axes[0, 0].set_ylabel("x [µm]")               # one y label
    return fig


def _pixels(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


@pytest.mark.parametrize("sharex, sharey", [("col", False), (True, "row"), (False, False)])
def test_skipping_the_placement_of_empty_labels_keeps_every_pixel(sharex, sharey):
    reference = _pixels(_figure(sharex, sharey))
    fig = _figure(sharex, sharey)
    figures._unlabelled_axes_not_placed(fig)
    assert np.array_equal(_pixels(fig), reference)
    placed = [a.label.get_text() for ax in fig.axes for a in (ax.xaxis, ax.yaxis)
              if not a._autolabelpos]
    assert placed and all(text == "" for text in placed)    # only empty labels were fixed


def test_save_writes_the_same_png_pixels_as_matplotlib(tmp_path):
    from PIL import Image
    reference = _pixels(_figure("col", False))[..., :3]
    buffer = io.BytesIO()
    figures.save(_figure("col", False), buffer)
    buffer.seek(0)
    assert np.array_equal(np.asarray(Image.open(buffer).convert("RGB")), reference)
