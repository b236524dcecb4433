"""``hammerstein identify --model classical|preisach|generalized|auto`` (issue 17).

Records: decreasing-amplitude sines played through a Preisach actuator with asymmetric,
tilted density (not a PI), quasi-static (1 kHz sampling), written as CSV files; and a
single closed loop of a classical PI. Expectations: the held-out minor loops decide,
the actuator's own minor loops, the class that draws them.
"""

import numpy as np
import pytest

from hammerstein.cli.main import main
from hysteresis_records import decreasing_sine_records, preisach_actuator as actuator, write
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.io.presets import load_model

T = 1e-3


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("model")
    act = actuator()
    return act, d, decreasing_sine_records(d, act, 0.04, "hyst", T)


def loop_pp(model, k, frac):
    n = int(round(1 / T))
    u = np.zeros((2, 2 * n))
    u[k] = frac * 10.0 * np.sin(2 * np.pi * np.arange(2 * n) / n)
    return np.ptp(model.simulate(u)[0][k, n:])


@pytest.mark.slow  # end-to-end; default pytest stays fast, .ci/run runs -m slow
def test_auto_chooses_the_class_with_the_lower_minor_loop_error(files, capsys):
    act, d, recs = files
    out = d / "auto.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--out", str(out), "--preisach-levels", "12"]) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    lines = [ln.strip() for ln in printed.splitlines() if "model auto:" in ln]
    chosen = lines[0].split()[3]
    scores = {ln.split()[2]: float(ln.split()[3]) for ln in lines[1:]}
    assert set(scores) == {"classical", "preisach", "generalized"}
    assert scores[chosen] == min(scores.values())
    # the actuator is not a PI: both classes that draw asymmetric, non-PI minor loops beat the
    # classical PI by far (measured 4.51 % against 12.6 %). Between them the held-out levels
    # decide; on these records the generalised PI (quadratic reversible term, 16 plays) ties
    # with the Preisach model (4.51 %) and draws the never-recorded 15 % and 30 % loops within
    # 0.23 % (the Preisach model of 12 levels: 1.56 %)
    assert chosen in ("preisach", "generalized")
    assert 2 * max(scores["preisach"], scores["generalized"]) < scores["classical"]
    model = load_model(str(out))                     # the file round trip
    assert isinstance(model, MultivariableHysteresis)
    for k in range(2):
        for frac in (0.3, 0.15):                     # minor loops never recorded
            assert abs(loop_pp(model, k, frac) / loop_pp(act, k, frac) - 1) < 0.02


def test_model_classical_is_kept_when_asked(files, capsys):
    _, d, recs = files
    out = d / "classical.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", "classical", "--out", str(out)]) == 0
    assert "model auto" not in capsys.readouterr().out
    assert isinstance(load_model(str(out)), MultivariablePI)


def test_single_loop_auto_keeps_the_classical_pi_and_says_why(tmp_path, capsys):
    pi = MultivariablePI([[PrandtlIshlinskii([0.0, 1.0, 2.0], [2.0, 0.5, 0.3])]],
                         input_amplitude=[5.0])
    n = 1000
    t = np.arange(n) * T
    u = 5 * np.sin(2 * np.pi * t)[None]
    y = pi.simulate(np.tile(u, 2))[0][:, n:]
    np.savetxt(tmp_path / "loop.csv", np.column_stack([t, u[0], y[0]]), delimiter=",",
               header="t,u,y", comments="")
    assert main(["identify", str(tmp_path / "loop.csv"), "--inputs", "u", "--outputs", "y",
                 "--time", "t", "--out", str(tmp_path / "m.toml")]) == 0
    assert "model auto: classical PI (no held-out amplitude level" in capsys.readouterr().out


def test_preisach_levels_out_of_range_is_a_usage_error(files, capsys):
    _, d, recs = files
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--preisach-levels", "1", "--out", str(d / "x.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--preisach-levels" in err


@pytest.mark.parametrize("argv, problem", [
    (["--preisach-smoothing", "0.x"], "expected auto or a smoothing weight >= 0"),
    (["--preisach-smoothing", "-1e-5"], "found '-1e-5'"),
    (["--preisach-smoothing", "nan"], "found 'nan'"),
    (["--preisach-smoothing", "inf"], "found 'inf'"),
    (["--preisach-smoothing", "1e-5", "--model", "generalized"], "only used by --model preisach"),
    (["--preisach-smoothing", "1e-5", "--model", "classical"], "only used by --model preisach"),
])
def test_a_bad_preisach_smoothing_is_a_usage_error(files, capsys, argv, problem):
    _, d, recs = files
    out = d / "bad-smoothing.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--preisach-smoothing: " in err and problem in err
    assert not out.exists()


