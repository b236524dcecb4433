"""The start-up corrected in the reference (:func:`start_up_in_reference`), on a static gain."""

import warnings

import numpy as np

from hammerstein.compensation.start_up import start_up_in_reference


def test_an_axis_held_once_settled_leaves_the_others_corrected():
    """A reference that holds one axis (its settled drive steps 0 V) divided by that 0,
    printed numpy's divide-by-zero warning on compensate's stderr and corrected no axis.
    Now the held axis is left to the fade and the slew limit, and the moving one's start-up
    keeps within its settled step, as it does alone (the docstring's example)."""
    moving = np.r_[0.0, np.full(29, 0.5), 0.5 + 0.05 * (np.arange(10) % 2)]
    held = np.r_[0.0, np.full(39, 0.3)]
    r = np.vstack([moving, held])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u, ref, asked, S, stop, changed = start_up_in_reference(
            lambda x: 2 * x, 2 * r, r, 20, 30, np.zeros(2), lambda v: v / 2)
    alone = start_up_in_reference(lambda x: 2 * x, 2 * r[:1], r[:1], 20, 30, np.zeros(1),
                                  lambda v: v / 2)
    assert changed and alone[5]
    assert S[1] == 0.0 and S[0] > 0
    steps = np.max(np.abs(np.diff(np.hstack([np.zeros((2, 1)), u]), axis=1)), axis=1)
    assert steps[0] <= S[0] * (1 + 1e-6)
    np.testing.assert_array_equal(ref[1], held)          # the held axis: left as asked
    np.testing.assert_allclose(ref[0], alone[1][0], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(u, 2 * ref)
