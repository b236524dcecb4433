"""hammerstein.models.lti: validation, identification of G, sensor handling, figure."""

import control
import numpy as np
import pytest

from hammerstein.models.dynamics import DynamicsError, bending_modes, discretize
from hammerstein.models.lti import (DynamicsIdentifier, align_dc_gain, compare_frequency_responses,
                                  continuous_system, dc_gain, excitation, modal_parameters,
                                  sensor_filter, state_space_dynamics)
from hammerstein.identification.sensors import Sensor

T = 5e-5
FN, ZETA = np.array([310.0, 290.0]), np.array([0.15, 0.20])


def mode_matrices(fn=300.0, zeta=0.2):
    wn = 2 * np.pi * fn
    return [[0.0, wn], [-wn, -2 * zeta * wn]], [[0.0], [wn]], [[1.0, 0.0]]


# -- state_space_dynamics ------------------------------------------------------------
def test_state_space_dynamics_dc_gain_reported_not_forced():
    A, B, C = mode_matrices()
    G = state_space_dynamics(A, B, 0.8 * np.array(C), names=["x"])
    assert isinstance(G, control.StateSpace) and G.isctime()
    assert dc_gain(G)[0, 0] == pytest.approx(0.8, rel=1e-12)   # -C A^-1 B = 0.8
    assert G.output_labels == ["x"] and G.input_labels == ["x_h"]


