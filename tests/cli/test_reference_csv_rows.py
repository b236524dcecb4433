"""A CSV reference's short row or repeated column name is refused by every command.

pandas fills a short row with empty cells and renames a second ``x`` to ``x.1``: a
ragged row in a column compensate did not read, and a repeated name, were accepted
without a word, where evaluate (which reads every column) refused the ragged row.
"""

import contextlib
import io

import numpy as np
import pytest

from hammerstein.cli.main import main


def _run(*args, cwd):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, err.getvalue()


def _reference(path, header, short_row=None):
    t = np.arange(2000) * 5e-5
    x, y = 5 * np.sin(2 * np.pi * 50 * t), 5 * np.cos(2 * np.pi * 50 * t) - 5
    rows = [f"{a:.9g},{b:.9g},{c:.9g},1" for a, b, c in zip(t, x, y)]
    if short_row is not None:
        rows[short_row - 1] = rows[short_row - 1].rsplit(",", 1)[0]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("command", ["compensate", "evaluate"])
@pytest.mark.parametrize("header, short_row, says", [
    ("t,x,y,extra", 1001, "r.csv: ragged rows: data row 1001 has 3 fields, the header has 4; "
                          "expected the same number of fields on every row"),
    ("t,x,y,x", None, "r.csv: the column name 'x' appears more than once in the header; "
                      "expected each column named once"),
])
def test_a_ragged_or_repeated_column_reference_is_refused(tmp_path, command, header, short_row,
                                                          says):
    _reference(tmp_path / "r.csv", header, short_row)
    _reference(tmp_path / "y.csv", "t,x,y,z")
    args = (("compensate", "rakotondrabe-2dof", "--reference", "r.csv", "--out", "u.csv")
            if command == "compensate" else
            ("evaluate", "--reference", "r.csv", "--outputs", "x,y", "--measured", "y.csv",
             "--out", "ev"))
    code, err = _run(*args, cwd=tmp_path)
    assert code == 1, err
    assert err.count("\n") == 1 and f"--reference: {says}" in err, err


def test_an_empty_last_cell_written_is_no_ragged_row(tmp_path):
    _reference(tmp_path / "r.csv", "t,x,y,extra")
    text = (tmp_path / "r.csv").read_text().replace(",1\n", ",\n", 1)   # 'extra' empty on row 1
    (tmp_path / "r.csv").write_text(text)
    code, err = _run("compensate", "rakotondrabe-2dof", "--reference", "r.csv", "--out", "u.csv",
                     cwd=tmp_path)
    assert code == 0, err


def test_identify_refuses_a_record_naming_a_column_twice(tmp_path):
    """An outside check: ``identify`` read the first of two ``ux`` columns without a word,
    where compensate, learn and evaluate refuse such a file. Nothing is written."""
    t = np.arange(400) * 1e-3
    u = 5 * np.sin(2 * np.pi * t)
    rows = [f"{a:.9g},{b:.9g},{b:.9g},{2 * b:.9g}" for a, b in zip(t, u)]
    (tmp_path / "rec.csv").write_text("t,ux,ux,x\n" + "\n".join(rows) + "\n")
    code, err = _run("identify", "rec.csv", "--input", "ux", "--output", "x", "--time", "t",
                     "--out", "m.toml", cwd=tmp_path)
    assert code == 1 and err.count("\n") == 1, err
    assert ("rec.csv: the column name 'ux' appears more than once in the header; expected each "
            "column named once") in err
    assert not (tmp_path / "m.toml").exists()


def test_identify_names_the_record_and_the_option_of_a_burn_in_too_long(tmp_path):
    """An outside check: ``identify --skip 1000`` printed "error: skip: expected a burn-in
    shorter than the record (2 s)", naming neither the file nor the option."""
    t = np.arange(60000) * 5e-5
    u = 5 * np.sin(2 * np.pi * 5 * t) * (1 - t / 4)
    rows = [f"{a:.9g},{b:.9g},{2 * b:.9g}" for a, b in zip(t, u)]
    (tmp_path / "rec.csv").write_text("t,ux,x\n" + "\n".join(rows) + "\n")
    code, err = _run("identify", "rec.csv", "--input", "ux", "--output", "x", "--time", "t",
                     "--out", "m.toml", "--skip", "1000", cwd=tmp_path)
    assert code == 1 and err.count("\n") == 1, err
    assert ("rec.csv: skip (identify --skip): expected a burn-in shorter than the record (3 s), "
            "found 1000 s") in err
    assert not (tmp_path / "m.toml").exists()
