"""Which loop brings feedforward + feedback to 0.3 % on realistic-2dof: the options, measured.

Run (from the repository root)::

    python benchmarks/feedback_options.py [--only 10Hz,raster] [--options pi-notch,pi-notch+im3]
        [--no-noise] [--without-feedforward] [--decay 2] [--max-harmonic 380]

Not a test. The feedforward is the Hammerstein compensator identified on the
actuator exactly as ``scenarios/realistic-feedback.toml`` (and ``hammerstein
run``) identifies it; the references are that scenario's (15 and 40 µm
circles at 10-100 Hz, 40 x 40 µm raster at 20 Hz); the sensor 40 nm RMS at
5 kHz with one sample of delay, the amplifier +/-10 V with back-calculation.
Every option runs every case with the feedforward and prints the settled max
error in % of the radius (the largest ``||r - y||`` over the settled
window, as the scenario's ``max_euclidean_error_percent``), so the table of docs/feedback.md can be
re-measured. Options:

* ``pi-notch``: the bundled scenario's loop (PI + notch, 150 Hz crossover);
* ``ppf``, ``irc``: the damping designs (``BASE@FC`` sets the crossover);
* ``vel@FC@KD``: an integral-like PI (zero at 8 times the crossover FC, no
  notch) in parallel with velocity feedback on the error,
  ``KD / g * s * w_f^2 / (s^2 + 2 w_f s + w_f^2)`` with ``w_f = 2 pi 4 kHz``
  (``KD`` [s]; 4e-4 takes the first modes' damping from 0.06-0.08 to
  0.3-0.5): direct damping of the modes, what it buys and what the sensor's
  noise costs;
* ``BASE+imN``: BASE with internal-model (resonant) elements at the
  reference's harmonics 1..N below ``--max-harmonic``, each ``k_h w_h (s cos phi_h + w_h sin phi_h) / (s^2 + w_h^2)`` in
  series with the PI (phase lead ``phi_h = -arg T(j w_h)`` so the loop
  stays stable, gain ``k_h`` so that each harmonic's error decays to e^-3
  in ``--decay`` periods of the fundamental; pre-warped so that Tustin puts
  the pole on the harmonic exactly:
  :func:`hammerstein.compensation.feedback.with_internal_model`);
* ``--no-noise``: the same without sensor noise (what the noise costs);
* ``--without-feedforward``: the loop alone (what the feedforward adds);
* ``--max-harmonic``: internal models only below this frequency;
  ``--decay``: the periods in which each harmonic's error decays (gain);
* ``--bands``: where the error is, for each case and option, the feedforward
  alone first: the RMS of the settled error's Fourier components per axis
  in the bands 0-1, 1-60, 60-200, 200-600 and 600-10000 Hz [nm] (the
  bending modes are at 420-450 Hz and 1300 Hz);
* ``--levels N``: the identified Preisach grid's levels (30 as in the
  scenario);
* ``--kinks``: the actuator's own hysteresis (no modes), driven by smooth
  20 Hz circles of 3 and 8 V: the RMS of its output per band [nm], i.e.
  what its piecewise-linear loops put near the modes whatever the drive.

Each option also prints its noise floor: the largest Euclidean position
error [nm] over 0.5 s of the loop at rest with the sensor's noise alone.

Prints the load average before and after and the CPU time of the process.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import control  # noqa: E402

from hammerstein.compensation.feedback import (AxisDesign, FeedbackLoop,  # noqa: E402
                                               design_axis, diagonal_controller,
                                               linearised_plant, with_internal_model)
from hammerstein.compensation.hammerstein_compensator import fade_in  # noqa: E402
from hammerstein.scenario.execute import fade_samples  # noqa: E402
from hammerstein.scenario.feedback import _feedforward, _metrics, build_loops  # noqa: E402
from hammerstein.scenario.resolve import resolve_scenario  # noqa: E402
from hammerstein.scenario.validate import validate_scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def scenario_text(noise_nm):
    """The bundled scenario with the identified feedforward only."""
    text = (ROOT / "scenarios" / "realistic-feedback.toml").read_text(encoding="utf-8")
    text = text.replace('preset-model = { kind = "hammerstein", model = "plant", dynamics = '
                        '"plant", creep = "plant" }\n', "")
    return text.replace("noise_nm = 40.0", f"noise_nm = {noise_nm}")


def velocity_design(gain, crossover_hz, kd, filter_hz=4000.0):
    """PI (zero at 8 crossovers) in parallel with filtered velocity feedback on the error."""
    pi = design_axis("pi", gain, crossover_hz, zero_hz=8.0 * crossover_hz).system
    s = control.tf("s")
    wf = 2 * np.pi * filter_hz
    system = control.parallel(pi, control.ss(kd / gain * s * wf ** 2 / (s ** 2 + 2 * wf * s
                                                                          + wf ** 2)))
    mask = np.zeros(system.nstates, bool)
    mask[0] = True
    return AxisDesign(system, mask, f"PI + velocity feedback {kd:g} s")


def noise_floor(loop, n=20000, seed=3):
    """Largest Euclidean position [nm] over the last half of n samples at rest, noise only."""
    m = loop.controller.n_outputs
    y = loop.simulate(np.zeros((loop.controller.n_measurements, n)),
                      feedforward=np.zeros((m, n)), seed=seed).outputs[:, n // 2:]
    y = y - y.mean(axis=1, keepdims=True)
    return 1e3 * float(np.max(np.linalg.norm(y, axis=0)))


def kinks(plant, T):
    """RMS [nm] per band of the actuator's hysteresis output on smooth 20 Hz circles."""
    P = int(round(1 / (20.0 * T)))
    t = np.arange(6 * P) * T
    for amp in (3.0, 8.0):
        u = amp * np.vstack([np.sin(2 * np.pi * 20 * t), np.cos(2 * np.pi * 20 * t)])
        v = plant.hysteresis.simulate(u)
        v = np.asarray(v[0] if isinstance(v, tuple) else v)[:, -4 * P:]
        a = np.abs(np.fft.rfft(v, axis=1)) / v.shape[1] * 2
        f = np.fft.rfftfreq(v.shape[1], T)
        print(f"hysteresis alone, {amp:g} V circle at 20 Hz: " + ", ".join(
            f"{lo:g}-{hi:g} Hz " + "/".join(f"{1e3 * x:.1f}" for x in np.sqrt(np.sum(
                a[:, (f >= lo) & (f < hi)] ** 2 / 2, axis=1))) for lo, hi in BANDS[1:]))


