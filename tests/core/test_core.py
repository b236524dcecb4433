"""The existing core against closed forms and the paper's numbers:
play operator on triangles, chunked = whole, PI peak, Fig. 5, the literal
law's divergence and the preset's bandwidths."""

import warnings

import numpy as np
import pytest

from hammerstein import (CompensatorError, InverseMultiplicativeCompensator,
                         bandwidths_hz, convergence_report, play,
                         simulate_chain)
from hammerstein.io.presets import bundled_presets, dynamics_from_table, read_toml

T = 5e-5
PERIOD = 400


def triangle(A, n_quarter=50):
    """0 -> A -> -A -> A, linear pieces, exact extrema."""
    up = np.linspace(0, A, n_quarter + 1)
    down = np.linspace(A, -A, 2 * n_quarter + 1)[1:]
    up2 = np.linspace(-A, A, 2 * n_quarter + 1)[1:]
    return np.concatenate([up, down, up2])


def play_triangle_closed_form(u, r, A):
    """Play output for triangle(A): virgin rise, then the backlash branches."""
    y = np.empty_like(u)
    n1 = np.argmax(u)                       # first maximum (A)
    n2 = n1 + np.argmin(u[n1:])             # minimum (-A)
    y[:n1 + 1] = np.maximum(u[:n1 + 1] - r, 0.0)
    y[n1:n2 + 1] = np.minimum(A - r, u[n1:n2 + 1] + r)
    y[n2:] = np.maximum(-A + r, u[n2:] - r)
    return y


@pytest.mark.parametrize("A, r", [(10.0, 0.0), (10.0, 0.07), (10.0, 3.0), (10.0, 9.7), (5.0, 2.5)])
def test_play_closed_form_on_triangle(A, r):
    u = triangle(A)
    y, final = play(u, [r])
    np.testing.assert_allclose(y[0], play_triangle_closed_form(u, r, A), atol=1e-12)
    assert final[0] == pytest.approx(A - r, abs=1e-12)


def test_play_threshold_above_amplitude_stays_at_initial_state():
    y, _ = play(triangle(2.0), [3.0], initial_state=[0.5])
    np.testing.assert_allclose(y, 0.5)


@pytest.fixture
def preset(preset_plant):
    return preset_plant


@pytest.fixture
def static(static_plant):
    return static_plant


def _record(n=900, seed=1):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    return np.vstack([8 * np.sin(2 * np.pi * 50 * t) + rng.normal(0, 0.5, n),
                      6 * np.sin(2 * np.pi * 70 * t + 1.0) + rng.normal(0, 0.5, n)])


def _chunks(run, data, splits=(137, 500)):
    """Run in chunks, carrying the final state; concatenate along time."""
    parts, state = [], None
    for a, b in zip((0, *splits), (*splits, data.shape[-1])):
        out, state = run(data[..., a:b], state)
        parts.append(out)
    return np.concatenate(parts, axis=-1)


@pytest.mark.parametrize("what", ["play", "pi", "mimo", "static-plant", "plant", "compensator"])
def test_chunked_equals_whole(what, preset, static):
    U = _record()
    if what == "play":
        r = [0.0, 0.5, 2.0]
        run = lambda u, s: play(u, r, s)  # noqa: E731
        data = U[0]
    elif what == "pi":
        op = preset.hysteresis.component("x", "ux")
        run, data = op.simulate, U[0]
    elif what == "mimo":
        run, data = preset.hysteresis.simulate, U
    elif what == "static-plant":
        run, data = static.simulate, U
    elif what == "plant":
        run, data = preset.simulate, U
    else:
        comp = InverseMultiplicativeCompensator(static.hysteresis)
        run, data = comp.simulate, 5.0 * U
    whole, _ = run(data, None)
    np.testing.assert_allclose(_chunks(run, data), whole, rtol=0, atol=1e-10)


