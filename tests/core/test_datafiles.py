"""Reading measured records: formats that real files have, and one-line errors for the rest."""

import numpy as np
import pytest

from hammerstein.io.datafiles import DataFileError, Record, bundled_data, read_record

N = 20
T = 1e-3


def _rows(sep=",", header=True, index=False):
    t = np.arange(N) * T
    u = 10 * np.sin(2 * np.pi * 5 * t)
    y = 5 * u + 0.5
    lines = []
    if header:
        lines.append(sep.join((["idx"] if index else []) + ["time", "volts", "microns"]))
    for i in range(N):
        cells = ([""] if index else []) + [f"{t[i]:.6f}", f"{u[i]:.9f}", f"{y[i]:.9f}"]
        lines.append(sep.join(cells))
    return "\n".join(lines) + "\n", t, u, y


@pytest.mark.parametrize("sep", [",", ";", "\t", " "])
@pytest.mark.parametrize("header", [True, False])
def test_separators_and_header_detection(tmp_path, sep, header):
    text, t, u, y = _rows(sep, header)
    path = tmp_path / "rec.csv"
    path.write_text(text)
    cols = ("volts", "microns", "time") if header else (1, 2, 0)
    rec = read_record(path, *cols)
    assert isinstance(rec, Record)
    np.testing.assert_allclose(rec.u, u, atol=1e-8)
    np.testing.assert_allclose(rec.y, y, atol=1e-8)
    assert rec.sampling_period == pytest.approx(T, rel=1e-6)
    assert rec.input_name == ("volts" if header else "column 1")


def test_empty_leading_index_column_is_dropped(tmp_path):
    text, t, u, y = _rows(",", header=False, index=True)
    path = tmp_path / "rec.csv"
    path.write_text(text)
    rec = read_record(path, input="1", output="2", time="0")       # indices given as text (CLI)
    np.testing.assert_allclose(rec.u, u, atol=1e-8)


def test_sampling_period_without_time_column(tmp_path):
    text, t, u, y = _rows(",", header=True)
    path = tmp_path / "rec.csv"
    path.write_text(text)
    rec = read_record(path, "volts", "microns", sampling_period=2e-3)
    np.testing.assert_allclose(rec.timepts, np.arange(N) * 2e-3)


def test_shipped_record():
    rec = read_record(bundled_data(), input=2, output=1, time=0)
    assert rec.n_samples == 50001
    assert rec.sampling_period == pytest.approx(2e-4, rel=1e-3)
    assert np.ptp(rec.u) == pytest.approx(300.0, abs=1e-6)
    assert rec.y.min() == pytest.approx(-19.73, abs=0.01) and rec.y.max() == pytest.approx(19.72, abs=0.01)