@pytest.mark.parametrize("A, B, C, D, key", [
    ([[1.0, 0.0]], [[1.0]], [[1.0]], None, "dynamics.A"),                    # not square
    ([[-1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0]], None, "dynamics.B"),       # rows != n
    ([[-1.0]], [[1.0]], [[1.0], [1.0]], None, "dynamics.C"),                 # p rows != p cols
    ([[-1.0]], [[1.0]], [[1.0]], [[0.0, 1.0]], "dynamics.D"),
    ([[-1.0]], [[np.nan]], [[1.0]], None, "dynamics.B"),
    ([[0.1]], [[1.0]], [[1.0]], None, "dynamics.A"),                         # unstable
    ([[0.0, 1.0], [-1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], None, "dynamics.A"),  # marginal
    ("abc", [[1.0]], [[1.0]], None, "dynamics.A"),
    ([-1.0], [[1.0]], [[1.0]], None, "dynamics.A"),                          # 1-D
])
def test_state_space_dynamics_bad_matrices_name_the_key(A, B, C, D, key):
    with pytest.raises(DynamicsError, match=key.replace(".", r"\.")):
        state_space_dynamics(A, B, C, D)


def test_modal_parameters_and_continuous_round_trip():
    Gc = bending_modes(FN, ZETA)
    Gd = discretize(Gc, T)
    f, z = modal_parameters(Gd)
    np.testing.assert_allclose(f, np.sort(FN), rtol=1e-9)
    np.testing.assert_allclose(z, ZETA[np.argsort(FN)], rtol=1e-9)
    back = continuous_system(Gd)
    np.testing.assert_allclose(dc_gain(back), np.eye(2), atol=1e-9)
    np.testing.assert_allclose(np.sort(np.abs(back.poles())), np.sort(np.abs(Gc.poles())), rtol=1e-9)


# -- identification ------------------------------------------------------------------
@pytest.fixture(scope="module")
def records():
    G = discretize(bending_modes(FN, ZETA), T)
    _, u = excitation(T, 2, 5.0, f_max=2000.0, period=0.02, periods=3, seed=3)
    y = [control.forced_response(G, U=ui).outputs for ui in u]
    return G, u, y


def check_model(ident, G, tol_resp):
    f, z = modal_parameters(ident.system_)
    assert ident.order_ == 4
    np.testing.assert_allclose(f, np.sort(FN), rtol=0.01)          # natural frequency within 1 %
    np.testing.assert_allclose(z, ZETA[np.argsort(FN)], rtol=0.05)
    c = compare_frequency_responses(ident.system_, G, np.linspace(5, 1000, 60))
    assert np.max(c["relative_error"]) < tol_resp                    # all 2x2 entries up to 1 kHz


def test_identifies_noise_free_system_from_two_records(records):
    G, u, y = records
    ident = DynamicsIdentifier(max_order=6).fit(u, y, T)
    check_model(ident, G, 1e-6)
    assert np.all(ident.fit_percent_ > 99.99)
    assert ident.singular_values_[3] > 1e6 * ident.singular_values_[4]   # order gap at 4
    assert ident.system_.dt == T


def test_sensor_pole_is_kept_out_of_the_model(records):
    G, u, y = records
    sensor = Sensor(resolution=0.04, bandwidth_hz=2000.0, noise_rms=0.01, seed=7)
    ym = [sensor.measure(yi, T) for yi in y]
    ident = DynamicsIdentifier(max_order=6, sensor=sensor).fit(u, ym, T)
    check_model(ident, G, 0.01)
    b, a = sensor_filter(sensor, T)
    z_sensor = -a[1] / a[0]                                           # 0.52 at 2 kHz, 20 kHz
    assert np.min(np.abs(ident.system_.poles() - z_sensor)) > 0.3
    # ignoring the sensor: the fit has to model its pole (more states or a worse response)
    naive = DynamicsIdentifier(max_order=6).fit(u, ym, T)
    c = compare_frequency_responses(naive.system_, G, np.linspace(5, 1000, 60))
    assert naive.order_ > 4 or np.max(c["relative_error"]) > 0.02


def test_single_array_record_and_fixed_order(records):
    G, u, y = records
    one = u[0] + u[1]
    out = y[0] + y[1]
    ident = DynamicsIdentifier(order=4).fit(one, out, T)
    assert ident.order_ == 4 and ident.orders_.tolist() == [4]


def test_malformed_records_raise(records):
    _, u, y = records
    with pytest.raises(DynamicsError, match="records"):
        DynamicsIdentifier().fit(u[0], y[0][:, :-1], T)
    with pytest.raises(DynamicsError, match="sampling_period"):
        DynamicsIdentifier().fit(u, y, 0.0)


def test_excitation_peak_and_band():
    t, recs = excitation(T, 2, [1.0, 2.0], f_max=1000.0, period=0.01, periods=2, offset=0.5)
    assert len(recs) == 2 and recs[1].shape == (2, t.size)
    assert np.max(np.abs(recs[1][1] - 0.5)) == pytest.approx(2.0)
    np.testing.assert_allclose(recs[1][0], 0.5)
    spec = np.abs(np.fft.rfft(recs[0][0, :200] - 0.5))
    freqs = np.fft.rfftfreq(200, T)
    assert np.all(spec[freqs > 1000.0] < 1e-9) and np.all(spec[(freqs > 0) & (freqs <= 1000)] > 1e-3)


def test_bode_figure(records, tmp_path):
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    G, _, _ = records
    fig = dynamics_bode_figure(G, G, frequencies_hz=np.logspace(0, 3.5, 50))
    assert len(fig.axes) >= 8                       # 2 x 2 entries x (magnitude, phase)
    fig.savefig(tmp_path / "bode.png")


def test_bode_figure_shows_both_systems_and_the_signal_names():
    """Regression: the 'true' curve was drawn solid over an identical 'identified' curve
    (the dashed style went to a Nyquist marker), and the panels read u[0] -> y[0]."""
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    G = discretize(bending_modes(FN, ZETA, ["x", "y"]), T)
    anonymous = control.ss(G.A, G.B, G.C, G.D, G.dt)            # identified: default names
    fig = dynamics_bode_figure(anonymous, G, frequencies_hz=np.logspace(0, 3.5, 50))
    both = 0
    for ax in fig.axes:
        styles = {ln.get_label(): ln.get_linestyle() for ln in ax.get_lines()
                  if len(ln.get_xdata()) == 50}
        assert styles.get("identified", "-") == "-" and styles.get("true", "--") == "--"
        both += styles == {"identified": "-", "true": "--"}
    assert both == 4              # the direct entries: magnitude and phase of x and y
    # one figure legend (off the panels), none on the axes; the Nyquist marker dotted
    assert all(ax.get_legend() is None for ax in fig.axes)
    (legend,) = fig.legends
    entries = {t.get_text(): h.get_linestyle() for t, h in
               zip(legend.get_texts(), legend.legend_handles)}
    assert {k: v for k, v in entries.items() if not k.startswith("Nyquist")} == \
        {"identified": "-", "true": "--"}
    assert all(v == ":" for k, v in entries.items() if k.startswith("Nyquist"))
    titles = " ".join(ax.get_title() for ax in fig.axes) + " ".join(
        t.get_text() for t in fig.texts)
    assert "x_h" in titles and "y_h" in titles and "u[0]" not in titles


def test_align_dc_gain_keeps_the_dynamics_and_takes_the_other_dc_gain():
    """G N with N = G(0)^-1 R(0): closed form at any frequency, poles unchanged."""
    wn = 2 * np.pi * np.array([350.0, 330.0])
    A = [[0, wn[0], 0, 0], [-wn[0], -0.24 * wn[0], 0, 0], [0, 0, 0, wn[1]],
         [0, 0, -wn[1], -0.36 * wn[1]]]
    B = [[0, 0], [wn[0], 0.05 * wn[0]], [0, 0], [-0.04 * wn[1], wn[1]]]
    G = discretize(state_space_dynamics(A, B, [[1, 0, 0, 0], [0, 0, 1, 0]], names=["x", "y"]), T)
    R = discretize(bending_modes(FN, ZETA, ["x", "y"]), T)         # DC gain I
    H = align_dc_gain(G, R)
    np.testing.assert_allclose(dc_gain(H), np.eye(2), atol=1e-9)
    N = np.linalg.inv([[1.0, 0.05], [-0.04, 1.0]])                 # G(0) written out from B
    z = np.exp(2j * np.pi * 300.0 * T)
    np.testing.assert_allclose(H(z), G(z) @ N, rtol=1e-9, atol=1e-12)
    assert abs(H(z)[0, 1]) < 1e-12   # the coupling through B shares the modes: all static
    np.testing.assert_allclose(np.sort_complex(H.poles()), np.sort_complex(G.poles()))
    assert H.output_labels == ["x", "y"] and H.dt == T
    singular = state_space_dynamics([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]])
    with pytest.raises(DynamicsError, match="singular"):
        align_dc_gain(singular, singular)


