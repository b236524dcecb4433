"""``hammerstein identify --model generalized|auto`` on a generalised-PI actuator (issue 17).

The records are the excitation files of :mod:`hammerstein.signals.excitation`
played through ``gpi_actuator.GPIActuator`` (written without the package:
generalised-PI direct paths with asymmetric saturating envelopes, hysteretic
and even cross-couplings, three bending modes with dynamic coupling, 40 nm
noise). Expectations come from the simulator itself: its quasi-static loops
``G(0) H(u)`` and its response to the compensator's voltages.
"""

import numpy as np
import pytest

from gpi_actuator import T, GPIActuator, _lsim
from outside_actuator import write_csv
from hammerstein.cli.main import main
from hammerstein.signals.excitation import decreasing_sine, excitation_set
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.io.presets import load_model, load_plant, read_toml


def test_model_generalized_on_a_quasi_static_record(tmp_path, capsys):
    """A one-input generalised PI (thresholds and envelopes other than the identifier's)
    identified through the CLI; the file is a generalised PI that predicts the true loops."""
    true = GeneralizedPI([0.0, 0.7, 1.9, 3.5], [1.2, 0.4, 0.25, 0.2],
                         gamma_l=[16.0, 0.07, 0.1, 0.0], gamma_r=[14.0, 0.08, -0.05, 0.4])
    t, u, _ = decreasing_sine(2.5e-3, 10.0)     # quasi-static: 400 samples a period
    y = true.simulate(u)[0] + 0.01 * np.random.default_rng(2).standard_normal(u.size)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u,y", comments="")
    out = tmp_path / "gpi.toml"
    base = ["identify", str(path), "--inputs", "u", "--outputs", "y", "--time", "t",
            "--model", "generalized", "--out", str(out)]
    assert main(base) == 0, capsys.readouterr().err
    assert "u: generalized PI 16 plays" in capsys.readouterr().out
    model = load_model(str(out))
    assert isinstance(model.components[0][0], GeneralizedPI)
    v = 6.0 * np.sin(2 * np.pi * np.arange(2000) / 1000)       # a minor loop never recorded
    np.testing.assert_allclose(model.simulate(v[None])[0][0, 1000:],
                               true.simulate(v)[0][1000:], atol=0.01 * np.ptp(y))
    assert main(base[:-2] + ["--method", "closed-form", "--out", str(tmp_path / "b.toml")]) == 2
    assert "--model generalized: fitted by least squares" in capsys.readouterr().err
    # --threshold-spacing auto: both spacings fitted, the choice printed as the partition, its
    # reason in the notes, the scores in the file's identification metadata
    assert main(base[:-1] + [str(tmp_path / "c.toml"), "--threshold-spacing", "auto"]) == 0
    printed = capsys.readouterr().out
    meta = read_toml(str(tmp_path / "c.toml"))["identification"]
    assert set(meta["partition_scores_percent"]) == {"power", "uniform"}
    best = min(meta["partition_scores_percent"], key=meta["partition_scores_percent"].get)
    assert meta["partition"] == best and f"partition {best}," in printed
    assert f"threshold spacing auto: chose {best} (power " in printed


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    d = tmp_path_factory.mktemp("gpi")
    act = GPIActuator()
    rng = np.random.default_rng(11)
    files = {}
    for r in excitation_set(["ux", "uy"], 10.0, T, sine_frequency=5.0, hold=0.1):
        if r.kind == "creep":
            continue
        write_csv(d / f"{r.name}.csv", r.time, r.u, act.simulate(r.u, rng=rng))
        files.setdefault(r.kind, []).append(str(d / f"{r.name}.csv"))
    return act, d, files


def identify(d, files, model, capsys):
    out = d / f"{model}.toml"
    args = ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
            "--time", "t", "--model", model, "--dynamics", "--dynamics-records",
            *files["multisine"], *files["multisine-validation"], "--out", str(out)]
    assert main(args) == 0, capsys.readouterr().err
    return load_plant(out), capsys.readouterr().out


def loop_error(act, model, k, fraction):
    """Quasi-static loop amplitude of output k (1 Hz sine at ``fraction`` of 10 V): model vs the
    actuator's own steady state G(0) H(u), relative."""
    n = int(round(1 / T))
    u = np.zeros((2, 2 * n))
    u[k] = fraction * 10.0 * np.sin(2 * np.pi * np.arange(2 * n) / n)
    true = (act.dc_gain() @ act.hysteresis(u))[k, n:]
    est = model.simulate(u)[0][k, n:]
    return np.ptp(est) / np.ptp(true) - 1


