"""Sweeps: expansion (names, count, frequencies), sweep CSV shape, compensator family via the runner."""

import numpy as np
import pandas as pd
import pytest

from hammerstein.runner import run_scenario
from hammerstein.scenario.resolve import load_scenario
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.sweeps import expand_sweeps

HEAD = """
name = "sw"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
"""

FREQS = [10.0, 25.0, 50.0]


def _write(tmp_path, text, name="sw.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_expansion_names_count_and_frequencies():
    sweeps = [{"name": "s", "frequencies": FREQS, "settle_periods": 1.0,
               "reference": {"kind": "sine", "output": ["x", "y"], "amplitude": 50.0, "periods": 3},
               "compensators": {"mv": {"kind": "multivariable"}, "pa": {"kind": "per-axis"}}}]
    problems = []
    entries, specs = expand_sweeps(sweeps, "f.toml", problems)
    assert problems == []
    names = [raw["name"] for _, raw in entries]
    assert len(names) == 2 * 2 * len(FREQS) == len(set(names))
    assert names[0] == "s-mv-x-10Hz" and "s-pa-y-50Hz" in names
    for _, raw in entries:
        lab, axis, f = raw["name"].split("-")[1:]
        assert raw["reference"]["output"] == axis
        assert raw["reference"]["frequency"] == pytest.approx(float(f[:-2]), rel=0, abs=0)
        assert raw["compensator"]["kind"] == {"mv": "multivariable", "pa": "per-axis"}[lab]
    assert [c["frequency_hz"] for c in specs[0].cases[:3]] == FREQS


@pytest.mark.parametrize("sweep, message", [
    ({"name": "s", "frequencies": [10.0], "reference": {"kind": "sine", "output": "x", "amplitude": 5.0,
                                                       "frequency": 3.0, "periods": 2}}, "given by the sweep"),
    ({"name": "s", "reference": {"kind": "sine", "output": "x", "amplitude": 5.0, "periods": 2}},
     "expected frequencies"),
    ({"name": "s", "frequencies": [10.0, 10.0], "reference": {"kind": "sine", "output": "x"}}, "duplicates"),
    ({"name": "s", "frequencies": [-1.0], "reference": {"kind": "sine", "output": "x"}}, "positive"),
    ({"name": "s", "frequencies": [1.0], "refrence": {}}, "did you mean 'reference'"),
])
def test_expansion_errors_name_the_field(sweep, message):
    problems = []
    expand_sweeps([sweep], "f.toml", problems)
    assert any(message in p and p.startswith("f.toml: sweeps[0]") for p in problems), problems


def test_sweep_csv_shape_and_no_time_series(tmp_path):
    text = HEAD + """
[[sweeps]]
name = "s"
frequencies = [10.0, 25.0, 50.0]
reference = { kind = "sine", output = ["x", "y"], amplitude = 50.0, periods = 3 }
[sweeps.compensators]
mv = { kind = "multivariable" }
pa = { kind = "per-axis" }
"""
    out = run_scenario(_write(tmp_path, text), tmp_path / "out")
    assert out.ok, out.error
    d = out.out_dir
    table = pd.read_csv(d / "sweep-s.csv")
    assert list(table.columns[:4]) == ["frequency_hz", "compensator", "axis", "channel"]
    # 2 compensators x 2 axes x 3 frequencies x (3 output channels x, y, x+y
    # + 2 input channels ux, uy with peak_input and peak_slew)
    assert len(table) == 2 * 2 * 3 * (3 + 2)
    assert sorted(table["frequency_hz"].unique()) == FREQS
    assert not list(d.glob("timeseries-*.csv"))
    assert (d / "sweep-s.png").is_file() and "sweep-s.png" in (d / "report.md").read_text()
    m = pd.read_csv(d / "metrics.csv")
    assert list(m.columns) == ["case", "channel", "metric", "value", "unit"]
    assert m["case"].nunique() == 12
    # the same cases simulated one by one (no batching) give the same metrics
    one = _write(tmp_path, HEAD + """
[[cases]]
name = "one"
reference = { kind = "sine", output = "y", amplitude = 50.0, frequency = 25.0, periods = 3 }
""", "one.toml")
    single = run_scenario(one, tmp_path / "out").metrics
    a = m[m["case"] == "s-mv-y-25Hz"].set_index(["channel", "metric"])["value"]
    b = single.set_index(["channel", "metric"])["value"]
    np.testing.assert_allclose(a.loc[b.index], b, rtol=1e-9, atol=1e-9)


def test_per_axis_exact_on_direct_axes_and_multivariable_cuts_cross_couplings(tmp_path, no_figures):
    """Static plant: per-axis inverse ∘ model = identity on the direct axes; the multivariable
    compensator leaves >= 5x smaller residual cross-couplings than the per-axis baseline."""
    text = HEAD + """
[[sweeps]]
name = "fam"
frequencies = [50.0]
reference = { kind = "sine", output = ["x", "y"], amplitude = 50.0, periods = 3 }
[sweeps.compensators]
mv = { kind = "multivariable", iterations = 3 }
pa = { kind = "per-axis" }
"""
    out = run_scenario(_write(tmp_path, text), tmp_path / "out", renderer=no_figures)
    assert out.ok, out.error
    t = pd.read_csv(out.out_dir / "sweep-fam.csv")
    rms = t.set_index(["compensator", "axis", "channel"])["rms_error"]
    for ax in "xy":
        assert rms[("pa", ax, ax)] < 1e-9  # numerical precision [µm]
    for ax, other in (("x", "y"), ("y", "x")):
        assert rms[("pa", ax, other)] > 0.5  # untouched cross-coupling [µm]
        assert rms[("mv", ax, other)] * 5 <= rms[("pa", ax, other)]


def test_compensator_only_sweep_and_lowpass_feedback(tmp_path, no_figures):
    text = HEAD + """
[[sweeps]]
name = "fam"
reference = { kind = "circle", radius = 30.0, frequency = 50.0, periods = 3 }
[sweeps.compensators]
delay = { kind = "multivariable" }
lowpass = { kind = "multivariable", feedback = "lowpass", cutoff_hz = 4000.0 }
diag = { kind = "diagonal" }
none = { kind = "static-gain" }
"""
    sc = load_scenario(_write(tmp_path, text))
    assert [c.name for c in sc.cases] == ["fam-delay", "fam-lowpass", "fam-diag", "fam-none"]
    assert sc.cases[1].compensator.feedback == "lowpass"
    assert sc.cases[1].compensator.filter_coefficient == pytest.approx(np.exp(-2 * np.pi * 4000 * 50e-6))
    out = run_scenario(_write(tmp_path, text), tmp_path / "out", renderer=no_figures)
    t = pd.read_csv(out.out_dir / "sweep-fam.csv").set_index(["compensator", "channel"])
    e = t["max_euclidean_error"]
    assert e[("delay", "x+y")] < e[("diag", "x+y")] < e[("none", "x+y")]


def test_lowpass_needs_a_cutoff(tmp_path):
    text = HEAD + """
[[cases]]
name = "c"
reference = { kind = "sine", output = "x", amplitude = 50.0, frequency = 50.0, periods = 2 }
compensator = { feedback = "lowpass" }
"""
    with pytest.raises(ScenarioError, match="cutoff_hz"):
        load_scenario(_write(tmp_path, text))


def test_stability_map_table(tmp_path, no_figures):
    text = HEAD + """
[stability_map]
scales = [0.1, 1.0, 5.0]
[[cases]]
name = "c"
reference = { kind = "sine", output = "x", amplitude = 50.0, frequency = 50.0, periods = 2 }
"""
    out = run_scenario(_write(tmp_path, text), tmp_path / "out", renderer=no_figures)
    assert out.ok, out.error
    t = pd.read_csv(out.out_dir / "stability-map.csv")
    assert list(t["scale"]) == [0.1, 1.0, 5.0]
    row = t.set_index("scale")
    assert row.loc[1.0, "max_radius"] < 1 and bool(row.loc[1.0, "converges"])
    assert row.loc[0.1, "max_radius"] > 1  # far under-normalised, like K = I (docs/compensator.md)


def test_a_parameter_sweep_draws_its_figure_against_the_values(tmp_path):
    # the figure was drawn against frequency_hz, a column the table of a parameter sweep
    # renames to the parameter: every such sweep with figures failed with a KeyError
    text = HEAD + """
[[sweeps]]
name = "amp"
parameter = "amplitude"
values = [10.0, 20.0, 40.0]
reference = { kind = "sine", output = "x", frequency = 20.0, periods = 2 }
metric = "max_euclidean_error"
"""
    out = run_scenario(_write(tmp_path, text), tmp_path / "out")
    assert out.ok, out.error
    table = pd.read_csv(out.out_dir / "sweep-amp.csv")
    assert sorted(set(table["amplitude"])) == [10.0, 20.0, 40.0] and "frequency_hz" not in table
    assert (out.out_dir / "sweep-amp.png").stat().st_size > 10_000
    err = table[table["channel"] == "x+y"]["max_euclidean_error"]   # per output: max_abs_error
    assert len(err) == 3 and err.notna().all() and (err > 0).all()
    report = (out.out_dir / "report.md").read_text(encoding="utf-8")
    assert "![max_euclidean_error vs amplitude](sweep-amp.png)" in report   # was "vs frequency"


def test_the_axis_of_a_parameter_sweep_names_its_unit():
    from types import SimpleNamespace
    from hammerstein.report.sweeps import sweep_figure
    table = pd.DataFrame({"amplitude": [10.0, 20.0], "compensator": ["-", "-"], "axis": ["x", "x"],
                          "channel": ["x+y", "x+y"], "max_euclidean_error": [0.5, 1.0]})
    spec = SimpleNamespace(parameter="amplitude", metric="max_euclidean_error", frequencies=[10.0, 20.0],
                           name="amp", axes=["x"], mode="reference")
    fig = sweep_figure(table, spec, ["x", "y"], "t")
    assert fig.axes[0].get_xlabel() == "amplitude [µm]"
