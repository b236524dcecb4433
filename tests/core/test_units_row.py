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
