"""The one schema toolkit (hammerstein/core/schema.py): checkers, tables, the one "did you mean"."""

import difflib
import re
from pathlib import Path

import pytest
from hypothesis import given, strategies as st

from hammerstein.io.presets import PresetError, load_plant, model_from_table
from hammerstein.core.schema import (Field, Invalid, NestedInvalid, check_table, choice, did_you_mean,
                                     integer, nested_table, number, table_problems)

PACKAGE = Path(__file__).resolve().parents[2] / "hammerstein"
SCHEMA = {"frequency": Field(number("Hz", 0), required=True),
          "periods": Field(integer(1), default=3),
          "method": Field(choice("closed-form", "least-squares"))}


def test_one_did_you_mean_in_the_package():
    """Every hint comes from did_you_mean: no other module calls difflib or writes the phrase."""
    users = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                   if re.search(r"get_close_matches|did you mean \{", p.read_text(encoding="utf-8")))
    assert users == ["core/schema.py"]


@given(st.text(min_size=1, max_size=12), st.lists(st.text(min_size=1, max_size=12), max_size=6))
def test_did_you_mean_is_difflibs_closest_match(value, options):
    hint = difflib.get_close_matches(value, options, n=1)
    assert did_you_mean(value, options) == (f" (did you mean {hint[0]!r}?)" if hint else "")


def test_check_table_reports_every_problem_and_fills_defaults():
    problems = []
    clean = check_table({"frequncy": 5.0, "method": "least-square"}, SCHEMA, "identify", problems,
                        "f.toml")
    assert clean == {"periods": 3}
    assert problems == [
        "f.toml: identify.frequncy: unknown key (did you mean 'frequency'?)",
        "f.toml: identify.method: expected one of 'closed-form', 'least-squares', found "
        "'least-square' (did you mean 'least-squares'?)",
        "f.toml: identify.frequency: missing (required)"]


@pytest.mark.parametrize("value, problems", [
    ({"frequency": 2.0}, []),
    ({"frequency": -1.0, "periods": 0}, ["identify.frequency: expected a number > 0 [Hz], found -1.0",
                                         "identify.periods: expected an integer >= 1, found 0"]),
    ({"zzz": 1}, ["identify.zzz: unknown key (valid keys: frequency, periods, method)",
                  "identify.frequency: missing (required)"]),
])
def test_table_problems_have_no_file_prefix(value, problems):
    assert table_problems(value, SCHEMA, "identify")[1] == problems


def test_nested_table_raises_every_problem_at_once():
    with pytest.raises(NestedInvalid) as exc:
        nested_table({"frequency": 0.0, "perods": 2}, SCHEMA, "{ frequency = 50.0 }",
                     cross=lambda clean: ["method: cross-key problem"])
    # in the table's key order, then the checks across keys
    assert exc.value.problems == [("frequency", "expected a number > 0 [Hz], found 0.0"),
                                  ("perods", "unknown key (did you mean 'periods'?)"),
                                  ("method", "cross-key problem")]
    with pytest.raises(Invalid, match=r"expected a table such as \{ frequency = 50.0 \}"):
        nested_table(3, SCHEMA, "{ frequency = 50.0 }")


def test_model_and_preset_files_use_the_same_hints(tmp_path):
    with pytest.raises(PresetError, match=r"model.outptus: unknown key \(did you mean 'outputs'\?\)"):
        model_from_table({"inputs": ["u"], "outputs": ["y"], "outptus": []})
    preset = tmp_path / "p.toml"
    preset.write_text('[preset]\nsampling_period = 1e-4\nnmae = "x"\n'
                      '[dynamics]\nkind = "bending_modes"\nnatural_frequency = [300.0]\n'
                      'damping_ratio = [0.1]\ndampin = 1\n'
                      '[model]\ninputs = ["u"]\noutputs = ["y"]\n'
                      '[model.components.y.u]\ngain = 1.0\n', encoding="utf-8")
    with pytest.raises(PresetError) as exc:
        load_plant(preset)
    assert "preset.nmae: unknown key (did you mean 'name'?)" in str(exc.value)
    assert "dynamics.dampin: unknown key (did you mean 'damping_ratio'?)" in str(exc.value)
