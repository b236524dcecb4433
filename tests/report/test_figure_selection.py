"""``hammerstein run --figures``: the default draws every figure; a selection leaves the
others out and report.md says so instead of linking a missing PNG."""

import re
from pathlib import Path

import pytest

from hammerstein.cli.main import main
from hammerstein.report.render import figure_selection

SCENARIO = """
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
[[cases]]
name = "circle"
reference = { kind = "circle", radius = 10.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "open-loop-x"
drive = { kind = "sine", amplitude = 5.0, frequency = 50.0, periods = 2, input = "ux" }
"""

LINK = re.compile(r"!\[[^\]]*\]\(([^)]+\.png)\)")


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("scn") / "small.toml"
    path.write_text(SCENARIO)
    return path


@pytest.fixture(scope="module")
def full_run(scenario, tmp_path_factory):
    return _run(scenario, tmp_path_factory.mktemp("all"))


def _run(scenario, out, *extra):
    assert main(["run", str(scenario), "--out", str(out), "-q", *extra]) == 0
    (report,) = [d for d in out.iterdir() if d.is_dir()]
    return report, (report / "report.md").read_text()


@pytest.mark.parametrize("spec", ["none", "trajectory-*", "maps-*,trajectory-*"])
def test_selection_draws_exactly_the_selected_figures(scenario, full_run, tmp_path, spec):
    full, md_full = full_run
    every = set(LINK.findall(md_full))
    assert every and every == {p.name for p in full.glob("*.png")}    # default: all, linked
    part, md = _run(scenario, tmp_path / "part", "--figures", spec)
    select = figure_selection(spec)
    wanted = {n for n in every if select(part / n)}
    assert {p.name for p in part.glob("*.png")} == wanted
    assert set(LINK.findall(md)) == wanted                             # no dangling link
    for name in every - wanted:
        assert f"figure `{name}` not drawn" in md
    for name in wanted:                                                # same pictures
        assert (part / name).read_bytes() == (full / name).read_bytes()


@pytest.mark.parametrize("spec, warned", [("nonsense", True), ("loops*", True),
                                           ("trajectory-*", False), ("none", False)])
def test_a_selection_that_matches_no_figure_is_said(scenario, tmp_path, capsys, spec, warned):
    # --figures nonsense drew nothing and said nothing (exit 0, a silent empty report)
    assert main(["run", str(scenario), "--out", str(tmp_path), "--figures", spec]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning: --figures")]
    assert len(err) == (1 if warned else 0)
    if warned:
        assert "matched none of the" in err[0] and "trajectory-*" in err[0]


@pytest.mark.parametrize("spec", ["", ",", "maps-*,"])
def test_bad_selection_is_a_usage_error(scenario, tmp_path, capsys, spec):
    assert main(["run", str(scenario), "--out", str(tmp_path), "--figures", spec]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--figures" in err[0]
    assert not any(tmp_path.iterdir())


def test_selection_patterns():
    sel = figure_selection(" maps-* , xy-all.png ")
    assert sel(Path("d/maps-open-loop.png"))
    assert sel(Path("xy-all.png"))
    assert not sel(Path("d/trajectory-a.png"))
    assert figure_selection("all") is None
    assert not figure_selection("none")(Path("x.png"))
