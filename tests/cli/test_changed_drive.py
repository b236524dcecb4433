"""A drive file changed since compensate or learn wrote it is not replaced without --force.

A user ran ``compensate --out drive.csv``, appended the measured column to drive.csv (its
``#`` lines kept) and ran compensate again with the same --out: the file was replaced
silently (exit 0), the measurement lost. A drive file now keeps the SHA-256 of its bytes
(its digest line), computed again before the file is replaced. Expectations: the digest is
computed here with hashlib over the file's other lines; the edits are a user's (a column,
rows, a number, a note), made on the file's text. identify's --metrics CSV, replaced on its
first line as well, signs that line the same way.
"""

import contextlib
import hashlib
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli._hardware import load_actuator
from hammerstein.cli.main import main

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'
DIGEST = "# sha256 of this file without this line: "


def _run(*args, cwd):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, err.getvalue()


def _compensate(cwd, *more, ref=REF):
    return _run("compensate", "rakotondrabe-2dof", "--reference", ref, "--out", "drive.csv",
                *more, cwd=cwd)


def _add_column(text):
    """The measured column appended: named on the row of column names, a value on every row."""
    lines = []
    for line in text.splitlines(keepends=True):
        if line.startswith("#"):
            lines.append(line)
        elif line.startswith("t,"):
            lines.append(line.rstrip("\n") + ",x_meas\n")
        else:
            lines.append(line.rstrip("\n") + ",0.25\n")
    return "".join(lines)


def _add_rows(text):
    return text + "0.5,1,1\n0.50005,1,1\n"


def _edit_number(text):
    head, _, rows = text.partition("\nt,ux,uy\n")
    first, rest = rows.split("\n", 1)
    return f"{head}\nt,ux,uy\n{first}\n" + rest.replace("0,0\n", "0,0.125\n", 1)


def _add_note(text):
    first, rest = text.split("\n", 1)         # the drive's first line stays first
    return f"{first}\n# measured on the stage in room 12, 21 °C\n{rest}"


def _digest_of(path):
    """(the digest line's digits, the SHA-256 of the file's other lines), both computed here."""
    lines = path.read_bytes().splitlines(keepends=True)
    marked = [ln for ln in lines if ln.startswith(DIGEST.encode())]
    assert len(marked) == 1, marked
    digits = marked[0][len(DIGEST):len(DIGEST) + 64].decode()
    return digits, hashlib.sha256(b"".join(ln for ln in lines if ln not in marked)).hexdigest()


@pytest.mark.parametrize("edit", [_add_column, _add_rows, _edit_number, _add_note])
def test_a_changed_drive_is_kept(tmp_path, edit):
    assert _compensate(tmp_path)[0] == 0
    drive = tmp_path / "drive.csv"
    edited = edit(drive.read_text(encoding="utf-8"))
    assert edited != drive.read_text(encoding="utf-8")
    drive.write_text(edited, encoding="utf-8")
    before = drive.read_bytes()
    code, err = _compensate(tmp_path)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("hammerstein compensate: error: --out: drive.csv changed since "
                          "hammerstein compensate wrote it (a measured column added?); nothing "
                          "was written"), err
    assert "--force" in err
    assert drive.read_bytes() == before
    # --force replaces it, as it replaces any file the command did not write
    code, err = _compensate(tmp_path, "--force")
    assert code == 0, err
    assert "x_meas" not in drive.read_text(encoding="utf-8")
    digits, computed = _digest_of(drive)
    assert digits == computed


def test_an_unchanged_drive_is_replaced_and_its_digest_is_its_lines(tmp_path):
    assert _compensate(tmp_path)[0] == 0
    drive = tmp_path / "drive.csv"
    digits, computed = _digest_of(drive)
    assert digits == computed
    n = len(pd.read_csv(drive, comment="#"))
    code, err = _compensate(tmp_path, ref=REF.replace("periods = 6", "periods = 8"))
    assert code == 0, err
    assert len(pd.read_csv(drive, comment="#")) > n
    digits, computed = _digest_of(drive)
    assert digits == computed
    # the digest line is a comment: the table is the one the rows hold
    table = pd.read_csv(drive, comment="#")
    assert list(table.columns) == ["t", "ux", "uy"]


def test_a_drive_without_a_digest_line_is_replaced_as_before(tmp_path):
    assert _compensate(tmp_path)[0] == 0
    drive = tmp_path / "drive.csv"
    lines = drive.read_text(encoding="utf-8").splitlines(keepends=True)
    old = "".join(ln for ln in lines if not ln.startswith(DIGEST))   # an earlier version's file
    drive.write_text(_add_column(old), encoding="utf-8")
    code, err = _compensate(tmp_path)
    assert code == 0, err
    assert "x_meas" not in drive.read_text(encoding="utf-8")


