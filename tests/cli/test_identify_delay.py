"""``identify --delay N``: the acquisition's delay kept out of G and handed to ``learn``.

A lab's measured outputs lag the drive by the acquisition's delay in every
record. Expectations derived without the code under test:

* records whose outputs are those of delay-free records shifted by N samples
  (the plant at rest before), identified with ``--delay N``, give exactly the
  model identified from the delay-free records without their last N samples
  (the same numbers reach the fit);
* the model file keeps N, and ``learn --delay auto`` takes it instead of
  estimating one (a wrong value is refused, naming the field);
* a negative delay is a usage error, one longer than the records a data error;
* without ``--delay`` (``auto``, the default with ``--dynamics``) the inserted
  delay is found from the broadband records, and the model is then the one
  ``--delay N`` gives for that N, bit for bit; delay-free records give 0;
* ``--delay auto`` without broadband records is a usage error, and records
  that cannot tell the delay a data error (one line, nothing written); with
  the default the delay stays 0, is not written, and the report says so.
"""

import contextlib
import io

import numpy as np
import pytest

import hammerstein.cli.identify as identify_cli
from hammerstein.cli.main import main
from hammerstein.models.lti import MeasurementDelay
from hammerstein.compensation.drive import read_signals
from hammerstein.io.presets import load_plant, read_toml

# Every test here reads presets identified through the CLI (two identify runs with --dynamics,
# about 3 s of CPU): end-to-end, run by .ci/run with -m slow; the delay estimate itself is
# tested in tests/core/test_measurement_delay.py in the default run.
pytestmark = pytest.mark.slow

D = 4                      # samples


def _write(path, T, u, y, time="time"):
    t = np.arange(u.shape[1]) * T
    with open(path, "w") as fh:
        fh.write(f"{time},ux,uy,x,y\n")
        for row in zip(t, u[0], u[1], y[0], y[1]):
            fh.write(",".join(f"{v:.9g}" for v in row) + "\n")


def _records(directory, delay, drop):
    """Slow sines and multisines through the bundled plant from rest; outputs delayed by
    ``delay`` samples (zeros first: the plant is at rest), the last ``drop`` samples dropped."""
    plant = load_plant("rakotondrabe-2dof")
    T = plant.sampling_period
    rng = np.random.default_rng(5)
    n = int(round(3 / (10.0 * T)))
    t = np.arange(n) * T
    n_period = int(round(0.05 / T))
    f = 20.0 * np.arange(1, 101)
    files = {"slow": [], "broadband": []}
    for k, name in enumerate(["ux", "uy"]):
        phases = rng.uniform(0, 2 * np.pi, f.size)
        s = np.cos(2 * np.pi * f[:, None] * (np.arange(n_period) * T) + phases[:, None]).sum(0)
        slow = np.zeros((2, n))
        slow[k] = 10 * np.sin(2 * np.pi * 10.0 * t)
        broad = np.zeros((2, 2 * n_period))
        broad[k] = np.tile(8 * s / np.abs(s).max(), 2)
        for kind, u in (("slow", slow), ("broadband", broad)):
            y, _ = plant.simulate(u)
            y = y + 0.01 * np.random.default_rng(k).standard_normal(y.shape)
            y = np.concatenate([np.zeros((2, delay)), y[:, :y.shape[1] - delay]], axis=1)
            m = u.shape[1] - drop
            path = directory / f"{kind}_{name}.csv"
            _write(path, T, u[:, :m], y[:, :m])
            files[kind].append(str(path))
    return files


