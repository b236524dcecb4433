"""Property-based hostile input for every command (issue 39, item 5).

Each command (run, validate, identify, excitation, compensate, evaluate,
learn, export, check) is driven with generated files (CSV tables with
hostile cells, encodings, line endings and shapes; scenario files with
absurd numbers), options and numbers (NaN, infinities, subnormals, 1e300,
booleans, words, huge integers). For every example:

- the exit status is 0, 1 or 2;
- no traceback and no ``unexpected`` line on stderr;
- every stderr line is at most 2000 characters;
- nothing is written outside the output directory ``out/`` (the inputs and
  the working directory are unchanged).

The commands run in this process (``hammerstein.cli.main.main``), each
example in a fresh temporary directory. Bounded: 20 examples per command,
no deadline (a first example may compile kernels); the whole module takes a
few minutes, so it is marked slow (``pytest -m slow``). A command added to
:data:`hammerstein.cli.main.COMMANDS` must be added to :data:`DRIVEN`
(``test_every_command_is_driven``), so it inherits the checks.
"""

import contextlib
import io
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hammerstein.cli.main import COMMANDS, main

pytestmark = pytest.mark.slow

PRESET = "rakotondrabe-2dof"
EXAMPLES = settings(max_examples=20, deadline=None, derandomize=True,
                    suppress_health_check=list(HealthCheck))

#: Commands driven here (``list`` and ``replicate`` take no user numbers or files).
DRIVEN = {"run", "validate", "identify", "excitation", "compensate", "evaluate", "learn",
          "export", "check"}

# -- numbers and cells ------------------------------------------------------------------------
HOSTILE_NUMBERS = ["0", "-1", "nan", "NaN", "inf", "-inf", "1e300", "-1e300", "5e-324",
                   "1e-300", "1e9", "1e-9", "True", "False", "", " ", "abc", "0x10", "1_000",
                   "1e999", "9" * 400, "1,5", "١٢", "2e-5\n", "1+2j"]


def number(valid):
    """A valid value (a strategy or a list of texts) 7 times in 10, else a hostile one."""
    valid = st.sampled_from(valid) if isinstance(valid, list) else valid
    hostile = st.sampled_from(HOSTILE_NUMBERS)
    anything = st.floats(allow_nan=True, allow_infinity=True).map(repr)
    return st.integers(0, 9).flatmap(lambda k: valid if k < 7 else hostile if k < 9 else anything)


CELL = st.one_of(st.floats(-100, 100).map(repr), st.floats(-100, 100).map(repr),
                 st.sampled_from(HOSTILE_NUMBERS + ["True", "z" * 5000, "\"1\"", "#", "1;2"]))


@st.composite
def csv_bytes(draw, columns):
    """A table: a header (mostly ``columns``), rows of cells, any line ending and encoding."""
    header = draw(st.one_of(st.just(list(columns)), st.just(list(columns)),
                            st.lists(st.sampled_from(list(columns) + ["", "t ", "é", "x" * 3000]),
                                     max_size=5)))
    n = draw(st.sampled_from([0, 1, 2, 12, 60, 400]))
    step = draw(st.sampled_from([5e-5, 5e-5, 1e-3, 5e-14, 5e4, -5e-5]))
    good = draw(st.booleans())
    rows = []
    for i in range(n):
        cells = [repr(i * step)] + [repr(float(20 * np.sin(0.1 * i + k)))
                                    for k in range(len(header) - 1)]
        if not good and draw(st.integers(0, 9)) == 0:
            j = draw(st.integers(0, max(len(cells) - 1, 0)))
            cells[j:j + 1] = [draw(CELL)] if cells else []
        if not good and draw(st.integers(0, 19)) == 0:
            cells = cells[:-1] if draw(st.booleans()) else cells + ["7"]
        rows.append(cells)
    sep = draw(st.sampled_from([",", ",", ";", "\t", " "]))
    end = draw(st.sampled_from(["\n", "\n", "\r\n", "\r"]))
    text = end.join(sep.join(r) for r in [header] + rows) + end
    if draw(st.integers(0, 9)) == 0:
        text = "# hammerstein comment" + end + text
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "utf-8-sig", "utf-16", "utf-16-le",
                                     "latin-1", "binary"]))
    if encoding == "binary":
        return bytes(draw(st.binary(min_size=0, max_size=300)))
    return text.encode(encoding, errors="replace")


