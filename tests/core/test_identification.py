"""Identification round trips: closed form (Appendix eq. 14-17), least squares, Steps 1-4.

A known model is simulated, re-identified, and the weights compared
(docs/identification.md: exact when the breakpoints fall on samples, about 1-2 % at 50 µs
sampling on a 50 Hz sine).
"""

import numpy as np
import pytest

from hammerstein import (HammersteinPlant, InverseMultiplicativeCompensator, MultivariablePI,
                         PrandtlIshlinskii, load_model)
from hammerstein.identification.identification import (ClosedFormPI, IdentificationError, LeastSquaresPI,
                                        MultivariableIdentifier, ascending_branches, fit_report,
                                        partition_thresholds)
from hammerstein.io.presets import read_toml
from hammerstein.identification.sensors import Sensor, characterize, identify_plant

EQ12 = np.array([0.07, 0.32, 0.74, 1.3, 2.0, 2.8, 3.67, 4.61, 5.54, 6.5, 7.34, 8.1, 8.8, 9.3, 9.7])
T = 5e-5


def sine(amplitude=10.0, frequency=50.0, periods=3, offset=0.0):
    t = np.arange(int(round(periods / (frequency * T))) + 1) * T
    return offset + amplitude * np.sin(2 * np.pi * frequency * t)


def triangle(lo, hi, step, cycles=3, start=None):
    """Triangle through the grid lo + k*step: start -> hi -> lo -> hi ... (all on the grid)."""
    start = lo if start is None else start
    up = lambda a, b: np.arange(a, b + step / 2, step)  # noqa: E731
    parts = [up(start, hi)]
    for _ in range(cycles):
        parts += [up(lo, hi)[::-1][1:], up(lo, hi)[1:]]
    return np.concatenate(parts)


# -- partitions -------------------------------------------------------------------
def test_time_partition_is_shifted_cosine_and_close_to_eq12():
    u = sine()
    r = partition_thresholds(u, 15, "time")
    i = np.arange(1, 16)
    np.testing.assert_allclose(r, 5.0 * (1 - np.cos(np.pi * i / 16)), atol=1e-3)
    # eq. (12) was made this way (Remark 5.1); with n+1 = 16 equal time steps the
    # thresholds agree with the printed ones to within 0.45 V (0.03 V at r_1).
    np.testing.assert_allclose(r, EQ12, atol=0.45)
    assert abs(r[0] - EQ12[0]) < 0.03


def test_input_partition_is_uniform_from_zero():
    r = partition_thresholds(sine(), 10, "input")
    np.testing.assert_allclose(r, np.arange(10) * 1.0, atol=1e-12)


def test_branches_skip_virgin_curve():
    u = sine(periods=3)          # 400 samples per period, starts at 0 V
    assert ascending_branches(u) == [(300, 500), (700, 900)]


# -- closed form ------------------------------------------------------------------
TRI_R = np.array([0.0, 0.5, 1.0, 2.0, 3.5, 5.0, 7.5, 9.0])


@pytest.mark.parametrize("weights", [
    [2.0, -0.3, 0.5, 0.4, 0.2, -0.1, 0.3, 1.0],
    [4.3, 0.1, 0.1, 0.2, 0.3, 0.4, 0.5, 2.0],
    [0.2, -0.05, 0.1, -0.1, 0.05, 0.02, -0.03, 0.01],   # a cross-coupling-like, non-monotone one
])
def test_closed_form_exact_when_breakpoints_on_samples(weights):
    u = triangle(-10.0, 10.0, 0.05, start=0.0)
    pi = PrandtlIshlinskii(TRI_R, weights)
    y, _ = pi.simulate(u)
    cf = ClosedFormPI(partition=TRI_R).fit(u, y)
    np.testing.assert_allclose(cf.weights_, weights, atol=1e-9)
    assert cf.offset_ == pytest.approx(0.0, abs=1e-9)
    assert cf.amplitude_ == pytest.approx(10.0, abs=1e-12)


def test_closed_form_offsets_and_off_centre_input():
    """Input centred at 4 V and output offset 3 µm: same weights, offset_ = 3 µm."""
    u = triangle(-6.0, 14.0, 0.05, start=4.0)
    w = [2.0, -0.3, 0.5, 0.4, 0.2, -0.1, 0.3, 1.0]
    y, _ = PrandtlIshlinskii(TRI_R, w).simulate(u)
    cf = ClosedFormPI(partition=TRI_R).fit(u, y + 3.0)
    np.testing.assert_allclose(cf.weights_, w, atol=1e-9)
    assert cf.offset_ == pytest.approx(3.0, abs=1e-9)
    assert cf.input_center_ == pytest.approx(4.0, abs=1e-9)


