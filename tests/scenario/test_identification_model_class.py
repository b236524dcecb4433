"""A ``kind = "identification"`` scenario fits every model class ``hammerstein identify`` writes.

Regression: ``[identification] model = "preisach"`` was refused (``identification.model:
unknown key``): the scenario fitted only the classical PI. The fixture is a Preisach
actuator (asymmetric densities, reversible terms, an even cross-coupling) played by one
decreasing sine per input, as ``tests/cli/test_identify_model.py``'s.
"""

import numpy as np
import pytest

from hysteresis_records import decreasing_sine_records, preisach_actuator as actuator
from cli_run import run_cli
from hammerstein.io.presets import load_model
from hammerstein.scenario.records import load_identification_scenario, run_identification_scenario
from hammerstein.scenario.schema import ScenarioError
from hammerstein.io.presets import read_toml

T = 1e-3


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    d = tmp_path_factory.mktemp("ident")
    decreasing_sine_records(d, actuator(), 0.04, "hyst", T)
    return d


def _scenario(d, extra):
    path = d / "s.toml"
    path.write_text('kind = "identification"\n[data]\nfiles = ["hyst-0.csv", "hyst-1.csv"]\n'
                    'inputs = ["ux", "uy"]\noutputs = ["x", "y"]\ntime = "t"\n'
                    f'[identification]\n{extra}', encoding="utf-8")
    return path


def _load(path):
    return load_identification_scenario(path, read_toml(path, "scenario"))


@pytest.mark.slow
@pytest.mark.parametrize("model, options", [
    ("preisach", ["--preisach-levels", "12"]),
    ("preisach", ["--preisach-levels", "12", "--preisach-smoothing", "0.003"]),
    ("generalized", [])])
def test_the_scenario_fits_the_class_identify_fits(records, model, options):
    extra = f'model = "{model}"\n' + ("preisach_levels = 12\n" if options else "") + (
        "preisach_smoothing = 0.003\n" if "--preisach-smoothing" in options else "")
    fit = run_identification_scenario(_load(_scenario(records, extra)))[0].fit
    assert run_cli("identify", "hyst-0.csv", "hyst-1.csv", "--inputs", "ux,uy", "--outputs",
                   "x,y", "--time", "t", "--model", model, *options, "--out", "m.toml",
                   cwd=records).returncode == 0
    cli = load_model(records / "m.toml")
    assert type(fit.model.components[0][0]) is type(cli.components[0][0])
    assert type(cli.components[0][0]).__name__ != "PrandtlIshlinskii"
    # the same model: the same outputs on a loop neither was fitted on
    t = np.arange(3000) * T
    u = np.vstack([7.0 * np.sin(2 * np.pi * t), 4.0 * np.sin(2 * np.pi * 1.7 * t)])
    y_cli, y = cli.simulate(u)[0], fit.model.simulate(u)[0]
    assert np.max(np.abs(y - y_cli)) <= 1e-9 * np.max(np.abs(y_cli))


def test_closed_form_and_thresholds_are_classical_options(records):
    with pytest.raises(ScenarioError) as err:
        _load(_scenario(records, 'model = "preisach"\nmethod = "closed-form"\n'))
    assert str(err.value).count("\n") == 0
    assert "identification.method: model = 'preisach' is fitted by least squares" in str(err.value)
    with pytest.raises(ScenarioError, match="identification.thresholds: only used by model = "
                                            "'classical'"):
        _load(_scenario(records, 'model = "generalized"\nthresholds = [0.0, 2.0, 4.0]\n'))
    assert _load(_scenario(records, "")).identification["model"] == "classical"


def test_a_training_fraction_with_nothing_held_out_is_refused_as_identify_refuses_it(records):
    """identify --hold-out none --train-fraction 0.5 is a usage error; the scenario used the
    fraction, ignored hold_out and reported a validation case."""
    with pytest.raises(ScenarioError, match=r"identification\.train_fraction: give train_fraction "
                                            r"or hold_out = 'none', not both"):
        _load(_scenario(records, 'hold_out = "none"\ntrain_fraction = 0.5\n'))
    assert _load(_scenario(records, 'train_fraction = 0.5\n')) is not None


def test_a_record_in_milliseconds_is_warned_of_as_identify_warns(tmp_path):
    """A time column in ms read as s: identify warns "a time in ms?"; the scenario read the
    same file without a word (its sampling period 1000 times too long)."""
    import warnings as w
    from hammerstein.io.datafiles import bundled_data, read_record
    rec = read_record(bundled_data(), input=2, output=1, time=0)
    t = np.arange(rec.u.shape[-1]) * rec.sampling_period * 1000.0
    np.savetxt(tmp_path / "ms.csv", np.column_stack([t, np.ravel(rec.u), np.ravel(rec.y)]),
               delimiter=",", header="t,u,y", comments="", fmt="%.9g")
    path = tmp_path / "ms.toml"
    path.write_text('kind = "identification"\n[data]\nfile = "ms.csv"\ninput = "u"\n'
                    'output = "y"\ntime = "t"\n[identification]\n', encoding="utf-8")
    with w.catch_warnings(record=True) as caught:
        w.simplefilter("always")
        run_identification_scenario(_load(path))
    said = [str(c.message) for c in caught if "a time in ms?" in str(c.message)]
    assert len(said) == 1 and "data.sampling_period" in said[0]
