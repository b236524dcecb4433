"""Minor-loop prediction of the model ``identify --model auto`` picks (issue 17 target: within 2 %).

For each plant (default: the bundled ``realistic-2dof``,
``scenarios/presets/realistic-b.toml`` (creep on) and
``realistic-b-nocreep.toml`` (creep off)), with and without the staircases:

1. the records of ``hammerstein excitation`` are played through the plant
   with 40 nm sensor noise (``benchmarks/real_actuators.py``);
2. ``hammerstein identify ... --dynamics`` with the defaults (``--model
   auto``), and again with ``--creep-records``;
3. the identified hysteresis draws 1 Hz sines at 30 % and 15 % of the
   amplitude, compared with the plant's own hysteresis (loop amplitude,
   per axis); with ``--creep-records`` also the identified hysteresis then
   its creep against the plant's hysteresis then creep (the gain split
   between them is a normalisation at 1 Hz; the cascade is what predicts).

Prints the class auto chose, the loop amplitude errors, CPU and load.

Usage: ``python benchmarks/minor_loops.py [--plants NAME_OR_PATH ...] [--keep DIR]``
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_actuators import AMPLITUDE, ROOT, _cli, _minor_loops, _play  # noqa: E402

from hammerstein.io.presets import load_model, load_plant, read_toml  # noqa: E402


def run_plant(spec, work, rng):
    source = str((ROOT / spec).resolve()) if spec.endswith(".toml") else spec
    plant = load_plant(source)
    d = work / Path(spec).stem
    rec = d / "records"
    T = plant.sampling_period
    cpu = {}
    if not rec.exists():
        d.mkdir(parents=True, exist_ok=True)
        _, cpu["excitation"] = _cli("excitation", "--inputs", "ux,uy", "--amplitude", str(AMPLITUDE),
                                    "--sampling-period", repr(T), "--out", str(rec), cwd=d)
        t0 = time.process_time()
        _play(plant, rec, rng)
        cpu["play"] = time.process_time() - t0
    hyst = [str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")]
    dyn = [str(rec / f"multisine-{i}{s}.csv") for s in ("", "-validation") for i in ("ux", "uy")]
    rows = []
    for creep in (False, True):
        preset = d / ("creep.toml" if creep else "hysteresis.toml")
        stairs = ["--creep-records", *[str(rec / f"creep-{i}.csv") for i in ("ux", "uy")]] if creep else []
        if not preset.exists():
            _, cpu[f"identify{' --creep-records' if creep else ''}"] = _cli(
                "identify", *hyst, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
                "--dynamics", "--dynamics-records", *dyn, *stairs, "--out", str(preset), cwd=d)
        chosen = read_toml(preset)["identification"]["method"]
        model = load_model(str(preset))
        loops = _minor_loops(plant, model, T)
        ident = load_plant(str(preset))
        chain = (_minor_loops(plant, model, T, ident.creep)
                 if creep and plant.creep is not None and ident.creep is not None else None)
        cells = []
        for frac in (0.30, 0.15):
            cell = f"x {loops[(frac, 'x')]:+.2f} %, y {loops[(frac, 'y')]:+.2f} %"
            if chain is not None:
                cell += f" (with creep: x {chain[(frac, 'x')]:+.2f} %, y {chain[(frac, 'y')]:+.2f} %)"
            cells.append(cell)
        rows.append((("--creep-records" if creep else "hysteresis records only"), chosen, *cells))
    return Path(spec).stem, rows, cpu


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", nargs="+", default=["realistic-2dof", "scenarios/presets/realistic-b.toml",
                                                    "scenarios/presets/realistic-b-nocreep.toml"])
    ap.add_argument("--keep", metavar="DIR", help="work in DIR and keep the files (reused)")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(17)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        print("| plant | identify | class auto chose | loop amplitude at 30 % | at 15 % |")
        print("|---|---|---|---|---|")
        for spec in args.plants:
            name, rows, cpu = run_plant(spec, work, rng)
            for r in rows:
                print(f"| `{name}` | " + " | ".join(r) + " |")
            print("CPU s: " + ", ".join(f"{k} {v:.1f}" for k, v in cpu.items())
                  + f"; load {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
