"""``validate`` checks ``[stability_map.compensators]`` with the rules of a case's compensator.

They were checked only by ``run`` (one problem at a time, and ``check = 5``
not at all); ``validate`` said "ok".
"""

import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.scenario.validate import validate_scenario

TEXT = """
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
model = "plant"
[stability_map]
scales = { start = 0.5, stop = 2.0, num = 5 }
[stability_map.compensators]
ok = { kind = "multivariable", model = "plant" }
a = { kind = "multivariable", model = "plant", check = 5 }
b = { kind = "multivariable", model = "identified", identify = { frequency = 50.0, periods = 1000000000 } }
c = { kind = -9223372036854775808 }
d = { kind = "multivariable", model = "identified", identify = { frequency = 50.0, n_hysterons = 1000000, amplitude = 5e-324 } }
e = { kind = "multivariable", modle = "plant" }
f = { kind = "multivariable", model = "no-such-model.toml" }
g = { kind = "multivariable", model = "identified" }
[[cases]]
name = "c"
reference = { kind = "sine", output = "x", amplitude = 10.0, frequency = 50.0, periods = 2 }
plant = { dynamics = false }
"""


def test_every_problem_of_the_map_compensators_is_listed(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(TEXT, encoding="utf-8")
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    problems = err.value.problems
    where = "stability_map.compensators"
    for key in ("a.check", "b.identify.periods", "c.kind", "d.identify.n_hysterons",
                "d.identify.amplitude", "e.modle", "f: ", "g: identify: missing"):
        assert sum(f"{where}.{key}" in p for p in problems) == 1, (key, problems)
    assert not any(f"{where}.ok" in p for p in problems)
    assert len(problems) == 8, problems


def test_a_valid_map_still_validates(tmp_path):
    path = tmp_path / "s.toml"
    text = "\n".join(line for line in TEXT.splitlines()
                     if not line.startswith(("a ", "b ", "c ", "d ", "e ", "f ", "g ")))
    path.write_text(text, encoding="utf-8")
    spec = validate_scenario(path)
    assert list(spec.stability_map["compensators"]) == ["ok"]
