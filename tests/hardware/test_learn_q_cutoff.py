"""The default cutoff of the learning filter Q (``hammerstein learn`` without ``--q-cutoff-hz``)."""

from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.cli.learn import default_q_cutoff
from hammerstein.io.presets import load_plant


def _mode(f, zeta, T):
    """A discrete second-order mode (2 x 2 state matrix) at f [Hz] of damping zeta."""
    w = 2 * np.pi * f
    z = np.exp(T * (-zeta * w + 1j * w * np.sqrt(1 - zeta ** 2)))
    return np.array([[z.real, -z.imag], [z.imag, z.real]])


@pytest.mark.parametrize("f1", [300.0, 400.0, 580.0, 800.0])
def test_two_and_a_half_times_the_first_mode_at_least_1000_hz(f1):
    T = 5e-5
    expected = max(1000.0, 2.5 * f1 * np.sqrt(1 - 0.03 ** 2))   # the damped frequency's
    A = np.zeros((6, 6))
    A[:2, :2] = _mode(1.3 * f1, 0.05, T)                  # a higher mode first: the lowest counts
    A[2:4, 2:4] = _mode(f1, 0.03, T)
    A[4, 4] = np.exp(-T / 0.5)                            # a creep lag: real, no frequency
    cutoff, note = default_q_cutoff(SimpleNamespace(matrices=(A,), sampling_period=T))
    assert cutoff == pytest.approx(expected, rel=1e-9)
    assert note.startswith(f"note: Q cutoff {expected:.4g} Hz because") and "--q-cutoff-hz" in note
    # both frequencies of the mode, the natural one as identify and compensate print it
    assert f"damped frequency {f1 * np.sqrt(1 - 0.03 ** 2):.4g} Hz" in note
    assert f"natural frequency {f1:.4g} Hz" in note


def test_without_a_mode_and_below_nyquist():
    cutoff, note = default_q_cutoff(SimpleNamespace(matrices=(np.zeros((0, 0)),),
                                                    sampling_period=1e-4))
    assert cutoff == 1000.0 and "no oscillatory mode" in note
    T = 1e-3                                              # 1 kHz sampling: at most 450 Hz
    cutoff, _ = default_q_cutoff(SimpleNamespace(matrices=(_mode(100.0, 0.05, T),), sampling_period=T))
    assert cutoff == pytest.approx(450.0)


def test_a_bundled_preset_uses_its_lowest_mode():
    plant = load_plant("realistic-2dof")                  # modes 450, 420 and 1300 Hz
    cutoff, _ = default_q_cutoff(plant)
    assert cutoff == pytest.approx(2.5 * 420.0, rel=2e-3)


def test_a_cap_at_045_of_the_sampling_rate_is_said():
    """A 5 kHz stage whose first mode is at 1534 Hz: 2.5 x 1534 = 3835 Hz is capped at
    0.45 x 5000 = 2250 Hz, and the note says so (it named the 2.5 x rule alone)."""
    T = 2e-4
    cutoff, note = default_q_cutoff(SimpleNamespace(matrices=(_mode(1534.0, 0.03, T),),
                                                    sampling_period=T))
    assert cutoff == pytest.approx(2250.0)
    assert "capped at 0.45 x the sampling rate 5000 Hz" in note
    assert f"{2.5 * 1534.0 * np.sqrt(1 - 0.03 ** 2):.4g} Hz" in note     # what the rule asked
    # uncapped, no such clause
    _, note = default_q_cutoff(SimpleNamespace(matrices=(_mode(300.0, 0.03, 5e-5),),
                                               sampling_period=5e-5))
    assert "capped" not in note


@pytest.mark.parametrize("T, expected", [(1e-4, 100.0), (5e-5, 100.0), (1 / 200.0, 90.0)])
def test_without_identified_dynamics_a_safe_cutoff_and_a_warning(T, expected):
    """A model identified without --dynamics does not know the modes: 100 Hz (at most 0.45 x
    the sampling rate), below the 200 Hz under which piezo stages' first modes rarely lie, and
    a warning naming the remedies (it said 1000 Hz "because the actuator has no oscillatory
    mode", and a stage with modes at 380/450 Hz diverged to 71 % of the radius)."""
    plant = SimpleNamespace(dynamics=None, matrices=(np.zeros((0, 0)),), sampling_period=T)
    cutoff, line = default_q_cutoff(plant)
    assert cutoff == pytest.approx(expected) and cutoff < 200.0
    assert line.startswith(f"warning: Q cutoff {expected:g} Hz: the model has no identified "
                           f"dynamics") and "\n" not in line
    assert "can diverge" in line and "identify --dynamics" in line
    assert "--q-cutoff-hz below your actuator's first mode" in line
    assert "no oscillatory mode" not in line


def test_learn_on_a_model_without_dynamics_warns_once_and_claims_no_monotony(tmp_path):
    """Through the command: one warning line, Q at 100 Hz in the drive's header, and the
    convergence condition said to be the model's static gain's only."""
    from hammerstein.cli.main import main
    from hammerstein.compensation.drive import read_signals
    from hammerstein.io.presets import save_model
    import contextlib
    import io
    import pandas as pd

    save_model(load_plant("rakotondrabe-2dof").hysteresis, tmp_path / "static.toml")
    ref = '{ kind = "circle", radius = 20, frequency = 50, periods = 8 }'
    common = ["static.toml", "--sampling-period", "5e-5", "--reference", ref]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(tmp_path), contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        assert main(["compensate", *common, "--out", "u0.csv"]) == 0
        t, u, _ = read_signals("u0.csv", ["ux", "uy"])
        y, _ = load_plant("rakotondrabe-2dof").simulate(u)
        pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv("y0.csv", index=False)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["learn", *common, "--drive", "u0.csv", "--measured", "y0.csv",
                         "--out", "u1.csv"])
    assert code == 0, err.getvalue()
    warnings = [ln for ln in err.getvalue().splitlines() if "no identified dynamics" in ln]
    assert len(warnings) == 1 and warnings[0].startswith("warning: Q cutoff 100 Hz")
    assert "monotonic" not in out.getvalue()
    assert "on the model's static gain only" in out.getvalue()
    assert "Q 100 Hz" in (tmp_path / "u1.csv").read_text()[:3000]