def test_align_dc_gain_to_identity_keeps_a_decoupled_system_exactly_decoupled():
    G = discretize(bending_modes(FN, ZETA, ["x", "y"]), T)
    H = align_dc_gain(G, np.eye(2))
    z = np.exp(2j * np.pi * 200.0 * T)
    assert H(z)[0, 1] == 0 and H(z)[1, 0] == 0           # the Bode figure's 'no coupling'
    np.testing.assert_allclose(np.diag(H(z)), np.diag(G(z)), rtol=1e-9)   # G(0) = I already


def test_bode_figure_marks_round_off_entries_as_no_coupling():
    """Regression: G G(0)^-1 of a coupled preset whose coupling is static leaves 1e-17
    off-diagonal entries; drawn at -340 dB they squeezed every panel's scale."""
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    G = discretize(bending_modes(FN, ZETA, ["x", "y"]), T)
    B = G.B.copy()
    B[0, 1] = B[2, 0] = 1e-17
    noisy = control.ss(G.A, B, G.C, G.D, T, inputs=G.input_labels, outputs=G.output_labels)
    fig = dynamics_bode_figure(G, noisy, frequencies_hz=np.logspace(0, 3.5, 50))
    assert sum("no coupling" in t.get_text() for ax in fig.axes for t in ax.texts) == 2
    assert min(ax.get_ylim()[0] for ax in fig.axes if "dB" in ax.get_ylabel()) > -200


