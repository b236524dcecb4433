"""``hammerstein identify --creep-records``: the report, the preset tables, the errors.

Records of a PI actuator with a known creep (one lag of 0.5 s adding 4 %),
sampled at 1 kHz, made with the package's excitation signals (slow: two
identifications of 10 s records, 30-150 s CPU under load); the expected
drift is the closed form ``0.04 (exp(-0.1 / 0.5) - exp(-10 / 0.5))`` over
``s(0.1)``.
"""

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.models.creep import Creep
from hammerstein.signals.excitation import excitation_set
from hammerstein.models.plant import HammersteinPlant
from hammerstein.io.presets import load_plant, read_toml

T = 1e-3
LAG = Creep([0.5], [0.04])


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    d = tmp_path_factory.mktemp("creep")
    pi = load_plant("rakotondrabe-2dof").hysteresis
    plant = HammersteinPlant(pi, T, None, creep=[LAG, LAG])
    rng = np.random.default_rng(2)
    files = {}
    for r in excitation_set(["ux", "uy"], 10.0, T, multisine_periods=1):
        if r.kind in ("hysteresis", "creep"):
            y, _ = plant.simulate(r.u)
            y = y + 0.02 * rng.standard_normal(y.shape)
            path = d / f"{r.name}.csv"
            np.savetxt(path, np.column_stack([r.time, r.u.T, y.T]), delimiter=",",
                       header="t,ux,uy,x,y", comments="", fmt="%.9g")
            files.setdefault(r.kind, []).append(str(path))
    return d, files


@pytest.mark.slow
def test_creep_is_reported_and_written(records, capsys):
    d, files = records
    out = d / "model.toml"
    args = ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y", "--time",
            "t", "--creep-records", *files["creep"], "--creep-refits", "1", "--out", str(out), "--metrics",
            str(d / "fit.csv")]
    assert main(args) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "creep: 9 lags, time constants 0.01-100 s" in printed
    doc = read_toml(out)
    assert set(doc["creep"]) == {"x", "y"} and doc["creep"]["x"]["kind"] == "lags"
    s = 1 + 0.04 * (1 - np.exp(-np.array([0.1, 10.0]) / 0.5))
    want = 100 * (s[1] - s[0]) / s[0]
    for name in ("x", "y"):
        got = doc["identification"]["creep"]["outputs"][name]["drift_0p1_to_10s_percent"]
        assert got == pytest.approx(want, rel=0.15)
        assert f"  {name}: drift +" in printed
    rows = (d / "fit.csv").read_text().splitlines()
    assert any(r.startswith("creep,x,drift_0p1_to_10s_percent,") for r in rows)
    # the hysteresis was refitted once on the records with the creep removed
    assert "creep refit 1: hysteresis refitted on the records with the identified creep removed" \
        in printed and "creep refit 2" not in printed


@pytest.mark.slow
def test_records_that_are_not_staircases_exit_1_with_one_line(records, capsys):
    d, files = records
    out = d / "bad.toml"
    args = ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y", "--time",
            "t", "--creep-records", files["hysteresis"][0], "--out", str(out)]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "expected a voltage staircase" in err
    assert not out.exists()


@pytest.mark.parametrize("extra, message", [
    (["--creep-refits", "2"], "--creep-refits: only used with --creep-records"),
    (["--creep-records", "s.csv", "--creep-refits", "9"], "--creep-refits: expected an integer "
                                                          "from 0 to 5, found 9"),
], ids=["without-records", "too-many"])
def test_creep_refits_usage_errors_exit_2(tmp_path, capsys, extra, message):
    out = tmp_path / "m.toml"
    args = ["identify", str(tmp_path / "h.csv"), "--inputs", "ux", "--outputs", "x", "--time", "t",
            *extra, "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not out.exists()
