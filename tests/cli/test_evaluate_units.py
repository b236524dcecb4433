"""evaluate labels a drive's measurement in the drive's units: a model identified in nm and mV.

``identify --output-unit nm --input-unit mV`` writes a model whose drives state nm and mV in
their header (``compensate drive: t [s]; ux, uy [mV]``, ``from the rest output x = 0.07 nm``),
and the measurement of such a drive is in nm. evaluate computed its metrics on those values
as they are but labelled them µm and V: ``x_um``, ``ux_V`` columns, a ``unit`` column of µm,
a figure in µm whose error axis was rescaled "to nm" (a factor 1000 on nm values), and learn's
convergence figure said µm too.
"""

import numpy as np
import pytest

import hammerstein.cli._learn_history as history
import hammerstein.cli.evaluate as evaluate
from hammerstein.cli._hardware import load_actuator
from hammerstein.cli.main import main
from hammerstein.compensation.drive import read_signals
from hammerstein.compensation.drive_files import drive_units
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.report.figures import plt
from hammerstein.report.ilc_figure import convergence_figure
from hammerstein.report.trajectories import trajectory_figure
from hysteresis_records import decreasing_sine_records, write

T = 1e-3
REFERENCE = '{ kind = "circle", radius = 2000, frequency = 2, periods = 6 }'


def _actuator():
    r = np.linspace(0.0, 9.0, 6)
    x = PrandtlIshlinskii(r, [1.0, 0.3, 0.2, 0.1, 0.05, 0.02])
    y = PrandtlIshlinskii(r, [0.8, 0.25, 0.15, 0.1, 0.05, 0.02])
    return MultivariablePI([[x, None], [None, y]], ["ux", "uy"], ["x", "y"])


def _records_in_nm_and_mV(d):
    """The actuator's records with the outputs in nm and the inputs in mV."""
    files = decreasing_sine_records(d, _actuator(), 0.01, "h", T, (1e3, 1e3))
    for f in files:
        a = np.loadtxt(f, delimiter=",", skiprows=1)
        write(f, a[:, 0], 1e3 * a[:, 1:3].T, a[:, 3:5].T)
    return files


def _labels(fig):
    return [label for ax in fig.axes for label in (ax.get_xlabel(), ax.get_ylabel()) if label]


@pytest.fixture
def figures(monkeypatch):
    """The figures evaluate and learn draw, as drawn (their axis labels read back)."""
    drawn = {}

    def keep(name, function):
        def wrapper(*args, **kwargs):
            drawn[name] = function(*args, **kwargs)
            return drawn[name]
        return wrapper
    monkeypatch.setattr(evaluate, "trajectory_figure", keep("trajectory", trajectory_figure))
    monkeypatch.setattr(history, "convergence_figure", keep("convergence", convergence_figure))
    yield drawn
    for fig in drawn.values():
        plt.close(fig)


