"""CPU time of ``hammerstein identify`` on realistic 2 x 2 records, per model class.

Run: ``python benchmarks/identify.py [--models auto classical ...] [--repeat N]
[--against OTHER_CHECKOUT] [--work DIR] [--plant PRESET]`` (from the repository root).

Not a test. The records are those a lab would take: ``hammerstein
excitation`` (10 V, the plant's sampling period) played through the bundled
``realistic-2dof`` preset with creep (or ``--plant``) and 40 nm Gaussian
sensor noise (``benchmarks/real_actuators.py``'s ``_play``), written once to
``--work`` (default: a temporary directory). Each timed command is

``hammerstein identify hysteresis-ux.csv hysteresis-uy.csv --inputs ux,uy
--outputs x,y --time t --model M --dynamics --dynamics-records multisine-*
--creep-records creep-* --out preset.toml``

in a fresh process with this checkout on ``PYTHONPATH`` (numba's cache warm:
one untimed run first). CPU = user + system of the child and of the worker
processes it waited for (``--model auto`` fits its classes side by side;
``--workers 1`` times them one after the other), from ``os.times``.

This machine's speed drifts with its load, so every timing is bracketed by a
reference loop (``s += i`` for 20 million ``i``, 1.0 s CPU on the nominal
machine) timed before and after; the scaled figure is the raw CPU divided by
the faster of the two loop times. With ``--against DIR`` (a second checkout,
e.g. ``git worktree add /tmp/ref <commit>``) the two checkouts alternate,
command by command, and the ratio new / old is printed.

Targets (scaled CPU): ``--model auto`` <= 10 s, each single class <= 5 s.
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_actuators import AMPLITUDE, _play  # noqa: E402

TARGETS = {"auto": 10.0, "classical": 5.0, "preisach": 5.0, "generalized": 5.0}
LOOP = "s = 0\nfor i in range(20_000_000): s += i"


def reference_loop():
    """CPU seconds of the reference loop in a fresh interpreter."""
    t0 = os.times()
    subprocess.run([sys.executable, "-c", f"exec({LOOP!r})"], check=True)
    t1 = os.times()
    return (t1.children_user - t0.children_user) + (t1.children_system - t0.children_system)


def run(tree, args, cwd, workers=None):
    """``python -m hammerstein *args`` with ``tree`` first on the path: CPU seconds."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    if workers is not None:
        env["HAMMERSTEIN_WORKERS"] = str(workers)
    t0 = os.times()
    res = subprocess.run([sys.executable, "-m", "hammerstein", *args], cwd=cwd, env=env,
                         capture_output=True, text=True)
    t1 = os.times()
    if res.returncode != 0:
        raise SystemExit(f"{tree}: hammerstein {args[0]} failed: {res.stderr.strip()[-2000:]}")
    return (t1.children_user - t0.children_user) + (t1.children_system - t0.children_system), res.stdout


def records(work, plant_spec, seed=5):
    """The excitation records through the plant (written once): {kind: [paths]}."""
    from hammerstein.io.presets import load_plant

    rec = work / "records"
    if not (rec / "creep-uy.csv").exists():
        plant = load_plant(plant_spec)
        rec.mkdir(parents=True, exist_ok=True)
        run(ROOT, ["excitation", "--inputs", "ux,uy", "--amplitude", str(AMPLITUDE),
                   "--sampling-period", repr(plant.sampling_period), "--out", str(rec)], work)
        _play(plant, rec, np.random.default_rng(seed))
    return {
        "hysteresis": [str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")],
        "dynamics": [str(rec / f"multisine-{i}{s}.csv") for s in ("", "-validation")
                     for i in ("ux", "uy")],
        "creep": [str(rec / f"creep-{i}.csv") for i in ("ux", "uy")],
    }


def identify_args(files, model, out):
    return ["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
            "--time", "t", "--model", model, "--dynamics", "--dynamics-records",
            *files["dynamics"], "--creep-records", *files["creep"], "--out", str(out), "--force"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["auto", "classical", "preisach", "generalized"],
                    choices=list(TARGETS))
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--against", default=None, help="another checkout to alternate with")
    ap.add_argument("--work", default=None, help="directory for the records (kept)")
    ap.add_argument("--plant", default="realistic-2dof", help="preset the records come from")
    ap.add_argument("--verbose", action="store_true", help="print identify's output")
    ap.add_argument("--workers", type=int, default=None,
                    help="HAMMERSTEIN_WORKERS of the timed commands (auto's classes side by side "
                         "in that many processes; 1: one after the other)")
    args = ap.parse_args(argv)
    work = Path(args.work or tempfile.mkdtemp(prefix="identify-bench-")).resolve()
    work.mkdir(parents=True, exist_ok=True)
    files = records(work, args.plant)
    trees = [("new", ROOT)] + ([("old", Path(args.against).resolve())] if args.against else [])
    for _, tree in trees:                          # numba's cache warm, imports in the page cache
        run(tree, identify_args(files, "classical", work / "warm.toml"), work)
    print(f"records: {work / 'records'}; load {os.getloadavg()[0]:.2f}")
    print(f"{'model':<12} {'tree':<4} {'CPU [s]':>8} {'loop [s]':>8} {'scaled [s]':>10} "
          f"{'target':>6}")
    for model in args.models:
        best = {}
        for _ in range(args.repeat):
            for name, tree in trees:
                before = reference_loop()
                cpu, out = run(tree, identify_args(files, model, work / f"{name}-{model}.toml"),
                               work, args.workers)
                after = reference_loop()
                loop = min(before, after)
                scaled = cpu / loop
                print(f"{model:<12} {name:<4} {cpu:8.2f} {loop:8.2f} {scaled:10.2f} "
                      f"{TARGETS[model]:6.1f}", flush=True)
                if args.verbose:
                    print(out)
                best[name] = min(best.get(name, np.inf), scaled)
        if "old" in best:
            print(f"{model:<12} new/old {best['new'] / best['old']:.2f} (best scaled)")
    print(f"load {os.getloadavg()[0]:.2f}; {time.strftime('%H:%M:%S')}")


if __name__ == "__main__":
    main()