def test_bode_figure_is_a_new_figure_each_call():
    """Regression: python-control drew the second call onto the first, unclosed figure."""
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    G = discretize(bending_modes(FN, ZETA, ["x", "y"]), T)
    f = np.logspace(0, 3.5, 50)
    first, second = dynamics_bode_figure(G, G, frequencies_hz=f), dynamics_bode_figure(G, G, frequencies_hz=f)
    assert first is not second
    assert [len(ax.get_lines()) for ax in second.axes] == [len(ax.get_lines()) for ax in first.axes]


def _loop_response(A, B, C, D, u, x0):
    """Naive reference: x_{k+1} = A x_k + B u_k, y_k = C x_k + D u_k, one step at a time."""
    x = np.array(x0, dtype=float)
    y = np.empty((C.shape[0], u.shape[1]))
    for k in range(u.shape[1]):
        y[:, k] = C @ x + D @ u[:, k]
        x = A @ x + B @ u[:, k]
    return y


@pytest.mark.parametrize("kind", ["lightly-damped modes", "real poles", "defective"])
def test_simulate_equals_the_state_recursion(kind):
    """_simulate (modal first-order filters; the regressors when A is defective) against
    the plain state recursion, from a non-zero initial state."""
    from hammerstein.models.lti import _simulate
    rng = np.random.default_rng(7)
    if kind == "lightly-damped modes":
        G = discretize(bending_modes(FN, [0.02, 0.05], ["x", "y"]), T)
        A, B, C = G.A, G.B + 0.1 * rng.standard_normal(G.B.shape), G.C
    elif kind == "real poles":
        Q = rng.standard_normal((3, 3))
        A, B, C = Q @ np.diag([0.9, -0.5, 0.2]) @ np.linalg.inv(Q), rng.standard_normal((3, 2)), \
            rng.standard_normal((2, 3))
    else:                                                   # a Jordan block: no eigenbasis
        A, B, C = np.array([[0.9, 1.0], [0.0, 0.9]]), rng.standard_normal((2, 2)), np.eye(2)
    D = rng.standard_normal((C.shape[0], B.shape[1]))
    u = rng.standard_normal((B.shape[1], 3000))
    x0 = rng.standard_normal(A.shape[0])
    expected = _loop_response(A, B, C, D, u, x0)
    np.testing.assert_allclose(_simulate(A, B, C, D, u, x0), expected, rtol=0,
                               atol=1e-10 * np.max(np.abs(expected)))


def test_fitted_identifier_round_trips_through_json(records):
    import json
    _, u, y = records
    sensor = Sensor(bandwidth_hz=2000.0)
    ident = DynamicsIdentifier(max_order=6, sensor=sensor).fit(u, y, T)
    back = DynamicsIdentifier.from_dict(json.loads(json.dumps(ident.to_dict())), sensor=sensor)
    for k in ("singular_values_", "orders_", "validation_fit_", "aic_", "fit_percent_",
              "initial_states_"):
        a, b = getattr(ident, k), getattr(back, k)
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(a, b)
    for k in "ABCD":
        np.testing.assert_array_equal(getattr(back.system_, k), getattr(ident.system_, k))
    assert (back.system_.dt, back.order_, back.sampling_period_) == (T, ident.order_, T)
    # NaN (orders whose validation failed) != NaN under ==: compare the JSON text of the two
    # dicts instead, where NaN is the token NaN and every float is written exactly (repr)
    assert json.dumps(ident.to_dict(), sort_keys=True).count("NaN") == sum(
        int(np.isnan(np.asarray(getattr(ident, k), dtype=float)).sum())
        for k in ident._FITTED_ARRAYS)
    assert json.dumps(back.to_dict(), sort_keys=True) == json.dumps(ident.to_dict(), sort_keys=True)
    assert back.sensor is sensor
    with pytest.raises(DynamicsError, match="not fitted"):
        DynamicsIdentifier().to_dict()
    with pytest.raises(DynamicsError, match="not a fitted identifier"):
        DynamicsIdentifier.from_dict({"params": {}, "fitted": {"A": [[1.0]]}})
