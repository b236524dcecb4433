"""Issue 22, defects 5 and 17: a cache entry is used only when it can be trusted.

Foreign entries (another uid), entries in directories others may write, edited
entries (weights scaled with the key intact) and malformed ones (``meta`` a
list, deeply nested JSON) are ignored with one note, never fatal; the
identification then runs again and gives the fresh model.
"""

import json
import os

import pytest

from hammerstein.io.presets import model_to_table
from hammerstein.scenario import diskcache
from hammerstein.scenario import identification as identified

SPEC = {"frequency": 50.0, "amplitude": 10.0, "periods": 2, "n_hysterons": 8,
        "method": "least-squares", "partition": "time", "bounds": "monotone"}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(diskcache.ENV, str(tmp_path / "cache"))
    notes = []
    diskcache.set_reporter(notes.append)
    diskcache._REPORT["said"].clear()
    yield tmp_path / "cache" / "identified", notes
    diskcache.set_reporter(None)


def _fresh(static_plant):
    model, _ = identified.identified_model(static_plant, SPEC)
    (entry,) = (p for p in (diskcache.cache_dir()).iterdir())
    return model_to_table(model), entry


def _scale_weights(table, factor):
    for comps in table["components"].values():
        for comp in comps.values():
            if isinstance(comp, dict) and "weights" in comp:
                comp["weights"] = [w * factor for w in comp["weights"]]
            elif isinstance(comp, dict) and "gain" in comp:
                comp["gain"] = comp["gain"] * factor


def _again(static_plant):
    model, _ = identified.identified_model(static_plant, SPEC)
    return model_to_table(model)


def test_directories_and_entries_are_private(cache, static_plant):
    d, _ = cache
    _fresh(static_plant)
    for p in (d, d.parent):
        assert os.stat(p).st_mode & 0o077 == 0
    (entry,) = d.iterdir()
    assert os.stat(entry).st_uid == os.getuid()


def test_edited_weights_are_ignored(cache, static_plant):
    d, notes = cache
    table, entry = _fresh(static_plant)
    data = json.loads(entry.read_text())
    _scale_weights(data["value"]["model"], 1.5)          # key intact, content changed
    entry.write_text(json.dumps(data))
    assert _again(static_plant) == table
    assert any("digest" in n for n in notes)


@pytest.mark.skipif(os.getuid() != 0, reason="needs root to give a file to another user")
def test_entry_of_another_user_is_ignored(cache, static_plant):
    d, notes = cache
    table, entry = _fresh(static_plant)
    data = json.loads(entry.read_text())
    _scale_weights(data["value"]["model"], 1.5)
    data["digest"] = diskcache._value_digest(data["value"])   # a careful attacker
    entry.write_text(json.dumps(data))
    os.chown(entry, 65534, 65534)
    assert _again(static_plant) == table
    assert any("another user" in n for n in notes)


def test_group_writable_directory_is_not_used(cache, static_plant):
    d, notes = cache
    table, entry = _fresh(static_plant)
    os.chmod(d, 0o777)
    data = json.loads(entry.read_text())
    _scale_weights(data["value"]["model"], 1.5)
    data["digest"] = diskcache._value_digest(data["value"])
    entry.write_text(json.dumps(data))
    assert _again(static_plant) == table
    assert any("writable by group or others" in n for n in notes)


@pytest.mark.parametrize("damage", ["meta-list", "nested", "uid", "not-json"])
def test_malformed_entries_are_ignored(cache, static_plant, damage):
    d, notes = cache
    table, entry = _fresh(static_plant)
    data = json.loads(entry.read_text())
    if damage == "meta-list":
        data["value"]["meta"] = [1, 2]
        data["digest"] = diskcache._value_digest(data["value"])
        entry.write_text(json.dumps(data))
    elif damage == "nested":
        entry.write_text('{"key": ' + json.dumps(data["key"]) + ', "value": ' + "[" * 200000
                         + "]" * 200000 + "}")
    elif damage == "uid":
        data["uid"] = os.getuid() + 1
        entry.write_text(json.dumps(data))
    else:
        entry.write_bytes(b"\x00\xff garbage")
    assert _again(static_plant) == table
    assert len(notes) == 1 and str(entry.name) in notes[0]