SCENARIO_NUMBER = st.one_of(st.sampled_from(["2", "5.0", "50.0", "1e38", "1e300", "-1", "0",
                                             "nan", "inf", "1e-300", "10000", "true",
                                             '"5"', "[1, 2]", "1000000000"]),
                            st.floats(-1e6, 1e6).map(repr))


@st.composite
def scenario_text(draw):
    mode = draw(st.sampled_from(["reference", "drive"]))
    amp, freq, periods = draw(SCENARIO_NUMBER), draw(SCENARIO_NUMBER), draw(SCENARIO_NUMBER)
    if mode == "reference":
        signal = (f'reference = {{ kind = "sine", output = "x", amplitude = {amp}, '
                  f'frequency = {freq}, periods = {periods} }}')
        comp = '[compensator]\nkind = "multivariable"\n'
    else:
        signal = (f'drive = {{ kind = "sine", input = "ux", amplitude = {amp}, '
                  f'frequency = {freq}, periods = {periods} }}')
        comp = ""
    return (f'name = "h"\n[plant]\npreset = "{PRESET}"\ndynamics = false\n{comp}'
            f'[[cases]]\nname = "c"\n{signal}\n')


# -- the checks ---------------------------------------------------------------------------------
def _snapshot(root, skip):
    found = {}
    for dirpath, dirnames, filenames in os.walk(root):
        if Path(dirpath) == skip or skip in Path(dirpath).parents:
            dirnames[:] = []
            continue
        for name in filenames + dirnames:
            p = Path(dirpath) / name
            if p == skip:
                continue
            st_ = os.lstat(p)
            found[str(p.relative_to(root))] = (st_.st_size, st_.st_mtime_ns, st_.st_mode)
    return found


def drive(files, argv):
    """Write ``files`` (name -> bytes) in a fresh directory, run ``hammerstein argv`` there, check."""
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        root = Path(tmp)
        for name, data in files.items():
            (root / name).write_bytes(data)
        (root / "out").mkdir()
        before = _snapshot(root, root / "out")
        err, out = io.StringIO(), io.StringIO()
        os.chdir(root)
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                status = main(argv)
        finally:
            os.chdir(cwd)
        after = _snapshot(root, root / "out")
        lines = err.getvalue().splitlines()
        where = f"hammerstein {' '.join(a[:80] for a in argv)}"
        assert status in (0, 1, 2), (where, status, lines)
        assert not any("Traceback" in ln or "unexpected" in ln for ln in lines), (where, lines)
        assert all(len(ln) <= 2000 for ln in lines), (where, [len(ln) for ln in lines])
        assert before == after, (where, set(before) ^ set(after))
        return status, lines


def test_every_command_is_driven():
    # list, replicate and warmup read no file and take no number (warmup: only -q)
    assert set(COMMANDS) - {"list", "replicate", "warmup"} == DRIVEN


# -- one property per command -----------------------------------------------------------------
@EXAMPLES
@given(scenario=scenario_text())
def test_validate(scenario):
    drive({"s.toml": scenario.encode()}, ["validate", "s.toml"])


@EXAMPLES
@given(scenario=scenario_text(), workers=st.sampled_from([[], [], ["--workers", "1000"],
                                                          ["--scheduler", "tls://127.0.0.1:1"],
                                                          ["--scheduler", "127.0.0.1:99999"]]))
def test_run(scenario, workers):
    drive({"s.toml": scenario.encode()}, ["run", "s.toml", "--out", "out", "--figures", "none",
                                          *workers])


@EXAMPLES
@given(scenario=scenario_text(), rtol=number(["0.05", "0"]),
       baseline=st.sampled_from([b"scenario,case,channel,metric,value,unit\nh,c,x,rms_error,1,\xc2\xb5m\n",
                                 b"scenario,case,channel,metric,value,unit\nh,c,x,rms_error,nan,\n",
                                 b"", b"scenario,case,channel,metric,value,unit\n",
                                 b"\xff\xfe\x00", b"a,b\n1\n"]))
