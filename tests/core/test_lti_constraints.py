"""The identifier's unit-static-gain constraint and its removal of slow / cancelled modes."""

import control
import numpy as np
import pytest

from hammerstein.models.dynamics import bending_modes, discretize
from hammerstein.models.lti import DynamicsIdentifier, dc_gain, excitation, modal_parameters

T = 5e-5


@pytest.fixture(scope="module")
def records():
    # a 2x2 G with static gain 1.3 I and two modes, plus a 2 Hz real pole
    # barely visible (0.2 % of the gain) that no 50 Hz-and-up excitation can show
    G = discretize(bending_modes([500.0, 700.0], [0.05, 0.08]), T)
    slow = control.sample_system(control.ss([[-2 * np.pi * 2.0]], [[2 * np.pi * 2.0, 0.0]],
                                            [[0.002], [0.0]], np.zeros((2, 2))), T, "zoh")
    _, u = excitation(T, 2, 5.0, f_min=50.0, f_max=4000.0, period=0.02, periods=4, seed=1)
    rng = np.random.default_rng(0)
    y = [1.3 * control.forced_response(G, U=ui).outputs
         + control.forced_response(slow, U=ui).outputs
         + 1e-3 * rng.standard_normal((2, ui.shape[1])) for ui in u]
    return u, y


def test_unit_dc_gain_is_exact_and_reports_the_unconstrained_gain(records):
    u, y = records
    ident = DynamicsIdentifier(order=4, unit_dc_gain=True).fit(u, y, T)
    np.testing.assert_allclose(dc_gain(ident.system_), np.eye(2), atol=1e-9)
    # the data's own static gain (1.3 on the diagonal) is what the constraint removed
    np.testing.assert_allclose(np.diag(ident.dc_gain_unconstrained_), 1.3, rtol=0.02)
    f, z = modal_parameters(ident.system_)
    np.testing.assert_allclose(f, [500.0, 700.0], rtol=0.01)


def test_slow_and_cancelled_modes_are_removed(records):
    u, y = records
    ident = DynamicsIdentifier(max_order=6, low_pole_fraction=0.5, cancel_tolerance=0.01,
                               unit_dc_gain=True).fit(u, y, T)
    f, _ = modal_parameters(ident.system_)
    # the band edge is estimated from the spectrum (Hann leakage of 12.5 Hz bins)
    assert 20.0 < ident.band_hz_[0] <= 50.0
    low = 0.5 * ident.band_hz_[0]
    assert np.all(f > low), f             # the 2 Hz pole is not in the model
    for c in ident.candidates_:
        assert all(m[0] > low for m in c.get("modes", []))
