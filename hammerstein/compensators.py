"""Feedforward compensators of the multivariable PI hysteresis.

The inverse multiplicative compensator of Theorem 4.1 of the paper,
``U(t) = Yr(t) + U(t-T) - Gamma(U(t-T))``, is a fixed-point iteration, one
step per sample, that converges only when ``rho(I - J) < 1`` for the slope
matrices J of the model (NOTES §4). Normalised by a static gain matrix K,

``U(t) = U(t-T) + K^-1 (Yr(t) - Gamma(U(t-T)))``,

it converges when ``rho(I - K^-1 J) < 1`` for every reachable J; K = I is
the paper's literal law.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass, field

import numpy as np

from .hysteresis import HysteresisError, MultivariablePI

__all__ = [
    "CompensatorError",
    "CompensatorDivergence",
    "ConvergenceWarning",
    "ConvergenceReport",
    "convergence_report",
    "InverseMultiplicativeCompensator",
]


class CompensatorError(ValueError):
    """Invalid compensator parameters, or a law that cannot converge."""


class ConvergenceWarning(UserWarning):
    """The compensator's fixed-point iteration may not converge."""


class CompensatorDivergence(RuntimeError):
    """The compensator output left every bound during a simulation.

    Attributes
    ----------
    sample : int
        Index of the first sample where the divergence was detected.
    reason : str
        What was detected (non-finite or out-of-bound input).
    """

    def __init__(self, sample, reason):
        self.sample = int(sample)
        self.reason = str(reason)
        super().__init__(f"compensator diverged at sample {self.sample}: {self.reason}")


@dataclass
class ConvergenceReport:
    """Spectral radii of ``I - K^-1 J`` over the reachable slope matrices.

    Attributes
    ----------
    max_radius : float
        Largest ``rho(I - K^-1 J)`` over the slope matrices outside the dead
        band (every input past its first threshold) [-].
    min_radius : float
        Smallest such radius [-].
    worst_slopes : numpy.ndarray, shape (m, m)
        Slope matrix J [µm/V] where the radius is largest.
    radii : numpy.ndarray, shape (n_matrices,)
        All radii, in the order of the enumerated slope matrices.
    n_matrices : int
        Number of slope matrices examined.
    converges : bool
        ``max_radius < 1``.
    """

    max_radius: float
    min_radius: float
    worst_slopes: np.ndarray
    radii: np.ndarray = field(repr=False)
    n_matrices: int = 0

    @property
    def converges(self) -> bool:
        return bool(self.max_radius < 1.0)


def _inverse_gain(model, gain):
    m = model.n_inputs
    if model.n_outputs != m:
        raise CompensatorError(
            f"model: the inverse multiplicative compensator needs a square model, "
            f"found {model.n_outputs} outputs and {m} inputs (paper Section 4)")
    if gain is None or (isinstance(gain, str) and gain == "secant"):
        K = np.diag(np.diag(model.secant_gains()))
    elif isinstance(gain, str) and gain == "identity":
        K = np.eye(m)
    elif isinstance(gain, str):
        raise CompensatorError(
            f"gain: expected 'secant', 'identity' or an {m}x{m} matrix [µm/V], found {gain!r}")
    else:
        K = np.asarray(gain, dtype=float)
        if K.ndim == 0:
            K = K * np.eye(m)
        elif K.ndim == 1 and K.size == m:
            K = np.diag(K)
        if K.shape != (m, m) or not np.all(np.isfinite(K)):
            raise CompensatorError(f"gain: expected an {m}x{m} finite matrix [µm/V], found shape {K.shape}")
    try:
        Kinv = np.linalg.inv(K)
    except np.linalg.LinAlgError as exc:
        raise CompensatorError(f"gain: the gain matrix K is singular: {K.tolist()}") from exc
    return K, Kinv


def convergence_report(model: MultivariablePI, gain=None, max_matrices=100_000):
    """Check ``rho(I - K^-1 J) < 1`` over the reachable slope matrices.

    Column k of J steps through the cumulative weight sums of the components
    driven by input k as the travel of u_k since its last reversal grows
    (:meth:`MultivariablePI.slope_levels`). Every combination of columns is
    examined, except the dead band (an input that has not yet travelled past
    twice its smallest threshold), where the iteration integrates the error
    with ``rho = 1`` until the play operators move.

    Parameters
    ----------
    model : MultivariablePI
        Square model (m inputs, m outputs).
    gain : {'secant', 'identity'} or array_like, shape (m, m), optional
        Normalisation K [µm/V]; default the diagonal secant gains of the
        direct transfers over the identified range (NOTES §4).
    max_matrices : int
        Upper bound on the number of combinations examined; beyond it a
        random subset (fixed seed) is used.

    Returns
    -------
    ConvergenceReport

    Raises
    ------
    CompensatorError
        If the model is not square or K is invalid.
    """
    K, Kinv = _inverse_gain(model, gain)
    m = model.n_inputs
    levels = [model.slope_levels(k)[1:] for k in range(m)]  # skip dead band
    total = int(np.prod([len(lv) for lv in levels]))
    if total <= max_matrices:
        combos = itertools.product(*[range(len(lv)) for lv in levels])
    else:
        rng = np.random.default_rng(0)
        combos = (tuple(rng.integers(len(lv)) for lv in levels) for _ in range(max_matrices))
    radii, worst, worst_r = [], None, -1.0
    eye = np.eye(m)
    for combo in combos:
        J = np.column_stack([levels[k][i] for k, i in enumerate(combo)])
        r = float(np.max(np.abs(np.linalg.eigvals(eye - Kinv @ J))))
        radii.append(r)
        if r > worst_r:
            worst_r, worst = r, J
    radii = np.asarray(radii)
    return ConvergenceReport(max_radius=float(radii.max()), min_radius=float(radii.min()),
                             worst_slopes=worst, radii=radii, n_matrices=radii.size)


