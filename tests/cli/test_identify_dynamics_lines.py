"""The identify line of the dynamics kept: the candidate it came from, and the states dropped.

A bender's identify printed "dynamics: order 4 (candidate order 5)" above a candidate line
"order 4: ... modes 260, 2583 Hz" that was another model than the one kept (the order-5
candidate with one pole dropped below the band: 260 and 1599 Hz).
"""

import pytest

from hammerstein.cli._identify_report import dynamics_report_lines


def _summary(order, candidate):
    return {"order": order, "candidate_order": candidate, "chosen_on": "held-out records",
            "band_hz": [4.3, 1255.0], "candidates": [], "modes": [],
            "dc_gain_unconstrained": [[1.0]], "dc_gain": [[1.0]], "unit_dc_gain": True,
            "dc_gain_scaled": False, "held_out_fit_percent": 97.0, "fit_percent": [97.0]}


@pytest.mark.parametrize("order, candidate, head", [
    (4, 5, "dynamics: order 4 (the order-5 candidate below, 1 state dropped), chosen on"),
    (4, 6, "dynamics: order 4 (the order-6 candidate below, 2 states dropped), chosen on"),
    (4, 4, "dynamics: order 4, chosen on"),
])
def test_the_order_kept_names_its_candidate_and_the_states_dropped(order, candidate, head):
    (first, *_) = dynamics_report_lines(_summary(order, candidate), ["x"], ["u"])
    assert first.startswith(head), first
