"""Property-based hostile input (issue 13, item 6): scenario files generated from
the schema with random valid and invalid values, next to pre-existing files
and directories, through ``validate`` and ``run``.

Asserted for every generated file: exit status 0, 1 or 2 only; no traceback;
one stderr line per problem (``validate``: one ``error: <file>: ...`` line
each, distinct; ``run``: at most one ``error:`` line for the one scenario);
nothing written outside the chosen report directory ``out/<name>/``; no
pre-existing file or directory changed; no temporary left behind.

Tiny scenarios (static plant by default, a few periods at 20 kHz) keep the
default run fast; the heavier variant (more examples, dynamics on) is
marked slow.
"""

import contextlib
import io
import math
import tempfile
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hammerstein.cli.main import main
from hammerstein.runner import MARKER, TMP_PREFIX
from snapshots import tree_snapshot

# -- values: mostly valid (so that some files run), sometimes hostile ------------------------
def mostly(valid, *hostile):
    """``valid`` (a strategy or a value) 19 times in 20, else one of ``hostile``."""
    valid = valid if isinstance(valid, st.SearchStrategy) else st.just(valid)
    return st.integers(0, 19).flatmap(lambda k: valid if k else st.sampled_from(hostile))


NAME = mostly(st.sampled_from(["ok", "a.b_c-1"]), "..", ".", "a/b", "", "x" * 101, "é", 7)
TITLE = mostly(st.text(max_size=20), "t" * 300, 12)
FREQ = mostly(st.sampled_from([50.0, 100.0]), 0.0, -5.0, 1e5, math.inf, math.nan, "50 Hz", 1e-9)
AMPLITUDE = mostly(st.sampled_from([1.0, 5.0]), 0.0, -1.0, math.nan, [1.0])
PERIODS = mostly(st.sampled_from([2, 3]), 0, -1, 10**12, 1.5)
ITERATIONS = mostly(st.sampled_from([1, 2]), 0, 9223372036854775807, -3, True)


@st.composite
def signal(draw, mode):
    kinds = ["sine"] if mode == "drive" else ["sine", "circle", "lissajous"]
    kind = draw(mostly(st.sampled_from(kinds), "bogus", 3))
    table = {"kind": kind}
    if kind == "sine":
        key = "input" if mode == "drive" else "output"
        table[key] = draw(mostly(st.sampled_from(["ux", "uy"] if mode == "drive" else ["x", "y"]),
                                 "z", 3))
        table["amplitude"] = draw(AMPLITUDE)
        table["frequency"] = draw(FREQ)
    elif kind == "circle":
        table["radius"] = draw(AMPLITUDE)
        table["frequency"] = draw(FREQ)
        if draw(st.booleans()):
            table["outputs"] = draw(mostly(["x", "y"], ["x", "x"], ["x"], ["q", "y"]))
    elif kind == "lissajous":
        table["amplitude"] = draw(AMPLITUDE)
        table["frequencies"] = draw(mostly([150.0, 100.0], [50.0, 50.0001], [0.0, 1.0]))
    length = draw(mostly(st.sampled_from(["periods", "duration"]), "both", "none"))
    if length in ("periods", "both"):
        table["periods"] = draw(PERIODS)
    if length in ("duration", "both"):
        table["duration"] = draw(mostly(0.04, 0.0, 1e6))
    if draw(st.integers(0, 19)) == 0:
        table[draw(st.sampled_from(["amplitud", "frequncy", "phse"]))] = 1.0
    return table


@st.composite
def compensator(draw):
    table = {"kind": draw(mostly(st.sampled_from(["multivariable", "diagonal", "per-axis",
                                                  "static-gain"]), "none", "multivariabel"))}
    if draw(st.booleans()):
        table["iterations"] = draw(ITERATIONS)
    if draw(st.integers(0, 9)) == 0:
        table["feedback"] = "lowpass"
        table["cutoff_hz"] = draw(mostly(500.0, 2e4, -1.0))
    if draw(st.integers(0, 9)) == 0:
        table["cutoff_hz"] = 500.0  # without feedback = "lowpass": refused
    if draw(st.integers(0, 9)) == 0:
        table["model"] = draw(st.sampled_from(["plant", "/dev/zero", "nowhere.toml", "."]))
    return table


