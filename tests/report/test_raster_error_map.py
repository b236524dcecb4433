"""The raster error map: a centred raster drawn where it scans, and colours a start-up cannot
wash out (a new user's scenario: a raster centred at (25, 25) µm drawn over 0-20 µm, and
every line but the first white)."""

import matplotlib
import numpy as np

matplotlib.use("Agg")

from hammerstein.report.trajectories import raster_error_map  # noqa: E402
from hammerstein.signals.references import REFERENCE_KINDS  # noqa: E402


def test_a_centred_raster_is_drawn_where_it_scans():
    table = {"outputs": ["x", "y"], "size": [20.0, 20.0], "lines": 8, "frequency": 20.0,
             "slow": "step", "smoothing": 0.0, "center": [25.0, 25.0]}
    kind = REFERENCE_KINDS["raster"]
    t, ref, _, _ = kind.generate(dict(table), 1e-4, ["x", "y"], None)
    scan = kind.scan(t, table, ["x", "y"])
    assert scan["start"] == 15.0 and scan["extent"] == 20.0
    e = np.full((2, t.size), 0.05)
    e[:, scan["line"] == 0] = 16.0                     # a start-up on the first line
    fig = raster_error_map(ref[0], e, ["x", "y"], scan["line"], scan["trace"], scan["extent"],
                           "x", "t", start=scan["start"])
    ax = fig.axes[0]
    assert ax.get_xlim() == (15.0, 35.0)
    img = ax.get_images()[0]
    assert np.isfinite(img.get_array()).mean() > 0.9      # the scan is inside the map
    lo, hi = img.get_clim()
    assert hi < 16.0 and hi >= 0.05                       # not the start-up's scale
    assert "capped (max 16)" in fig.axes[-1].get_ylabel()
