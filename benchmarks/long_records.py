"""Peak memory, wall and CPU time of the commands on long records (3e5 to 3e6 samples).

Run: ``python benchmarks/long_records.py [--sizes 300000 1000000 3000000]
[--commands compensate evaluate identify] [--work DIR] [--against OTHER_CHECKOUT]``
(from the repository root).

Not a test. It writes, per size ``n`` (samples at the preset's 20 kHz, 2 inputs,
2 outputs; 3e6 samples is 150 s), the files of the hardware route
(README.md, docs/hardware.md, docs/drives.md, docs/records.md) and times
the commands a user runs on them, each in a fresh process with this
checkout on ``PYTHONPATH`` and ``HAMMERSTEIN_MAX_DATA_BYTES`` at 1 GiB (the
drive file of 3e6 samples, with its predicted and shaped columns, is 270 MiB,
beyond the default 256 MiB a checkout before 2026-11-29 read it within; a drive
file is now read within the size of the largest accepted record's drive, so
the variable only matters for an ``--against`` checkout that old):

* ``compensate``: ``hammerstein compensate realistic-2dof --reference
  '{ kind = "circle", radius = 30, frequency = 10, periods = n / 2000 }'
  --out drive.csv --predicted`` (a 10 Hz circle, 2000 samples a period;
  the run that writes the drive is printed as ``writing``);
* the measured response (not timed): the drive's ``ux, uy`` played
  through the ``realistic-2dof`` plant (hysteresis, creep, bending modes)
  with 40 nm Gaussian sensor noise, written as ``measured.csv``
  (``t, x, y``, ``%.9g``, as a data-acquisition card writes it);
* ``evaluate``: ``hammerstein evaluate --reference ... --drive drive.csv
  --measured measured.csv --out eval/``;
* ``identify``: ``hammerstein identify hysteresis-ux.csv hysteresis-uy.csv
  --inputs ux,uy --outputs x,y --time t --model classical --out model.toml
  --plot fit.png``, the records of ``hammerstein excitation`` (its
  decreasing sine at ``240000 / n`` Hz, so that each record holds ``n``
  samples) played through the same plant with the same noise.

Each command runs in a child process that this script waits for with
``os.wait4``: its peak resident set size (``ru_maxrss``: the largest of the
process and the children it waited for, e.g. figure workers), its user +
system CPU time and the wall time. This machine is shared, so the load
(``os.getloadavg``) is printed before and after each command and a
reference loop (``s += i`` for 20 million ``i`` in a fresh interpreter,
1.0 s CPU on the nominal machine) is timed before and after each size.

With ``--against DIR`` (a second checkout, e.g. ``git worktree add
/tmp/ref <commit>``) each command also runs from that checkout, on the
same files, right after this one's.

Results: benchmarks/results/long-records.md.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
PRESET = "realistic-2dof"
NOISE_UM = 0.04
LOOP = "s = 0\nfor i in range(20_000_000): s += i"
SIZES = (300_000, 1_000_000, 3_000_000)
COMMANDS = ("compensate", "evaluate", "identify")
#: the files' size limit [bytes] every command is given: the drive file of 3e6 samples with
#: its predicted and shaped columns (270 MiB) is beyond the default 256 MiB of a checkout
#: before 2026-11-29 (since then a drive file has a limit of its own)
DATA_LIMIT = 1 << 30


def reference_loop():
    """CPU and wall seconds of the reference loop in a fresh interpreter."""
    t0, w0 = os.times(), time.perf_counter()
    subprocess.run([sys.executable, "-c", f"exec({LOOP!r})"], check=True)
    t1, w1 = os.times(), time.perf_counter()
    cpu = (t1.children_user - t0.children_user) + (t1.children_system - t0.children_system)
    return cpu, w1 - w0


def measure(tree, args, cwd):
    """One ``python -m hammerstein *args`` from ``tree``: its peak RSS, wall and CPU.

    Parameters
    ----------
    tree : path-like
        The checkout put first on ``PYTHONPATH``.
    args : list of str
        The command line after ``python -m hammerstein``.
    cwd : path-like
        Working directory of the command.

    Returns
    -------
    dict
        ``rss_mb`` (peak resident set size [MiB] of the process or of the
        largest child it waited for), ``wall`` and ``cpu`` (user + system of
        it and its waited-for children) [s], ``load`` (1-minute load
        average before and after).

    Raises
    ------
    SystemExit
        If the command fails (its stderr's tail in the message).
    """
    env = dict(os.environ, PYTHONPATH=str(tree), HAMMERSTEIN_MAX_DATA_BYTES=str(DATA_LIMIT))
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen([sys.executable, "-m", "hammerstein", *args], cwd=cwd, env=env,
                                stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            err.seek(0)
            raise SystemExit(f"{tree}: hammerstein {args[0]} failed: "
                             f"{err.read().decode(errors='replace').strip()[-2000:]}")
    return {"rss_mb": usage.ru_maxrss / 1024.0, "wall": wall,
            "cpu": usage.ru_utime + usage.ru_stime, "load": (load0, os.getloadavg()[0])}


def _line(n, name, label, r):
    return (f"{n:>9} {name:<11} {label:<8} {r['rss_mb']:>6.0f} MB {r['wall']:>6.1f}s "
            f"{r['cpu']:>6.1f}s  {r['load'][0]:.1f}-{r['load'][1]:.1f}")


def _play(plant, u, rng):
    """The plant's response [µm], shape (2, n), to ``u`` [V], shape (2, n), plus 40 nm noise."""
    y, _ = plant.simulate(u)
    return y + NOISE_UM * rng.standard_normal(y.shape)


def _write(path, header, columns):
    """Write ``columns`` (equal 1-D arrays) as CSV with ``%.9g`` (a DAQ card's precision)."""
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="",
               fmt="%.9g")


