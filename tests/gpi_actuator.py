"""A 2 x 2 piezo actuator with generalised Prandtl-Ishlinskii hysteresis (test helper).

Written independently of ``hammerstein``: nothing here imports the package.
Each direct path is a generalised PI operator (Al Janaideh, Rakheja and Su,
IEEE/ASME Trans. Mechatronics 16(4), 2011): play operators whose rising and
falling branches follow two different envelope functions
``gamma(u) = a0 tanh(a1 u + a2) + a3``, so its loops are asymmetric and
saturate, plus a reversible part ``a u + b u^2``. The cross-couplings are a
hysteretic generalised PI on x and an even (``u^2``) term on y. The linear
part has three bending modes (400 Hz x, 470 Hz y, 1400 Hz coupling both
axes), sampled exactly (zero-order hold by the matrix exponential), with a
static gain that is not the identity; 40 nm Gaussian sensor noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
import scipy.linalg

T = 5e-5                      # sampling period [s] (20 kHz)
NOISE_UM = 0.04               # sensor noise, standard deviation [µm]


@numba.njit(cache=True)
def _gpi(u, r, w, gl, gr, state):
    """Weighted sum of generalised plays; ``state`` (one value per play) in/out."""
    y = np.empty(u.size)
    for t in range(u.size):
        up = gl[0] * np.tanh(gl[1] * u[t] + gl[2]) + gl[3]
        down = gr[0] * np.tanh(gr[1] * u[t] + gr[2]) + gr[3]
        acc = 0.0
        for j in range(r.size):
            s = state[j]
            if s < up - r[j]:           # rising branch pushes the play up
                s = up - r[j]
            if s > down + r[j]:         # falling branch pushes it down
                s = down + r[j]
            state[j] = s
            acc += w[j] * s
        y[t] = acc
    return y


@numba.njit(cache=True)
def _lsim(Ad, Bd, C, h_t):
    """Zero-order-hold state space from rest; ``h_t`` (N, 2) -> y (N, 2)."""
    x = np.zeros(Ad.shape[0])
    y = np.empty((h_t.shape[0], C.shape[0]))
    for k in range(h_t.shape[0]):
        y[k] = C @ x
        x = Ad @ x + Bd @ h_t[k]
    return y


@dataclass
class GPIActuator:
    """The actuator: ``u`` (2, N) [V] -> ``y`` (2, N) [µm]."""

    seed: int = 0
    noise_um: float = NOISE_UM
    # (thresholds, weights, gamma rising, gamma falling) per direct path, then the x <- uy coupling
    direct: tuple = (
        ([0.0, 0.8, 1.8, 3.0, 4.6], [1.3, 0.5, 0.3, 0.2, 0.12],
         [14.0, 0.085, 0.1, 0.0], [12.5, 0.1, -0.06, 0.5]),
        ([0.0, 1.0, 2.1, 3.6], [1.1, 0.5, 0.3, 0.18],
         [13.0, 0.09, -0.08, 0.3], [15.0, 0.075, 0.05, -0.2]))
    coupling: tuple = ([0.0, 1.2, 2.5], [0.18, 0.06, 0.04], [12.0, 0.09, 0.1, 0.0],
                       [11.0, 0.1, 0.0, 0.3])
    reversible: tuple = ((2.8, 0.02), (3.0, -0.03))     # a [µm/V], b [µm/V²] per direct path
    coupling_even: float = -0.025                       # y <- ux even term [µm/V²]
    modes_hz: tuple = (400.0, 470.0, 1400.0)
    damping: tuple = (0.04, 0.05, 0.04)
    c: np.ndarray = field(default_factory=lambda: np.array([[1.0, 0.05, 0.25], [-0.04, 1.0, -0.2]]))
    b: np.ndarray = field(default_factory=lambda: np.array([[0.9, 0.04], [0.05, 0.95], [0.4, -0.3]]))

    def __post_init__(self):
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

    @staticmethod
    def _play(u, spec):
        r, w, gl, gr = (np.asarray(v, dtype=float) for v in spec)
        up0 = gl[0] * np.tanh(gl[2]) + gl[3]           # rest state: the plays at u = 0
        down0 = gr[0] * np.tanh(gr[2]) + gr[3]
        state = np.clip(np.zeros(r.size), up0 - r, np.maximum(down0 + r, up0 - r))
        return _gpi(np.ascontiguousarray(u, dtype=float), r, w, gl, gr, state)

    def hysteresis(self, u):
        """Static part H (2, N) [µm] from rest."""
        u = np.asarray(u, dtype=float)
        h = np.zeros_like(u)
        for l in range(2):
            a, b = self.reversible[l]
            h[l] = self._play(u[l], self.direct[l]) + a * u[l] + b * u[l] ** 2
        h[0] += self._play(u[1], self.coupling)
        h[1] += self.coupling_even * u[0] ** 2
        return h

    def simulate(self, u, noise=True, rng=None):
        """Measured displacements (2, N) [µm] for voltages u (2, N) [V], from rest."""
        Ad, Bd, C = map(np.ascontiguousarray, (self.Ad, self.Bd, self.C))
        y = _lsim(Ad, Bd, C, np.ascontiguousarray(self.hysteresis(u).T)).T
        if noise:
            rng = np.random.default_rng(self.seed) if rng is None else rng
            y = y + self.noise_um * rng.standard_normal(y.shape)
        return y
