"""Budgets before work, one number checker, CSV messages (issue 39: N3-N9, N12-N17).

Every oversized request is refused before anything is allocated, with one
line naming the limit and its override; every malformed CSV is one line
naming its file and what it is; no stderr line is longer than 2000
characters. The commands run in this process (``main``), so the time to
refuse is the command's own, without the interpreter's start.
"""

import argparse
import io
import os
import time
from pathlib import Path

import numpy as np
import pytest

from hammerstein.cli._common import (MAX_LINE, SafeStream, integer_type, number_type,
                                     scheduler_type, workers_type)
from hammerstein.cli.main import main
from hammerstein.io.datafiles import Record
from hammerstein.compensation.drive import read_signals
from hammerstein.signals.excitation import excitation_set, multisine, staircase
from hammerstein.models.hysteresis import PrandtlIshlinskii
from hammerstein.core.numbers import (RECORD_SAMPLES_ENV, check_samples, max_record_samples,
                                      plausibility_problem)
from hammerstein.identification.record_identification import identify_records
from hammerstein.exceptions import HysteresisError, IdentificationError, SignalError

PRESET = "rakotondrabe-2dof"
T = 5e-5


def _run(argv, capsys):
    """``hammerstein ARGV`` in this process: (status, stdout, stderr lines, seconds)."""
    start = time.perf_counter()
    status = main(argv)
    took = time.perf_counter() - start
    out, err = capsys.readouterr()
    return status, out, err.splitlines(), took


def _one_clean_line(err):
    assert len(err) == 1, err
    assert len(err[0]) <= MAX_LINE
    assert "unexpected" not in err[0] and "Traceback" not in err[0], err[0]
    return err[0]


def _signals(n=400, step=T):
    t = np.arange(n) * step
    return t, 20 * np.sin(2 * np.pi * 50 * t), 10 * np.cos(2 * np.pi * 50 * t) - 10


def _csv(path, t, x, y, header="t,x,y", sep=","):
    rows = [header] + [f"{float(a)!r}{sep}{float(b)!r}{sep}{float(c)!r}" for a, b, c in zip(t, x, y)]
    Path(path).write_text("\n".join(rows) + "\n")
    return path


# -- N3: sizes computed from the arguments, refused before allocating ------------------------
EXCITATION = ["excitation", "--inputs", "ux,uy", "--amplitude", "5", "--out", "exc"]


