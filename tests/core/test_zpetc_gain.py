"""The ZPETC inverse's gain error, named by ``compensate`` (a new user's unipolar stage).

Its identified dynamics held a zero pair at 375 Hz just outside the unit circle
(|z| = 1.004); ZPETC approximates such a zero by a zero-phase factor, and its 30 µm
circle at 150 Hz came out at 0.70 of its size without a word. Expectations: Tomizuka's
closed form ``G F = |b(e^jwT)|^2 / b(1)^2`` against the gain measured on a sine through
the inverse and G, and the note's threshold.
"""

import numpy as np
import pytest
import control

from hammerstein.compensation.inversion import ZPETCInverse
from hammerstein.compensation.zpetc_notes import ZPETC_NOTE_ERROR, zpetc_gain, zpetc_note

T = 1e-4


def _plant(radius=1.004, zero_hz=375.0):
    """A sampled second-order mode at 180 Hz whose numerator holds the zero pair
    ``radius e^(+-j 2 pi zero_hz T)`` (outside the unit circle for radius > 1), unit DC gain."""
    zeros = radius * np.exp(2j * np.pi * zero_hz * T * np.array([1, -1]))
    poles = 0.97 * np.exp(2j * np.pi * 180.0 * T * np.array([1, -1]))
    num, den = np.real(np.poly(zeros)), np.real(np.poly(poles))
    num = num * np.polyval(den, 1.0) / np.polyval(num, 1.0)
    return control.ss(control.tf(num, np.concatenate([den, [0.0]]), T))   # one sample of delay


@pytest.mark.parametrize("hz", [20.0, 50.0, 150.0, 300.0])
def test_the_closed_form_is_the_measured_gain(hz):
    G = _plant()
    inv = ZPETCInverse(G)
    assert inv.unacceptable_zeros.size == 2
    n = 20000
    t = np.arange(n) * T
    yr = np.sin(2 * np.pi * hz * t)[None, :]
    v = inv.apply(yr)
    y = control.forced_response(G, U=v, X0=inv.plant_state(yr[:, 0])).outputs
    y = np.atleast_2d(y)
    tail = slice(n // 2, n - 50)
    basis = np.vstack([np.sin(2 * np.pi * hz * t[tail]), np.cos(2 * np.pi * hz * t[tail])]).T
    measured = np.linalg.norm(np.linalg.lstsq(basis, y[0, tail], rcond=None)[0])
    assert measured == pytest.approx(zpetc_gain(inv.unacceptable_zeros, T, [hz])[0], rel=1e-3)


def test_the_note_names_a_gain_error_beyond_its_threshold():
    zeros = ZPETCInverse(_plant()).unacceptable_zeros
    t = np.arange(8000) * T
    for hz, named in ((5.0, False), (150.0, True)):
        ref = 30.0 * np.vstack([np.cos(2 * np.pi * hz * t), np.sin(2 * np.pi * hz * t)])
        note = zpetc_note(zeros, T, ref, int(round(1 / (hz * T))))
        g = zpetc_gain(zeros, T, [hz])[0]
        assert (abs(g - 1) > ZPETC_NOTE_ERROR) == named and (note is not None) == named
        if named:
            assert f"at {g:.3g} of its gain" in note and "375" in note and "--inversion stable" in note
    assert zpetc_note([], T, ref, 67) is None
    assert zpetc_note(zeros, T, ref, None) is None
