"""A reference beyond what the model reaches over the amplifier's range is named as such.

A new user on a -20..120 V stage left a circle's ``center`` at 0: the reference asked for
-30 µm where the stage reaches +1.5 µm at -20 V, and ``compensate`` refused a drive that
chatters, naming a flat model or a raster's step, never the reference's place.
"""

import re
from pathlib import Path

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.compensation.reach import output_reach, reach_note
from hammerstein.io.presets import load_plant

IDENTIFIED = Path(__file__).parent / "data" / "outside-gpi-identified.toml"


def test_the_reach_holds_every_output_a_slow_sweep_of_the_range_gives():
    plant = load_plant(str(IDENTIFIED))
    reach = output_reach(plant.hysteresis, plant.amplifier, plant.creep)
    low = np.array([c.low for c in plant.amplifier.channels])
    high = np.array([c.high for c in plant.amplifier.channels])
    t = np.linspace(0.0, 1.0, 4000)
    # the two inputs swept together and in opposition, from rest, to the rails
    for sign in (1.0, -1.0):
        u = np.vstack([np.interp(np.sin(2 * np.pi * 3 * t), [-1, 1], [low[0], high[0]]),
                       np.interp(sign * np.sin(2 * np.pi * 3 * t), [-1, 1], [low[1], high[1]])])
        u[:, :200] *= np.linspace(0, 1, 200)          # from rest
        y, _ = plant.hysteresis.simulate(u)
        y = y * np.array([c.static_gain for c in plant.creep])[:, None]
        span = reach[:, 1] - reach[:, 0]
        assert np.all(y.min(axis=1) >= reach[:, 0] - 0.01 * span)
        assert np.all(y.max(axis=1) <= reach[:, 1] + 0.01 * span)
        assert np.all(y.max(axis=1) - y.min(axis=1) >= 0.5 * span)   # and it is not loose


def test_reach_note_names_each_output_beyond_and_the_middle():
    note = reach_note([[1.5, 99.5], [-4.0, 98.0]], [[-30.0, 30.0], [10.0, 20.0]], ["x", "y"])
    assert "x asks -30..30 µm, the model reaches 1.5..99.5 µm" in note
    assert "y asks" not in note
    assert "center = [50.5, 47]" in note
    assert reach_note(None, [[-30.0, 30.0]]) is None
    one = reach_note([[0.9, 20.1]], [[-5.0, 25.0]], ["z"])    # a single axis: a triangle's offset
    assert "offset = 10.5 is the reach's middle" in one and "center" not in one


@pytest.mark.parametrize("center, named", [("[0, 0]", False), ("[80, 0]", True)])
def test_compensate_names_a_circle_beyond_the_reach(tmp_path, capsys, center, named):
    out = tmp_path / "drive.csv"
    code = main(["compensate", str(IDENTIFIED), "--reference",
                 f'{{ kind = "circle", radius = 30, frequency = 50, periods = 10, '
                 f'center = {center} }}', "--out", str(out)])
    text = capsys.readouterr()
    said = text.err + text.out + (out.read_text()[:20000] if out.exists() else "")
    assert ("the reference leaves what the model reaches" in said) == named
    if named:
        assert "x asks 50..110 µm" in said
    else:
        assert code == 0


def test_the_reach_is_the_steady_cycles_not_the_virgin_rest():
    # a unipolar stack (0..150 V): 0 V from the virgin state gives 0 µm, but once risen to
    # 150 V and back, 0 V leaves sum w_i r_i (the plays' thresholds): the reach said 0 µm and
    # a reference inside it was then refused as needing a negative voltage
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    from hammerstein.models.amplifier import amplifier_from_table
    r, w = [0.0, 20.0, 50.0, 90.0], [0.1, 0.05, 0.03, 0.02]
    model = MultivariablePI([[PrandtlIshlinskii(r, w)]], input_amplitude=[150.0])
    amp = amplifier_from_table({"range": [0.0, 150.0]}, model.input_names)
    reach = output_reach(model, amp)
    # 0 V after 150 V: a play of threshold r went to 150 - r, then down to max(0 - r,
    # min(0 + r, 150 - r)) = min(r, 150 - r)
    low_steady = float(np.dot(w, [min(ri, 150.0 - ri) for ri in r]))
    high = float(np.dot(w, [150.0 - ri for ri in r]))    # 150 V: each play at 150 - r
    assert reach[0, 0] == pytest.approx(low_steady, rel=1e-9) and low_steady > 0.0
    assert reach[0, 1] == pytest.approx(high, rel=1e-9)


