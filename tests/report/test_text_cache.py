"""save() draws text with a renderer that caches layouts, extents and glyph images.

Reference: the same figure drawn by matplotlib's own Agg canvas. Text at
many sub-pixel positions (moved by fractions and by whole pixels), rotated,
not antialiased, mathtext (glyphs and rule boxes), several sizes and fonts;
drawn with an empty cache, a warm one, and a cache that fills up.
"""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hammerstein.report import figures


def _text_figure(seed):
    rng = np.random.default_rng(seed)
    fig = Figure(figsize=(5, 4), dpi=figures.DPI)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    for i in range(40):                   # the same strings at random sub-pixel positions
        ax.text(rng.uniform(0.02, 0.9), rng.uniform(0.02, 0.95), ["x [µm]", "−20", "0.5"][i % 3],
                fontsize=[7, 8, 10.5][(i // 3) % 3], transform=ax.transAxes,
                ha=["left", "center", "right"][i % 2], va=["baseline", "center", "top"][i % 3])
    for dx in range(3):                   # moved by whole pixels only
        ax.text(0.3, 0.5, "Wg", transform=ax.transAxes + _pixels_offset(fig, dx))
    ax.text(0.5, 0.2, "rotated 30°", rotation=30, transform=ax.transAxes)
    ax.text(0.5, 0.3, "vertical", rotation=90, transform=ax.transAxes)
    ax.text(0.1, 0.1, "aliased", antialiased=False, fontsize=12, transform=ax.transAxes)
    ax.text(0.6, 0.8, r"$\frac{a}{b}\,\sqrt{x_1^2}$", fontsize=11, transform=ax.transAxes)
    ax.text(0.6, 0.6, "serif bold", family="serif", weight="bold", transform=ax.transAxes)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(r"$u_1$ [V]")
    fig.suptitle("a title")
    return fig


def _pixels_offset(fig, dx):
    from matplotlib.transforms import ScaledTranslation
    return ScaledTranslation(dx / fig.dpi, 0.0, fig.dpi_scale_trans)


def _pixels(fig, canvas_class):
    canvas = canvas_class(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


@pytest.fixture
def empty_caches():
    for cache in (figures._layouts, figures._extents, figures._glyphs):
        cache.clear()


@pytest.mark.parametrize("seed", [0, 1])
def test_cached_text_has_matplotlibs_pixels_cold_and_warm(seed, empty_caches):
    reference = _pixels(_text_figure(seed), FigureCanvasAgg)
    assert np.array_equal(_pixels(_text_figure(seed), figures._Canvas), reference)    # cold
    assert figures._glyphs and figures._layouts and figures._extents
    assert np.array_equal(_pixels(_text_figure(seed), figures._Canvas), reference)    # warm


def test_a_full_cache_starts_again(monkeypatch, empty_caches):
    monkeypatch.setattr(figures, "_TEXT_CACHE_ENTRIES", 5)
    reference = _pixels(_text_figure(2), FigureCanvasAgg)
    assert np.array_equal(_pixels(_text_figure(2), figures._Canvas), reference)
    assert all(len(c) <= 5 for c in (figures._layouts, figures._extents, figures._glyphs))

