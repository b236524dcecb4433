"""A unipolar 0-150 V stage through the route with every default (``excitation --range``).

The actuator is a simulator written apart from the package by a session that saw only its
user documentation (a new user's check): a two-axis piezo-stack stage, Maxwell-slip
(elasto-slip) hysteresis of 30 elements per direct path with skewed thresholds (loop width
13-15 % of the stroke), a hysteretic uy -> x coupling (about 4 %) and a linear ux -> y one
(3 %), creep of three lags (0.1, 1, 10 s, 1.9 %), two coupled bending modes (180 Hz,
damping 0.03; 700 Hz, 0.05) and 20 nm sensor noise, sampled at 10 kHz. None of the package's
model classes is Maxwell-slip. ``demagnetise.csv`` is played before every file and drive
(the stage's memory continues through it).

The route: ``excitation --range 0,150``; ``identify`` as the excitation README says;
``compensate`` circles of 15 and 30 µm around (50, 50) µm at 10, 50 and 100 Hz, each with
its defaults and with ``--inversion stable``; each drive played back; the settled max
Euclidean error (after the fade-in and two periods) in % of the radius, the drive's range,
its first sample and its largest step against the settled drive's.

Usage::

    python benchmarks/unipolar_route.py [--work DIR]

About 1-2 min of CPU.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy import signal

T = 1e-4
VMAX = 150.0


def _build(seed=12345):
    rng = np.random.default_rng(seed)
    P = {}
    n = 30
    paths = []  # (output, input, thresholds+, thresholds-, weights)
    for out, inp, skew, wsum in ((0, 0, 0.35, 0.80), (1, 1, 0.25, 0.74)):
        d = np.sort(np.exp(rng.uniform(np.log(3.0), np.log(110.0), n)))  # V
        w = rng.uniform(0.2, 1.0, n)
        w = w / w.sum() * wsum                         # sum of stiffnesses < linear slope 1
        paths.append((out, inp, d * (1 + skew), d * (1 - skew), w))
    # cross-coupling uy -> x with its own small hysteresis
    d = np.sort(np.exp(rng.uniform(np.log(1.0), np.log(50.0), 10)))
    w = rng.uniform(0.2, 1.0, 10); w = w / w.sum() * 0.5
    paths.append((0, 1, d * 1.2, d * 0.8, w))
    P['paths'] = paths
    return P


P = _build()
# static part per output: y_h = S_out * (a1*u + a2*u^2/150 - sum w*z) for the direct path
S_DIRECT = (0.65, 0.69)          # µm/V scale (about 100 µm at 150 V after the hysteresis)
A2 = (0.18, 0.10)               # skew (convex anhysteretic curve)
S_CROSS_X = 0.045 * 0.75        # uy -> x: ~4 % incl. hysteresis
S_CROSS_Y = 0.032 * 0.75        # ux -> y: ~3 %, linear + slight quadratic, no hysteresis
CREEP_TAU = np.array([0.1, 1.0, 10.0])
CREEP_W = np.array([0.006, 0.006, 0.007])   # ~1.9 % after a long hold


def _dyn():
    w1, w2 = 2 * np.pi * 180.0, 2 * np.pi * 700.0
    z1, z2 = 0.03, 0.05
    R1 = np.array([[0.85, 0.04], [-0.03, 0.80]])
    R2 = np.eye(2) - R1
    # modal: q_j'' = -w^2 q - 2zw q' + w^2 * (R_j row-mixing), two outputs per mode
    A = np.zeros((8, 8)); B = np.zeros((8, 2)); C = np.zeros((2, 8))
    k = 0
    for (w, z, R) in ((w1, z1, R1), (w2, z2, R2)):
        for o in range(2):
            A[k, k + 1] = 1.0
            A[k + 1, k] = -w * w
            A[k + 1, k + 1] = -2 * z * w
            B[k + 1, :] = w * w * R[o, :]
            C[o, k] = 1.0
            k += 2
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, np.zeros((2, 2))), T, method='zoh')
    return Ad, Bd, Cd


AD, BD, CD = _dyn()


def hysteresis(u):
    """u (2, N) V -> static hysteretic outputs (2, N) µm, from the virgin state."""
    u = np.asarray(u, float)
    N = u.shape[1]
    idx, hi, lo, w, out = [], [], [], [], []
    for (o, i, dp, dm, ww) in P['paths']:
        idx.append(np.full(len(ww), i)); hi.append(dp); lo.append(-dm); w.append(ww); out.append(np.full(len(ww), o))
    idx = np.concatenate(idx); hi = np.concatenate(hi); lo = np.concatenate(lo)
    w = np.concatenate(w); out = np.concatenate(out)
    ne = len(idx)
    z = np.zeros(ne)
    Z = np.empty((N, ne))
    du = np.diff(np.concatenate([np.zeros((2, 1)), u], axis=1), axis=1)
    for k in range(N):
        z = np.minimum(np.maximum(z + du[idx, k], lo), hi)
        Z[k] = z
    ux, uy = u
    x = S_DIRECT[0] * (ux + A2[0] * ux ** 2 / VMAX - Z[:, :30] @ w[:30])
    y = S_DIRECT[1] * (uy + A2[1] * uy ** 2 / VMAX - Z[:, 30:60] @ w[30:60])
    x = x + S_CROSS_X * (uy - Z[:, 60:] @ w[60:])
    y = y + S_CROSS_Y * (ux + 0.15 * ux ** 2 / VMAX)
    return np.vstack([x, y])


def creep(h):
    """y = h + sum_k w_k x_k, tau_k dx_k/dt = h - x_k (x_k = 0 at rest): +2.2 % drift after a step."""
    a = np.exp(-T / CREEP_TAU)
    out = h.copy()
    for ak, wk in zip(a, CREEP_W):
        xk = signal.lfilter([0.0, 1 - ak], [1.0, -ak], h, axis=1)
        out += wk * xk
    return out


def dynamics(v):
    N = v.shape[1]
    x = np.zeros(AD.shape[0])
    # step of an LTI system: use dlsim-equivalent via lfilter on states is awkward; loop in blocks
    _, y, _ = signal.dlsim((AD, BD, CD, np.zeros((2, 2)), T), v.T, x0=x)
    return y.T


def simulate(u, seed=0, noise=0.020):
    u = np.asarray(u, float)
    h = hysteresis(u)
    c = creep(h)
    y = dynamics(c)
    rng = np.random.default_rng(seed)
    return y + noise * rng.standard_normal(y.shape)




def _run(args, cwd):
    p = subprocess.run([sys.executable, "-m", "hammerstein", *args], cwd=cwd,
                       capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def _drive(path):
    text = Path(path).read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    v = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    return np.vstack([v[:, head.index("ux")], v[:, head.index("uy")]]), fade


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", help="keep the files here (default a temporary directory)")
    args = ap.parse_args(argv)
    work = Path(args.work or tempfile.mkdtemp(prefix="unipolar-"))
    work.mkdir(parents=True, exist_ok=True)
    code, out = _run(["excitation", "--inputs", "ux,uy", "--range", "0,150", "--sampling-period",
                      str(T), "--out", "exc", "--force"], work)
    if code:
        raise SystemExit(out)
    d = np.genfromtxt(work / "exc" / "demagnetise.csv", delimiter=",", names=True)
    demag = np.vstack([d["ux"], d["uy"]])

    def play(u, seed):
        assert u.min() >= 0.0 and u.max() <= VMAX, "a command outside 0..150 V"
        return simulate(np.concatenate([demag, u], axis=1), seed=seed)[:, demag.shape[1]:]

    files = {"hysteresis": [], "multisine": [], "creep": []}
    for i, f in enumerate(sorted((work / "exc").glob("*.csv"))):
        if f.name == "demagnetise.csv":
            continue
        r = np.genfromtxt(f, delimiter=",", names=True)
        u = np.vstack([r["ux"], r["uy"]])
        np.savetxt(work / f.name, np.column_stack([r["t"], u.T, play(u, i).T]), delimiter=",",
                   header="t,ux,uy,x,y", comments="", fmt="%.9g")
        files[next(k for k in files if f.name.startswith(k))].append(f.name)
    validation = sorted(f for f in files["multisine"] if "validation" in f)
    code, out = _run(["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
                      "--time", "t", "--dynamics", "--dynamics-records",
                      *sorted(set(files["multisine"]) - set(validation)), *validation,
                      "--creep-records", *files["creep"], "--out", "preset.toml"], work)
    if code:
        raise SystemExit(out)
    for line in out.splitlines():
        if "chose" in line or "held-out fit" in line and "order" not in line or "warning" in line:
            print(line.strip()[:160])
    for inversion in ("zpetc", "stable"):
        for radius, freq in ((15, 10), (30, 10), (15, 50), (30, 50), (30, 100)):
            periods = max(4, int(0.2 * freq))
            spec = (f"{{ kind = \"circle\", radius = {radius}, frequency = {freq}, "
                    f"periods = {periods}, center = [50, 50] }}")
            name = f"{inversion}-{radius}-{freq}.csv"
            code, out = _run(["compensate", "preset.toml", "--reference", spec, "--inversion",
                              inversion, "--out", name, "--force"], work)
            if code:
                print(f"{inversion} circle {radius} µm {freq} Hz: refused: {out.strip()[:120]}")
                continue
            u, fade = _drive(work / name)
            y = play(u, 0)
            t = np.arange(u.shape[1]) * T
            ref = 50.0 + radius * np.vstack([np.cos(2 * np.pi * freq * t),
                                             np.sin(2 * np.pi * freq * t)])
            s = fade + 2 * int(round(1 / freq / T))
            e = np.linalg.norm(y[:, s:] - ref[:, s:], axis=0)
            steps = np.abs(np.diff(np.concatenate([np.zeros((2, 1)), u], axis=1), axis=1))
            print(f"{inversion} circle {radius} µm {freq} Hz: settled max {100 * e.max() / radius:.3g} % "
                  f"of r, drive {u.min():.3g}..{u.max():.3g} V, first {np.abs(u[:, 0]).max():.2g} V, "
                  f"step ratio {steps.max() / steps[:, s:].max():.3g}")


if __name__ == "__main__":
    main()
