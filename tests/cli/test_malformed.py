"""Hostile input: the corpus of malformed scenarios, model and data files
(``tests/corpus/``) through ``validate``, ``run``, ``identify`` and ``check``
(issue 6, items 1-4), and the numerical guards of item 2.

The stderr contract (``hammerstein.cli``): ``validate`` prints one
``error: <file>: <key>: <message>`` line per problem; ``run`` and
``identify`` print exactly one ``error: <file>: ...`` line per failed
scenario or data file; a usage error is one ``hammerstein <cmd>: error:``
line. Exit status 0 all ok, 1 a scenario or data file failed, 2 usage
error. No traceback, no partial report directory or model file.

Each corpus file is listed below with a fragment its error must contain
(the key path and what was expected), so a new corpus file needs an entry.
"""

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hammerstein.cli import listing
from hammerstein.signals import references as refs
from hammerstein.cli.main import main
from hammerstein.compensation.compensators import (CompensatorError, InverseMultiplicativeCompensator,
                                      PerAxisInverseCompensator, RangeWarning,
                                      check_reference_range)
from hammerstein.models.hysteresis import HysteresisError, MultivariablePI, PrandtlIshlinskii
from hammerstein.io.presets import load_plant

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good"

#: Malformed scenario file -> fragment its error must contain.
SCENARIOS = {
    "above-nyquist": "cases[0].reference.frequency: 10000 Hz is at or above the Nyquist frequency",
    "bad-case-name": "cases[0].name: expected a name of letters",
    "bad-seed": "seed: expected an integer >= 0, found -1",
    "deeply-nested-array": "invalid TOML: arrays or inline tables nested too deeply",
    "deeply-nested-inline-table": "invalid TOML: arrays or inline tables nested too deeply",
    "binary-garbage": "invalid TOML: not UTF-8 text",
    "both-drive-and-reference": "cases[0]: expected exactly one of reference",
    "cases-not-list": "cases: expected one or more [[cases]] tables",
    "drive-model-missing-file": "cases[0].model:",
    "duplicate-case-names": "cases[1].name: duplicate case name 'a'",
    "empty": "plant: missing (required)",
    "few-samples-per-period": "cases[0].drive.frequency: 3000 Hz gives 6.67 samples per period; expected at least 8",
    "huge-record": "cases[0].drive.periods: the record would have 4e+17 samples",
    "identification-bad-keys": "identification.methd: unknown key (did you mean 'method'?)",
    "identification-constant-input": "the input is constant",
    "identification-decreasing-time": "data.file:",
    "identification-directory": "is a directory",
    "identification-empty": "the file is empty",
    "identification-garbage": "not a text table (binary content)",
    "identification-misnamed-column": "no input column named 'u'; available columns: 0:time_s, 1:u_V, 2:y_um",
    "identification-missing-file": "nowhere.csv: no such file",
    "identification-non-numeric": "input column 'u_V': non-numeric or empty cell 'abc' at data row 8",
    "identify-above-nyquist": "identify.frequency: 15000 Hz is beyond the Nyquist frequency",
    "identify-bad-values": "compensator.identify.method: expected one of 'closed-form', 'least-squares', "
                           "found 'least-square' (did you mean 'least-squares'?)",
    "identify-missing": "identify: missing (required with model = 'identified')",
    "identify-not-table": "compensator.identify: expected a table",
    "identify-unknown-key": "compensator.identify.frequncy: unknown key (did you mean 'frequency'?)",
    "inf-frequency": "cases[0].drive.frequency: expected a number > 0 [Hz], found inf",
    "invalid-toml": "invalid TOML: Expected ']'",
    "kind-unknown": "kind: expected one of 'cases', 'identification', 'monte-carlo', 'feedback', found 'identificaton' "
                    "(did you mean 'identification'?)",
    "latin1": "invalid TOML: not UTF-8 text",
    "lissajous-bad-ratio": "cases[0].reference.frequencies: the ratio 50.0/50.0001 is not a simple fraction",
    "list-for-table": "cases[0].drive: expected a table, found ['sine'",
    "literal-law-check-error": "cases[0].compensator: gain: rho(I - K^-1 J) reaches 8.96 >= 1",
    "lowpass-above-nyquist": "compensator.cutoff_hz: expected 0 < cutoff_hz < 10000 Hz",
    "lowpass-without-cutoff": "compensator.cutoff_hz: missing (feedback='lowpass' needs a cut-off frequency",
    "many-wrong-types": "cases[0].drive.amplitude: expected a number > 0 [V], found datetime.date(1979, 5, 27)",
    "missing-case-name": "cases[0].name: missing (required)",
    "missing-cases": "cases: missing (required)",
    "missing-length": "cases[0].drive.periods/duration: give exactly one of periods or duration",
    "missing-model-file": "no-such-model.toml: no such file",
    "missing-plant": "plant: missing (required)",
    "missing-required": "cases[0].drive.amplitude: missing (required)",
    "model-duplicated-thresholds": "model.components.x.ux: thresholds: expected strictly increasing "
                                   "thresholds, found r[1]=3 followed by r[2]=3",
    "model-inf-thresholds": "model.components.x.ux: thresholds: expected finite values",
    "model-invalid-toml": "invalid-toml.toml: invalid TOML",
    "model-mismatched-lengths": "model.components.x.ux: weights: expected 3 weights to match the "
                                "thresholds, found 2",
    "model-nan-weights": "model.components.x.ux: weights: expected finite values",
    "model-huge-weights": "model.components.x.ux.weights[1]: 1e+300 is beyond the magnitude limit 1e+150",
    "model-negative-thresholds": "model.components.x.ux: thresholds: expected non-negative thresholds, found -1",
    "model-no-model-table": "missing [model] table",
    "model-string-weights": "model.components.x.ux: weights: expected numbers",
    "model-unknown-component-output": "model.components.z: unknown output",
    "model-unsorted-thresholds": "model.components.x.ux: thresholds: expected strictly increasing "
                                 "thresholds, found r[1]=6 followed by r[2]=3",
    "nan-amplitude": "cases[0].drive.amplitude: expected a number > 0 [V], found nan",
    "nan-gain-matrix": "compensator.gain: expected 'secant', 'midpoint', 'identity' or a square matrix",
    "negative-amplitude": "cases[0].drive.amplitude: expected a number > 0 [V], found -10.0",
    "per-axis-non-invertible": "Gamma_xux: weights: the cumulative weight sum S_2 = -1 µm/V is <= 0",
    "plant-not-table": "plant: expected a table",
    "plant-preset-nan-dynamics": "dynamics.natural_frequency: expected positive values [Hz], found [nan]",
    "plant-preset-unsorted": "model.components.x.ux: thresholds: expected strictly increasing",
    "plant-preset-zero-period": "preset.sampling_period: expected a positive time [s], found 0.0",
    "reference-without-compensator": "cases[0].reference: a reference needs a compensator",
    "singular-gain-matrix": "gain: the gain matrix K is singular",
    "spiral-missing-duration": "cases[0].reference.duration: missing (required)",
    "stability-map-bad-scales": "stability_map.scales: expected a list of positive gain scalings",
    "string-for-number": "cases[0].drive.amplitude: expected a number > 0 [V], found '10 V'",
    "sweep-above-nyquist": "sweeps[0](s-12000Hz).reference.frequency: 12000 Hz is at or above the Nyquist",
    "sweep-duplicate-frequencies": "sweeps[0].frequencies: expected distinct frequencies",
    "sweep-frequency-in-template": "sweeps[0].reference.frequency: given by the sweep's frequencies",
    "sweep-nan-frequency": "sweeps[0].frequencies: expected a non-empty list of positive frequencies",
    "sweep-negative-frequency": "sweeps[0].frequencies: expected a non-empty list of positive frequencies",
    "sweep-not-list": "sweeps: expected one or more [[sweeps]] tables",
    "sweep-string-frequencies": "sweeps[0].frequencies: expected a non-empty list",
    "sweep-unknown-key": "sweeps[0].frequency: unknown key (did you mean 'frequencies'?)",
    "too-much-settling": "cases[0].settle_periods: 5 periods of settling leave less than one period",
    "unknown-case-key": "cases[0].settle_period: unknown key (did you mean 'settle_periods'?)",
    "unknown-circle-outputs": "cases[0].reference.outputs: expected two of the plant's outputs",
    "unknown-compensator-key": "compensator.iteration: unknown key (did you mean 'iterations'?)",
    "unknown-compensator-kind": "compensator.kind: expected one of 'none', 'multivariable'",
    "unknown-input": "cases[0].drive.input: expected one of ['ux', 'uy'], found 'uz'",
    "unknown-output": "cases[0].reference.output: expected one of ['x', 'y'], found 'z'",
    "unknown-plant-key": "plant.dynamic: unknown key (did you mean 'dynamics'?)",
    "unknown-preset": "rakotondrabe-2dfo: not a bundled preset",
    "unknown-reference-key": "cases[0].reference.amplitud: unknown key (did you mean 'amplitude'?)",
    "unknown-reference-kind": f"cases[0].reference.kind: expected one of "   # from the registry
                              f"{', '.join(map(repr, refs.REFERENCE_KINDS))}, found 'sinus' "
                              "(did you mean 'sine'?)",
    "unknown-top-key": "nmae: unknown key (did you mean 'name'?)",
    "zero-frequency": "cases[0].drive.frequency: expected a number > 0 [Hz], found 0.0",
    "zero-iterations": "compensator.iterations: expected an integer 1..100, found 0",
    "zero-radius": "cases[0].reference.radius: expected a number > 0 [µm], found 0",
    # issue 13: bounds, names, what validate can know
    "..": "name: missing, and the file name '..' is not usable as the report directory name",
    "huge-iterations": "compensator.iterations: expected an integer 1..100, found 9223372036854775807",
    "long-title": "title: expected at most 200 characters, found 300",
    "long-name": "name: expected at most 100 characters, found 300",
    "long-case-name": "cases[0].name: expected at most 100 characters, found 101",
    "long-record": "cases[0].drive: the record would have 4e+06 samples; expected at most 2e+06 per case",
    "samples-budget": "cases[2].drive: its 1.8e+06 samples bring the scenario to 5.4e+06; expected at "
                      "most 5e+06 samples per scenario",
    "too-many-cases": "cases: 2200 cases (sweeps expanded); expected at most 2000",
    "sweep-too-many-frequencies": "sweeps[0].frequencies: expected at most 200 frequencies, found 201",
    "sweep-duplicate-names": "sweeps[1].name: duplicate sweep name 's' (also sweeps[0])",
    "sweep-unknown-metric": "sweeps[0].metric: expected one of 'peak_to_peak'",
    "model-shape-mismatch": "compensator.model: ../models/one-by-one.toml: the model has 1 input(s) "
                            "['u'] and 1 output(s) ['y']; the plant has 2 ['ux', 'uy'] and 2 ['x', 'y']",
    "drive-model-shape-mismatch": "cases[0].model: ../models/one-by-one.toml: the model has 1 input(s)",
    "dynamics-without-dynamics": "plant.dynamics: true, but the preset '../models/preset-static.toml' "
                                 "has no [dynamics]",
    "circle-same-outputs": "cases[0].reference.outputs: expected two different outputs of the plant",
    "cutoff-with-delay": "compensator.cutoff_hz: only used with feedback = 'lowpass' (feedback is 'delay')",
    "identify-without-identified": "compensator.identify: only used with model = 'identified'",
    "identify-huge-periods": "compensator.identify.periods: expected an integer 2..1000, found 100000",
    "identify-too-slow": "identify.frequency: 1e-06 Hz for 3 periods would record 6e+10 samples",
    "plant-preset-unknown-key": "preset.sampling_perod: unknown key (did you mean 'sampling_period'?); "
                                "dynamics.damping: unknown key (did you mean 'damping_ratio'?)",
    "model-unknown-key": "model.input_amplitud: unknown key (did you mean 'input_amplitude'?)",
    "device-model": "/dev/zero: not a regular file (a device, FIFO or socket), expected a model file",
    "device-preset": "/dev/zero: not a regular file (a device, FIFO or socket), expected a preset file",
    # issue 22: confinement, numbers beyond the float range, subnormals
    "outside-absolute-model": "/etc/passwd: outside the scenario's directory",
    "bundled-dotdot": "expected bundled:<file name> of a file shipped with hammerstein",
    "huge-int-frequency": "frequency: expected a number > 0 [Hz], found 1000000",
    "subnormal-frequency": "frequency: expected a number > 0 [Hz], found 5e-324",
    "nul-in-path": "a path cannot contain a NUL character",
}
#: Files whose problems ``validate`` cannot see: they are found when the scenario is
#: resolved (a compensator refused by its own checks) or run (an identification on a
#: record); stem -> number of cases ``validate`` reports.
RUN_ONLY = {"identification-constant-input": 2, "literal-law-check-error": 1,
            "per-axis-non-invertible": 1, "singular-gain-matrix": 1}
