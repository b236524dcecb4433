"""A drive that chatters (large steps of opposite sign on consecutive samples) is named.

chatter_warnings: the exact inverse alternating between two inputs that give a flat model the
same output (16.4 / 19.8 V sample to sample on an outside actuator) against smooth drives,
whose steps change sign only where they are near zero.
"""

import numpy as np
import pytest

from hammerstein.compensation.shaping import CHATTER_FRACTION, chatter_warnings

T = 5e-5


def _circle_drive(amplitude, hz, n=8000):
    t = np.arange(n) * T
    return np.vstack([amplitude * np.cos(2 * np.pi * hz * t), amplitude * np.sin(2 * np.pi * hz * t)])


@pytest.mark.parametrize("amplitude, hz, steep", [(20.0, 200.0, True), (20.0, 10.0, False),
                                                  (1.0, 400.0, False)])
def test_smooth_drives_are_not_named(amplitude, hz, steep):
    """A 20 V drive at 200 Hz steps 1.26 V a sample (3 % of 40 V, beyond the 2 % threshold)
    but reverses only where its steps are near zero: not named, nor are the gentler ones."""
    u = _circle_drive(amplitude, hz)
    assert (np.abs(np.diff(u)).max() > CHATTER_FRACTION * 40.0) == steep
    assert chatter_warnings(u, T, [40.0, 40.0], ["ux", "uy"]) == []


def test_an_alternating_stretch_is_counted_and_placed():
    u = _circle_drive(10.0, 10.0)
    k = np.arange(2500, 2560)
    u[1, k[::2]] += 1.7            # 16.4 / 19.8 V: 3.4 V up and down, sample after sample
    lines = chatter_warnings(u, T, [40.0, 40.0], ["ux", "uy"])
    assert len(lines) == 1 and lines[0].startswith("uy: ")
    assert "at 60 samples" in lines[0] or "at 59 samples" in lines[0], lines[0]
    assert f"{2498 * T:.4f}" in lines[0]                    # the episode's start, one run
    # below the threshold: 2 % of 40 V is 0.8 V; a 0.3 V alternation is not named
    v = _circle_drive(10.0, 10.0)
    v[1, k[::2]] += 0.3
    assert chatter_warnings(v, T, [40.0, 40.0]) == []


def test_without_a_range_the_drives_own_span_is_the_scale():
    u = _circle_drive(1.0, 10.0)
    u[0, 100:140:2] += 0.5          # 25 % of its 2 V span
    assert len(chatter_warnings(u, T)) == 1


@pytest.mark.parametrize("limits, status, written", [("error", 1, False), ("warn", 0, True)])
def test_compensate_refuses_a_chattering_drive_by_default(tmp_path, capsys, monkeypatch, limits,
                                                          status, written):
    """With ``--limits error`` (the default) a drive that chatters is no file at all: one line
    on stderr, exit 1; ``--limits warn`` writes it with the warning in its header. The
    detector is held to its answer here (its own tests are above); what is checked is the
    command's contract around it."""
    import hammerstein.cli.compensate as compensate_cli
    from hammerstein.cli.main import main
    line = "ux: the drive reverses by more than 3 V from one sample to the next at 2 samples"
    monkeypatch.setattr(compensate_cli, "chatter_warnings", lambda *a, **k: [line])
    out = tmp_path / "drive.csv"
    argv = ["compensate", "rakotondrabe-2dof", "--reference",
            '{ kind = "circle", radius = 10, frequency = 20, periods = 2 }', "--out", str(out)]
    got = main(argv + (["--limits", limits] if limits != "error" else []))
    err = capsys.readouterr().err.splitlines()
    assert got == status
    assert out.exists() == written
    if written:
        assert f"# warning: {line}" in out.read_text()
    else:
        assert len(err) == 1 and "chatters, nothing written" in err[0] and line in err[0], err


@pytest.mark.parametrize("glitch, named, refused", [(0.05, True, False), (0.2, True, True),
                                                    (0.01, False, False)])
def test_a_glitch_is_named_and_a_chatter_refused(glitch, named, refused):
    """One reversal of ``glitch`` times the 40 V range on a slow ramp: named from
    CHATTER_FRACTION (2 %), refused from CHATTER_REFUSE_FRACTION (10 %)."""
    from hammerstein.compensation.shaping import CHATTER_REFUSE_FRACTION
    u = np.vstack([np.linspace(-5.0, 5.0, 400), np.zeros(400)])
    u[0, 200] += glitch * 40.0
    assert bool(chatter_warnings(u, T, [40.0, 40.0])) == named
    assert bool(chatter_warnings(u, T, [40.0, 40.0], fraction=CHATTER_REFUSE_FRACTION)) == refused


@pytest.mark.parametrize("first, inversion, said", [(0.0, "zpetc", None), (5e-10, "stable", None),
                                                    (0.056, "stable", "anti-causal"),
                                                    (-3e-6, "zpetc", "tolerance")])
def test_a_first_sample_off_rest_is_named(first, inversion, said):
    """compensate names a drive whose first sample is more than 1e-9 V from rest, and why."""
    from types import SimpleNamespace
    from hammerstein.scenario.hardware_route import _first_sample_note
    plant = SimpleNamespace(amplifier=None,
                            hysteresis=SimpleNamespace(input_names=["ux", "uy"], n_inputs=2))
    drive = SimpleNamespace(inputs=np.array([[0.0, 1.0], [first, 1.0]]))
    note = _first_sample_note(plant, drive, inversion)
    assert (note is None) == (said is None)
    if said:
        assert said in note and f"uy {first:+.3g} V" in note


def test_a_tapered_first_sample_names_the_largest_change_over_the_lead():
    """A drive whose pre-actuation was faded in names how far it differs from the
    compensator's voltages (the exported C's) over the lead, not only the first sample."""
    from types import SimpleNamespace
    from hammerstein.scenario.hardware_route import _first_sample_note
    plant = SimpleNamespace(amplifier=None,
                            hysteresis=SimpleNamespace(input_names=["ux", "uy"], n_inputs=2))
    drive = SimpleNamespace(inputs=np.zeros((2, 3)), start_offset=np.array([2e-6, -5e-6]),
                            taper_change=0.0123, rest_lead=None, fade_samples=100)
    note = _first_sample_note(plant, drive, "stable")
    assert "ux +2e-06 V, uy -5e-06 V" in note
    assert "(10 samples), where it differs from the compensator's voltages by up to 0.0123 V" \
        in note and "exported C" in note
