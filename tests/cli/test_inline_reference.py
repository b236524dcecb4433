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
