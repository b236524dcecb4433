"""The convergence figure draws what ``learn`` judges: the settled max Euclidean error (two
outputs or more) and the judged error, from ``settled.csv`` and the trial being written.

It drew the per-axis max and RMS alone, while ``learn`` prints and judges the Euclidean max
and the period-averaged error.
"""

import numpy as np
import pytest

from hammerstein.cli._learn_history import SETTLED_FILE, _settled_series
from hammerstein.report.ilc_figure import convergence_figure


def _lines(fig):
    return {ln.get_label(): ln.get_ydata() for ln in fig.axes[0].get_lines()}


JUDGED = "judged error (what learn compares: noise averaged out)"
EUCLID = "max Euclidean error ||Y_r - Y|| (settled)"


@pytest.mark.parametrize("names, drawn", [(["x", "y"], True), (["x"], False)])
def test_the_euclidean_and_judged_errors_are_drawn(names, drawn):
    k = np.arange(4)
    mx = np.full((len(names), 4), 1.0)
    euclid, judged = np.array([2.0, 1.0, 0.5, np.nan]), np.array([1.5, 0.8, 0.3, 0.2])
    fig = convergence_figure(k, mx, 0.5 * mx, names, "t", 30.0, euclidean=euclid, judged=judged)
    lines = _lines(fig)
    np.testing.assert_array_equal(lines[JUDGED], judged)
    assert (EUCLID in lines) == drawn          # one output: its max is the Euclidean
    if drawn:
        np.testing.assert_array_equal(lines[EUCLID], euclid)
    (legend,) = fig.legends
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels.count(JUDGED) == 1


def test_settled_series_reads_the_file_and_the_trial_being_written(tmp_path):
    (tmp_path / SETTLED_FILE).write_text(
        "trial,settled_max_euclidean_um,settled_rms_euclidean_um,judged_um\n"
        "0,2.5,1.0,2.0\n1,1.25,0.5,0.75\nbroken line\n")
    euclid, judged = _settled_series(tmp_path, [0, 1, 2, 3], (2, 0.6, 0.4))
    np.testing.assert_array_equal(euclid, [2.5, 1.25, 0.6, np.nan])
    np.testing.assert_array_equal(judged, [2.0, 0.75, 0.4, np.nan])
