"""Dynamics identified from records sampled far faster than the modes (50 kHz).

The records are built here with python-control (no project code but the multisine): each
output holds two lightly damped modes, 350 Hz (damping 0.03) and 520 Hz (0.04), in the
shares 0.8/0.2 (x) and 0.25/0.75 (y), unit static gain, 30 nm of white noise, random-phase
multisines of 16 µm from 10 Hz to a quarter of the rate (as `hammerstein excitation`
writes them), one estimation and one held-out record per input. Before the decimation the
50 kHz records gave modes at 365 and 515 Hz with twice the damping (held-out fit 52 %).
"""

import control
import numpy as np
import pytest

from hammerstein.identification.record_identification import DYNAMICS_DEFAULTS
from hammerstein.models._lti_rate import decimation_factor
from hammerstein.models.lti import DynamicsIdentifier, continuous_system, modal_parameters
from hammerstein.signals.excitation import multisine

MODES = ((350.0, 0.03), (520.0, 0.04))


def _plant():
    s = control.tf("s")

    def mode(f, zeta):
        w = 2 * np.pi * f
        return control.ss(w * w / (s * s + 2 * zeta * w * s + w * w))

    (f1, z1), (f2, z2) = MODES
    return control.append(0.8 * mode(f1, z1) + 0.2 * mode(f2, z2),
                          0.25 * mode(f1, z1) + 0.75 * mode(f2, z2))


def _records(T, amplitude=16.0, noise=0.03, seed=1):
    G = control.c2d(_plant(), T, "zoh")
    rng = np.random.default_rng(seed + 100)
    ins, outs = [], []
    for r in range(2):
        for k in range(2):
            _, one = multisine(T, amplitude, 10.0, periods=4, seed=seed + 2 * k + r)[:2]
            u = np.zeros((2, one.size))
            u[k] = one
            y = control.forced_response(G, U=u).outputs
            ins.append(u)
            outs.append(y + noise * rng.standard_normal(y.shape))
    return ins, outs


def _identify(T, **options):
    opts = dict(DYNAMICS_DEFAULTS, validation_records=(2, 3))
    opts.update(options)
    return DynamicsIdentifier(**opts).fit(*_records(T), T)


@pytest.mark.parametrize("T", [1e-4, 2e-5])
def test_records_at_50_khz_give_the_modes_of_records_at_10_khz(T):
    """Both modes within 2 % of their frequency and 25 % of their damping, held-out fit
    above 90 %, the model at the records' own period."""
    ident = _identify(T)
    assert ident.system_.dt == pytest.approx(T)
    f, zeta = modal_parameters(continuous_system(ident.system_))
    for true_f, true_zeta in MODES:
        i = np.argmin(np.abs(f - true_f))
        assert abs(f[i] - true_f) < 0.02 * true_f, (f, zeta)
        assert abs(zeta[i] - true_zeta) < 0.25 * true_zeta, (f, zeta)
    chosen = np.flatnonzero(ident.orders_ == ident.candidate_order_)[0]
    assert ident.validation_fit_[chosen] > 90.0
    assert ident.decimation_ == (1 if T == 1e-4 else 5)


def test_the_model_at_50_khz_has_the_plants_response():
    """Returned at T = 20 µs through continuous time: gain within 1 %, phase within 2 deg
    of the plant's ZOH response at and around the modes (the ZOH half-sample corrected)."""
    T = 2e-5
    ident = _identify(T)
    G = control.c2d(_plant(), T, "zoh")
    for f in (100.0, 350.0, 520.0, 1000.0):
        z = np.exp(2j * np.pi * f * T)
        ratio = ident.system_(z)[0, 0] / G(z)[0, 0]
        assert abs(abs(ratio) - 1) < 0.01 and abs(np.degrees(np.angle(ratio))) < 2.0, f


def test_records_at_20_khz_and_below_are_not_decimated():
    """The identification of records at 20 kHz or below is unchanged."""
    assert [decimation_factor(T, 1e4) for T in (5e-5, 1e-4, 2e-4, 4.5e-5)] == [1, 1, 1, 1]
    assert decimation_factor(2e-5, None) == 1
