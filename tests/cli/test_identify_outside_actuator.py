"""``hammerstein identify --dynamics`` on an actuator outside the model class (issue 17).

The records are the excitation files of :mod:`hammerstein.signals.excitation`
played through ``outside_actuator.OutsideActuator`` (written without the
package: Preisach hysteresis with asymmetric loops, hysteretic and even
cross-couplings, three bending modes with dynamic coupling, 40 nm noise).
Expectations come from the simulator's own parameters: its modal
frequencies and damping ratios (450/420/1300 Hz), not from the code.
"""

import numpy as np
import pytest

from outside_actuator import OutsideActuator, write_csv
from hammerstein.cli.main import main
from hammerstein.signals.excitation import excitation_set
from hammerstein.models.lti import dc_gain, modal_parameters
from hammerstein.io.presets import load_plant, read_toml


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    d = tmp_path_factory.mktemp("outside")
    act = OutsideActuator()
    rng = np.random.default_rng(7)
    files = {}
    for r in excitation_set(["ux", "uy"], 10.0, 5e-5, sine_frequency=5.0, hold=0.1):
        if r.kind == "creep":
            continue
        write_csv(d / f"{r.name}.csv", r.time, r.u, act.simulate(r.u, rng=rng))
        files.setdefault(r.kind, []).append(str(d / f"{r.name}.csv"))
    out = d / "preset.toml"
    args = ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
            "--time", "t", "--components", "all", "--dynamics", "--dynamics-records",
            *files["multisine"], *files["multisine-validation"], "--out", str(out),
            "--metrics", str(d / "fit.csv")]
    return act, out, d, args


@pytest.mark.slow
def test_modes_g0_and_report_of_the_outside_actuator(identified, capsys):
    act, out, d, args = identified
    assert main(args) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    plant = load_plant(out)
    f_true, z_true = act.true_modes()
    f_id, z_id = modal_parameters(plant.dynamics)
    assert f_id.shape == f_true.shape                     # no spurious pole at all
    np.testing.assert_allclose(f_id, f_true, rtol=0.01)   # frequency within 1 %
    np.testing.assert_allclose(z_id, z_true, rtol=0.10)   # damping within 10 %
    np.testing.assert_allclose(dc_gain(plant.dynamics), np.eye(2), atol=1e-6)
    summary = read_toml(out)["identification"]["dynamics"]
    assert summary["order"] == 6 and "multisine-ux-validation.csv" in summary["chosen_on"]
    assert [round(m["frequency_hz"]) for m in summary["modes"]] == [round(v) for v in f_id]
    assert "dynamics: order 6" in printed and "G(0) unconstrained" in printed
    rows = (d / "fit.csv").read_text().splitlines()
    assert any(r.startswith("dynamics,G,order,6") for r in rows)


@pytest.mark.slow
def test_fixed_order_is_used_and_reported(identified, capsys):
    act, out, d, args = identified
    args = [a if a != str(out) else str(d / "fixed.toml") for a in args]
    args = [a for a in args if not a.endswith("fit.csv") and a != "--metrics"]
    assert main(args + ["--order", "4"]) == 0, capsys.readouterr().err
    summary = read_toml(d / "fixed.toml")["identification"]["dynamics"]
    assert summary["candidate_order"] == 4 and [c["order"] for c in summary["candidates"]] == [4]
    assert main(args + ["--order", "4", "--max-order", "6"]) == 2
    assert "give one of them" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("gain, warned", [(1.0, False), (1.08, True)])
def test_multisines_of_a_changed_actuator_are_named(tmp_path, capsys, gain, warned):
    """Hysteresis records of one session beside multisines of another, the actuator 8 %
    stronger on x since (warmer): a user's re-identification came out worse than the stale
    model, and nothing said why. The multisines' unconstrained G(0) then departs from the
    identity by about the gain's change, and identify says so."""
    act, rng, files = OutsideActuator(), np.random.default_rng(11), {}
    for r in excitation_set(["ux", "uy"], 10.0, 5e-5, sine_frequency=5.0, hold=0.1):
        if r.kind == "creep":
            continue
        y = act.simulate(r.u, rng=rng)
        if r.kind != "hysteresis":
            y = y * np.array([[gain], [1.0]])
        write_csv(tmp_path / f"{r.name}.csv", r.time, r.u, y)
        files.setdefault(r.kind, []).append(str(tmp_path / f"{r.name}.csv"))
    args = ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
            "--time", "t", "--dynamics", "--dynamics-records", *files["multisine"],
            *files["multisine-validation"], "--out", str(tmp_path / "p.toml")]
    assert main(args) == 0
    err = capsys.readouterr().err
    summary = read_toml(tmp_path / "p.toml")["identification"]["dynamics"]
    assert abs(summary["dc_gain_unconstrained"][0][0] - gain) < 0.03
    lines = [ln for ln in err.splitlines() if "the multisines show" in ln]
    assert bool(lines) == warned
    if warned:
        assert lines[0].startswith("warning: the multisines show") and "more static gain on x" in lines[0]
