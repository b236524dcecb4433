"""A model whose outputs each mix every input (a tip-tilt-piston platform): the
compensators that solve each output on its own input cannot invert it, and
``compensate``, ``export`` and ``learn`` say so alike (one decision,
:func:`hammerstein.compensation.kind_choice.law_check`), never a useless drive.
"""

import numpy as np
import pytest

from hammerstein.cli.learn import _inverse_gain
from hammerstein.cli.main import main
from hammerstein.compensation.kind_choice import choose_kind, law_check
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator, sweep_radius
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import dynamics_to_table, load_plant, save_model
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.scenario.hardware_route import _kind_and_options

CIRCLE = '{ kind = "circle", radius = 2, frequency = 20, periods = 3 }'


def _preisach(total=10.0):
    return PreisachModel.from_density(np.linspace(-12, 12, 25), total=total, coercivity=1.0,
                                      coercivity_width=2.0, reversible=[1.0])


def _dense_preisach(c01, c10):
    """2 x 2: Preisach direct paths (secant gain 2 µm/V), linear cross-couplings [µm/V]."""
    return MultivariableHysteresis([[_preisach(), Polynomial([c01])],
                                    [Polynomial([c10]), _preisach()]], input_amplitude=[10.0, 10.0])


def _reachable(model):
    t = np.linspace(0, 1, 2000)
    u = np.vstack([6 * np.sin(2 * np.pi * 2 * t), 6 * np.cos(2 * np.pi * 3 * t)])
    return model.simulate(u)[0]


def test_the_sweep_radius_is_gauss_seidels_own():
    # 2 x 2 Gauss-Seidel on K u = y: error contracts by K01 K10 / (K00 K11) per sweep
    K = np.array([[2.0, 5.0], [5.0, 2.0]])
    assert sweep_radius(K, (1.0,)) == pytest.approx(25.0 / 4.0)
    # damped sweeps converge iff D^-1 K has eigenvalues of positive real part: 1 +- 2.5 has not
    assert sweep_radius(K) >= 1.0
    # skew couplings: D^-1 K = I + 2.5 i (-)1, under-relaxation converges
    assert sweep_radius(np.array([[2.0, 5.0], [-5.0, 2.0]])) < 1.0


def test_exact_inverse_refuses_a_model_its_sweeps_cannot_solve():
    model = _dense_preisach(5.0, 5.0)      # cross-couplings 2.5 x the direct paths, same sign
    with pytest.raises(CompensatorError) as info:
        PreisachInverseCompensator(model)
    text = str(info.value)
    assert "Gauss-Seidel over the direct paths" in text and "spectral radius" in text
    assert "y0: direct 2 µm/V against 5 from the others" in text
    # the comparison (full K, not sweeps) is not refused
    PreisachInverseCompensator(model, method="multiplicative")


def test_exact_inverse_still_solves_strong_skew_couplings():
    model = _dense_preisach(5.0, -5.0)     # not diagonally dominant, but the sweeps converge
    y = _reachable(model)
    u, _ = PreisachInverseCompensator(model).simulate(y)
    assert np.max(np.abs(model.simulate(u)[0] - y)) < 1e-8


def _dense_pi_preset(tmp_path, c01, c10):
    """rakotondrabe-2dof (classical PI, dynamics) with linear cross-couplings [µm/V]."""
    plant = load_plant("rakotondrabe-2dof")
    h = plant.hysteresis
    model = MultivariablePI([[h.components[0][0], c01], [c10, h.components[1][1]]],
                            h.input_names, h.output_names, h.input_amplitude)
    path = tmp_path / f"dense{c01:g}_{c10:g}.toml"
    save_model(model, path, extra={"preset": {"sampling_period": plant.sampling_period},
                                   "dynamics": dynamics_to_table(plant.dynamics)})
    return path, load_plant(str(path))


def _lines(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_compensate_learn_and_export_refuse_a_law_that_diverges_alike(tmp_path, capsys):
    # direct secant gains ~9.9 and ~7.4 µm/V against -30 and -25 from the other input
    path, plant = _dense_pi_preset(tmp_path, -30.0, -25.0)
    with pytest.raises(CompensatorError) as info:
        law_check(plant.hysteresis)
    reason = str(info.value)
    assert "diverges on the model's own outputs" in reason and "--check warn" in reason
    with pytest.raises(CompensatorError, match="diverges on the model's own outputs"):
        _inverse_gain(plant.hysteresis, None, None)          # learn's
    code, _, err = _lines(capsys, "compensate", str(path), "--reference", CIRCLE,
                          "--out", str(tmp_path / "d.csv"))
    assert code == 1 and not (tmp_path / "d.csv").exists()
    assert err.strip().splitlines()[-1] == f"hammerstein compensate: error: {reason}"
    code, out, err = _lines(capsys, "export", str(path), "--out", str(tmp_path / "c"))
    assert code == 1 and not list((tmp_path / "c").glob("*.c")) and "wrote" not in out
    assert err.strip().splitlines()[-1] == f"hammerstein export: error: {path}: {reason}"
    # the user's --check warn is kept by all three
    assert law_check(plant.hysteresis, check="warn").check == "warn"
    assert _inverse_gain(plant.hysteresis, None, "warn")[1] == "warn"


def test_compensate_learn_and_export_run_a_law_that_follows_with_check_warn(tmp_path, capsys):
    path, plant = _dense_pi_preset(tmp_path, 5.0, 5.0)      # rho 1.1 >= 1, yet it follows
    law = law_check(plant.hysteresis)
    assert law.radius >= 1.0 and law.check == "warn"
    assert _inverse_gain(plant.hysteresis, None, None)[1] == "warn"          # learn's
    kind, options, note = _kind_and_options(plant, None, None, None)         # compensate's
    assert kind == "hammerstein" and options["check"] == "warn"
    choice = choose_kind(plant.hysteresis, True)                             # export's
    assert choice.options["check"] == "warn" and note.startswith(choice.note())
    code, out, err = _lines(capsys, "export", str(path), "--out", str(tmp_path / "c"))
    assert code == 0, err
    assert choice.note() in err.splitlines()
    # the default chose a scaled-midpoint K: the warning gives it, not "an explicit gain"
    assert "an explicit gain" not in err and "gain K = diag(" in err


@pytest.mark.parametrize("preset, refused", [
    ("hammerstein/presets/rakotondrabe-2dof.toml", True),
    ("tests/hardware/data/outside-classical-deadzone.toml", False)])
def test_a_users_gain_that_does_not_converge_is_not_taken_for_every_gain(preset, refused):
    """--gain identity diverges (rho 8.96 and 2.53) where the midpoint gain converges (0.458 and
    0.4): the refusal said that no gain makes the law converge and to measure and identify
    again, and learn's warning that no gain makes it provably converge."""
    from pathlib import Path
    model = load_plant(Path(__file__).resolve().parents[2] / preset).hysteresis
    if refused:
        with pytest.raises(CompensatorError) as err:
            law_check(model, "identity")
        text = str(err.value)
    else:
        law = law_check(model, "identity")
        assert law.check == "warn"
        text = law.reason
        notes = _inverse_gain(model, "identity", None)[2]
        assert notes[0].startswith("warning: gain identity: rho(I - K^-1 J) reaches 2.53 >= 1")
        assert "no gain" not in notes[0] and "takes one with 0.4)" in notes[0]
    assert "no gain" not in text
    assert text.startswith("gain identity does not make the classical PI law provably converge "
                           "(rho(I - K^-1 J) ")
    assert "without --gain the law takes one with 0.4" in text
