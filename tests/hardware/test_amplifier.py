"""The amplifier model: range clip, slew limit, first-order bandwidth, limits and metrics.

Expectations: a naive per-sample loop written here from the documented
equations, closed forms (a sine's peak and slew rate), chunked == whole.
"""

import math
import warnings

import numpy as np
import pytest

from hammerstein.models.amplifier import (Amplifier, AmplifierChannel, amplifier_from_table,
                                        drive_metrics)
from hammerstein.io.presets import load_plant
from hammerstein.exceptions import AmplifierError, AmplifierWarning, PresetError


def naive(u, T, low, high, slew, bw, rest=0.0):
    """The three documented steps, one sample at a time."""
    out = []
    s = a = min(max(rest, low), high)
    beta = 1.0 - math.exp(-2 * math.pi * bw * T) if bw else 1.0
    for x in u:
        c = min(max(x, low), high)
        s = s + min(max(c - s, -slew * T), slew * T)
        a = a + beta * (s - a)
        out.append(a)
    return np.array(out)


@pytest.mark.parametrize("low, high, slew, bw", [
    (-10.0, 10.0, 2e4, None),
    (-10.0, 10.0, math.inf, None),
    (0.0, 150.0, 5e3, 2000.0),
    (-5.0, 8.0, 1e5, 500.0),
])
def test_apply_equals_the_naive_loop_and_chunks_equal_whole(low, high, slew, bw):
    T = 5e-5
    rng = np.random.default_rng(3)
    u = np.cumsum(rng.normal(0, 1.5, (1, 3000)), axis=1) + 20 * np.sin(np.arange(3000) / 50)
    amp = Amplifier([AmplifierChannel(low, high, slew, bw)], ["u"])
    whole, _ = amp.apply(u, T)
    np.testing.assert_allclose(whole[0], naive(u[0], T, low, high, slew, bw), rtol=0, atol=1e-10)
    parts, state = [], None
    for k in range(0, 3000, 701):
        y, state = amp.apply(u[:, k:k + 701], T, state)
        parts.append(y)
    np.testing.assert_allclose(np.concatenate(parts, axis=1), whole, rtol=0, atol=1e-12)
    assert whole.min() >= low - 1e-12 and whole.max() <= high + 1e-12
    steps = np.diff(np.concatenate([[min(max(0.0, low), high)], whole[0]]))
    assert np.max(np.abs(steps)) <= slew * T * (1 + 1e-9)


def test_drive_metrics_of_a_sine_match_the_closed_form():
    T, f, A = 1e-5, 100.0, 7.0
    t = np.arange(int(1 / f / T) * 3) * T
    u = A * np.sin(2 * np.pi * f * t)[None]
    peak, slew = drive_metrics(u, T)
    assert peak[0] == pytest.approx(A, rel=1e-6)
    assert slew[0] == pytest.approx(2 * np.pi * f * A, rel=1e-3)       # max |du/dt| = 2 pi f A
    _, step = drive_metrics(u + 3.0, T)                                  # a 3 V step from rest
    assert step[0] == pytest.approx(3.0 / T, rel=1e-3)


def test_check_reacts_as_limits_says_and_names_input_peak_and_limit():
    amp = amplifier_from_table({"range": [-10, 10], "slew_rate": 1e5}, ["ux", "uy"])
    T = 5e-5
    u = np.vstack([np.linspace(0, 19.4, 400), np.zeros(400)])
    # where: the peak's sample 399 of the ramp, t = 399 T = 0.01995 s
    with pytest.raises(AmplifierError, match=r"c1: input ux needs 19.4 V at t = 0.01995 s, "
                                             r"beyond the amplifier's range \[-10, 10\] V"):
        amp.check(u, T, "error", "c1")
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        problems = amp.check(u, T, "warn")
    assert len(problems) == 1 and len(rec) == 1 and issubclass(rec[0].category, AmplifierWarning)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert amp.check(u, T, "clip") == problems                 # silent
    step = np.vstack([np.full(10, 9.0), np.zeros(10)])                  # 9 V in one sample
    assert "slew rate of 1.8e+05 V/s, beyond the amplifier's 1e+05 V/s" in amp.violations(step, T)[0]
    assert amp.violations(np.clip(u, -10, 10), T) == []               # at the limit: passes


@pytest.mark.parametrize("table, message", [
    ({"range": [10, -10]}, "amplifier.range: expected min < max"),
    ({"range": 10}, "amplifier.range: expected [min, max]"),
    ({"slew_rate": -1}, "amplifier.slew_rate: expected a positive number"),
    ({"bandwith_hz": 1}, "amplifier.bandwith_hz: unknown key"),
    ({"uz": {"range": [0, 1]}}, "amplifier.uz: not an input"),
    ({"uy": {"slew_rate": "fast"}}, "amplifier.uy.slew_rate: expected a positive number"),
])
def test_bad_tables_name_the_key(table, message):
    with pytest.raises(AmplifierError) as info:
        amplifier_from_table(table, ["ux", "uy"])
    assert message in str(info.value)


def test_preset_amplifier_table_per_input_overrides(tmp_path, repo_root):
    text = (repo_root / "hammerstein/presets/rakotondrabe-2dof.toml").read_text()
    p = tmp_path / "amp.toml"
    p.write_text(text + "\n[amplifier]\nrange = [-10.0, 10.0]\nslew_rate = 2e4\n"
                        "[amplifier.uy]\nrange = [0.0, 150.0]\nbandwidth_hz = 3000.0\n")
    plant = load_plant(p)
    ux, uy = plant.amplifier.channels
    assert (ux.low, ux.high, ux.slew_rate, ux.bandwidth_hz) == (-10, 10, 2e4, None)
    assert (uy.low, uy.high, uy.slew_rate, uy.bandwidth_hz) == (0, 150, 2e4, 3000.0)
    assert uy.rest == 0.0 and load_plant("rakotondrabe-2dof").amplifier is None
    p.write_text(text + "\n[amplifier]\nrange = [1.0, -1.0]\n")
    with pytest.raises(PresetError, match="amplifier.range"):
        load_plant(p)
