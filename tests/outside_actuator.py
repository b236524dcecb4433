"""A 2 x 2 piezo actuator simulated outside the project's model classes (test helper).

Written independently of ``hammerstein``: nothing here imports the package.
Hysteresis per component is a discrete Preisach model (relays on a grid of
switching pairs alpha >= beta, wiping-out memory) with an asymmetric density
and a reversible part ``a u + b u^2``, so its loops are not point-symmetric
and its minor loops are not those of a Prandtl-Ishlinskii model; the
cross-couplings are hysteretic with an even (``u^2``) term. The linear part
has three bending modes (two near 450/420 Hz, one at 1300 Hz coupling both
axes), sampled exactly (zero-order hold by the matrix exponential), and a
static gain that is not the identity. Optional logarithmic-like creep (sum
of first-order lags) and 40 nm Gaussian sensor noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
import scipy.linalg

T = 5e-5                      # sampling period [s] (20 kHz)
NOISE_UM = 0.04               # sensor noise, standard deviation [µm]


@numba.njit(cache=True)
def _preisach(u, alpha, beta, w, state):
    y = np.empty(u.size)
    for k in range(u.size):
        acc = 0.0
        for i in range(alpha.size):
            if u[k] >= alpha[i]:
                state[i] = 1.0
            elif u[k] <= beta[i]:
                state[i] = -1.0
            acc += w[i] * state[i]
        y[k] = acc
    return y


@numba.njit(cache=True)
def _lsim(Ad, Bd, C, h_t):
    """Zero-order-hold state space from rest; ``h_t`` (N, k) -> y (q, N)."""
    x = np.zeros(Ad.shape[0])
    y = np.empty((C.shape[0], h_t.shape[0]))
    for k in range(h_t.shape[0]):
        y[:, k] = C @ x
        x = Ad @ x + Bd @ h_t[k]
    return y


def preisach_grid(n=24, umax=10.5, skew=0.35, spread=0.45, scale=1.0):
    """Relays (alpha, beta, weight) of an asymmetric Preisach density.

    The density is a Gaussian in (alpha - beta) (loop width) times a skewed
    weight along (alpha + beta) (the loop centre): more relays switch at
    positive voltages, so ascending and descending branches are not mirror
    images. Weights are scaled so that the relays span ``scale`` (output
    range 2 * scale).
    """
    levels = np.linspace(-umax, umax, n)
    a, b = np.meshgrid(levels, levels, indexing="ij")
    keep = a > b
    a, b = a[keep], b[keep]
    width = (a - b) / (2 * umax)
    centre = (a + b) / (2 * umax)
    w = np.exp(-(width / spread) ** 2) * (1.0 + skew * centre) * np.exp(-2.0 * centre ** 2)
    w = scale * w / w.sum()
    return a, b, w


@dataclass
class OutsideActuator:
    """The actuator: ``u`` (2, N) [V] -> ``y`` (2, N) [µm]."""

    seed: int = 0
    noise_um: float = NOISE_UM
    creep: bool = False
    direct_um: tuple = (25.0, 22.0)        # relay span per direct path [µm]
    reversible: tuple = ((1.8, 0.06), (1.6, -0.05))   # a [µm/V], b [µm/V²] per direct path
    coupling_um: tuple = (1.5, 1.2)        # hysteretic cross-coupling relay span [µm]
    coupling_even: tuple = (0.02, -0.015)  # even cross-coupling [µm/V²]
    modes_hz: tuple = (450.0, 420.0, 1300.0)
    damping: tuple = (0.03, 0.04, 0.05)
    c: np.ndarray = field(default_factory=lambda: np.array([[1.0, 0.02, 0.3], [0.03, 1.0, -0.25]]))
    b: np.ndarray = field(default_factory=lambda: np.array([[0.85, 0.05], [0.04, 0.9], [0.5, -0.3]]))
    creep_tau: tuple = (0.05, 0.5, 5.0)     # [s]
    creep_gain: float = 0.03                 # total creep as a fraction of the static output

    def __post_init__(self):
        self.grid_direct = [preisach_grid(scale=s, skew=sk)
                            for s, sk in zip(self.direct_um, (0.35, -0.3))]
        self.grid_cross = [preisach_grid(n=12, scale=s, skew=0.5) for s in self.coupling_um]
        n = len(self.modes_hz)
        A = np.zeros((2 * n, 2 * n))
        B = np.zeros((2 * n, 2))
        C = np.zeros((2, 2 * n))
        for i, (f, z) in enumerate(zip(self.modes_hz, self.damping)):
            wn = 2 * np.pi * f
            A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-wn * wn, -2 * z * wn]]
            B[2 * i + 1] = wn * wn * self.b[i]
            C[:, 2 * i] = self.c[:, i]
        self.A, self.B, self.C = A, B, C
        M = scipy.linalg.expm(np.block([[A, B], [np.zeros((2, 2 * n + 2))]]) * T)
        self.Ad, self.Bd = M[:2 * n, :2 * n], M[:2 * n, 2 * n:]

    def dc_gain(self):
        """G(0) = -C A^-1 B (2, 2)."""
        return -self.C @ np.linalg.solve(self.A, self.B)

    def hysteresis(self, u):
        """Static part H (2, N) [µm] from rest (all relays down, then centred)."""
        u = np.asarray(u, dtype=float)
        h = np.zeros_like(u)
        for l in range(2):
            for k in range(2):
                grid = self.grid_direct[l] if l == k else self.grid_cross[l]
                a, b, w = grid
                state = -np.ones(a.size)
                state[(a + b) < 0] = 1.0     # demagnetised start: half up
                h[l] += _preisach(np.ascontiguousarray(u[k]), a, b, w, state)
            ra, rb = self.reversible[l]
            h[l] += ra * u[l] + rb * u[l] ** 2
            k = 1 - l
            h[l] += self.coupling_even[l] * u[k] ** 2
        return h

    def simulate(self, u, noise=True, rng=None):
        """Measured displacements (2, N) [µm] for voltages u (2, N) [V], from rest."""
        h = self.hysteresis(u)
        if self.creep:
            h = h + self._creep(h)
        Ad, Bd, C = map(np.ascontiguousarray, (self.Ad, self.Bd, self.C))
        y = _lsim(Ad, Bd, C, np.ascontiguousarray(h.T))
        if noise:
            rng = np.random.default_rng(self.seed) if rng is None else rng
            y = y + self.noise_um * rng.standard_normal(y.shape)
        return y

    def _creep(self, h):
        import scipy.signal
        out = np.zeros_like(h)
        w = self.creep_gain / len(self.creep_tau)
        for tau in self.creep_tau:
            a = np.exp(-T / tau)
            for l in range(h.shape[0]):
                out[l] += w * scipy.signal.lfilter([0.0, 1 - a], [1.0, -a], h[l])
        return out

    def true_modes(self):
        """(frequency [Hz], damping) of the three modes, ascending frequency."""
        order = np.argsort(self.modes_hz)
        return np.asarray(self.modes_hz)[order], np.asarray(self.damping)[order]


def write_csv(path, t, u, y, inputs=("ux", "uy"), outputs=("x", "y"), time="t"):
    """Write ``time,inputs...,outputs...`` as a lab would."""
    data = np.column_stack([t, u.T, y.T])
    header = ",".join([time, *inputs, *outputs])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.9g")