#: frequency bands of --bands [Hz]
BANDS = ((0.0, 1.0), (1.0, 60.0), (60.0, 200.0), (200.0, 600.0), (600.0, 10000.0))


def bands(case, outputs, T):
    """RMS [nm] per axis of the settled error's Fourier components in each of :data:`BANDS`."""
    P = int(case.period_samples)
    start = int(case.settle_periods * P)
    n = (case.signal.shape[1] - start) // P * P
    e = (outputs - case.signal)[:, start:start + n]
    amp = np.abs(np.fft.rfft(e, axis=1)) / n * 2
    f = np.fft.rfftfreq(n, T)
    out = []
    for lo, hi in BANDS:
        sel = (f >= lo) & (f < hi)
        out.append(f"{lo:g}-{hi:g} Hz " + "/".join(
            f"{1e3 * v:.1f}" for v in np.sqrt(np.sum(amp[:, sel] ** 2 / 2, axis=1))))
    return ", ".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-noise", action="store_true")
    ap.add_argument("--without-feedforward", action="store_true")
    ap.add_argument("--options", default="pi-notch,pi-notch+im1,pi-notch+im3,ppf,irc")
    ap.add_argument("--max-harmonic", type=float, default=380.0,
                    help="internal models only below this frequency [Hz]")
    ap.add_argument("--only", default="", help="comma-separated substrings of case names")
    ap.add_argument("--decay", type=float, default=1.0, help="periods for the harmonics to decay")
    ap.add_argument("--bands", action="store_true", help="the error's RMS per frequency band")
    ap.add_argument("--levels", type=int, default=30, help="levels of the identified Preisach grid")
    ap.add_argument("--kinks", action="store_true",
                    help="the actuator's hysteresis alone on smooth circles, per band")
    args = ap.parse_args(argv)
    print(f"load before {os.getloadavg()}")
    cpu0 = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fb.toml"
        path.write_text(scenario_text(0.0 if args.no_noise else 40.0).replace(
            "preisach_levels = 30", f"preisach_levels = {args.levels}"), encoding="utf-8")
        spec = validate_scenario(path)
        t0 = time.perf_counter()
        cases = resolve_scenario(spec.cases_spec).cases
        print(f"resolved {len(cases)} cases (identification) in {time.perf_counter() - t0:.1f} s")
    plant = cases[0].plant
    T = plant.sampling_period
    base, _ = build_loops(spec.table, plant)
    g = np.real(np.atleast_2d(linearised_plant(plant)(1.0)))
    if args.kinks:
        kinks(plant, T)
    ffs = []
    for c in cases:
        fade = fade_samples(c) if c.compensator is not None else 0
        r_loop = fade_in(c.signal, fade) if fade else c.signal
        ff, div = _feedforward(c, r_loop, fade)
        ffs.append((r_loop, ff))
    options = args.options.split(",")
    if args.bands:
        _, loop_ff = build_loops(spec.table, plant)
        for i, c in enumerate(cases):
            if not args.only or any(o in c.name for o in args.only.split(",")):
                print(f"{c.name} feedforward alone: "
                      f"{bands(c, loop_ff.simulate(ffs[i][0], feedforward=ffs[i][1]).outputs, T)}")

    def designs(base_name):
        kind, _, fc = base_name.partition("@")
        if kind == "vel":
            fc, _, kd = fc.partition("@")
            return [velocity_design(g[l, l], float(fc or 100.0), float(kd or 4e-4))
                    for l in range(2)]
        fc = float(fc or 150.0)
        extra = [{"notch_hz": 450.0}, {"notch_hz": 420.0}] if kind == "pi-notch" else \
            [{"mode_hz": 450.0}, {"mode_hz": 420.0}]
        return [design_axis(kind, g[l, l], crossover_hz=fc, **extra[l]) for l in range(2)]

    table = {}
    floors = {}
    for opt in options:
        for i, c in enumerate(cases):
            if args.only and not any(o in c.name for o in args.only.split(",")):
                continue
            f0 = c.signal_spec.get("frequency") if isinstance(c.signal_spec, dict) else None
            f0 = float(f0 if f0 is not None else 1.0 / (c.period_samples * T))
            base_name, _, im = opt.partition("+im")
            harm = [h * f0 for h in range(1, int(im or 0) + 1) if h * f0 < args.max_harmonic]
            d0 = designs(base_name)
            ctrl0 = diagonal_controller(d0, T, "tustin")
            loop0 = FeedbackLoop(plant, ctrl0, base.sensor, base.amplifier, base.anti_windup,
                                 base.tracking_time)
            L0 = loop0.loop_transfer()
            ds = [with_internal_model(d, lambda z, l=l: L0(z)[l, l], T, harm, args.decay)
                  for l, d in enumerate(d0)]
            loop = FeedbackLoop(plant, diagonal_controller(ds, T, "tustin"), base.sensor,
                                base.amplifier, base.anti_windup, base.tracking_time)
            poles = np.abs(control.poles(loop.closed_system()))
            if np.max(poles) >= 1:
                table[(c.name, opt)] = "unstable"
                continue
            if opt not in floors and not harm:
                floors[opt] = noise_floor(loop)
            r_loop, ff = ffs[i]
            both = loop.simulate(r_loop, feedforward=0 * ff if args.without_feedforward else ff,
                                 seed=i)
            rows = _metrics(c, both.outputs, both.inputs)
            mx = [r["value"] for r in rows if r["metric"] == "max_euclidean_error_percent"]
            table[(c.name, opt)] = f"{max(mx):.3g}" if mx else "?"
            if args.bands:
                print(f"{c.name} {opt}: {bands(c, both.outputs, T)}")
            if i == 0 and opt == options[0]:
                print(sorted({r["metric"] for r in rows}))
    print("case".ljust(24) + "".join(o.rjust(12) for o in options))
    for c in cases:
        print(c.name.ljust(24) + "".join(str(table.get((c.name, o), "-")).rjust(12)
                                         for o in options))
    print("noise floor [nm]".ljust(24) + "".join(
        (f"{floors[o]:.1f}" if o in floors else "-").rjust(12) for o in options))
    print(f"CPU {time.process_time() - cpu0:.1f} s; load after {os.getloadavg()}")


if __name__ == "__main__":
    main()
