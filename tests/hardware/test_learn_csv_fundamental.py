"""A CSV reference given without ``--period``: its fundamental found from its samples.

``learn`` on a CSV raster (a triangle on the fast axis, a ramp on the slow one,
no ``--period``) took no period: a first trial's lag could differ from the
delay by one sample only, not by 4 deg of the reference's fundamental, and a
compensator's phase lead of a few samples was refused as "a trigger or latency
change" (the record "starting late"), with advice (``--delay`` with "the new
latency") that could not help. The fundamental is now found from the reference
(:func:`hammerstein.signals.fundamental.reference_fundamental`); the simulated
actuator is the bundled preset's own prediction of the drive, shifted by a known
number of samples.
"""

import math

import numpy as np
import pandas as pd
import pytest

from hammerstein.compensation.drive import drive_fade_samples, read_signals
from hammerstein.io.presets import load_plant
from hammerstein.signals.fundamental import reference_fundamental
from cli_run import run_cli as _cli

T = 5e-5
F_LINE, LINES = 25.0, 10            # 800 samples a line, 8000 in all
P_LINE = int(round(1 / (F_LINE * T)))


def _triangle(phase):
    p = phase % 1.0
    return np.where(p < 0.25, 4 * p, np.where(p < 0.75, 2 - 4 * p, 4 * p - 4))


def _raster(slow="ramp", f=F_LINE, lines=LINES, width=20.0, height=10.0):
    t = np.arange(int(round(lines / f / T))) * T
    x = width / 2 * _triangle(f * t)
    if slow == "ramp":
        y = height * f * t / lines
    else:    # a staircase stepping at each left turn, its last step cut (as a CSV tool writes it)
        y = height / (lines - 1) * np.clip(np.floor(f * t + 0.25), 0, lines - 1)
    return t, np.vstack([x, y])


def _setup(tmp_path):
    t, r = _raster()
    pd.DataFrame({"t": t, "x": r[0], "y": r[1]}).to_csv(tmp_path / "ref.csv", index=False,
                                                         float_format="%.12g")
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", "ref.csv", "--out", "u0.csv",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr


def _measure(tmp_path, shift, name):
    """The preset's prediction of u0.csv, ``shift`` samples late (negative: leading)."""
    t, u, _ = read_signals(tmp_path / "u0.csv", ["ux", "uy"])
    clean, _ = load_plant("rakotondrabe-2dof").simulate(u)
    if shift >= 0:
        y = np.concatenate([np.repeat(clean[:, :1], shift, axis=1),
                            clean[:, :clean.shape[1] - shift]], axis=1)
    else:
        y = np.concatenate([clean[:, -shift:], np.repeat(clean[:, -1:], -shift, axis=1)], axis=1)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(tmp_path / name, index=False)


def _learn(tmp_path, measured, delay="0"):
    return _cli("learn", "rakotondrabe-2dof", "--reference", "ref.csv", "--delay", delay,
                "--drive", "u0.csv", "--measured", measured, "--out", "u1.csv", cwd=tmp_path)


# -- the fundamental found from the samples ------------------------------------------------

def test_a_raster_repeats_every_line_its_slow_axis_ramping():
    _, r = _raster()
    f = reference_fundamental(r, T)
    assert f.period_samples == P_LINE and f.frequency_hz == pytest.approx(F_LINE, rel=1e-9)


def test_a_staircase_cut_short_has_its_dominant_line_and_no_repeat():
    _, r = _raster("step")
    f = reference_fundamental(r, T)
    assert f.period_samples is None and f.frequency_hz == pytest.approx(F_LINE, rel=0.01)


def test_a_period_of_no_whole_number_of_samples_is_its_own_frequency():
    t = np.arange(6000) * T                  # 150 Hz: 133.3 samples, repeats every 400
    f = reference_fundamental(np.vstack([np.cos(2 * np.pi * 150 * t),
                                         np.sin(2 * np.pi * 150 * t)]), T)
    assert f.frequency_hz == pytest.approx(150.0, rel=1e-9) and f.period_samples == 133


@pytest.mark.parametrize("signal", [np.arange(4000.0)[None, :] * 1e-3,   # a ramp
                                    np.full((2, 4000), 3.0),             # at rest
                                    np.random.default_rng(0).normal(size=(2, 4000))])
def test_no_line_no_fundamental(signal):
    assert reference_fundamental(signal, T) is None


# -- learn on a CSV raster without --period ---------------------------------------------------