def _write(tmp_path, text, name="bad.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _good(tmp_path):
    return _write(tmp_path, _rows(",", header=True)[0], "good.csv")


@pytest.mark.parametrize("case, kwargs, message", [
    ("missing file", dict(path="nope.csv", input=0, output=1, time=None, sampling_period=1e-3),
     "no such file"),
    ("empty file", dict(text="", input=0, output=1, sampling_period=1e-3), "the file is empty"),
    ("blank lines only", dict(text="\n\n  \n", input=0, output=1, sampling_period=1e-3),
     "the file is empty"),
    ("misnamed column", dict(input="volt", output="microns", time="time"),
     "no input column named 'volt'; available columns: 0:time, 1:volts, 2:microns"),
    ("index out of range", dict(input=0, output=7, time=None, sampling_period=1e-3),
     "output column 7 out of range"),
    ("no time information", dict(input="volts", output="microns"),
     "give a time column or a sampling period"),
    ("bad sampling period", dict(input="volts", output="microns", sampling_period=-1.0),
     "expected a positive time"),
    ("disagreeing period", dict(input="volts", output="microns", time="time", sampling_period=0.5),
     "disagrees with the time column step"),
])
def test_errors_are_one_line_and_name_the_file(tmp_path, case, kwargs, message):
    kwargs = dict(kwargs)
    if "text" in kwargs:
        path = _write(tmp_path, kwargs.pop("text"))
    elif "path" in kwargs:
        path = tmp_path / kwargs.pop("path")
    else:
        path = _good(tmp_path)
    with pytest.raises(DataFileError) as err:
        read_record(path, **kwargs)
    text = str(err.value)
    assert message in text and str(path) in text and "\n" not in text


@pytest.mark.parametrize("mutate, message", [
    (lambda rows: rows.__setitem__(5, "0.004,abc,1.0"), "input column 'volts': non-numeric or empty cell 'abc' at data row 5"),
    (lambda rows: rows.__setitem__(6, "0.005,,1.0"), "non-numeric or empty cell"),
    (lambda rows: rows.__setitem__(8, "0.001,1.0,1.0"), "time column 'time' is not increasing"),
    (lambda rows: rows.__setitem__(8, "0.0075,1.0,1.0"), "not uniformly sampled"),
    (lambda rows: rows.__delitem__(slice(5, None)), "too short, expected at least 10 samples, found 4"),
])
def test_bad_contents(tmp_path, mutate, message):
    rows = _rows(",", header=True)[0].splitlines()
    mutate(rows)
    path = _write(tmp_path, "\n".join(rows) + "\n")
    with pytest.raises(DataFileError, match=message.replace("(", r"\(").replace(")", r"\)")) as err:
        read_record(path, "volts", "microns", time="time")
    assert str(path) in str(err.value)


def test_directory_is_rejected(tmp_path):
    with pytest.raises(DataFileError, match="is a directory"):
        read_record(tmp_path, 0, 1, sampling_period=1e-3)


def test_read_records_several_columns_by_name_and_index(tmp_path):
    from hammerstein.io.datafiles import read_records
    path = tmp_path / "mimo.csv"
    rows = ["t;ux;uy;x;y"] + [f"{i * 0.5};{i};{-i};{2 * i};{3 * i}" for i in range(12)]
    path.write_text("\n".join(rows) + "\n")
    rec = read_records(path, "ux,2", ["x", 4], time="t")
    assert rec.input_names == ("ux", "uy") and rec.output_names == ("x", "y")
    assert rec.u.shape == (2, 12) and rec.y.shape == (2, 12)
    assert np.array_equal(rec.y[1], 3 * np.arange(12)) and rec.sampling_period == 0.5
    with pytest.raises(DataFileError, match="same column 'ux'"):
        read_records(path, "ux", "ux,x", time="t")
    with pytest.raises(DataFileError, match="no input column named 'uz'"):
        read_records(path, "ux,uz", "x", sampling_period=1.0)


@pytest.mark.parametrize("name, unit", [("time_ms", "ms"), ("t [us]", "us"), ("t(µs)", "µs"),
                                        ("t_min", "min")])
def test_a_time_column_named_in_another_unit_is_refused(tmp_path, name, unit):
    """A data logger's ``time_ms`` read as seconds made a 10 kHz record one at 10 Hz: a mode
    at "1.8 Hz", creep steps of "2e+03 s", no word. Times are seconds; the name says not."""
    path = tmp_path / "rec.csv"
    k = np.arange(40)
    path.write_text(f"{name},u,y\n" + "".join(f"{0.1 * i:.1f},{np.sin(i)},{np.cos(i)}\n" for i in k),
                    encoding="utf-8")
    with pytest.raises(DataFileError) as info:
        read_record(path, "u", "y", time=name)
    text = str(info.value)
    assert f"time column {name!r} is named in {unit}" in text and "seconds" in text
    assert "\n" not in text


@pytest.mark.parametrize("name", ["t", "time", "t_s", "time [s]", "t_hist"])
def test_a_time_column_in_seconds_is_read(tmp_path, name):
    path = tmp_path / "rec.csv"
    path.write_text(f"{name},u,y\n" + "".join(f"{1e-4 * i:.4f},{np.sin(i)},{np.cos(i)}\n"
                                             for i in range(40)), encoding="utf-8")
    assert read_record(path, "u", "y", time=name).sampling_period == pytest.approx(1e-4)


def test_a_preamble_without_comment_marks_is_named(tmp_path):
    """A logger's three '%' lines before the header: the ragged-row error says how to skip
    them (the new user's file was refused with no word of --skip-rows)."""
    path = tmp_path / "rec.csv"
    path.write_text("% NanoLab logger v3.2, stage AFM-Z1\n% fs=10 kHz\n% operator\n"
                    "time,V,z,\n" + "".join(f"{1e-4 * i:.4f},{i},{2 * i},\n" for i in range(40)),
                    encoding="utf-8")
    with pytest.raises(DataFileError) as info:
        read_record(path, "V", "z", time="time")
    assert "ragged rows" in str(info.value) and "--skip-rows 3," in str(info.value)
    rec = read_record(path, "V", "z", time="time", skip_rows=3)   # as the hint says
    assert rec.sampling_period == pytest.approx(1e-4) and rec.u[-1] == 39


def test_a_long_preamble_gets_the_skip_that_reads_the_table(tmp_path):
    """A DAQ's 10-line preamble: pandas stops at line 6, the first line whose fields differ
    from the first's, and the hint said "--skip-rows N, N < 6" where 10 is needed."""
    preamble = ["MyDAQ v3.2 export", "Operator: records", "Date: 2026-11-27 10:20",
                "Stage: XY-100", "Amplifier: 0..100 V", "Sensor: capacitive, 25 nm",
                "Rate: 10000 Hz", "Channels: 4", "Comment: excitation from hammerstein",
                "---------------"]
    path = tmp_path / "rec.csv"
    path.write_text("\n".join(preamble) + "\nt,u,y\n"
                    + "".join(f"{1e-4 * i:.4f},{i},{2 * i}\n" for i in range(40)),
                    encoding="utf-8")
    with pytest.raises(DataFileError) as info:
        read_record(path, "u", "y", time="t")
    said = str(info.value)
    assert "ragged rows" in said and "--skip-rows 10," in said and "N <" not in said, said
    rec = read_record(path, "u", "y", time="t", skip_rows=len(preamble))   # as the hint says
    assert rec.sampling_period == pytest.approx(1e-4) and rec.u[-1] == 39
    # after a skip of 4 of them: the 6 lines left, counted on from the skip
    with pytest.raises(DataFileError) as info:
        read_record(path, "u", "y", time="t", skip_rows=4)
    assert "--skip-rows 10," in str(info.value), str(info.value)


def test_the_column_check_reads_only_the_opening_and_agrees_with_the_whole_read(tmp_path,
                                                                                monkeypatch):
    from hammerstein.core import files
    from hammerstein.io import datafiles
    from hammerstein.io.datafiles import HEAD_BYTES, read_records
    from hammerstein.io.record_columns import record_column_problem
    rows = "".join(f"{k * 1e-4:.4f},{0.001 * k:.6f},{0.002 * k:.6f}\n" for k in range(40_000))
    path = tmp_path / "long.csv"
    path.write_text("t,ux,x\ns,V,µm\n" + rows)
    assert path.stat().st_size > 10 * HEAD_BYTES
    sizes = []
    real = files.bounded_read_bytes
    monkeypatch.setattr(datafiles, "bounded_read_bytes",
                        lambda *a, **k: sizes.append(k.get("head")) or real(*a, **k))
    assert record_column_problem(path, "ux", "x", "t") is None
    assert sizes == [4 * HEAD_BYTES]          # the opening only, whatever the file's size
    # a wrong name, in the words of the whole read
    with pytest.raises(DataFileError) as whole:
        read_records(path, "uy", "x", "t")
    assert record_column_problem(path, "uy", "x", "t") == str(whole.value)
    # a column in another unit, input and output the same column, a time in ms
    path.write_text("t,ux,x\ns,mV,µm\n" + rows[:5000])
    assert "mV" in record_column_problem(path, "ux", "x", "t")
    path.write_text("t,ux,x\n" + rows[:5000])
    assert "the same column 'ux'" in record_column_problem(path, "ux", "ux", "t")
    path.write_text("t_ms,ux,x\n" + rows[:5000])
    assert "named in ms" in record_column_problem(path, "ux", "x", "t_ms")
    # the opening is cut at a complete row: no ragged or cut-short row is made up
    path.write_text("t,ux,x\n" + rows)
    assert record_column_problem(path, "ux", "x", "t") is None


def test_a_text_cell_far_down_a_long_file_is_named_without_pandas_words(tmp_path, recwarn):
    """An outside check: a bad cell in a long file (read in chunks, one numeric and one not)
    also printed pandas' 'Columns (1: ux) have mixed types. Specify dtype option on import or
    set low_memory=False', advice no command can take. The cell alone is named."""
    n = 300_000
    rows = ["time_s,volts,um"] + [f"{i * 1e-4:.6g},0.5,1.0" for i in range(n)]
    rows[n - 9] = f"{(n - 10) * 1e-4:.6g},abc,1.0"
    path = tmp_path / "long.csv"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(DataFileError, match=rf"non-numeric or empty cell 'abc' at data row {n - 9}"):
        read_record(path, "volts", "um", time="time_s")
    assert [str(w.message) for w in recwarn] == []