#: Files with several problems: validate lists each on its own line.
SEVERAL = {"empty": 2, "identification-bad-keys": 5, "identify-bad-values": 4,
           "many-wrong-types": 5, "spiral-missing-duration": 2, "unknown-reference-key": 2,
           "identify-unknown-key": 2}

#: Malformed data file for ``hammerstein identify`` -> fragment of its error.
DATA = {
    "a-directory.csv": "is a directory, expected a data file",
    "constant-input.csv": "the input is constant",
    "decreasing-time.csv": "time column 'time_s' is not increasing at data row 12",
    "empty-cell.csv": "input column 'u_V': non-numeric or empty cell (empty or NaN) at data row 16",
    "empty.csv": "the file is empty",
    "constant-output.csv": "output column 'y_um': the output is constant over the training samples",
    "garbage.bin": "not a text table (binary content)",
    "header-only.csv": "too short, expected at least 10 samples, found 0",
    "inf-cell.csv": "output column 'y_um': infinite values",
    "misnamed-columns.csv": "no input column named 'u_V'; available columns: 0:time, 1:voltage, 2:displacement",
    "nan-cell.csv": "input column 'u_V': non-numeric or empty cell (empty or NaN) at data row 13",
    "non-numeric-cell.csv": "input column 'u_V': non-numeric or empty cell 'abc' at data row 8",
    "non-uniform-time.csv": "time column 'time_s' is not uniformly sampled: step 0.0015 s at data row 21",
    "ragged-rows.csv": "output column 'y_um': non-numeric or empty cell (empty or NaN) at data row 21",
    "single-column.csv": "no output column named 'y_um'; available columns: 0:u_V",
    "too-short.csv": "too short, expected at least 10 samples, found 5",
    "nowhere.csv": "no such file",
}
IDENTIFY_COLUMNS = ["--time", "time_s", "--input", "u_V", "--output", "y_um", "--thresholds", "5"]