def test_check(scenario, rtol, baseline):
    drive({"s.toml": scenario.encode(), "base.csv": baseline},
          ["check", "s.toml", "--baseline", "base.csv", "--rtol", rtol, "--out", "out", "-q"])


@EXAMPLES
@given(data=csv_bytes(["t", "u", "y"]), period=number(["5e-5", "1e-3"]),
       thresholds=number(["3", "8", "1000000000"]), timed=st.booleans())
def test_identify(data, period, thresholds, timed):
    timing = ["--time", "t"] if timed else ["--sampling-period", period]
    drive({"r.csv": data}, ["identify", "r.csv", "--inputs", "u", "--outputs", "y", *timing,
                            "--thresholds", thresholds, "--out", "out/m.toml"])


@EXAMPLES
@given(amplitude=number(["5", "5,4"]), period=number(["5e-4", "1e-3"]),
       option=st.sampled_from(["--hold", "--f-min", "--f-max", "--periods", "--sine-frequency",
                               "--seed"]),
       value=number(["0.1", "20", "2"]))
def test_excitation(amplitude, period, option, value):
    drive({}, ["excitation", "--inputs", "ux,uy", "--amplitude", amplitude, "--sampling-period",
               period, option, value, "--hold", "0.05", "--out", "out/exc"])


REFERENCES = st.sampled_from([
    '{ kind = "circle", radius = 20, frequency = 100, periods = 2 }',
    '{ kind = "circle", radius = 1e300, frequency = 100, periods = 2 }',
    '{ kind = "circle", radius = 20, frequency = 1e-9, periods = 2 }',
    '{ kind = "circle", radius = 20, frequency = 100, periods = 1e9 }',
    '{ kind = "circle", radius = nan, frequency = 100, periods = 2 }', "{", "ref.csv"])


@EXAMPLES
@given(reference=REFERENCES, data=csv_bytes(["t", "x", "y"]), period=number(["5e-5", "1e-4"]),
       fade=number(["0.001", "0"]), timed=st.booleans())
def test_compensate(reference, data, period, fade, timed):
    extra = ["--sampling-period", period] if timed else []
    drive({"ref.csv": data}, ["compensate", PRESET, "--reference", reference, "--out",
                              "out/d.csv", "--fade-in", fade, *extra])


@EXAMPLES
@given(reference=REFERENCES, measured=csv_bytes(["t", "x", "y"]),
       period=number(["5e-5", "1e-4"]), settle=number(["1", "0"]))
def test_evaluate(reference, measured, period, settle):
    drive({"ref.csv": measured, "m.csv": measured},
          ["evaluate", "--reference", reference, "--measured", "m.csv", "--out", "out/ev",
           "--sampling-period", period, "--settle-periods", settle])


@EXAMPLES
@given(drive_csv=csv_bytes(["t", "ux", "uy"]), measured=csv_bytes(["t", "x", "y"]),
       gain=number(["0.5", "1"]), period=number(["5e-5"]), history=st.booleans())
def test_learn(drive_csv, measured, gain, period, history):
    extra = ["--history", "out/h"] if history else []
    drive({"u.csv": drive_csv, "y.csv": measured},
          ["learn", PRESET, "--reference",
           '{ kind = "circle", radius = 20, frequency = 100, periods = 2 }', "--drive", "u.csv",
           "--measured", "y.csv", "--out", "out/u1.csv", "--learning-gain", gain,
           "--sampling-period", period, *extra])


@EXAMPLES
@given(name=st.sampled_from(["ok", "p1", "math", "main", "../x", "a b", "é", "x" * 300, ""]),
       option=st.sampled_from(["--iterations", "--cutoff-hz", "--sampling-period",
                               "--slew-rate"]),
       value=number(["2", "100", "5e-5"]))
def test_export(name, option, value):
    drive({}, ["export", PRESET, "--target", "c", "--out", "out/c", "--name", name,
               "--kind", "multivariable", option, value])
