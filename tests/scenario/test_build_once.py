"""A compensator (identification, convergence report) is built once per distinct table."""

import numpy as np
import pytest

from hammerstein.scenario import resolve
from hammerstein.scenario.resolve import canonical_key, load_scenario

SCENARIO = """
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
[[cases]]
name = "a"
reference = { kind = "circle", radius = 10.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "b"
reference = { kind = "circle", radius = 20.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "c"
reference = { kind = "circle", radius = 10.0, frequency = 50.0, periods = 2 }
compensator = { kind = "multivariable", gain = "identity", check = "warn" }
[[cases]]
name = "d"
reference = { kind = "circle", radius = 30.0, frequency = 50.0, periods = 2 }
compensator = { check = "warn", gain = "identity", kind = "multivariable" }
[[cases]]
name = "e"
reference = { kind = "circle", radius = 5.0, frequency = 50.0, periods = 2 }
compensator = { kind = "diagonal" }
"""


def test_equal_tables_build_one_compensator(tmp_path, monkeypatch):
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO)
    calls = []
    real = resolve.build_compensator

    def counting(spec, plant, base):
        calls.append(spec)
        return real(spec, plant, base)

    monkeypatch.setattr(resolve, "build_compensator", counting)
    sc = load_scenario(path)
    by = {c.name: c for c in sc.cases}
    assert len(calls) == 3                              # a = b, c = d (keys in any order), e
    assert by["a"].compensator is by["b"].compensator
    assert by["c"].compensator is by["d"].compensator
    assert len({id(by[n].compensator) for n in "ace"}) == 3
    # each case keeps the warnings its build raised (the literal law's convergence warning)
    assert by["c"].warnings == by["d"].warnings
    monkeypatch.setattr(resolve, "build_compensator", real)
    alone = load_scenario(path)                          # the same compensators as built alone
    for c in alone.cases:
        assert c.warnings == by[c.name].warnings
        np.testing.assert_array_equal(c.compensator.K_inv, by[c.name].compensator.K_inv)


@pytest.mark.parametrize("a, b, equal", [
    ({"x": 1.0, "y": [1, 2]}, {"y": (1, 2), "x": 1.0}, True),
    ({"x": 1.0}, {"x": 1.0000000000000002}, False),
    ({"x": np.arange(3.0)}, {"x": np.arange(3.0)}, True),
    ({"x": np.arange(3.0)}, {"x": np.arange(3)}, False),          # dtype matters
    ({"x": np.zeros(2000)}, {"x": np.r_[np.zeros(1999), 1e-300]}, False),  # no repr cut
    ({"x": "1"}, {"x": 1}, False),
])
def test_canonical_key(a, b, equal):
    assert (canonical_key(a) == canonical_key(b)) is equal
