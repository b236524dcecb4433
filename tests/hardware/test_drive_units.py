"""A drive file's header and the commands' lines give units in the model's units.

A model whose inputs are in mV and outputs in nm (its [model] input_unit, output_unit) was
written drive files headed ``ux, uy [V]``, ``peak input and slew: ux 20 V 2398 V/s``, ``ends
at ux 16.9 V``, ``from the rest output x = ... µm`` and told ``y asks -80..80 µm`` on stderr.
The expected lines are computed from the drive file's own samples; evaluate and learn read
the drive back (its rest output in nm).
"""

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cli_run import run_cli
from hammerstein.compensation.drive import read_signals
from hammerstein.io.presets import load_plant

OUTSIDE_GPI = Path(__file__).parent / "data" / "outside-gpi-identified.toml"
REF = '{ kind = "circle", radius = 80, frequency = 20, periods = 4 }'

#: a unit token in V or µm: "V", "V/s", "[V]", "µm" (not mV, kV, nm, µs)
OTHER_UNIT = re.compile(r"(?<![\w/])V(?:/s)?(?![\w])|µm")


def _header(path):
    return [line for line in path.read_text(encoding="utf-8").splitlines()
            if line.startswith("#")]


def _unit_lines(lines):
    return [line for line in lines if OTHER_UNIT.search(line)]


@pytest.fixture(scope="module")
def mv_nm(tmp_path_factory):
    """The outside actuator's model with its inputs in mV and outputs in nm, a compensate
    drive for it and the model's response to that drive."""
    d = tmp_path_factory.mktemp("units")
    text = OUTSIDE_GPI.read_text(encoding="utf-8")
    text = text.replace('\ninput_unit = "V"\n', '\ninput_unit = "mV"\n').replace(
        '\noutput_unit = "µm"\n', '\noutput_unit = "nm"\n')
    assert text.count('input_unit = "mV"') == 2 and text.count('output_unit = "nm"') == 2
    (d / "mv.toml").write_text(text, encoding="utf-8")
    assert load_plant(str(d / "mv.toml")).units == ("mV", "nm")
    res = run_cli("compensate", "mv.toml", "--reference", REF, "--out", "u0.csv", "--predicted",
                  cwd=d)
    assert res.returncode == 0, res.stderr
    t, u, _ = read_signals(d / "u0.csv", ["ux", "uy"])
    y, _ = load_plant(str(d / "mv.toml")).simulate(u)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(d / "y0.csv", index=False)
    return d, res


def test_compensate_writes_the_models_units(mv_nm):
    d, res = mv_nm
    head = _header(d / "u0.csv")
    assert _unit_lines(head) == [] and _unit_lines(res.stdout.splitlines()) == []
    assert _unit_lines(res.stderr.splitlines()) == []
    assert head[0] == ("# hammerstein compensate drive: t [s]; ux, uy [mV]; x_predicted, "
                       "y_predicted [nm] (model)")
    # the numbers from the drive's samples, from rest (0: the range is +-20 mV)
    table = pd.read_csv(d / "u0.csv", comment="#")
    u = table[["ux", "uy"]].to_numpy().T
    T = float(table.t[1] - table.t[0])
    slew = np.abs(np.diff(u, axis=1, prepend=0.0)).max(axis=1) / T
    peaks = ", ".join(f"{n} {np.abs(row).max():.4g} mV {s:.4g} mV/s"
                      for n, row, s in zip(("ux", "uy"), u, slew))
    assert any(line.startswith(f"# peak input and slew: {peaks}") for line in head), head
    assert f"peak {peaks}" in res.stdout
    ends = f"# ends at ux {u[0, -1]:.4g} mV, uy {u[1, -1]:.4g} mV ("
    assert any(line.startswith(ends) for line in head), head
    rest = next(line for line in head if "from the rest output" in line)
    assert re.search(r"from the rest output x = \S+ nm, y = \S+ nm \(the model's output at "
                     r"0 mV\)$", rest), rest
    shaped = [line for line in head if line.startswith("# shaped: ")]
    assert shaped and all(" mV per sample" in line for line in shaped), shaped
    assert re.search(r"^note: .*y asks -80\.\.80 nm, the model reaches \S+ nm", res.stderr, re.M)


