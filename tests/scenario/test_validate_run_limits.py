"""``validate`` refuses what ``run`` would refuse: signals beyond 1e150, bad identification components.

A reference of radius 1e151 was only warned ("implausible") by validate, then
run failed "reference: 1e+151 is beyond the limit" without the key path; an
identification scenario's ``components = "zz"`` passed validate and failed at run.
"""

import shutil

import pytest

from hammerstein.exceptions import ScenarioError
from hammerstein.scenario.validate import validate_scenario

SIGNALS = """
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "multivariable"
model = "plant"
[[cases]]
name = "c"
reference = { kind = "circle", radius = 1e151, frequency = 10.0, periods = 2 }
[[cases]]
name = "d"
reference = { kind = "sine", output = "x", amplitude = 0.9e150, offset = 0.9e150, frequency = 10.0, periods = 2 }
[[cases]]
name = "e"
drive = { kind = "sine", input = "ux", amplitude = 2e150, frequency = 10.0, periods = 2 }
[[cases]]
name = "ok"
reference = { kind = "circle", radius = 5.0, frequency = 10.0, periods = 2 }
[[sweeps]]
name = "s"
frequencies = [10.0]
reference = { kind = "sine", output = "x", amplitude = 1e151, periods = 2 }
"""


def _problems(path):
    with pytest.raises(ScenarioError) as err:
        validate_scenario(path)
    return err.value.problems


def test_a_signal_beyond_the_simulation_limit_names_its_key(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SIGNALS, encoding="utf-8")
    problems = _problems(path)
    expected = ["cases[0].reference.radius: 1e+151 µm is beyond the limit 1e+150",
                "cases[1].reference: its peak 1.8e+150 µm is beyond the limit 1e+150",
                "cases[2].drive.amplitude: 2e+150 V is beyond the limit 1e+150",
                "sweeps[0](s-10Hz).reference.amplitude: 1e+151 µm is beyond the limit 1e+150"]
    assert [p.split(": ", 1)[1] for p in problems] == expected


IDENT = """kind = "identification"
[data]
file = "record.csv"
time = "t"
output = "y"
input = "u"
[identification]
method = "least-squares"
n_hysterons = 15
components = {components}
"""


@pytest.mark.parametrize("components, message", [
    ('"zz"', "identification.components: expected 'auto', 'all' or OUTPUT:INPUT=pi|gain|none"),
    ('"y:u=pj"', "identification.components: expected 'auto', 'all' or OUTPUT:INPUT"),
    ('"y:v=pi"', "identification.components: unknown input 'v' (inputs: u)"),
    ('"x:u=gain"', "identification.components: unknown output 'x' (outputs: y)"),
])
def test_identification_components_are_checked_by_validate(tmp_path, components, message):
    t = [i * 1e-3 for i in range(400)]
    rows = [f"{ti:g},{2.0 * ((i % 100) / 50.0 - 1.0):g},{(i % 100) / 50.0 - 1.0:g}"
            for i, ti in enumerate(t)]
    (tmp_path / "record.csv").write_text("t,y,u\n" + "\n".join(rows) + "\n", encoding="utf-8")
    path = tmp_path / "i.toml"
    path.write_text(IDENT.format(components=components), encoding="utf-8")
    problems = _problems(path)
    assert len(problems) == 1 and message in problems[0], problems
    path.write_text(IDENT.format(components='"y:u=pi"'), encoding="utf-8")
    validate_scenario(path)
