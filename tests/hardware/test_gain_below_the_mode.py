"""The gain against the model is judged below the first bending mode, not at it.

A 10 µm circle at 300 Hz on a stage whose identified first mode is 299 Hz
(22.7 times its static gain there) read a gain of 1.218 against a model
fresh from ``identify``: ``evaluate --model`` and every ``learn`` trial said
the actuator had changed since it was identified. At a resonance the mode's
gain depends on its identified frequency and damping to the per mil; the
same stage read 1.003 at 150 Hz.
"""

import numpy as np
import pytest

from hammerstein.cli._learn_checks import (BAND_HARMONICS, GAIN_MODE_SHARE, band_share, gain_band,
                                           plant_first_mode)
from hammerstein.io.presets import load_plant

T = 5e-5


def test_the_first_mode_of_a_preset_is_its_damped_frequency():
    # rakotondrabe-2dof: y at 290 Hz, damping 0.20 (x at 310 Hz, 0.15): f_d = f_n sqrt(1 - z^2)
    f1 = plant_first_mode(load_plant("rakotondrabe-2dof")) / T
    assert f1 == pytest.approx(290.0 * np.sqrt(1 - 0.2 ** 2), rel=1e-9)
    assert plant_first_mode(load_plant("rakotondrabe-2dof", dynamics=False)) is None


@pytest.mark.parametrize("f_ref, expected", [
    (20.0, 4 * 20.0 * T),                      # 80 Hz: below 0.6 f1, band_share's band
    (100.0, GAIN_MODE_SHARE * 284.14 * T),     # 400 Hz capped at 0.6 f1 = 170 Hz
    (171.0, 0.0),                              # above 0.6 f1 (170.5 Hz): not judged
    (300.0, 0.0),
])
def test_the_band_stops_below_the_mode(f_ref, expected):
    P = 1.0 / (f_ref * T)
    t = np.arange(4000) * T
    circle = np.vstack([np.cos(2 * np.pi * f_ref * t), np.sin(2 * np.pi * f_ref * t)])
    band = gain_band(P, circle, 284.14 * T)
    assert band == pytest.approx(expected, rel=1e-3, abs=0.0)
    # without dynamics: band_share's, whatever the frequency
    assert gain_band(P, circle, None) == band_share(P, circle) == pytest.approx(
        BAND_HARMONICS * f_ref * T, rel=1e-3)
