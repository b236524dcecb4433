"""What ``learn --history`` files and ``evaluate``'s report say about how their errors were measured.

Regression: history.csv and settled.csv held errors of the measurement advanced by its
delay, over the window after the fade-in, and said neither; ``evaluate`` keeps the delay
by default and gave ten times larger figures for the same records without pointing to
``--remove-delay``. Its report's heading named no actuator nor reference, and its values
had 6 significant digits where ``run``'s have 4.
"""

import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli._learn_history import (BEST_FILE, HISTORY_MARK, STATE_FILE, _read_state,
                                            history_rows)
from hammerstein.exceptions import DataFileError, PresetError
from hammerstein.io.model_table import model_from_table
from hammerstein.models.preisach import is_mixed_table
from tests.hardware.test_evaluate_learn import REF, _cli, _hardware


def _trials(tmp_path, ref, n):
    """compensate, then ``n`` learn trials on the preset's own prediction (exact gain, noise
    seeded per trial) into hist/; each trial's stdout."""
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    learn = ["learn", "rakotondrabe-2dof", "--reference", ref, "--outputs", "x=x_meas,y=y_meas",
             "--history", "hist"]
    outs = []
    for k in range(n):
        _hardware(tmp_path / f"u{k}.csv", tmp_path / f"y{k}.csv", 0, k, gain=1.0)
        res = _cli(*learn, "--drive", f"u{k}.csv", "--measured", f"y{k}.csv", "--out",
                   f"u{k + 1}.csv", cwd=tmp_path)
        assert res.returncode == 0, res.stderr
        outs.append(res.stdout)
    return outs


