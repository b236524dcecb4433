"""Dynamics fitted on records whose static gain is not the hysteresis model's.

The multisines' response is built here with python-control (no project code): two modes
(350 Hz, damping 0.03, on x; 410 Hz, 0.045, on y, 2 % coupling), unit DC gain, driven by
what the hysteresis model predicts, v, times a static small-signal gain K = diag(0.88,
0.94) that the model does not draw (a Bouc-Wen stage's many small reversals), 20 nm noise.
The dynamics G are the actuator's shape: identify must return order 4 and G (G(0) = I),
the records' gain K only in ``dc_gain_unconstrained_``.
"""

import control
import numpy as np
import pytest

from hammerstein.identification.record_identification import DYNAMICS_DEFAULTS
from hammerstein.identification.identification_pipeline import STATIC_GAIN_WARN
from hammerstein.models._lti_subspace import STATIC_GAIN_STEP
from hammerstein.models.lti import DynamicsIdentifier

T = 1e-4
K = np.diag([0.88, 0.94])


def _stage():
    s = control.tf("s")
    w = [2 * np.pi * 350.0, 2 * np.pi * 410.0]
    z = [0.03, 0.045]
    axes = [control.ss(wi * wi / (s * s + 2 * zi * wi * s + wi * wi)) for wi, zi in zip(w, z)]
    G = control.append(*axes) * control.ss([], [], [], np.array([[1.0, 0.02], [-0.02, 1.0]]))
    G = G * control.ss([], [], [], np.linalg.inv(np.array([[1.0, 0.02], [-0.02, 1.0]])))
    return control.c2d(G, T, "zoh")          # G(1) = I


def _records(seed=3, gain=K):
    G = _stage()
    rng = np.random.default_rng(seed)
    ins, outs = [], []
    n_period = 2000
    df = 1 / (n_period * T)
    j = np.arange(1, int(1500 / df) + 1)
    for r in range(2):
        for k in range(2):
            spec = np.zeros(n_period // 2 + 1, complex)
            spec[j] = np.exp(1j * rng.uniform(0, 2 * np.pi, j.size))
            one = np.fft.irfft(spec, n_period)
            v = np.zeros((2, 4 * n_period))
            v[k] = np.tile(5.0 * one / np.abs(one).max(), 4)
            y = control.forced_response(G, U=gain @ v).outputs
            ins.append(v)
            outs.append(y + 0.02 * rng.standard_normal(y.shape))
    return G, ins, outs


@pytest.mark.parametrize("seed", [3, 4])
def test_the_records_static_gain_is_not_made_into_dynamics(seed):
    G, ins, outs = _records(seed)
    opts = dict(DYNAMICS_DEFAULTS, validation_records=(2, 3))
    d = DynamicsIdentifier(**opts).fit(ins, outs, T)
    np.testing.assert_allclose(d.dc_gain_unconstrained_, K, atol=0.01)
    assert d.order_ == 4 and d.dc_gain_scaled_  # the two modes, no slow pole pairs
    # what decided it, as identify prints it: the first fit's largest |G(1) - I|, K's 0.12
    assert d.dc_gain_step_ == pytest.approx(np.abs(K - np.eye(2)).max(), abs=0.01)
    s = d.system_
    np.testing.assert_allclose(s.C @ np.linalg.solve(np.eye(4) - s.A, s.B) + s.D, np.eye(2),
                               atol=1e-9)
    for f in (20.0, 200.0, 330.0, 500.0):       # the shape: G itself, not G K
        z = np.exp(2j * np.pi * f * T)
        got = s.C @ np.linalg.solve(z * np.eye(4) - s.A, s.B) + s.D
        true = G.C @ np.linalg.solve(z * np.eye(4) - G.A, G.B) + G.D
        assert np.abs(got - true).max() <= 0.03 * np.abs(true).max(), (f, got, true)


def test_records_with_the_models_gain_keep_g1_imposed_on_every_candidate():
    # within identify's static-gain warning the constraint stays (a free fit's G(1) is an
    # extrapolation below the band: scaled by it, realistic-2dof's circles went 1.0 -> 4.7 %)
    assert STATIC_GAIN_STEP == STATIC_GAIN_WARN
    G, ins, outs = _records(3, gain=np.diag([0.99, 1.01]))
    d = DynamicsIdentifier(**dict(DYNAMICS_DEFAULTS, validation_records=(2, 3))).fit(ins, outs, T)
    assert not d.dc_gain_scaled_
    s = d.system_
    np.testing.assert_allclose(s.C @ np.linalg.solve(np.eye(s.A.shape[0]) - s.A, s.B) + s.D,
                               np.eye(2), atol=1e-9)


def test_a_free_fit_whose_scaling_reaches_into_the_band_is_not_kept():
    """A slow lag-lead on x (DC 0.48, 1.0 from about 20 Hz: what a free fit drew on an AFM
    tube's records as a 7.1 Hz lag) makes the records' G(1) depart from I; scaled by that
    G(1), the free fit doubled G in the band and a 20 µm circle at 30 Hz missed by 55 %. The
    scaling may move the level below the band, not the band's gain: G(1) = I is imposed."""
    s = control.tf("s")
    wb = 2 * np.pi * 7.0
    lag = control.ss(0.48 * (1 + s / (0.48 * wb)) / (1 + s / wb))       # 0.48 at DC, 1 above
    L = control.c2d(control.append(lag, control.ss([], [], [], [[1.0]])), T, "zoh")
    G, ins, outs = _records(3)                # the small loops' gain K, as above
    outs = [control.forced_response(L, U=y).outputs for y in outs]     # y = L G K v
    # the free fit with its lag (lag_tolerance 0, chosen on the fit alone): not scaled; with
    # identify's defaults the lag (3.6 Hz, +0.65 points) is left out and the lag-free order
    # scaled: either way the band's gain is L G's
    for lag_tolerance, scaled in ((0.0, False), (DYNAMICS_DEFAULTS["lag_tolerance"], True)):
        d = DynamicsIdentifier(**dict(DYNAMICS_DEFAULTS, validation_records=(2, 3),
                                      lag_tolerance=lag_tolerance)).fit(ins, outs, T)
        assert d.dc_gain_unconstrained_[0, 0] < 1 - STATIC_GAIN_STEP    # the records' G(1)
        assert d.dc_gain_scaled_ is scaled
        sys_ = d.system_
        for f in (50.0, 200.0):               # the band's gain: L G's, about G's, not twice
            z = np.exp(2j * np.pi * f * T)
            got = sys_.C @ np.linalg.solve(z * np.eye(sys_.A.shape[0]) - sys_.A, sys_.B) + sys_.D
            true = (L.C @ np.linalg.solve(z * np.eye(L.A.shape[0]) - L.A, L.B) + L.D) @ (
                G.C @ np.linalg.solve(z * np.eye(4) - G.A, G.B) + G.D) @ K
            assert abs(abs(got[0, 0]) / abs(true[0, 0]) - 1) <= 0.25, (f, got, true)
