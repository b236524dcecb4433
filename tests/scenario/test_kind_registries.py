"""Kinds are objects: a throw-away reference kind and compensator kind, registered and removed.

Each is one registry entry (no other file touched); the test runs them through
``validate``, ``run``, the report and ``check``, then checks that nothing is
left once they are unregistered. Lists of kinds are read from the registries
(no test pins the whole list).
"""

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli.main import main
from hammerstein.signals import references as refs
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.core.schema import Field, integer, number, string
from hammerstein.scenario import registry
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.validate import validate_scenario

AMPLITUDE, FREQUENCY, PERIODS, T = 20.0, 200.0, 4, 5e-5


def sawtooth(sampling_period, outputs, output, amplitude, frequency, periods):
    """Naive sawtooth -A..A on one output (the test's own generator)."""
    t = np.arange(int(round(periods / frequency / sampling_period))) * sampling_period
    sig = np.zeros((len(outputs), t.size))
    sig[list(outputs).index(output)] = amplitude * (2.0 * np.mod(frequency * t, 1.0) - 1.0)
    return t, sig


def _generate(c, T, names, base_dir):
    t, sig = sawtooth(T, names, **c)
    return t, sig, 1.0 / c["frequency"], {"scale": c["amplitude"]}


def _peak_metric(time, table, reference, outputs):
    ch = 0
    return [{"channel": "x", "metric": "reference_peak", "value": float(reference[ch].max()),
             "unit": "µm"}]


SAWTOOTH = refs.ReferenceKind(
    {"output": Field(string(), required=True), "amplitude": Field(number("µm", 0), required=True),
     "frequency": Field(number("Hz", 0), required=True), "periods": Field(integer(1), default=2)},
    _generate, lambda s, unit: [f"sawtooth on {s['output']}", f"{s['amplitude']:g} {unit}"],
    "sawtooth on one output (test)", metrics=_peak_metric)


class HalfGain:
    """U = Yr / (2 K), K the direct secant gains of the plant's model: a toy law."""

    name = "half-gain"

    def __init__(self, model, factor):
        self.model = model
        self.gain = factor * np.diag([model.components[k][k].peak_output(10.0) / 10.0
                                      for k in range(model.n_outputs)])

    def simulate(self, reference, initial_state=None):
        return np.linalg.solve(self.gain, np.asarray(reference, dtype=float)), None


def _half_gain_kind(rate_independent):
    return registry.CompensatorKind(
        lambda spec, plant, context: HalfGain(plant.hysteresis, spec["factor"]),
        {"factor": Field(number("-", 0), default=2.0)}, "U = Yr / (factor K) (test)",
        rate_independent=rate_independent, summary=lambda spec: [f"toy law, factor {spec['factor']:g}"])


SCENARIO = f"""
name = "throwaway"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true
[compensator]
kind = "half-gain"
factor = 2.0
[[cases]]
name = "saw"
settle_periods = 1
reference = {{ kind = "sawtooth", output = "x", amplitude = {AMPLITUDE}, frequency = {FREQUENCY}, periods = {PERIODS} }}
"""


@pytest.fixture
def scenario(tmp_path):
    path = tmp_path / "throwaway.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    return path