def test_a_changed_learn_drive_is_kept(tmp_path):
    assert _compensate(tmp_path)[0] == 0
    plant = load_actuator("rakotondrabe-2dof")
    u = pd.read_csv(tmp_path / "drive.csv", comment="#")
    y, _ = plant.simulate(u[["ux", "uy"]].to_numpy().T, plant.rest_state())
    pd.DataFrame({"t": u["t"], "x": y[0], "y": y[1]}).to_csv(tmp_path / "m0.csv", index=False)
    learn = ("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "drive.csv",
             "--measured", "m0.csv", "--out", "d1.csv", "--history", "h")
    code, err = _run(*learn, cwd=tmp_path)
    assert code == 0, err
    d1 = tmp_path / "d1.csv"
    d1.write_text(_add_column(d1.read_text(encoding="utf-8")), encoding="utf-8")
    before = d1.read_bytes()
    learn = learn[:-2]         # without the history: its mark does not judge d1.csv
    code, err = _run(*learn, cwd=tmp_path)
    assert code == 2 and err.count("\n") == 1, err
    assert ("--out: d1.csv changed since hammerstein learn wrote it (a measured column added?)"
            in err), err
    assert d1.read_bytes() == before
    code, err = _run(*learn, "--force", cwd=tmp_path)
    assert code == 0, err
    assert np.isfinite(pd.read_csv(d1, comment="#")[["ux", "uy"]].to_numpy()).all()
    digits, computed = _digest_of(d1)
    assert digits == computed
    # the best trial's file copies the drive's header: one digest line, its own
    digits, computed = _digest_of(tmp_path / "h" / "best-trial.csv")
    assert digits == computed


# -- identify --metrics: the other single CSV replaced on its first line ------------------------
DATA = Path(__file__).resolve().parents[1] / "corpus" / "data" / "good.csv"
IDENTIFY = ("identify", str(DATA), "--time", "time_s", "--input", "u_V", "--output", "y_um",
            "--thresholds", "5", "--out", "m.toml", "--metrics", "fit.csv")
SIGNED = "; sha256 of the lines below: "


def test_a_changed_metrics_file_is_kept(tmp_path):
    code, err = _run(*IDENTIFY, cwd=tmp_path)
    assert code == 0, err
    fit = tmp_path / "fit.csv"
    code, err = _run(*IDENTIFY, cwd=tmp_path)          # as written: replaced
    assert code == 0, err
    fit.write_text(_add_note_column(fit.read_text(encoding="utf-8")), encoding="utf-8")
    before = fit.read_bytes()
    code, err = _run(*IDENTIFY, cwd=tmp_path)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("hammerstein identify: error: --metrics: fit.csv changed since "
                          "hammerstein identify wrote it"), err
    assert "--force" in err and fit.read_bytes() == before
    code, err = _run(*IDENTIFY, "--force", cwd=tmp_path)
    assert code == 0, err
    assert "remark" not in fit.read_text(encoding="utf-8")
    first, rest = fit.read_bytes().split(b"\n", 1)
    assert first.startswith(b"# generated by hammerstein identify")
    assert first.decode().split(SIGNED)[1] == hashlib.sha256(rest).hexdigest()
    assert list(pd.read_csv(fit, comment="#").columns) == ["case", "channel", "metric", "value",
                                                           "unit"]
    # an earlier version's file (its first line not signed) is replaced as before
    first, rest = fit.read_text(encoding="utf-8").split("\n", 1)
    fit.write_text(first.split(SIGNED)[0] + "\n" + _add_note_column(rest), encoding="utf-8")
    code, err = _run(*IDENTIFY, cwd=tmp_path)
    assert code == 0, err
    assert "remark" not in fit.read_text(encoding="utf-8")


def _add_note_column(text):
    lines = text.splitlines(keepends=True)
    return "".join(ln if ln.startswith("#") else
                   ln.rstrip("\n") + (",remark\n" if ln.startswith("case,") else ",ok\n")
                   for ln in lines)


def test_a_model_edited_by_hand_is_kept(tmp_path):
    """The docs say to widen an identified model's [amplifier] by hand; identify again to the
    same --out replaced it without a word, the edit lost. The model file's provenance line now
    signs the text below it."""
    code, err = _run(*IDENTIFY, cwd=tmp_path)
    assert code == 0, err
    model = tmp_path / "m.toml"
    first, rest = model.read_bytes().split(b"\n", 1)
    assert first.decode().split(SIGNED)[1] == hashlib.sha256(rest).hexdigest()
    code, err = _run(*IDENTIFY, cwd=tmp_path)          # as written: replaced
    assert code == 0, err
    model.write_text(model.read_text(encoding="utf-8") + "# amplifier widened to 12 V by hand\n",
                     encoding="utf-8")
    before = model.read_bytes()
    code, err = _run(*IDENTIFY, cwd=tmp_path)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("hammerstein identify: error: --out: m.toml changed since "
                          "hammerstein identify wrote it"), err
    assert "--force" in err and model.read_bytes() == before
    code, err = _run(*IDENTIFY, "--force", cwd=tmp_path)
    assert code == 0, err
    assert b"by hand" not in model.read_bytes()
    assert main(["compensate", str(model), "--reference",
                 '{ kind = "sine", amplitude = 10, frequency = 1, periods = 2 }',
                 "--out", str(tmp_path / "d.csv")]) == 0          # the signed model still loads
