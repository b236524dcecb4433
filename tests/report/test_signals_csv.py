"""write_signals_csv writes the bytes pandas' to_csv writes (it replaces it for the time series)."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hammerstein.report import tables
from hammerstein.report.tables import write_signals_csv

FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)


def _pandas_bytes(tmp_path, columns, float_format):
    path = tmp_path / "pandas.csv"
    pd.DataFrame(columns).to_csv(path, index=False, float_format=float_format)
    return path.read_bytes()


def _our_bytes(tmp_path, columns, float_format):
    path = tmp_path / "ours.csv"
    write_signals_csv(path, columns, float_format=float_format)
    return path.read_bytes()


@settings(max_examples=30, deadline=None)
@given(data=st.data(), n_columns=st.integers(1, 4), n_rows=st.integers(0, 40),
       float_format=st.sampled_from(["%.6g", "%.7g", "%.3e"]))
def test_same_bytes_as_pandas(tmp_path_factory, data, n_columns, n_rows, float_format):
    tmp_path = tmp_path_factory.mktemp("csv")
    names = data.draw(st.lists(st.sampled_from(["time_s", "x_um", "nan", "a,b", 'q"t', "u V"]),
                               min_size=n_columns, max_size=n_columns, unique=True))
    columns = {n: data.draw(arrays(np.float64, n_rows, elements=FLOATS)) for n in names}
    assert _our_bytes(tmp_path, columns, float_format) == _pandas_bytes(tmp_path, columns,
                                                                        float_format)


@pytest.mark.parametrize("values", [
    [np.nan, np.nan, np.nan],           # a whole row of empty fields
    [-0.0, 5e-324, 1.7976931348623157e308],
    [np.inf, -np.inf, np.nan],
    [1 / 3, 2 / 3, 1e-5],
])
def test_edge_values_and_chunks(tmp_path, monkeypatch, values):
    monkeypatch.setattr(tables, "CSV_CHUNK_ROWS", 2)      # rows split over several blocks
    v = np.array(values)
    columns = {"t": np.arange(v.size) * 5e-5, "a": v, "b": v[::-1].copy()}
    columns["t"][1] = np.nan
    assert _our_bytes(tmp_path, columns, "%.6g") == _pandas_bytes(tmp_path, columns, "%.6g")


def test_columns_that_are_not_float_go_to_pandas(tmp_path):
    columns = {"k": np.arange(3), "x": np.array([0.5, np.nan, 2.0])}
    assert _our_bytes(tmp_path, columns, "%.6g") == _pandas_bytes(tmp_path, columns, "%.6g")
    assert (tmp_path / "ours.csv").read_text() == "k,x\n0,0.5\n1,\n2,2\n"