def test_a_drive_in_nm_and_mV_is_evaluated_and_learnt_in_nm_and_mV(tmp_path, capsys, figures):
    """identify in nm and mV, compensate a circle, "measure" the model's response to the drive
    (nm), evaluate and learn: every label is nm, mV or mV/s; none is µm or V."""
    model = tmp_path / "m.toml"
    assert main(["identify", *_records_in_nm_and_mV(tmp_path), "--inputs", "ux,uy",
                 "--outputs", "x,y", "--time", "t", "--model", "classical",
                 "--input-unit", "mV", "--output-unit", "nm", "--out", str(model)]) == 0
    drive = tmp_path / "u.csv"
    assert main(["compensate", str(model), "--reference", REFERENCE, "--out", str(drive)]) == 0
    plant = load_actuator(str(model), T)
    assert plant.units == ("mV", "nm")
    t, u, _ = read_signals(drive, ["ux", "uy"])
    y, _ = plant.simulate(u, plant.rest_state())
    measured = tmp_path / "y.csv"
    write(measured, t, u, y)
    capsys.readouterr()
    out = tmp_path / "report"
    assert main(["evaluate", "--reference", REFERENCE, "--drive", str(drive),
                 "--measured", str(measured), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "max Euclidean error" in said and " nm," in said and "µm," not in said, said

    head = (out / "timeseries-measured.csv").read_text().splitlines()[0]
    assert head == "time_s,x_ref_nm,y_ref_nm,x_nm,y_nm,ux_mV,uy_mV"
    rows = [line.split(",") for line in (out / "metrics.csv").read_text().splitlines()[1:]]
    units = {(r[1], r[2]): r[4] for r in rows}
    assert units[("x", "rms_error")] == units[("x+y", "max_euclidean_error")] == "nm"
    assert units[("ux", "peak_input")] == "mV" and units[("uy", "peak_slew")] == "mV/s"
    assert units[("x+y", "max_euclidean_error_percent")] == "%"
    assert units[("x+y", "delay")] == "s" and units[("x+y", "delay_samples")] == ""
    assert not {"µm", "V", "V/s"} & set(units.values()), units
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "| x+y | max_euclidean_error |" in report and "| nm |" in report
    assert "| ux | peak_slew |" in report and "| mV/s |" in report
    assert "radius 2000 nm" in report
    assert "µm |" not in report and "[µm]" not in report and "[V]" not in report

    labels = _labels(figures["trajectory"])
    assert {"x [nm]", "y [nm]", "displacement [nm]", "voltage [mV]",
            "tracking error [nm]"} <= set(labels), labels
    assert not any("µm" in label or "[V]" in label for label in labels), labels

    # a measured file with a units row in the model's units is read (it was refused: "expected
    # V or µm"), by evaluate and by learn
    rows = measured.read_text().splitlines()
    header = rows[0].split(",")
    row = ",".join("s" if c == "t" else "mV" if c.startswith("u") else "nm" for c in header)
    labelled = tmp_path / "y-units.csv"
    labelled.write_text("\n".join([rows[0], row] + rows[1:]) + "\n")
    assert main(["evaluate", "--reference", REFERENCE, "--drive", str(drive), "--measured",
                 str(labelled), "--out", str(tmp_path / "labelled")]) == 0
    assert main(["learn", str(model), "--reference", REFERENCE, "--drive", str(drive),
                 "--measured", str(labelled), "--out", str(tmp_path / "next-labelled.csv")]) == 0

    # the model given instead of the drive: its units
    capsys.readouterr()
    assert main(["evaluate", "--reference", REFERENCE, "--model", str(model), "--measured",
                 str(measured), "--out", str(tmp_path / "by-model")]) == 0
    head = (tmp_path / "by-model" / "timeseries-measured.csv").read_text().splitlines()[0]
    assert head.startswith("time_s,x_ref_nm,y_ref_nm,x_nm,y_nm"), head
    assert " nm," in capsys.readouterr().out

    assert main(["learn", str(model), "--reference", REFERENCE, "--drive", str(drive),
                 "--measured", str(measured), "--out", str(tmp_path / "next.csv"),
                 "--history", str(tmp_path / "history")]) == 0
    labels = _labels(figures["convergence"])
    assert "tracking error [nm]" in labels and not any("µm" in lb for lb in labels), labels


@pytest.mark.parametrize("text, expected", [
    ("# hammerstein compensate drive: t [s]; ux, uy [mV]; x_predicted, y_predicted [nm] "
     "(model)\n# actuator m.toml, kind multivariable, sampling period 0.001 s, fade-in 500 "
     "samples (0.5 s, excluded from the metrics) from the rest output x = 1.2005 nm, "
     "y = 1.4454 nm (the model's output at 0 mV)\nt,ux,uy\n0,0,0\n", ("mV", "nm")),
    ("# hammerstein learn drive: t [s]; ux, uy [kV]; x_learnt, y_learnt [mm]: the learnt "
     "reference the drive was computed for (fade-in included)\n# actuator m.toml, kind "
     "ilc, sampling period 0.001 s, fade-in 500 samples (0.5 s, excluded from the "
     "metrics)\nt,ux,uy,x_learnt,y_learnt\n0,0,0,0,0\n", ("kV", "mm")),
    ("t,ux,uy,x,y\n0,0,0,0,0\n", ("V", "µm")),                 # a record: no header
    ("# hammerstein compensate drive: t [s]\n# actuator realistic-a, fade-in 500 samples\n"
     "t,ux\n0,0\n", ("V", "µm")),                              # a header that states no unit
])
def test_drive_units_reads_the_header_of_compensate_and_learn(tmp_path, text, expected):
    """The inputs' unit after their names on the first line, the outputs' after the rest
    output's values or after a learnt reference's columns; µm and V where none is stated."""
    path = tmp_path / "drive.csv"
    path.write_text(text, encoding="utf-8")
    assert drive_units(path) == expected


def test_the_trajectory_figure_is_labelled_in_the_units_it_is_given():
    """Every axis in the given units; an error below 0.1 in nm is not rescaled as one in µm
    is (to nm, a factor 1000 on values already in nm)."""
    t = np.arange(400) * 1e-3
    r = np.vstack([np.sin(2 * np.pi * 5 * t), np.cos(2 * np.pi * 5 * t)])
    y = r - 0.02
    u = 2.0 * r
    for units, expect in (((("mV", "nm")), {"x [nm]", "y [nm]", "displacement [nm]",
                                             "voltage [mV]", "tracking error [nm]",
                                             "||Y_r - Y|| over x, y [nm]"}),
                          (("V", "µm"), {"x [µm]", "y [µm]", "displacement [µm]",
                                         "voltage [V]", "tracking error [nm]"})):
        fig = trajectory_figure(t, r, y, ["x", "y"], "title", 0.1, inputs=u,
                                input_names=["ux", "uy"], units=units)
        try:
            labels = set(_labels(fig))
            assert expect <= labels, labels
            if units[1] == "nm":       # the errors as they are, 0.02 nm: not 20 "nm"
                top = max(abs(v) for v in fig.axes[3].get_ylim())
                assert top < 0.1, top
        finally:
            plt.close(fig)