def _call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err.splitlines()


def test_every_corpus_file_is_listed():
    on_disk = {p.stem for p in (CORPUS / "scenarios").glob("*.toml")}
    assert on_disk == set(SCENARIOS)
    data = {p.name for p in (CORPUS / "data").iterdir()} - {"good.csv", "utf16.csv"}
    assert data | {"nowhere.csv"} == set(DATA)


@pytest.mark.parametrize("stem", sorted(SCENARIOS))
def test_validate_lists_every_problem(capsys, stem):
    path = CORPUS / "scenarios" / f"{stem}.toml"
    status, out, err = _call(capsys, "validate", path)
    if stem in RUN_ONLY:
        n = RUN_ONLY[stem]
        assert (status, err) == (0, []) and f"ok ({n} case{'' if n == 1 else 's'})" in out
        return
    assert status == 1 and out == ""
    assert len(err) == SEVERAL.get(stem, 1), err
    assert all(line.startswith(f"error: {path}: ") for line in err), err
    assert any(SCENARIOS[stem] in line for line in err), err


@pytest.mark.parametrize("stem", sorted(SCENARIOS))
def test_run_fails_in_one_line_and_writes_nothing(capsys, tmp_path, stem):
    path = CORPUS / "scenarios" / f"{stem}.toml"
    out_dir = tmp_path / "out"
    status, out, err = _call(capsys, "run", path, "--out", out_dir)
    assert status == 1 and out == ""
    assert len(err) == 1 and err[0].startswith(f"error: {path}: ") and SCENARIOS[stem] in err[0]
    assert err[0].count(f"{path}:") == 1  # the file is named once, problems joined by '; '
    assert not out_dir.exists() or not list(out_dir.iterdir())


