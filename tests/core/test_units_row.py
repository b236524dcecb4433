"""A DAQ CSV with a units row under its header is read without hand editing."""

import numpy as np
import pytest

from hammerstein.core.datafiles import read_record, read_records


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
