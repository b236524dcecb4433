"""Records to drives with every default on an actuator outside the model classes (issue 38, item 4).

The records are the excitation files (:func:`hammerstein.signals.excitation.excitation_set`)
played through ``outside_actuator.OutsideActuator`` (no package code: Preisach
loops, couplings, three modes, 40 nm noise); ``identify`` is run as the
excitation README says. Expected, from the records themselves: the preset's
``[amplifier]`` holds each input's min/max and largest ``|du| / T`` over the
records, marked ``source = "records"``; every drive of ``compensate`` and of
two ``learn`` trials (circle starting at (r, 0), and the same circle as a CSV
file) stays within that range, starts at exactly 0 V and never steps more
than its settled part's largest step.
"""

import contextlib
import io
import re

import numpy as np
import pytest

from outside_actuator import OutsideActuator, write_csv
from hammerstein.cli.main import main
from hammerstein.signals.excitation import excitation_set
from hammerstein.io.presets import read_toml

T = 5e-5


def _cli(*args, cwd):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    assert code == 0, err.getvalue()
    return out.getvalue()


def _drive(path):
    text = path.read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    rows = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    return np.array([[float(v) for v in ln.split(",")] for ln in rows[1:]])[:, 1:3].T, fade


def _safe(u, fade, period, lo, hi):
    steps = np.abs(np.diff(np.concatenate([np.zeros((2, 1)), u], axis=1), axis=1))
    assert np.all(u[:, 0] == 0.0)                                   # at rest first
    assert np.all(u.min(axis=1) >= lo) and np.all(u.max(axis=1) <= hi)
    assert np.all(steps.max(axis=1) <= steps[:, fade + period + 1:].max(axis=1) * (1 + 1e-9))
    assert fade * T >= 0.02 - 1e-12


@pytest.mark.slow
def test_identify_compensate_learn_with_defaults_keep_the_drives_safe(tmp_path):
    act = OutsideActuator(creep=True)
    rng = np.random.default_rng(3)
    files, lo, hi, slew = {}, np.full(2, np.inf), np.full(2, -np.inf), np.zeros(2)
    for r in excitation_set(["ux", "uy"], 10.0, T, sine_frequency=5.0, hold=0.1):
        if r.kind == "creep":
            continue
        write_csv(tmp_path / f"{r.name}.csv", r.time, r.u, act.simulate(r.u, rng=rng))
        files.setdefault(r.kind, []).append(f"{r.name}.csv")
        lo, hi = np.minimum(lo, r.u.min(axis=1)), np.maximum(hi, r.u.max(axis=1))
        slew = np.maximum(slew, np.abs(np.diff(r.u, axis=1)).max(axis=1) / T)
    _cli("identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
         "--dynamics", "--dynamics-records", *files["multisine"], *files["multisine-validation"],
         "--out", "preset.toml", cwd=tmp_path)
    table = read_toml(tmp_path / "preset.toml")["amplifier"]
    assert table["source"] == "records"
    for i, name in enumerate(["ux", "uy"]):
        np.testing.assert_allclose(table[name]["range"], [lo[i], hi[i]], rtol=1e-6)
        np.testing.assert_allclose(table[name]["slew_rate"], slew[i], rtol=1e-6)
    # a circle larger than the records allow at 100 Hz: shaped, and said where
    spec = '{ kind = "circle", radius = 30, frequency = 100, periods = 14 }'
    _cli("compensate", "preset.toml", "--reference", spec, "--out", "u0.csv", cwd=tmp_path)
    t = np.arange(2800) * T
    circle = 30 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    np.savetxt(tmp_path / "circle.csv", np.column_stack([t, circle.T]), delimiter=",",
               header="t,x,y", comments="", fmt="%.12g")
    _cli("compensate", "preset.toml", "--reference", "circle.csv", "--out", "file.csv", cwd=tmp_path)
    u, fade = _drive(tmp_path / "file.csv")
    _safe(u, fade, 1, lo, hi)
    for k in range(3):
        u, fade = _drive(tmp_path / f"u{k}.csv")
        _safe(u, fade, 200, lo, hi)
        if k == 2:
            break
        y = act.simulate(u, rng=rng)
        np.savetxt(tmp_path / f"y{k}.csv", np.column_stack([t, y.T]), delimiter=",",
                   header="t,x,y", comments="", fmt="%.9g")
        out = _cli("learn", "preset.toml", "--reference", spec, "--drive", f"u{k}.csv",
                   "--measured", f"y{k}.csv", "--out", f"u{k + 1}.csv", "--history", "hist",
                   cwd=tmp_path)
        assert f"trial {k}: settled (from" in out
