"""Bit-for-bit reproducible runs: an identification computed in the run, read from the
disk cache, or computed with the cache off gives the same numbers, with 1 or 2 numba
and OpenBLAS threads.

The failures this guards against (measured): the identified G's ``C`` matrix came out
of the subspace fit Fortran-ordered and read back from the cache C-ordered; the real
Schur form of the ZPETC design then took other (equally valid) bases and the start
drive of ``ilc-realistic-2dof`` moved by 3e-12 V, 1.5e-8 µm in its metrics. And
``OPENBLAS_NUM_THREADS=2`` changed the least-squares PI weights in their 13th digit.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

from hammerstein.compensation.inversion import ZPETCInverse
from hammerstein.scenario import diskcache
from hammerstein.scenario import identification as identified
from hammerstein.scenario.identification_cache import IdentificationCache

SPEC = {"frequency": 50.0, "amplitude": 10.0, "periods": 2, "n_hysterons": 8,
        "method": "least-squares", "partition": "time", "bounds": "monotone"}
DYN = {"period": 0.02, "periods": 3, "max_order": 4}


def _design(ident):
    """Every array of the ZPETC design of an identified G."""
    inv = ZPETCInverse(ident.system_)
    return [inv._taps_v, inv._taps_w, inv._Ag, inv._Bg, inv._Cg]


def test_cold_warm_and_no_cache_give_the_same_bits(tmp_path, monkeypatch, preset_plant):
    monkeypatch.setenv(diskcache.ENV, str(tmp_path / "cache"))
    cold = identified.identified_hammerstein(preset_plant, SPEC, DYN)
    warm = identified.identified_hammerstein(preset_plant, SPEC, DYN)      # read from the disk
    monkeypatch.setenv(diskcache.ENV, "off")
    off = identified.identified_hammerstein(preset_plant, SPEC, DYN)
    assert len(list((tmp_path / "cache" / "identified").iterdir())) >= 1  # the warm one read it
    for other in (warm, off):
        for k in "ABCD":
            a, b = getattr(cold[2].system_, k), getattr(other[2].system_, k)
            np.testing.assert_array_equal(a, b)
            assert a.flags["C_CONTIGUOUS"] == b.flags["C_CONTIGUOUS"], k     # same layout
        for a, b in zip(_design(cold[2]), _design(other[2])):
            np.testing.assert_array_equal(a, b)


def test_a_computed_value_is_used_as_read_back():
    """What the run uses is the stored form rebuilt, not the object computed."""
    computed = np.asfortranarray(np.arange(6.0).reshape(2, 3))
    cache = IdentificationCache(disk=False)
    got = cache.get("pi", ("k",), compute=lambda: computed,
                    load=lambda v: np.array(v["a"]), dump=lambda v: {"a": v.tolist()})
    assert got is not computed and got.flags["C_CONTIGUOUS"]
    np.testing.assert_array_equal(got, computed)
    # a value whose stored form would not read back equal (a tuple) is used as computed
    cache = IdentificationCache(disk=False)
    got = cache.get("pi", ("k",), compute=lambda: computed,
                    load=lambda v: np.array(v["a"]), dump=lambda v: {"a": tuple(v.ravel())})
    assert got is computed


CLASSICAL = '''name = "classical"
[plant]
preset = "rakotondrabe-2dof"
dynamics = true

[compensator]
kind = "hammerstein"
model = "identified"
identify = { frequency = 50.0, sensor = true }
dynamics = "identified"

[[cases]]
name = "circle"
reference = { kind = "circle", radius = 30.0, frequency = 100.0, periods = 6 }
'''

SCENARIO = '''name = "determinism"
[plant]
preset = "realistic-2dof"
dynamics = true

[compensator]
kind = "ilc"
iterations = 2
learning_gain = 0.8
q_cutoff_hz = 500.0
sensor_noise = 0.04
seed = 1
start = { kind = "hammerstein", model = "identified", identify = { frequency = 50.0, sensor = true, model = "preisach" }, dynamics = "identified" }

[[cases]]
name = "circle"
reference = { kind = "circle", radius = 20.0, frequency = 100.0, periods = 8 }
settle_periods = 3
'''


@pytest.mark.slow
def test_threads_and_cache_do_not_change_a_learning_run(tmp_path):
    """An ILC case from an identified Preisach start and a Hammerstein compensator over an
    identified classical PI (least squares), in fresh processes."""
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    classical = tmp_path / "c.toml"
    classical.write_text(CLASSICAL, encoding="utf-8")
    runs = {"1 thread, empty cache": ("1", "1", str(tmp_path / "cache")),
            "2 threads, warm cache": ("2", "2", str(tmp_path / "cache")),
            "2 numba, 1 BLAS thread, no cache": ("2", "1", "off"),
            "1 numba, 2 BLAS threads, no cache": ("1", "2", "off")}
    metrics = {}
    for i, (label, (numba, blas, cache)) in enumerate(runs.items()):
        env = {**os.environ, "NUMBA_NUM_THREADS": numba, "OPENBLAS_NUM_THREADS": blas,
               "HAMMERSTEIN_CACHE_DIR": cache, "PYTHONHASHSEED": str(i)}
        out = tmp_path / f"out{i}"
        subprocess.run([sys.executable, "-m", "hammerstein", "run", str(path), str(classical),
                        "--out", str(out)], check=True, env=env, capture_output=True, timeout=600)
        metrics[label] = [(out / name / "metrics.csv").read_bytes()
                          for name in ("determinism", "classical")]
    first = next(iter(metrics.values()))
    assert b"iteration-2" in first[0] and b"max_euclidean_error" in first[1]
    for label, text in metrics.items():
        assert text == first, label
