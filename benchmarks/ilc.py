"""Iterative learning control against the issue's targets: error per iteration.

The actuator is the bundled ``rakotondrabe-2dof`` (PI + bending modes); the
learning model has its PI and the mismatched dynamics of
``scenarios/presets/mismatch/*.toml`` (natural frequencies +-5 %, damping
+-30 %); the start drive is the Hammerstein compensator of that model; every
trial is measured with 40 nm RMS white sensor noise. Printed per case: the
max Euclidean error in % of the radius (rasters: of the 40 µm size) for
trials 0..10 on the noise-free output, over the window after the fade-in
and one period, the largest growth from one trial to the next, and the CPU
time. Targets: <= 0.3 % within 10 iterations, no growth above 10 %.

    python benchmarks/ilc.py [--quick] [--gain 0.5] [--q 500] [--only raster]
    python benchmarks/ilc.py --plant realistic --gain 0.8 --q 500    # realistic-2dof, realistic-b
    python benchmarks/ilc.py --plant realistic --model preisach --gain 0.8 --q 500
    python benchmarks/ilc.py --files --gain 0.8 --q 500              # learn through files
    python benchmarks/ilc.py --files --model preisach --lab-delay given   # delay in every record
    python benchmarks/ilc.py --files --model classical --lab-delay auto   # ... found by identify
    python -m benchmarks.ilc --files --model preisach --lab-delay auto --actuator realistic-b
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np

from hammerstein.signals import references as refs
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.ilc import LearningCompensator
from hammerstein.io.presets import load_dynamics, load_plant
from hammerstein.scenario.registry import build_compensator

ROOT = Path(__file__).resolve().parents[1]


def cases(quick, full=False):
    circles = [(15.0, 10.0), (15.0, 200.0), (50.0, 50.0), (50.0, 200.0)] if not quick else \
        [(15.0, 200.0)]
    if full and not quick:
        circles = [(R, f) for R in (15.0, 30.0, 50.0) for f in (10.0, 50.0, 100.0, 200.0)]
    for R, f in circles:
        periods = 6 if f < 50 else 12
        yield f"circle {R:g} µm {f:g} Hz", R, f, ("circle", R, f, periods)
    for f in ([10.0, 40.0] if not quick else [40.0]):
        yield f"raster 40x40 µm {f:g} Hz", 40.0, f, ("raster", 40.0, f, 16)


def signal(spec, T):
    kind, size, f, n = spec
    if kind == "circle":
        _, xy = refs.circle(T, size, f, periods=n)
        return xy, int(round(1 / f / T))
    _, xy = refs.raster(T, [size, size], n, f, slow="step", smoothing=0.1)
    return xy, int(round(1 / f / T))


def actuators(which, quick, model_class="classical"):
    """(label, plant, start-compensator factory) of the actuators benchmarked."""
    if which == "rakotondrabe":
        plant = load_plant("rakotondrabe-2dof")
        T = plant.sampling_period
        for mm in (["fn+5", "fn-5", "zeta+30", "zeta-30"] if not quick else ["fn+5"]):
            G = load_dynamics(ROOT / f"scenarios/presets/mismatch/{mm}.toml",
                              plant.hysteresis.output_names, T)
            yield mm, plant, (lambda G=G: HammersteinCompensator(plant.hysteresis, G))
        return
    spec = {"kind": "hammerstein", "model": "identified",
            "identify": {"frequency": 50.0, "sensor": True}, "dynamics": "identified"}
    for name in (["realistic-2dof", "realistic-b"] if not quick else ["realistic-2dof"]):
        plant = load_plant(name if name == "realistic-2dof"
                           else ROOT / f"scenarios/presets/{name}.toml")
        c0 = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if model_class == "classical":
                start = build_compensator(spec, plant, ROOT / "scenarios")   # identified once
            else:
                start = identified_through_files(plant, name, model_class)
        print(f"# {name}: start = Hammerstein compensator over the identified "
              f"{type(start.model).__name__} ({model_class}), identified in "
              f"{time.process_time() - c0:.1f} s CPU (this process; CLI children: {_CHILD_CPU[0]:.1f} s)",
              flush=True)
        yield name, plant, (lambda start=start: start)


_CHILD_CPU = [0.0]


def identified_through_files(plant, name, model_class, keep=None, record_delay=0,
                             identify_delay=0):
    """The Hammerstein compensator over a model identified as a user would, through the CLI.

    ``hammerstein excitation`` (10 V, the plant's sampling period), every
    record played through the plant from rest with 40 nm sensor noise, then
    ``hammerstein identify --model MODEL_CLASS --dynamics`` (the default
    30-level Preisach grid for ``preisach``; ``auto`` keeps the class that
    predicts the held-out minor loops better). No creep identified. With
    ``keep`` (a directory) the identified preset is copied there as
    ``model.toml``. ``record_delay``: samples the recorded outputs lag (the
    acquisition's delay, in every record as in a lab); ``identify_delay``:
    the ``identify --delay`` given (None: not given, ``auto`` with
    ``--dynamics``).
    """
    import subprocess
    import sys
    import tempfile

    from hammerstein.io.presets import load_model
    rng = np.random.default_rng(7)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        rec = d / "records"

        def cli(*a):
            t0 = os.times()
            # the package of this checkout (a worktree's), not whichever one is installed
            env = dict(os.environ, PYTHONPATH=os.pathsep.join(
                [str(ROOT)] + [v for v in [os.environ.get("PYTHONPATH")] if v]))
            res = subprocess.run([sys.executable, "-m", "hammerstein", *a], cwd=d,
                                 capture_output=True, text=True, env=env)
            t1 = os.times()
            _CHILD_CPU[0] += t1.children_user - t0.children_user + t1.children_system - t0.children_system
            if res.returncode != 0:
                raise SystemExit(f"hammerstein {a[0]} failed: {res.stderr.strip()}")
        cli("excitation", "--inputs", "ux,uy", "--amplitude", "10", "--sampling-period",
            repr(plant.sampling_period), "--out", str(rec))
        for path in sorted(rec.glob("*.csv")):
            data = np.loadtxt(path, delimiter=",", skiprows=1)
            y, _ = plant.simulate(data[:, 1:3].T)
            if record_delay:
                y = np.concatenate([np.zeros((2, record_delay)), y[:, :-record_delay]], axis=1)
            y = y + 0.04 * rng.standard_normal(y.shape)
            np.savetxt(path, np.column_stack([data, y.T]), delimiter=",", header="t,ux,uy,x,y",
                       comments="", fmt="%.9g")
        hyst = [str(rec / f"hysteresis-{i}.csv") for i in ("ux", "uy")]
        dyn = [str(rec / f"multisine-{i}.csv") for i in ("ux", "uy")] + \
              [str(rec / f"multisine-{i}-validation.csv") for i in ("ux", "uy")]
        preset = d / f"{name}-identified.toml"
        cli("identify", *hyst, "--inputs", "ux,uy", "--outputs", "x,y", "--time", "t", "--dynamics",
            "--dynamics-records", *dyn, "--out", str(preset), "--model", model_class,
            *([] if identify_delay is None else ["--delay", str(identify_delay)]))
        model = load_model(str(preset))
        G = load_plant(str(preset)).dynamics
        if keep is not None:
            (Path(keep) / "model.toml").write_bytes(preset.read_bytes())
    return HammersteinCompensator(model, G)


def file_cases(args):
    """(label, reference TOML, scale [µm]) of the --files route."""
    circles = [(15.0, 10.0), (50.0, 10.0), (50.0, 50.0), (50.0, 200.0), (15.0, 200.0)]
    if args.quick:
        circles = [(50.0, 200.0)]
    elif args.model == "classical" and not args.lab_delay:
        circles = circles[2:]                      # the cases measured before
    for R, f in circles:
        yield (f"circle {R:g} µm {f:g} Hz",
               f'{{ kind = "circle", radius = {R:g}, frequency = {f:g}, periods = '
               f'{6 if f < 50 else 12} }}', R)
    if args.lab_delay and not args.quick:
        for f in (10.0, 40.0):
            yield (f"raster 40x40 µm {f:g} Hz",
                   f'{{ kind = "raster", outputs = ["x", "y"], size = [40.0, 40.0], lines = 16, '
                   f'frequency = {f:g}, slow = "step", smoothing = 0.1 }}', 40.0)


def through_files(args):
    """Ten ``learn`` trials through files against an actuator (``--actuator``, default
    realistic-2dof), as a user with hardware would.

    The model is identified on the actuator through the sensor (as the
    scenarios' ``model = "identified"``) and saved as a preset file, or, with
    ``--lab-delay``, through ``hammerstein identify`` on excitation records
    that carry the lab's 3-sample delay; the first drive comes from
    ``hammerstein compensate`` on it; each trial applies the drive file to
    the actuator, writes the measured response (40 nm noise, a 3-sample
    delay) to a CSV and calls ``hammerstein learn``. Printed: the true max
    Euclidean error per trial [% of the radius, of the raster's size] after
    the fade-in and three periods, the delay ``learn`` used, the final and
    smallest error and the largest growth from one trial to the next.
    """
    import contextlib
    import io
    import re
    import tempfile

    import pandas as pd

    from hammerstein.cli._hardware import load_reference
    from hammerstein.compensation.drive import drive_fade_samples
    from hammerstein.cli.main import main as cli
    from hammerstein.compensation.drive import read_signals
    from hammerstein.compensation.hammerstein_compensator import fade_in
    from hammerstein.io.presets import dynamics_to_table, read_toml, save_model
    name = args.actuator
    plant = load_plant(name if name == "realistic-2dof" else ROOT / f"scenarios/presets/{name}.toml")
    T = plant.sampling_period
    spec = {"kind": "hammerstein", "model": "identified",
            "identify": {"frequency": 50.0, "sensor": True}, "dynamics": "identified"}
    summary = []
    keep = Path(args.keep) if args.keep else None
    if keep is not None:
        keep.mkdir(parents=True, exist_ok=False)
    with tempfile.TemporaryDirectory() if keep is None else contextlib.nullcontext(keep) as tmp:
        d = Path(tmp)
        if args.model == "classical" and not args.lab_delay:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                start = build_compensator(spec, plant, ROOT / "scenarios")
            save_model(start.model, d / "model.toml", extra={
                "preset": {"name": f"{name}-identified", "sampling_period": T},
                "dynamics": dynamics_to_table(start.dynamics)})
        else:          # the preset written by identify --model ... --dynamics
            lab = args.lab_samples if args.lab_delay else 0   # the trials' delay, in the records too
            c0 = time.process_time()
            given = {"given": lab, "ignored": 0, "auto": None}.get(args.lab_delay, 0)  # --delay
            identified_through_files(plant, name, args.model, keep=d, record_delay=lab,
                                     identify_delay=given)
            ident = read_toml(d / "model.toml").get("identification", {})
            est = ident.get("measurement_delay_estimate", {})
            print(f"# identified ({args.model}) in {_CHILD_CPU[0]:.1f} s CPU of CLI children: "
                  f"model file's measurement delay {ident.get('measurement_delay_samples')} "
                  f"samples (estimate {est.get('samples', float('nan')):.2f} +- "
                  f"{est.get('std_samples', float('nan')):.2f}); G's modes "
                  + ", ".join(f"{m['frequency_hz']:.0f} Hz/{m['damping_ratio']:.2f}"
                              for m in ident.get("dynamics", {}).get("modes", [])), flush=True)
        for label, ref, scale in file_cases(args):
            if args.only and args.only not in label:
                continue
            c0 = time.process_time()
            case = d / re.sub(r"[^0-9a-z]+", "-", label)
            case.mkdir()
            rc = cli(["compensate", str(d / "model.toml"), "--reference", ref, "--out",
                      str(case / "u0.csv")])
            reference = load_reference(ref, plant)
            P = reference.period_samples
            fade = drive_fade_samples(case / "u0.csv")
            target = fade_in(reference.signal, fade)
            w = slice(fade + 3 * P, None)   # after the fade-in and three periods (4P for circles)
            errors, delays = [], set()
            for k in range(args.iterations + 1):
                t, u, _ = read_signals(case / f"u{k}.csv", ["ux", "uy"])
                clean, _ = plant.simulate(u)
                errors.append(np.linalg.norm(target[:, w] - clean[:, w], axis=0).max()
                              / scale * 100)
                lag = args.lab_samples
                y = np.concatenate([np.zeros((2, lag)), clean[:, :clean.shape[1] - lag]], axis=1)
                y = y + np.random.default_rng(k).normal(0.0, 0.04, y.shape)
                pd.DataFrame({"t": t, "x": y[0], "y": y[1]}).to_csv(case / f"y{k}.csv",
                                                                    index=False)
                if k == args.iterations:
                    break
                said = io.StringIO()
                with warnings.catch_warnings(), contextlib.redirect_stdout(said):
                    warnings.simplefilter("ignore")
                    rc = cli(["learn", str(d / "model.toml"), "--reference", ref, "--drive",
                              str(case / f"u{k}.csv"), "--measured", str(case / f"y{k}.csv"),
                              "--out", str(case / f"u{k + 1}.csv"), "--history",
                              str(case / "hist"), "--learning-gain", str(args.gain),
                              "--q-cutoff-hz", str(args.q), "--limits", "clip",
                              "--delay", args.delay]
                             + ([] if args.slope_floor is None
                                else ["--slope-floor", str(args.slope_floor)]))
                delays.update(int(v) for v in re.findall(r"measured delay (\d+) samples",
                                                         said.getvalue()))
                if keep is not None:
                    (case / f"learn{k}.txt").write_text(said.getvalue())
                if rc != 0:
                    print(f"learn failed at trial {k}")
                    break
            e = np.array(errors)
            growth = np.max(e[1:] / e[:-1]) if e.size > 1 else 1.0
            ok = e[-1] <= 0.3 and growth <= 1.10
            summary.append((label, e[-1], growth, ok))
            print(f"files {label}".ljust(34) + " ".join(f"{v:.3g}" for v in e)
                  + f" | final {e[-1]:.3f} % (min {e.min():.3f}), max growth x{growth:.2f}, "
                    f"learn's delay {sorted(delays)} {'OK' if ok else 'MISS'}, "
                    f"CPU {time.process_time() - c0:.1f} s", flush=True)
    if summary:
        print(f"# {len(summary)} cases: {sum(ok for *_, ok in summary)} within 0.3 % after "
              f"{args.iterations} trials and x1.10; worst final "
              f"{max(v for _, v, _, _ in summary):.3f} %, largest growth "
              f"x{max(g for _, _, g, _ in summary):.3f}; load {os.getloadavg()[0]:.2f}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--gain", type=float, default=0.5)
    ap.add_argument("--q", type=float, default=500.0)        # learn's default
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--plant", choices=["rakotondrabe", "realistic"], default="rakotondrabe",
                    help="realistic: the actuators outside the model class (realistic-2dof and "
                         "scenarios/presets/realistic-b.toml), start drive identified on them")
    ap.add_argument("--model", choices=["classical", "preisach", "auto"], default="classical",
                    help="--plant realistic: class of the identified start model; classical: the "
                         "scenarios' model = \"identified\" (a PI at 50 Hz through the sensor); "
                         "preisach/auto: identify --model preisach/auto --dynamics on excitation "
                         "records played through the actuator (40 nm noise), as a user would")
    ap.add_argument("--time-domain", action="store_true",
                    help="learn periodic references through the time-domain inverse and Q only "
                         "(no per-harmonic learning)")
    ap.add_argument("--delay", default="auto",
                    help="--delay of learn in the --files route (auto or the known 3 samples)")
    ap.add_argument("--only", default=None,
                    help="run only the cases whose actuator or case label contains this text "
                         "(e.g. 'raster', 'fn-5', 'realistic-b'); identification still runs per actuator")
    ap.add_argument("--lab-delay", choices=["given", "ignored", "auto"], default=None,
                    help="--files: the 3-sample delay in the identification records too, as in "
                         "a lab, and the model identified from them through the CLI (also "
                         "--model classical); given: identify --delay 3, ignored: identify "
                         "--delay 0, auto: identify without --delay (estimated from the "
                         "multisines); adds the 40x40 um rasters at 10 and 40 Hz")
    ap.add_argument("--lab-samples", type=int, default=3,
                    help="--files: the lab's delay [samples] in every trial (and, with "
                         "--lab-delay, in every identification record); default 3")
    ap.add_argument("--slope-floor", type=float, default=None,
                    help="--files: learn --slope-floor (default: learn's own)")
    ap.add_argument("--keep", metavar="DIR",
                    help="--files: keep the model, drives, measurements, learn's printout and "
                         "history of every case in DIR (a new directory)")
    ap.add_argument("--files", action="store_true",
                    help="realistic-2dof through compensate/learn files (the hardware route)")
    ap.add_argument("--actuator", choices=["realistic-2dof", "realistic-b", "realistic-gpi"],
                    default="realistic-2dof",
                    help="--files: the actuator the trials run on (realistic-b: "
                         "scenarios/presets/realistic-b.toml)")
    args = ap.parse_args()
    if args.files:
        print(f"load {os.getloadavg()[0]:.2f}; {args.actuator}; gain {args.gain}, Q {args.q:g} Hz, "
              f"40 nm noise, {args.lab_samples}-sample delay, learn through files, identified model: "
              f"{args.model}"
              + (f"; the delay in the identification records too, {args.lab_delay} to identify"
                 if args.lab_delay else ""))
        through_files(args)
        return
    print(f"load {os.getloadavg()[0]:.2f}; gain {args.gain}, Q {args.q:g} Hz, 40 nm noise, "
          f"{'time-domain' if args.time_domain else 'per-harmonic'} learning of periodic references")
    worst, misses, n_cases = 1.0, [], 0
    for mm, plant, make_start in actuators(args.plant, args.quick, args.model):
        T = plant.sampling_period
        for label, scale, f, spec in cases(args.quick, full=args.plant == "realistic"):
            if args.only and args.only not in f"{mm} {label}":
                continue
            yr, P = signal(spec, T)
            start = make_start()
            ilc = LearningCompensator(start, T, args.iterations, args.gain, args.q,
                                      sensor_noise=0.04, seed=1, harmonics=not args.time_domain)
            fade = P if spec[0] == "circle" else 0
            c0 = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ilc.run_reference(plant, yr, P, fade)
            cpu = time.process_time() - c0
            e = np.array([r.max_euclidean_error for r in ilc.history]) / scale * 100
            growth = np.max(e[1:] / e[:-1]) if e.size > 1 else 1.0
            worst, n_cases = max(worst, growth), n_cases + 1
            if e.min() > 0.3:
                misses.append(f"{mm} {label}")
            print(f"{mm:14s} {label:24s} " + " ".join(f"{v:.3g}" for v in e)
                  + f" | final {e[-1]:.3f} % {'OK' if e.min() <= 0.3 else 'MISS'}, "
                    f"max growth x{growth:.2f}, {ilc.stopped}, CPU {cpu:.1f} s", flush=True)
    print(f"# {n_cases} cases: largest growth from one trial to the next x{worst:.3f}; "
          f"{len(misses)} above 0.3 % after 10 trials{': ' + ', '.join(misses) if misses else ''}; "
          f"load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