@pytest.mark.parametrize("name", sorted(DATA))
def test_identify_fails_in_one_line_and_writes_no_model(capsys, tmp_path, name):
    data = CORPUS / "data" / name
    model = tmp_path / "models" / "m.toml"
    status, out, err = _call(capsys, "identify", data, *IDENTIFY_COLUMNS, "--out", model)
    assert status == 1 and out == ""
    assert len(err) == 1 and err[0].startswith(f"error: {data}: ") and DATA[name] in err[0], err
    assert not model.parent.exists() or not list(model.parent.iterdir())


@pytest.mark.parametrize("name", ["good.csv", "utf16.csv"])
def test_identify_accepts_good_records(capsys, tmp_path, name):
    model = tmp_path / "m.toml"
    status, out, err = _call(capsys, "identify", CORPUS / "data" / name, *IDENTIFY_COLUMNS,
                             "--out", model)
    assert (status, err) == (0, []) and model.is_file() and [p.name for p in tmp_path.iterdir()] == ["m.toml"]


@pytest.mark.parametrize("argv, message", [
    (["run"], "hammerstein run: error: the following arguments are required: SCENARIO"),
    (["frobnicate"], "hammerstein: error: argument COMMAND: invalid choice: 'frobnicate'"),
    (["run", GOOD / "good-static.toml", "--out", GOOD / "good-static.toml"],
     "hammerstein run: error: --out:"),
    (["identify", CORPUS / "data" / "good.csv", "--input", "u_V", "--output", "y_um", "--out", "m.toml"],
     "hammerstein identify: error: give --time COL or --sampling-period S"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--skip", "nan", "--out", "m.toml"],
     "hammerstein identify: error: argument --skip: expected a number >= 0 [s], found 'nan' "
     "(not finite)"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--sampling-period", "-1",
      "--out", "m.toml"],
     "hammerstein identify: error: argument --sampling-period: expected a number in "
     "(0, 1e+06] [s], found '-1'"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--out", CORPUS / "data"],
     "hammerstein identify: error: --out:"),
    (["identify", CORPUS / "data" / "good.csv", "--time", "0", "--input", "1"],
     "hammerstein identify: error: the following arguments are required: --output/--outputs, --out"),
    (["check", GOOD / "good-static.toml"],
     "hammerstein check: error: the following arguments are required: --baseline"),
    (["validate", GOOD / "good-static.toml", "--bogus"], "hammerstein validate: error: unrecognized arguments: --bogus"),
    # issue 13: every path or option problem is a usage error of its command
    (["run", GOOD / "good-static.toml", "--out", ""], "hammerstein run: error: --out: empty path"),
    (["run", GOOD / "good-static.toml", "--out", GOOD / "good-static.toml" / "sub"],
     f"hammerstein run: error: --out: {GOOD / 'good-static.toml'} is not a directory"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS[:-1], "1,,2", "--out", "m.toml"],
     "hammerstein identify: error: --thresholds: expected numbers separated by commas, found an "
     "empty entry in '1,,2'"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--out", "/dev/null"],
     "hammerstein identify: error: --out: /dev/null is not a regular file"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--out", ""],
     "hammerstein identify: error: --out: empty path"),
    (["identify", CORPUS / "data" / "good.csv", *IDENTIFY_COLUMNS, "--out",
      GOOD / "good-static.toml" / "m.toml"], "hammerstein identify: error: --out: "),
    (["check", GOOD / "good-static.toml", "--baseline", CORPUS / "nowhere.csv"],
     "hammerstein check: error: "),
    (["check", GOOD / "good-static.toml", "--baseline", "/dev/zero"],
     "hammerstein check: error: /dev/zero: not a regular file"),
    (["check", GOOD / "good-static.toml", "--baseline", "b.csv", "--update", "--out",
      GOOD / "good-static.toml" / "x"], "hammerstein check: error: --out: "),
    (["replicate", "--scenarios", CORPUS / "nowhere"], "hammerstein replicate: error: "),
    (["replicate", "--out", ""], "hammerstein replicate: error: --out: empty path"),
])
def test_usage_errors_are_one_line_exit_2(capsys, argv, message):
    status, out, err = _call(capsys, *argv)
    assert status == 2 and out == "" and len(err) == 1 and err[0].startswith(message), err


