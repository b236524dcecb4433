"""A stable inversion's drive starts at rest: the default fade-in's rest lead grows with G's
zero outside the unit circle, and the drive file says so, so that `learn` fades the same way.

G: the bundled 2x2 modes after ``(z - 1.01) / ((1 - 1.01) z)`` per output (a zero at 1.01,
whose anti-causal part decays as 1.01^-k, 0.37 per 100 samples).
"""

from __future__ import annotations

import math
import warnings

import control
import numpy as np
import pytest

from hammerstein.compensation.drive import drive_signal, hardware_drive, hardware_fade, rest_output
from hammerstein.compensation.drive_files import drive_rest_lead, fade_weight, rest_lead_text
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.lookahead import FIRST_SAMPLE_TOLERANCE
from hammerstein.io.presets import load_plant
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel

T = 5e-5
ZERO = 1.01


def _g():
    G = load_plant("rakotondrabe-2dof").dynamics
    G = control.ss(G.A, G.B, G.C, G.D, T)
    f = control.ss(control.tf([1.0, -ZERO], [1.0 - ZERO, 0.0], T))
    return control.series(G, control.append(f, f))


def _model():
    e = np.linspace(-12.0, 12.0, 13)
    d = [PreisachModel.from_density(e, total=t, coercivity=1.0, coercivity_width=2.0,
                                    reversible=[1.0]) for t in (25.0, 20.0)]
    return MultivariableHysteresis([[d[0], None], [None, d[1]]], input_names=["ux", "uy"],
                                   output_names=["x", "y"], input_amplitude=[10.0, 10.0])


def _circle(n=16000, f=100.0, radius=10.0):
    t = np.arange(n) * T
    return radius * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def _untapered(comp, fade, rest, lead=None):
    """The stable inversion's own drive of the circle faded over ``fade`` samples (V)."""
    return drive_signal(comp, hardware_fade(_circle(), fade, rest, lead), T, 200,
                        fade_samples=0).inputs


def test_the_default_fade_rests_until_the_pre_actuation_has_decayed():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = HammersteinCompensator(_model(), _g(), inversion="stable")
        rest = rest_output(comp.hysteresis_compensator.model)
        res = hardware_drive(comp, _circle(), T, 200, rest=rest)
        # the same fade with the plain tenth at rest: the pre-actuation is still there
        plain = _untapered(comp, res.fade_samples, rest)
    assert res.rest_lead is not None and res.rest_lead > res.fade_samples // 10
    assert np.max(np.abs(res.inputs[:, 0])) <= FIRST_SAMPLE_TOLERANCE     # rest: 0 V
    off = float(np.max(np.abs(plain[:, 0])))
    assert off > 1e3 * FIRST_SAMPLE_TOLERANCE
    # the lead held it: the drive is the inversion's own, not tapered
    np.testing.assert_array_equal(res.inputs, _untapered(comp, res.fade_samples, rest,
                                                         res.rest_lead))
    # the samples added are what the closed form asks of the drive before them (its fade
    # n0 = fade - added, a tenth of it at rest) for a tenth of the tolerance
    n0 = next(n for n in range(res.fade_samples) if res.fade_samples - n == res.rest_lead - n // 10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        before = _untapered(comp, n0, rest)
    d0 = float(np.max(np.abs(before[:, 0])))
    need = math.ceil(math.log(10 * d0 / FIRST_SAMPLE_TOLERANCE) / math.log(ZERO))
    assert abs(res.fade_samples - n0 - (need + 1)) <= 3
    # the reference the drive follows is hardware_fade's with that lead
    np.testing.assert_array_equal(res.reference,
                                  hardware_fade(_circle(), res.fade_samples, rest, res.rest_lead))


def test_a_zpetc_drive_keeps_the_tenth():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = HammersteinCompensator(_model(), _g())
        res = hardware_drive(comp, _circle(), T, 200)
    assert res.rest_lead is None


@pytest.mark.parametrize("lead", [None, 0, 1234])
def test_the_header_phrase_reads_back(tmp_path, lead):
    path = tmp_path / "d.csv"
    path.write_text(f"# hammerstein compensate drive: t [s]; ux [V]\n# actuator p, fade-in 4000 "
                    f"samples (0.2 s, {rest_lead_text(lead)}excluded from the metrics)\nt,ux\n0,0\n")
    assert drive_rest_lead(path) == lead


def test_a_short_record_keeps_three_quarters_to_judge():
    """The rest lead stops at a quarter of the record, fade included: what it did not hold is
    faded in over the lead (the drive still starts at rest), not bought with the part that is
    judged."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = HammersteinCompensator(_model(), _g(), inversion="stable")
        short = _circle(n=4000)
        res = hardware_drive(comp, short, T, 200)
    assert res.fade_samples <= short.shape[1] // 4
    lead = res.rest_lead if res.rest_lead is not None else res.fade_samples // 10
    rest = np.zeros(2)
    own = drive_signal(comp, hardware_fade(short, res.fade_samples, rest, lead), T, 200,
                       fade_samples=0).inputs
    assert np.max(np.abs(own[:, 0])) > FIRST_SAMPLE_TOLERANCE
    assert np.all(res.inputs[:, 0] == 0.0)
    np.testing.assert_array_equal(res.inputs[:, lead:], own[:, lead:])


def test_a_pre_actuation_the_lead_cannot_hold_is_faded_in_from_rest():
    """A given fade-in too short for the zero at 1.01 (its tenth at rest, 40 samples): the
    drive starts at rest, is the inversion's own drive weighted by the fade's weights over
    the lead and the inversion's own after it, and steps no more than that drive does."""
    fade = 400
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = HammersteinCompensator(_model(), _g(), inversion="stable")
        rest = rest_output(comp.hysteresis_compensator.model)
        res = hardware_drive(comp, _circle(), T, 200, fade_samples=fade, rest=rest)
    own = _untapered(comp, fade, rest)
    lead = fade // 10
    assert np.max(np.abs(own[:, 0])) > 1e3 * FIRST_SAMPLE_TOLERANCE
    assert np.all(res.inputs[:, 0] == 0.0)
    w = fade_weight(np.arange(lead) / lead)
    np.testing.assert_allclose(res.inputs[:, :lead], w * own[:, :lead], rtol=1e-12, atol=0)
    np.testing.assert_array_equal(res.inputs[:, lead:], own[:, lead:])
    # what the drive differs from the compensator's own (the exported C's) is said, and it
    # is the largest over the lead, not the first sample's offset, which understates it
    assert res.taper_change == np.max(np.abs(res.inputs - own))
    assert res.taper_change > np.max(np.abs(res.start_offset))
    steps = np.abs(np.diff(np.concatenate([np.zeros((2, 1)), res.inputs], axis=1), axis=1))
    assert np.all(steps.max(axis=1) <= np.abs(np.diff(own, axis=1)).max(axis=1))
