"""A Lissajous reference is swept over frequency: each f sets f_x = f and keeps f_y / f_x.

Regression: the sweep wrote `frequency` into the template, a key the
Lissajous kind does not have, and the errors named `frequencies`, once per case.
"""

from hammerstein.scenario.sweeps import expand_sweeps


def _expand(reference, frequencies=(15.0, 30.0)):
    problems = []
    entries, specs = expand_sweeps([{"name": "liss", "frequencies": list(frequencies),
                                     "reference": reference}], "s.toml", problems)
    return entries, specs, problems


def test_lissajous_frequencies_scale_with_the_swept_frequency():
    entries, specs, problems = _expand({"kind": "lissajous", "amplitude": 30.0,
                                        "frequencies": [3.0, 2.0], "periods": 2})
    assert problems == []
    refs = {case["name"]: case["reference"] for _, case in entries}
    assert refs["liss-15Hz"]["frequencies"] == [15.0, 10.0]
    assert refs["liss-30Hz"]["frequencies"] == [30.0, 20.0]
    assert all("frequency" not in r for r in refs.values())
    assert [c["frequency_hz"] for c in specs[0].cases] == [15.0, 30.0]


def test_a_lissajous_template_without_its_frequencies_is_one_problem():
    entries, _, problems = _expand({"kind": "lissajous", "amplitude": 30.0, "periods": 2})
    assert entries == [] and len(problems) == 1
    assert "reference.frequencies" in problems[0] and "ratio" in problems[0]


def test_a_kind_without_frequency_says_so_once():
    _, _, problems = _expand({"kind": "file", "file": "r.csv", "columns": {"x": "x"}})
    assert len(problems) == 1 and "no frequency to sweep" in problems[0]


def test_a_sine_template_still_takes_the_frequency():
    entries, _, problems = _expand({"kind": "sine", "output": "x", "amplitude": 10.0,
                                    "periods": 2})
    assert problems == [] and entries[0][1]["reference"]["frequency"] == 15.0
    _, _, problems = _expand({"kind": "sine", "output": "x", "amplitude": 10.0,
                              "frequency": 5.0, "periods": 2})
    assert len(problems) == 1 and "reference.frequency: given by the sweep" in problems[0]
