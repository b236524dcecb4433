"""`learn` runs what `compensate` runs with the same defaults.

tip-tilt-piston-z.toml: a tester's tip-tilt-piston platform identified in its three stacks'
own displacements (z1..z3 µm, classical PI with bending modes and creep): no gain makes
the classical law provably converge (smallest rho(I - K^-1 J) 1.75). `compensate` then runs
the law with check = warn by itself; `learn` with the same model and defaults refused with
exit 1 until --check warn was given.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.cli._hardware import load_actuator
from hammerstein.cli.main import main

PRESET = Path(__file__).parent / "data" / "tip-tilt-piston-z.toml"
REF = ('{ kind = "circle", radius = 1.5, frequency = 100, periods = 12, outputs = ["z1", "z2"], '
       'center = [5, 5, 5] }')


def test_learn_takes_compensates_default_check(tmp_path, capsys):
    drive = tmp_path / "d0.csv"
    assert main(["compensate", str(PRESET), "--reference", REF, "--out", str(drive)]) == 0
    said = capsys.readouterr().err
    assert "no gain makes the classical PI law provably converge" in said
    plant = load_actuator(str(PRESET))
    u = pd.read_csv(drive, comment="#")
    y, _ = plant.simulate(u[["u1", "u2", "u3"]].to_numpy().T, plant.rest_state())
    pd.DataFrame({"t": u["t"], "z1": y[0], "z2": y[1], "z3": y[2]}).to_csv(
        tmp_path / "m0.csv", index=False)
    code = main(["learn", str(PRESET), "--reference", REF, "--drive", str(drive),
                 "--measured", str(tmp_path / "m0.csv"), "--out", str(tmp_path / "d1.csv")])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "as with --check warn" in out.out + out.err      # said, as compensate says it
    u1 = pd.read_csv(tmp_path / "d1.csv", comment="#")[["u1", "u2", "u3"]].to_numpy()
    assert np.all(np.isfinite(u1)) and u1.min() >= 0.0 and u1.max() <= 100.0
