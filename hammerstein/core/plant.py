"""The Hammerstein actuator: multivariable PI cascaded with linear dynamics.

``U (m, N) [V] -> Gamma (multivariable PI) -> H (p, N) [µm] -> G(z) -> Y (p, N) [µm]``

The linear part makes the hysteresis rate dependent (paper, Sections 1 and 6;
docs/hammerstein-plant.md). Without dynamics the plant is the static (rate-independent) model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hammerstein.core.dynamics import SampledSystem
from hammerstein.core.hysteresis import HysteresisError, MultivariablePI
from hammerstein.simulation import simulate_plant, state_vector

if TYPE_CHECKING:                      # the plant only reads A, B, C, D: no python-control needed
    import control

__all__ = ["HammersteinPlant"]


class HammersteinPlant:
    """Multivariable PI hysteresis followed by discrete-time linear dynamics.

    Parameters
    ----------
    hysteresis : MultivariablePI
        Rate-independent part, m inputs [V] -> p outputs [µm].
    sampling_period : float
        Sampling period T [s].
    dynamics : control.StateSpace, hammerstein.core.dynamics.SampledSystem or None
        Discrete-time linear part with ``dt == sampling_period``, p inputs and
        p outputs [µm]; ``None`` for the static plant. A ``SampledSystem``
        (the presets' bending modes) is simulated from its matrices and
        turned into a ``control.StateSpace`` on the first access of
        :attr:`dynamics` (python-control is imported only then).
    name : str
        Label used in reports.

    Notes
    -----
    The plant state is one flat vector: the ``n_hysterons`` play states
    followed by the ``n_linear_states`` states of the linear part.

    Attributes
    ----------
    amplifier : hammerstein.core.amplifier.Amplifier or None
        The preset's ``[amplifier]`` (range, slew rate, bandwidth of the
        voltages that reach the actuator); None: unlimited.

    Raises
    ------
    HysteresisError
        If the dynamics do not match the hysteresis outputs or the sampling
        period.
    """

    amplifier = None

    def __init__(self, hysteresis: MultivariablePI, sampling_period: float,
                 dynamics: control.StateSpace | None = None, name: str = "plant"):
        self.hysteresis, self.sampling_period, self.name = hysteresis, sampling_period, name
        self._dynamics = dynamics
        if not (np.isfinite(self.sampling_period) and self.sampling_period > 0):
            raise HysteresisError(
                f"sampling_period: expected a positive time [s], found {self.sampling_period!r}")
        if dynamics is not None:
            d = dynamics
            p = self.hysteresis.n_outputs
            if d.ninputs != p or d.noutputs != p:
                raise HysteresisError(
                    f"dynamics: expected {p} inputs and {p} outputs, found "
                    f"{d.ninputs} inputs and {d.noutputs} outputs")
            if not d.isdtime(strict=True) or not np.isclose(d.dt, self.sampling_period):
                raise HysteresisError(
                    f"dynamics: expected a discrete system with dt={self.sampling_period}, "
                    f"found dt={d.dt}")

    def __repr__(self):
        return (f"HammersteinPlant(hysteresis={self.hysteresis!r}, sampling_period="
                f"{self.sampling_period!r}, dynamics={self._dynamics!r}, name={self.name!r})")

    @property
    def dynamics(self):
        """The linear part as a ``control.StateSpace`` (None for the static plant)."""
        if self._dynamics is not None and hasattr(self._dynamics, "to_control"):
            self._dynamics = self._dynamics.to_control()  # python-control loaded here, once
        return self._dynamics

    @property
    def sampled_dynamics(self):
        """The linear part as a :class:`hammerstein.core.dynamics.SampledSystem` (no python-control).

        None for the static plant.
        """
        d = self._dynamics
        return d if d is None or hasattr(d, "to_control") else SampledSystem.from_system(d)

    @property
    def is_static(self) -> bool:
        """True when the plant has no linear dynamics."""
        return self._dynamics is None

    @property
    def n_linear_states(self) -> int:
        """Number of states of the linear part (0 for the static plant)."""
        return 0 if self._dynamics is None else self._dynamics.nstates

    @property
    def n_states(self) -> int:
        """Length of the flat plant state vector."""
        return self.hysteresis.n_hysterons + self.n_linear_states

    @property
    def matrices(self):
        """Discrete ``(A, B, C, D)`` of the linear part, identity-like if static."""
        if self._dynamics is None:
            p = self.hysteresis.n_outputs
            return (np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p))
        d = self._dynamics
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
