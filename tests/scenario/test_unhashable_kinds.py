"""A ``kind`` written as a list or a table is an error that names it, with every other problem.

It was ``unexpected TypeError: unhashable type: 'list'`` (``kind not in DICT``), and validate
stopped before the file's other problems.
"""

import pytest

from hammerstein.cli.main import main

CASE = ('[[cases]]\nname = "c"\nsettle_periods = "one"\n'
        'reference = {{ kind = {ref}, radius = 10.0, frequency = 50.0, periods = 2 }}\n')


@pytest.mark.parametrize("top, ref, said", [
    ('[compensator]\nkind = ["multivariable"]\n', '"circle"',
     "compensator.kind: expected one of 'none'"),
    ('[compensator]\nkind = "multivariable"\n', '{}', "cases[0].reference.kind: expected one of 'sine'"),
    ('kind = ["cases"]\n[compensator]\nkind = "multivariable"\n', '"circle"', ": kind: expected one of"),
])
def test_a_list_or_table_kind_is_named(tmp_path, capsys, top, ref, said):
    path = tmp_path / "s.toml"
    path.write_text(top + '[plant]\npreset = "rakotondrabe-2dof"\n' + CASE.format(ref=ref))
    assert main(["validate", str(path)]) == 1
    err = capsys.readouterr().err
    assert "unexpected" not in err and "TypeError" not in err
    assert said in err
    if "kind = [\"cases\"]" not in top:          # a file's kind stops at once; a case's do not
        assert "settle_periods: expected a number" in err


def test_a_list_dynamics_kind_in_a_model_file_is_named(tmp_path, capsys):
    from pathlib import Path

    from hammerstein.io.presets import resolve_preset
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    text = text.replace('kind = "bending_modes"', 'kind = []', 1)
    assert 'kind = []' in text
    (tmp_path / "p.toml").write_text(text)
    code = main(["compensate", str(tmp_path / "p.toml"), "--reference",
                 '{ kind = "circle", radius = 10, frequency = 50, periods = 2 }',
                 "--out", str(tmp_path / "d.csv")])
    err = capsys.readouterr().err
    assert code == 1 and "dynamics.kind: expected 'bending_modes'" in err and "found []" in err
    assert "unexpected" not in err


@pytest.mark.parametrize("old, new, said", [
    ("natural_frequency = [", 'natural_frequency = ["420 Hz", ',
     "dynamics.natural_frequency: expected numbers [Hz], one per output, found '420 Hz'"),
    ("damping_ratio = [", 'damping_ratio = ["3 %", ',
     "dynamics.damping_ratio: expected numbers [a ratio, 0.03 for 3 %], one per output, found '3 %'"),
    # a boolean is an int to Python: true became a 1 Hz mode
    ("natural_frequency = [", "natural_frequency = [true, ",
     "dynamics.natural_frequency: expected numbers [Hz], one per output, found True"),
])
def test_a_dynamics_value_that_is_not_a_number_is_named(tmp_path, capsys, old, new, said):
    import re
    from pathlib import Path

    from hammerstein.io.presets import resolve_preset
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    # the first value of the list replaced
    text = re.sub(re.escape(old) + r"\s*[-0-9.e+]+\s*,?", new.rstrip(", ") + ", ", text, count=1)
    assert new.rstrip(", ") in text
    (tmp_path / "p.toml").write_text(text)
    for command in (["compensate", str(tmp_path / "p.toml"), "--reference",
                     '{ kind = "circle", radius = 10, frequency = 50, periods = 2 }',
                     "--out", str(tmp_path / "d.csv")],
                    ["export", str(tmp_path / "p.toml"), "--out", str(tmp_path / "c")]):
        code = main(command)
        err = capsys.readouterr().err
        assert code == 1 and said in err and "unexpected" not in err, err
        assert len(err.strip().splitlines()) == 1