def test_mixed_list_good_bad_good(capsys, tmp_path):
    bad = CORPUS / "scenarios" / "model-unsorted-thresholds.toml"
    status, out, err = _call(capsys, "run", GOOD / "good-static.toml", bad,
                             GOOD / "good-static-2.toml", "--out", tmp_path)
    assert status == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["good-static", "good-static-2"]
    assert len(err) == 1 and err[0].startswith(f"error: {bad}: ")
    assert len(out.splitlines()) == 2


def test_same_scenario_and_seed_give_identical_metrics(capsys, tmp_path):
    for d in ("a", "b"):
        assert _call(capsys, "run", GOOD / "good-static.toml", GOOD / "good-identification.toml",
                     "--out", tmp_path / d, "--figures", "none")[0] == 0  # metrics only
    for name in ("good-static", "good-identification"):
        a = (tmp_path / "a" / name / "metrics.csv").read_bytes()
        assert a == (tmp_path / "b" / name / "metrics.csv").read_bytes() and a.count(b"\n") > 3


def test_reference_beyond_identified_range_is_one_warning_line(capsys, tmp_path):
    path = GOOD / "warn-out-of-range.toml"
    status, out, err = _call(capsys, "run", path, "--out", tmp_path)
    # independent expectation: peak of Gamma_xx at 10 V = sum w_i (10 - r_i), 58.4 µm (Fig. 5)
    model = load_plant("rakotondrabe-2dof", dynamics=False).hysteresis
    pi = model.components[0][0]
    peak = float(np.sum(pi.weights * np.clip(10.0 - pi.thresholds, 0, None)))
    assert peak == pytest.approx(58.4, abs=0.05)
    expected = f"x: 70 µm > {peak:.4g} µm"
    assert status == 0 and len(err) == 1
    assert err[0].startswith(f"warning: {path}: beyond-range: reference: beyond the range") and expected in err[0]
    table = pd.read_csv(tmp_path / "warn-out-of-range" / "warnings.csv")
    assert list(table.columns) == ["case", "message"] and list(table.case) == ["beyond-range"]
    assert expected in (tmp_path / "warn-out-of-range" / "report.md").read_text(encoding="utf-8")


