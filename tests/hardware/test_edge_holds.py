"""A drive held on its amplifier's range edge is named (it was silent: no limit was exceeded).

Expectations counted on the drive file itself: the samples after the header's fade-in whose
voltage is the range's edge.
"""

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cli_run import run_cli
from hammerstein.cli.main import main
from hammerstein.compensation.drive import read_signals
from hammerstein.compensation.edge_holds import edge_hold_note
from hammerstein.io.presets import load_plant
from hammerstein.models.amplifier import Amplifier, AmplifierChannel

OUTSIDE_GPI = Path(__file__).parent / "data" / "outside-gpi-identified.toml"


@pytest.mark.parametrize("radius, held", [(60, False), (80, True)])
def test_compensate_names_the_inputs_held_on_the_records_range(tmp_path, capsys, radius, held):
    out = tmp_path / "drive.csv"
    assert main(["compensate", str(OUTSIDE_GPI), "--reference",
                 f'{{ kind = "circle", radius = {radius}, frequency = 20, periods = 4 }}',
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    text = out.read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    u = pd.read_csv(out, comment="#")[["ux", "uy"]].to_numpy().T[:, fade:]
    found = 0
    for name, row in zip(("ux", "uy"), u):
        for edge in (-20.0, 20.0):                          # the records' range, +-20 V
            on = np.abs(row - edge) <= 40.0 * 1e-9
            found += int(on.sum())
            said = f"{name} holds the range edge {edge:g} V on {int(on.sum())} of the " \
                   f"{u.shape[1]} samples after the fade-in"
            assert (said in err and said in text) == bool(on.any()), err
    assert (found > 0) == held
    assert ("# note: ux holds the range edge" in text) == held      # in the drive's header too


def test_an_edge_that_is_the_rest_is_no_hold():
    """A unipolar stage rests at 0 V, its range's low edge: a reference at the rest output is
    met there exactly."""
    amp = Amplifier([AmplifierChannel(0.0, 100.0), AmplifierChannel(-10.0, 10.0)], ["ux", "uy"])
    u = np.array([[0.0, 0.0, 50.0, 100.0, 100.0, 100.0],
                  [0.0, 0.0, 1.0, 2.0, 3.0, -10.0]])
    note = edge_hold_note(u, amp, 1, 0.01)
    assert note.startswith("ux holds the range edge 100 V on 3 of the 5 samples after the "
                           "fade-in (60 %; 0.0300-0.0500 s); uy holds the range edge -10 V on 1 "
                           "of the 5 samples after the fade-in (20 %; 0.0500-0.0500 s): ")
    assert edge_hold_note(u[:, :3], amp, 1, 0.01) is None     # 0 V on ux: its rest
    assert edge_hold_note(u, None, 1, 0.01) is None


def _held_lines(path, names, edges, unit="V"):
    """The edge-hold sentences counted on a drive file: its samples after the header's fade-in
    on each edge (in ``unit``)."""
    text = path.read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    u = pd.read_csv(path, comment="#")[list(names)].to_numpy().T[:, fade:]
    lines = {}
    for name, row in zip(names, u):
        for edge in edges:
            on = np.abs(row - edge) <= (edges[1] - edges[0]) * 1e-9
            lines[f"{name} holds the range edge {edge:g} {unit} on {int(on.sum())} of the "
                  f"{u.shape[1]} samples after the fade-in"] = int(on.sum())
    return lines


def test_learn_names_the_inputs_its_next_drive_holds_on_the_records_range(tmp_path):
    """learn's next drive, beyond the records' range as compensate's first was, is named alike:
    on stderr and in its header (it was silent)."""
    ref = '{ kind = "circle", radius = 80, frequency = 20, periods = 4 }'
    assert main(["compensate", str(OUTSIDE_GPI), "--reference", ref,
                 "--out", str(tmp_path / "u0.csv")]) == 0
    t, u, _ = read_signals(tmp_path / "u0.csv", ["ux", "uy"])
    y, _ = load_plant(str(OUTSIDE_GPI)).simulate(u)          # the measurement: the model itself
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(tmp_path / "y0.csv", index=False)
    res = run_cli("learn", OUTSIDE_GPI, "--reference", ref, "--drive", "u0.csv", "--measured",
                  "y0.csv", "--out", "u1.csv", "--delay", "0", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    text = (tmp_path / "u1.csv").read_text()
    lines = _held_lines(tmp_path / "u1.csv", ("ux", "uy"), (-20.0, 20.0))
    assert sum(lines.values()) > 0                          # the learnt drive holds an edge
    for said, count in lines.items():       # one note line on stderr, one in the header
        assert bool(re.search(f"^note: .*{re.escape(said)}", res.stderr, re.M)) == (count > 0)
        assert bool(re.search(f"^# note: .*{re.escape(said)}", text, re.M)) == (count > 0)


def test_the_edges_are_in_the_models_input_unit(tmp_path):
    """A model whose inputs are in mV (its [model] input_unit, the records' range in mV): the
    edges are named in mV, by compensate and by learn (they said V)."""
    text = OUTSIDE_GPI.read_text().replace('\ninput_unit = "V"\n', '\ninput_unit = "mV"\n')
    assert text.count('input_unit = "mV"') == 2
    (tmp_path / "mv.toml").write_text(text)
    ref = '{ kind = "circle", radius = 80, frequency = 20, periods = 4 }'
    res = run_cli("compensate", "mv.toml", "--reference", ref, "--out", "u0.csv", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    t, u, _ = read_signals(tmp_path / "u0.csv", ["ux", "uy"])
    y, _ = load_plant(str(tmp_path / "mv.toml")).simulate(u)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(tmp_path / "y0.csv", index=False)
    learnt = run_cli("learn", "mv.toml", "--reference", ref, "--drive", "u0.csv", "--measured",
                     "y0.csv", "--out", "u1.csv", "--delay", "0", cwd=tmp_path)
    assert learnt.returncode == 0, learnt.stderr
    for run, drive in ((res, "u0.csv"), (learnt, "u1.csv")):
        text = (tmp_path / drive).read_text()
        lines = _held_lines(tmp_path / drive, ("ux", "uy"), (-20.0, 20.0), "mV")
        assert sum(lines.values()) > 0
        for said, count in lines.items():
            assert bool(re.search(f"^note: .*{re.escape(said)}", run.stderr, re.M)) == (count > 0)
            assert bool(re.search(f"^# note: .*{re.escape(said)}", text, re.M)) == (count > 0)
        assert "holds the range edge 20 V" not in run.stderr + text


def test_a_rest_edge_is_a_hold_where_the_reference_is_away_from_rest():
    """0 V on a unipolar stage is met exactly by a reference at the rest output; elsewhere the
    output falls short there as at any edge (a learnt drive sat on vy = 0 V under a circle
    that never came near the rest output, unnamed)."""
    from hammerstein.compensation.edge_holds import reference_at_rest
    amp = Amplifier([AmplifierChannel(0.0, 100.0), AmplifierChannel(0.0, 100.0)], ["vx", "vy"])
    rest_output = np.array([3.0, -2.0])
    ref = np.array([[3.0, 3.0, 20.0, 40.0, 20.0, 3.0, 3.0],
                    [-2.0, -2.0, 10.0, 30.0, 10.0, -2.0, -2.0]])
    u = np.array([[0.0, 0.0, 20.0, 40.0, 20.0, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 0.0, 15.0, 0.0, 0.0]])
    at_rest = reference_at_rest(ref, rest_output)
    assert at_rest.tolist() == [True, True, False, False, False, True, True]
    # counted here: after sample 1, vy on 0 V where the reference is away from rest: 2, 3
    note = edge_hold_note(u, amp, 1, 0.01, at_rest=at_rest)
    assert note.startswith("vy holds the range edge 0 V on 2 of the 6 samples after the "
                           "fade-in (33.3 %; 0.0200-0.0300 s; its rest, where the reference is "
                           "away from the rest output): ")
    assert "vx holds" not in note                  # 0 V only where the reference is at rest
    assert edge_hold_note(u, amp, 1, 0.01) is None            # without the reference: as before
    assert edge_hold_note(u[:, :2], amp, 1, 0.01, at_rest=at_rest[:2]) is None


def _unipolar(tmp_path):
    """The outside actuator's model on a 0..20 V stage (it rests at 0 V, its range's low edge)."""
    text = OUTSIDE_GPI.read_text().replace("range = [\n    -20.0,", "range = [\n    0.0,")
    assert text.count("range = [\n    0.0,") == 2
    (tmp_path / "uni.toml").write_text(text)
    return tmp_path / "uni.toml"


UNI_CIRCLE = '{{ kind = "circle", radius = 40, frequency = 20, periods = {p}, center = [47.7, 32.4] }}'


def _away_from_rest(path, preset, periods):
    """The circle never comes within 5 µm of the model's output at 0 V (counted here)."""
    import hammerstein as hs
    plant = load_plant(str(preset))
    y0 = plant.simulate(np.zeros((2, 50)))[0][:, -1]
    _, r = hs.circle(plant.sampling_period, radius=40.0, frequency=20.0, periods=periods,
                     center=[47.7, 32.4])
    assert np.min(np.max(np.abs(r - y0[:, None]), axis=0)) > 5.0


def test_compensate_names_the_rest_edge_held_away_from_rest(tmp_path, capsys):
    uni = _unipolar(tmp_path)
    _away_from_rest(tmp_path, uni, 4)
    out = tmp_path / "drive.csv"
    assert main(["compensate", str(uni), "--reference", UNI_CIRCLE.format(p=4),
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    text = out.read_text()
    lines = _held_lines(out, ("ux", "uy"), (0.0, 20.0))
    on_rest = sum(n for said, n in lines.items() if "edge 0 V" in said)
    assert on_rest > 0                            # the drive file sits on 0 V after the fade-in
    for said, count in lines.items():
        assert bool(re.search(f"^note: .*{re.escape(said)}", err, re.M)) == (count > 0), err
        assert bool(re.search(f"^# note: .*{re.escape(said)}", text, re.M)) == (count > 0)


def test_learn_names_the_rest_edge_and_a_stall_names_the_held_inputs(tmp_path):
    """A trial no better than the best, its drive on 0 V and 20 V: the stall names the holds
    (it said only that the learning does not reduce the error at this gain)."""
    uni = _unipolar(tmp_path)
    _away_from_rest(tmp_path, uni, 8)
    ref = UNI_CIRCLE.format(p=8)
    assert main(["compensate", str(uni), "--reference", ref, "--out",
                 str(tmp_path / "u0.csv")]) == 0
    t, u, _ = read_signals(tmp_path / "u0.csv", ["ux", "uy"])
    y, _ = load_plant(str(uni)).simulate(u)
    for k, seed in ((0, 0), (1, 1)):             # the same response, measured twice
        noisy = y + 0.02 * np.random.default_rng(seed).standard_normal(y.shape)
        pd.DataFrame({"t": t, "x": noisy[0], "y": noisy[1]}).to_csv(tmp_path / f"y{k}.csv",
                                                                     index=False)
    first = run_cli("learn", uni, "--reference", ref, "--drive", "u0.csv", "--measured",
                    "y0.csv", "--out", "u1.csv", "--history", "h", "--delay", "0", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    lines = _held_lines(tmp_path / "u1.csv", ("ux", "uy"), (0.0, 20.0))
    assert sum(n for said, n in lines.items() if "edge 0 V" in said) > 0
    for said, count in lines.items():               # the next drive's holds, 0 V included
        assert bool(re.search(f"^note: .*{re.escape(said)}", first.stderr, re.M)) == (count > 0)
    res = run_cli("learn", uni, "--reference", ref, "--drive", "u1.csv", "--measured",
                  "y1.csv", "--out", "u2.csv", "--history", "h", "--delay", "0", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    stall = next(line for line in res.stdout.splitlines() + res.stderr.splitlines()
                 if "the learning stalls" in line)
    text = (tmp_path / "u1.csv").read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    uy = pd.read_csv(tmp_path / "u1.csv", comment="#")["uy"].to_numpy()[fade:]
    for edge, rest in ((0.0, " (its rest)"), (20.0, "")):
        share = 100 * float(np.mean(np.abs(uy - edge) <= 20.0 * 1e-9))
        assert share > 0
        assert f"uy holds {edge:g} V{rest} on {share:.3g} % of the samples after the fade-in" \
            in stall, stall
