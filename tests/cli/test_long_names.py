"""A file name over 255 bytes: a one-line error naming the option, not ``unexpected OSError``.

The system refuses such a name (ENAMETOOLONG) at the first look; ``export`` said so
(``a name of N bytes in the path``), every other output option and ``check --baseline``
let the OSError through.
"""

import contextlib
import io

import numpy as np
import pytest

from hammerstein.cli.main import main

LONG = "a" * 300
REF = '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }'


def _run(*args, cwd):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, err.getvalue()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("long")
    t = np.arange(2000) * 1e-4
    u = 5 * np.sin(2 * np.pi * 5 * t)
    (d / "rec.csv").write_text("t,u,x\n" + "\n".join(
        f"{a!r},{b!r},{2 * b + 0.1 * np.sin(b)!r}" for a, b in zip(t, u)) + "\n")
    (d / "x.toml").write_text("")
    return d


@pytest.mark.parametrize("args, option", [
    (("compensate", "rakotondrabe-2dof", "--reference", REF, "--out", LONG + ".csv"), "--out"),
    (("evaluate", "--reference", REF, "--measured", "rec.csv", "--out", LONG), "--out"),
    (("learn", "rakotondrabe-2dof", "--reference", REF, "--drive", "rec.csv", "--measured",
      "rec.csv", "--out", "u1.csv", "--history", LONG), "--history"),
    (("identify", "rec.csv", "--time", "t", "--output", "x", "--input", "u", "--out",
      LONG + ".toml"), "--out"),
    (("identify", "rec.csv", "--time", "t", "--output", "x", "--input", "u", "--out", "m.toml",
      "--metrics", LONG + ".csv"), "--metrics"),
    (("check", "--baseline", LONG + ".csv", "x.toml"), "--baseline"),
])
def test_a_name_too_long_is_a_usage_error_naming_the_option(files, args, option):
    code, err = _run(*args, cwd=files)
    assert code == 2, err
    assert err.count("\n") == 1 and "unexpected" not in err
    assert err.split("error: ", 1)[1].startswith(f"{option}: ")
    assert "bytes in the path; expected at most 255" in err


def test_identify_refuses_a_huge_sampling_period_in_one_line(files):
    (files / "nt.csv").write_text("u,x\n" + "\n".join(f"{i % 7},{2 * (i % 7)}" for i in range(50)))
    code, err = _run("identify", "nt.csv", "--output", "x", "--input", "u", "--sampling-period",
                     "1e308", "--out", "m2.toml", cwd=files)
    assert code == 2
    assert err.count("\n") == 1 and "--sampling-period" in err, err