def test_evaluate_reads_the_rest_output_of_a_drive_in_nm(mv_nm):
    """evaluate fades the reference in from the rest output the header gives in nm (it read
    none there, and faded from 0)."""
    d, _ = mv_nm
    rest = next(line for line in _header(d / "u0.csv") if "from the rest output" in line)
    said = [float(v) for v in re.findall(r"\b[xy] = (\S+) nm", rest)]
    assert len(said) == 2 and min(abs(v) for v in said) > 0
    res = run_cli("evaluate", "--reference", REF, "--drive", "u0.csv", "--measured", "y0.csv",
                  "--model", "mv.toml", "--out", "ev", cwd=d)
    assert res.returncode == 0, res.stderr
    ts = pd.read_csv(d / "ev" / "timeseries-measured.csv")
    assert ts.iloc[0, 1:3].tolist() == pytest.approx(said, rel=1e-8)


def test_learn_writes_the_models_units(mv_nm):
    d, _ = mv_nm
    res = run_cli("learn", "mv.toml", "--reference", REF, "--drive", "u0.csv", "--measured",
                  "y0.csv", "--out", "u1.csv", "--delay", "0", "--history", "hist", cwd=d)
    assert res.returncode == 0, res.stderr
    head = _header(d / "u1.csv")
    best = _header(d / "hist" / "best-trial.csv")
    for lines in (head, best, res.stdout.splitlines(), res.stderr.splitlines()):
        assert _unit_lines(lines) == [], lines
    assert head[0] == "# hammerstein learn drive: t [s]; ux, uy [mV]"
    assert best[0].startswith("# hammerstein learn best trial 0: the drive [mV], its measured "
                              "response [nm]")
    u1 = pd.read_csv(d / "u1.csv", comment="#")[["ux", "uy"]].to_numpy().T
    assert f"# ends at ux {u1[0, -1]:.4g} mV, uy {u1[1, -1]:.4g} mV (" in "\n".join(head)
    # the settled error, in nm, against the circle's radius 80 nm
    m = re.search(r"max Euclidean error (\S+) nm \((\S+) % of 80 nm\)", res.stdout)
    assert m and float(m.group(2)) == pytest.approx(100 * float(m.group(1)) / 80, rel=2e-3)
    assert re.search(r"^note: .*y asks -80\.\.80 nm", res.stderr, re.M)
    # learn reads its own drive back: a second trial from u1.csv
    t, u, _ = read_signals(d / "u1.csv", ["ux", "uy"])
    y, _ = load_plant(str(d / "mv.toml")).simulate(u)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(d / "y1.csv", index=False)
    again = run_cli("learn", "mv.toml", "--reference", REF, "--drive", "u1.csv", "--measured",
                    "y1.csv", "--out", "u2.csv", "--delay", "0", "--history", "hist", cwd=d)
    assert again.returncode == 0, again.stderr
    assert _unit_lines(_header(d / "u2.csv") + again.stderr.splitlines()) == []
    # the history's columns are named in nm, and the second trial read them back (its best
    # score from learning.csv, the rows of the first trial kept)
    hist = pd.read_csv(d / "hist" / "history.csv")
    assert hist.columns[2:4].tolist() == ["max_error_nm", "rms_error_nm"]
    assert hist["iteration"].tolist() == [0, 0, 1, 1]
    settled = pd.read_csv(d / "hist" / "settled.csv")
    assert settled.columns[1:4].tolist() == ["settled_max_euclidean_nm", "settled_rms_euclidean_nm",
                                             "judged_nm"] and settled["trial"].tolist() == [0, 1]
    state = (d / "hist" / "learning.csv").read_text(encoding="utf-8")
    assert "\nbest_score_nm," in state and "_um" not in state
    # the same actuator's model in µm may not add its errors to this nm history (it would
    # relabel the rows): one line, exit 1, the history as it was
    (d / "um.toml").write_text(OUTSIDE_GPI.read_text(encoding="utf-8"), encoding="utf-8")
    t, u, _ = read_signals(d / "u2.csv", ["ux", "uy"])      # the drive the history asks for next
    y, _ = load_plant(str(d / "mv.toml")).simulate(u)
    pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(d / "y2.csv", index=False)
    before = {p.name: p.read_bytes() for p in (d / "hist").iterdir()}
    um = run_cli("learn", "um.toml", "--reference", REF, "--drive", "u2.csv", "--measured",
                 "y2.csv", "--out", "u9.csv", "--delay", "0", "--history", "hist", cwd=d)
    assert um.returncode == 1 and len(um.stderr.strip().splitlines()) == 1, um.stderr
    assert "holds errors in nm (max_error_nm), this model's output unit is µm" in um.stderr
    assert {p.name: p.read_bytes() for p in (d / "hist").iterdir()} == before
    assert not (d / "u9.csv").exists()


