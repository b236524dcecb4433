"""``evaluate --drive``: the drive file read bounded, its length and the measurement's checked.

A device or FIFO given as the drive was read line by line without bound (``/dev/zero``
until the memory ran out, a FIFO forever); a drive or measurement of another length
than the reference gave a raw numpy error or was scored on part of the drive.
"""

import os
import resource
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import hammerstein
from hammerstein.cli.main import main
from cli_run import run_cli as _cli

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'
ROOT = Path(hammerstein.__file__).resolve().parents[1]     # the package under test


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("drive")
    assert _cli("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u0.csv",
                cwd=d).returncode == 0
    u = pd.read_csv(d / "u0.csv", comment="#")
    m = pd.DataFrame({"t": u.t, "x": 0.0 * u.t, "y": 0.0 * u.t})
    m.to_csv(d / "y0.csv", index=False)
    m.iloc[:len(m) // 2].to_csv(d / "yhalf.csv", index=False)
    tiny = m.copy()
    tiny["t"] = tiny.index * 1e-300
    tiny.to_csv(d / "ytiny.csv", index=False)
    return d


def _limited():                     # the old unbounded read of /dev/zero fails fast, not the box
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))


@pytest.mark.parametrize("drive", ["/dev/zero", "fifo"])
def test_a_device_or_fifo_drive_is_refused_without_reading_it(files, drive):
    if drive == "fifo":
        drive = str(files / "fifo")
        if not os.path.exists(drive):
            os.mkfifo(drive)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        res = subprocess.run([sys.executable, "-m", "hammerstein", "evaluate", "--reference", REF,
                              "--measured", "y0.csv", "--drive", drive, "--out", "ev-dev"],
                             cwd=files, env=env, capture_output=True, text=True, timeout=120,
                             preexec_fn=_limited)
    except subprocess.TimeoutExpired:
        pytest.fail(f"evaluate --drive {drive} did not return")
    assert res.returncode == 1, res.stderr
    assert res.stderr.strip().splitlines()[-1] == (
        f"hammerstein evaluate: error: --drive: {drive}: not a regular file (a device, FIFO or "
        f"socket), expected a data file")


@pytest.mark.parametrize("drive, says", [("/dev/null", "not a regular file"),
                                         (".", "is a directory"),
                                         ("missing.csv", "missing.csv: no such file")])
def test_a_drive_that_is_no_data_file_is_named(files, drive, says):
    res = _cli("evaluate", "--reference", REF, "--measured", "y0.csv", "--drive", drive,
               "--out", "ev-bad", cwd=files)
    assert res.returncode == 1
    line = [x for x in res.stderr.splitlines() if not x.startswith("note")]
    assert len(line) == 1 and line[0].startswith("hammerstein evaluate: error: --drive: ")
    assert says in line[0]


def test_a_drive_of_another_length_than_the_reference_is_refused(files):
    other = REF.replace("periods = 6", "periods = 7")
    res = _cli("evaluate", "--reference", other, "--measured", "y0.csv", "--drive", "u0.csv",
               "--out", "ev-len", cwd=files)
    assert res.returncode == 1
    assert res.stderr.strip() == ("hammerstein evaluate: error: --drive: 1200 samples; expected "
                                  "the reference's 1400")


def test_a_measurement_of_part_of_the_drive_is_refused(files):
    res = _cli("evaluate", "--reference", REF, "--measured", "yhalf.csv", "--drive", "u0.csv",
               "--out", "ev-half", cwd=files)
    assert res.returncode == 1
    assert res.stderr.strip() == (
        "hammerstein evaluate: error: --measured: 600 samples at 5e-05 s; expected at least the "
        "drive's 1200 (the measurement must cover the whole drive)")


