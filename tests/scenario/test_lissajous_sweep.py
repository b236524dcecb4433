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


def _expand_parameter(reference, parameter, values, **extra):
    problems = []
    entries, specs = expand_sweeps([{"name": "p", "parameter": parameter, "values": values,
                                     "reference": reference, **extra}], "s.toml", problems)
    return entries, specs, problems


def test_any_numeric_key_is_swept_with_parameter_and_values():
    entries, specs, problems = _expand_parameter(
        {"kind": "lissajous", "frequencies": [30.0, 20.0], "periods": 2}, "amplitude",
        [10.0, 20.0])
    assert problems == []
    assert [c["name"] for _, c in entries] == ["p-amplitude-10", "p-amplitude-20"]
    assert [c["reference"]["amplitude"] for _, c in entries] == [10.0, 20.0]
    assert specs[0].parameter == "amplitude" and specs[0].frequencies == [10.0, 20.0]


def test_a_pair_key_is_swept_and_drawn_against_its_first_value():
    entries, specs, problems = _expand_parameter(
        {"kind": "lissajous", "amplitude": 30.0, "periods": 2}, "frequencies",
        [[15.0, 10.0], [30.0, 20.0]])
    assert problems == []
    assert entries[1][1]["name"] == "p-frequencies-30x20"
    assert entries[1][1]["reference"]["frequencies"] == [30.0, 20.0]
    assert [c["frequency_hz"] for c in specs[0].cases] == [15.0, 30.0]


def test_a_parameter_the_kind_lacks_names_the_keys_it_has():
    _, _, problems = _expand_parameter({"kind": "circle", "frequency": 50.0, "periods": 2},
                                       "amplitude", [1.0, 2.0])
    assert len(problems) == 1 and "sweeps[0].parameter" in problems[0] and "radius" in problems[0]
    _, _, problems = _expand_parameter({"kind": "circle", "radius": 5.0, "frequency": 50.0,
                                        "periods": 2}, "radius", [1.0, 2.0])
    assert len(problems) == 1 and "reference.radius: given by the sweep's values" in problems[0]
    _, _, problems = _expand_parameter({"kind": "circle", "radius": 5.0, "periods": 2},
                                       "frequency", [10.0], frequencies=[5.0])
    assert len(problems) == 1 and "not both" in problems[0]