@pytest.mark.parametrize("command", ["compensate", "learn", "evaluate"])
def test_a_references_problem_is_told_in_the_models_output_unit(mv_nm, command):
    """A reference table's lengths are in the model's output unit: a negative radius is told
    "[nm]", not the scenarios' "[µm]"; nothing is written."""
    d, _ = mv_nm
    bad = '{ kind = "circle", radius = -2, frequency = 20, periods = 4 }'
    args = {"compensate": ("compensate", "mv.toml"),
            "learn": ("learn", "mv.toml", "--drive", "u0.csv", "--measured", "y0.csv"),
            "evaluate": ("evaluate", "--drive", "u0.csv", "--measured", "y0.csv")}[command]
    out = "bad.csv" if command != "evaluate" else "bad-report"
    res = run_cli(*args, "--reference", bad, "--out", out, cwd=d)
    assert res.returncode in (1, 2) and not (d / out).exists()
    assert "reference.radius: expected a number > 0 [nm], found -2" in res.stderr, res.stderr
    assert "µm" not in res.stderr


@pytest.mark.parametrize("radius, implausible", [(20_000, False), (2e7, True)])
def test_a_references_size_is_judged_in_the_models_output_unit(mv_nm, radius, implausible):
    """A 20 µm circle given as 20 000 nm to a model in nm is no unit slip (it was warned as
    20 000 µm, beyond 10 mm); 2e7 nm (20 mm) is, and the warning says nm."""
    d, _ = mv_nm
    ref = f'{{ kind = "circle", radius = {radius:g}, frequency = 20, periods = 4 }}'
    res = run_cli("compensate", "mv.toml", "--reference", ref, "--out", "far.csv", cwd=d)
    lines = [line for line in res.stderr.splitlines() if "implausible" in line]
    if implausible:
        assert len(lines) == 1 and f"reference peak {radius:g} nm (" in lines[0], res.stderr
        assert lines[0].endswith("is it in the model's output unit, nm?")
    else:
        assert lines == [], res.stderr


def test_a_glitch_in_a_file_reference_is_told_in_the_models_unit(mv_nm):
    """A file reference's sample beyond the compensators' bound (10 x the model's largest
    output, the one the exported C skips a sample at) is refused in nm: it said ``1e+07 µm,
    beyond the 177220 µm`` of a model in nm. Nothing is written."""
    from hammerstein.compensation.reference_check import reference_bound
    d, _ = mv_nm
    t = np.arange(400) * 2.5e-4
    x, y = 80.0 * np.cos(2 * np.pi * 20 * t), 80.0 * np.sin(2 * np.pi * 20 * t)
    bound = reference_bound(load_plant(str(d / "mv.toml")).hysteresis)
    x[300] = 2.0 * bound
    pd.DataFrame({"t": t, "x": x, "y": y}).to_csv(d / "glitch.csv", index=False)
    res = run_cli("compensate", "mv.toml", "--reference", "glitch.csv", "--out", "glitch-u.csv",
                  cwd=d)
    assert res.returncode == 1 and not (d / "glitch-u.csv").exists()
    # (the file is re-sampled at the model's period and faded in: its glitch's sample and
    # value move, the bound does not)
    assert re.search(rf"sample \d+ of output 'x' is [\d.e+]+ nm, beyond the {bound:.6g} nm a "
                     rf"compensator takes", res.stderr), res.stderr
    assert "µm" not in res.stderr, res.stderr


def test_the_range_warning_gives_the_models_unit(tmp_path):
    """Beyond the range a model in nm was identified on (a classical PI's check), the
    warning's lengths are nm: it said ``x: 150 µm > ...`` of a model saved in nm."""
    from hammerstein.compensation.reference_range import check_reference_range
    from hammerstein.exceptions import RangeWarning
    from hammerstein.io.presets import load_model, save_model
    from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
    r = np.linspace(0.0, 9.0, 6)
    pi = [PrandtlIshlinskii(r, [1.0, 0.3, 0.2, 0.1, 0.05, 0.02]) for _ in range(2)]
    model = MultivariablePI([[pi[0], None], [None, pi[1]]], ["ux", "uy"], ["x", "y"],
                            input_amplitude=[10.0, 10.0])
    save_model(model, tmp_path / "m.toml", input_unit="mV", output_unit="nm")
    loaded = load_model(tmp_path / "m.toml")
    t = np.arange(200) / 200
    far = 150.0 * np.vstack([np.cos(2 * np.pi * t), np.sin(2 * np.pi * t)])
    with pytest.warns(RangeWarning) as caught:
        ratio = check_reference_range(loaded, far)
    text = str(caught[0].message)
    assert np.all(ratio > 1) and "x: 150 nm > " in text and "µm" not in text, text