@dataclass
class InverseMultiplicativeCompensator:
    """Multivariable inverse multiplicative compensator, Theorem 4.1.

    ``U(t) = U(t-T) + K^-1 (Yr(t) - Gamma(U(t-T)))`` (NOTES §4); with
    ``gain='identity'`` it is the paper's literal law. The compensator is
    built from the model alone: no parameter is computed beyond K.

    Parameters
    ----------
    model : MultivariablePI
        Identified square model, m inputs [V], m outputs [µm].
    gain : {'secant', 'identity'} or array_like, optional
        Normalisation K [µm/V]: ``'secant'`` (default) the diagonal secant
        gains of the direct transfers over ``model.input_amplitude``;
        ``'identity'`` the literal law of the paper; or an explicit matrix.
    iterations : int
        Fixed-point iterations per sample (1 = the paper's law); further
        iterations use the play states frozen at the previous sample.
    check : {'error', 'warn', 'ignore'}
        What to do when :func:`convergence_report` finds
        ``rho(I - K^-1 J) >= 1``.
    divergence_bound : float, optional
        |U| [V] beyond which the simulation stops as diverged; default
        1000 times the largest identified input amplitude (or 1e4 V).

    Attributes
    ----------
    K : numpy.ndarray, shape (m, m)
        Gain matrix [µm/V].
    K_inv : numpy.ndarray, shape (m, m)
        Its inverse [V/µm].
    convergence : ConvergenceReport
        The check made at construction.

    Raises
    ------
    CompensatorError
        On a non-square model, an invalid gain or iteration count, or (with
        ``check='error'``) a law that cannot converge.
    """

    model: MultivariablePI
    gain: object = "secant"
    iterations: int = 1
    check: str = "error"
    divergence_bound: float | None = None
    name: str = "multivariable"

    def __post_init__(self):
        if not isinstance(self.iterations, (int, np.integer)) or self.iterations < 1:
            raise CompensatorError(f"iterations: expected an integer >= 1, found {self.iterations!r}")
        if self.check not in ("error", "warn", "ignore"):
            raise CompensatorError(f"check: expected 'error', 'warn' or 'ignore', found {self.check!r}")
        self.K, self.K_inv = _inverse_gain(self.model, self.gain)
        self.convergence = convergence_report(self.model, self.K)
        if not self.convergence.converges and self.check != "ignore":
            msg = (f"gain: rho(I - K^-1 J) reaches {self.convergence.max_radius:.3g} >= 1 "
                   f"over the model's slopes; the fixed-point iteration diverges (NOTES §4)")
            if self.check == "error":
                raise CompensatorError(msg)
            warnings.warn(msg, ConvergenceWarning, stacklevel=2)
        if self.divergence_bound is None:
            amp = self.model.input_amplitude
            self.divergence_bound = 1e3 * float(np.max(amp)) if amp is not None else 1e4

    @property
    def n_states(self) -> int:
        """Length of the flat compensator state: U(t-T) then the play states."""
        return self.model.n_inputs + self.model.n_hysterons

    def initial_state(self, initial_state=None):
        """Validated copy of a flat compensator state (zeros by default)."""
        if initial_state is None:
            return np.zeros(self.n_states)
        s = np.asarray(initial_state, dtype=float)
        if s.shape != (self.n_states,) or not np.all(np.isfinite(s)):
            raise HysteresisError(
                f"initial_state: expected {self.n_states} finite values, found shape {s.shape}")
        return s.copy()

    def simulate(self, reference, initial_state=None):
        """Input voltages that make the model follow a reference.

        Parameters
        ----------
        reference : array_like, shape (m, n_samples)
            Reference displacements Yr [µm].
        initial_state : array_like, shape (n_states,), optional
            U(t-T) [V] then the model's play states [V]; zeros by default.

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            Compensator output U [V].
        final_state : numpy.ndarray, shape (n_states,)

        Raises
        ------
        CompensatorDivergence
            If U becomes non-finite or exceeds ``divergence_bound``.
        """
        from .simulation import simulate_compensator
        return simulate_compensator(self, reference, initial_state)
