"""The sample-by-sample stepping core.

All time stepping of the project lives here: the open-loop plant, the
compensator, and the compensator -> plant chain. These plain numpy loops are
the reference implementation (the oracle for compiled kernels).

Every function takes explicit initial states and returns the final ones, so
a chunked run equals one long run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .compensators import CompensatorDivergence

__all__ = ["simulate_plant", "simulate_compensator", "simulate_chain", "ChainResult"]


def simulate_plant(plant, inputs, initial_state=None):
    """Open-loop response of a :class:`~hammerstein.plant.HammersteinPlant`.

    ``H(t) = Gamma(U(t))``; ``Y(t) = C x(t) + D H(t)``;
    ``x(t+T) = A x(t) + B H(t)`` (static plant: ``Y = H``).

    Parameters
    ----------
    plant : HammersteinPlant
    inputs : array_like, shape (m, n_samples)
        Input voltages [V].
    initial_state : array_like, shape (plant.n_states,), optional
        Play states [V] then linear states [µm]; zeros by default.

    Returns
    -------
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm].
    final_state : numpy.ndarray, shape (plant.n_states,)
    """
    model = plant.hysteresis
    u = model.check_inputs(inputs)
    state = plant.initial_state(initial_state)
    nh = model.n_hysterons
    h, play_final = model.simulate(u, state[:nh])
    if plant.is_static:
        return h, play_final
    A, B, C, D = plant.matrices
    x = state[nh:]
    y = np.empty_like(h)
    for t in range(h.shape[1]):
        y[:, t] = C @ x + D @ h[:, t]
        x = A @ x + B @ h[:, t]
    return y, np.concatenate([play_final, x])


def simulate_compensator(compensator, reference, initial_state=None):
    """Run the inverse multiplicative compensator on a reference record.

    For each sample, ``iterations`` fixed-point steps
    ``U <- U + K^-1 (Yr(t) - Gamma(U; s(t-T)))`` start from ``U(t-T)``, with
    the model's play states s frozen at the previous sample; then the states
    are committed with the final U (Theorem 4.1, normalised as in NOTES §4).

    Parameters
    ----------
    compensator : InverseMultiplicativeCompensator
    reference : array_like, shape (m, n_samples)
        Reference displacements [µm].
    initial_state : array_like, shape (compensator.n_states,), optional
        ``U(t-T)`` [V] then play states [V]; zeros by default.

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V].
    final_state : numpy.ndarray, shape (compensator.n_states,)

    Raises
    ------
    CompensatorDivergence
        When U is non-finite or beyond ``compensator.divergence_bound``.
    """
    model = compensator.model
    yr = model.check_inputs(reference, "reference")
    state = compensator.initial_state(initial_state)
    m = model.n_inputs
    u_prev, s = state[:m].copy(), state[m:].copy()
    Kinv = compensator.K_inv
    bound = compensator.divergence_bound
    u_out = np.empty_like(yr)
    for t in range(yr.shape[1]):
        u = u_prev
        for _ in range(compensator.iterations):
            y_hat, _ = model.evaluate(u, s)
            u = u + Kinv @ (yr[:, t] - y_hat)
        if not np.all(np.isfinite(u)):
            raise CompensatorDivergence(t, "the input voltage became non-finite")
        if np.max(np.abs(u)) > bound:
            raise CompensatorDivergence(
                t, f"|U| = {np.max(np.abs(u)):.3g} V exceeds the bound {bound:.3g} V")
        _, s = model.evaluate(u, s)
        u_out[:, t] = u
        u_prev = u
    return u_out, np.concatenate([u_prev, s])


@dataclass
class ChainResult:
    """Result of a compensator -> plant simulation.

    Attributes
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        Compensator output [V] (NaN after a divergence).
    outputs : numpy.ndarray, shape (p, n_samples)
        Plant displacements [µm] (NaN after a divergence).
    compensator_state, plant_state : numpy.ndarray or None
        Final states (None after a divergence).
    divergence : CompensatorDivergence or None
        Set when the compensator diverged; the arrays are valid before
        ``divergence.sample``.
    """

    inputs: np.ndarray
    outputs: np.ndarray
    compensator_state: np.ndarray | None
    plant_state: np.ndarray | None
    divergence: CompensatorDivergence | None = None

    @property
    def diverged(self) -> bool:
        return self.divergence is not None


def simulate_chain(compensator, plant, reference, compensator_state=None, plant_state=None):
    """Feedforward chain: reference -> compensator -> Hammerstein plant.

    The compensator needs no sensor, so the chain is the compensator's output
    fed open loop to the plant.

    Parameters
    ----------
    compensator : object with ``simulate(reference, initial_state)``
        A compensator (inputs [V] from references [µm]).
    plant : HammersteinPlant
    reference : array_like, shape (p, n_samples)
        Reference displacements [µm].
    compensator_state, plant_state : array_like, optional
        Initial states; zeros by default.

    Returns
    -------
    ChainResult
        Divergence of the compensator is reported in the result, not raised.
    """
    reference = np.asarray(reference, dtype=float)
    try:
        u, comp_final = compensator.simulate(reference, compensator_state)
    except CompensatorDivergence as div:
        m = plant.hysteresis.n_inputs
        n = reference.shape[-1]
        u = np.full((m, n), np.nan)
        # re-run the valid part to show the trajectory up to the divergence
        if div.sample > 0:
            u[:, :div.sample], _ = compensator.simulate(reference[:, :div.sample], compensator_state)
        y = np.full((plant.hysteresis.n_outputs, n), np.nan)
        if div.sample > 0:
            y[:, :div.sample], _ = plant.simulate(u[:, :div.sample], plant_state)
        return ChainResult(u, y, None, None, div)
    y, plant_final = plant.simulate(u, plant_state)
    return ChainResult(u, y, comp_final, plant_final)