@pytest.mark.parametrize("component", [(0, 0), (0, 1), (1, 0), (1, 1)])
def test_closed_form_sine_50hz_within_2_percent(static_plant, component):
    """50 Hz sine sampled at 50 µs: breakpoints between samples (docs/identification.md)."""
    pi = static_plant.hysteresis.components[component[0]][component[1]]
    u = sine(periods=4)
    y, _ = pi.simulate(u)
    cf = ClosedFormPI(partition=pi.thresholds).fit(u, y)
    np.testing.assert_allclose(cf.weights_, pi.weights, rtol=0,
                               atol=0.025 * np.abs(pi.weights).max())
    # the identified loop: peak within 0.5 %
    assert cf.model_.peak_output(10.0) == pytest.approx(pi.peak_output(10.0), rel=5e-3)


def test_closed_form_rejects_short_record_and_large_thresholds():
    with pytest.raises(IdentificationError, match="no complete ascending branch"):
        ClosedFormPI().fit(sine(periods=0.7), sine(periods=0.7))
    u = sine()
    with pytest.raises(IdentificationError, match="half input span"):
        ClosedFormPI(partition=[1.0, 12.0]).fit(u, u)


# -- least squares ----------------------------------------------------------------
def test_least_squares_exact_without_noise(static_plant):
    pi = static_plant.hysteresis.components[0][0]
    u = sine(periods=3)
    y, _ = pi.simulate(u)
    ls = LeastSquaresPI(thresholds=pi.thresholds).fit(u, y + 1.5)
    np.testing.assert_allclose(ls.weights_, pi.weights, atol=1e-9)
    assert ls.offset_ == pytest.approx(1.5, abs=1e-9)
    assert ls.residual_rms_ < 1e-9


def test_least_squares_under_sensor_noise(static_plant):
    """40 nm quantisation + 50 nm RMS white noise, 5 periods: weights within 0.05 µm/V."""
    sensor = Sensor(resolution=0.04, bandwidth_hz=None, noise_rms=0.05, seed=3)
    pi = static_plant.hysteresis.components[1][1]
    u = sine(periods=5)
    y, _ = pi.simulate(u)
    ym = sensor.measure(y[None, :], T)[0]
    ls = LeastSquaresPI(thresholds=pi.thresholds).fit(u, ym)
    np.testing.assert_allclose(ls.weights_, pi.weights, atol=0.05)
    assert ls.residual_rms_ == pytest.approx(np.sqrt(0.05**2 + 0.04**2 / 12), rel=0.1)


@pytest.mark.parametrize("bounds, lo, hi", [("nonnegative", 0.0, np.inf), ((0.1, 1.0), 0.1, 1.0)])
def test_least_squares_bounds_respected(bounds, lo, hi):
    u = sine(periods=3)
    y, _ = PrandtlIshlinskii(EQ12, np.linspace(-0.5, 1.5, 15)).simulate(u)
    ls = LeastSquaresPI(thresholds=EQ12, bounds=bounds).fit(u, y)
    assert np.all(ls.weights_ >= lo - 1e-9) and np.all(ls.weights_ <= hi + 1e-9)


def test_least_squares_nonnegative_recovers_nonnegative_model():
    w = np.linspace(0.2, 1.0, 15)
    u = sine(periods=3)
    y, _ = PrandtlIshlinskii(EQ12, w).simulate(u)
    ls = LeastSquaresPI(thresholds=EQ12, bounds="nonnegative").fit(u, y)
    np.testing.assert_allclose(ls.weights_, w, atol=1e-8)


def test_least_squares_skip_warms_up_unknown_initial_state(static_plant):
    """Record starting at 5 V from an unknown play state: skipping one period recovers the weights."""
    pi = static_plant.hysteresis.components[0][0]
    u = sine(periods=3, offset=0.0)[100:] * 1.0          # starts at +10 V (a maximum)
    y, _ = pi.simulate(u, initial_state=np.full(15, 3.0))
    zero_state = LeastSquaresPI(thresholds=pi.thresholds).fit(u, y)
    assert zero_state.residual_rms_ > 0.01                 # the wrong state matters
    ls = LeastSquaresPI(thresholds=pi.thresholds).fit(u, y, skip=400)
    np.testing.assert_allclose(ls.weights_, pi.weights, atol=1e-9)
    ls2 = LeastSquaresPI(thresholds=pi.thresholds).fit(u, y, skip_seconds=0.02, sampling_period=T)
    np.testing.assert_allclose(ls2.weights_, pi.weights, atol=1e-9)


# -- multivariable (Steps 1-4) ------------------------------------------------------
def _compare(model, truth, atol_fraction):
    for l in range(truth.n_outputs):
        for k in range(truth.n_inputs):
            w0 = truth.components[l][k].weights
            w = model.components[l][k].weights
            np.testing.assert_allclose(w, w0, rtol=0, atol=atol_fraction * np.abs(w0).max()
                                       if atol_fraction else 1e-9, err_msg=f"component {l},{k}")


@pytest.mark.parametrize("method, atol_fraction", [("least-squares", 0), ("closed-form", 0.025)])
def test_multivariable_2x2_round_trip(static_plant, method, atol_fraction):
    model = identify_plant(static_plant, 50.0, method=method, partition=EQ12)
    _compare(model, static_plant.hysteresis, atol_fraction)
    assert model.input_names == ["ux", "uy"] and model.output_names == ["x", "y"]
    np.testing.assert_allclose(model.input_amplitude, [10.0, 10.0], atol=1e-12)


