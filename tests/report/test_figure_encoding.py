"""figures.save: the PNG holds exactly the pixels matplotlib draws, with fewer tick objects."""

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from hammerstein.report import figures  # noqa: E402


def _figure(kind):
    fig, axes = plt.subplots(1, 2, figsize=(6, 3), sharex=True)
    f = np.logspace(0, 3.7, 300)
    if kind == "log":
        axes[0].loglog(f, 1 / (1 + (f / 300) ** 2))
        axes[1].semilogx(f, np.degrees(np.arctan(f / 300)))
        axes[1].grid(True, which="both")
    else:
        t = np.linspace(-3.3, 7.9, 500)
        axes[0].plot(t, np.sin(t) * 17.3)
        axes[1].plot(t, t ** 2)
        axes[1].set_title("(b) text")
    return fig


def _reference_pixels(fig):
    """matplotlib's own PNG writer at the same resolution, decoded to RGB."""
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=figures.DPI, format="png")
    buffer.seek(0)
    return np.asarray(Image.open(buffer).convert("RGB"))


@pytest.mark.parametrize("kind", ["linear", "log"])
def test_save_writes_the_pixels_matplotlib_draws(kind):
    expected = _reference_pixels(_figure(kind))
    buffer = io.BytesIO()
    figures.save(_figure(kind), buffer)
    buffer.seek(0)
    image = Image.open(buffer)
    assert image.mode == "RGB"                       # the opaque alpha channel is dropped
    assert np.array_equal(np.asarray(image), expected)


@pytest.mark.parametrize("kind", ["linear", "log"])
def test_only_ticks_in_view_are_created(kind):
    plain, clipped = _figure(kind), _figure(kind)
    figures._ticks_in_view(clipped)
    counts = []
    for fig in (plain, clipped):
        fig.canvas.draw()
        counts.append(sum(len(a.majorTicks) + len(a.minorTicks)
                          for ax in fig.axes for a in (ax.xaxis, ax.yaxis)))
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                lo, hi = sorted(axis.get_view_interval())
                drawn = [t.get_loc() for t in axis._update_ticks()]
                if fig is clipped:   # every tick object left is one matplotlib draws
                    locs = axis.get_majorticklocs().tolist() + axis.get_minorticklocs().tolist()
                    assert sorted(locs) == pytest.approx(sorted(drawn))
                assert all(lo - 1e-9 * (hi - lo) <= v <= hi + 1e-9 * (hi - lo) for v in drawn)
    assert counts[1] < counts[0]
    plt.close(plain)
    plt.close(clipped)