def test_a_given_preisach_smoothing_is_not_searched(files, capsys):
    """``--preisach-smoothing 0.003`` is the weight of every Preisach fit: the model equals the
    identifier's given that weight on the same records (the pipeline refits it on every level:
    so does the reference here), and no search is printed."""
    from hammerstein.identification.preisach_identification import (PreisachIdentifier,
                                                                    refit_on_every_level)
    from hammerstein.io.datafiles import read_records
    _, d, recs = files
    out = d / "given.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", "preisach", "--preisach-levels", "8", "--preisach-smoothing", "0.003",
                 "--out", str(out)]) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "smoothing auto" not in printed and "at lambda 0.003" in printed
    records = [read_records(r, ["ux", "uy"], ["x", "y"], time="t") for r in recs]
    est = PreisachIdentifier(8, 0.003).fit(records)
    est.fit_.smoothing = est.smoothing_
    ref = refit_on_every_level(est.fit_, 8).model
    mine = load_model(str(out))
    u = np.vstack([8 * np.sin(np.linspace(0, 6 * np.pi, 700)),
                   5 * np.cos(np.linspace(0, 4 * np.pi, 700))])
    np.testing.assert_allclose(mine.simulate(u)[0], ref.simulate(u)[0], rtol=0, atol=1e-9)


@pytest.mark.parametrize("model, grid", [("preisach", "--preisach-levels"),
                                         ("generalized", "--threshold-spacing")])
@pytest.mark.parametrize("thresholds", ["0,1,2.5", "7"])
def test_thresholds_with_a_class_that_ignores_them_is_a_usage_error(files, capsys, model, grid,
                                                                    thresholds):
    """The classical PI's hysterons: a Preisach or generalised-PI fit ignored them silently."""
    _, d, recs = files
    out = d / f"ignored-{model}.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", model, "--thresholds", thresholds, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--thresholds: only used by --model classical or auto" in err
    assert grid in err and not out.exists()


@pytest.mark.slow   # three classes fitted and judged on the staircases too: ~4.5 s of CPU
def test_auto_with_creep_records_judges_the_step_levels_too(files, capsys):
    # a staircase from rest per input (the actuator has no creep: the levels are its hysteresis);
    # both classes are judged on them too, one line each, and the numbers printed are those of
    # the chosen model and its creep on the staircases, recomputed here
    from hammerstein.models.creep import creep_from_table
    from hammerstein.signals.excitation import staircase
    from hammerstein.io.presets import read_toml
    act, d, recs = files
    rng = np.random.default_rng(5)
    stairs = []
    for k in range(2):
        t, one, _ = staircase(T, 10.0, hold=0.5)
        u = np.zeros((2, t.size))
        u[k] = one
        write(d / f"stairs-{k}.csv", t, u, act.simulate(u)[0] + 0.04 * rng.standard_normal((2, t.size)))
        stairs.append((u, act.simulate(u)[0]))
    out = d / "auto-creep.toml"
    assert main(["identify", *recs, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--creep-records", str(d / "stairs-0.csv"), str(d / "stairs-1.csv"),
                 "--creep-refits", "0", "--out", str(out), "--preisach-levels", "12"]) == 0, \
        capsys.readouterr().err
    lines = [ln.strip() for ln in capsys.readouterr().out.splitlines() if "model auto:" in ln]
    assert "staircases' step-level RMS" in lines[0]
    per = {ln.split()[2]: ln for ln in lines[1:]}
    assert set(per) == {"classical", "preisach", "generalized"}
    chosen = lines[0].split()[3]
    rms = float(per[chosen].split("step levels (model + its creep, from rest) RMS ")[1].split()[0])
    model = load_model(str(out))
    table = read_toml(out)["creep"]
    creeps = [creep_from_table(table[name], f"creep.{name}") for name in ("x", "y")]
    errs = []
    for u, y in stairs:                 # noise-free actuator: the levels of the steps
        h = model.simulate(u)[0]
        off = np.zeros(2) if model.output_offset is None else np.asarray(model.output_offset)
        for l in range(2):
            h[l] = creeps[l].simulate((h[l] - off[l])[None], T)[0][0] + off[l]
        edges = np.flatnonzero(np.any(np.diff(u, axis=1) != 0, axis=0)) + 1
        for a, b in zip(np.r_[0, edges], np.r_[edges, u.shape[1]]):
            a += int(round(0.1 / T))
            errs.append(np.mean(y[:, a:b] - h[:, a:b], axis=1))
    # the printed RMS is on the noisy records: within the noise's share of a level mean
    assert rms == pytest.approx(float(np.sqrt(np.mean(np.square(errs)))), abs=0.02 + 0.05 * rms)
