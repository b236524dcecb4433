"""The inline ``--reference`` table: one parser for compensate, learn and evaluate.

Nesting too deep for tomllib gave 'unexpected RecursionError'; TOML after the table
(``{...}\\n[x]\\ny = 1``) was parsed and silently dropped.
"""

import contextlib
import io

import pytest

from hammerstein.cli.main import main

REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'
DEEP = "{ a = " * 2000 + "1" + " }" * 2000


def _run(*args, cwd):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, err.getvalue()


@pytest.mark.parametrize("reference, says", [
    (DEEP, "--reference: invalid TOML: arrays or inline tables nested too deeply"),
    (REF + "\n[x]\ny = 1", "--reference: 'x' after the inline table; expected one inline TOML "
                           "table and nothing after it"),
    (REF + "\nz = 1", "--reference: 'z' after the inline table"),
])
@pytest.mark.parametrize("command", ["compensate", "evaluate"])
def test_a_bad_inline_reference_is_one_line_naming_it(tmp_path, reference, says, command):
    (tmp_path / "y.csv").write_text("t,x,y\n" + "".join(f"{i * 5e-5!r},0,0\n" for i in range(50)))
    args = (("compensate", "rakotondrabe-2dof", "--reference", reference, "--out", "u.csv")
            if command == "compensate" else
            ("evaluate", "--reference", reference, "--measured", "y.csv", "--out", "ev"))
    code, err = _run(*args, cwd=tmp_path)
    assert code == 1
    assert err.count("\n") == 1 and says in err, err


def _four_axis_measurement(path, n=4000, T=5e-5):
    """A 4-output stage's record: a 20 µm x-y circle at 20 Hz about (42, 42), z and f held at
    20 and 30 µm, each output 0.1 µm off its reference (a closed form for the metrics)."""
    import numpy as np
    t = np.arange(n) * T
    w = 2 * np.pi * 20 * t
    cols = [t, 42 + 20 * np.cos(w) + 0.1, 42 + 20 * np.sin(w), 20 + 0.1 + 0 * t, 30 - 0.1 + 0 * t]
    np.savetxt(path, np.column_stack(cols), delimiter=",", header="t,x,y,z,f", comments="",
               fmt="%.12g")


def test_evaluate_takes_a_four_axis_center_from_the_measured_outputs(tmp_path):
    """center = [42, 42, 20, 30] without --model was refused as 'expected two values', and a
    two-value center left z and f out of the metrics without a word."""
    _four_axis_measurement(tmp_path / "m.csv")
    ref = '{ kind = "circle", radius = 20, frequency = 20, periods = 4, center = [42, 42, 20, 30] }'
    code, err = _run("evaluate", "--reference", ref, "--measured", "m.csv", "--out", "ev",
                     "--fade-in", "0", cwd=tmp_path)
    assert code == 0, err
    rows = (tmp_path / "ev" / "metrics.csv").read_text().splitlines()
    judged = {r.split(",")[1] for r in rows[1:] if r.startswith("measured,")}
    assert {"x", "y", "z", "f"} <= judged
    ref2 = '{ kind = "circle", radius = 20, frequency = 20, periods = 4, center = [42, 42] }'
    code, err = _run("evaluate", "--reference", ref2, "--measured", "m.csv", "--out", "ev2",
                     "--fade-in", "0", cwd=tmp_path)
    assert code == 0, err
    assert "--measured also holds z, f, not judged" in err