def test_a_first_trial_leading_within_4_deg_of_the_line_is_learnt_from(tmp_path):
    """6 samples of lead: 2.7 deg of 25 Hz (4 deg = 8.9 samples); refused before (1 sample)."""
    _setup(tmp_path)
    _measure(tmp_path, -6, "y.csv")
    res = _learn(tmp_path, "y.csv")
    assert res.returncode == 0, res.stderr
    assert "measured lag -6 samples" in res.stdout
    assert "note: no --period: the reference's fundamental 25 Hz" in res.stderr
    # judged as a periodic reference: two periods after the fade-in (or after the first period)
    fade = drive_fade_samples(tmp_path / "u0.csv")
    start = max(fade, P_LINE) + 2 * P_LINE
    assert f"settled (from {start * T:.4g} s," in res.stdout


def test_a_lead_beyond_it_is_no_latency_and_the_advice_is_not_delay(tmp_path):
    _setup(tmp_path)
    _measure(tmp_path, -20, "y.csv")
    res = _learn(tmp_path, "y.csv")
    assert res.returncode == 1 and res.stderr.count("\n") == 1, res.stderr
    tol = math.ceil(P_LINE * 4 / 360)
    assert "leads the model's prediction by 20 samples, --delay is 0: no latency" in res.stderr
    assert f"a first trial may be off by {tol} samples, 4 deg of the reference's 25 Hz" \
        in res.stderr
    assert "samples late" not in res.stderr and "new latency" not in res.stderr
    assert "--delay cannot align a lead" in res.stderr and "--period S" in res.stderr
    assert not (tmp_path / "u1.csv").exists()


def test_a_lag_beyond_it_names_the_delay_that_aligns_it(tmp_path):
    _setup(tmp_path)
    _measure(tmp_path, 30, "y.csv")
    res = _learn(tmp_path, "y.csv")
    assert res.returncode == 1 and "lags 30 samples, --delay is 0" in res.stderr, res.stderr
    assert res.stderr.rstrip().endswith("give --delay 30")
    res = _learn(tmp_path, "y.csv", "30")        # the advice followed: learnt from
    assert res.returncode == 0 and "measured lag 30 samples" in res.stdout, res.stderr


def test_a_drive_learnt_on_the_voltages_says_the_exported_compensator_cannot_give_it(tmp_path):
    """Without --period the raster is learnt on the voltages: no reference fed to the exported C
    reproduces that drive (a user's learnt raster differed from the C fed its shaped columns by
    1.5 V after six trials), and its header says to play it as a file."""
    _setup(tmp_path)
    _measure(tmp_path, 0, "y.csv")
    res = _learn(tmp_path, "y.csv")
    assert res.returncode == 0, res.stderr
    header = [ln for ln in (tmp_path / "u1.csv").read_text().splitlines() if ln.startswith("#")]
    assert any("learnt on the voltages" in ln and "play it as a file" in ln for ln in header)
    assert "x_learnt" not in (tmp_path / "u1.csv").read_text().splitlines()[len(header)]


def test_a_lissajous_file_repeating_at_its_common_period_is_found_and_named(tmp_path):
    """An outside check: a 37/53 Hz Lissajous file repeating every second (37 periods of its
    dominant line, 20 000 samples) was taken for its 37 Hz line, and neither compensate nor
    learn said it repeats: the user learnt it sample by sample without --period. The repeat is
    now found over every lag (closed form: the common period 1/gcd(37, 53) = 1 s) and both
    commands name --period 1."""
    t = np.arange(3 * 20000) * T
    r = np.vstack([np.round(8 * np.sin(2 * np.pi * 37 * t + 0.7), 6),
                   np.round(6 * np.sin(2 * np.pi * 53 * t), 6)])
    f = reference_fundamental(r, T)
    assert (f.frequency_hz, f.period_samples, f.repeat_samples) == (pytest.approx(1.0), 20000,
                                                                     20000)
    noise = np.random.default_rng(0).standard_normal(r.shape)    # never a repeat
    assert reference_fundamental(noise, T) is None
    assert reference_fundamental(r[:, :30000], T).repeat_samples is None   # not twice: no repeat
    pd.DataFrame({"t": t, "x": r[0], "y": r[1]}).to_csv(tmp_path / "liss.csv", index=False,
                                                        float_format="%.12g")
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", "liss.csv", "--out", "u0.csv",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "liss.csv repeats every 1 s (20000 samples) and --period was not given" in res.stderr
    res = _cli("compensate", "rakotondrabe-2dof", "--reference", "liss.csv", "--period", "1",
               "--out", "u1.csv", cwd=tmp_path)
    assert res.returncode == 0 and "repeats every" not in res.stderr, res.stderr
    _measure(tmp_path, 0, "y0.csv")
    res = _cli("learn", "rakotondrabe-2dof", "--reference", "liss.csv", "--delay", "0",
               "--drive", "u0.csv", "--measured", "y0.csv", "--out", "u2.csv", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "the file repeats every 1 s (20000 samples): --period 1 learns it" in res.stderr
