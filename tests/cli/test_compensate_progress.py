"""compensate on a long reference: each pass over it said on a terminal, the --out file checked first.

A 60 s circle at 20 kHz over an identified Preisach model took four passes of the
compensator (the fade-in doubled twice, then the reference shaped into the records'
limits), 66 s of silence; and an --out file that may not be replaced was refused only
after them.
"""

import contextlib
import io

import numpy as np

from hammerstein.cli import compensate as compensate_cli
from hammerstein.cli.main import main
from hammerstein.compensation import drive as drive_module
from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
from hammerstein.io.presets import load_plant


def test_one_line_per_pass_over_the_reference(monkeypatch):
    plant = load_plant("rakotondrabe-2dof", dynamics=False)
    comp = InverseMultiplicativeCompensator(plant.hysteresis)
    T = plant.sampling_period
    t = np.arange(4000) * T
    yr = 30 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    calls = []
    real = drive_module._compensate

    def counted(*args, **kwargs):
        calls.append(args[1].shape[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(drive_module, "_compensate", counted)
    lines = []
    drive_module.hardware_drive(comp, yr, T, 200, progress=lines.append)
    # every pass of the compensator over the whole reference is said, in order, once
    assert len(lines) == len(calls) >= 1 and set(calls) == {4000}
    assert [line.split(" over ")[0] for line in lines] == [f"pass {k + 1}" for k in range(len(calls))]
    assert "fade-in" in lines[0] and "4000 samples" in lines[0]


def test_a_file_that_may_not_be_replaced_is_refused_before_the_drive(tmp_path, monkeypatch):
    (tmp_path / "f.csv").write_text("a,b\n")

    def never(*args, **kwargs):
        raise AssertionError("the drive was computed before --out was checked")

    monkeypatch.setattr(compensate_cli, "compensate", never)
    err = io.StringIO()
    with contextlib.chdir(tmp_path), contextlib.redirect_stderr(err):
        code = main(["compensate", "rakotondrabe-2dof", "--reference",
                     '{ kind = "circle", radius = 30, frequency = 100, periods = 6 }',
                     "--out", "f.csv"])
    assert code == 2 and "f.csv exists and was not written by hammerstein" in err.getvalue()
    assert (tmp_path / "f.csv").read_text() == "a,b\n"
