"""What ``learn --history`` files and ``evaluate``'s report say about how their errors were measured.

Regression: history.csv and settled.csv held errors of the measurement advanced by its
delay, over the window after the fade-in, and said neither; ``evaluate`` keeps the delay
by default and gave ten times larger figures for the same records without pointing to
``--remove-delay``. Its report's heading named no actuator nor reference, and its values
had 6 significant digits where ``run``'s have 4.
"""

import re

import pandas as pd

from hammerstein.cli._learn_history import history_rows
from tests.hardware.test_evaluate_learn import REF, _cli, _hardware


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