@pytest.mark.slow
def test_generalized_model_minor_loops_and_compensation(recorded, capsys):
    act, d, files = recorded
    plant, printed = identify(d, files, "generalized", capsys)
    assert "generalized PI 16 plays" in printed
    assert isinstance(plant.hysteresis.components[0][0], GeneralizedPI)
    for k in range(2):                      # minor loops never recorded (issue 17: within 2 %)
        for frac in (0.3, 0.15):
            assert abs(loop_error(act, plant.hysteresis, k, frac)) < 0.02, (k, frac)
    # the Hammerstein compensator over the identified preset drives the actuator itself
    comp = HammersteinCompensator(plant.hysteresis, plant.dynamics)
    R, f, n = 30.0, 50.0, 8000
    t = np.arange(n) * T
    ref = np.vstack([R * np.cos(2 * np.pi * f * t), R * np.sin(2 * np.pi * f * t)])
    lead, state, faded = comp.start(ref, period_samples=400, fade_samples=800)
    u, _ = comp.simulate(lead, state)
    y = act.simulate(u, noise=False)
    err = np.linalg.norm(y[:, 4000:] - faded[:, 4000:], axis=0)
    # measured 2.3 % of R worst, 1.2 % median: all of it from the identified G (the actuator's
    # G(0) is not I, [[1.003, 0.013], [-0.066, 1.008]]); the identified hysteresis through the
    # actuator's own modes (G(0)^-1 H_id, independent of the package's dynamics) is exact
    assert err.max() < 0.03 * R and np.median(err) < 0.02 * R, (err.max(), np.median(err))
    h_id = np.linalg.solve(act.dc_gain(), plant.hysteresis.simulate(u)[0])
    Ad, Bd, C = map(np.ascontiguousarray, (act.Ad, act.Bd, act.C))
    y_h = _lsim(Ad, Bd, C, np.ascontiguousarray(h_id.T)).T
    assert np.linalg.norm(y_h[:, 4000:] - faded[:, 4000:], axis=0).max() < 0.005 * R


@pytest.mark.slow
def test_auto_fits_three_classes_and_keeps_the_lowest_minor_loop_error(recorded, capsys):
    act, d, files = recorded
    plant, printed = identify(d, files, "auto", capsys)
    lines = [ln.strip() for ln in printed.splitlines() if "model auto:" in ln]
    chosen = lines[0].split()[3]
    scores = {ln.split()[2]: float(ln.split()[3]) for ln in lines[1:]}
    assert set(scores) == {"classical", "preisach", "generalized"}
    assert scores[chosen] == min(scores.values())
    assert scores["classical"] > min(scores["preisach"], scores["generalized"])


@pytest.mark.parametrize("asked", ["generalized", "auto"])
def test_a_refit_keeps_the_generalized_class(monkeypatch, asked):
    """The creep refit re-identifies the class that was kept, and only it.

    It used to map a generalised-PI fit to "classical": with ``--model
    generalized`` the refit then fitted a classical PI too and chose between the
    two by their held-out error, which could hand back a class the user had not
    asked for; with ``auto`` it paid for a classical fit it then compared again.
    """
    from types import SimpleNamespace

    import hammerstein.identification.identification_pipeline as pipeline
    calls = []

    def fake(kind):
        def fit(*args, **kwargs):
            calls.append(kind)
            return SimpleNamespace(method={"classical": "lsq"}.get(kind, kind), levels=[],
                                   notes=[], validation=[])
        return fit
    monkeypatch.setattr(pipeline, "identify_records", fake("classical"))
    monkeypatch.setattr(pipeline, "identify_preisach_records", fake("preisach"))
    monkeypatch.setattr(pipeline, "identify_gpi_records", fake("generalized-pi"))
    options = pipeline.PipelineOptions(model=asked, method="lsq", bounds="auto", skip=0,
                                       preisach_levels=None, threshold_spacing="power", n=10)
    first = SimpleNamespace(method="generalized-pi")
    assert pipeline.fit_class(first) == "generalized"
    fit = pipeline.identify_hysteresis([], options, (["u"], ["y"]), pipeline.fit_class(first))
    assert calls == ["generalized-pi"] and fit.method == "generalized-pi"