def test_divergence_stops_the_case_and_is_reported(capsys, tmp_path):
    path = GOOD / "warn-literal-law.toml"
    status, out, err = _call(capsys, "run", path, "--out", tmp_path)
    d = tmp_path / "warn-literal-law"
    assert status == 0 and len(err) == 2  # the convergence warning, then the divergence
    assert "rho(I - K^-1 J) reaches 8.96 >= 1" in err[0]
    assert err[1].startswith(f"warning: {path}: the compensator diverged in 1 case(s): literal")
    m = pd.read_csv(d / "metrics.csv")
    assert list(m.metric) == ["diverged_at_time"]
    ts = pd.read_csv(d / "timeseries-literal.csv")
    sample = int(np.flatnonzero(ts["ux_V"].isna().to_numpy())[0])  # stopped from here on
    assert ts["ux_V"].iloc[sample:].isna().all() and np.isfinite(ts["ux_V"].iloc[:sample]).all()
    assert m.value.iloc[0] == pytest.approx(sample * 5e-5, rel=1e-12)
    report = (d / "report.md").read_text(encoding="utf-8")
    assert f"DIVERGED at sample {sample} (t = {sample * 5e-2:.3g} ms): |U| =" in report
    assert "exceeds the bound" in report


def test_check_fails_one_line_per_bad_scenario(capsys, tmp_path):
    baseline = tmp_path / "baseline.csv"
    good = GOOD / "good-static-2.toml"
    assert _call(capsys, "check", good, "--baseline", baseline, "--update")[0] == 0
    n = len(pd.read_csv(baseline, comment="#"))
    status, out, err = _call(capsys, "check", good, "--baseline", baseline)
    assert status == 0 and err == []
    bad = [CORPUS / "scenarios" / f"{s}.toml" for s in ("model-nan-weights", "invalid-toml",
                                                          "identification-garbage")]
    status, out, err = _call(capsys, "check", good, *bad, "--baseline", baseline)
    assert status == 1 and len(err) == 3
    for line, path in zip(err, bad):
        assert line.startswith(f"error: scenario failed: {path}: ")
    assert f"{n} ok, 0 regressed" in out and "3 scenario(s) failed -> FAIL" in out