@st.composite
def scenario(draw, dynamics=False):
    doc = {}
    if draw(st.booleans()):
        doc["name"] = draw(NAME)
    if draw(st.integers(0, 3)) == 0:
        doc["title"] = draw(TITLE)
    doc["plant"] = {"preset": draw(mostly("rakotondrabe-2dof", "/dev/null", "nope", ".")),
                    "dynamics": draw(mostly(dynamics, "yes"))}
    if draw(st.booleans()):
        doc["compensator"] = draw(compensator())
    cases = []
    for i in range(draw(mostly(st.integers(1, 2), 0))):
        mode = draw(st.sampled_from(["drive", "reference"]))
        case = {"name": draw(mostly(f"c{i}", "c0", "..", "y" * 120)), mode: draw(signal(mode))}
        if draw(st.integers(0, 9)) == 0:
            case["settle_periods"] = draw(st.sampled_from([0, 1, 50, -1]))
        cases.append(case)
    doc["cases"] = cases
    if draw(st.integers(0, 5)) == 0:
        doc["sweeps"] = [{"name": draw(mostly(st.sampled_from(["s", "t"]), "..")),
                          "frequencies": draw(mostly([50.0, 100.0], [50.0, 50.0], [],
                                                     list(range(1, 300)))),
                          "metric": draw(mostly("rms_error", "bogus")),
                          "reference": {"kind": "sine", "output": "x", "amplitude": 1.0,
                                        "periods": 2}}
                         for _ in range(draw(st.integers(1, 2)))]
    if draw(st.integers(0, 19)) == 0:
        doc["nmae"] = "typo"
    return doc


def _check(doc, occupant, command):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "scenario.toml"
        path.write_text(tomli_w.dumps(doc), encoding="utf-8")
        (root / "precious.txt").write_text("keep me")
        out = root / "out"
        name = doc.get("name", "scenario")
        (out / "someone-else").mkdir(parents=True)
        (out / "someone-else" / "thesis.tex").write_text("precious")
        if isinstance(name, str) and name and "/" not in name and name not in (".", ".."):
            target = out / name
            if occupant == "user-dir":
                target.mkdir(exist_ok=True)
                (target / "notes.txt").write_text("mine")
            elif occupant == "file":
                target.write_text("mine")
            elif occupant == "report":
                target.mkdir(exist_ok=True)
                (target / MARKER).write_text("hammerstein 0.1.0\n")
                (target / "metrics.csv").write_text("old")
        before = tree_snapshot(root)
        err = io.StringIO()
        argv = [command, str(path)] + (["--out", str(out)] if command == "run" else [])
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(argv)
        # the one informational line a run may print: a kernel numba's cache did not hold
        # yet (the other xdist worker may be writing the cache at that moment)
        lines = [ln for ln in err.getvalue().splitlines()
                 if not ln.startswith(("compiling the simulation kernels once",
                                       "compiling one more simulation kernel once"))]
        assert status in (0, 1, 2), (status, lines)
        assert "Traceback" not in err.getvalue()
        errors = [ln for ln in lines if ln.startswith("error:")]
        assert all(ln.startswith(("error: ", "warning: ")) for ln in lines), lines
        assert all(ln.startswith(f"error: {path}: ") for ln in errors), errors
        if command == "validate":
            assert len(errors) == len(set(errors)) and (status == 0) == (not errors), lines
        else:
            assert len(errors) == (status == 1), lines
        after = tree_snapshot(root)
        written = out / name if isinstance(name, str) and name else None
        for p, info in before.items():  # nothing pre-existing changed (a marked report may be replaced)
            if status == 0 and occupant == "report" and written is not None and \
                    (p == written or written in p.parents):
                continue
            assert after.get(p) == info, p
        new = [p for p in after if p not in before]
        assert not [p for p in new if p.name.startswith(TMP_PREFIX) or p.name.endswith(".hammerstein-tmp")]
        if new:
            assert status == 0 and command == "run", new
            assert all(p == written or written in p.parents for p in new), new
            assert (written / MARKER).is_file()


_SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(max_examples=40, **_SETTINGS)
@given(doc=scenario())
def test_validate_on_generated_scenarios(doc):
    _check(doc, None, "validate")


@settings(max_examples=12, **_SETTINGS)
@given(doc=scenario(), occupant=st.sampled_from([None, "user-dir", "file", "report"]))
def test_run_on_generated_scenarios(doc, occupant):
    _check(doc, occupant, "run")


@pytest.mark.slow
@settings(max_examples=150, **_SETTINGS)
@given(doc=scenario(dynamics=True), occupant=st.sampled_from([None, "user-dir", "file", "report"]),
       command=st.sampled_from(["validate", "run"]))
def test_generated_scenarios_many(doc, occupant, command):
    _check(doc, occupant, command)
