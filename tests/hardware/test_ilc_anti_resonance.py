"""Learning leaves the harmonics at an anti-resonance alone, and says where Q contracts.

Expectations, derived independently of the code:

* two bending modes of one axis, ``G(s) = a w1^2 / (s^2 + 2 z w1 s + w1^2)
  + b w2^2 / (s^2 + 2 z w2 s + w2^2)`` with ``a + b = 1``, have a
  transmission zero between them where the two terms cancel:
  ``1 = f^2 (a / f2^2 + b / f1^2)`` in the undamped limit (a one-axis stage
  of 900 and 2800 Hz, 92 / 8 %: 2151 Hz). There the inverse's gain, relative
  to its static gain 1, is ``1 / |G(f)|``, of the order of ``1 / zeta``;
* :func:`inverse_gain_ratio` is that ``1 / |G|`` (checked against
  python-control's frequency response), and :func:`harmonic_base_gains`
  with ``inverse_limit`` zeroes exactly the harmonics where it exceeds the
  limit, leaving ``gamma |Q|^2`` elsewhere;
* ``||I - gamma Q L G||`` is 1 wherever Q passes nothing, so its maximum
  over every frequency is 1 for any learning: the summary reports the band
  Q passes, and says monotonic only below 1 there.
"""

import control
import numpy as np
import pytest
from scipy import signal

from hammerstein.compensation.ilc import (ConvergenceCondition, IterativeLearning,
                                          harmonic_base_gains, inverse_gain_ratio)
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii

T = 5e-5
F1, F2, SHARE = 900.0, 2800.0, 0.92


def _pi():
    return MultivariablePI([[PrandtlIshlinskii([0.0, 2.0, 4.0], [1.0, 0.3, 0.2])]],
                           input_names=["u"], output_names=["x"], input_amplitude=[10.0])


def _two_modes(zeta=0.02):
    w1, w2 = 2 * np.pi * F1, 2 * np.pi * F2
    g = (SHARE * control.tf([w1 ** 2], [1, 2 * zeta * w1, w1 ** 2])
         + (1 - SHARE) * control.tf([w2 ** 2], [1, 2 * zeta * w2, w2 ** 2]))
    return control.ss(control.c2d(g, T, "zoh"))


def test_the_zero_between_two_modes_is_where_the_closed_form_puts_it():
    G = _two_modes(zeta=1e-4)
    f0 = 1.0 / np.sqrt(SHARE / F2 ** 2 + (1 - SHARE) / F1 ** 2)        # 2151 Hz
    f = np.linspace(1500.0, 2600.0, 2201)
    ratio = inverse_gain_ratio(G, f, T)
    assert f[np.argmax(ratio)] == pytest.approx(f0, rel=0.01)        # zoh moves it a little
    mag = np.abs(G(np.exp(2j * np.pi * f * T)))
    np.testing.assert_allclose(ratio, (1.0 / mag) / (1.0 / abs(G(1.0))), rtol=1e-9)


def test_harmonics_beyond_the_inverse_limit_are_not_learnt_and_the_others_keep_their_gain():
    G = _two_modes(zeta=1e-3)
    ilc = IterativeLearning(_pi(), G, T, 0.5, 2250.0)
    P = 1000                                                          # 20 Hz harmonics
    free = harmonic_base_gains(ilc, P, None, 2250.0)
    kept = harmonic_base_gains(ilc, P, None, 2250.0, inverse_limit=100.0)
    fh = np.arange(P // 2 + 1) / (P * T)
    ratio = 1.0 / np.abs(G(np.exp(2j * np.pi * fh * T))) * abs(G(1.0))
    b, a = signal.butter(ilc.q_order, 2250.0, fs=1 / T)
    q2 = np.abs(signal.freqz(b, a, worN=fh, fs=1 / T)[1]) ** 2
    np.testing.assert_allclose(free, 0.5 * q2, rtol=1e-12)
    out = ratio > 100.0
    band = out & (fh <= 2250.0)                 # below Q's cut-off: around the zero only
    assert band.any() and np.all((fh[band] > 2000) & (fh[band] < 2300))
    assert np.all(kept[out] == 0.0)
    np.testing.assert_allclose(kept[~out], free[~out], rtol=0, atol=0)


def test_the_summary_reports_the_band_q_passes():
    f = np.geomspace(1.0, 9990.0, 400)
    passband = f <= 2000.0
    coupled = np.where(passband, 0.5, 1.0)
    cond = ConvergenceCondition(f, coupled[None, :], coupled, passband)
    text = cond.summary(["x"])
    assert "over the harmonics Q passes (the highest at 19" in text and "coupled 0.500" in text
    assert "<= 1: monotonic" in text and "9990" not in text
    flat = ConvergenceCondition(f, np.ones((1, f.size)), np.ones(f.size), passband)
    assert "monotonic" not in flat.summary(["x"]) and "no contraction" in flat.summary(["x"])


def test_the_learning_reports_its_condition_where_q_passes():
    G = _two_modes()
    ilc = IterativeLearning(_pi(), G, T, 0.5, 1000.0)
    cond = ilc.convergence()
    text = cond.summary(["x"])
    assert "the highest at" in text and float(text.split("coupled ")[1].split()[0]) < 0.9
