"""The Hammerstein actuator: multivariable PI cascaded with linear dynamics.

``U (m, N) [V] -> Gamma (multivariable PI) -> H (p, N) [µm] -> G(z) -> Y (p, N) [µm]``

The linear part makes the hysteresis rate dependent (paper, Sections 1 and 6;
docs/hammerstein-plant.md). Without dynamics the plant is the static (rate-independent) model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hammerstein.core.hysteresis import HysteresisError, MultivariablePI
from hammerstein.simulation import simulate_plant, state_vector

if TYPE_CHECKING:                      # the plant only reads A, B, C, D: no python-control needed
    import control

__all__ = ["HammersteinPlant"]


@dataclass
class HammersteinPlant:
    """Multivariable PI hysteresis followed by discrete-time linear dynamics.

    Parameters
    ----------
    hysteresis : MultivariablePI
        Rate-independent part, m inputs [V] -> p outputs [µm].
    sampling_period : float
        Sampling period T [s].
    dynamics : control.StateSpace or None
        Discrete-time linear part with ``dt == sampling_period``, p inputs and
        p outputs [µm]; ``None`` for the static plant.
    name : str
        Label used in reports.

    Notes
    -----
    The plant state is one flat vector: the ``n_hysterons`` play states
    followed by the ``n_linear_states`` states of the linear part.

    Raises
    ------
    HysteresisError
        If the dynamics do not match the hysteresis outputs or the sampling
        period.
    """

    hysteresis: MultivariablePI
    sampling_period: float
    dynamics: control.StateSpace | None = None
    name: str = "plant"

    def __post_init__(self):
        if not (np.isfinite(self.sampling_period) and self.sampling_period > 0):
            raise HysteresisError(
                f"sampling_period: expected a positive time [s], found {self.sampling_period!r}")
        if self.dynamics is not None:
            d = self.dynamics
            p = self.hysteresis.n_outputs
            if d.ninputs != p or d.noutputs != p:
                raise HysteresisError(
                    f"dynamics: expected {p} inputs and {p} outputs, found "
                    f"{d.ninputs} inputs and {d.noutputs} outputs")
            if not d.isdtime(strict=True) or not np.isclose(d.dt, self.sampling_period):
                raise HysteresisError(
                    f"dynamics: expected a discrete system with dt={self.sampling_period}, "
                    f"found dt={d.dt}")

    @property
    def is_static(self) -> bool:
        """True when the plant has no linear dynamics."""
        return self.dynamics is None

    @property
    def n_linear_states(self) -> int:
        """Number of states of the linear part (0 for the static plant)."""
        return 0 if self.dynamics is None else self.dynamics.nstates

    @property
    def n_states(self) -> int:
        """Length of the flat plant state vector."""
        return self.hysteresis.n_hysterons + self.n_linear_states

    @property
    def matrices(self):
        """Discrete ``(A, B, C, D)`` of the linear part, identity-like if static."""
        if self.dynamics is None:
            p = self.hysteresis.n_outputs
            return (np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p))
        d = self.dynamics
        return (np.asarray(d.A), np.asarray(d.B), np.asarray(d.C), np.asarray(d.D))

    def initial_state(self, initial_state=None):
        """Validated copy of a flat plant state (zeros by default).

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            Play states [V] then linear states [µm].

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array.

        Raises
        ------
        HysteresisError
            If the state does not have length ``n_states``.
        """
        return state_vector(initial_state, self.n_states)

    def simulate(self, inputs, initial_state=None):
        """Displacements for a record of input voltages (open loop).

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Input voltages [V] at the sampling period.
        initial_state : array_like, shape (n_states,), optional
            Play states then linear states; zeros by default.

        Returns
        -------
        outputs : numpy.ndarray, shape (p, n_samples)
            Displacements [µm].
        final_state : numpy.ndarray, shape (n_states,)
            State after the last sample, for a chunked continuation.
        """
        return simulate_plant(self, inputs, initial_state)
