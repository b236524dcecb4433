"""Dynamics identified from noisy records of a slow stage whose modes sit near Nyquist.

The records are built here with python-control (no project code): a 2-axis stage sampled
at 5 kHz with its first bending modes at 1650 Hz (x, damping 0.03) and 1850 Hz (y, 0.025),
0.66 and 0.74 of the Nyquist frequency, second modes above Nyquist (4.2 and 5.3 kHz,
aliased), 10 % cross-coupling, a 2-sample acquisition delay and 150 nm of white noise on
multisines of 1.2 µm (10-2400 Hz, four periods), one estimation and one held-out record
per input, as ``hammerstein excitation --f-max 2400`` writes them.
"""

import control
import numpy as np
import pytest

from hammerstein.identification.record_identification import DYNAMICS_DEFAULTS
from hammerstein.models.lti import DynamicsIdentifier, continuous_system, modal_parameters

T = 2e-4


def _stage():
    s = control.tf("s")

    def axis(spec):
        g = 0
        for f, zeta, share in spec:
            w = 2 * np.pi * f
            g = g + share * w * w / (s * s + 2 * zeta * w * s + w * w)
        return control.ss(g)

    G = control.append(axis([(1650.0, 0.03, 0.93), (4200.0, 0.04, 0.07)]),
                       axis([(1850.0, 0.025, 0.92), (5300.0, 0.05, 0.08)]))
    G = G * control.ss([], [], [], np.array([[1.0, 0.1], [-0.09, 1.0]]))
    return control.c2d(G, T, "zoh")


def _multisine(f_max, seed, amplitude, n_period=500, periods=4):
    df = 1 / (n_period * T)
    j = np.arange(1, int(f_max / df) + 1)
    spectrum = np.zeros(n_period // 2 + 1, complex)
    spectrum[j] = np.exp(1j * np.random.default_rng(seed).uniform(0, 2 * np.pi, j.size))
    one = np.fft.irfft(spectrum, n_period)
    return np.tile(one * amplitude / np.abs(one).max(), periods)


def lowrate_records(f_max=2400.0, amplitude=1.2, noise=0.15, delay=2, seed=1):
    """Estimation records of ux, uy, then the held-out ones (inputs [µm], outputs [µm])."""
    G = _stage()
    rng = np.random.default_rng(seed + 100)
    ins, outs = [], []
    for r in range(2):
        for k in range(2):
            u = np.zeros((2, 2000))
            u[k] = _multisine(f_max, seed + 2 * k + r, amplitude)
            y = control.forced_response(G, U=u).outputs
            y = np.concatenate([np.zeros((2, delay)), y[:, :-delay]], axis=1)
            ins.append(u)
            outs.append(y + noise * rng.standard_normal(y.shape))
    return ins, outs


def _identify(ins, outs, **options):
    opts = dict(DYNAMICS_DEFAULTS, validation_records=(2, 3))   # require_continuous as identify
    opts.update(options)
    return DynamicsIdentifier(**opts).fit(ins, outs, T)


def test_an_order_without_a_zoh_equivalent_is_a_rejected_candidate_not_the_choice():
    """The default search rejects the orders whose poles have no continuous ZOH equivalent
    (the preset stores G in continuous time) and keeps one that has one; the kept model
    holds both first modes of the simulated stage."""
    ident = _identify(*lowrate_records())
    cont = continuous_system(ident.system_)          # raised on the model chosen before
    rejected = [c["rejected"] for c in ident.candidates_ if c.get("rejected")]
    assert any("no continuous ZOH equivalent" in r and "2500 Hz" in r for r in rejected)
    f, zeta = modal_parameters(cont)
    resonant = f[zeta < 0.2]
    for true in (1650.0, 1850.0):
        assert np.min(np.abs(resonant - true)) < 0.03 * true, (true, f, zeta)


def test_a_fixed_order_without_a_zoh_equivalent_says_why():
    """--order N whose model has a real pole at z <= 0 is refused naming that reason."""
    ins, outs = lowrate_records()
    orders = _identify(ins, outs).candidates_
    bad = [c["order"] for c in orders if "no continuous ZOH" in c.get("rejected", "")]
    assert bad
    with pytest.raises(ValueError, match=f"order {bad[0]} is rejected: a real pole at z <= 0"):
        _identify(ins, outs, order=bad[0])