def test_a_measurement_on_another_time_scale_names_the_measurement(files):
    res = _cli("evaluate", "--reference", REF, "--measured", "ytiny.csv", "--drive", "u0.csv",
               "--out", "ev-tiny", cwd=files)
    assert res.returncode == 1
    # read at the drive's period, as learn reads it: its span is less than one of them
    assert res.stderr.startswith("hammerstein evaluate: error: --measured: ytiny.csv: spans ")
    assert "less than one sampling period 5e-05 s; is its time column 't' in seconds?" in res.stderr
    assert res.stderr.count("\n") == 1


@pytest.mark.parametrize("args, status, says", [
    (("--settle-periods", "1e308"), 2, "--settle-periods: expected a number in [0, 1e+09]"),
    (("--fade-in", "1e308"), 1, "--fade-in: 1e+308 s is longer than the record (1200 samples, "
                                "0.06 s); expected at most 0.06 s"),
])
def test_huge_settling_or_fade_in_is_a_range_error(files, args, status, says):
    res = _cli("evaluate", "--reference", REF, "--measured", "y0.csv", "--drive", "u0.csv",
               *args, "--out", "ev-huge", cwd=files)
    assert res.returncode == status
    assert res.stderr.count("\n") == 1 and says in res.stderr, res.stderr


def test_learn_huge_settling_is_a_range_error(files):
    res = _cli("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "u0.csv",
               "--measured", "y0.csv", "--settle-periods", "1e308", "--out", "u1.csv", cwd=files)
    assert res.returncode == 2
    assert "--settle-periods: expected a number in [0, 1e+09]" in res.stderr


def test_the_report_counts_settling_in_samples_without_a_period(files):
    pd.read_csv(files / "y0.csv").to_csv(files / "r.csv", index=False)
    res = _cli("evaluate", "--reference", "r.csv", "--measured", "y0.csv", "--out", "ev-samples",
               cwd=files)
    assert res.returncode == 0, res.stderr
    text = (files / "ev-samples/report.md").read_text()
    assert "settling 1 sample" in text and "skip the first 1 sample of" in text
    assert "period" not in text.split("Settled window:")[1].split(".")[0]


def test_a_sampling_period_other_than_the_drives_is_named(files):
    res = _cli("evaluate", "--reference", REF, "--measured", "y0.csv", "--drive", "u0.csv",
               "--sampling-period", "1e-4", "--out", "ev-T", cwd=files)
    assert res.returncode == 1
    assert res.stderr.startswith("hammerstein evaluate: error: --sampling-period: 0.0001 s; "
                                 "expected the drive's 5e-05 s")


def test_a_preset_given_as_the_model_is_read_at_its_own_sampling_period(files):
    """`evaluate --model preset.toml` read the preset at T = 1 s, and warned that its bending
    modes (about 2 kHz here) were beyond the Nyquist frequency of 0.5 Hz."""
    done = _cli("evaluate", "--reference", REF, "--drive", "u0.csv", "--measured", "y0.csv",
                "--model", "rakotondrabe-2dof", "--out", "ev-model", cwd=files)
    assert done.returncode == 0, done.stderr
    assert "Nyquist" not in done.stderr and "warning" not in done.stderr, done.stderr


def test_compensate_writes_no_drive_that_evaluate_would_refuse(tmp_path, monkeypatch, capsys):
    """A tester's 10-minute drive at 20 kHz (640 MiB) was written, and evaluate refused it at
    once (256 MiB); compensate then refused every drive beyond the data files' limit, a 150 s
    one (270 MiB) too. A drive file is now read within the size of the largest drive of the
    largest accepted record (``HAMMERSTEIN_MAX_RECORD_SAMPLES``): what compensate writes,
    evaluate and learn read (tests/hardware/test_long_drives.py)."""
    from hammerstein.compensation.drive_files import read_table
    from hammerstein.compensation.drive_size import drive_file_limit
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", str(50_000))
    out = tmp_path / "d.csv"
    assert main(["compensate", "rakotondrabe-2dof", "--reference", REF, "--out", str(out)]) == 0
    columns = len(read_table(out, "--drive").frame.columns)
    assert 50_000 < out.stat().st_size <= drive_file_limit(columns)
