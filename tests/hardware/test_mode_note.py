"""A harmonic of the reference at a bending mode: how much the linear part passes it, named.

Expectations are closed forms: one second-order mode ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``
passes ``1 / sqrt((1 - q^2)^2 + (2 zeta q)^2)`` times its static gain at ``q = f / fn``
(sampled finely, the zero-order hold moves it by less than 1e-3 relative below a tenth of
the sampling rate); decoupled axes pass the larger of their gains (the 2-norm of a diagonal
matrix); a static plant passes everything once.
"""

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.compensation.shaping import mode_amplification, mode_note
from hammerstein.io.presets import resolve_preset
from hammerstein.models.dynamics import sampled_bending_modes

T = 1e-5


def _gain(f, fn, zeta):
    q = np.asarray(f, dtype=float) / fn
    return 1.0 / np.sqrt((1 - q ** 2) ** 2 + (2 * zeta * q) ** 2)


def _mats(fn, zeta, names=None, T=T):
    names = names or [f"y{i}" for i in range(len(fn))]
    G = sampled_bending_modes(fn, zeta, names, T)
    return G.A, G.B, G.C, G.D


@pytest.mark.parametrize("fn, zeta", [(300.0, 0.04), (450.0, 0.02), (600.0, 0.1)])
def test_one_mode_closed_form(fn, zeta):
    f = np.array([0.0, 50.0, 0.5 * fn, fn, 1.3 * fn, 2.0 * fn])
    a = mode_amplification(_mats([fn], [zeta]), T, f)
    assert a == pytest.approx(_gain(f, fn, zeta), rel=1e-3)


def test_decoupled_axes_pass_the_larger_gain_and_a_static_plant_one():
    f = np.array([100.0, 280.0, 310.0, 520.0])
    a = mode_amplification(_mats([300.0, 500.0], [0.03, 0.05]), T, f)
    assert a == pytest.approx(np.maximum(_gain(f, 300.0, 0.03), _gain(f, 500.0, 0.05)), rel=1e-3)
    static = (np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((2, 0)), np.diag([2.0, 0.5]))
    assert mode_amplification(static, T, f) == pytest.approx(np.ones(4), rel=1e-12)


def _circle(f, r=15.0, n=4000):
    t = np.arange(n) * T
    return r * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


@pytest.mark.parametrize("f0, fn, which, n", [
    (100.0, 300.0, "3rd harmonic", 3),
    (150.0, 300.0, "2nd harmonic", 2),
    (100.0, 500.0, "5th harmonic", 5),
    (280.0, 300.0, "main frequency", 1),
])
def test_the_note_names_the_harmonic_at_the_mode_and_its_gain(f0, fn, which, n):
    zeta = 0.04
    mats = _mats([fn, fn], [zeta, zeta])
    P = int(round(1 / (f0 * T)))
    note = mode_note(mats, T, _circle(f0, n=4 * P), P)
    assert note is not None and which in note
    gain = float(re.search(r"\) ([0-9.]+) times its static gain", note).group(1))
    assert gain == pytest.approx(_gain(n * f0, fn, zeta), rel=2e-3)   # the reference's own f0
    assert f"bending mode at {fn * np.sqrt(1 - zeta ** 2):.0f} Hz" in note


@pytest.mark.parametrize("f0", [150.0, 240.0, 340.0])
def test_the_main_frequency_is_the_reference_s_not_the_whole_period_s(f0):
    # 150 Hz at 10 µs is 666.7 samples a period; the period of 667 samples is 149.93 Hz
    P = int(round(1 / (f0 * T)))
    assert abs(1 / (P * T) - f0) > 0.05
    note = mode_note(_mats([3 * f0, 3 * f0], [0.03, 0.03]), T, _circle(f0, n=20 * P), P)
    named = float(re.search(r"3rd harmonic \(([0-9.]+) Hz, of ([0-9.]+) Hz\)", note).group(2))
    assert named == pytest.approx(f0, abs=0.02 * f0 / P)


def test_the_nearest_of_two_modes_is_named():
    mats = _mats([300.0, 900.0], [0.04, 0.04])
    P = int(round(1 / (180.0 * T)))                             # 180 Hz: its 5th, 900 Hz
    assert "5th harmonic" in mode_note(mats, T, _circle(180.0, n=4 * P), P)
    # a mode is named by its natural frequency, as identify lists it (not the damped 899.3 Hz)
    assert "bending mode at 900 Hz" in mode_note(mats, T, _circle(180.0, n=4 * P), P)
    P = int(round(1 / (100.0 * T)))
    assert "bending mode at 300 Hz" in mode_note(mats, T, _circle(100.0, n=4 * P), P)


