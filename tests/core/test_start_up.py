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


@pytest.mark.parametrize("level, hold_step, held", [
    (1.41, 0.0, True), (1.41, 2.4e-11, True), (1.41, 1e-4, False),
    (0.0, 1e-17, True),         # held at 0 V beside a moving input: rounding is not motion
    (0.0, 1e-3, False),
])
def test_an_input_is_held_when_its_settled_steps_are_rounding(level, hold_step, held):
    """Held: settled steps within HELD_STEP of the drive's largest settled voltage (a law's
    2.4e-11 V on a 1.41 V hold was a bound that kept the input at rest; 1e-17 V of rounding
    on an input at 0 V, measured against its own 0 V, kept its start-up at rest too); it
    then takes the moving input's settled step."""
    n = np.arange(200)
    u = np.vstack([3.0 * np.sin(2 * np.pi * n / 50), level + hold_step * (n % 2)])
    S = settled_bound(u, 100)
    own = np.max(np.abs(np.diff(u[:, 100:], axis=1)), axis=1)
    assert S[0] == own[0]
    assert S[1] == (own[0] if held else own[1])
    assert (own[1] <= HELD_STEP * np.max(np.abs(u[:, 100:]))) == held


def test_a_single_input_held_has_no_bound_and_moving_inputs_keep_their_own():
    """Every input held: nothing to bound the start-up with (inf); two moving inputs keep
    their own settled steps."""
    n = np.arange(200)
    held = np.vstack([np.full(200, 2.0)])
    assert settled_bound(held, 100).tolist() == [np.inf]
    moving = np.vstack([np.sin(2 * np.pi * n / 50), 0.5 * np.sin(2 * np.pi * n / 40)])
    own = np.max(np.abs(np.diff(moving[:, 100:], axis=1)), axis=1)
    np.testing.assert_array_equal(settled_bound(moving, 100), own)