def test_history_files_say_the_delay_removed_and_the_window(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    _hardware(tmp_path / "u0.csv", tmp_path / "y0.csv", 4, 0)
    res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
               "--measured", "y0.csv", "--outputs", "x=x_meas,y=y_meas", "--out", "u1.csv",
               "--history", "hist", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    hist = pd.read_csv(tmp_path / "hist/history.csv")
    settled = pd.read_csv(tmp_path / "hist/settled.csv")
    for frame in (hist, settled):
        assert (frame["delay_removed_samples"] == 4).all()
        assert (frame["window_from_s"] > 0.01).all()         # after the fade-in and a period
    assert settled.columns[:4].tolist() == ["trial", "settled_max_euclidean_um",
                                            "settled_rms_euclidean_um", "judged_um"]
    assert [r[:2] for r in history_rows(tmp_path / "hist")] == [(0, "x"), (0, "y")]


def test_an_older_settled_file_keeps_its_rows(tmp_path):
    from hammerstein.cli._learn_history import SETTLED_FILE, _settled_rows

    (tmp_path / SETTLED_FILE).write_text(
        "trial,settled_max_euclidean_um,settled_rms_euclidean_um,judged_um\n0,1.0,0.5,0.9\n")
    _settled_rows(tmp_path, 1, 0.8, 0.4, 0.7, 0.01, (3, 0.03))
    rows = pd.read_csv(tmp_path / SETTLED_FILE)
    assert rows["trial"].tolist() == [0, 1] and rows["judged_um"].tolist() == [0.9, 0.7]
    assert rows["delay_removed_samples"].isna().tolist() == [True, False]
    assert rows["window_from_s"].iloc[1] == 0.03


def test_a_settled_file_is_headed_in_its_unit_and_its_rows_kept(tmp_path):
    from hammerstein.cli._learn_history import SETTLED_FILE, _settled_rows

    assert _settled_rows(tmp_path, 0, 8.0, 4.0, 7.0, 0.5, (3, 0.03), "nm") is None
    # the second trial's judged error is above the first's by more than the margin
    assert _settled_rows(tmp_path, 1, 9.0, 5.0, 8.0, 0.5, (3, 0.03), "nm") == (0, 7.0)
    rows = pd.read_csv(tmp_path / SETTLED_FILE)
    assert rows.columns.tolist() == ["trial", "settled_max_euclidean_nm", "settled_rms_euclidean_nm",
                                     "judged_nm", "delay_removed_samples", "window_from_s"]
    assert rows["judged_nm"].tolist() == [7.0, 8.0] and rows["delay_removed_samples"].tolist() == [3, 3]


def test_evaluate_report_names_what_it_measured_and_points_to_remove_delay(tmp_path):
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    _hardware(tmp_path / "u0.csv", tmp_path / "y0.csv", 5, 0)
    args = ["evaluate", "--reference", REF, "--measured", "y0.csv", "--outputs",
            "x=x_meas,y=y_meas", "--drive", "u0.csv"]
    assert _cli(*args, "--out", "kept", cwd=tmp_path).returncode == 0
    assert _cli(*args, "--remove-delay", "--out", "removed", cwd=tmp_path).returncode == 0
    kept = (tmp_path / "kept/report.md").read_text(encoding="utf-8")
    removed = (tmp_path / "removed/report.md").read_text(encoding="utf-8")
    assert kept.splitlines()[0] == ("# Measured response of rakotondrabe-2dof to: circle, "
                                    "radius 30 µm, 100 Hz, 10 periods")
    assert kept.count("`--remove-delay`") == 1 and "--remove-delay" not in removed
    assert "## Definitions" in kept and "- `max_euclidean_error_percent`:" in kept
    values = [ln.split("|")[3].strip() for ln in kept.splitlines()
              if ln.startswith("| ") and not ln.startswith("| channel")]
    assert values and all(len(re.sub(r"[^0-9]", "", v.split("e")[0]).lstrip("0")) <= 4
                          for v in values), values


def test_a_history_file_changed_since_learn_wrote_it_is_never_replaced(tmp_path):
    """An outside check: a user's notes written over ``hist/history.csv`` were replaced, and
    lines put in ``settled.csv`` were mangled into data rows, without a word. The history's
    mark keeps each file's SHA-256; a changed file stops the next trial (exit 2, nothing
    written), an unchanged history goes on."""
    import hashlib

    from hammerstein.cli._learn_history import HISTORY_MARK
    from snapshots import tree_snapshot

    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=tmp_path).returncode == 0
    _hardware(tmp_path / "u0.csv", tmp_path / "y0.csv", 0, 0)
    learn = ["learn", "rakotondrabe-2dof", "--reference", REF, "--outputs", "x=x_meas,y=y_meas",
             "--history", "hist"]
    assert _cli(*learn, "--drive", "u0.csv", "--measured", "y0.csv", "--out", "u1.csv",
                cwd=tmp_path).returncode == 0
    mark = (tmp_path / "hist" / HISTORY_MARK).read_text()
    for name in ("history.csv", "settled.csv", "convergence.png", "best-trial.csv"):
        digest = hashlib.sha256((tmp_path / "hist" / name).read_bytes()).hexdigest()
        assert f"sha256 {digest} {name}" in mark         # closed form: the bytes on disk
    _hardware(tmp_path / "u1.csv", tmp_path / "y1.csv", 0, 0)
    for name, text in (("history.csv", "my lab notes: do not lose\n"),
                       ("settled.csv", "my notes 1\nmy notes 2\n")):
        original = (tmp_path / "hist" / name).read_bytes()
        (tmp_path / "hist" / name).write_text(text)
        before = tree_snapshot(tmp_path)
        res = _cli(*learn, "--drive", "u1.csv", "--measured", "y1.csv", "--out", "u2.csv",
                   cwd=tmp_path)
        assert res.returncode == 2 and len(res.stderr.splitlines()) == 1, res.stderr
        assert f"{name}: changed or deleted since hammerstein learn wrote it" in res.stderr
        assert tree_snapshot(tmp_path) == before
        (tmp_path / "hist" / name).write_bytes(original)       # restored: the learning goes on
    for name in ("history.csv", "learning.csv", "best-trial.csv"):   # deleted: restarted half
        original = (tmp_path / "hist" / name).read_bytes()
        (tmp_path / "hist" / name).unlink()
        before = tree_snapshot(tmp_path)
        res = _cli(*learn, "--drive", "u1.csv", "--measured", "y1.csv", "--out", "u2.csv",
                   cwd=tmp_path)
        assert res.returncode == 2 and f"{name}: changed or deleted" in res.stderr, res.stderr
        assert tree_snapshot(tmp_path) == before
        (tmp_path / "hist" / name).write_bytes(original)
    res = _cli(*learn, "--drive", "u1.csv", "--measured", "y1.csv", "--out", "u2.csv",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert [r[0] for r in history_rows(tmp_path / "hist")] == [0, 0, 1, 1]


def test_the_judged_error_printed_is_the_one_compared_and_kept(tmp_path):
    """An outside check: on a 120 Hz circle (166.67 samples a period: judged as the RMS less
    the noise) trial 8 printed 'RMS 0.0188 µm' where settled.csv kept 0.02091 and the best
    trial was chosen on the kept one: the printed number was the noise of one record
    removed, the compared one that of both. Printed now is what is compared and kept."""
    ref = '{ kind = "circle", radius = 30, frequency = 120, periods = 12 }'
    printed = []
    for k, out in enumerate(_trials(tmp_path, ref, 3)):
        m = re.search(rf"trial {k} judged \(RMS less the sensor noise\): RMS ([0-9.e-]+) µm", out)
        assert m, out
        printed.append(float(m.group(1)))
    kept = pd.read_csv(tmp_path / "hist/settled.csv")["judged_um"].tolist()
    assert len(kept) == 3
    for p, v in zip(printed, kept):
        assert abs(p - v) <= 5e-4 * v        # the 4 significant digits printed


def test_learn_names_a_reference_beyond_the_reach(tmp_path):
    """An outside check: a 30 µm circle on a stage that reaches about 19 µm over its range
    learnt ten trials, each told 'the learning diverges at the gain it had (the model holds
    the bending modes...)', never that the reference is out of reach, which compensate said."""
    from hammerstein.io.presets import load_plant

    preset = tmp_path / "small.toml"
    text = (Path(__file__).resolve().parents[2] / "hammerstein" / "presets"
            / "rakotondrabe-2dof.toml").read_text(encoding="utf-8")
    preset.write_text(text + '\n[amplifier.ux]\nrange = [-6.0, 6.0]\n\n'
                             '[amplifier.uy]\nrange = [-6.0, 6.0]\n', encoding="utf-8")
    plant = load_plant(str(preset))
    y, _ = plant.simulate(np.tile([[6.0], [6.0]], (1, 2000)))  # the reach, from the model
    assert y[1, -1] < 29.0                                      # a 30 µm circle is beyond it
    ref = '{ kind = "circle", radius = 30, frequency = 100, periods = 10 }'
    assert _cli("compensate", str(preset), "--reference", ref, "--out", "u0.csv", "--limits",
                "clip", cwd=tmp_path).returncode == 0
    _hardware(tmp_path / "u0.csv", tmp_path / "y0.csv", 0, 0)
    res = _cli("learn", str(preset), "--reference", ref, "--outputs", "x=x_meas,y=y_meas",
               "--drive", "u0.csv", "--measured", "y0.csv", "--out", "u1.csv", "--limits",
               "clip", cwd=tmp_path)
    assert "the reference leaves what the model reaches over the amplifier's range" in res.stderr
    assert "the error there is the reach's, which no trial removes" in res.stderr
    ok = _cli("learn", "rakotondrabe-2dof", "--reference", ref, "--outputs", "x=x_meas,y=y_meas",
              "--drive", "u0.csv", "--measured", "y0.csv", "--out", "u2.csv", cwd=tmp_path)
    assert "reach" not in ok.stderr                # no amplifier: nothing said


def test_monotonic_is_said_only_of_a_trial_better_than_the_best(tmp_path):
    """An outside check: 'monotonic on the model' was printed beside judged errors that rose
    within the noise. A trial not better than the best says the condition holds on the model
    only."""
    ref = '{ kind = "circle", radius = 30, frequency = 100, periods = 12 }'
    said = ["<= 1: monotonic on the model" in out for out in _trials(tmp_path, ref, 8)]
    state = pd.read_csv(tmp_path / "hist/learning.csv", header=None, index_col=0)[1]
    judged = pd.read_csv(tmp_path / "hist/settled.csv")["judged_um"].tolist()
    best = [k == 0 or judged[k] < min(judged[:k]) for k in range(8)]
    assert not all(best), judged                 # the noise: some trial is not a new best
    assert said == best, (said, judged, state.to_dict())


def test_a_malformed_history_line_names_no_unit(tmp_path):
    """history.csv's columns are named in the model's unit (max_error_nm): the refusal of a
    malformed line names none, rather than max_error_um."""
    d = tmp_path / "h"
    d.mkdir()
    (d / "history.csv").write_text("iteration,output,max_error_nm,rms_error_nm\n0,x,abc,0.1\n")
    with pytest.raises(DataFileError, match="line 2") as err:
        history_rows(d)
    assert "_um" not in str(err.value)


def test_an_empty_output_unit_of_a_preisach_model_is_refused():
    """A Preisach or generalised-PI [model] with output_unit = "" was read (the unit check came
    after the mixed tables' return) and learn then named its columns _um."""
    path = Path(__file__).parent / "data" / "outside-gpi-identified.toml"
    table = tomllib.loads(path.read_text(encoding="utf-8"))["model"]
    assert is_mixed_table(table)
    model_from_table(table, path.name)
    table["output_unit"] = ""
    with pytest.raises(PresetError, match="model.output_unit: expected a unit name"):
        model_from_table(table, path.name)


def test_a_learning_state_file_not_utf8_is_refused_naming_it(tmp_path):
    """A learning.csv of bytes that are not UTF-8 gave the codec's own message; now one line
    naming the file."""
    for name, data in ((HISTORY_MARK, b""), (BEST_FILE, b"t,ux\n0,0\n"),
                       (STATE_FILE, b"key,value\nbest_trial,\xff\n")):
        (tmp_path / name).write_bytes(data)
    with pytest.raises(DataFileError, match=f"{STATE_FILE}: not UTF-8 text"):
        _read_state(tmp_path, 1)