def test_no_note_below_the_limit_without_a_period_or_dynamics():
    mats = _mats([3000.0, 3000.0], [0.04, 0.04])
    P = int(round(1 / (100.0 * T)))
    ref = _circle(100.0, n=4 * P)
    assert mode_note(mats, T, ref, P) is None                  # 500 Hz: 1.03 times
    assert mode_note(mats, T, ref, P, limit=1.01) is not None
    assert mode_note(_mats([300.0, 300.0], [0.04, 0.04]), T, ref, None) is None
    static = (np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((2, 0)), np.eye(2))
    assert mode_note(static, T, ref, P) is None
    A, B, C, D = _mats([300.0, 300.0], [0.04, 0.04])
    C = C.copy()
    C[1] = C[0]                                                 # G(1) singular: no ratio
    with pytest.raises(np.linalg.LinAlgError):
        mode_amplification((A, B, C, D), T, [100.0])
    assert mode_note((A, B, C, D), T, ref, P) is None


def _compensate(tmp_path, frequency):
    out, err = io.StringIO(), io.StringIO()
    path = tmp_path / f"d{frequency}.csv"
    ref = f'{{ kind = "circle", radius = 10, frequency = {frequency}, periods = 12 }}'
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compensate", str(resolve_preset("rakotondrabe-2dof")), "--reference", ref,
                     "--out", str(path)])
    assert code == 0, err.getvalue()
    return err.getvalue(), Path(path).read_text()      # note: lines go to stderr


def test_compensate_names_the_harmonic_in_its_output_and_the_drive_header(tmp_path):
    """The preset's modes are at 290 and 310 Hz: a 100 Hz circle's 3rd harmonic meets them."""
    out, text = _compensate(tmp_path, 100)
    line = next(ln for ln in out.splitlines() if ln.startswith("note: the bending mode"))
    assert "3rd harmonic (300 Hz, of 100 Hz)" in line
    assert f"# {line}" in text.splitlines()
    out, text = _compensate(tmp_path, 10)                    # 50 Hz at most: 1.03 times
    assert "bending mode" not in out and "bending mode" not in text


def test_a_linear_part_without_modes_is_named_as_such():
    """Real poles only, with a zero: G(z) = 1 - 0.4 / (z - 0.5) rises from 0.2 at z = 1 to
    1 + 0.4 / 1.5 at z = -1; no oscillatory mode to name."""
    mats = (np.array([[0.5]]), np.array([[1.0]]), np.array([[-0.4]]), np.array([[1.0]]))
    z = np.exp(2j * np.pi * 0.3)                                # f = 0.3 / T
    assert mode_amplification(mats, 1.0, [0.3]) == pytest.approx([abs(1 - 0.4 / (z - 0.5)) / 0.2])
    t = np.arange(100)
    note = mode_note(mats, 1.0, np.sin(2 * np.pi * 0.1 * t)[None, :], 10)
    assert note.startswith("the linear part passes the reference's")


def test_the_named_mode_is_the_one_that_amplifies_by_its_natural_frequency():
    # a user's identified modes: 449.8 Hz damped at 0.18 (at most 1 / (2 zeta) = 2.8 times)
    # and 470.24 Hz damped at 0.025; a 150 Hz circle's 3rd harmonic (450 Hz) is passed
    # 1 / |1 - q^2 + 2 j zeta q| = 10.4 times by the second (q = 450 / 470.24), 2.8 times by the
    # first: the note names 470 Hz (natural frequency, as identify lists it; the first mode's
    # damped frequency would read 442 Hz)
    fn, zeta, T2 = [449.8, 470.24], [0.18, 0.025], 5e-5
    assert _gain(450.0, 470.24, 0.025) == pytest.approx(10.4, abs=0.1)
    assert _gain(450.0, 449.8, 0.18) == pytest.approx(2.78, abs=0.01)
    t = np.arange(4000) * T2
    ref = np.vstack([15.0 * np.sin(2 * np.pi * 150.0 * t), 15.0 * np.cos(2 * np.pi * 150.0 * t)])
    note = mode_note(_mats(fn, zeta, T=T2), T2, ref, int(round(1 / 150.0 / T2)))
    assert note is not None and note.startswith("the bending mode at 470 Hz passes the reference's "
                                                "3rd harmonic (450 Hz, of 150 Hz)")
