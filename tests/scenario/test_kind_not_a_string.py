"""A ``kind`` written as a list or a table is a problem listed with the others, not a TypeError.

``kind in {...}`` raises ``TypeError: unhashable type`` for a list or a table,
which stopped ``validate`` at the first one ("unexpected TypeError") and hid
the file's other problems.
"""

from pathlib import Path

import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.io.presets import PresetError, load_plant
from hammerstein.scenario.registry import compensator_kind
from hammerstein.scenario.validate import validate_scenario

ROOT = Path(__file__).resolve().parents[2]

CASES = """
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = {comp}
[[cases]]
name = "c"
reference = {{ kind = {ref}, output = "x", amplitude = 10.0, frequency = 50.0, periods = 3 }}
settle_periods = "one"
"""


def _problems(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    return err.value.problems


@pytest.mark.parametrize("comp, ref, key, found", [
    ('["multivariable"]', '"sine"', "compensator.kind", "['multivariable']"),
    ('{ a = 1 }', '"sine"', "compensator.kind", "{'a': 1}"),
    ('"multivariable"', "{}", "cases[0].reference.kind", "{}"),
    ('"multivariable"', '["sine"]', "cases[0].reference.kind", "['sine']"),
])
def test_a_kind_list_or_table_is_listed_with_the_other_problems(tmp_path, comp, ref, key, found):
    problems = _problems(tmp_path, CASES.format(comp=comp, ref=ref))
    assert any(f": {key}: expected one of " in p and f"found {found}" in p for p in problems), problems
    if key == "cases[0].reference.kind":
        return      # the case is not checked further without its signal
    assert any("cases[0].settle_periods" in p for p in problems), problems


def test_a_drive_kind_list_is_a_problem(tmp_path):
    text = ('[plant]\npreset = "rakotondrabe-2dof"\n[[cases]]\nname = "c"\n'
            'drive = { kind = ["sine"], input = "ux", amplitude = 5.0, frequency = 50.0 }\n'
            '[[cases]]\nname = "c"\ndrive = { kind = "sine", input = "ux", amplitude = 5.0, '
            'frequency = 50.0 }\n')
    problems = _problems(tmp_path, text)
    assert any("cases[0].drive.kind: expected one of" in p for p in problems), problems
    assert any("duplicate case name" in p for p in problems), problems


def test_a_top_level_kind_list_is_a_problem(tmp_path):
    problems = _problems(tmp_path, 'kind = ["cases"]\n[plant]\npreset = "rakotondrabe-2dof"\n')
    assert len(problems) == 1 and ": kind: expected one of " in problems[0], problems
    assert "found ['cases']" in problems[0]


def test_a_stability_map_kind_list_is_refused_at_run():
    with pytest.raises(ValueError, match=r"kind: expected one of .*found \['hammerstein'\]"):
        compensator_kind({"kind": ["hammerstein"]})


def test_an_ilc_start_kind_list_is_a_problem(tmp_path):
    text = CASES.format(comp='"ilc"', ref='"sine"').replace(
        'kind = "ilc"', 'kind = "ilc"\nstart = { kind = ["hammerstein"] }')
    problems = _problems(tmp_path, text)
    assert any("compensator.start" in p and "found ['hammerstein']" in p for p in problems), problems


def test_a_preset_dynamics_kind_list_names_the_key(tmp_path):
    text = (ROOT / "hammerstein" / "presets" / "rakotondrabe-2dof.toml").read_text(encoding="utf-8")
    assert 'kind = "bending_modes"' in text
    path = tmp_path / "p.toml"
    path.write_text(text.replace('kind = "bending_modes"', "kind = []"), encoding="utf-8")
    with pytest.raises(PresetError, match=r"dynamics\.kind: expected 'bending_modes', 'state_space' "
                                          r"or 'none', found \[\]"):
        load_plant(str(path))