def _identify(files, out, *extra, dynamics=True, printed=None):
    err, out_text = io.StringIO(), io.StringIO()
    dyn = ["--dynamics", "--dynamics-records", *files["broadband"]] if dynamics else []
    with contextlib.redirect_stdout(out_text), contextlib.redirect_stderr(err):
        code = main(["identify", *files["slow"], "--inputs", "ux,uy", "--outputs", "x,y",
                     "--time", "time", *dyn, "--out", str(out), *extra])
    if printed is not None:
        printed.append(out_text.getvalue())
    return code, err.getvalue()


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Model files from delayed records with --delay D and from delay-free records cut by D
    (the latter without --delay: auto, the default with --dynamics)."""
    a = tmp_path_factory.mktemp("delayed")
    b = tmp_path_factory.mktemp("plain")
    assert _identify(_records(a, D, 0), a / "model.toml", "--delay", str(D))[0] == 0
    assert _identify(_records(b, 0, D), b / "model.toml")[0] == 0
    return a / "model.toml", b / "model.toml"


@pytest.fixture(scope="module")
def delayed_files(tmp_path_factory):
    """Delayed records (D samples) in a directory of their own."""
    d = tmp_path_factory.mktemp("delayed-auto")
    return d, _records(d, D, 0)


def test_delayed_records_with_delay_give_the_delay_free_model(pair):
    delayed, plain = (load_plant(str(p)) for p in pair)
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(delayed.dynamics, name), getattr(plain.dynamics, name))
    u = np.vstack([np.linspace(0, 9, 300), np.linspace(0, -7, 300)])
    np.testing.assert_array_equal(delayed.hysteresis.simulate(u)[0], plain.hysteresis.simulate(u)[0])
    assert read_toml(pair[0])["identification"]["measurement_delay_samples"] == D
    assert read_toml(pair[1])["identification"]["measurement_delay_samples"] == 0   # auto


def _same_model(a, b):
    pa, pb = load_plant(str(a)), load_plant(str(b))
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(pa.dynamics, name), getattr(pb.dynamics, name))
    u = np.vstack([np.linspace(0, 9, 300), np.linspace(0, -7, 300)])
    np.testing.assert_array_equal(pa.hysteresis.simulate(u)[0], pb.hysteresis.simulate(u)[0])


@pytest.mark.parametrize("extra", [[], ["--delay", "auto"]])
def test_auto_finds_the_inserted_delay_and_gives_the_model_of_delay_n(pair, delayed_files, extra):
    directory, files = delayed_files
    out, printed = directory / f"auto{len(extra)}.toml", []
    code, err = _identify(files, out, *extra, printed=printed)
    assert code == 0, err
    ident = read_toml(out)["identification"]
    assert ident["measurement_delay_samples"] == D
    assert ident["measurement_delay_estimate"]["used"] is True
    _same_model(out, pair[0])                       # the model of --delay D, bit for bit
    assert f"measurement delay {D} samples" in printed[0]
    assert ("--delay auto" if extra else "auto, the default with --dynamics") in printed[0]
    assert "estimated from the phase slope" in printed[0]


def test_auto_refusals_are_one_line(delayed_files, tmp_path):
    _, files = delayed_files
    out = tmp_path / "m.toml"
    for extra, dynamics, status, says in (
            (["--delay", "auto"], False, 2, "--delay auto"),        # nothing to estimate from
            (["--delay", "three"], True, 2, "--delay"),
            (["--delay", "2.5"], True, 2, "--delay")):
        code, err = _identify(files, out, *extra, dynamics=dynamics)
        assert code == status and says in err and err.count("\n") == 1, (extra, err)
        assert not out.exists()
    # broadband records that cannot tell the delay: the 10 Hz sines as --dynamics-records
    code, err = _identify({"slow": files["slow"], "broadband": files["slow"]}, out,
                          "--delay", "auto")
    assert code == 1 and err.startswith("error: --delay auto: ")
    assert err.count("\n") == 1 and not out.exists()


def test_default_auto_keeps_zero_when_the_records_cannot_tell(pair, monkeypatch, tmp_path):
    """The default (no --delay) with an estimate refused: delay 0, not written, said so; the
    model is the one of delay 0 (the delay-free records of ``pair``)."""
    refused = MeasurementDelay(5, 5.4, (1000.0, 2000.0), 0.3, (5.1, 5.6), 12.0, 13,
                               "refused for the test")
    monkeypatch.setattr(identify_cli, "estimate_measurement_delay", lambda *a, **k: refused)
    out, printed = tmp_path / "m.toml", []
    code, err = _identify(_records(tmp_path, 0, D), out, printed=printed)
    assert code == 0, err
    ident = read_toml(out)["identification"]
    assert "measurement_delay_samples" not in ident
    assert ident["measurement_delay_estimate"]["used"] is False
    assert "measurement delay not estimated" in printed[0] and "refused for the test" in printed[0]
    assert err.startswith("warning: the measurement delay could not be estimated from the "
                          "--dynamics-records (refused for the test) and was taken as 0")
    assert err.count("\n") == 1
    _same_model(out, pair[1])


def _learn(model, directory):
    """One learn call on a drive of ``compensate`` and a measurement delayed by D samples."""
    ref = '{ kind = "circle", radius = 20, frequency = 100, periods = 10 }'
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(directory), contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        assert main(["compensate", str(model), "--reference", ref, "--out", "u0.csv",
                     "--force"]) == 0
        t, u, _ = read_signals(directory / "u0.csv", ["ux", "uy"])
        y, _ = load_plant("rakotondrabe-2dof").simulate(u)
        y = np.concatenate([np.zeros((2, D)), y[:, :-D]], axis=1)
        _write(directory / "y0.csv", t[1] - t[0], u, y, "t")
        code = main(["learn", str(model), "--reference", ref, "--drive", "u0.csv", "--measured",
                     "y0.csv", "--out", "u1.csv", "--force"])
    return code, out.getvalue(), err.getvalue()


def test_learn_takes_the_model_files_delay(pair, tmp_path):
    code, out, err = _learn(pair[0], tmp_path)
    assert code == 0, err
    assert f"delay {D} samples: the model file's measurement delay" in out
    # the delay removed is the model file's; the lag measured on the trial is the same one
    assert f"delay removed {D} samples" in out and f"measured lag {D} samples" in out


@pytest.mark.parametrize("bad", ["-2", "1.5", '"3"', "true"])
def test_a_wrong_measurement_delay_is_refused_naming_the_field(pair, tmp_path, bad):
    text = pair[0].read_text().replace(f"measurement_delay_samples = {D}",
                                       f"measurement_delay_samples = {bad}")
    assert f"measurement_delay_samples = {bad}" in text
    (tmp_path / "model.toml").write_text(text)
    err = io.StringIO()
    with contextlib.chdir(tmp_path), contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(err):
        code = main(["compensate", "model.toml", "--reference",
                     '{ kind = "circle", radius = 20, frequency = 100, periods = 10 }',
                     "--out", "u0.csv"])
    assert code == 1 and err.getvalue().count("\n") == 1
    assert "measurement_delay_samples" in err.getvalue() and not (tmp_path / "u0.csv").exists()


@pytest.mark.parametrize("delay, status, says", [("-1", 2, "--delay"), ("100000", 2, "--delay"),
                                                  ("3000", 1, "--delay 3000")])
def test_delay_out_of_range(pair, tmp_path, delay, status, says):
    files = _records(tmp_path, 0, 0)
    code, err = _identify(files, tmp_path / "m.toml", "--delay", delay)
    assert code == status and says in err and err.count("\n") == 1
    assert not (tmp_path / "m.toml").exists()


def test_a_delay_of_0_given_is_kept_for_learn(tmp_path):
    """``--delay 0`` given: the model file said nothing, and ``learn --delay auto`` estimated
    a delay of its own from the model's prediction (one sample on an outside stage, whose
    learning then converged to that lag, 1.6 % of a 50 Hz circle's radius)."""
    out = tmp_path / "model.toml"
    code, err = _identify(_records(tmp_path, 0, 0), out, "--delay", "0")
    assert code == 0, err
    assert read_toml(out)["identification"]["measurement_delay_samples"] == 0
