"""Issue 22: reliability, second round (ownership by content, concurrency, hygiene, numbers).

Each test is one defect of the issue, named by its number.
"""

import os
import shutil
import threading
import time
from pathlib import Path

import pytest

from hammerstein.cli.main import main
from hammerstein.core import files
from hammerstein.runner import MARKER, TMP_PREFIX, remove_stale_temporaries, run_scenarios

CORPUS = Path(__file__).resolve().parents[1] / "corpus"
GOOD = CORPUS / "good" / "good-static.toml"
GOOD2 = CORPUS / "good" / "good-static-2.toml"


def _call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return status, out, err.splitlines()


# -- 4. temporaries owned by a token, not by a PID ---------------------------------------
def _fake_temporary(out, token, age=3600.0):
    d = out / f"{TMP_PREFIX}2.deadbeef.x"
    d.mkdir(parents=True)
    (d / MARKER).write_text(f"hammerstein 0\nowner {token}\n")
    old = time.time() - age
    os.utime(d / MARKER, (old, old))
    return d


def _token(**change):
    fields = files.parse_owner(files.owner_token())
    files.release_owner(files.owner_token())
    fields.update(change)
    return " ".join(f"{k}={v}" for k, v in fields.items())


def test_4_other_pid_namespace_keeps_its_temporary(tmp_path):
    # pid 2 of another PID namespace: its liveness cannot be told here, so it stays
    d = _fake_temporary(tmp_path, _token(pidns="1", pid="2"))
    assert remove_stale_temporaries(tmp_path) == []
    assert d.is_dir()


def test_4_other_host_keeps_its_temporary(tmp_path):
    d = _fake_temporary(tmp_path, _token(host="elsewhere"))
    assert remove_stale_temporaries(tmp_path) == []
    assert d.is_dir()


def test_4_reused_pid_is_stale(tmp_path):
    # same namespace, the PID alive but started at another time: its owner is gone
    d = _fake_temporary(tmp_path, _token(pid=str(os.getppid()), start="1"))
    assert remove_stale_temporaries(tmp_path) == [d]
    assert not d.exists()


def test_4_live_call_of_this_process_is_kept_finished_one_removed(tmp_path):
    token = files.owner_token()
    d = _fake_temporary(tmp_path, token)
    assert files.owner_alive(token) is True
    assert remove_stale_temporaries(tmp_path) == []
    files.release_owner(token)
    assert files.owner_alive(token) is False
    assert remove_stale_temporaries(tmp_path) == [d]


def test_4_young_empty_temporary_is_kept(tmp_path):
    d = tmp_path / f"{TMP_PREFIX}{os.getpid()}.0.x"
    d.mkdir()
    old = time.time() - 1.0
    os.utime(d, (old, old))
    assert remove_stale_temporaries(tmp_path) == []
    os.utime(d, (old - 3600, old - 3600))
    assert remove_stale_temporaries(tmp_path) == [d]


def test_4_two_threads_share_one_out_directory(tmp_path):
    # each thread's sweep of stale temporaries must not remove the other's live report
    out = tmp_path / "out"
    results, errors = {}, []

    def work(i, src):
        try:
            scen = tmp_path / f"s{i}.toml"
            text = src.read_text()
            scen.write_text(text.replace(f'name = "{src.stem}"', f'name = "x{i}"', 1))
            results[i] = run_scenarios([scen], out)
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i, GOOD if i % 2 else GOOD2)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert all(o.ok for r in results.values() for o in r), [o.error for r in results.values() for o in r]
    assert not [p for p in out.iterdir() if p.name.startswith(TMP_PREFIX)]
