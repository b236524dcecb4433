"""Dynamics identified from outputs of unequal units (a tip-tilt platform's µrad beside µm).

The records of tests/core/test_fast_records_dynamics.py at 10 kHz (modes 350 and 520 Hz in
each output, 30 nm of noise), with the second output and its input (the hysteresis model's
output of the same unit) multiplied by k: the same actuator read in another unit. Before
the outputs were balanced, k = 300 fitted the first output at 68 % (99.4 % at k = 1) and
found a third mode at 350.7 Hz with damping 0.047; k = 1e4 fitted it at -12 % with a
2.4 kHz lag.
"""

import numpy as np
import pytest
from test_fast_records_dynamics import _records

from hammerstein.identification.record_identification import DYNAMICS_DEFAULTS
from hammerstein.models._lti_scaling import OUTPUT_SCALE_RATIO, output_scales
from hammerstein.models.lti import DynamicsIdentifier, modal_parameters

T = 1e-4


def _fit(k):
    ins, outs = _records(T)
    S = np.array([1.0, k])[:, None]
    opts = dict(DYNAMICS_DEFAULTS, validation_records=(2, 3))
    return DynamicsIdentifier(**opts).fit([u * S for u in ins], [y * S for y in outs], T)


@pytest.fixture(scope="module")
def alike():
    return _fit(1.0)


@pytest.mark.parametrize("k", [300.0, 1e4, 1e-3])
def test_an_output_in_another_unit_gives_the_same_model(alike, k):
    ident = _fit(k)
    assert ident.order_ == alike.order_
    np.testing.assert_allclose(np.sort(modal_parameters(ident.system_)[0]),
                               np.sort(modal_parameters(alike.system_)[0]), rtol=2e-3)
    np.testing.assert_allclose(ident.fit_percent_, alike.fit_percent_, atol=0.05)
    S = np.diag([1.0, k])
    G0 = np.asarray(ident.system_.dcgain())
    np.testing.assert_allclose(G0, np.eye(2), atol=1e-9)                 # G(0) = I kept
    # the same G read in the other unit: S G S^-1, at every frequency
    for f in (100.0, 350.0, 520.0, 1500.0):
        z = np.exp(2j * np.pi * f * T)
        H = ident.system_(z)
        H1 = S @ alike.system_(z) @ np.linalg.inv(S)
        assert np.max(np.abs(H - H1)) <= 0.02 * np.max(np.abs(H1)), f


def test_outputs_of_one_scale_are_fitted_as_they_are():
    y = np.vstack([np.sin(np.arange(500.0)), 3.0 * np.cos(np.arange(500.0))])
    assert output_scales([y]) is None
    assert output_scales([np.vstack([y[0], OUTPUT_SCALE_RATIO * y[0]])]) is not None
    assert output_scales([np.vstack([y[0], np.zeros(500)])]) is None
