"""compensate and learn repeat identify's warning when a preset's dynamics fitted their
held-out broadband records poorly (``[identification.dynamics] held_out_fit_percent``)."""

import pytest

from hammerstein.cli._hardware import load_actuator
from hammerstein.cli.main import main
from hammerstein.io.presets import resolve_preset


def _preset(tmp_path, fit):
    text = resolve_preset("rakotondrabe-2dof").read_text()
    if fit is not None:
        text += f"\n[identification.dynamics]\nheld_out_fit_percent = {fit}\n"
    path = tmp_path / "stage.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("fit, warned", [(-13.5, True), (89.0, True), (97.0, False), (None, False)])
def test_the_actuator_carries_the_poor_fit(tmp_path, fit, warned):
    plant = load_actuator(str(_preset(tmp_path, fit)))
    assert (plant.dynamics_problem is not None) == warned
    if warned:
        assert f"only {fit:.3g} %" in plant.dynamics_problem and "learn" in plant.dynamics_problem


def test_compensate_warns(tmp_path, capsys):
    path = _preset(tmp_path, -13.5)
    status = main(["compensate", str(path), "--reference",
                   '{ kind = "circle", radius = 10, frequency = 5, periods = 2 }',
                   "--out", str(tmp_path / "drive.csv")])
    err = capsys.readouterr().err
    assert status == 0
    assert "warning: stage.toml: its dynamics fitted the held-out broadband records at only " \
           "-13.5 %" in err


@pytest.mark.parametrize("fault", ["nan", "missing", "columns"])
def test_learn_s_bad_measured_file_is_one_line_even_with_a_poor_fit(tmp_path, capsys, fault):
    """The warning came before the files were read: a NaN in the measured response gave the
    warning line and then the error line (two lines on stderr for a bad input)."""
    path = _preset(tmp_path, -13.5)
    ref = '{ kind = "circle", radius = 10, frequency = 50, periods = 4 }'
    drive = tmp_path / "drive.csv"
    assert main(["compensate", str(path), "--reference", ref, "--out", str(drive)]) == 0
    rows = [ln for ln in drive.read_text().splitlines() if ln and not ln.startswith("#")]
    n = len(rows) - 1
    measured = tmp_path / "measured.csv"
    head = "t,x,y" if fault != "columns" else "t,x_um,y_um"
    cells = [f"{k * 5e-5!r},{'nan' if fault == 'nan' and k == n // 2 else 1.0},0.5"
             for k in range(n)]
    if fault != "missing":
        measured.write_text(head + "\n" + "\n".join(cells) + "\n")
    capsys.readouterr()
    out = tmp_path / "next.csv"
    status = main(["learn", str(path), "--reference", ref, "--drive", str(drive),
                   "--measured", str(measured), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 1 and not out.exists()
    assert err.count("\n") == 1 and err.startswith("hammerstein learn: error: --measured: "), err