def test_stray_python_warning_and_unexpected_error_are_one_line(capsys, monkeypatch):
    def noisy(args):
        warnings.warn("first line\n  second line", RuntimeWarning)
        return 0
    monkeypatch.setattr(listing, "handler", noisy)
    status, out, err = _call(capsys, "list")
    assert status == 0 and err == ["warning: hammerstein list: first line second line"]

    def broken(args):
        raise TypeError("bug\nwith two lines")
    monkeypatch.setattr(listing, "handler", broken)
    monkeypatch.delenv("HAMMERSTEIN_DEBUG", raising=False)
    status, out, err = _call(capsys, "list")
    assert status == 1 and len(err) == 1
    assert err[0].startswith("hammerstein list: error: unexpected TypeError: bug; with two lines")


def test_real_stderr_through_python_m(forked_cli):
    """The console entry (python -m hammerstein): the real stderr, no traceback (its
    process: tests/cli/conftest.py, with Python's default warning filter)."""
    results, tmp = forked_cli
    run = results["real-stderr"]
    bad = CORPUS / "scenarios" / "unknown-reference-key.toml"
    warn = GOOD / "warn-out-of-range.toml"
    lines = run["stderr"].splitlines()
    assert run["status"] == 1 and "Traceback" not in run["stderr"], run["stderr"]
    assert len(lines) == 2
    assert lines[0] == (f"error: {bad}: cases[0].reference.amplitud: unknown key (did you mean "
                        f"'amplitude'?); cases[0].reference.amplitude: missing (required)")
    assert lines[1].startswith(f"warning: {warn}: beyond-range: reference: beyond the range")
    assert sorted(p.name for p in (tmp / "real-stderr").iterdir()) == ["good-static-2",
                                                                      "warn-out-of-range"]


# -- numerical guards (issue 6, item 2) through the Python API ---------------------------
@pytest.mark.parametrize("thresholds, weights, message", [
    ([0.0, 1.0, 2.0], [1.0, 2.0], "weights: expected 3 weights to match the thresholds, found 2"),
    ([0.0, 2.0, 1.0], [1.0, 1.0, 1.0], "thresholds: expected strictly increasing thresholds, found r[1]=2 followed by r[2]=1"),
    ([0.0, 1.0, 1.0], [1.0, 1.0, 1.0], "thresholds: expected strictly increasing thresholds, found r[1]=1 followed by r[2]=1"),
    ([-0.5, 1.0], [1.0, 1.0], "thresholds: expected non-negative thresholds, found -0.5"),
    ([0.0, np.inf], [1.0, 1.0], "thresholds: expected finite values"),
    ([0.0, 1.0], [1.0, np.nan], "weights: expected finite values"),
    ([], [], "thresholds: expected at least one threshold"),
])
def test_model_parameter_guards(thresholds, weights, message):
    with pytest.raises(HysteresisError) as err:
        PrandtlIshlinskii(thresholds, weights)
    assert message in str(err.value)


@pytest.fixture
def plant(static_plant):
    return static_plant


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_signals_are_refused(plant, bad):
    u = np.zeros((2, 10))
    u[1, 4] = bad
    with pytest.raises(HysteresisError, match="inputs: expected finite values"):
        plant.simulate(u)
    with pytest.raises(HysteresisError, match="reference: expected finite values"):
        InverseMultiplicativeCompensator(plant.hysteresis).simulate(u)
    with pytest.raises(HysteresisError, match="reference: expected finite values"):
        PerAxisInverseCompensator(plant.hysteresis).simulate(u)


def test_kuhnen_inverse_refuses_non_increasing_cumulative_weights():
    # S_1 = 1, S_2 = 1 - 2 = -1 <= 0: the direct transfer x/ux has a falling branch
    model = MultivariablePI([[PrandtlIshlinskii([0.0, 3.0, 6.0], [1.0, -2.0, 0.5])]], ["u"], ["y"], [10.0])
    with pytest.raises(CompensatorError, match=r"Gamma_yu: weights: the cumulative weight sum S_2 = -1 µm/V is <= 0"):
        PerAxisInverseCompensator(model)


