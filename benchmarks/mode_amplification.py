"""How much of the feedforward circles' error the actuator's bending modes make.

Reads the drives that ``benchmarks/route_defaults.py --work DIR`` kept (every
command at its defaults) and plays each circle's drive through its actuator
again (no noise). The settled error (after the fade-in and two periods, the
route's definition) is then taken over whole periods and split into its
harmonics of the circle's frequency. Each harmonic ``E(f)`` below twice the
first mode is mapped back through the actuator's own linear part,
``G(1) G(f)^-1 E(f)`` (those above are kept as measured): what the same
hysteresis error would leave on a stage whose linear part passes every
harmonic at its static gain, with no resonance. Printed per actuator and
circle: the error as measured and without the modes' amplification [% of
the radius], and the largest amplification over the static gain of the
circle's first five harmonics that the *identified* dynamics give (what
``hammerstein compensate`` names in its note) beside the actuator's true one.
The raster's error against the shaped reference its drive file carries is
split the same way [% of 20 µm], over the whole record from rest,
zero-padded (a raster is not periodic), its last samples left out.

Usage (one minute for the family, one core)::

    python benchmarks/route_defaults.py --work /tmp/route        # keeps the drives
    python benchmarks/mode_amplification.py /tmp/route
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import route_defaults as rd  # noqa: E402

from hammerstein.cli._hardware import load_actuator  # noqa: E402
from hammerstein.compensation.shaping import mode_amplification  # noqa: E402

RADII = (15, 30, 50)
FREQUENCIES = (10, 100, 200)
HARMONICS = np.arange(1, 6)


def actuator_matrices(act):
    """The actuator's own discrete (A, B, C, D) of its modes."""
    n, m = act.Bd.shape
    return act.Ad, act.Bd, act.C, np.zeros((act.C.shape[0], m))


def without_modes(act, e, length=None):
    """The error ``e`` (2, k) with its spectrum below twice the first mode mapped back
    through ``G(1) G(f)^-1`` of the actuator's linear part.

    ``length`` None: ``e`` holds whole periods (a circle's settled part), its DFT lines are
    the harmonics. ``length`` 2 k: ``e`` is a whole record from rest (a raster, not
    periodic), zero-padded so that the mapping is a linear, not a circular, filter of it
    (the last samples see the cut).
    """
    A, B, C, _ = actuator_matrices(act)
    n, k = A.shape[0], e.shape[1]
    N = k if length is None else int(length)
    E = np.fft.rfft(e, n=N, axis=1)
    eye = np.eye(n)
    G1 = C @ np.linalg.solve(eye - A, B)
    for b in range(1, E.shape[1]):
        f = b / (N * rd.T)
        if f >= 2.0 * act.modes_hz[0]:
            break
        G = C @ np.linalg.solve(np.exp(2j * np.pi * f * rd.T) * eye - A, B)
        E[:, b] = G1 @ np.linalg.solve(G, E[:, b])
    return np.fft.irfft(E, n=N, axis=1)[:, :k]


#: samples left out at the end of a raster's record (where the zero-padded mapping sees the cut)
EDGE = 40


def raster_row(act, d):
    """(measured, without the modes) settled max against the shaped reference [% of 20 µm]."""
    _, u, fade, shaped = rd.read_drive(d / "raster.csv", shaped=True)
    y = act.simulate(u, noise=False)
    start = fade + rd.START_PERIODS * int(round(1 / 50 / rd.T))     # the route's 50 Hz lines
    e = y - shaped
    q = without_modes(act, e, 2 * e.shape[1])
    return (100 * float(np.max(np.hypot(*e[:, start:]))) / 20,
            100 * float(np.max(np.hypot(*q[:, start:-EDGE]))) / 20)


def member(name, act, d):
    plant = load_actuator(str(d / "preset.toml"))
    rows = []
    for r in RADII:
        for f in FREQUENCIES:
            t, u, fade, _ = rd.read_drive(d / f"circle-{r}-{f}.csv", shaped=True)
            P = int(round(1 / f / rd.T))
            ref = rd.circle(r, f, 0, u.shape[1])
            y = act.simulate(u, noise=False)
            measured = rd.settled_error(ref, y, fade, P, r)[0]
            e = (y - ref)[:, fade + rd.START_PERIODS * P:]
            e = e[:, e.shape[1] - (e.shape[1] // P) * P:]
            q = without_modes(act, e)
            flat = 100 * float(np.max(np.hypot(*q))) / r
            ident = mode_amplification(plant.matrices, rd.T, HARMONICS * f)
            true = mode_amplification(actuator_matrices(act), rd.T, HARMONICS * f)
            rows.append((r, f, measured, flat, float(ident.max()), float(true.max())))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("work", nargs="+", help="route_defaults --work directories")
    ap.add_argument("--seed", type=int, default=rd.FAMILY_SEED,
                    help="the family's seed, as given to route_defaults.py")
    args = ap.parse_args(argv)
    dirs = {p.name: p for w in args.work for p in Path(w).iterdir()
            if (p / "preset.toml").is_file()}
    worst = {"measured": [], "flat": []}
    rasters = {"measured": [], "flat": []}
    print("| actuator | first mode [Hz] | worst circle: measured / without the modes [% of r] | "
          "raster against the shaped reference: measured / without the modes [% of 20 µm] | "
          "per circle (r µm, f Hz): measured / without the modes; amplification identified "
          "(true) |")
    print("|---|---|---|---|---|")
    for name, act in rd.family(20, args.seed):
        if name not in dirs:
            continue
        rows = member(name, act, dirs[name])
        wm, wf = max(x[2] for x in rows), max(x[3] for x in rows)
        worst["measured"].append(wm)
        worst["flat"].append(wf)
        cells = "; ".join(f"{r}/{f}: {m:.2f}/{q:.2f} x{a:.1f} ({b:.1f})"
                          for r, f, m, q, a, b in rows)
        rm, rf = raster_row(act, dirs[name])
        rasters["measured"].append(rm)
        rasters["flat"].append(rf)
        print(f"| {name} | {act.modes_hz[0]:.0f} | {wm:.2f} / {wf:.2f} | {rm:.2f} / {rf:.2f} | "
              f"{cells} |", flush=True)
    for what, table in (("worst circle per actuator", worst), ("raster", rasters)):
        for key, vals in table.items():
            if vals:
                print(f"{what}, {key}: median {np.median(vals):.2f}, worst {max(vals):.2f} %; "
                      f"{sum(v <= 1.5 for v in vals)} of {len(vals)} within 1.5 %")


if __name__ == "__main__":
    main()
