"""Independent identifications side by side (identification/concurrent_fits.py)."""

import numpy as np
import pytest

from hammerstein.identification.concurrent_fits import fit_concurrently, worker_count
from hammerstein.io.datafiles import bundled_data, read_record
from hammerstein.identification.preisach_identification import identify_preisach_records
from hammerstein.identification.record_identification import identify_records


def test_results_and_errors_come_back_by_name():
    tasks = {"pow": (pow, (2, 10), {}), "bad": (int, ("x",), {}), "sum": (sum, ([1, 2, 3],), {})}
    for workers in (1, 2):
        out = fit_concurrently(tasks, workers=workers)
        assert list(out) == ["pow", "bad", "sum"]
        assert out["pow"] == 1024 and out["sum"] == 6
        assert isinstance(out["bad"], ValueError)


def test_worker_cap(monkeypatch):
    monkeypatch.setenv("HAMMERSTEIN_WORKERS", "1")
    assert worker_count(5) == 1
    monkeypatch.delenv("HAMMERSTEIN_WORKERS")
    assert 1 <= worker_count(2) <= 2


@pytest.mark.slow
def test_fits_in_workers_equal_the_fits_here():
    rec = read_record(bundled_data(), input=2, output=1, time=0)
    tasks = {"classical": (identify_records, (rec,), {}),
             "preisach": (identify_preisach_records, (rec,), {"n_levels": 8})}
    here = fit_concurrently(tasks, workers=1)
    there = fit_concurrently(tasks, workers=2)
    for name in tasks:
        # the same code on the same data in another process: the same floating-point result
        np.testing.assert_array_equal(here[name].predictions[0], there[name].predictions[0])
        assert here[name].notes == there[name].notes
