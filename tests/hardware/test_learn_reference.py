"""``learn`` on a repeating reference learns the compensator's reference (issue 38, item 5).

Expectations, derived independently of the code:

* the correction of one period keeps what the followed reference already
  carried over the repeating part, and adds ``g_h E_h`` per harmonic: an
  error that is one harmonic is learnt as that harmonic times its gain,
  exactly (a linear map per harmonic);
* on an actuator that is its model plus a constant offset ``delta`` (no
  noise), the compensator's reference after trial k is
  ``y_r - (1 - (1 - gamma)^k) delta``, gamma = 0.5, the learning's default
  gain at 0 Hz (``|Q(0)| = 1``): -0.5 delta, then -0.75 delta; each drive
  is the compensator's for it, so it starts at rest, and the model's
  prediction of it is that reference as closely as the first drive's is
  the reference asked for (the compensator's own error);
* a drive that neither ``compensate`` nor ``learn`` wrote has no
  compensator reference: it is learnt through the drive, as before.
"""


import numpy as np
import pandas as pd
import pytest

from hammerstein.compensation.drive import drive_fade_samples, read_signals
from hammerstein.compensation.ilc import HarmonicGains, reference_correction
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import load_plant
from cli_run import run_cli as _cli

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 12 }'
P = 200
DELTA = np.array([0.4, -0.2])          # µm: the actuator's output above its model's


def _measure(drive, out):
    t, u, _ = read_signals(drive, ["ux", "uy"])
    y, _ = load_plant("rakotondrabe-2dof").simulate(u)
    y = y + DELTA[:, None]
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(out, index=False)
    return u, y


def _learnt(path):
    cols = pd.read_csv(path, comment="#")
    return np.vstack([cols["x_learnt"], cols["y_learnt"]]) if "x_learnt" in cols else None


@pytest.mark.parametrize("h", [0, 1, 3])
def test_one_harmonic_is_learnt_at_its_gain_on_top_of_the_followed_correction(h):
    N, s0 = 12 * P, 3 * P
    i = np.arange(N)
    target = np.vstack([np.cos(2 * np.pi * i / P), np.sin(2 * np.pi * i / P)])
    carried = np.vstack([0.2 * np.sin(4 * np.pi * i / P), 0.1 + 0 * i])
    followed = target + carried
    error = np.vstack([0.3 * np.cos(2 * np.pi * h * i / P + 0.7), -0.1 * np.cos(2 * np.pi * h * i / P)])
    gains = np.full(P // 2 + 1, 0.25)
    gains[h] = 0.6
    c = reference_correction(target, followed, error, P, s0,
                             HarmonicGains(gains, threshold=0.0))
    phase = (np.arange(P) + s0) % P         # sample i of the period is sample s0 + i
    expected = carried[:, phase] + 0.6 * error[:, phase]
    np.testing.assert_allclose(c, expected, atol=1e-12)


@pytest.mark.parametrize("bad", ["short", "shape"])
def test_fewer_than_two_periods_or_mismatched_shapes_are_refused(bad):
    r = np.zeros((2, 10 * P))
    e = r[:, :3 * P + P + 1] if bad == "short" else r
    f = r if bad == "short" else r[:1]
    with pytest.raises(CompensatorError, match="reference_correction"):
        reference_correction(r, f, e, P, 3 * P, HarmonicGains(np.full(P // 2 + 1, 0.5)))


def test_learnt_reference_converges_geometrically_and_every_drive_starts_at_rest(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    fade = drive_fade_samples(tmp_path / "u0.csv")
    s0 = fade + 2 * P                       # the repeating part
    plant = load_plant("rakotondrabe-2dof")
    _, u0, _ = read_signals(tmp_path / "u0.csv", ["ux", "uy"])
    t = np.arange(u0.shape[1]) * plant.sampling_period
    circle = 30.0 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    own = np.max(np.abs(plant.simulate(u0)[0] - circle)[:, s0:])   # the compensator's own error
    for k, share in ((0, 0.5), (1, 0.75)):
        _measure(tmp_path / f"u{k}.csv", tmp_path / f"y{k}.csv")
        res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", f"u{k}.csv",
                   "--measured", f"y{k}.csv", "--out", f"u{k + 1}.csv", "--delay", "0",
                   cwd=tmp_path)
        assert res.returncode == 0, res.stderr
        assert "reference the compensator follows is learnt per harmonic" in res.stderr
        learnt = _learnt(tmp_path / f"u{k + 1}.csv")
        assert learnt is not None
        offset = (learnt - circle)[:, s0:].mean(axis=1)
        np.testing.assert_allclose(offset, -share * DELTA, atol=0.01)
        # the drive is the compensator's for that reference: from rest, and the model follows it
        _, u, _ = read_signals(tmp_path / f"u{k + 1}.csv", ["ux", "uy"])
        assert np.all(u[:, 0] == 0.0)
        y_model, _ = plant.simulate(u)
        assert np.max(np.abs(y_model - learnt)[:, s0:]) < 1.05 * own
        assert np.max(np.abs(learnt[:, :fade // 10])) < 1e-9          # at rest until the fade


def test_a_drive_no_command_wrote_is_learnt_through_the_drive(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    text = (tmp_path / "u0.csv").read_text()
    fade = drive_fade_samples(tmp_path / "u0.csv")
    body = "\n".join(line for line in text.splitlines() if not line.startswith("#"))
    (tmp_path / "mine.csv").write_text(f"# my drive, fade-in {fade} samples\n" + body + "\n")
    _measure(tmp_path / "mine.csv", tmp_path / "y0.csv")
    res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "mine.csv",
               "--measured", "y0.csv", "--out", "u1.csv", "--delay", "0", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "learnt per harmonic" not in res.stdout + res.stderr
    assert _learnt(tmp_path / "u1.csv") is None
