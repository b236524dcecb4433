"""Creep compensation on actuators outside the model class: drift before and after.

For each plant (default: the bundled ``realistic-2dof`` and
``scenarios/presets/realistic-b.toml``, both with log creep):

1. the excitation records are played through the plant with 40 nm noise
   and ``hammerstein identify --dynamics --creep-records`` writes a preset
   (what ``benchmarks/real_actuators.py --creep`` does; its ``--keep DIR``
   is reused when given here as ``--work``);
2. the Hammerstein compensator built from the identified preset (PI, G)
   runs on the TRUE plant with no creep inversion, with the identified creep
   (``[creep]`` of the preset) and with the plant's true creep (an oracle);
3. printed per case: max Euclidean error [% of the half size or step] and
   the drift, the largest change of the error over the holds / over the
   raster (its part slower than one line, a 50 ms moving average).

Cases: a 40 x 40 µm raster (64 lines, 20 Hz fast axis, centred) and a slow
staircase of both axes (+/-30 µm steps held 2 s, 50 ms raised-cosine edges).

Usage: ``python benchmarks/creep.py [--plants ...] [--work DIR]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_actuators import AMPLITUDE, ROOT, _cli, _play  # noqa: E402

from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator  # noqa: E402
from hammerstein.io.presets import load_creep, load_dynamics, load_model, load_plant  # noqa: E402
from hammerstein.signals.references import raster  # noqa: E402

HOLD_S, EDGE_S, STEP_UM = 2.0, 0.05, 30.0


def _identify(spec, work, rng):
    source = str((ROOT / spec).resolve()) if spec.endswith(".toml") else spec
    plant = load_plant(source)
    d = work / Path(spec).stem
    preset = d / "identified.toml"
    if preset.exists():
        return plant, preset, 0.0
    rec = d / "records"
    d.mkdir(parents=True, exist_ok=True)
    _cli("excitation", "--inputs", "ux,uy", "--amplitude", str(AMPLITUDE), "--sampling-period",
         repr(plant.sampling_period), "--out", str(rec), cwd=d)
    _play(plant, rec, rng)
    _, cpu = _cli("identify", *[str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")],
                  "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t", "--dynamics",
                  "--dynamics-records", *[str(rec / f"multisine-{i}{s}.csv") for s in ("", "-validation")
                                          for i in ("ux", "uy")],
                  "--creep-records", *[str(rec / f"creep-{i}.csv") for i in ("ux", "uy")],
                  "--out", str(preset), cwd=d)
    return plant, preset, cpu


def _staircase(T):
    levels = STEP_UM * np.array([0.0, 1.0, 0.0, -1.0, 0.0, 1.0])
    n, m = int(round(HOLD_S / T)), int(round(EDGE_S / T))
    r = np.repeat(levels, n)
    w = 0.5 * (1 - np.cos(np.pi * np.arange(m) / m))
    for j in range(1, levels.size):
        r[j * n:j * n + m] = levels[j - 1] + w * (levels[j] - levels[j - 1])
    held = np.concatenate([np.arange(j * n + int(0.1 / T), (j + 1) * n) for j in range(1, levels.size)])
    starts = [j * n + int(0.1 / T) for j in range(1, levels.size)]
    return np.vstack([r, -r]), held, starts, n


def _run(plant, comp, ref):
    return comp.run_reference(plant, ref, fade_samples=int(round(0.05 / plant.sampling_period))).outputs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", nargs="+",
                    default=["realistic-2dof", "scenarios/presets/realistic-b.toml"])
    ap.add_argument("--work", metavar="DIR", default="creep-benchmark",
                    help="work directory (identified presets reused when present)")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(17)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    for spec in args.plants:
        plant, preset, cpu_id = _identify(spec, work, rng)
        T = plant.sampling_period
        names = plant.hysteresis.output_names
        model = load_model(preset)
        G = load_dynamics(preset, names, T)
        identified = load_creep(preset, names)
        t0 = time.process_time()
        _, rr = raster(T, [40.0, 40.0], 64, 20.0, slow="ramp")
        rr = rr - 20.0
        stairs, held, starts, n = _staircase(T)
        k = int(round(0.05 / T))
        print(f"\n## {Path(spec).stem}: Hammerstein compensator from the identified preset, "
              f"on the true plant\n")
        print("| creep inverted | raster 40x40 µm 20 Hz: max error | raster: slow error (drift) "
              "| staircase ±30 µm: max error after 0.1 s | staircase: drift within the holds |")
        print("|---|---|---|---|---|")
        for label, creep in (("none", None), ("identified", identified), ("true (oracle)", plant.creep)):
            comp = HammersteinCompensator(model, G, check="warn", creep=creep)
            e = _run(plant, comp, rr) - rr
            settle = int(round(0.1 / T))
            eu = np.linalg.norm(e[:, settle:], axis=0)
            slow = np.array([np.convolve(row, np.ones(k) / k, mode="valid") for row in e[:, settle:]])
            slow_ptp = float(np.max(np.ptp(slow, axis=1)))
            es = _run(plant, comp, stairs) - stairs
            eh = np.linalg.norm(es[:, held], axis=0)
            drift = max(float(np.max(np.abs(es[:, s:s + n - int(0.1 / T)] - es[:, s:s + 1])))
                        for s in starts)
            print(f"| {label} | {eu.max():.3f} µm = {100 * eu.max() / 20.0:.2f} % | "
                  f"{slow_ptp:.3f} µm p-p | {eh.max():.3f} µm = {100 * eh.max() / STEP_UM:.2f} % | "
                  f"{drift:.3f} µm |")
        print(f"\nCPU s: identify {cpu_id:.1f}, compensation runs {time.process_time() - t0:.1f}; "
              f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
