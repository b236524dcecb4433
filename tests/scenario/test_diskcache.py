"""The on-disk identification cache: exact round trips, and every bad entry ignored."""

import json

import numpy as np
import pytest

from hammerstein.io.presets import model_to_table
from hammerstein.scenario import diskcache
from hammerstein.scenario import identification as identified

SPEC = {"frequency": 50.0, "amplitude": 10.0, "periods": 2, "n_hysterons": 8,
        "method": "least-squares", "partition": "time", "bounds": "monotone"}
DYN = {"period": 0.02, "periods": 3, "max_order": 4}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(diskcache.ENV, str(tmp_path / "cache"))
    yield tmp_path / "cache" / "identified"


def _no_identification(*args, **kwargs):
    raise AssertionError("identified again instead of reading the cache")


def test_pi_entry_round_trips_exactly(cache, static_plant, monkeypatch):
    model, meta = identified.identified_model(static_plant, SPEC)
    (entry,) = cache.iterdir()
    assert entry.name.startswith("pi-") and entry.suffix == ".json"
    # a new call has a cache of its own: a new process, as far as it knows
    monkeypatch.setattr(identified, "characterize", _no_identification)
    again, meta_again = identified.identified_model(static_plant, SPEC)
    assert model_to_table(again) == model_to_table(model) and meta_again == meta
    u = np.vstack([8 * np.sin(np.linspace(0, 12, 400)), 4 * np.cos(np.linspace(0, 9, 400))])
    np.testing.assert_array_equal(again.simulate(u)[0], model.simulate(u)[0])


def test_hammerstein_entry_round_trips_exactly(cache, preset_plant, monkeypatch):
    pi, meta, ident, dmeta = identified.identified_hammerstein(preset_plant, SPEC, DYN)
    assert sorted(p.name.split("-")[0] for p in cache.iterdir()).count("hammerstein") == 1
    monkeypatch.setattr(identified, "characterize", _no_identification)
    monkeypatch.setattr(identified, "_fit_dynamics", _no_identification)
    pi2, meta2, ident2, dmeta2 = identified.identified_hammerstein(preset_plant, SPEC, DYN)
    assert model_to_table(pi2) == model_to_table(pi) and meta2 == meta and dmeta2 == dmeta
    for k in "ABCD":
        np.testing.assert_array_equal(getattr(ident2.system_, k), getattr(ident.system_, k))
    assert ident2.system_.dt == ident.system_.dt and ident2.order_ == ident.order_
    np.testing.assert_array_equal(ident2.validation_fit_, ident.validation_fit_)
    assert ident2.sensor == ident.sensor


def test_other_settings_are_other_entries(cache, static_plant):
    identified.identified_model(static_plant, SPEC)
    identified.identified_model(static_plant, {**SPEC, "n_hysterons": 9})
    assert len(list(cache.iterdir())) == 2
    before = diskcache.entry_path("pi", ("k",))
    monkey = diskcache._DIGEST.copy()
    try:
        diskcache._DIGEST["value"] = "other code"
        assert diskcache.entry_path("pi", ("k",)) != before   # new code: never the old entries
    finally:
        diskcache._DIGEST.clear()
        diskcache._DIGEST.update(monkey)


@pytest.mark.parametrize("damage", ["garbage", "truncated", "other key", "too large", "directory"])
def test_a_bad_entry_is_ignored_and_left_alone(cache, static_plant, monkeypatch, damage):
    model, _ = identified.identified_model(static_plant, SPEC)
    (entry,) = cache.iterdir()
    text = entry.read_text()
    if damage == "garbage":
        entry.write_bytes(b"\x00\xff not json")
    elif damage == "truncated":
        entry.write_text(text[: len(text) // 2])
    elif damage == "other key":
        data = json.loads(text)
        data["key"] = data["key"].replace("pi", "px", 1)
        entry.write_text(json.dumps(data))
    elif damage == "too large":
        monkeypatch.setenv("HAMMERSTEIN_MAX_CACHE_BYTES", "100")
    else:
        entry.unlink()
        entry.mkdir()
    kept = None if damage == "directory" else entry.read_bytes()
    again, _ = identified.identified_model(static_plant, SPEC)       # identified again
    assert model_to_table(again) == model_to_table(model)
    if kept is None:
        assert entry.is_dir() and not any(entry.iterdir())
    else:
        assert entry.read_bytes() == kept                          # not overwritten


def test_off_writes_nothing(tmp_path, static_plant, monkeypatch):
    for value in ("off", ""):
        monkeypatch.setenv(diskcache.ENV, value)
        assert diskcache.cache_dir() is None and diskcache.entry_path("pi", (1,)) is None
        assert not diskcache.store("pi", (1,), {"a": 1}) and diskcache.load("pi", (1,)) is None


def test_default_location_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.delenv(diskcache.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert diskcache.cache_dir() == tmp_path / "hammerstein" / "identified"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert diskcache.cache_dir() == tmp_path / "home" / ".cache" / "hammerstein" / "identified"


def test_no_home_directory_means_no_cache(monkeypatch):
    from pathlib import Path

    def no_home():
        raise RuntimeError("Could not determine home directory.")
    monkeypatch.delenv(diskcache.ENV, raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(Path, "home", staticmethod(no_home))
    assert diskcache.cache_dir() is None and diskcache.load("pi", (1,)) is None


def test_unwritable_cache_costs_only_time(tmp_path, static_plant, monkeypatch):
    blocker = tmp_path / "not-a-dir"
    blocker.write_text("a file where the cache directory would be")
    monkeypatch.setenv(diskcache.ENV, str(blocker))
    try:
        model, _ = identified.identified_model(static_plant, SPEC)
    finally:
        assert model.n_inputs == 2 and blocker.read_text().startswith("a file")


@pytest.mark.parametrize("value", [{"x": (1, 2)}, {"x": np.float64(1.5)}, {"x": {1: "a"}}])
def test_values_that_would_not_read_back_equal_are_not_stored(cache, value):
    assert not diskcache.store("pi", ("v",), value)
    assert not cache.exists() or not any(cache.iterdir())


def test_nan_reads_back(cache):
    assert diskcache.store("pi", ("nan",), {"fit": [1.0, float("nan")]})
    got = diskcache.load("pi", ("nan",))
    assert got["fit"][0] == 1.0 and np.isnan(got["fit"][1])
    assert not diskcache.store("pi", ("nan",), {"fit": []})     # exists: never rewritten
