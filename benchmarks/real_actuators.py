"""Identification and compensation on actuators outside the model class (issue 17 targets).

For each plant (default: the bundled ``realistic-2dof`` and
``scenarios/presets/realistic-b.toml``, creep on; ``--plants`` to choose):

1. ``hammerstein excitation`` writes the records to play (20 kHz, 10 V);
2. each record is played through the plant (``plant.simulate``, from rest)
   with 40 nm Gaussian sensor noise, and the displacements are added as
   columns ``x``, ``y`` -- what a lab would do;
3. ``hammerstein identify`` (CLI only, defaults) on those files with
   ``--dynamics`` writes a preset;
4. the identified modes and G(0) are compared with the plant's; the
   identified hysteresis predicts quasi-static minor loops (1 Hz sines at
   30 % and 15 % of the amplitude) compared with the plant's own loops;
5. ``hammerstein run`` of a scenario whose plant is the true preset and
   whose Hammerstein compensator uses the identified preset (model and
   dynamics): the voltages go back to the true actuator.

Prints one table per plant with every target of issue 17 and the measured
value, and the CPU time and load.

With ``--creep`` the staircases go to ``identify --creep-records`` too, and
the compensator inverts the identified creep with the dynamics (scenario
``creep = "auto"``: the identified preset's ``[creep]``).

Usage: ``python benchmarks/real_actuators.py [--plants NAME_OR_PATH ...] [--keep DIR] [--creep]
[--model auto|classical|preisach|generalized ...] [--seed N]``

``--plants scenarios/presets/realistic-gpi.toml`` is the actuator with
generalised-PI direct paths.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from types import SimpleNamespace

from hammerstein.models.lti import dc_gain, modal_parameters
from hammerstein.models.plant import HammersteinPlant
from hammerstein.io.presets import load_model, load_plant, read_toml

ROOT = Path(__file__).resolve().parents[1]
NOISE_UM = 0.04
AMPLITUDE = 10.0

CASES = """
[[cases]]
name = "circle-50um-10Hz"
reference = {{ kind = "circle", radius = 50.0, frequency = 10.0, periods = 3 }}
settle_periods = 2
[[cases]]
name = "circle-50um-50Hz"
reference = {{ kind = "circle", radius = 50.0, frequency = 50.0, periods = 6 }}
settle_periods = 4
[[cases]]
name = "circle-30um-150Hz"
reference = {{ kind = "circle", radius = 30.0, frequency = 150.0, periods = 12 }}
settle_periods = 8
[[cases]]
name = "circle-15um-20Hz"
reference = {{ kind = "circle", radius = 15.0, frequency = 20.0, periods = 4 }}
settle_periods = 2
[[cases]]
name = "circle-15um-200Hz"
reference = {{ kind = "circle", radius = 15.0, frequency = 200.0, periods = 16 }}
settle_periods = 12
[[cases]]
name = "lissajous-40um-50Hz"
reference = {{ kind = "lissajous", amplitude = 40.0, frequencies = [75.0, 50.0], periods = 4 }}
settle_periods = 2
[[cases]]
name = "sine-x-40um-200Hz"
reference = {{ kind = "sine", output = "x", amplitude = 40.0, frequency = 200.0, periods = 16 }}
settle_periods = 12
[[cases]]
name = "sine-x-30um-300Hz"
reference = {{ kind = "sine", output = "x", amplitude = 30.0, frequency = 300.0, periods = 24 }}
settle_periods = 18
[[cases]]
name = "raster-40um-64-lines-20Hz"
reference = {{ kind = "raster", outputs = ["x", "y"], size = [40.0, 40.0], lines = 64, frequency = 20.0, slow = "ramp" }}
settle_periods = 1
"""


def _cli(*args, cwd):
    t0 = os.times()
    env = dict(os.environ)               # the scenarios name presets of this checkout
    env["HAMMERSTEIN_ALLOW_PATHS"] = os.pathsep.join(
        p for p in (env.get("HAMMERSTEIN_ALLOW_PATHS"), str(ROOT / "scenarios" / "presets")) if p)
    res = subprocess.run([sys.executable, "-m", "hammerstein", *args], cwd=cwd,
                         capture_output=True, text=True, env=env)
    t1 = os.times()
    cpu = (t1.children_user - t0.children_user) + (t1.children_system - t0.children_system)
    if res.returncode != 0:
        raise SystemExit(f"hammerstein {args[0]} failed ({res.returncode}): {res.stderr.strip()}")
    return res.stdout, cpu


def _play(plant, directory, rng):
    """Add x, y columns (plant output + 40 nm noise) to every excitation file."""
    for path in sorted(directory.glob("*.csv")):
        data = np.loadtxt(path, delimiter=",", skiprows=1)
        u = data[:, 1:3].T
        y, _ = plant.simulate(u)
        y = y + NOISE_UM * rng.standard_normal(y.shape)
        out = np.column_stack([data, y.T])
        np.savetxt(path, out, delimiter=",", header="t,ux,uy,x,y", comments="", fmt="%.9g")


def _loop_amplitude(y):
    return float(np.ptp(y[len(y) // 2:]))


def _minor_loops(plant, model, T, creep=None):
    """Loop amplitude errors [%] of the identified hysteresis at 30 % and 15 %, per axis.

    With ``creep`` (the identified one), the identified hysteresis then creep
    against the plant's hysteresis then creep (no modes): the split of the
    gain between hysteresis and creep is a normalisation (unit creep gain at
    the 1 Hz of the records), only their cascade is measured.
    """
    if creep is not None:
        plant = SimpleNamespace(hysteresis=HammersteinPlant(plant.hysteresis, T, None,
                                                            creep=plant.creep))
        model = HammersteinPlant(model, T, None, creep=creep)
    out = {}
    n = int(round(1.0 / T))
    t = np.arange(2 * n) * T
    for frac in (0.30, 0.15):
        for k, name in enumerate(("x", "y")):
            u = np.zeros((2, t.size))
            u[k] = frac * AMPLITUDE * np.sin(2 * np.pi * t)
            y_true, _ = plant.hysteresis.simulate(u)
            y_id, _ = model.simulate(u)
            a_true, a_id = _loop_amplitude(y_true[k]), _loop_amplitude(y_id[k])
            out[(frac, name)] = 100 * (a_id - a_true) / a_true
    return out


def _metrics(path):
    with open(path) as fh:
        return [(r["case"], r["channel"], r["metric"], float(r["value"]))
                for r in csv.DictReader(fh)]


def run_plant(spec, work, rng, creep=False, model_class="auto"):
    source = str((ROOT / spec).resolve()) if spec.endswith(".toml") else spec
    plant = load_plant(source)
    name = Path(spec).stem
    d = work / f"{name}-{model_class}"
    rec = d / "records"
    T = plant.sampling_period
    cpu = {}
    _, cpu["excitation"] = _cli("excitation", "--inputs", "ux,uy", "--amplitude", str(AMPLITUDE),
                                "--sampling-period", repr(T), "--out", str(rec), cwd=d.parent)
    t0 = time.process_time()
    _play(plant, rec, rng)
    cpu["play"] = time.process_time() - t0
    hyst = [str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")]
    dyn = [str(rec / f"multisine-{i}.csv") for i in ("ux", "uy")] + \
          [str(rec / f"multisine-{i}-validation.csv") for i in ("ux", "uy")]
    preset = d / "identified.toml"
    stairs = ["--creep-records", *[str(rec / f"creep-{i}.csv") for i in ("ux", "uy")]] if creep else []
    printed, cpu["identify"] = _cli("identify", *hyst, "--inputs", "ux,uy", "--outputs", "x,y",
                                    "--time", "t", "--dynamics", "--dynamics-records", *dyn, *stairs,
                                    "--out", str(preset), "--metrics", str(d / "fit.csv"),
                                    "--model", model_class, "--force", cwd=d)
    summary = read_toml(preset)["identification"]["dynamics"]
    f_true, z_true = modal_parameters(plant.dynamics)
    f_id = np.array([m["frequency_hz"] for m in summary["modes"]])
    z_id = np.array([m["damping_ratio"] for m in summary["modes"]])
    ident_plant = load_plant(str(preset))
    rows = []
    if f_id.size == f_true.size:
        rows.append(("modes: frequency error (<= 1 %)",
                     f"{np.max(np.abs(f_id / f_true - 1)) * 100:.2f} % "
                     f"({', '.join(f'{v:.1f}' for v in f_id)} Hz)"))
        rows.append(("modes: damping error (<= 10 %)",
                     f"{np.max(np.abs(z_id / z_true - 1)) * 100:.1f} % "
                     f"({', '.join(f'{v:.3f}' for v in z_id)})"))
    else:
        rows.append(("modes (3 expected)", f"{f_id.size} identified: "
                     f"{', '.join(f'{v:.1f}' for v in f_id)} Hz"))
    rows.append(("no spurious pole below the first mode",
                 "yes" if np.all(f_id >= 0.99 * f_true.min()) else "NO"))
    rows.append(("G(0) after normalisation within 2 % of I",
                 f"{np.max(np.abs(dc_gain(ident_plant.dynamics) - np.eye(2))) * 100:.2g} % "
                 f"(unconstrained {np.round(summary['dc_gain_unconstrained'], 3).tolist()})"))
    loops = _minor_loops(plant, load_model(str(preset)), T)
    chain = (_minor_loops(plant, load_model(str(preset)), T, ident_plant.creep)
             if creep and plant.creep is not None and ident_plant.creep is not None else None)
    for frac in (0.30, 0.15):
        rows.append((f"minor loop amplitude at {frac:.0%} (within 2 %)",
                     f"x {loops[(frac, 'x')]:+.1f} %, y {loops[(frac, 'y')]:+.1f} %"
                     + ("" if chain is None else
                        f" (hysteresis then creep: x {chain[(frac, 'x')]:+.1f} %, "
                        f"y {chain[(frac, 'y')]:+.1f} %)")))
    scenario = d / "tracking.toml"
    scenario.write_text(
        f'name = "tracking-{name}"\n[plant]\npreset = "{source}"\n'
        f'dynamics = true\n[compensator]\nkind = "hammerstein"\nmodel = "identified.toml"\n'
        f'dynamics = "identified.toml"\n' + CASES.format())
    _, cpu["run"] = _cli("run", str(scenario), "--out", str(d / "reports"), "--force", cwd=d)
    m = _metrics(d / "reports" / f"tracking-{name}" / "metrics.csv")
    get = lambda case, ch, metric: next((v for c, h, k, v in m if c == case and h == ch
                                         and k == metric), float("nan"))
    for case in ("circle-50um-10Hz", "circle-50um-50Hz", "circle-30um-150Hz", "circle-15um-20Hz",
                 "circle-15um-200Hz", "lissajous-40um-50Hz", "raster-40um-64-lines-20Hz"):
        rows.append((f"{case}: max Euclidean error (<= 2 %)",
                     f"{get(case, 'x+y', 'max_euclidean_error_percent'):.2f} %"))
    for case, target in (("sine-x-40um-200Hz", "2"), ("sine-x-30um-300Hz", "5")):
        rows.append((f"{case}: RMS (<= {target} %)", f"{get(case, 'x', 'rms_error_percent'):.2f} %"))
        rows.append((f"{case}: cross-coupling p-p (<= 0.25 µm)",
                     f"{get(case, 'y', 'cross_coupling_peak_to_peak'):.3f} µm"))
    return name, rows, cpu, printed


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", nargs="+",
                    default=["realistic-2dof", "scenarios/presets/realistic-b.toml"])
    ap.add_argument("--keep", metavar="DIR", help="work in DIR and keep the files")
    ap.add_argument("--model", nargs="+", default=["auto"],
                    choices=["auto", "classical", "preisach", "generalized"],
                    help="identify --model class(es) to compare (default: auto)")
    ap.add_argument("--verbose", action="store_true", help="print identify's output too")
    ap.add_argument("--creep", action="store_true",
                    help="identify the creep from the staircases and invert it with G")
    ap.add_argument("--seed", type=int, default=17,
                    help="seed of the sensor noise added to the records (default 17)")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        runs = [(spec, mc) for spec in args.plants for mc in args.model]
        for spec, model_class in runs:
            name, rows, cpu, printed = run_plant(spec, work, rng, args.creep, model_class)
            print(f"\n## {name}, identify --model {model_class} (identified through the CLI from "
                  f"the excitation records, 40 nm noise)\n")
            if args.verbose:
                print(printed)
            print("| target | measured |\n|---|---|")
            for k, v in rows:
                print(f"| {k} | {v} |")
            print("\nCPU s: " + ", ".join(f"{k} {v:.1f}" for k, v in cpu.items())
                  + f"; load {os.getloadavg()[0]:.1f}", flush=True)

if __name__ == "__main__":
    main()
