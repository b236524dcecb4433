"""The caching renderer's font line metrics: the layouts of texts equal matplotlib's own."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import RendererAgg  # noqa: E402

from hammerstein.report import figures  # noqa: E402


@pytest.mark.parametrize("text,props", [
    ("x [µm]", {"fontsize": 10}),
    ("(a) direct: x vs ux\nsecond line", {"fontsize": 12, "fontweight": "bold"}),
    ("−3.5", {"fontsize": 8, "family": "monospace"}),
    ("tracking error", {"fontsize": 9.5, "style": "italic", "rotation": 90}),
    ("Ag", {"fontsize": 23, "family": "serif", "linespacing": 1.7}),
])
def test_text_layout_equals_matplotlib(text, props):
    fig = plt.figure(dpi=figures.DPI)
    t = fig.text(0.3, 0.4, text, **props)
    plain = RendererAgg(400, 300, figures.DPI)
    cached = figures._TextCachingRenderer(400, 300, figures.DPI)
    assert not hasattr(plain, "_get_font_height_metrics")   # matplotlib reads the font tables itself
    for _ in range(2):                                        # computed, then from the cache
        bbox, lines, descent = t._get_layout(cached)
        ref_bbox, ref_lines, ref_descent = t._get_layout(plain)
        assert bbox.bounds == ref_bbox.bounds
        assert lines == ref_lines and descent == ref_descent
    plt.close(fig)
