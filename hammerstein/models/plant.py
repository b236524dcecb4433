"""The Hammerstein actuator: multivariable hysteresis cascaded with linear dynamics.

``U (m, N) [V] -> Gamma (hysteresis) -> H (p, N) [µm] -> creep -> G(z) -> Y (p, N) [µm]``

The linear part makes the hysteresis rate dependent (paper, Sections 1 and 6;
docs/hammerstein-plant.md). Without dynamics the plant is the static (rate-independent) model.
The hysteresis is the multivariable classical PI of the paper or, for plants outside that
class, a :class:`~hammerstein.models.preisach.MultivariableHysteresis` (Preisach, generalised
PI, polynomial components); the optional creep (:mod:`hammerstein.models.creep`) is linear and
sits between the hysteresis and the bending modes (docs/plants.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hammerstein.models.creep import Creep, creep_matrices, series_matrices
from hammerstein.models.dynamics import SampledSystem
from hammerstein.models.hysteresis import HysteresisError, MultivariablePI
from hammerstein.simulation import simulate_plant, state_vector

if TYPE_CHECKING:                      # the plant only reads A, B, C, D: no python-control needed
    import control

__all__ = ["HammersteinPlant", "hardware_start"]


class HammersteinPlant:
    """Multivariable hysteresis followed by (creep and) discrete-time linear dynamics.

    Parameters
    ----------
    hysteresis : MultivariablePI or MultivariableHysteresis
        Rate-independent part, m inputs [V] -> p outputs [µm]: the classical
        multivariable PI, or a model with Preisach / generalised-PI /
        polynomial components (:mod:`hammerstein.models.preisach`; simulated
        component by component, never by the fused PI kernels).
    sampling_period : float
        Sampling period T [s].
    dynamics : control.StateSpace, hammerstein.models.dynamics.SampledSystem or None
        Discrete-time linear part with ``dt == sampling_period``, p inputs and
        p outputs [µm]; ``None`` for the static plant. A ``SampledSystem``
        (the presets' bending modes) is simulated from its matrices and
        turned into a ``control.StateSpace`` on the first access of
        :attr:`dynamics` (python-control is imported only then).
    name : str
        Label used in reports.
    creep : sequence of (Creep or None), length p, optional
        Creep per output (:class:`hammerstein.models.creep.Creep`), applied to
        the hysteresis output before the dynamics; None: no creep.

    Notes
    -----
    The plant state is one flat vector: the ``n_hysterons`` hysteresis states
    followed by the ``n_linear_states`` states of the linear part (creep lags
    first, then the dynamics). :attr:`matrices` is the whole linear part
    (creep then dynamics); :attr:`dynamics` the bending modes alone.

    Attributes
    ----------
    amplifier : hammerstein.models.amplifier.Amplifier or None
        The preset's ``[amplifier]`` (range, slew rate, bandwidth of the
        voltages that reach the actuator); None: unlimited.
    units : tuple of str
        ``(input unit, output unit)`` of the preset's ``[model]`` table
        (``input_unit``, ``output_unit``; default ``("V", "µm")``): what its
        inputs take and its outputs give, and what references are in.

    Raises
    ------
    HysteresisError
        If the dynamics do not match the hysteresis outputs or the sampling
        period.
    """

    amplifier = None
    units = ("V", "µm")

    def __init__(self, hysteresis: MultivariablePI, sampling_period: float,
                 dynamics: control.StateSpace | None = None, name: str = "plant", creep=None):
        self.hysteresis, self.sampling_period, self.name = hysteresis, sampling_period, name
        self._dynamics = dynamics
        self.creep = None
        if creep is not None:
            try:
                creep = list(creep)
            except TypeError:       # a CreepIdentifier: its creeps_, or IdentificationResult.plant
                raise HysteresisError(
                    f"creep: expected {hysteresis.n_outputs} entries (a Creep or None per "
                    f"output), found {type(creep).__name__} (an identification's creep: its "
                    f"creeps_; IdentificationResult.plant builds the whole plant)") from None
            if len(creep) != hysteresis.n_outputs or not all(
                    c is None or isinstance(c, Creep) for c in creep):
                raise HysteresisError(f"creep: expected {hysteresis.n_outputs} entries (a Creep "
                                      f"or None per output), found {creep!r}")
            self.creep = creep if any(c is not None for c in creep) else None
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
        """Class, name, hysteresis model, the dynamics' order and the creep (no arrays)."""
        d = self._dynamics
        if d is None:
            dyn = "static (no dynamics)"
        else:
            n = d.nstates if hasattr(d, "nstates") else d.A.shape[0]
            dyn = f"dynamics order {n}"
        creep = "" if self.creep is None else ", creep on " + ", ".join(
            f"{o} ({c.time_constants.size} lags {c.time_constants.min():.3g}.."
            f"{c.time_constants.max():.3g} s, settled gain {c.static_gain:.4g})"
            for o, c in zip(self.hysteresis.output_names, self.creep) if c is not None)
        return (f"HammersteinPlant(name={self.name!r}, {self.hysteresis!r}, {dyn}{creep}, "
                f"sampling_period={self.sampling_period:g} s)")

    @property
    def dynamics(self):
        """The linear part as a ``control.StateSpace`` (None for the static plant)."""
        if self._dynamics is not None and hasattr(self._dynamics, "to_control"):
            self._dynamics = self._dynamics.to_control()  # python-control loaded here, once
        return self._dynamics

    @property
    def sampled_dynamics(self):
        """The linear part as a :class:`hammerstein.models.dynamics.SampledSystem` (no python-control).

        None for the static plant.
        """
        d = self._dynamics
        return d if d is None or hasattr(d, "to_control") else SampledSystem.from_system(d)

    @property
    def is_static(self) -> bool:
        """True when the plant has no linear part (no dynamics and no creep)."""
        return self._dynamics is None and self.creep is None

    @property
    def n_creep_states(self) -> int:
        """Number of creep lag states (0 without creep)."""
        return 0 if self.creep is None else sum(c.n_states for c in self.creep if c is not None)

    @property
    def n_linear_states(self) -> int:
        """Number of states of the linear part, creep included (0 for the static plant)."""
        return (0 if self._dynamics is None else self._dynamics.nstates) + self.n_creep_states

    @property
    def n_states(self) -> int:
        """Length of the flat plant state vector."""
        return self.hysteresis.n_hysterons + self.n_linear_states

    @property
    def matrices(self):
        """Discrete ``(A, B, C, D)`` of the linear part (creep then dynamics), identity-like if static."""
        p = self.hysteresis.n_outputs
        if self._dynamics is None:
            mats = (np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p))
        else:
            d = self._dynamics
            mats = (np.asarray(d.A), np.asarray(d.B), np.asarray(d.C), np.asarray(d.D))
        if self.creep is None:
            return mats
        return series_matrices(creep_matrices(self.creep, self.sampling_period), mats)

    @property
    def packable(self) -> bool:
        """True when the fused PI kernels can run the hysteresis (a classical multivariable PI)."""
        return getattr(self.hysteresis, "packable", True)

    def initial_state(self, initial_state=None):
        """Validated copy of a flat plant state.

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            Hysteresis states then linear states [µm]. By default the
            hysteresis model's default state (play outputs [V] at 0 for the classical
            PI, or where its demagnetising cycle leaves them; the demagnetised state of
            a Preisach model)
            and zero linear states.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array.

        Raises
        ------
        HysteresisError
            If the state does not have length ``n_states``.
        """
        if initial_state is None:
            return np.concatenate([self.hysteresis.initial_state(),
                                   np.zeros(self.n_linear_states)])
        state = state_vector(initial_state, self.n_states)
        if not self.packable:
            self.hysteresis.initial_state(state[:self.hysteresis.n_hysterons])
        return state

    def rest_state(self):
        """The flat state at rest: 0 V held long enough for the linear part to settle.

        The hysteresis model's default state (:meth:`initial_state`) and the
        linear part (creep then dynamics) in its DC steady state for the
        hysteresis output at 0 V, ``x = (I - A)^-1 B h0`` (``h0`` without the model's
        ``output_offset`` c, which :meth:`simulate` adds after the linear part as a sensor
        zero; counted in ``h0`` too it showed twice, 4.0 instead of 2.0 um): simulated from it,
        a drive that stays at 0 V keeps the output at its rest value (the
        creep's settled output, :func:`hammerstein.compensation.drive.rest_output`,
        through the dynamics' DC gain), as the actuator it models does,
        instead of ringing up from 0 µm.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            Hysteresis states then linear states [µm].

        Raises
        ------
        numpy.linalg.LinAlgError
            If the linear part has a pole at z = 1 (no steady state).

        Examples
        --------
        >>> import numpy as np
        >>> from hammerstein.io.presets import load_plant
        >>> plant = load_plant("rakotondrabe-2dof")
        >>> y, _ = plant.simulate(np.zeros((2, 5)), plant.rest_state())
        >>> bool(np.allclose(y, y[:, :1]))
        True
        """
        state = self.initial_state()
        nh = self.hysteresis.n_hysterons
        if self.n_linear_states:
            h0, _ = self.hysteresis.simulate(np.zeros((self.hysteresis.n_inputs, 1)),
                                             state[:nh].copy())
            h0 = np.asarray(h0, dtype=float)[:, 0]
            off = getattr(self.hysteresis, "output_offset", None)
            if off is not None:     # a sensor zero: simulate adds it after the linear part
                h0 = h0 - np.asarray(off, dtype=float)
            A, B, _, _ = self.matrices
            state[nh:] = np.linalg.solve(np.eye(A.shape[0]) - A, B @ h0)
        return state

    def simulate(self, inputs, initial_state=None):
        """Displacements for a record of input voltages (open loop).

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Input voltages [V] at the sampling period.
        initial_state : array_like, shape (n_states,), optional
            Hysteresis states then linear states; see :meth:`initial_state`.

        Returns
        -------
        outputs : numpy.ndarray, shape (p, n_samples)
            Displacements [µm].
        final_state : numpy.ndarray, shape (n_states,)
            State after the last sample, for a chunked continuation.
        """
        return simulate_plant(self, inputs, initial_state)


def hardware_start(plant):
    """True when a plant starts as the hardware commands start it: an identified or hardware-like actuator.

    Such a plant has an amplifier (its ``[amplifier]`` table: the range and
    slew rate the drive must keep; ``hammerstein identify`` writes one) or
    a hysteresis model with an output offset (an identified model's sensor
    zero: its output at 0 V is not 0 µm). A scenario case on it computes
    its drive as ``compensate`` does (:func:`hammerstein.scenario.hardware_route.start_drive`: faded in from
    the model's rest output over a duration). The bundled presets (no
    amplifier, no offset) keep the scenarios' own start, and their
    numbers, also those whose Preisach plant is not at 0 µm at 0 V from its
    initial state (realistic-2dof, -1.6 µm).

    Parameters
    ----------
    plant : HammersteinPlant

    Returns
    -------
    bool

    Examples
    --------
    >>> import hammerstein as hs
    >>> hardware_start(hs.load_plant("rakotondrabe-2dof"))
    False
    """
    if getattr(plant, "amplifier", None) is not None:
        return True
    offset = getattr(plant.hysteresis, "output_offset", None)
    return offset is not None and bool(np.any(np.asarray(offset, dtype=float) != 0.0))
