"""identify warns when the numbers look like another unit than the one declared, and says why
a record was fitted on fewer samples than its file holds.

A tester's x written in nm gave a 2.346e+04 µm range, y in metres 3.181e-05 µm, time in ms a
sampling period of 0.1 s, all accepted without a word (nothing is converted on reading,
docs/records.md). The expectations are the records' own spans, computed here.
"""

import numpy as np
import pytest

from hammerstein.cli.main import main
from hysteresis_records import decreasing_sine_records, write
from hammerstein.signals.excitation import excitation_set
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii

T = 1e-3


def _actuator():
    r = np.linspace(0.0, 9.0, 6)
    x = PrandtlIshlinskii(r, [1.0, 0.3, 0.2, 0.1, 0.05, 0.02])
    y = PrandtlIshlinskii(r, [0.8, 0.25, 0.15, 0.1, 0.05, 0.02])
    return MultivariablePI([[x, None], [None, y]], ["ux", "uy"], ["x", "y"])


def _files(d, x_scale=1.0, y_scale=1.0, t_scale=1.0):
    return decreasing_sine_records(d, _actuator(), 0.01, "h", T, (x_scale, y_scale), t_scale)


def _identify(files, tmp_path, capsys):
    assert main(["identify", *files, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", "classical", "--out", str(tmp_path / "m.toml")]) == 0
    return capsys.readouterr()


def _span(files, col):
    return max(float(np.ptp(np.loadtxt(f, delimiter=",", skiprows=1)[:, col])) for f in files)


def test_outputs_in_nm_and_metres_and_a_time_in_ms_are_warned(tmp_path, capsys):
    files = _files(tmp_path, x_scale=1e3, y_scale=1e-6, t_scale=1e3)
    err = _identify(files, tmp_path, capsys).err
    warn = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    x = [ln for ln in warn if "output 'x'" in ln]
    y = [ln for ln in warn if "output 'y'" in ln]
    t = [ln for ln in warn if "time column 't'" in ln]
    assert len(x) == len(y) == len(t) == 1, err
    assert f"spans {_span(files, 3):.4g} µm" in x[0] and "in nm" in x[0] and "--output-unit" in x[0]
    assert f"spans {_span(files, 4):.4g} µm" in y[0] and "metres" in y[0]
    assert "sampling period 1 s" in t[0] and "--sampling-period" in t[0]


def test_an_output_in_mm_is_warned_by_its_gain_per_volt(tmp_path, capsys):
    """A stage's x in mm spans more than 0.01 (the range check's floor: 0.078 for a 78 µm
    stage, exit 0 without a word) but moves less than 1e-3 "µm" per volt of its input."""
    files = _files(tmp_path, x_scale=0.5e-3)
    span_x, span_ux = _span(files, 3), _span(files, 1)
    assert span_x > 0.01 and span_x / span_ux < 1e-3        # what the range check cannot see
    warn = [ln for ln in _identify(files, tmp_path, capsys).err.splitlines()
            if ln.startswith("warning:") and "output '" in ln]
    assert len(warn) == 1 and "output 'x'" in warn[0], warn
    assert f"spans {span_x:.4g} µm" in warn[0] and f"{span_x / span_ux:.3g} µm/V" in warn[0]
    assert f"over ux's {span_ux:.4g} V" in warn[0] and "in mm?" in warn[0]


def test_records_in_um_and_s_are_not_warned(tmp_path, capsys):
    err = _identify(_files(tmp_path), tmp_path, capsys).err
    assert "spans" not in err and "time column" not in err, err


def test_a_declared_unit_is_not_second_guessed(tmp_path, capsys):
    files = _files(tmp_path, x_scale=1e3, y_scale=1e3)
    assert main(["identify", *files, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", "classical", "--output-unit", "nm",
                 "--out", str(tmp_path / "m.toml")]) == 0
    assert "spans" not in capsys.readouterr().err


def test_a_model_file_in_nm_gives_drives_in_nm(tmp_path, capsys):
    """A model file identified in nm (no --dynamics: no [preset] table) is compensated in nm:
    the drive's header gives its rest output in nm. compensate read such a file without its
    units and labelled a drive for a model in nm with µm."""
    files = _files(tmp_path, x_scale=1e3, y_scale=1e3)
    model = tmp_path / "m.toml"
    assert main(["identify", *files, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                 "--model", "classical", "--output-unit", "nm", "--out", str(model)]) == 0
    drive = tmp_path / "u.csv"
    assert main(["compensate", str(model), "--reference",
                 '{ kind = "circle", radius = 2000, frequency = 0.5, periods = 2 }',
                 "--out", str(drive)]) == 0
    capsys.readouterr()
    header = [ln for ln in drive.read_text().splitlines() if ln.startswith("#")]
    rest = next(ln for ln in header if "from the rest output" in ln)
    assert rest.count(" nm") >= 2 and "µm" not in rest, rest


def test_a_record_cut_after_its_levels_says_so(tmp_path, capsys):
    """A unipolar input's record ramps back to rest after its levels: the classical PI is
    fitted on the levels only (103257 of 105000 samples said without a reason before)."""
    recs = excitation_set(["ux", "uy"], 5.0, T, centre=[0.0, 5.0], multisine_periods=1)
    act = _actuator()
    files = []
    for r in recs:
        if r.kind == "hysteresis":
            y = act.simulate(r.u)[0]
            write(tmp_path / f"{r.name}.csv", r.time, r.u, y)
            files.append(str(tmp_path / f"{r.name}.csv"))
    out = _identify(files, tmp_path, capsys).out
    whole = np.loadtxt(files[1], delimiter=",", skiprows=1).shape[0]
    line = [ln for ln in out.splitlines() if ln.startswith(f"{files[1]}: ")][0]
    n = int(line[len(files[1]) + 2:].split()[0])
    assert n < whole
    assert f"{n} samples (of {whole}: what follows the last amplitude level" in line


def test_a_model_file_with_creep_and_no_dynamics_keeps_its_creep(tmp_path):
    """A model file with a [creep] table and no [dynamics] (identify --creep-records without
    --dynamics) is read with its creep by the commands as by a scenario: compensate, learn and
    evaluate read it without, and their predictions lacked the drift the file holds."""
    from pathlib import Path

    from hammerstein.cli._hardware import load_actuator
    preset = Path(__file__).resolve().parents[2] / "scenarios" / "presets" / "realistic-b.toml"
    kept, skip = [], False
    for line in preset.read_text().splitlines():      # the model file: no [preset], no [dynamics]
        if line.startswith("["):
            skip = line.split("]")[0] in ("[preset", "[dynamics")
        if not skip:
            kept.append(line)
    model = tmp_path / "m.toml"
    model.write_text("\n".join(kept) + "\n")
    plant = load_actuator(str(model), 5e-5)
    assert plant.creep is not None
    u = np.zeros((2, 40000))
    u[0, 100:] = 5.0                  # a 5 V step held 2 s: the output creeps on after it
    y = plant.simulate(u)[0]
    assert y[0, -1] - y[0, 200] > 0.005 * abs(y[0, 200] - y[0, 0])
