"""Records to hardware with every default, on a seeded family of independent actuators.

Per actuator (Preisach-type ``tests/outside_actuator.py`` or generalised-PI-type
``tests/gpi_actuator.py``, simulated outside the project's model classes,
with varied loop shapes and skews, couplings, first mode 250-600 Hz, creep
strength and 40 nm noise):

1. ``hammerstein excitation`` writes the excitation files; they are played
   through the actuator and ``hammerstein identify`` is run as the
   excitation README says (hysteresis records, ``--dynamics`` on the
   multisines, ``--creep-records`` on the staircases);
2. ``hammerstein compensate`` with its defaults writes the drive of circles
   (15-50 µm, 10-200 Hz, starting at (r, 0)) and of a 40 x 40 µm raster;
   each drive is played through the actuator;
3. ten ``hammerstein learn`` trials through files on a circle that starts
   at (r, 0) (30 µm, 100 Hz), every drive played through the actuator.

The Preisach-type actuators' relays switch over one spacing of their grid
(a population of domains, so the output is continuous); with
``--discrete-relays`` they switch in one sample, a whole row at once, as in
the earlier family: a staircase of 1-3 µm steps that rings the modes and
that no drive can remove.

Measured per drive, independently of the package: the settled max
Euclidean error of the position (the drive played through the actuator
without the sensor's noise: the 40 nm noise alone has a largest Euclidean
value of about 0.16 µm over the 3600 settled samples of a learning trial,
0.54 % of 30 µm and 1.1 % of 15 µm, which is not an error of the
actuator's position; the error as measured, noise included, is logged
beside it) (after the fade-in the drive file's header states and two
periods, % of the radius / half the raster's size) against the reference
asked for and, where ``compensate`` shaped it (a raster's line steps, a
range beyond the records; the drive file's ``x_shaped``, ``y_shaped``),
against the shaped reference the drive follows; whether the drive stays
within the records' input range, its first sample (V from rest), and its
largest sample-to-sample step over the settled drive's own largest. Printed:
the median and the worst of each over the family, against the targets of
issue 38. The results file reports the family of seed 2026; ``--seed``
draws another from the same distributions (``--seed 2027 --actuators 10``:
ten actuators no default was chosen or checked on).

The excitation amplitude is 20 V. Every actuator's reversible part
``a u + b u^2`` is drawn monotonic up to 40 V, so that the records cover
at least +-55 µm on each axis: the 50 µm circles are within reach. The
generalised-PI-type actuators have 24 plays per direct path (12 for the
coupling) under a drawn smooth density and drawn envelope skews
(``--few-plays``: the test actuator's 4-5 plays, a kink at each threshold).
Every file and drive is played after the excitation's own
``demagnetise.csv`` (its turning points, read from the file: every member is
rate-independent), as its README asks of the bench, from the state the
previous one left; the creep and the modes settled at the rest that follows.
(Before 2026-11-27 the generalised-PI-type members started from the state a
60-period decay from 30 V leaves and the Preisach-type ones from the ideal
demagnetised state: ``--ideal-start``.)

With ``--bouc-wen`` every member's hysteresis is a Bouc-Wen loop per input
(:class:`BoucWenActuator`, modes, creep and noise drawn as the others'): a
class whose memory is neither Preisach's (no wiping out: an off-centre
cycle's loop relaxes, cycle after cycle, towards one centred on the
hysteretic variable's zero) nor a play's.

Usage (2-4 minutes per actuator on two cores)::

    python benchmarks/route_defaults.py --quick      # 3 actuators, 3 circles, 1 raster
    python benchmarks/route_defaults.py              # 20 actuators, 9 circles, 1 raster
    python benchmarks/route_defaults.py --bouc-wen --actuators 10
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import numba
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from gpi_actuator import GPIActuator, _gpi  # noqa: E402
from outside_actuator import T, OutsideActuator, preisach_grid, write_csv  # noqa: E402

TRIALS = 10


def _settled(act, h, noise, rng):
    """Positions (2, N) [µm] of an actuator at rest before ``h`` (2, N) [µm] starts: the creep
    lags and the modes settled on the rest output ``h[:, 0]`` (a stack at rest for long, not one
    whose output steps from 0 to its remanence at the first sample and drifts for seconds)."""
    import scipy.signal
    from gpi_actuator import _lsim
    h0 = h[:, :1]
    if act.creep:
        w = act.creep_gain / len(act.creep_tau)
        dh = h - h0
        lags = sum(scipy.signal.lfilter([0.0, 1 - a], [1.0, -a], dh, axis=1)
                   for a in np.exp(-T / np.asarray(act.creep_tau)))
        h = h + w * (lags + len(act.creep_tau) * h0)
    n = act.Ad.shape[0]
    dc = act.C @ np.linalg.solve(np.eye(n) - act.Ad, act.Bd)      # the sampled G(1)
    y = _lsim(*map(np.ascontiguousarray, (act.Ad, act.Bd, act.C)),
              np.ascontiguousarray((h - h[:, :1]).T)).T + dc @ h[:, :1]
    if noise:
        rng = np.random.default_rng(act.seed) if rng is None else rng
        y = y + act.noise_um * rng.standard_normal(y.shape)
    return y


#: with --ideal-start, every member starts each file from its earlier idealised start
IDEAL_START = {"on": False}


def demagnetising_prefix(path):
    """The turning points (2, n) [V] of a ``demagnetise.csv`` (``ux``, ``uy``): its samples
    where either input's differences change sign, then its last sample. A rate-independent
    actuator driven through them is left where the whole file leaves it."""
    data = np.genfromtxt(path, delimiter=",", names=True, comments="#")
    u = np.vstack([data["ux"], data["uy"]])
    keep = np.zeros(u.shape[1], dtype=bool)
    for k in range(2):
        d = np.diff(u[k])
        nz = np.flatnonzero(d)
        flip = np.flatnonzero(np.sign(d[nz][1:]) != np.sign(d[nz][:-1]))
        keep[nz[flip + 1]] = True
    keep[-1] = True
    return np.ascontiguousarray(u[:, keep])


def start_after_cycle(act, directory):
    """Make ``act`` play ``directory/exc/demagnetise.csv`` before every file and drive."""
    if not IDEAL_START["on"]:
        act.demagnetise = demagnetising_prefix(Path(directory) / "exc" / "demagnetise.csv")


def _after_cycle(act, u):
    """The static part (2, N) [µm] of ``u`` played after the actuator's demagnetising prefix
    (from its rest state: the plays at rest, the relays half up, the Bouc-Wen ``z`` at 0)."""
    pre = getattr(act, "demagnetise", None)
    if pre is None:
        return act.hysteresis(u)
    return act.hysteresis(np.hstack([pre, np.asarray(u, dtype=float)]))[:, pre.shape[1]:]


def _demagnetised(spec):
    """Play states of a generalised-PI path after a demagnetising cycle (a sine decaying from
    30 V to 0 over 60 periods, from the rest state): where every file and drive starts."""
    r, w, gl, gr = (np.asarray(v, dtype=float) for v in spec)
    up0 = gl[0] * np.tanh(gl[2]) + gl[3]
    down0 = gr[0] * np.tanh(gr[2]) + gr[3]
    state = np.clip(np.zeros(r.size), up0 - r, np.maximum(down0 + r, up0 - r))
    k = np.arange(60 * 400)
    u = 30.0 * (1.0 - k / k[-1]) * np.sin(2 * np.pi * k / 400)
    _gpi(np.ascontiguousarray(u), r, w, gl, gr, state)
    return state


class CreepGPI(GPIActuator):
    """The generalised-PI actuator with the outside actuator's creep (sum of first-order lags),
    at rest in the demagnetised state (the state a demagnetising cycle leaves, which the
    Preisach-type actuators also start from) before every file or drive: its plays do not start
    from the rest state under skewed envelope functions, which no demagnetised model shares."""

    creep = True
    creep_gain = 0.02
    creep_tau = (0.05, 0.5, 5.0)

    def _play(self, u, spec):
        if getattr(self, "demagnetise", None) is not None:     # the file's cycle, from rest
            return GPIActuator._play(u, spec)
        r, w, gl, gr = (np.asarray(v, dtype=float) for v in spec)
        key = id(spec)
        cache = self.__dict__.setdefault("_demag", {})
        if key not in cache or cache[key][0] is not spec:
            cache[key] = (spec, _demagnetised(spec))
        return _gpi(np.ascontiguousarray(u, dtype=float), r, w, gl, gr, cache[key][1].copy())

    def simulate(self, u, noise=True, rng=None):
        return _settled(self, _after_cycle(self, u), noise, rng)


@numba.njit(cache=True)
def _preisach_domains(u, alpha, beta, w, state, width):
    """Relays that switch over ``width`` [V] (a domain population, not one domain): the state
    rises from -1 to 1 while u crosses [alpha - width, alpha] and falls while it crosses
    [beta, beta + width]; wiping-out memory as the relays (alpha - beta >= width)."""
    y = np.empty(u.size)
    for k in range(u.size):
        acc = 0.0
        for i in range(alpha.size):
            up = min(1.0, max(-1.0, 2.0 * (u[k] - alpha[i]) / width + 1.0))
            down = min(1.0, max(-1.0, 2.0 * (u[k] - beta[i]) / width - 1.0))
            state[i] = max(up, min(down, state[i]))
            acc += w[i] * state[i]
        y[k] = acc
    return y


class DomainPreisach(OutsideActuator):
    """The Preisach-type actuator whose relays switch over one grid spacing.

    A relay grid switches a whole row of relays in one sample: a staircase of 1-3 µm steps
    that rings the modes (a real stack's domains switch over a spread of fields); here each
    relay's state is a ramp over one spacing of its grid, so the output is continuous.
    """

    def hysteresis(self, u):
        u = np.asarray(u, dtype=float)
        h = np.zeros_like(u)
        for l in range(2):
            for k in range(2):
                a, b, w = self.grid_direct[l] if l == k else self.grid_cross[l]
                width = float(np.min(a - b))          # the grid's spacing
                state = -np.ones(a.size)
                state[(a + b) < 0] = 1.0              # demagnetised start: half up
                h[l] += _preisach_domains(np.ascontiguousarray(u[k]), a, b, w, state, width)
            ra, rb = self.reversible[l]
            h[l] += ra * u[l] + rb * u[l] ** 2
            h[l] += self.coupling_even[l] * u[1 - l] ** 2
        return h

    def simulate(self, u, noise=True, rng=None):
        """Positions (2, N) [µm] from rest in the demagnetised state, creep and modes settled."""
        return _settled(self, _after_cycle(self, u), noise, rng)


@numba.njit(cache=True)
def _bouc_wen(u, A, beta, gamma, z, step):
    """The Bouc-Wen hysteretic variable (exponent 1) along ``u`` from ``z``: rate-independent,
    ``dz = A du - beta |du| z - gamma du |z|``, so along a monotonic piece of sign ``s``
    ``dz/du = A - beta s z - gamma |z|`` (Ismail, Ikhouane and Rodellar, "The hysteresis
    Bouc-Wen model, a survey", Arch. Comput. Methods Eng. 16, 161-188, 2009), integrated by
    classical Runge-Kutta in input steps of at most ``step`` [V]."""
    out = np.empty(u.size)
    prev = u[0]
    for k in range(u.size):
        du = u[k] - prev
        m = max(1, int(np.ceil(abs(du) / step)))
        h = du / m
        s = 1.0 if du >= 0.0 else -1.0
        for _ in range(m):
            k1 = A - beta * s * z - gamma * abs(z)
            z1 = z + 0.5 * h * k1
            k2 = A - beta * s * z1 - gamma * abs(z1)
            z2 = z + 0.5 * h * k2
            k3 = A - beta * s * z2 - gamma * abs(z2)
            z3 = z + h * k3
            k4 = A - beta * s * z3 - gamma * abs(z3)
            z = z + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        out[k] = z
        prev = u[k]
    return out


class BoucWenActuator(DomainPreisach):
    """An actuator whose hysteresis is of neither model class the package identifies: a
    Bouc-Wen loop per input (no wiping-out memory, no congruent minor loops), each output
    ``a u_l + b u_l^2 - d z_l`` plus the other input's ``c1 u_k + c2 z_k + c3 u_k^2``; creep,
    modes and noise as the other members'. ``z`` starts at 0 (the state a demagnetising
    cycle leaves). Parameters ``bw`` per output: (A, beta, gamma, d, c1, c2, c3)."""

    bw: tuple = ()

    def hysteresis(self, u):
        u = np.asarray(u, dtype=float)
        z = np.vstack([_bouc_wen(np.ascontiguousarray(u[k]), *self.bw[k][:3], 0.0, 0.01)
                       for k in range(2)])
        h = np.zeros_like(u)
        for l in range(2):
            k = 1 - l
            ra, rb = self.reversible[l]
            _, _, _, d, c1, c2, c3 = self.bw[l]
            h[l] = ra * u[l] + rb * u[l] ** 2 - d * z[l] + c1 * u[k] + c2 * z[k] + c3 * u[k] ** 2
        return h


def bouc_wen(act, rng):
    """Give an actuator drawn Bouc-Wen loops (:class:`BoucWenActuator`): per output A = 1,
    beta + gamma in 0.1-0.25 /V (the loop saturates at z = A / (beta + gamma), 4-10 V),
    gamma / beta in -0.5..0.5 (the loop's shape), d 1-2 µm/V (loops 7-20 % of the
    records' span wide), couplings c1 within 8 % of a, c2 within 10 % of d, c3 within
    0.02 µm/V^2; a 3.8-4.6 µm/V and |b| <= a / 80, so that +-20 V reach +-55 µm past the
    loop's d z."""
    params, reversible = [], []
    for l in range(2):
        total, ratio = rng.uniform(0.1, 0.25), rng.uniform(-0.5, 0.5)
        beta = total / (1.0 + ratio)
        a = float(rng.uniform(3.8, 4.6))
        reversible.append((a, float(rng.uniform(-1.0, 1.0) * a / 80.0)))
        params.append((1.0, float(beta), float(total - beta), float(rng.uniform(1.0, 2.0)),
                       float(rng.uniform(-0.08, 0.08) * a), float(rng.uniform(-0.1, 0.1)),
                       float(rng.uniform(-0.02, 0.02))))
    act.bw, act.reversible = tuple(params), tuple(reversible)


#: with --bouc-wen, every member's hysteresis is a Bouc-Wen loop per input
BOUC_WEN = {"on": False}


#: with --discrete-relays, the Preisach-type actuators switch a relay row in one sample
DISCRETE = {"relays": False}

#: with --few-plays, the generalised-PI-type actuators keep the test actuator's 4-5 plays
FEW_PLAYS = {"on": False}


def _density_plays(spec, n, rng):
    """``n`` plays whose weights follow a drawn smooth density in the threshold, instead of
    the 3-5 plays of ``spec`` (whose loops have a kink at every threshold: a real stack's
    domains switch over a spread). The play at threshold 0 keeps a drawn share of the
    weight; the others share the rest by ``exp(-r / r0)``, ``r0`` drawn (the loop's
    roundness). The envelope functions are drawn around the test actuator's (gain, slope
    +-10 %, offsets inside tanh +-0.15: the skew of the rising and falling branches)."""
    r, w, gl, gr = (np.asarray(v, dtype=float) for v in spec)
    top = float(r[-1]) * rng.uniform(1.0, 1.4)
    thresholds = top * (np.arange(n) / (n - 1)) ** 1.3
    r0 = rng.uniform(0.25, 0.6) * top
    dens = np.exp(-thresholds[1:] / r0) * np.gradient(thresholds)[1:]
    total = float(w.sum()) * rng.uniform(0.9, 1.1)
    w0 = float(w[0]) / float(w.sum()) * total * rng.uniform(0.85, 1.15)
    weights = np.concatenate([[w0], (total - w0) * dens / dens.sum()])

    def envelope(g):
        g = g.copy()
        g[0] *= rng.uniform(0.9, 1.1)
        g[1] *= rng.uniform(0.9, 1.1)
        g[2] += rng.uniform(-0.15, 0.15)
        return g.tolist()
    return (thresholds.tolist(), weights.tolist(), envelope(gl), envelope(gr))


def smooth_plays(act, rng):
    """Give a generalised-PI-type actuator smooth, drawn loop shapes (24 plays per direct
    path, 12 for the x <- uy coupling; :func:`_density_plays`)."""
    act.direct = tuple(_density_plays(spec, 24, rng) for spec in act.direct)
    act.coupling = _density_plays(act.coupling, 12, rng)


#: the seed of the family benchmarks/results/route-defaults.md reports
FAMILY_SEED = 2026


def family(n, seed=FAMILY_SEED):
    """``n`` actuators drawn from one seeded generator: (name, actuator)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        f1 = rng.uniform(250.0, 600.0)
        modes = (f1, f1 * rng.uniform(0.9, 1.2), rng.uniform(1100.0, 1600.0))
        damping = tuple(rng.uniform(0.02, 0.06, 3))
        c = np.array([[1.0, rng.uniform(-0.08, 0.08), rng.uniform(0.1, 0.35)],
                      [rng.uniform(-0.08, 0.08), 1.0, -rng.uniform(0.1, 0.35)]])
        b = np.array([[rng.uniform(0.8, 0.95), rng.uniform(-0.08, 0.08)],
                      [rng.uniform(-0.08, 0.08), rng.uniform(0.8, 0.95)],
                      [rng.uniform(0.3, 0.5), -rng.uniform(0.2, 0.4)]])
        if i % 2 == 0 or BOUC_WEN["on"]:
            cls = OutsideActuator if DISCRETE["relays"] else DomainPreisach
            cls = BoucWenActuator if BOUC_WEN["on"] else cls
            act = cls(seed=i, creep=True, modes_hz=modes, damping=damping, c=c, b=b,
                                  direct_um=tuple(rng.uniform(20.0, 30.0, 2)),
                                  coupling_um=tuple(rng.uniform(0.5, 2.0, 2)),
                                  creep_gain=float(rng.uniform(0.01, 0.05)))
            skews = rng.uniform(-0.5, 0.5, 2)
            spreads = rng.uniform(0.3, 0.6, 2)
            # 64 levels (the test actuator's 24 switch rows of relays at once: a staircase of
            # 1-3 µm steps no drive can smooth; a real stack's domains switch continuously)
            act.grid_direct = [preisach_grid(n=64, scale=s, skew=sk, spread=sp) for s, sk, sp in
                               zip(act.direct_um, skews, spreads)]
            act.grid_cross = [preisach_grid(n=32, scale=s, skew=0.5) for s in act.coupling_um]
            # reversible a u + b u^2 drawn per member (its own generator, so that the other
            # draws stay those of earlier runs), monotonic up to 40 V (|b| <= a / 80): a stack
            # whose displacement falls while the voltage rises is no piezo (the earlier fixed
            # (1.8, 0.06), (1.6, -0.05) turned back at -15 and +16 V, inside the records'
            # +-20 V, and left x no more than -43 µm and y +42 µm: no 50 µm circle)
            rr = np.random.default_rng([seed, i])
            act.reversible = tuple((float(a), float(rr.uniform(-1.0, 1.0) * a / 80.0))
                                   for a in rr.uniform(2.2, 3.0, 2))
            name = f"preisach-{i}"
            if BOUC_WEN["on"]:
                bouc_wen(act, np.random.default_rng([seed, i, 2]))
                name = f"bouc-wen-{i}"
        else:
            act = CreepGPI(seed=i, modes_hz=modes, damping=damping, c=c, b=b)
            act.creep_gain = float(rng.uniform(0.01, 0.05))
            act.reversible = tuple((float(rng.uniform(2.4, 3.2)), float(rng.uniform(-0.03, 0.03)))
                                   for _ in range(2))
            if not FEW_PLAYS["on"]:
                smooth_plays(act, np.random.default_rng([seed, i, 1]))
            name = f"gpi-{i}"
        out.append((name, act))
    return out


def hammerstein(*args, cwd):
    """Run ``python -m hammerstein ARGS`` in ``cwd``; its stdout (raises on a non-zero exit)."""
    p = subprocess.run([sys.executable, "-m", "hammerstein", *map(str, args)], cwd=cwd,
                       capture_output=True, text=True, env=os.environ.copy())
    if p.returncode:
        raise RuntimeError(f"hammerstein {args[0]} failed ({p.returncode}): {p.stderr.strip()}")
    return p.stdout


def read_drive(path, shaped=False):
    """(t, u (2, N), fade samples) of a drive file; with ``shaped``, also the shaped reference
    (2, N) the file carries (``x_shaped``, ``y_shaped``) or None."""
    text = Path(path).read_text()
    fade = int(re.search(r"fade-in (\d+) samples", text).group(1))
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    vals = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    u = np.vstack([vals[:, head.index("ux")], vals[:, head.index("uy")]])
    if not shaped:
        return vals[:, 0], u, fade
    ref = (np.vstack([vals[:, head.index("x_shaped")], vals[:, head.index("y_shaped")]])
           if "x_shaped" in head else None)
    return vals[:, 0], u, fade, ref


def circle(radius, frequency, periods, n=None):
    t = np.arange(n if n is not None else int(round(periods / frequency / T))) * T
    return radius * np.vstack([np.cos(2 * np.pi * frequency * t), np.sin(2 * np.pi * frequency * t)])


def play(act, u, rng, path, t):
    y = act.simulate(u, rng=rng)
    np.savetxt(path, np.column_stack([t, y.T]), delimiter=",", header="t,x,y", comments="",
               fmt="%.9g")
    return y


def drive_checks(u, fade, period, lo, hi):
    """(within the records' range, first sample |u0| [V], largest step / settled largest step)."""
    within = bool(np.all(u.min(axis=1) >= lo - 1e-9) and np.all(u.max(axis=1) <= hi + 1e-9))
    first = float(np.max(np.abs(u[:, 0])))
    steps = np.abs(np.diff(np.concatenate([np.zeros((2, 1)), u], axis=1), axis=1))
    settled = steps[:, fade + period + 1:].max(axis=1)
    return within, first, float(np.max(steps.max(axis=1) / settled))


#: the settled part starts this many periods after the fade-in: the repeating part `learn`
#: judges (two periods after the fade-in, hammerstein.compensation.ilc.repeating_from); the first period
#: after the fade still carries the start-up (hysteresis memory, dynamics, creep)
START_PERIODS = 2


def settled_error(ref, y, fade, period, scale, periods=START_PERIODS):
    start = fade + periods * period
    e = np.linalg.norm(ref[:, start:] - y[:, start:], axis=0)
    return 100 * float(e.max()) / scale, 100 * float(np.sqrt(np.mean(e ** 2))) / scale


def one_actuator(name, act, work, quick, log):
    d = Path(work) / name
    d.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(zlib.crc32(name.encode()))   # the same draws every run
    hammerstein("excitation", "--inputs", "ux,uy", "--amplitude", "20", "--sampling-period", T,
                "--out", "exc", cwd=d)
    start_after_cycle(act, d)
    files = {"hysteresis": [], "multisine": [], "creep": []}
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for f in sorted((d / "exc").glob("*.csv")):
        if f.name == "demagnetise.csv":       # played before each file: the demagnetised start
            continue
        kind = next(k for k in files if f.name.startswith(k))
        data = np.genfromtxt(f, delimiter=",", names=True, comments="#")
        u = np.vstack([data["ux"], data["uy"]])
        lo, hi = np.minimum(lo, u.min(axis=1)), np.maximum(hi, u.max(axis=1))
        write_csv(d / f.name, data["t"], u, act.simulate(u, rng=rng))
        files[kind].append(f.name)
    hammerstein("identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
                "--time", "t", "--dynamics", "--dynamics-records", *files["multisine"],
                "--creep-records", *files["creep"], "--out", "preset.toml", cwd=d)
    rows = []
    circles = ([(15, 200), (30, 100), (50, 10)] if quick else
               [(r, f) for r in (15, 30, 50) for f in (10, 100, 200)])
    for radius, freq in circles:
        periods = max(4, int(round(0.2 * freq)))
        spec = f"{{ kind = \"circle\", radius = {radius}, frequency = {freq}, periods = {periods} }}"
        out = d / f"circle-{radius}-{freq}.csv"
        try:
            hammerstein("compensate", "preset.toml", "--reference", spec, "--out", out.name, cwd=d)
        except RuntimeError as exc:         # a drive that chatters is refused, not written
            if "chatters" not in str(exc):
                raise
            log(f"{name}: circle {radius} µm {freq} Hz: refused: {exc}")
            continue
        t, u, fade, shaped = read_drive(out, shaped=True)
        P = int(round(1 / freq / T))
        y = act.simulate(u, noise=False)              # the position; the sensor adds noise
        ref = circle(radius, freq, periods, u.shape[1])
        mx, rms = settled_error(ref, y, fade, P, radius)
        mxm = settled_error(ref, y + act.noise_um * rng.standard_normal(y.shape), fade, P,
                            radius)[0]
        mx1, _ = settled_error(ref, y, fade, P, radius, 1)
        mxs = mx if shaped is None else settled_error(shaped, y, fade, P, radius)[0]
        within, first, ratio = drive_checks(u, fade, P, lo, hi)
        rows.append(("ff", f"circle {radius} µm {freq} Hz", mx, rms, within, first, ratio, mxs))
        log(f"{name}: circle {radius} µm {freq} Hz: settled max {mx:.3g} % RMS {rms:.3g} % "
            f"(as measured with the sensor's noise {mxm:.3g} %; from one period after the fade: max {mx1:.3g} %; against the shaped reference "
            f"{mxs:.3g} %), fade {fade * T:.3g} s, within {within}, first {first:.2g} V, step "
            f"ratio {ratio:.3g}")
    spec = '{ kind = "raster", size = [40, 40], lines = 8, frequency = 50, outputs = ["x", "y"] }'
    out = d / "raster.csv"
    hammerstein("compensate", "preset.toml", "--reference", spec, "--out", out.name, cwd=d)
    t, u, fade, shaped = read_drive(out, shaped=True)
    y = act.simulate(u, noise=False)
    from hammerstein.signals.references import raster      # the reference as the command generates it
    ref = raster(T, [40, 40], 8, 50.0)[1][:, :u.shape[1]]
    P = int(round(1 / 50 / T))
    mx, rms = settled_error(ref, y, fade, P, 20.0)
    mxs = mx if shaped is None else settled_error(shaped, y, fade, P, 20.0)[0]
    within, first, ratio = drive_checks(u, fade, P, lo, hi)
    rows.append(("ff-raster", "raster 40x40 µm", mx, rms, within, first, ratio, mxs))
    log(f"{name}: raster: settled max {mx:.3g} % RMS {rms:.3g} % of 20 µm (against the shaped "
        f"reference {mxs:.3g} %), fade {fade * T:.3g} s, within {within}, first {first:.2g} V, "
        f"step ratio {ratio:.3g}")
    # ten learn trials through files on a 30 µm 100 Hz circle starting at (30, 0)
    spec = '{ kind = "circle", radius = 30, frequency = 100, periods = 20 }'
    hammerstein("compensate", "preset.toml", "--reference", spec, "--out", "u0.csv", cwd=d)
    shutil.rmtree(d / "hist", ignore_errors=True)    # a new learning: the history of a new run
    for k in range(TRIALS):
        t, u, fade = read_drive(d / f"u{k}.csv")
        play(act, u, rng, d / f"y{k}.csv", t)
        hammerstein("learn", "preset.toml", "--reference", spec, "--drive", f"u{k}.csv",
                    "--measured", f"y{k}.csv", "--out", f"u{k + 1}.csv", "--history", "hist",
                    cwd=d)
    return learn_rows(name, act, d, rows, lo, hi, log)


def learn_rows(name, act, d, rows, lo, hi, log):
    """The learn trials' rows from their drive and measured files; (rows, last, worst ratio).

    Scored on the position (each trial's drive played again without the sensor's noise);
    the measured files (with it) are what ``learn`` learnt from, and their error is logged.
    """
    errs, errs1, errs_m = [], [], []
    for k in range(TRIALS):
        t, u, fade = read_drive(d / f"u{k}.csv")
        y_meas = np.loadtxt(d / f"y{k}.csv", delimiter=",", skiprows=1)[:, 1:3].T
        y = act.simulate(u, noise=False)
        ref = circle(30, 100, 20, u.shape[1])
        mx, rms = settled_error(ref, y, fade, 200, 30.0)
        errs_m.append(settled_error(ref, y_meas, fade, 200, 30.0)[0])
        errs.append(mx)
        errs1.append(settled_error(ref, y, fade, 200, 30.0, 1)[0])
        within, first, ratio = drive_checks(u, fade, 200, lo, hi)
        rows.append(("learn", f"trial {k}", mx, rms, within, first, ratio, mx))
    log(f"{name}: learn settled max per trial [%]: " + ", ".join(f"{e:.3g}" for e in errs)
        + " (from one period after the fade: " + ", ".join(f"{e:.3g}" for e in errs1)
        + "; as measured, with the sensor's noise: " + ", ".join(f"{e:.3g}" for e in errs_m) + ")")
    # a trial worse than the best one before it (the learning's regressions)
    return rows, errs[-1], max(errs[k] / min(errs[:k]) for k in range(1, len(errs)))


def records_range(d):
    """Each input's min and max over the excitation files played (hysteresis, multisines)."""
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for f in sorted((d / "exc").glob("*.csv")):
        if f.name.startswith(("hysteresis", "multisine")):
            data = np.genfromtxt(f, delimiter=",", names=True, comments="#")
            u = np.vstack([data["ux"], data["uy"]])
            lo, hi = np.minimum(lo, u.min(axis=1)), np.maximum(hi, u.max(axis=1))
    return lo, hi


def rescore(name, act, work, quick, log):
    """:func:`one_actuator` on the files an earlier run left (no command run again)."""
    from hammerstein.signals.references import raster
    d = Path(work) / name
    if not (d / "u9.csv").is_file():
        raise RuntimeError(f"{d}: no complete earlier run")
    lo, hi = records_range(d)
    start_after_cycle(act, d)
    rng = np.random.default_rng(zlib.crc32(name.encode()))   # the same draws every run
    rows = []
    for f in sorted(d.glob("circle-*.csv")):
        radius, freq = (int(v) for v in f.stem.split("-")[1:3])
        t, u, fade, shaped = read_drive(f, shaped=True)
        P = int(round(1 / freq / T))
        y = act.simulate(u, noise=False)
        ref = circle(radius, freq, 0, u.shape[1])
        mx, rms = settled_error(ref, y, fade, P, radius)
        mx1, _ = settled_error(ref, y, fade, P, radius, 1)
        mxs = mx if shaped is None else settled_error(shaped, y, fade, P, radius)[0]
        within, first, ratio = drive_checks(u, fade, P, lo, hi)
        rows.append(("ff", f.stem, mx, rms, within, first, ratio, mxs))
        log(f"{name}: {f.stem}: settled max {mx:.3g} % RMS {rms:.3g} % (from one period after the "
            f"fade: max {mx1:.3g} %; against the shaped reference {mxs:.3g} %), within {within}, "
            f"first {first:.2g} V, step ratio {ratio:.3g}")
    t, u, fade, shaped = read_drive(d / "raster.csv", shaped=True)
    y = act.simulate(u, noise=False)
    ref = raster(T, [40, 40], 8, 50.0)[1][:, :u.shape[1]]
    mx, rms = settled_error(ref, y, fade, 400, 20.0)
    mxs = mx if shaped is None else settled_error(shaped, y, fade, 400, 20.0)[0]
    within, first, ratio = drive_checks(u, fade, 400, lo, hi)
    rows.append(("ff-raster", "raster", mx, rms, within, first, ratio, mxs))
    log(f"{name}: raster: settled max {mx:.3g} % RMS {rms:.3g} % of 20 µm (against the shaped "
        f"reference {mxs:.3g} %), within {within}, first {first:.2g} V, step ratio {ratio:.3g}")
    return learn_rows(name, act, d, rows, lo, hi, log)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="3 actuators, 3 circles")
    ap.add_argument("--actuators", type=int, help="family size (default 20, --quick 3)")
    ap.add_argument("--work", help="keep the files here (default a temporary directory)")
    ap.add_argument("--only", help="comma-separated actuator names of the family to run (e.g. "
                                   "gpi-3,preisach-4: more actuators into a --work directory in "
                                   "several sessions; --rescore then scores them all)")
    ap.add_argument("--seed", type=int, default=FAMILY_SEED,
                    help=f"the family's seed (default {FAMILY_SEED}, the family the results "
                         f"file reports; another draws actuators the defaults were never "
                         f"looked at on)")
    ap.add_argument("--rescore", action="store_true",
                    help="score the files of an earlier run in --work again (no command is run; "
                         "the feedforward drives are played through the actuators again)")
    ap.add_argument("--discrete-relays", action="store_true",
                    help="the Preisach-type actuators' relays switch in one sample (a row of "
                         "relays at once: the staircase the earlier family had)")
    ap.add_argument("--few-plays", action="store_true",
                    help="the generalised-PI-type actuators keep 4-5 plays per path (a kink in "
                         "their loops at every threshold: the earlier family)")
    ap.add_argument("--bouc-wen", action="store_true",
                    help="every member's hysteresis a Bouc-Wen loop per input (a third class, "
                         "neither Preisach nor generalised PI), modes, creep and noise drawn "
                         "as the others'")
    ap.add_argument("--ideal-start", action="store_true",
                    help="every file and drive from the member's idealised start (the "
                         "generalised-PI type after a 60-period decay from 30 V, the Preisach "
                         "type in the ideal demagnetised state) instead of after the "
                         "excitation's demagnetise.csv: the family before 2026-11-27")
    args = ap.parse_args(argv)
    IDEAL_START["on"] = args.ideal_start
    BOUC_WEN["on"] = args.bouc_wen
    DISCRETE["relays"] = args.discrete_relays
    FEW_PLAYS["on"] = args.few_plays
    n = args.actuators or (3 if args.quick else 20)
    work = args.work or tempfile.mkdtemp(prefix="route-defaults-")
    results = []
    only = set(args.only.split(",")) if args.only else None
    for name, act in family(n, args.seed):
        if only is not None and name not in only:
            continue
        try:
            run = rescore if args.rescore else one_actuator
            results.append((name, *run(name, act, work, args.quick,
                                       lambda s: print(s, flush=True))))
        except RuntimeError as exc:
            print(f"{name}: FAILED: {exc}", flush=True)
            results.append((name, None, None, None))
    ok = [r for r in results if r[1] is not None]
    print(f"\n{len(ok)} of {len(results)} actuators through the route (files in {work})")
    if not ok:
        return 1
    ff = np.array([row[2] for r in ok for row in r[1] if row[0] == "ff"])
    raster = np.array([row[2] for r in ok for row in r[1] if row[0] == "ff-raster"])
    ff_s = np.array([row[7] for r in ok for row in r[1] if row[0] == "ff"])
    raster_s = np.array([row[7] for r in ok for row in r[1] if row[0] == "ff-raster"])
    within = [row[4] for r in ok for row in r[1]]
    first = np.array([row[5] for r in ok for row in r[1]])
    ratio = np.array([row[6] for r in ok for row in r[1]])
    final = np.array([r[2] for r in ok])
    worse = np.array([r[3] for r in ok])

    def line(label, v, target, unit=""):
        print(f"{label:58s} median {np.median(v):8.3g}{unit}  worst {np.max(v):8.3g}{unit}  "
              f"(target {target})")

    line("feedforward circles: settled max Euclidean [% of radius]", ff, "<= 1.5 %")
    line("feedforward raster: settled max Euclidean [% of half size]", raster, "<= 1.5 %")
    line("  circles against the shaped reference the drive file carries", ff_s, "<= 1.5 %")
    line("  raster against the shaped reference the drive file carries", raster_s, "<= 1.5 %")
    print(f"{'drives within the records range':58s} {sum(within)} of {len(within)}  (target all)")
    line("first sample [V from rest]", first, "0")
    line("largest step / settled drive's largest step", ratio, "<= 1")
    line("learn: settled max after 10 trials [% of radius]", final, "<= 0.3 %")
    line("learn: worst trial / best trial before it", worse, "<= 1.1")
    return 0


if __name__ == "__main__":
    sys.exit(main())
