"""A DAQ CSV with a units row under its header is read without hand editing."""

import numpy as np
import pytest

from hammerstein.io.datafiles import read_record, read_records


def _write(path, header, units, sep=","):
    t = np.arange(50) * 1e-3
    u = 5 * np.sin(2 * np.pi * 20 * t)
    rows = [sep.join(header), sep.join(units)] + [sep.join(f"{v:.6g}" for v in r)
                                                  for r in zip(t, u, 2 * u)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return t, u


@pytest.mark.parametrize("units, sep", [(["s", "V", "µm"], ","), (["[s]", "[V]", "[um]"], ";"),
                                        (["sec", "volt", "micron"], "\t")])
def test_units_row_is_skipped(tmp_path, units, sep):
    path = tmp_path / "daq.csv"
    t, u = _write(path, ["time", "ux", "x"], units, sep)
    rec = read_record(path, input="ux", output="x", time="time")
    assert rec.n_samples == 50
    np.testing.assert_allclose(rec.u, u, atol=1e-5)
    np.testing.assert_allclose(rec.y, 2 * u, atol=1e-5)
    multi = read_records(path, inputs=["ux"], outputs=["x"], time="time")
    assert multi.n_samples == 50


def test_a_numeric_first_row_is_data(tmp_path):
    path = tmp_path / "plain.csv"
    path.write_text("time,ux,x\n0,0,0\n" + "".join(f"{k * 1e-3},{k},{2 * k}\n" for k in range(1, 20)))
    assert read_record(path, input="ux", output="x", time="time").n_samples == 20


def test_a_preamble_is_skipped_with_skip_rows(tmp_path):
    path = tmp_path / "daq.csv"
    t, u = _write(path, ["time", "ux", "x"], ["s", "V", "µm"])
    text = path.read_text(encoding="utf-8")
    path.write_text("Instrument: DAQ-9000\nSample rate: 1000 Hz\nDate: 2026-01-01\n" + text,
                    encoding="utf-8")
    rec = read_record(path, input="ux", output="x", time="time", skip_rows=3)
    assert rec.n_samples == 50
    np.testing.assert_allclose(rec.y, 2 * u, atol=1e-5)


def test_identify_reads_a_daq_file_with_preamble_and_units(tmp_path, capsys):
    from hammerstein.cli.main import main
    t = np.arange(4000) * 1e-3
    u = 10 * np.sin(2 * np.pi * t)                    # 1 Hz, 4 periods
    y = 2 * u + 0.5 * np.sign(np.gradient(u)) * (1 - np.abs(u) / 10)
    rows = ["Instrument: DAQ-9000", "Rate: 1 kHz", "time,ux,x", "s,V,um"]
    rows += [f"{a:.6g},{b:.6g},{c:.6g}" for a, b, c in zip(t, u, y)]
    data = tmp_path / "daq.csv"
    data.write_text("\n".join(rows) + "\n", encoding="utf-8")
    status = main(["identify", str(data), "--input", "ux", "--output", "x", "--time", "time",
                   "--skip-rows", "2", "--model", "classical", "--out", str(tmp_path / "m.toml")])
    assert status == 0, capsys.readouterr().err
    assert (tmp_path / "m.toml").exists()


# A units row or a column name in another unit than s, V, µm is refused, naming the column
# and the unit: read as s, V and µm it made a model 1000 times off (modes at 0.4 Hz).
@pytest.mark.parametrize("units, column, said", [
    (["ms", "V", "µm"], "time column 'time'", "ms"),
    (["s", "mV", "µm"], "input column 'ux'", "mV"),
    (["s", "V", "nm"], "output column 'x'", "nm"),
    (["[s]", "[V]", "[mm]"], "output column 'x'", "mm")])
def test_a_units_row_in_other_units_is_refused(tmp_path, units, column, said):
    from hammerstein.io.datafiles import DataFileError
    path = tmp_path / "daq.csv"
    _write(path, ["time", "ux", "x"], units)
    with pytest.raises(DataFileError, match=rf"daq.csv: {column}: the units row says '{said}', "
                                            rf"and \w+ are read in"):
        read_records(path, inputs=["ux"], outputs=["x"], time="time")


@pytest.mark.parametrize("name, unit", [("x_nm", "nm"), ("x [mm]", "mm"), ("x(m)", "m")])
def test_an_output_named_in_another_unit_is_refused(tmp_path, name, unit):
    from hammerstein.io.datafiles import DataFileError
    path = tmp_path / "daq.csv"
    _write(path, ["time", "ux", name], ["s", "V", ""])
    with pytest.raises(DataFileError, match=rf"output column '{re_escape(name)}' is named in "
                                            rf"{unit}, and outputs are read in µm"):
        read_record(path, input="ux", output=name, time="time")


def re_escape(text):
    import re
    return re.escape(text)


def test_declared_units_are_accepted(tmp_path):
    path = tmp_path / "daq.csv"
    t, u = _write(path, ["time", "ux_mV", "x"], ["s", "mV", "nm"])
    rec = read_record(path, input="ux_mV", output="x", time="time", input_unit="mV",
                      output_unit="nm")
    np.testing.assert_allclose(rec.y, 2 * u, atol=1e-5)


def test_identify_refuses_a_units_row_in_ms(tmp_path, capsys):
    from hammerstein.cli.main import main
    path = tmp_path / "daq.csv"
    _write(path, ["time", "ux", "x"], ["ms", "V", "µm"])
    status = main(["identify", str(path), "--input", "ux", "--output", "x", "--time", "time",
                   "--out", str(tmp_path / "m.toml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1
    assert "time column 'time': the units row says 'ms', and times are read in s" in err[0]
    assert not (tmp_path / "m.toml").exists()


@pytest.mark.parametrize("units, column, names", [
    (["s", "mV", "µm"], "ux", {}), (["s", "V", "nm"], "x", {}), (["s", "V", ""], "x_nm", {"x": "x_nm"})])
def test_signal_files_in_other_units_are_refused(tmp_path, units, column, names):
    from hammerstein.compensation.drive_files import read_signals
    from hammerstein.io.datafiles import DataFileError
    path = tmp_path / "m.csv"
    _write(path, ["t", "ux", names.get("x", "x")], units)
    with pytest.raises(DataFileError, match=rf"--measured: .*m.csv: column '{column}'.* and "
                                            rf"signals are read in V or µm"):
        read_signals(path, ["ux", "x"], "t", names, None, "--measured")


def test_a_signal_file_with_a_units_row_in_s_v_um_is_read(tmp_path):
    from hammerstein.compensation.drive_files import read_signals
    path = tmp_path / "m.csv"
    t, u = _write(path, ["t", "ux", "x"], ["s", "V", "µm"])
    grid, vals, T = read_signals(path, ["ux", "x"], "t", None, None, "--measured")
    assert grid.size == 50 and T == pytest.approx(1e-3)
    np.testing.assert_allclose(vals[1], 2 * u, atol=1e-5)


# A decimal comma and a preamble without '#' were refused without a word of their cause.
def test_a_decimal_comma_is_named_as_such(tmp_path):
    from hammerstein.compensation.drive_files import read_signals
    from hammerstein.io.datafiles import DataFileError
    path = tmp_path / "de.csv"
    path.write_text("t;ux;x\n" + "".join(f"0,{k:03d};0,5;-1,25\n" for k in range(20)))
    with pytest.raises(DataFileError) as err:
        read_record(path, input="ux", output="x", time="t")
    assert str(err.value) == (f"{path}: input column 'ux': non-numeric or empty cell '0,5' at "
                              f"data row 1 (looks like a decimal comma; write '.' decimals)")
    with pytest.raises(DataFileError) as err:
        read_signals(path, ["ux", "x"], "t", None, None, "--measured")
    assert str(err.value).endswith("column 't': a non-numeric cell '0,000' on data row 1; "
                                   "expected finite numbers (looks like a decimal comma; "
                                   "write '.' decimals)")


def test_a_preamble_without_comment_marks_hints_at_skip_rows(tmp_path):
    from hammerstein.io.datafiles import DataFileError
    path = tmp_path / "daq.csv"
    _write(path, ["t", "ux", "x"], ["s", "V", "µm"])
    path.write_text("Instrument: Tek MSO\nDate: 2026-11-26\nRate: 1000\n"
                    + path.read_text(encoding="utf-8"), encoding="utf-8")
    with pytest.raises(DataFileError) as err:
        read_records(path, inputs=["ux"], outputs=["x"], time="t")
    assert "no input column named 'ux'" in str(err.value)
    assert str(err.value).endswith("(a preamble before the table? skip it with "
                                   "--skip-rows 3, or start its lines with '#')")   # its 3 lines
    assert read_records(path, inputs=["ux"], outputs=["x"], time="t", skip_rows=3)