@pytest.mark.parametrize("extra, words", [
    (["--sampling-period", "5e-5", "--hold", "1e9"], RECORD_SAMPLES_ENV),
    (["--sampling-period", "5e-5", "--periods", "1000000000"], RECORD_SAMPLES_ENV),
    (["--sampling-period", "5e-5", "--f-min", "1e-9"], RECORD_SAMPLES_ENV),
    (["--sampling-period", "1e-9"], RECORD_SAMPLES_ENV),
    (["--sampling-period", "5e-5", "--hold", "1e300"], "--hold"),
    (["--sampling-period", "5e-5", "--f-min", "1e9"], "--f-min"),          # was ZeroDivisionError
    (["--sampling-period", "5e-324"], "subnormal"),                         # was OverflowError
    (["--sampling-period", "nan"], "--sampling-period"),
    (["--sampling-period", "5e-5", "--hold", "inf"], "--hold"),
    (["--sampling-period", "5e-5", "--periods", "1.5"], "--periods"),
])
def test_excitation_refuses_oversized_or_absurd_requests_at_once(extra, words, tmp_path,
                                                                 monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, out, err, took = _run(EXCITATION + extra, capsys)
    line = _one_clean_line(err)
    assert status == 2 and words in line, line
    assert took < 1.0, f"{took:.2f} s to refuse"
    assert not (tmp_path / "exc").exists() and out == ""


def test_excitation_amplitude_beyond_any_signal_is_refused(tmp_path, monkeypatch, capsys):
    # N7: --amplitude 1e300 wrote files that identify then refused
    monkeypatch.chdir(tmp_path)
    status, _, err, _ = _run(["excitation", "--inputs", "ux", "--amplitude", "1e300",
                              "--sampling-period", "5e-5", "--out", "exc"], capsys)
    assert status == 2 and "--amplitude" in _one_clean_line(err)
    assert not (tmp_path / "exc").exists()


def test_the_record_budget_is_raised_by_its_variable(monkeypatch):
    with pytest.raises(ValueError, match=RECORD_SAMPLES_ENV):
        staircase(5e-5, 1.0, hold=100.0)          # 9 x 2e6 samples
    monkeypatch.setenv(RECORD_SAMPLES_ENV, "20000000")
    assert max_record_samples() == 20_000_000
    t, u, _ = staircase(5e-5, 1.0, hold=100.0)
    assert u.size == 9 * 2_000_000


@pytest.mark.parametrize("kwargs, name", [
    ({"hold": 1e9}, "hold"), ({"multisine_periods": 10**9}, "periods"),
    ({"f_min": 1e-9}, "f_min"), ({"sampling_period": 1e-9}, "frequency"),
    ({"f_min": 1e9}, "f_min"), ({"hold": float("nan")}, "hold"),
    ({"multisine_periods": True}, "periods"), ({"amplitude": 1e300}, "amplitude"),
])
def test_excitation_api_checks_the_same_budget(kwargs, name):
    args = {"input_names": ["ux"], "amplitude": 5.0, "sampling_period": 5e-5, **kwargs}
    start = time.perf_counter()
    with pytest.raises(ValueError, match=name):
        excitation_set(**args)
    assert time.perf_counter() - start < 1.0


def test_check_samples_names_the_limit_the_size_and_the_override():
    with pytest.raises(SignalError) as info:
        check_samples(1.8e14, "--hold", SignalError, 5e-5, rows=2)
    msg = str(info.value)
    assert "1.8e+14 samples" in msg and "2.88 PB" in msg and "1e+07" in msg
    assert "500 s at T = 5e-05 s" in msg and RECORD_SAMPLES_ENV in msg
    with pytest.raises(ValueError):
        check_samples(float("nan"), "x")
    assert check_samples(10.0, "x") == 10


def test_the_multisine_is_the_sum_of_its_lines():
    """The inverse-FFT multisine equals the sum of cosines it replaces (no O(lines x N) loop)."""
    t, u, f = multisine(5e-5, 8.0, f_min=10.0, periods=2, seed=3)
    n = 2000
    phases = np.random.default_rng(3).uniform(0.0, 2 * np.pi, f.size)
    k = np.arange(n)
    one = sum(np.cos(2 * np.pi * fj * k * 5e-5 + ph) for fj, ph in zip(f, phases))
    one *= 8.0 / np.max(np.abs(one))
    np.testing.assert_allclose(u, np.tile(one, 2), atol=1e-9)
    start = time.perf_counter()
    multisine(5e-5, 8.0, f_min=0.01, periods=1)            # 2e6 samples, 5e5 lines
    assert time.perf_counter() - start < 5.0


# -- N5: the API's hysteron bound is the CLI's -----------------------------------------------
def _record():
    t = np.arange(4000) * 1e-3
    u = 5 * np.sin(2 * np.pi * t) * np.linspace(1.0, 0.2, t.size)
    return Record(t, u, 2 * u, "u", "y", 1e-3, "r.csv")


@pytest.mark.parametrize("n", [10**9, 101, 0, float("nan"), True, 2.0, "15"])
def test_identify_records_refuses_hysteron_counts_outside_1_to_100(n):
    start = time.perf_counter()
    with pytest.raises(IdentificationError, match="n_hysterons: expected an integer"):
        identify_records([_record()], n_hysterons=n)
    assert time.perf_counter() - start < 1.0


# -- N15: records and operators refuse empty, complex and huge inputs --------------------------
@pytest.mark.parametrize("n", [0, 1, 9])
def test_an_empty_or_tiny_record_is_a_clear_error(n):
    # an empty Record raised numpy's "zero-size array to reduction operation" ValueError
    t = np.arange(n) * 1e-3
    with pytest.raises(IdentificationError, match=f"{n} samples; expected a record of at least 10"):
        identify_records([Record(t, np.sin(t), np.sin(t), "u", "y", 1e-3)])


@pytest.mark.parametrize("thresholds, weights, words", [
    ([0.0, 1 + 1j], [1.0, 1.0], "thresholds: expected real numbers"),
    ([0.0, 1e300], [1.0, 1.0], r"thresholds: 1e\+300 is beyond"),
    ([0.0, 1.0], [1e300, 1.0], r"weights: 1e\+300 is beyond"),
])
def test_the_pi_operator_refuses_complex_and_huge_parameters(thresholds, weights, words):
    with pytest.raises(HysteresisError, match=words):
        PrandtlIshlinskii(np.array(thresholds), np.array(weights))


@pytest.mark.parametrize("u, words", [([1 + 1j, 2.0], "complex"), ([1e300, 0.0], "beyond")])
def test_the_pi_operator_refuses_complex_and_huge_inputs(u, words):
    op = PrandtlIshlinskii(np.array([0.0, 1.0]), np.array([1.0, 0.5]))
    with pytest.raises(HysteresisError, match=words):
        op.simulate(np.array(u))


# -- the CLI's one number checker --------------------------------------------------------------
@pytest.mark.parametrize("text, problem", [
    ("5e-324", "subnormal"), ("nan", "not finite"), ("inf", "not finite"), ("1e999", "not finite"),
    ("True", "found 'True'"), ("1+2j", "found '1+2j'"), ("0", "found '0'"), ("-1", "found '-1'"),
])
def test_number_type_refuses(text, problem):
    with pytest.raises(argparse.ArgumentTypeError, match=problem.replace("+", r"\+")):
        number_type(0, low_open=True, unit="s")(text)


def test_number_type_accepts_a_normal_positive_number():
    assert number_type(0, low_open=True)("5e-5") == 5e-5
    assert number_type(0, 1)("1") == 1.0
    with pytest.raises(argparse.ArgumentTypeError, match=r"in \[0, 1\]"):
        number_type(0, 1)("1.5")


@pytest.mark.parametrize("text", ["1.5", "1e3", "", "x", "-0x1", "9" * 40])
def test_integer_type_refuses_what_is_not_an_integer(text):
    with pytest.raises(argparse.ArgumentTypeError):
        integer_type(1)(text)


# -- N4, N14: workers and schedulers ------------------------------------------------------------
def test_workers_are_capped_by_the_machine(monkeypatch):
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert workers_type(str(cores)) == cores
    with pytest.raises(argparse.ArgumentTypeError, match="HAMMERSTEIN_MAX_WORKERS"):
        workers_type(str(cores + 1))
    monkeypatch.setenv("HAMMERSTEIN_MAX_WORKERS", str(cores + 1))
    assert workers_type(str(cores + 1)) == cores + 1


@pytest.mark.parametrize("address, words", [
    ("tls://127.0.0.1:1", "TLS certificates"), ("inproc://x", "another process"),
    ("127.0.0.1:99999", "port 1..65535"), ("tcp://127.0.0.1:0", "port 1..65535"),
    ("udp://h:1", "not a transport"), ("tcp://:8786", "HOST:PORT"), ("h", "HOST:PORT"),
    ("tcp://a b:1", "HOST:PORT"),
])
def test_scheduler_addresses_are_parsed_before_connecting(address, words):
    with pytest.raises(argparse.ArgumentTypeError, match=words):
        scheduler_type(address)


def test_a_valid_scheduler_address_is_normalised():
    assert scheduler_type("127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    assert scheduler_type("TCP://[::1]:8786") == "tcp://[::1]:8786"


@pytest.mark.parametrize("extra, status", [
    (["--workers", "100000"], 2), (["--scheduler", "tls://127.0.0.1:1"], 2),
    (["--scheduler", "inproc://x"], 2), (["--scheduler", "127.0.0.1:99999"], 2),
    (["--scheduler", "tcp://127.0.0.1:1"], 1),          # nothing listens: refused at once
])
def test_run_refuses_workers_and_schedulers_at_once(extra, status, tmp_path, capsys):
    scenario = Path(__file__).parents[1] / "corpus" / "good" / "good-static.toml"
    code, _, err, took = _run(["run", str(scenario), "--out", str(tmp_path / "r"),
                               "--figures", "none", *extra], capsys)
    _one_clean_line(err)
    assert code == status and took < 5.0, (err, took)
    assert not (tmp_path / "r" / "good-static").exists()


# -- N12, N13, N16, N17: one line naming the file and what it is --------------------------------
def _bad_files(d):
    t, x, y = _signals()
    good = _csv(d / "good.csv", t, x, y).read_text()
    lines = good.splitlines()
    files = {
        "empty": ("", "the file is empty"),
        "header-only": ("t,x,y\n", "no data rows"),
        "one-row": ("t,x,y\n0,0,0\n", "1 data row"),
        "booleans": ("\n".join(lines[:5] + [lines[5].rsplit(",", 1)[0] + ",True"] + lines[6:]),
                     "a boolean 'True'"),
        "long-cell": ("\n".join(lines[:5] + [lines[5].rsplit(",", 1)[0] + "," + "z" * 140_000]
                                + lines[6:]),
                      "more characters"),
        "more-fields": ("\n".join(lines[:10] + [lines[10] + ",7"] + lines[11:]), "ragged rows"),
        "fewer-fields": ("\n".join(lines[:10] + [lines[10].rsplit(",", 1)[0]] + lines[11:]),
                         "ragged rows"),
        "time-x1e9": (None, RECORD_SAMPLES_ENV),
        "time-5e-14": (None, "less than one sampling period"),
    }
    out = {}
    for name, (text, words) in files.items():
        path = d / f"{name}.csv"
        if name == "time-x1e9":
            _csv(path, t * 1e9, x, y)
        elif name == "time-5e-14":
            _csv(path, np.arange(t.size) * 5e-14, x, y)
        else:
            path.write_text(text)
        out[name] = (path, words)
    p = d / "utf16.csv"
    p.write_bytes(good.encode("utf-16-le"))
    out["utf16"] = (p, "UTF-16 text without a byte-order mark")
    p = d / "binary.csv"
    p.write_bytes(bytes(range(256)) * 64)
    out["binary"] = (p, "binary content")
    return out


BAD = ["empty", "header-only", "one-row", "booleans", "long-cell", "more-fields", "fewer-fields",
       "time-x1e9", "time-5e-14", "utf16", "binary"]


@pytest.mark.parametrize("name", BAD)
def test_compensate_names_each_malformed_reference(name, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    path, words = _bad_files(tmp_path)[name]
    status, _, err, took = _run(["compensate", PRESET, "--reference", path.name,
                                 "--out", "drive.csv"], capsys)
    line = _one_clean_line(err)
    assert status == 1 and path.name in line and words in line, line
    assert took < 3.0 and not (tmp_path / "drive.csv").exists()


@pytest.mark.parametrize("name", ["booleans", "long-cell", "utf16", "binary", "more-fields",
                                  "empty"])
def test_identify_names_each_malformed_record(name, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    path, _ = _bad_files(tmp_path)[name]
    status, _, err, _ = _run(["identify", path.name, "--inputs", "x", "--outputs", "y",
                              "--time", "t", "--out", "m.toml"], capsys)
    line = _one_clean_line(err)
    assert status == 1 and path.name in line, line
    assert not (tmp_path / "m.toml").exists()


def test_cr_only_line_endings_read_as_lines(tmp_path):
    t, x, y = _signals()
    lf = _csv(tmp_path / "lf.csv", t, x, y)
    cr = tmp_path / "cr.csv"
    cr.write_bytes(lf.read_bytes().replace(b"\n", b"\r"))
    a, b = read_signals(lf, ["x", "y"]), read_signals(cr, ["x", "y"])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2] == b[2]


def test_a_finer_reference_resampled_coarser_is_said(tmp_path):
    t, x, y = _signals(4000, T / 10)
    path = _csv(tmp_path / "fine.csv", t, x, y)
    with pytest.warns(UserWarning, match=r"sampled every 5e-06 s, resampled \(interpolated "
                                         r"linearly\) onto the sampling period 5e-05 s"):
        grid, values, _ = read_signals(path, ["x", "y"], sampling_period=T)
    assert values.shape == (2, 400)


def test_stderr_lines_are_cut_at_max_line():
    buf = io.StringIO()
    stream = SafeStream(buf, 50)
    print("a" * 500, file=stream)
    print("b" * 10, "c" * 100, file=stream)
    stream.write("d" * 30)
    stream.write("e" * 30 + "\nshort\n")
    lines = buf.getvalue().splitlines()
    assert [len(ln) for ln in lines] == [50, 50, 50, 5]
    assert lines[0].endswith("(cut)") and lines[3] == "short"


# -- N8, N9: compensate says or refuses, never clamps silently; learn's T -----------------------
def test_compensate_refuses_a_fade_in_longer_than_the_reference(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    t, x, y = _signals()
    _csv(tmp_path / "ref.csv", t, x, y)
    status, _, err, _ = _run(["compensate", PRESET, "--reference", "ref.csv", "--out", "d.csv",
                              "--fade-in", "1e9"], capsys)
    line = _one_clean_line(err)
    assert status == 1 and "--fade-in" in line and "longer than the reference" in line
    assert not (tmp_path / "d.csv").exists()


@pytest.mark.parametrize("period, words", [("1e-300", RECORD_SAMPLES_ENV),
                                           ("5e-324", "subnormal")])
def test_a_tiny_sampling_period_is_not_file_not_found(period, words, tmp_path, monkeypatch,
                                                      capsys):
    monkeypatch.chdir(tmp_path)
    t, x, y = _signals()
    _csv(tmp_path / "ref.csv", t, x, y)
    status, _, err, _ = _run(["compensate", PRESET, "--reference", "ref.csv", "--out", "d.csv",
                              "--sampling-period", period], capsys)
    line = _one_clean_line(err)
    assert status in (1, 2) and words in line and "not found" not in line, line


def test_evaluate_refuses_a_reference_whose_metrics_would_be_infinite(tmp_path, monkeypatch,
                                                                      capsys):
    # N6: rms_error=inf was written, with two RuntimeWarning lines
    monkeypatch.chdir(tmp_path)
    t, x, y = _signals()
    _csv(tmp_path / "meas.csv", t, x, y)
    status, _, err, _ = _run(["evaluate", "--reference", '{ kind = "circle", radius = 1e300, '
                              'frequency = 100, periods = 2 }', "--measured", "meas.csv",
                              "--out", "ev", "--sampling-period", str(T)], capsys)
    line = _one_clean_line(err)
    assert status == 1 and "beyond the limit" in line and "RuntimeWarning" not in line
    assert not (tmp_path / "ev").exists() or not any((tmp_path / "ev").iterdir())


def test_the_staircase_budget_counts_every_step():
    """The size in the message is that of the arguments: 9 steps of hold / T samples."""
    with pytest.raises(ValueError) as info:
        staircase(5e-5, 1.0, hold=1e9)
    assert "1.8e+14 samples" in str(info.value)


# -- plausibility: valid values no actuator has are said, naming the likely unit slip ------------
@pytest.mark.parametrize("value, unit, slip", [
    (1e38, "µm", "nm"), (3e-5, "µm", "m or mm"), (10_000.0, "V", "mV"), (6.3e5, "Hz", "rad/s"),
    (30.0, "µm", None), (150.0, "V", None), (100.0, "Hz", None), (0.0, "µm", None),
])
def test_plausibility_names_the_likely_unit_slip(value, unit, slip):
    problem = plausibility_problem(value, unit, "peak")
    if slip is None:
        assert problem is None
    else:
        assert problem.startswith(f"peak {value:g} {unit}") and f"given in {slip}" in problem


@pytest.mark.parametrize("table, words", [
    ('reference = { kind = "sine", output = "x", amplitude = 1e38, frequency = 50.0, '
     'periods = 2 }', "reference peak 1e+38 µm"),
    ('drive = { kind = "sine", input = "ux", amplitude = 10000, frequency = 50.0, periods = 2 }',
     "drive peak 10000 V"),
])
def test_validate_does_not_pass_absurd_amplitudes_silently(table, words, tmp_path, capsys):
    path = tmp_path / "absurd.toml"
    compensator = '[compensator]\nkind = "multivariable"\n' if "reference" in table else ""
    path.write_text(f'name = "absurd"\n[plant]\npreset = "{PRESET}"\ndynamics = false\n'
                    f'{compensator}[[cases]]\nname = "c"\n{table}\n')
    status, out, err, _ = _run(["validate", str(path)], capsys)
    assert status == 0 and "ok (1 case)" in out
    assert len(err) == 1 and err[0].startswith(f"warning: {path}: c: ") and words in err[0], err


def test_excitation_warns_of_an_amplitude_no_amplifier_gives(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, _, err, _ = _run(["excitation", "--inputs", "ux", "--amplitude", "5000",
                              "--sampling-period", "5e-4", "--hold", "0.1", "--out", "exc"],
                             capsys)
    assert status == 0 and len(err) == 1 and "given in mV" in err[0], err


@pytest.mark.parametrize("argv, words", [
    (["export", PRESET, "--target", "c", "--out", "c", "--sampling-period", "5e-324"], "subnormal"),
    (["export", PRESET, "--target", "c", "--out", "c", "--cutoff-hz", "nan"], "not finite"),
    (["export", PRESET, "--target", "c", "--out", "c", "--amplifier-range", "-1e300", "1e300"],
     "--amplifier-range"),
    (["identify", "r.csv", "--inputs", "x", "--outputs", "y", "--sampling-period", "5e-324",
      "--out", "m.toml"], "subnormal"),
    (["identify", "r.csv", "--inputs", "x", "--outputs", "y", "--time", "t", "--skip", "inf",
      "--out", "m.toml"], "--skip"),
    (["check", "s.toml", "--baseline", "b.csv", "--rtol", "nan"], "--rtol"),
])
def test_every_command_checks_its_numbers_before_work(argv, words, tmp_path, monkeypatch,
                                                      capsys):
    monkeypatch.chdir(tmp_path)
    status, _, err, took = _run(argv, capsys)
    line = _one_clean_line(err)
    assert status == 2 and words in line and took < 1.0, line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["compensate", "evaluate"])
@pytest.mark.parametrize("period", ["1e-300", "1e9"])
def test_a_period_outside_the_reference_is_refused(command, period, tmp_path, monkeypatch,
                                                   capsys):
    # a 1e-300 s period was rounded up to one sample, silently
    monkeypatch.chdir(tmp_path)
    t, x, y = _signals()
    _csv(tmp_path / "ref.csv", t, x, y)
    args = (["compensate", PRESET, "--reference", "ref.csv", "--out", "d.csv"]
            if command == "compensate" else
            ["evaluate", "--reference", "ref.csv", "--measured", "ref.csv", "--out", "ev",
             "--sampling-period", str(T)])
    status, _, err, _ = _run(args + ["--period", period], capsys)
    line = _one_clean_line(err)
    assert status == 1 and "--period" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ref.csv"]


@pytest.mark.parametrize("value, words", [("True", "the boolean 'True'"),
                                          ("z" * 150_000, "more characters")])
def test_check_refuses_a_boolean_or_huge_baseline_value(value, words, tmp_path, capsys):
    # a True value was read as 1
    base = tmp_path / "base.csv"
    base.write_text(f"scenario,case,channel,metric,value,unit\ngood-static,c,x,rms_error,"
                    f"{value},µm\n")
    scenario = Path(__file__).parents[1] / "corpus" / "good" / "good-static.toml"
    status, _, err, _ = _run(["check", str(scenario), "--baseline", str(base), "-q"], capsys)
    line = _one_clean_line(err)
    assert status == 2 and "base.csv: value: expected a number" in line and words in line, line
    assert len(line) < 400


# -- the cell bound of every reader: rows x the widest line, counted before parsing ---------
# The signal-table readers (compensate --reference, evaluate --measured, learn, check
# --baseline) had no cell check: 75 M cells took 2.1 GB and 38 s before failing; identify
# counted the first 64 KiB of the first line only: one data row of 10^7 fields took 3.4 GB.
def _wide_row(path, fields):
    path.write_text("t,x,y\n" + ",".join(["1"] * fields) + "\n")
    return path


def _cell_commands(name):
    return {"identify": ["identify", name, "--input", "x", "--output", "y", "--time", "t",
                         "--out", "m.toml"],
            "compensate": ["compensate", PRESET, "--reference", name, "--out", "d.csv"],
            "evaluate": ["evaluate", "--reference", '{ kind = "circle", radius = 1, '
                         'frequency = 100, periods = 2 }', "--measured", name, "--out", "ev",
                         "--sampling-period", str(T)],
            "check": ["check", "s.toml", "--baseline", name]}


@pytest.mark.parametrize("command", ["identify", "compensate", "evaluate", "check"])
def test_a_line_wider_than_the_column_limit_is_refused_at_once(command, tmp_path, monkeypatch,
                                                               capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text("")
    _wide_row(tmp_path / "wide.csv", 300_000)       # 600 kB: 10 s and 0.4 GB in pandas
    status, _, err, took = _run(_cell_commands("wide.csv")[command], capsys)
    line = _one_clean_line(err)
    assert status in (1, 2) and took < 1.0, (line, took)
    assert ("wide.csv: line 2 has 300000 fields, more than the limit of 10000 columns (one per "
            "4000 cells of the limit of 40000000 cells; raise it with "
            "HAMMERSTEIN_MAX_DATA_CELLS=N)") in line, line


@pytest.mark.parametrize("command", ["identify", "compensate", "evaluate", "check"])
def test_cells_are_counted_by_every_reader(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HAMMERSTEIN_MAX_DATA_CELLS", "30000")
    (tmp_path / "s.toml").write_text("")
    t, x, y = _signals(10_000)
    _csv(tmp_path / "tall.csv", t, x, y)
    status, _, err, took = _run(_cell_commands("tall.csv")[command], capsys)
    line = _one_clean_line(err)
    assert status in (1, 2) and took < 1.0, (line, took)
    assert ("tall.csv: 10001 rows x 3 columns = 30003 cells is more than the limit of 30000 "
            "cells (raise it with HAMMERSTEIN_MAX_DATA_CELLS=N)") in line, line


def test_the_widest_line_counts_wherever_it_is(tmp_path):
    from hammerstein.io.datafiles import DataFileError, read_records
    from hammerstein.io.table_checks import wide_line
    t, x, y = _signals(20_000)
    path = _csv(tmp_path / "r.csv", t, x, y)
    with open(path, "a") as f:                          # past the first 64 KiB
        f.write(",".join(["0"] * 2500) + "\n")
    assert wide_line(path.read_bytes(), ",", 3) == (20_002, 2500)
    with pytest.raises(DataFileError, match=r"20002 rows x 2500 columns \(line 20002\) = "
                                            r"50005000 cells is more than the limit"):
        read_records(path, "x", "y", "t")
    assert wide_line(b"a b\n" + b" 1\t 2 \n" * 1000 + b"1 2 3", r"\s+", 2) == (1002, 3)
    assert wide_line(b"a;b\r\n1;2\r\n", ";", 2) is None