@pytest.mark.parametrize("A", [10.0, 5.0, 1.0, 0.05])
def test_pi_peak_closed_form(preset, A):
    for l in range(2):
        for k in range(2):
            op = preset.hysteresis.components[l][k]
            active = op.thresholds < A
            expected = float(np.sum(op.weights[active] * (A - op.thresholds[active])))
            y, _ = op.simulate(triangle(A)[:51])  # the virgin rise to A
            assert y[-1] == pytest.approx(expected, abs=1e-10)
            assert op.peak_output(A) == pytest.approx(expected, abs=1e-10)


def _drive(k, f=50.0, periods=3):
    t = np.arange(int(periods * round(1 / (f * T)))) * T
    u = np.zeros((2, t.size))
    u[k] = 10.0 * np.sin(2 * np.pi * f * t)
    return u


def _h_over_H(u, y):
    from hammerstein.signals.metrics import hysteresis_width
    H = np.ptp(y[-PERIOD:])
    return 100 * hysteresis_width(u, y, PERIOD) / H


def test_fig05_numbers_from_the_preset(static):
    """Paper Section 5.1: ±58 µm, ±50.5 µm, h/H 17 % and 15.8 %, cross 3 and 4 µm p-p."""
    ux, uy = _drive(0), _drive(1)
    yx, _ = static.simulate(ux)
    yy, _ = static.simulate(uy)
    last = slice(-PERIOD, None)
    assert yx[0, last].max() == pytest.approx(58.0, rel=0.10)
    assert -yx[0, last].min() == pytest.approx(58.0, rel=0.10)
    assert yy[1, last].max() == pytest.approx(50.5, rel=0.10)
    assert _h_over_H(ux[0], yx[0]) == pytest.approx(17.0, rel=0.10)
    assert _h_over_H(uy[1], yy[1]) == pytest.approx(15.8, rel=0.10)
    assert np.ptp(yy[0, last]) == pytest.approx(3.0, rel=0.10)   # (u_y, x)
    assert np.ptp(yx[1, last]) == pytest.approx(4.0, rel=0.10)   # (u_x, y)
    # the peak of the direct loop is the closed form of Gamma_xx (u_y = 0)
    np.testing.assert_allclose(yx[0, last].max(),
                               static.hysteresis.components[0][0].peak_output(10.0), rtol=1e-9)


def test_literal_law_is_detected_as_divergent(static):
    model = static.hysteresis
    rep = convergence_report(model, "identity")
    assert not rep.converges and rep.max_radius > 2.0        # docs/compensator.md: about 3-9
    assert convergence_report(model, "secant").converges
    with pytest.raises(CompensatorError, match="rho"):
        InverseMultiplicativeCompensator(model, gain="identity")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        literal = InverseMultiplicativeCompensator(model, gain="identity", check="warn")
    t = np.arange(3 * PERIOD) * T
    ref = np.vstack([50 * np.sin(2 * np.pi * 50 * t), np.zeros_like(t)])
    res = simulate_chain(literal, static, ref)
    assert res.diverged and 0 < res.divergence.sample < 20
    assert np.all(np.isfinite(res.outputs[:, :res.divergence.sample]))
    assert np.all(np.isnan(res.outputs[:, res.divergence.sample:]))
    ok = simulate_chain(InverseMultiplicativeCompensator(model), static, ref)
    assert not ok.diverged
    assert np.sqrt(np.mean((ok.outputs[0, -PERIOD:] - ref[0, -PERIOD:]) ** 2)) < 0.5


def test_preset_bandwidths_between_400_and_500_hz():
    path = bundled_presets()["rakotondrabe-2dof"]
    data = read_toml(path)
    sys = dynamics_from_table(data["dynamics"], data["model"]["outputs"])
    bw = bandwidths_hz(sys)
    assert bw.shape == (2,)
    assert np.all((bw >= 400) & (bw <= 500)), bw
    # unit DC gain (the linear part does not rescale the PI output)
    assert np.allclose(np.diag(np.asarray(sys.dcgain())), 1.0)