def test_a_reference_beyond_the_range_is_refused_with_where_it_fits(tmp_path, capsys):
    # "lower the reference" alone: the refusal now names the steady reach and its middle
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    from hammerstein.io.presets import save_model
    model = MultivariablePI([[PrandtlIshlinskii([0.0, 20.0, 50.0, 90.0],
                                                [0.1, 0.05, 0.03, 0.02])]],
                            input_amplitude=[150.0], input_names=["u"], output_names=["y"])
    path = tmp_path / "stack.toml"
    save_model(model, path, {"note": "test"})
    path.write_text(path.read_text() + '\n[amplifier]\nrange = [0.0, 150.0]\n')
    ref = '{ kind = "sine", amplitude = 12, offset = 10, frequency = 1, periods = 3 }'
    status = main(["compensate", str(path), "--sampling-period", "1e-3", "--reference", ref,
                   "--out", str(tmp_path / "d.csv")])
    err = capsys.readouterr().err
    assert status == 1 and "beyond the amplifier's range [0, 150] V" in err
    assert "the model reaches 3.7..25.7 µm" in err and "offset = 14.7" in err   # 0.1*150+...


def _settled_inputs(path, start_s):
    """The drive file's inputs after ``start_s`` [V], shape (m, n)."""
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    data = np.array([[float(v) for v in line.split(",")] for line in rows[1:]])
    return data[data[:, 0] >= start_s, 1:].T


def test_the_centre_and_size_advised_fit_when_followed(tmp_path, capsys):
    # a 160 µm circle: each output's extent is within its reach's span (172.5, 168.1 µm), but
    # the outputs reached together are fewer; centring it alone, as the note advised, left
    # uy on -20 V on 17 % of the settled samples
    ref = '{{ kind = "circle", radius = {r}, frequency = 50, periods = 10, center = [{c}] }}'
    out = tmp_path / "asked.csv"
    main(["compensate", str(IDENTIFIED), "--reference", ref.format(r=80, c="20, 0"),
          "--out", str(out)])
    err = capsys.readouterr().err
    note = next(line for line in err.splitlines() if "the reference leaves" in line)
    centre = note.split("center = [")[1].split("]")[0]
    found = re.search(r"at most ([0-9.]+) times its size", note)
    radius = 80 * float(found.group(1)) if found else 80.0
    followed = tmp_path / "followed.csv"
    status = main(["compensate", str(IDENTIFIED), "--reference", ref.format(r=radius, c=centre),
                   "--out", str(followed)])
    text = capsys.readouterr()
    err = text.err + text.out
    assert status == 0
    assert "the reference leaves" not in err and "holds the range edge" not in err
    fade = float(re.search(r"fade-in ([0-9.e-]+) s", err).group(1))
    u = _settled_inputs(followed, fade)
    # off both edges of the -20..20 V range, by the drive file's own samples
    assert np.all(np.abs(u) < 20.0 - 1e-6)
    assert radius < 80.0 * 0.95          # the size had to change, not the centre alone


def test_a_reference_too_long_for_the_size_search_keeps_the_extents_advice(tmp_path, capsys,
                                                                          monkeypatch):
    # the size search runs the compensator up to eleven times over the whole reference: on
    # one longer than SCALE_MAX_SAMPLES (here lowered below the circle's 4000 samples) the
    # note keeps the advice of the extents alone, each output's extent within its reach
    from hammerstein.scenario import hardware_route
    ref = '{ kind = "circle", radius = 80, frequency = 50, periods = 10, center = [20, 0] }'
    notes = []
    for cap in (10**6, 100):
        monkeypatch.setattr(hardware_route, "SCALE_MAX_SAMPLES", cap)
        main(["compensate", str(IDENTIFIED), "--reference", ref, "--out",
              str(tmp_path / f"d{cap}.csv")])
        err = capsys.readouterr().err
        notes.append(next(line for line in err.splitlines() if "the reference leaves" in line))
    assert "times its size" in notes[0]
    assert "times its size" not in notes[1] and "center = [" in notes[1]
