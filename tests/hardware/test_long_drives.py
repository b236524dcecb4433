"""Long drives: parsed once by ``evaluate``, read within the largest accepted record's size,
written by blocks of rows with the same bytes.

``evaluate --drive`` had parsed the drive file three times (its length, its input columns,
its shaped reference) and the measured file three times; the drive file of
``compensate --predicted`` for a 150 s record at 20 kHz (270 MiB) was beyond the 256 MiB
every data file is read within, so a drive the project wrote for a record it accepts
could not be evaluated (and ``compensate`` refused to write it); ``compensate`` built the
whole file's text at once (1.8 GB for 3e6 samples).
"""

import hashlib
import io

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli import compensate as compensate_cli
from hammerstein.cli import evaluate as evaluate_cli
from hammerstein.cli.main import main
from hammerstein.compensation import drive_files, drive_size
from hammerstein.compensation.drive_files import signals_csv
from hammerstein.compensation.drive_size import drive_file_limit, write_drive_rows
from memory_trace import traced_write

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """A drive of compensate with its predicted outputs, and the outputs as the measurement."""
    d = tmp_path_factory.mktemp("long")
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(d)
        assert main(["compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "u.csv",
                     "--predicted"]) == 0
    u = pd.read_csv(d / "u.csv", comment="#")
    pd.DataFrame({"t": u.t, "x": u.x_predicted, "y": u.y_predicted}).to_csv(
        d / "y.csv", index=False, float_format="%.6g")
    return d


def _counting(monkeypatch, module):
    """Count ``module.signal_table``'s parses per file name."""
    counts = {}
    parse = module.signal_table

    def counted(raw, path, *args, **kwargs):
        name = str(path).rsplit("/", 1)[-1]
        counts[name] = counts.get(name, 0) + 1
        return parse(raw, path, *args, **kwargs)

    monkeypatch.setattr(module, "signal_table", counted)
    return counts


def test_evaluate_parses_the_drive_and_the_measured_file_once(drive, monkeypatch, capsys):
    monkeypatch.chdir(drive)
    counts = _counting(monkeypatch, drive_files)
    counts_here = _counting(monkeypatch, evaluate_cli)
    code = main(["evaluate", "--reference", REF, "--drive", "u.csv", "--measured", "y.csv",
                 "--out", "ev-once"])
    assert code == 0, capsys.readouterr().err
    for name, n in counts_here.items():
        counts[name] = counts.get(name, 0) + n
    assert counts == {"u.csv": 1, "y.csv": 1}
    metrics = (drive / "ev-once" / "metrics.csv").read_text()
    assert "shaped," in metrics or "measured," in metrics


def test_evaluate_parses_them_once_with_inputs_named(drive, monkeypatch, capsys):
    """``--input-columns`` reads the measured file's inputs: from the same table."""
    monkeypatch.chdir(drive)
    u = pd.read_csv("u.csv", comment="#")
    pd.DataFrame({"t": u.t, "x": u.x_predicted, "y": u.y_predicted, "ux": u.ux,
                  "uy": u.uy}).to_csv("yu.csv", index=False, float_format="%.6g")
    counts = _counting(monkeypatch, drive_files)
    code = main(["evaluate", "--reference", REF, "--drive", "u.csv", "--measured", "yu.csv",
                 "--input-columns", "ux,uy", "--output-columns", "x,y", "--out", "ev-inputs"])
    assert code == 0, capsys.readouterr().err
    assert counts == {"u.csv": 1, "yu.csv": 1}


def test_a_drive_of_the_largest_accepted_record_is_written_and_evaluated(drive, monkeypatch,
                                                                         capsys):
    """The largest record accepted is this reference's length; the data files' limit is below
    its drive's size (as 256 MiB is below the 270 MiB of a 150 s drive at 20 kHz)."""
    monkeypatch.chdir(drive)
    n = len(pd.read_csv("u.csv", comment="#"))
    monkeypatch.setenv("HAMMERSTEIN_MAX_RECORD_SAMPLES", str(n))
    measured = (drive / "y.csv").stat().st_size
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", str(measured + 100))
    code = main(["compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "big.csv",
                 "--predicted"])
    assert code == 0, capsys.readouterr().err
    size = (drive / "big.csv").stat().st_size
    assert measured + 100 < size <= drive_file_limit(5)
    assert (drive / "big.csv").read_bytes() == (drive / "u.csv").read_bytes()
    code = main(["evaluate", "--reference", REF, "--drive", "big.csv", "--measured", "y.csv",
                 "--out", "ev-big"])
    assert code == 0, capsys.readouterr().err
    assert (drive / "ev-big" / "report.md").is_file()