def _one_input_record(tmp_path, **start):
    """A 1-input generalised-PI record written as identify reads it: (t, u, y, base args)."""
    true = GeneralizedPI([0.0, 0.7, 1.9, 3.5], [1.2, 0.4, 0.25, 0.2],
                         gamma_l=[16.0, 0.07, 0.1, 0.0], gamma_r=[14.0, 0.08, -0.05, 0.4],
                         **start)
    t, u, _ = decreasing_sine(2.5e-3, 10.0)
    y = true.simulate(u)[0] + 0.01 * np.random.default_rng(2).standard_normal(u.size)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u,y", comments="",
               fmt="%.17g")
    return t, u, y, ["identify", str(path), "--inputs", "u", "--outputs", "y", "--time", "t",
                     "--model", "generalized"]


def test_level_weighting_option_is_the_identifiers(tmp_path, capsys):
    """``--level-weighting none`` writes the model ``GeneralizedPIIdentifier(level_weighting=
    "none")`` fits on the same record (the same loops to 1e-9 of their range), and the default
    (each level weighted by its amplitude) another one; a wrong value is a usage error."""
    from hammerstein.identification.gpi_identification import GeneralizedPIIdentifier
    from hammerstein.io.datafiles import MultiRecord
    t, u, y, base = _one_input_record(tmp_path)
    models = {}
    for weighting in ("amplitude", "none"):
        out = tmp_path / f"{weighting}.toml"
        assert main(base + ["--level-weighting", weighting, "--out", str(out)]) == 0
        models[weighting] = load_model(str(out))
    capsys.readouterr()
    rec = MultiRecord(t, u[None], y[None], ("u",), ("y",), 2.5e-3, "rec")
    est = GeneralizedPIIdentifier(level_weighting="none").fit(rec)
    v = 6.0 * np.sin(2 * np.pi * np.arange(2000) / 1000)[None]
    a, b = models["none"].simulate(v)[0], est.model_.simulate(v)[0]
    assert np.max(np.abs(a - b)) <= 1e-9 * np.ptp(a)
    assert np.max(np.abs(models["amplitude"].simulate(v)[0] - a)) > 1e-4 * np.ptp(a)
    assert main(base + ["--level-weighting", "relative", "--out", str(tmp_path / "x.toml")]) == 2
    assert "--level-weighting" in capsys.readouterr().err


def test_record_start_option_is_the_identifiers(tmp_path, capsys):
    """``identify`` writes the generalised PI that ``GeneralizedPIIdentifier`` fits (the same
    loops to 1e-9 of their range), starting after the demagnetising cycle of the record's
    amplitude by default (``demagnetised = 10`` in the preset) and from the plays at rest
    with ``--record-start rest``; a wrong value is a usage error."""
    from hammerstein.identification.gpi_identification import GeneralizedPIIdentifier
    from hammerstein.io.datafiles import MultiRecord
    from hammerstein.io.presets import read_toml
    t, u, y, base = _one_input_record(tmp_path, demagnetised=10.0)
    tables = {}
    for start in ("demagnetised", "rest"):
        out = tmp_path / f"{start}.toml"
        assert main(base + ["--record-start", start, "--out", str(out)]) == 0
        tables[start] = read_toml(out)["model"]["components"]["y"]["u"]
    capsys.readouterr()
    assert tables["demagnetised"]["demagnetised"] == 10.0
    assert "demagnetised" not in tables["rest"]
    rec = MultiRecord(t, u[None], y[None], ("u",), ("y",), 2.5e-3, "rec")
    est = GeneralizedPIIdentifier().fit(rec)
    v = 1.5 * np.sin(2 * np.pi * np.arange(2000) / 1000)[None]      # a 15 % loop from the start
    a, b = load_model(str(tmp_path / "demagnetised.toml")).simulate(v)[0], est.model_.simulate(v)[0]
    assert np.max(np.abs(a - b)) <= 1e-9 * np.ptp(a)
    assert main(base + ["--record-start", "cold", "--out", str(tmp_path / "x.toml")]) == 2
    assert "--record-start" in capsys.readouterr().err