@pytest.mark.parametrize("rate_independent", [True, False])
def test_throwaway_kinds_run_through_validate_run_report_and_check(scenario, tmp_path, capsys,
                                                                   monkeypatch, rate_independent):
    with monkeypatch.context() as m:
        m.setitem(refs.REFERENCE_KINDS, "sawtooth", SAWTOOTH)
        m.setitem(registry.COMPENSATORS, "half-gain", _half_gain_kind(rate_independent))
        spec = validate_scenario(scenario)
        _, expected = sawtooth(T, ["x", "y"], "x", AMPLITUDE, FREQUENCY, PERIODS)
        np.testing.assert_array_equal(spec.cases[0].signal, expected)
        assert spec.cases[0].period_samples == round(1 / FREQUENCY / T)
        assert main(["validate", str(scenario)]) == 0
        out = tmp_path / "reports"
        # the report's text and metrics are checked, not its figures: none drawn
        assert main(["run", str(scenario), "--out", str(out), "--figures", "none"]) == 0, \
            capsys.readouterr().err
        report = (out / "throwaway" / "report.md").read_text(encoding="utf-8")
        assert "reference: sawtooth on x, 20 µm" in report                   # summary
        assert "half-gain: plant model, factor 2, toy law, factor 2" in report  # kind's notes
        # the rate-independent capability alone decides the dynamics warning (200 Hz > 31 Hz)
        assert ("is rate independent" in report) == rate_independent
        metrics = pd.read_csv(out / "throwaway" / "metrics.csv")
        peak = metrics.query("metric == 'reference_peak'")["value"].item()
        P = round(1 / FREQUENCY / T)
        assert peak == pytest.approx(AMPLITUDE * (2.0 * (P - 1) / P - 1.0))   # closed form
        rms = metrics.query("channel == 'x' and metric == 'rms_error'")["value"].item()
        assert rms > 0.05 * AMPLITUDE  # a half gain tracks half the reference: far off
        baseline = tmp_path / "baseline.csv"
        assert main(["check", str(scenario), "--baseline", str(baseline),
                     "--update"]) == 0, capsys.readouterr().err
        assert main(["check", str(scenario), "--baseline", str(baseline)]) == 0, \
            capsys.readouterr().err
    # unregistered: the kinds are unknown again, and the message lists the registries' kinds
    assert "sawtooth" not in refs.REFERENCE_KINDS and "half-gain" not in registry.COMPENSATORS
    with pytest.raises(ScenarioError) as exc:
        validate_scenario(scenario)
    text = str(exc.value)
    assert "compensator.kind: expected one of " + ", ".join(map(repr, registry.COMPENSATORS)) in text
    assert "reference.kind: expected one of " + ", ".join(map(repr, refs.REFERENCE_KINDS)) in text


@pytest.mark.parametrize("name, entry", sorted(refs.REFERENCE_KINDS.items()))
def test_every_reference_kind_describes_itself(name, entry):
    assert entry.description and callable(entry.generate) and callable(entry.summary)
    assert all(isinstance(f, Field) for f in entry.fields.values())


@pytest.mark.parametrize("name, entry", sorted(registry.COMPENSATORS.items()))
def test_every_compensator_kind_declares_consistent_capabilities(name, entry):
    assert entry.description
    # an inverse of the dynamics is not rate independent, and runs with its own start-up:
    # in a batch only through its compensator's fused_run (fade-in, preview, initial state)
    assert not (entry.look_ahead and entry.rate_independent)
    if entry.look_ahead and entry.batchable:
        assert name == "hammerstein" and callable(HammersteinCompensator.fused_run)
    assert entry.fades_in <= entry.look_ahead


@pytest.mark.parametrize("extra, oracle", [
    ("", True),                                   # default: the plant's true G
    ('dynamics = "plant"', True),
    ('dynamics = "dyn.toml"', False),             # a dynamics file: what the user measured
])
def test_report_says_when_the_hammerstein_kind_inverts_the_true_dynamics(tmp_path, extra, oracle):
    from hammerstein.io.presets import load_plant, save_dynamics
    from hammerstein.runner import run_scenario

    plant = load_plant("rakotondrabe-2dof")
    save_dynamics(plant.dynamics, tmp_path / "dyn.toml")
    path = tmp_path / "h.toml"
    path.write_text(f"""
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "hammerstein"
model = "plant"
{extra}
[[cases]]
name = "x"
settle_periods = 1
reference = {{ kind = "sine", output = "x", amplitude = 20.0, frequency = 100.0, periods = 2 }}
""", encoding="utf-8")
    outcome = run_scenario(path, tmp_path / "out")
    assert outcome.ok, outcome.error
    report = (outcome.out_dir / "report.md").read_text(encoding="utf-8")
    assert ("inverts the plant's true dynamics G (an oracle" in report) == oracle
