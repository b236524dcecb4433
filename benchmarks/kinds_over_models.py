"""Every compensator kind over an identified Preisach model and an identified classical PI.

For each plant (default: the bundled ``realistic-2dof``; ``--plants`` to choose):

1. ``hammerstein excitation`` writes the records to play (20 kHz, 10 V), each
   played through the plant from rest with 40 nm sensor noise;
2. ``hammerstein identify ... --dynamics`` (CLI, defaults otherwise) with
   ``--model preisach`` and with ``--model classical`` writes two presets;
3. ``hammerstein run`` of one scenario on the true plant: a 30 µm circle at
   50 Hz (6 periods, the last 2 measured), a sweep over every compensator kind
   (``multivariable``, ``diagonal``, ``per-axis``, ``static-gain`` and
   ``hammerstein``) built from each identified preset, plus the exact
   per-sample inverse (``preisach-inverse``) of the identified Preisach model;
   oracles: every kind over the plant's true hysteresis (``hammerstein`` with
   the true G too), to split the error into model and dynamics.

Prints the max Euclidean error (% of the radius) and the RMS error per kind
and model class, and the CPU time and load (``--keep DIR`` reuses the
presets an earlier run identified there). The rate-independent kinds leave the modes and
creep uncompensated, so at 50 Hz they measure the static inverse and what
the dynamics add (the Hammerstein compensator inverts G too).

Usage: ``python benchmarks/kinds_over_models.py [--plants NAME_OR_PATH ...] [--keep DIR]
[--creep]``
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_actuators import AMPLITUDE, ROOT, _cli, _play  # noqa: E402

from hammerstein.io.presets import load_plant  # noqa: E402

KINDS = {
    "multivariable": 'kind = "multivariable", gain = "midpoint", check = "warn"',
    "diagonal": 'kind = "diagonal", gain = "midpoint", check = "warn"',
    "per-axis": 'kind = "per-axis"',
    "static-gain": 'kind = "static-gain"',
    "hammerstein": 'kind = "hammerstein", dynamics = "{file}", check = "warn"',
}


def run_plant(spec, work, rng, creep=False):
    source = str((ROOT / spec).resolve()) if spec.endswith(".toml") else spec
    plant = load_plant(source)
    name = Path(spec).stem
    d = work / name
    rec = d / "records"
    T = plant.sampling_period
    cpu = {}
    if not (d / "classical.toml").exists():     # --keep DIR of an earlier run: reuse its presets
        _, cpu["excitation"] = _cli("excitation", "--inputs", "ux,uy", "--amplitude", str(AMPLITUDE),
                                    "--sampling-period", repr(T), "--out", str(rec), cwd=work)
        t0 = time.process_time()
        _play(plant, rec, rng)
        cpu["play"] = time.process_time() - t0
    hyst = [str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")]
    dyn = [str(rec / f"multisine-{i}.csv") for i in ("ux", "uy")] + \
          [str(rec / f"multisine-{i}-validation.csv") for i in ("ux", "uy")]
    stairs = ["--creep-records", *[str(rec / f"creep-{i}.csv") for i in ("ux", "uy")]] if creep else []
    for cls in ("preisach", "classical"):
        if (d / f"{cls}.toml").exists():
            continue
        _, cpu[f"identify {cls}"] = _cli(
            "identify", *hyst, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t",
            "--dynamics", "--dynamics-records", *dyn, *stairs, "--model", cls,
            "--out", str(d / f"{cls}.toml"), "--force", cwd=d)
    lines = []
    for cls in ("preisach", "classical"):
        for kind, table in KINDS.items():
            file = f"{cls}.toml"
            lines.append(f'"{kind}.{cls}" = {{ {table.format(file=file)}, model = "{file}" }}')
    lines.append('"preisach-inverse.preisach" = { kind = "preisach-inverse", model = "preisach.toml" }')
    # oracles: the true hysteresis inverted exactly (what the modes alone leave at 50 Hz), and
    # with the true G too
    for kind, table in KINDS.items():
        if kind != "hammerstein":
            lines.append(f'"{kind}.true" = {{ {table}, model = "plant" }}')
    lines.append('"preisach-inverse.true" = { kind = "preisach-inverse", model = "plant" }')
    lines.append('"hammerstein.true" = { kind = "hammerstein", model = "plant", dynamics = "plant" }')
    scenario = d / "kinds.toml"
    scenario.write_text(
        f'name = "kinds-{name}"\n[plant]\npreset = "{source}"\ndynamics = true\n'
        '[compensator]\nkind = "none"\n'
        '[[sweeps]]\nname = "family-circle-30um-50Hz"\n'
        'reference = { kind = "circle", radius = 30.0, frequency = 50.0, periods = 6 }\n'
        'settle_periods = 4\n[sweeps.compensators]\n' + "\n".join(lines) + "\n")
    _, cpu["run"] = _cli("run", str(scenario), "--out", str(d / "reports"), "--force", cwd=d)
    return name, d / "reports" / f"kinds-{name}", cpu


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", nargs="+", default=["realistic-2dof"])
    ap.add_argument("--keep", metavar="DIR", help="work in DIR and keep the files")
    ap.add_argument("--creep", action="store_true", help="identify with --creep-records too")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(17)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        for spec in args.plants:
            name, report, cpu = run_plant(spec, work, rng, args.creep)
            rows = {}
            for path in sorted(report.glob("sweep-family-circle-30um-50Hz*.csv")):
                with open(path) as fh:
                    for r in csv.DictReader(fh):
                        if r["channel"] == "x+y":
                            rows[r["compensator"]] = (float(r["max_euclidean_error_percent"]),
                                                      float(r["rms_euclidean_error"]))
            print(f"\n## {name}: 30 µm circle at 50 Hz on the true plant, max Euclidean error "
                  f"% of the radius (RMS µm)\n")
            print("| kind | over the identified Preisach model | over the identified classical PI "
                  "| over the true hysteresis (oracle) |")
            print("|---|---|---|---|")
            for kind in (*KINDS, "preisach-inverse"):
                cells = [f"{rows[k][0]:.2f} % ({rows[k][1]:.2f})" if k in rows else "-"
                         for k in (f"{kind}.preisach", f"{kind}.classical", f"{kind}.true")]
                print(f"| {kind} | {' | '.join(cells)} |")
            print("CPU s: " + ", ".join(f"{k} {v:.1f}" for k, v in cpu.items())
                  + f"; load {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