def test_a_drive_beyond_its_limit_is_refused_naming_the_size_and_how_to_raise_it(
        drive, monkeypatch, capsys):
    monkeypatch.chdir(drive)
    monkeypatch.setattr(drive_size, "HEADER_BYTES", 0)       # the limit: the rows alone
    monkeypatch.setenv("HAMMERSTEIN_MAX_RECORD_SAMPLES", "100")
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_BYTES", "1000")
    size = (drive / "u.csv").stat().st_size
    code = main(["evaluate", "--reference", REF, "--drive", "u.csv", "--measured", "y.csv",
                 "--out", "ev-refused"])
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("note")]
    assert code == 1 and len(err) == 1, err
    line = err[0]
    assert line.startswith("hammerstein evaluate: error: --drive: u.csv: "), line
    assert f"({size} bytes) is larger than the limit of 12.21 KiB (12500 bytes)" in line, line
    assert "drive file of 5 columns" in line and "HAMMERSTEIN_MAX_RECORD_SAMPLES" in line
    assert "raise it with HAMMERSTEIN_MAX_DATA_BYTES=BYTES" in line
    assert not (drive / "ev-refused").exists()


def test_compensate_writes_nothing_beyond_the_limit(drive, monkeypatch, capsys):
    monkeypatch.chdir(drive)
    (drive / "kept.csv").write_bytes((drive / "u.csv").read_bytes())
    monkeypatch.setattr(compensate_cli, "drive_file_limit", lambda n_columns: 5000)
    before = sorted(p.name for p in drive.iterdir())
    code = main(["compensate", "rakotondrabe-2dof", "--reference", REF, "--out", "kept.csv",
                 "--predicted", "--force"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith("hammerstein compensate: error: --out: the drive "
                                            "file would take more than 0.004768 MiB"), err
    assert "HAMMERSTEIN_MAX_DATA_BYTES" in err[-1] and "nothing written" in err[-1]
    assert sorted(p.name for p in drive.iterdir()) == before       # no temporary left
    assert (drive / "kept.csv").read_bytes() == (drive / "u.csv").read_bytes()


def _savetxt_csv(t, columns, comment):
    """The drive file's text as it was built: the whole table through ``np.savetxt``."""
    lines = comment.splitlines() or [""]
    head = [f"# hammerstein {lines[0]}".rstrip()] + [f"# {ln}".rstrip() for ln in lines[1:]]
    data = np.column_stack([np.asarray(t, dtype=float)]
                           + [np.asarray(v, dtype=float) for v in columns.values()])
    buf = io.StringIO()
    np.savetxt(buf, data, delimiter=",", fmt="%.17g")
    names = ",".join(["t", *columns]) + "\n"
    # the last comment line: the SHA-256 of the file's other bytes
    digest = hashlib.sha256(("\n".join(head) + "\n" + names + buf.getvalue()).encode()).hexdigest()
    return ("\n".join(head) + f"\n# sha256 of this file without this line: {digest} (hammerstein "
            f"replaces the file only while it matches)\n" + names + buf.getvalue())


def test_the_drive_rows_are_the_same_bytes_across_blocks():
    rng = np.random.default_rng(11)
    n = 2 * drive_size.DRIVE_CHUNK_ROWS + 1
    t = np.arange(n) * 5e-5
    cols = {"ux": rng.standard_normal(n) * 40.0, "uy": rng.standard_normal(n) * 1e-300,
            "x_predicted": rng.standard_normal(n) * 1e5}
    cols["ux"][:6] = [0.0, -0.0, np.nan, np.inf, -np.inf, -2.2250738585072014e-308]
    comment = "compensate drive: t [s]; ux, uy [V]\nactuator a.toml, kind hammerstein"
    text = signals_csv(t, cols, comment)
    assert text == _savetxt_csv(t, cols, comment)
    fh = io.BytesIO()
    drive_files.signals_writer(t, cols, comment)(fh)
    assert fh.getvalue() == text.encode("utf-8")
    longest = max(len(v) for line in text.splitlines()[4:] for v in line.split(","))
    assert longest <= drive_size.VALUE_BYTES - 1


def test_the_drive_rows_take_a_blocks_memory():
    """200 000 rows x 7 columns (about 25 MB of text): under 12 MB traced beyond the table."""
    n = 200_000
    data = np.column_stack([np.arange(n) * 5e-5] + [np.sin(np.arange(n) * (k + 1) * 1e-3)
                                                    for k in range(6)])
    written, size, peak = traced_write(lambda sink: write_drive_rows(sink, "t,a,b,c,d,e,f\n",
                                                                      data))
    assert written == size > 20_000_000
    assert peak < 12_000_000, peak
