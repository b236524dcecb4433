"""The start-up corrected in the reference (:func:`start_up_in_reference`), on a static gain."""

import warnings

import numpy as np
import pytest

from hammerstein.compensation.start_up import HELD_STEP, settled_bound, start_up_in_reference


def test_an_axis_held_once_settled_is_corrected_within_the_moving_axis_steps():
    """A reference that holds one axis (its settled drive steps 0 V) divided by that 0,
    printed numpy's divide-by-zero warning on compensate's stderr and corrected no axis.
    The held axis now keeps within the moving one's settled step, and so does the moving
    one; beyond the correction the reference is the one asked."""
    moving = np.r_[0.0, np.full(29, 0.5), 0.5 + 0.05 * (np.arange(10) % 2)]
    held = np.r_[0.0, np.full(39, 0.3)]
    r = np.vstack([moving, held])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u, ref, asked, S, stop, changed = start_up_in_reference(
            lambda x: 2 * x, 2 * r, r, 20, 30, np.zeros(2), lambda v: v / 2)
    assert changed
    assert S[0] == pytest.approx(0.1, rel=1e-12) and S[1] == S[0]
    assert asked.tolist() == pytest.approx([1.0, 0.6], rel=1e-12)       # from rest, 2 x r
    steps = np.max(np.abs(np.diff(np.hstack([np.zeros((2, 1)), u]), axis=1)), axis=1)
    assert np.all(steps <= S * (1 + 1e-6))
    np.testing.assert_array_equal(u, 2 * ref)
    np.testing.assert_array_equal(ref[:, stop:], r[:, stop:])


@pytest.mark.parametrize("hold_step, held", [(0.0, True), (1e-11, True), (1e-4, False)])
def test_an_input_is_held_when_its_settled_steps_are_rounding(hold_step, held):
    """Held: settled steps within HELD_STEP of the input's voltage (a law's 2.4e-11 V on a
    1.41 V hold was a bound that kept the input at rest); it then takes the moving input's
    settled step."""
    n = np.arange(200)
    u = np.vstack([np.sin(2 * np.pi * n / 50), 1.41 + hold_step * (n % 2)])
    S = settled_bound(u, 100)
    own = np.max(np.abs(np.diff(u[:, 100:], axis=1)), axis=1)
    assert S[0] == own[0]
    assert S[1] == (own[0] if held else own[1])
    assert (hold_step <= HELD_STEP * 1.41) == held