def test_multivariable_3x2_round_trip(static_plant):
    h = static_plant.hysteresis
    z_x = PrandtlIshlinskii(EQ12, 0.5 * h.components[0][0].weights)
    z_y = PrandtlIshlinskii(EQ12, -0.3 * h.components[1][1].weights)
    truth = MultivariablePI([h.components[0], h.components[1], [z_x, z_y]],
                            ["ux", "uy"], ["x", "y", "z"], [10.0, 10.0])
    plant = HammersteinPlant(truth, T)
    recs = characterize(plant, amplitude=[10.0, 10.5], frequency=50.0, periods=3)
    mi = MultivariableIdentifier("least-squares", partition=EQ12).fit(
        recs, ["ux", "uy"], ["x", "y", "z"])
    _compare(mi.model_, truth, 0)
    np.testing.assert_allclose(mi.model_.input_amplitude, [10.0, 10.5], atol=1e-9)
    np.testing.assert_allclose(mi.fit_rms_, 0.0, atol=1e-9)


def test_multivariable_per_component_counts_and_errors(static_plant):
    recs = characterize(static_plant, periods=3)
    mi = MultivariableIdentifier("closed-form", n_hysterons=[[15, 5], [4, 12]]).fit(recs)
    counts = [[mi.model_.components[l][k].n_hysterons for k in range(2)] for l in range(2)]
    assert counts == [[15, 5], [4, 12]]
    both = [(t, u + u[::-1], y) for t, u, y in recs]
    with pytest.raises(IdentificationError, match="only input 0 excited"):
        MultivariableIdentifier().fit(both)
    with pytest.raises(IdentificationError, match="n_hysterons"):
        MultivariableIdentifier(n_hysterons=[15, 15]).fit(recs)


def test_identified_model_saved_loaded_and_compensable(static_plant, tmp_path):
    path = tmp_path / "id50.toml"
    # the 2 kHz sensor lag steepens the last hysterons of a time partition (thresholds
    # crowd near the turning point) beyond the compensator's secant-gain convergence
    # bound; a partition uniform in voltage keeps the model compensable.
    model = identify_plant(static_plant, 50.0, out=path, partition="input",
                           sensor=Sensor(noise_rms=0.02, seed=1))
    loaded = load_model(path)
    np.testing.assert_allclose(loaded.secant_gains(), model.secant_gains(), rtol=1e-12)
    meta = read_toml(path)["identification"]
    assert meta["method"] == "closed-form" and meta["frequency_hz"] == 50.0
    assert meta["amplitude_V"] == [10.0, 10.0] and meta["partition"] == "input"
    assert np.array(meta["fit_rms_um"]).shape == (2, 2)
    # the secant gains of the model identified through the sensor match the plant's within 1 %
    np.testing.assert_allclose(loaded.secant_gains(), static_plant.hysteresis.secant_gains(),
                               rtol=0.01, atol=0.01)
    InverseMultiplicativeCompensator(loaded)        # accepted by the compensator


# -- sensor ----------------------------------------------------------------------
def test_sensor_lowpass_gain_and_quantisation():
    t = np.arange(20000) * T
    s = Sensor(resolution=0.0, bandwidth_hz=2000.0)
    const = s.measure(np.full((1, 100), 7.3), T)
    np.testing.assert_allclose(const, 7.3, atol=1e-12)          # unit DC gain, no start transient
    x = np.sin(2 * np.pi * 2000.0 * t)[None, :]
    amp = np.abs(s.measure(x, T)[0, 10000:]).max()
    assert amp == pytest.approx(1 / np.sqrt(2), rel=0.03)      # -3 dB at the bandwidth (bilinear)
    q = Sensor(resolution=0.04, bandwidth_hz=None).measure(x * 10, T)
    np.testing.assert_allclose(q / 0.04, np.round(q / 0.04), atol=1e-9)
    assert np.abs(q - x * 10).max() <= 0.02 + 1e-12


def test_sensor_noise_rms_and_seed():
    z = np.zeros((2, 50000))
    a = Sensor(resolution=0.0, bandwidth_hz=None, noise_rms=0.1, seed=7).measure(z, T)
    b = Sensor(resolution=0.0, bandwidth_hz=None, noise_rms=0.1, seed=7).measure(z, T)
    np.testing.assert_array_equal(a, b)
    assert np.sqrt(np.mean(a**2)) == pytest.approx(0.1, rel=0.02)


def test_fit_report_of_exact_model_is_zero():
    pi = PrandtlIshlinskii(EQ12, np.linspace(0.1, 1.0, 15))
    u = sine()
    y, _ = pi.simulate(u)
    rep = fit_report(pi, u, y + 2.0, offset=2.0, start=100)
    assert rep["rms_um"] < 1e-12 and rep["max_abs_um"] < 1e-12
    assert rep["output_range_um"] == pytest.approx(np.ptp(y[100:]))
    rep = fit_report(pi, u, y + 0.1 * np.ptp(y[100:]) / 100)
    assert rep["rms_percent_of_range"] == pytest.approx(0.1, rel=1e-9)