@pytest.mark.parametrize("frequency, message", [
    (10_000.0, "at or above the Nyquist frequency 10000 Hz"),   # f = 1/(2T)
    (12_000.0, "at or above the Nyquist frequency 10000 Hz"),
    (20_000.0 / 7, "gives 7 samples per period; expected at least 8 (f <= 2500 Hz)"),
])
def test_signals_beyond_nyquist_or_undersampled(frequency, message):
    with pytest.raises(refs.SignalError, match=message.replace("(", r"\(").replace(")", r"\)")):
        refs.sine(5e-5, ["x", "y"], "x", 1.0, frequency, periods=2)
    refs.sine(5e-5, ["x", "y"], "x", 1.0, 2500.0, periods=2)  # exactly 8 samples per period: accepted


@pytest.mark.parametrize("T", [0.0, -5e-5, np.nan])
def test_bad_sampling_period_of_a_signal(T):
    with pytest.raises(refs.SignalError, match="sampling_period: expected a positive number"):
        refs.sine(T, ["x", "y"], "x", 1.0, 50.0, periods=2)


def test_range_warning_ratio(plant):
    ref = np.zeros((2, 3))
    ref[0, 1] = 70.0
    with pytest.warns(RangeWarning, match="beyond the range the model was identified on"):
        ratio = check_reference_range(plant.hysteresis, ref)
    peaks = np.array([np.sum(pi.weights * np.clip(10.0 - pi.thresholds, 0, None))
                      for pi in (plant.hysteresis.components[0][0], plant.hysteresis.components[1][1])])
    np.testing.assert_allclose(peaks, [58.4, 50.57], atol=0.01)  # Fig. 5 loops
    np.testing.assert_allclose(ratio, [70.0 / peaks[0], 0.0], rtol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_reference_range(plant.hysteresis, 0.99 * np.diag(peaks))  # inside: no warning


def test_two_scenarios_with_one_name_do_not_overwrite_each_other(tmp_path, capsys):
    """The second scenario of a run that reuses a name fails (exit 1) instead of
    silently replacing the first one's report directory."""
    text = (CORPUS / "good" / "good-static.toml").read_text(encoding="utf-8")
    first, second = tmp_path / "a.toml", tmp_path / "b.toml"
    first.write_text(text, encoding="utf-8")
    second.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(first), str(second), "--out", str(out), "--figures", "none"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is also the name of" in err[0] and str(second) in err[0]
    assert len([p for p in out.iterdir() if not p.name.startswith(".")]) == 1


def test_identify_refuses_one_column_as_input_and_output(tmp_path, capsys):
    data = tmp_path / "rec.csv"
    t = np.arange(400) * 1e-3
    u = 5 * np.sin(2 * np.pi * 5 * t)
    np.savetxt(data, np.column_stack([t, u, 2 * u]), delimiter=",", header="t,u,y", comments="")
    status = main(["identify", str(data), "--input", "u", "--output", "u", "--time", "t",
                   "--out", str(tmp_path / "m.toml")])
    assert status == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "same column" in err[0]
    assert not (tmp_path / "m.toml").exists()


def test_check_that_cannot_write_its_baseline_says_so_with_the_command(capsys, tmp_path,
                                                                       monkeypatch):
    """A full disk under `check --update` (a file-size limit, measured by an outside user)
    gave a bare "error: ..." where docs/cli.md gives a command's failure as
    "hammerstein check: error: ..."; the baseline it had stays as it was."""
    from hammerstein.core import files
    from hammerstein.scenario import regression
    baseline = tmp_path / "baseline.csv"
    good = GOOD / "good-static-2.toml"
    assert _call(capsys, "check", good, "--baseline", baseline, "--update")[0] == 0
    before = baseline.read_bytes()
    real = files.safe_write

    def full(path, data, what="file", root=None):
        if str(what) == "baseline CSV file":
            raise files.OutputError(f"{path}: cannot write the {what} (File too large); "
                                    f"nothing was written")
        return real(path, data, what, root)
    monkeypatch.setattr(regression, "safe_write", full)
    status, out, err = _call(capsys, "check", good, "--baseline", baseline, "--update",
                             "--force")
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith(f"hammerstein check: error: {baseline}: cannot write the baseline")
    assert baseline.read_bytes() == before
