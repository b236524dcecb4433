"""export's amplifier and feedback options: usage errors exit 2 naming the option plainly,
``--slew-rate`` alone takes the range of the model's [amplifier] table, and no warning
line carries a Python class name."""

from __future__ import annotations

import pytest

from hammerstein.cli.main import main
from hammerstein.io.presets import resolve_preset


def _run(capsys, *argv):
    code = main(["export", *argv])
    return code, capsys.readouterr()


def _with_amplifier(tmp_path):
    path = tmp_path / "rk.toml"
    path.write_text(resolve_preset("rakotondrabe-2dof").read_text()
                    + "\n[amplifier]\nrange = [-10.0, 10.0]\n")
    return path


def test_slew_rate_alone_takes_the_range_of_the_amplifier_table(tmp_path, capsys):
    code, out = _run(capsys, str(_with_amplifier(tmp_path)), "--out", str(tmp_path / "o"),
                     "--name", "act", "--slew-rate", "4000")
    assert code == 0, out.err
    source = (tmp_path / "o" / "act.c").read_text()
    assert "act_u_min0 = -10.0;" in source and "act_u_step0 = 0.2" in source


def test_slew_rate_without_any_range_says_where_a_range_comes_from(tmp_path, capsys):
    code, out = _run(capsys, "rakotondrabe-2dof", "--out", str(tmp_path / "o"),
                     "--slew-rate", "4000")
    assert code == 2
    assert "no [amplifier] range" in out.err and "--amplifier-range MIN MAX" in out.err


@pytest.mark.parametrize("argv, said", [
    (["--amplifier-range", "10", "-10"], "--amplifier-range: expected MIN MAX"),
    (["--cutoff-hz", "100"], "--cutoff-hz: only used with --feedback lowpass"),
])
def test_bad_option_values_are_usage_errors(tmp_path, capsys, argv, said):
    code, out = _run(capsys, "rakotondrabe-2dof", "--out", str(tmp_path / "o"), *argv)
    assert code == 2
    assert len(out.err.strip().splitlines()) == 1 and said in out.err
    assert "--slew-rate" not in out.err and "(kind " not in out.err


def test_a_convergence_warning_names_no_python_class(tmp_path, capsys):
    code, out = _run(capsys, "rakotondrabe-2dof", "--out", str(tmp_path / "o"), "--kind",
                     "multivariable", "--gain", "identity", "--check", "warn")
    assert code == 0
    warning = [line for line in out.err.splitlines() if line.startswith("warning:")]
    assert warning and "gain:" in warning[0]
    assert "Warning:" not in out.err
