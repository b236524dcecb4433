"""identify warns when the model misses the records' own loops on a direct path.

The rule (hammerstein.identification.identification_pipeline.minor_loop_warning) on hand-made level rows: only the
direct paths count (output l in the record of input l: a cross-coupling's small loop is mostly
the sensor's noise), the worst loop amplitude error is named, and the threshold is
MINOR_LOOP_WARN_PERCENT, between what Preisach- and generalised-PI-type actuators leave (at most
0.55 %) and what a Bouc-Wen family left (2.6-7.0 %).
"""

from types import SimpleNamespace

import pytest

from hammerstein.identification.identification_pipeline import MINOR_LOOP_WARN_PERCENT, minor_loop_warning


def _fit(rows):
    records = [SimpleNamespace(source="lab/hysteresis-ux.csv"),
               SimpleNamespace(source="lab/hysteresis-uy.csv")]
    splits = [SimpleNamespace(excitation=0), SimpleNamespace(excitation=1)]
    levels = [{"source": f"lab/hysteresis-{src}.csv", "percent": pct, "held_out": False,
               "output": out, "rms_percent": 0.1, "amplitude_error_percent": amp,
               "measured_peak_to_peak": 10.0} for src, pct, out, amp in rows]
    return SimpleNamespace(records=records, splits=splits, levels=levels)


@pytest.mark.parametrize("rows, expected", [
    ([("ux", 100, "x", 0.02), ("ux", 20, "x", -0.55), ("uy", 20, "y", 0.3)], None),
    # a coupling's loop (y in the ux record) is not judged, however far off
    ([("ux", 20, "y", 23.8), ("ux", 20, "x", 0.4), ("uy", 20, "y", -0.2)], None),
    ([("ux", 20, "x", -6.41), ("uy", 40, "y", -3.8), ("ux", 40, "x", 2.0)],
     "hysteresis-ux.csv's 20 % level by -6.41 % on x"),
    ([("ux", 20, "x", 0.1), ("uy", 40, "y", MINOR_LOOP_WARN_PERCENT + 0.01)],
     "hysteresis-uy.csv's 40 % level by +1.51 % on y"),
    ([("uy", 40, "y", MINOR_LOOP_WARN_PERCENT)], None),              # at the threshold: quiet
])
def test_the_worst_direct_loop_beyond_the_threshold_is_named(rows, expected):
    text = minor_loop_warning(_fit(rows), ["ux", "uy"], ["x", "y"])
    if expected is None:
        assert text is None
    else:
        assert expected in text and "learn" in text and "\n" not in text


def test_records_without_levels_get_no_warning():
    assert minor_loop_warning(_fit([]), ["ux", "uy"], ["x", "y"]) is None


@pytest.mark.parametrize("fit, warned", [(98.2, False), (90.0, False), (89.9, True), (16.0, True),
                                         (None, False), (float("nan"), False)])
def test_a_poor_dynamics_fit_is_named(fit, warned):
    """Below 90 % on the held-out broadband records (a 3-axis tube whose 2e4 V/s amplifier
    slew-limited the multisines: 16 %), identify warns and names the amplifier; a fit that
    was not measured is no warning."""
    from hammerstein.identification.identification_pipeline import dynamics_fit_warning
    line = dynamics_fit_warning({"held_out_fit_percent": fit})
    assert (line is not None) == warned
    if warned:
        assert f"{fit:.3g} %" in line and "amplifier" in line and "excitation" in line