def _drive_columns(path):
    """``t, ux, uy`` of a drive file, shape (3, n) [s, V, V] (its header's ``#`` lines skipped)."""
    frame = pd.read_csv(path, comment="#", usecols=["t", "ux", "uy"])
    return frame[["t", "ux", "uy"]].to_numpy().T


def circle(n):
    """The inline reference of ``n`` samples: a 30 µm circle at 10 Hz, ``n / 2000`` periods."""
    return f'{{ kind = "circle", radius = 30, frequency = 10, periods = {n // 2000} }}'


def files(work, n, seed=5):
    """Write the drive, measured response and identification records of size ``n`` (once).

    Parameters
    ----------
    work : pathlib.Path
        Directory of this size's files.
    n : int
        Samples per record.
    seed : int
        Seed of the sensor noise.

    Returns
    -------
    pathlib.Path
        ``work``, holding ``drive.csv``, ``measured.csv`` and ``hysteresis-u{x,y}.csv``.
    """
    from hammerstein.io.presets import load_plant

    work.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    plant = load_plant(PRESET)
    if not (work / "measured.csv").exists():
        r = measure(ROOT, ["compensate", PRESET, "--reference", circle(n), "--out", "drive.csv",
                           "--predicted", "--force"], work)
        print(_line(n, "compensate", "writing", r), flush=True)
        d = _drive_columns(work / "drive.csv")
        y = _play(plant, d[1:3], rng)
        _write(work / "measured.csv", "t,x,y", [d[0], y[0], y[1]])
    if not (work / "hysteresis-uy.csv").exists():
        lab = work / "lab"
        measure(ROOT, ["excitation", "--inputs", "ux,uy", "--amplitude", "10",
                       "--sampling-period", repr(plant.sampling_period),
                       "--sine-frequency", repr(240_000 / n), "--out", str(lab), "--force"], work)
        for name in ("ux", "uy"):
            data = np.loadtxt(lab / f"hysteresis-{name}.csv", delimiter=",", skiprows=1)
            y = _play(plant, data[:, 1:3].T, rng)
            _write(work / f"hysteresis-{name}.csv", "t,ux,uy,x,y",
                   [data[:, 0], data[:, 1], data[:, 2], y[0], y[1]])
    return work


def command(name, n):
    """The command line of ``name`` on the files of size ``n``."""
    if name == "compensate":
        return ["compensate", PRESET, "--reference", circle(n), "--out", "drive-timed.csv",
                "--predicted", "--force"]
    if name == "evaluate":
        return ["evaluate", "--reference", circle(n), "--drive", "drive.csv",
                "--measured", "measured.csv", "--out", "eval"]
    return ["identify", "hysteresis-ux.csv", "hysteresis-uy.csv", "--inputs", "ux,uy",
            "--outputs", "x,y", "--time", "t", "--model", "classical", "--out", "model.toml",
            "--plot", "fit.png", "--force"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=int, default=list(SIZES))
    ap.add_argument("--commands", nargs="+", choices=COMMANDS, default=list(COMMANDS))
    ap.add_argument("--work", help="directory of the files (kept; default temporary)")
    ap.add_argument("--against", help="a second checkout, timed on the same files")
    args = ap.parse_args(argv)
    trees = [("this", ROOT)] + ([("against", Path(args.against).resolve())] if args.against else [])
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.work) if args.work else Path(tmp)
        files(base / "warm", 20_000)       # numba's cache warm: a small compensate, untimed
        print(f"{'size':>9} {'command':<11} {'tree':<8} {'peak RSS':>9} {'wall':>7} {'CPU':>7}  load")
        for n in args.sizes:
            work = files(base / str(n), n)
            loop0 = reference_loop()
            for name in args.commands:
                for label, tree in trees:
                    print(_line(n, name, label, measure(tree, command(name, n), work)), flush=True)
            loop1 = reference_loop()
            print(f"{'':>9} reference loop {loop0[0]:.2f} s CPU ({loop0[1]:.2f} s wall) before, "
                  f"{loop1[0]:.2f} s CPU ({loop1[1]:.2f} s wall) after", flush=True)


if __name__ == "__main__":
    main()
