"""Multi-amplitude records: whole levels held out, per-level errors, noise-guarded pruning.

The records come from a naive play-operator loop written here (a classical
PI actuator, so its minor loops are exactly representable) and from the
decreasing-amplitude sine of the excitation module.
"""

import numpy as np
import pytest

from hammerstein.io.datafiles import MultiRecord
from hammerstein.signals.excitation import decreasing_sine
from hammerstein.identification.record_identification import (amplitude_levels, identify_records,
                                                    noise_level, split_record)

T = 1e-3


def _play(u, r):
    y = np.empty_like(u)
    prev = 0.0
    for i, v in enumerate(u):
        prev = max(v - r, min(v + r, prev))
        y[i] = prev
    return y


def _pi(u, radii=(0.0, 1.0, 2.5, 4.0), weights=(2.0, 1.0, 0.8, 0.5)):
    return sum(w * _play(u, r) for r, w in zip(radii, weights))


def _record(rng, coupling=0.0, noise=0.02):
    _, u, _ = decreasing_sine(T, 10.0, frequency=2.0)
    x = _pi(u) + noise * rng.standard_normal(u.size)
    # y: a hysteretic coupling of the given size (a wide play), and noise
    y = coupling * _play(u, 3.0) / 7.0 + noise * rng.standard_normal(u.size)
    return MultiRecord(np.arange(u.size) * T, u[None, :], np.vstack([x, y]), ["ux"], ["x", "y"],
                       T, "sine.csv")


def test_levels_of_a_decreasing_sine():
    _, u, level = decreasing_sine(T, 10.0, frequency=2.0)
    lv = amplitude_levels(u)
    assert [round(v["percent"]) for v in lv] == [100, 80, 60, 40, 20]
    for v, k in zip(lv, range(5)):      # each level ends where the sine's level ends
        assert level[v["stop"]] == k


def test_whole_levels_are_held_out_and_reported(rng=np.random.default_rng(1)):
    rec = _record(rng)
    _, split = split_record(rec)
    held = [round(v["percent"]) for v in split.levels if v["held_out"]]
    assert held == [80, 40] and "amplitude levels 80 %, 40 %" in split.description
    for v in split.levels:
        assert split.held_out[v["start"]:v["stop"] + 1].all() == v["held_out"]
    fit = identify_records([rec], components="all", output_map="none")
    rows = [r for r in fit.levels if r["output"] == "x"]
    assert [round(r["percent"]) for r in rows] == [100, 80, 60, 40, 20]
    # a PI actuator: its held-out minor loops are predicted to well within 1 %
    assert max(abs(r["amplitude_error_percent"]) for r in rows if r["held_out"]) < 1.0


def test_noise_level_of_white_noise_on_a_slow_signal():
    rng = np.random.default_rng(0)
    t = np.arange(50000) * T
    y = 40 * np.sin(2 * np.pi * 1.0 * t) + 0.05 * rng.standard_normal(t.size)
    assert noise_level(y) == pytest.approx(0.05, rel=0.05)


@pytest.mark.parametrize("coupling,kept", [(1.0, True), (0.0, False)])
def test_auto_components_keep_a_coupling_above_the_noise(coupling, kept):
    rec = _record(np.random.default_rng(2), coupling=coupling)
    fit = identify_records([rec], output_map="none")
    kinds = fit.structure[1][0]      # y <- ux
    assert (kinds != "none") == kept, fit.notes
