"""A scenario's report names a harmonic of the reference at a bending mode, as `compensate` does."""

import re

import control
import numpy as np
import pytest

from hammerstein.report.scenario import write_report
from hammerstein.scenario.execute import run_case
from hammerstein.scenario.resolve import load_scenario

SCENARIO = """
name = "modes"
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "hammerstein"
dynamics = "plant"
[[cases]]
name = "circle-100"
reference = { kind = "circle", radius = 15.0, frequency = 100.0, periods = 3 }
[[cases]]
name = "circle-20"
reference = { kind = "circle", radius = 15.0, frequency = 20.0, periods = 2 }
[[cases]]
name = "circle-100-law"
reference = { kind = "circle", radius = 15.0, frequency = 100.0, periods = 3 }
compensator = { kind = "multivariable", model = "plant" }
"""


def _gain(plant, f):
    """||G(f) G(0)^-1||_2 from python-control's frequency response of the plant's modes."""
    sys = plant.dynamics.to_control() if hasattr(plant.dynamics, "to_control") else plant.dynamics
    G = control.frequency_response(sys, 2 * np.pi * np.array([1e-6, f])).complex
    G = np.asarray(G).reshape(2, 2, 2)
    return float(np.linalg.norm(G[:, :, 1] @ np.linalg.inv(G[:, :, 0]), 2))


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    path = tmp_path_factory.mktemp("modes") / "modes.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    return load_scenario(path)


@pytest.fixture(scope="module")
def cases(scenario):
    return {c.name: c for c in scenario.cases}


def test_the_hammerstein_case_at_a_mode_gets_the_note_with_the_plants_gain(cases):
    case = cases["circle-100"]
    assert len(case.notes) == 1
    note = case.notes[0]
    n, f, f0 = re.search(r"(\d)\w\w harmonic \(([0-9.]+) Hz, of ([0-9.]+) Hz\)", note).groups()
    assert float(f0) == pytest.approx(100.0, abs=0.05) and float(f) == pytest.approx(int(n) * 100.0,
                                                                                      abs=0.2)
    gains = {k: _gain(case.plant, 100.0 * k) for k in range(1, 6)}
    assert int(n) == max(gains, key=gains.get) and gains[int(n)] >= 2
    named = float(re.search(r"\) ([0-9.]+) times its static gain", note).group(1))
    assert named == pytest.approx(gains[int(n)], rel=5e-3)
    assert not any("harmonic" in w for w in case.warnings)   # a note, not a warning


def test_no_note_below_the_modes_nor_for_a_rate_independent_kind(cases):
    assert max(_gain(cases["circle-20"].plant, 20.0 * k) for k in range(1, 6)) < 2
    assert cases["circle-20"].notes == []
    law = cases["circle-100-law"]
    assert law.notes == []                                   # its warning says kind hammerstein
    assert any("rate independent" in w for w in law.warnings)


def test_the_report_lists_the_notes_under_their_case(scenario, cases, tmp_path):
    write_report(scenario, [run_case(c) for c in scenario.cases], tmp_path)
    text = (tmp_path / "report.md").read_text(encoding="utf-8")
    notes = text.split("Notes:", 1)[1].split("##", 1)[0]
    assert f"- `circle-100`: {cases['circle-100'].notes[0]}" in notes
    assert "circle-20`" not in notes and "circle-100-law`" not in notes
