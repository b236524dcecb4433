"""Actuators with more channels than measured outputs, or more outputs than channels.

Simulation and identification take rectangular models; no compensator
inverts one. A tube driven on x, y and a common z with only x and y measured
(3 inputs, 2 outputs) and two stacks on one measured axis (2 inputs, 1
output) crashed ``compensate``, ``learn`` and ``export`` without ``--kind``
with an IndexError from the default kind's gain search; ``--kind hammerstein``
on a 1-input, 2-output model named as working kinds four that all refused;
``identify --dynamics`` refused such records only after 10-21 s of fitting.
"""

import numpy as np
import pytest

from hammerstein import MultivariablePI, PrandtlIshlinskii
from hammerstein.cli.main import main
from hammerstein.compensation.model_classes import kind_problem
from hammerstein.compensation.kind_choice import choose_kind
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import save_model
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel

CIRCLE = '{ kind = "circle", radius = 5, frequency = 10, periods = 3 }'
SINE = '{ kind = "sine", output = "x", amplitude = 5, frequency = 10, periods = 3 }'


def _pi():
    return PrandtlIshlinskii([0.0, 2.0, 5.0], [1.0, 0.3, 0.2])


def tube():
    """3 inputs (ux, uy, uz), 2 outputs (x, y): a classical PI."""
    return MultivariablePI([[_pi(), 0.02, 0.05], [0.02, _pi(), 0.05]],
                           input_names=["ux", "uy", "uz"], output_names=["x", "y"],
                           input_amplitude=[10.0, 10.0, 10.0])


def parallel_stacks():
    """2 inputs, 1 output: a Preisach model (the exact-inverse class)."""
    e = np.linspace(-10.0, 10.0, 11)
    d = PreisachModel.from_density(e, total=20.0, coercivity=1.0, coercivity_width=2.0)
    return MultivariableHysteresis([[d, Polynomial([1.0])]], input_names=["u1", "u2"],
                                   output_names=["x"], input_amplitude=[10.0, 10.0])


def tilt():
    """1 input, 2 outputs (x and a parasitic tilt)."""
    return MultivariablePI([[_pi()], [PrandtlIshlinskii([0.0, 2.0], [0.1, 0.02])]],
                           input_names=["u"], output_names=["x", "tilt"], input_amplitude=[10.0])


@pytest.mark.parametrize("make, ins, outs", [(tube, "3 inputs (ux, uy, uz)", "2 outputs (x, y)"),
                                             (parallel_stacks, "2 inputs (u1, u2)", "1 output (x)"),
                                             (tilt, "1 input (u)", "2 outputs (x, tilt)")])
@pytest.mark.parametrize("dynamics", [False, True])
def test_no_kind_is_chosen_and_every_kind_names_the_shape(make, ins, outs, dynamics):
    model = make()
    with pytest.raises(CompensatorError) as err:
        choose_kind(model, dynamics)
    assert f"as many inputs as outputs (a square model), found {ins} and {outs}" in str(err.value)
    for kind in ("hammerstein", "multivariable", "per-axis", "preisach-inverse"):
        assert kind_problem(model, kind, dynamics) == str(err.value)    # no kind that "works"


@pytest.mark.parametrize("make, ref", [(tube, CIRCLE), (parallel_stacks, SINE)])
def test_compensate_learn_and_export_refuse_it_in_one_line(make, ref, tmp_path, capsys):
    path = tmp_path / "model.toml"
    save_model(make(), path)
    drive = tmp_path / "drive.csv"
    drive.write_text("t,u1,u2\n0,0,0\n")
    commands = [
        ["compensate", str(path), "--sampling-period", "1e-4", "--reference", ref,
         "--out", str(tmp_path / "d.csv")],
        ["export", str(path), "--target", "c", "--name", "act", "--out", str(tmp_path / "gen")],
    ]
    for argv in commands:
        code = main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 1, (argv, err)
        assert len(err) == 1 and "a square model" in err[0] and "IndexError" not in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.csv", "model.toml"]


def test_identify_dynamics_refuses_a_rectangular_actuator_before_reading(tmp_path, capsys):
    # the records are not even read: files that are not records at all give the same line
    files = []
    for name in ("hysteresis-ux.csv", "multisine-ux.csv"):
        (tmp_path / name).write_text("not a record\n")
        files.append(str(tmp_path / name))
    code = main(["identify", files[0], "--inputs", "ux,uy,uz", "--outputs", "x,y", "--dynamics",
                 "--dynamics-records", files[1], "--time", "t", "--out", str(tmp_path / "p.toml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert "--dynamics: expected as many outputs as inputs" in err[0]
    assert "found 3 inputs (ux, uy, uz) and 2 outputs (x, y)" in err[0]
    assert not (tmp_path / "p.toml").exists()
