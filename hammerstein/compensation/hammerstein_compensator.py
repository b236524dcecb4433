"""The Hammerstein compensator: inverse of the linear dynamics, then of the hysteresis.

Length: about 950 lines: the compensator, its ZPETC preview and the
reference continuation it reads ahead are one state machine (the chunked
stream, the fused kernels and the exported C follow it step by step).

The actuator is the Hammerstein cascade ``U -> Gamma (multivariable PI) -> H
-> G(z) -> Y``. Its feedforward compensator inverts the two blocks in the
reverse order (docs/hammerstein-plant.md, "Compensation")::

    Yr -> G^-1 (stable approximate inverse) -> V -> Gamma^c (inverse multiplicative law) -> U

so that ``G Gamma(U) ~ G V ~ Yr``. ``G^-1`` is one of

* ``inversion = "zpetc"`` (default): the causal MIMO zero-phase-error
  tracking inverse (:class:`hammerstein.compensation.inversion.ZPETCInverse`). It
  runs sample by sample and needs the reference ``P = preview_samples``
  samples ahead (``P`` = relative degree + number of approximated zeros, 2
  for the bundled actuator, 3 for the coupled preset): the trajectory
  generator runs P samples (100-150 µs) ahead of the actuator. Without that
  preview the inverse is delayed by P samples, a tracking error of
  ``2 sin(pi f P T)`` (12.6 % at 200 Hz).
* ``inversion = "stable"``: stable inversion of a record known in advance
  (Devasia-Chen-Paden), its anti-causal part summed over the reference ahead
  down to 1e-14 (:class:`hammerstein.compensation.lookahead.LookaheadInverse`,
  what the export runs; the whole-record recursion of
  :func:`hammerstein.compensation.inversion.preview_inverse` beyond 20000
  samples); not chunkable.

``Gamma^c`` is the normalised inverse multiplicative law of
:class:`hammerstein.compensation.compensators.InverseMultiplicativeCompensator`
with all its options (gain, iterations, check, feedback). Three iterations
per sample are the default here: once G is inverted the one-iteration
law's lag costs 2-4 % at 200-300 Hz.

Start-up. A reference that starts away from the actuator's rest (a circle
starts at x = R) or with a slope asks the inverse for a step of velocity
at t = 0, a spike of V many times the amplitude that the PI compensator
cannot follow. :meth:`HammersteinCompensator.start` therefore fades the
reference in from the rest output (0 µm, zero play and linear states) by a
raised cosine ``w(t) = (1 - cos(pi t / t_f)) / 2`` over ``t_f`` (value and
slope continuous at both ends) and starts the inverse at rest; metrics are
taken after ``settle_periods``, which must cover the fade.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

from hammerstein.compensation._repeat import continuation, continuations, repeat_lag  # noqa: F401
from hammerstein.compensation.compensators import CompensatorError, _gain_text
from hammerstein.models.creep import creep_dynamics, creep_matrices, series_matrices
from hammerstein.models.dynamics import DynamicsError
from hammerstein.models.hysteresis import HysteresisError, state_vector
from hammerstein.compensation.inversion import ZPETCInverse, inverse_system, preview_inverse
from hammerstein.compensation.lookahead import (EXPORT_DECAY, MAX_LOOKAHEAD, LookaheadInverse,
                                                creep_rest_state, rest_output)
from hammerstein.compensation.model_classes import model_class
from hammerstein.compensation.reference_check import check_reference, reference_checked
from hammerstein.simulation import (ChainResult, LinearArrays, linear_steps, simulate_chain,
                                    simulate_compensator)

__all__ = ["HammersteinCompensator", "INVERSIONS", "fade_in", "continuation", "continuations",
           "creep_inverse", "CreepCascadeInverse"]

#: What the stable inversion's anti-causal part decays to over the periodic continuation it
#: reads past a periodic record's end (:meth:`HammersteinCompensator._stable_continuation`).
STABLE_DECAY = 1e-9
#: The longest such continuation [samples] (a zero at |z| = 1.004 needs 5200 for 1e-9).
MAX_STABLE_CONTINUATION = 20000

#: Inverse methods of G: name -> description.
INVERSIONS = {
    "zpetc": "causal MIMO ZPETC, sample by sample, reference needed preview_samples ahead",
    "stable": "stable inversion of a record known in advance (reference read ahead)",
}


def fade_in(reference, samples, rest=None):
    """Raised-cosine fade of a reference from the rest output.

    ``yr_f(t) = rest + w(t) (yr(t) - rest)``, ``w = (1 - cos(pi k / samples)) / 2``
    for ``k < samples``, 1 after.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    samples : int
        Fade length in samples (0: no fade).
    rest : array_like, shape (p,), optional
        Output at rest [µm]; zeros by default (zero play and linear states).

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
    """
    r = np.array(reference, dtype=float)
    n = int(min(max(samples, 0), r.shape[1]))
    if n == 0:
        return r
    r0 = np.zeros(r.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    w = 0.5 * (1.0 - np.cos(np.pi * np.arange(n) / n))
    r[:, :n] = r0[:, None] + w * (r[:, :n] - r0[:, None])
    return r


def _zpetc_preview_states(inverse, heads):
    """ZPETC states after the preview samples ``heads`` (B, p, P) of faded-in records.

    The start-up of :meth:`HammersteinCompensator.start` for its usual case:
    a plain :class:`ZPETCInverse` and references faded in from rest, so each
    record's first sample is 0 and the inverse starts from its all-zero rest
    state: ``inverse.filter(head, zeros)`` on each record (the compiled state
    space the exported C runs, so the same bits as the general path), without
    the initial state's solve. Returns ``(states, fast)``: ``states``
    (B, n_states), valid where ``fast`` (B,) is True; False for a record
    whose first sample is away from 0 or that holds a non-finite sample (the
    caller runs the general path), all False for another inverse.
    """
    B = heads.shape[0]
    if type(inverse) is not ZPETCInverse:
        return None, np.zeros(B, dtype=bool)
    fast = ~heads[:, :, 0].any(axis=1) & np.isfinite(heads).all(axis=(1, 2))
    states = np.zeros((B, inverse.n_states))
    for b in np.flatnonzero(fast):
        _, states[b] = inverse.filter(heads[b], np.zeros(inverse.n_states))
    return states, fast


def _fade_weights(lengths):
    """The raised-cosine weights of :func:`fade_in` for several fade lengths, end to end.

    ``lengths`` (B,) int: fade lengths in samples; the weights of record b
    are ``out[offsets[b]:offsets[b + 1]]`` with ``offsets`` the cumulative
    lengths. The same elementwise operations as :func:`fade_in` (the same bits).
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    total = int(lengths.sum())
    starts = np.cumsum(lengths) - lengths
    k = np.arange(total) - np.repeat(starts, lengths)
    return 0.5 * (1.0 - np.cos(np.pi * k / np.repeat(lengths, lengths)))


def creep_inverse(creeps, sampling_period):
    """Exact inverse ``(I + C)^-1`` of the discrete creep of p outputs.

    ``(A, B, C, D)`` of the creep (:func:`hammerstein.models.creep.creep_matrices`)
    gives the inverse ``(A - B D^-1 C, B D^-1, -D^-1 C, D^-1)``; its poles are
    the creep's zeros, inside the unit circle for a minimum-phase creep
    (:func:`hammerstein.models.creep.minimum_phase_margin`).

    Parameters
    ----------
    creeps : sequence of (Creep or None), length p
    sampling_period : float
        T [s].

    Returns
    -------
    tuple of numpy.ndarray
        ``(A, B, C, D)``: (n, n), (n, p), (p, n), (p, p) [µm -> µm].
    """
    A, B, C, D = creep_matrices(creeps, sampling_period)
    Di = np.diag(1.0 / np.diag(D))
    return A - B @ Di @ C, B @ Di, -Di @ C, Di


class CreepCascadeInverse:
    """Causal inverse of ``G (I + C)``: the ZPETC inverse of G, then the exact creep inverse.

    ``(G (I + C))^-1 = (I + C)^-1 G^-1``: the same operator as the ZPETC of the
    combined system (the creep's zeros are acceptable: inside the unit
    circle), computed as a cascade because the creep's poles and zeros lie
    within ``T / tau`` of z = 1 (1e-7 for 100 s at 20 kHz), where the Schur
    split of the combined inverse loses accuracy: on a +/-40 µm staircase
    at 1 kHz through a PI with log creep (0.01-100 s) and slow modes,
    ``G (I + C) V`` missed the reference by 0.16 µm with the combined ZPETC
    and by 2e-4 µm with the cascade (after 0.1 s of each step). The
    interface is that of :class:`hammerstein.compensation.inversion.ZPETCInverse`.

    Parameters
    ----------
    bending : ZPETCInverse
        Inverse of G.
    creeps : sequence of (Creep or None), length p
    sampling_period : float
        T [s].

    Attributes
    ----------
    preview_samples : int
        That of ``bending``.
    n_states : int
        ``bending.n_states`` plus the creep lags.
    """

    def __init__(self, bending, creeps, sampling_period):
        self.bending = bending
        self.creep_matrices = creep_inverse(creeps, sampling_period)
        self.preview_samples = bending.preview_samples
        self.unacceptable_zeros = bending.unacceptable_zeros
        self.relative_degree = bending.relative_degree
        self.p = bending.p
        self.n_states = bending.n_states + self.creep_matrices[0].shape[0]

    def initial_state(self, reference=None):
        """State at rest for a constant reference (both stages in DC steady state).

        Parameters
        ----------
        reference : array_like, shape (p,), optional
            [µm]; zeros by default.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
        """
        s1 = self.bending.initial_state(reference)
        A, B, _, _ = self.creep_matrices
        x = np.zeros(A.shape[0])
        if reference is not None and np.any(np.asarray(reference) != 0):
            Ab, Bb, Cb, Db = self.bending.state_space()
            v0 = Cb @ s1 + Db @ np.asarray(reference, dtype=float)
            x = np.linalg.solve(np.eye(A.shape[0]) - A, B @ v0)
        return np.concatenate([s1, x])

    def filter(self, reference, initial_state=None):
        """:meth:`ZPETCInverse.filter` followed by the creep inverse.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            [µm].
        initial_state : array_like, shape (n_states,), optional

        Returns
        -------
        v : numpy.ndarray, shape (p, n_samples)
            [µm].
        final_state : numpy.ndarray, shape (n_states,)
        """
        s = np.zeros(self.n_states) if initial_state is None else np.asarray(initial_state, float)
        nb = self.bending.n_states
        v, s1 = self.bending.filter(reference, s[:nb])
        w, s2 = linear_steps(v, self.creep_matrices, s[nb:])
        return w, np.concatenate([s1, s2])

    def state_space(self):
        """The cascade as one discrete state space on the flat state (see :meth:`filter`).

        Returns
        -------
        tuple of numpy.ndarray
            ``(A, B, C, D)`` [µm -> µm].
        """
        return series_matrices(self.bending.state_space(), self.creep_matrices)


class HammersteinCompensator:
    """Feedforward compensator of a Hammerstein actuator: ``U = Gamma^c(G^-1 Yr)``.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Model of the actuator's hysteresis (m inputs [V], p outputs [µm]),
        e.g. identified. A classical PI is inverted by the inverse
        multiplicative law (below); any other model (a Preisach model,
        :class:`~hammerstein.models.preisach.MultivariableHysteresis`) by the
        exact per-sample root of
        :class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`
        (monotone Preisach direct paths), after the same inverse of G; the
        law's options (gain, iterations, check, feedback) then do not apply.
    dynamics : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        Discrete p x p linear part G (``dt`` = the plant's sampling period),
        e.g. identified (:class:`hammerstein.models.lti.DynamicsIdentifier`).
        A ``SampledSystem`` (``plant.sampled_dynamics``) is inverted by
        ``'zpetc'`` without importing python-control (about 1 s of imports);
        ``'stable'`` and the creep inverse convert it to a
        ``control.StateSpace``.
    inversion : {'zpetc', 'stable'}
        Inverse of G (see the module docstring).
    gain, iterations, check, feedback, cutoff_hz, sampling_period
        Options of :class:`InverseMultiplicativeCompensator` (the
        hysteresis compensator, paper Theorem 4.1, normalised as in
        docs/compensator.md); ``iterations`` defaults to 3 here.
    name : str
        Label in reports.
    creep : sequence of (Creep or None), length p, optional
        Creep per output after the hysteresis (:mod:`hammerstein.models.creep`,
        e.g. identified from staircases). Creep is linear, so the inverted
        system is ``G (I + C)`` (:func:`hammerstein.models.creep.creep_dynamics`,
        minimum phase by construction: the creep's zeros are inside the unit
        circle, the poles of its exact inverse), inverted with the same ZPETC
        or stable inversion of G followed by the exact creep inverse
        (:class:`CreepCascadeInverse`; Croft, Shed and Devasia [4]_).

    Attributes
    ----------
    hysteresis_compensator : InverseMultiplicativeCompensator or PreisachInverseCompensator
    dynamics : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        The system inverted: G, or ``G (I + C)`` with creep.
    bending_dynamics : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        G alone (as given for ``'zpetc'`` without creep, else a ``control.StateSpace``).
    creep : list of (Creep or None) or None
    inverse : ZPETCInverse or None
        The causal inverse (``'zpetc'``).
    preview_samples : int
        P: samples of reference needed ahead (0 for ``'stable'``, whose
        preview is the whole record).
    n_states : int
        Length of the flat state: the hysteresis compensator's state
        (``U(t-T)``, [``v_f``,] play states) then the filter state.

    Raises
    ------
    CompensatorError
        On an unknown inversion, a sampling period that is not a positive
        time, or dynamics not p x p with p the model's outputs; the
        hysteresis compensator's own errors.

    References
    ----------
    .. [1] M. Tomizuka, J. Dyn. Sys., Meas., Control 109(1), 65-68, 1987 (ZPETC).
    .. [2] S. Devasia, D. Chen and B. Paden, IEEE TAC 41(7), 930-942, 1996.
    .. [3] M. Rakotondrabe, C. Clevy and P. Lutz, IEEE T-ASE 7(3), 2010
       (Hammerstein compensation of piezocantilevers).
    .. [4] D. Croft, G. Shed and S. Devasia, J. Dyn. Sys., Meas., Control
       123(1), 35-43, 2001 (creep, hysteresis and vibration compensation).

    Examples
    --------
    >>> from hammerstein import HammersteinCompensator
    >>> import numpy as np
    >>> from hammerstein.io.presets import load_plant
    >>> plant = load_plant("rakotondrabe-2dof")
    >>> comp = HammersteinCompensator(plant.hysteresis, plant.dynamics)
    >>> comp.preview_samples
    2
    >>> t = np.arange(4000) * plant.sampling_period
    >>> yr = 20.0 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    >>> res = comp.run_reference(plant, yr, period_samples=200, fade_samples=400)
    >>> e = np.linalg.norm(res.outputs[:, 2000:] - yr[:, 2000:], axis=0)
    >>> bool(e.max() < 0.1)          # µm, true models, 20 µm circle at 100 Hz
    True
    """

    #: > 0 inside :meth:`simulate` and :meth:`chain` (:meth:`packed_law` refuses outside them)
    _entered = 0
    #: the ZPETC pre-filter's LinearArrays, built by the first :meth:`packed_law`
    _prefilter = None

    def __init__(self, model, dynamics, inversion="zpetc", gain="midpoint", iterations=3,
                 check="error", feedback="delay", cutoff_hz=None, sampling_period=None,
                 name="hammerstein", creep=None):
        if inversion not in INVERSIONS:
            raise CompensatorError(f"inversion: expected one of {', '.join(map(repr, INVERSIONS))}, "
                                   f"found {inversion!r}")
        if sampling_period is not None and not (np.isfinite(sampling_period) and sampling_period > 0):
            raise CompensatorError(f"sampling_period: expected a positive time [s], found "
                                   f"{sampling_period!r}")
        p = model.n_outputs
        if dynamics is None or dynamics.ninputs != p or dynamics.noutputs != p \
                or not dynamics.isdtime(strict=True):
            raise CompensatorError(f"dynamics: expected a discrete {p}x{p} system (the model's "
                                   f"{p} outputs), found {dynamics!r}")
        options = {}
        if feedback != "delay":
            options = {"feedback": feedback, "cutoff_hz": cutoff_hz,
                       "sampling_period": sampling_period or dynamics.dt}
        entry = model_class(model)        # the model's class: its exact inverse, or the law
        #: True when the static part is the class's exact inverse (Preisach, generalised PI)
        self.exact_static = entry.exact_inverse_kind is not None
        if self.exact_static:
            try:
                self.hysteresis_compensator = entry.exact_inverse(model, name=name)
            except CompensatorError as exc:
                raise CompensatorError(
                    f"kind 'hammerstein' with a {type(model).__name__} model (class "
                    f"{entry.name!r}): its static part is "
                    f"the exact inverse, which refuses this model: {exc}") from None
        else:
            try:
                self.hysteresis_compensator = entry.compensator(
                    model, "multivariable", gain=gain, iterations=iterations, check=check,
                    **options)
            except CompensatorError as exc:     # named as the kind the user chose
                raise CompensatorError(str(exc).replace(
                    "of this multivariable compensator",
                    f"of this {name} compensator's static part (the multivariable law)")) from None
        with_creep = creep is not None and any(c is not None for c in creep)
        if (inversion != "zpetc" or with_creep) and hasattr(dynamics, "to_control"):
            dynamics = dynamics.to_control()     # 'stable' and the creep cascade use python-control
        self.bending_dynamics = dynamics
        self.creep = None
        if with_creep:
            try:
                dynamics = creep_dynamics(creep, dynamics)
            except HysteresisError as exc:
                raise CompensatorError(str(exc)) from None
            self.creep = list(creep)
        self.dynamics = dynamics
        self.inversion = inversion
        self.name = name
        try:
            self.inverse = ZPETCInverse(self.bending_dynamics) if inversion == "zpetc" else None
        except DynamicsError as exc:
            raise CompensatorError(f"dynamics: cannot be inverted: {exc}") from None
        if self.inverse is not None and self.creep is not None:
            self.inverse = CreepCascadeInverse(self.inverse, self.creep, dynamics.dt)
        self.preview_samples = 0 if self.inverse is None else self.inverse.preview_samples

    def __repr__(self):
        """Class, model size, the dynamics inverted, the inversion and its preview (no arrays)."""
        d = self.dynamics
        hc = self.hysteresis_compensator
        if self.exact_static:
            return (f"HammersteinCompensator(name={self.name!r}, model "
                    f"{type(self.model).__name__} {self.model.n_outputs}x{self.model.n_inputs}; "
                    f"dynamics order {d.nstates}, inversion={self.inversion!r}, preview "
                    f"{self.preview_samples} samples; static part: exact Preisach inverse)")
        return (f"HammersteinCompensator(name={self.name!r}, model {self.model.size_text()}; "
                f"dynamics order {d.nstates} ({d.noutputs}x{d.ninputs}, T = {d.dt:g} s)"
                f"{'' if self.creep is None else ' with creep'}, "
                f"inversion={self.inversion!r}, preview {self.preview_samples} samples; "
                f"gain={hc.gain if isinstance(hc.gain, str) else 'given'!r}: {_gain_text(hc.K)}, "
                f"max rho {hc.convergence.max_radius:.3g})")

    # -- sizes and states ---------------------------------------------------------------
    @property
    def model(self):
        """The PI model of the hysteresis compensator."""
        return self.hysteresis_compensator.model

    @property
    def n_filter_states(self) -> int:
        """States of the causal inverse (0 for ``'stable'``)."""
        return 0 if self.inverse is None else self.inverse.n_states

    @property
    def n_states(self) -> int:
        """Length of the flat compensator state."""
        return self.hysteresis_compensator.n_states + self.n_filter_states

    def initial_state(self, initial_state=None):
        """Validated copy of a flat state (by default the hysteresis compensator's default
        state, where its model starts, and the filter at 0).

        The default is not the compensator at rest: its inverse of G sits at 0 µm, where an
        identified stage rests elsewhere (its model's output at 0 V, e.g. (-0.99, 0.62) µm),
        and a loop started from it is off ``compensate``'s drive by volts at its first
        samples (5.15 V on such a stage). A streaming loop starts from :meth:`rest_state`
        and feeds ``compensate``'s faded reference P samples ahead (docs/python-api.md,
        "Streaming in your own loop").

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            The hysteresis compensator's state then the filter state.

        Returns
        -------
        numpy.ndarray, shape (n_states,)

        Raises
        ------
        HysteresisError
            If the state has the wrong length or non-finite values.
        """
        if initial_state is None:   # the hysteresis compensator's default (the model's start)
            return np.concatenate([self.hysteresis_compensator.initial_state(),
                                   np.zeros(self.n_filter_states)])
        return state_vector(initial_state, self.n_states)

    def rest_state(self):
        """The state of the compensator at rest: where a streaming loop starts.

        The hysteresis compensator's default state (:meth:`initial_state`), and the
        inverse of G settled at the output ``compensate`` fades its reference in from
        (:func:`~hammerstein.compensation.drive.compensator_rest`: the model's output at
        0 V, with creep settled), in the frame the inverse filters
        (:meth:`prefilter_reference`), as the exported C's ``NAME_init`` sets it. From
        it, :meth:`simulate` (inside :meth:`previewed`) on ``compensate``'s faded
        reference P samples ahead gives ``compensate``'s voltages, in any chunks.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            For ``'stable'``, :meth:`initial_state` (the whole-record inverse starts
            itself at rest).
        """
        state = self.initial_state()
        if self.inverse is not None:
            rest = rest_output(self.model, self.creep)
            state[self.hysteresis_compensator.n_states:] = self.preview_state(rest[:, None], 0)
        return state

    def _split(self, state):
        nc = self.hysteresis_compensator.n_states
        return state[:nc], state[nc:]

    # -- the inverse of G ---------------------------------------------------------------------
    def inverse_dynamics(self, reference, filter_state):
        """``V = G^-1 Yr`` for a chunk of (lead) reference.

        Parameters
        ----------
        reference : numpy.ndarray, shape (p, n_samples)
            ``'zpetc'``: the reference P samples ahead, ``yr(t + P)`` [µm];
            ``'stable'``: the whole record ``yr(t)``, G at rest at its first
            sample.
        filter_state : numpy.ndarray, shape (n_filter_states,)

        Returns
        -------
        v : numpy.ndarray, shape (p, n_samples)
            Desired PI outputs [µm].
        final_state : numpy.ndarray, shape (n_filter_states,)
        """
        if self.inverse is None:    # continued past the end: no held-end spike
            off = None if self.exact_static else getattr(self.model, "output_offset", None)
            if off is not None:     # y = L(S(Gamma)) + c: L^-1(Yr - c), + c for the law's S^-1(. - c)
                reference = reference - off[:, None]
            ext = np.concatenate([reference, self._stable_continuation(reference)], axis=1)
            N, la = reference.shape[1], self.lookahead_inverse
            if la is None:          # a look-ahead too long to build: the whole-record recursion
                v = preview_inverse(self.bending_dynamics, ext, method="stable")[:, :N]
            else:                   # what the exported C computes, term for term
                ext = np.concatenate([ext, np.repeat(ext[:, -1:], max(0, N + la.preview_samples
                                                                      - ext.shape[1]), axis=1)], 1)
                v = la.filter(ext[:, :N + la.preview_samples], la.initial_state(reference[:, 0]))[0]
            if self.creep is not None:     # (G (I + C))^-1 = (I + C)^-1 G^-1, creep at rest
                mats = creep_inverse(self.creep, self.dynamics.dt)
                v = linear_steps(v, mats, creep_rest_state(mats, self.bending_dynamics,
                                                           reference[:, 0]))[0]
            return (v if off is None else v + off[:, None]), filter_state
        return self.inverse.filter(reference, filter_state)

    def start(self, reference, period_samples=None, fade_samples=0):
        """Lead reference and initial state for a record (start-up handling).

        The reference is faded in from rest (:func:`fade_in`); for
        ``'zpetc'`` the inverse starts at rest at the faded reference's first
        sample and consumes its first P samples, and the lead is the
        reference P samples ahead, continued past the end by
        :func:`continuation` (periodic when ``period_samples`` is given).
        The hysteresis compensator starts from zero (the actuator at rest).

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            ``yr(t)`` [µm].
        period_samples : int, optional
            Period of a periodic reference [samples].
        fade_samples : int
            Fade-in length [samples] (0: abrupt start).

        Returns
        -------
        lead : numpy.ndarray, shape (p, n_samples)
            What :meth:`simulate` takes.
        state : numpy.ndarray, shape (n_states,)
        faded : numpy.ndarray, shape (p, n_samples)
            The faded reference the outputs should follow.
        """
        reference = self._checked_reference(reference)
        if self.inverse is None:
            self._stable_period = period_samples      # the continuation past the record's end
            faded = fade_in(reference, fade_samples)
            return faded, self.initial_state(), faded
        return self._starts([reference], [period_samples], [fade_samples])[0]

    def _checked_reference(self, reference, name="reference"):
        """The reference as a finite (p, n_samples) float array, or a CompensatorError that
        names the shape given (not that of an array built from it: a (1600,) record was
        reported as (1600, 2), the preview-padded one)."""
        p = self.model.n_outputs
        try:
            r = np.asarray(reference, dtype=float)
        except (TypeError, ValueError):
            raise CompensatorError(f"{name}: expected a finite ({p}, n_samples) array [µm], "
                                   f"found {type(reference).__name__}") from None
        if r.ndim != 2 or r.shape[0] != p or r.shape[1] < 1 or not np.all(np.isfinite(r)):
            what = f"shape {r.shape}" if r.ndim != 2 or r.shape[0] != p or r.shape[1] < 1 \
                else f"a non-finite value at sample {int(np.flatnonzero(~np.all(np.isfinite(r), axis=0))[0])}"
            raise CompensatorError(f"{name}: expected a finite ({p}, n_samples) array [µm], one "
                                   f"row per output, found {what}")
        return r

    def stable_lookahead(self, decay=1e-12):
        """Samples over which the stable inversion's anti-causal part decays below ``decay``.

        The slowest unstable pole of G^-1 (a zero of G outside the unit circle, ``|z| > 1``)
        decays backward in time as ``|z|^-k`` (Devasia, Chen & Paden, IEEE TAC 41(7), 1996).

        Parameters
        ----------
        decay : float
            Relative size left, in (0, 1).

        Returns
        -------
        int
            ``ceil(log(1 / decay) / log |z|_min)``; 0 when G has no zero outside the unit
            circle.
        """
        radius = self.anticausal_radius
        if radius == 0.0:
            return 0
        return int(math.ceil(math.log(1.0 / decay) / math.log(radius)))

    @property
    def anticausal_radius(self):
        """``|z|`` of G's zero outside the unit circle nearest to it (the slowest decaying
        anti-causal mode of the stable inversion); 0.0 when G has none."""
        if getattr(self, "_anticausal_radius", None) is None:
            poles = np.linalg.eigvals(np.atleast_2d(inverse_system(self.bending_dynamics).A))
            outside = np.abs(poles[np.abs(poles) > 1.0 + 1e-12])
            self._anticausal_radius = float(np.min(outside)) if outside.size else 0.0
        return self._anticausal_radius

    @property
    def lookahead_inverse(self):
        """``'stable'``: G's stable inversion as a filter of the reference ahead
        (:class:`~hammerstein.compensation.lookahead.LookaheadInverse`, what the export runs),
        None for ``'zpetc'`` or a look-ahead beyond ``MAX_LOOKAHEAD`` samples."""
        if self.inverse is None and not hasattr(self, "_lookahead"):
            self._lookahead = (LookaheadInverse(self.bending_dynamics, max_lookahead=None)
                               if self.stable_lookahead(EXPORT_DECAY) <= MAX_LOOKAHEAD else None)
        return getattr(self, "_lookahead", None)

    def _stable_continuation(self, reference):
        """What the stable inversion reads past a record's end: the record's own periods
        repeated, when :meth:`start` was given its period and its last 8 samples repeat one
        or more periods earlier (:func:`~hammerstein.compensation._repeat.repeat_lag`), over :data:`STABLE_DECAY` of the anti-causal part and the look-ahead
        (at most :data:`MAX_STABLE_CONTINUATION` samples); else 8 extrapolated samples. (Held,
        the end is a kink the anti-causal modes ring back from: a zero near -1 as 15-50 V
        reversals over a new user's stage's last 40 samples, refused as chatter.)
        """
        r = np.asarray(reference, dtype=float)
        lag = repeat_lag(r, getattr(self, "_stable_period", None), 1)
        if lag is not None:
            la = self.lookahead_inverse
            n = min(max(8, self.stable_lookahead(STABLE_DECAY),
                        0 if la is None else la.preview_samples), MAX_STABLE_CONTINUATION)
            return r[:, r.shape[1] - lag + np.arange(n) % lag]
        return continuation(r, 8)

    def _starts(self, references, period_samples, fade_samples):
        """:meth:`start` of several records (``'zpetc'``), the numpy work done for all at once.

        Each record gets one (p, n + P) buffer: the faded record (the same
        values as :func:`fade_in`, its weights computed for all records in one
        call), then its continuation (:func:`continuations`); the inverse's
        state after the P preview samples comes from
        :func:`_zpetc_preview_states` for all records, or from
        ``inverse.filter`` for a record that does not start at rest. The
        results are those of :meth:`start` on each record alone, bit for bit
        (``start`` calls this with one record).

        Returns
        -------
        list of (lead, state, faded)
            As :meth:`start` returns them, in the order of ``references``.
        """
        P = self.preview_samples
        refs = [self._checked_reference(r, f"references[{i}]") for i, r in enumerate(references)]
        ns = [int(min(max(f, 0), r.shape[-1])) for f, r in zip(fade_samples, refs)]
        weights = _fade_weights(ns)
        exts, at = [], 0
        for r, n in zip(refs, ns):
            N = r.shape[-1]
            ext = np.empty((r.shape[0], N + P))
            ext[:, :N] = r
            if n:        # rest + w (r - rest) with rest 0: w r, then + 0.0 (-0.0 -> 0.0)
                seg = ext[:, :n]
                seg *= weights[at:at + n]
                seg += 0.0
                at += n
            exts.append(ext)
        for ext, r, cont in zip(exts, refs, continuations([e[:, :r.shape[-1]] for e, r in
                                                           zip(exts, refs)], P, period_samples)):
            ext[:, r.shape[-1]:] = cont
        nc = self.hysteresis_compensator.n_states
        # initial states: the hysteresis compensator at rest (initial_state()), then the inverse's
        state = np.tile(self.initial_state(), (len(refs), 1))
        fast = np.zeros(len(refs), dtype=bool)
        pre = self.prefilter_reference
        if P:
            s0, fast = _zpetc_preview_states(self.inverse, np.stack([pre(e[:, :P]) for e in exts]))
            if fast.any():
                state[fast, nc:] = s0[fast]
        for b in np.flatnonzero(~fast):
            state[b, nc:] = self.preview_state(exts[b], P)
        return [(ext[:, P:], state[b], ext[:, :r.shape[-1]])
                for b, (ext, r) in enumerate(zip(exts, refs))]

    def prefilter_reference(self, reference):
        """What the inverse of the dynamics filters (its fused kernel and the exported C
        alike): for the law over a classical PI, ``Yr - c`` (c its offset), then ``S^-1`` of
        a map after the inverse, the plant being ``y = L(S(Gamma(U))) + c`` (L: creep, G).
        :meth:`start` starts the inverse at rest in this frame (in ``Yr``, a PI with offset
        (-0.12, 0.45) um asked for -0.05 and -0.47 V at its drive's first sample).

        Parameters
        ----------
        reference : numpy.ndarray, shape (p, n_samples)
            [µm].

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
        """
        if self.exact_static or self.inverse is None or not hasattr(self.model, "gamma_reference"):
            return reference
        r, off = np.asarray(reference, dtype=float), self.model.output_offset
        if self.model.has_output_map:     # S^-1 comes after the inverse, in the law
            return r if off is None else r - off[:, None]
        return self.model.gamma_reference(r)

    def preview_state(self, reference, preview):
        """The inverse's state after the first ``preview`` samples of a (faded) reference.

        From rest at its first sample (the DC steady state there), the samples taken in the
        frame the inverse filters (:meth:`prefilter_reference`): :meth:`start`'s start-up, and
        :class:`hammerstein.compensation.drive.DriveStream`'s.

        Parameters
        ----------
        reference : numpy.ndarray, shape (p, n_samples)
            The faded reference, at least one sample [µm].
        preview : int
            P, the samples the inverse consumes before the first voltage.

        Returns
        -------
        numpy.ndarray, shape (n_filter_states,)
        """
        pre = self.prefilter_reference
        s0 = self.inverse.initial_state(pre(reference[:, :1])[:, 0])
        if preview:
            _, s0 = self.inverse.filter(pre(reference[:, :preview]), s0)
        return s0

    # -- the compensator protocol ----------------------------------------------------------
    def simulate(self, reference, initial_state=None):
        """Input voltages for a (lead) reference record.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            ``'zpetc'``: ``yr(t + P)`` [µm], the reference P samples ahead
            (see :meth:`start`); ``'stable'``: ``yr(t)``, a whole record.
        initial_state : array_like, shape (n_states,), optional
            Zeros by default; chunked runs equal one run (``'zpetc'``).

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            [V].
        final_state : numpy.ndarray, shape (n_states,)

        Raises
        ------
        CompensatorDivergence
            When the hysteresis compensator diverges.
        CompensatorError
            On a reference sample the exported C skips with status 4 (beyond
            :func:`~hammerstein.export.c_base.reference_bound`, a glitch): the
            message names the first one; nothing is run, so the caller's
            state stays valid (:func:`~hammerstein.compensation.reference_check.check_reference`).
        HysteresisError
            On a wrongly shaped reference or a non-finite sample (named).
        """
        if self.inverse is not None and not self.exact_static:   # the declared law, pre-filter included
            self._entered += 1
            try:
                reference = check_reference(self, reference)
                return simulate_compensator(self, reference, self.initial_state(initial_state))
            finally:
                self._entered -= 1
        r = check_reference(self, reference)
        cstate, fstate = self._split(self.initial_state(initial_state))
        v, fstate = self.inverse_dynamics(r, fstate)
        with reference_checked():       # V is the inverse's, not a reference to check
            u, cstate = self.hysteresis_compensator.simulate(v, cstate)
        return u, np.concatenate([cstate, fstate])

    @contextlib.contextmanager
    def previewed(self):
        """Declare that the references given inside already carry the preview and the fade-in.

        Outside :meth:`simulate`, :meth:`chain`, :func:`hammerstein.drive_signal`
        and :meth:`run_reference`, :meth:`packed_law` refuses (see there). Code
        that feeds the law itself, the reference of sample k + ``preview_samples``
        at call k, starting from rest (a real-time loop, the C export, a test
        of the fused kernels), runs it inside ``with compensator.previewed():``.

        Yields
        ------
        HammersteinCompensator
            This compensator.
        """
        self._entered += 1
        try:
            yield self
        finally:
            self._entered -= 1

    def packed_law(self):
        """The fused law: the ZPETC inverse as the kernel's linear reference pre-filter.

        Returns
        -------
        hammerstein.simulation.CompensatorLaw or None
            The hysteresis compensator's law with ``prefilter`` = the ZPETC
            state space (:meth:`ZPETCInverse.state_space`); None for
            ``'stable'`` (whole-record inverse, run by :meth:`chain`).

        Raises
        ------
        CompensatorError
            When asked outside :meth:`simulate` and :meth:`chain`, i.e. by
            ``simulate_chain(compensator, plant, reference)`` on a raw
            reference: without its preview and fade-in the inverse gives a
            spike of V and a delayed output. The message names the right call.
        """
        if not self._entered:
            raise CompensatorError(
                "simulate_chain(HammersteinCompensator, plant, reference) would run the inverse "
                "without its preview and fade-in; call compensator.run_reference(plant, reference, "
                "period_samples=..., fade_samples=...) or, for the voltages alone, "
                "hammerstein.drive_signal(compensator, reference, sampling_period, ...)")
        if self.inverse is None or self.exact_static:   # run by simulate (no fused law)
            return None
        if self._prefilter is None:      # the inverse is fixed at construction: built once
            self._prefilter = LinearArrays(*(np.ascontiguousarray(M, dtype=float)
                                             for M in self.inverse.state_space()))
        return self.hysteresis_compensator.packed_law()._replace(prefilter=self._prefilter)

    def chain(self, plant, reference, compensator_state=None, plant_state=None):
        """Reference (lead) -> G^-1 -> PI compensator -> plant, compiled.

        ``'zpetc'``: :func:`hammerstein.simulation.simulate_chain` runs the
        ZPETC inverse (the law's reference pre-filter, :meth:`packed_law`),
        the hysteresis compensator and the plant fused in one compiled loop.
        ``'stable'``: V is computed over the whole record first, then the
        hysteresis compensator and the plant run fused.

        Parameters
        ----------
        plant : HammersteinPlant
        reference : array_like, shape (p, n_samples)
            As for :meth:`simulate`.
        compensator_state, plant_state : array_like, optional
            Initial states; zeros by default.

        Returns
        -------
        ChainResult
            Divergence reported, not raised; chunked runs equal one run.
        """
        if self.inverse is not None:           # one compiled loop: pre-filter, law, plant
            self._entered += 1
            try:
                return simulate_chain(self, plant, reference,
                                      self.initial_state(compensator_state), plant_state)
            finally:
                self._entered -= 1
        r = self.model.check_inputs(reference, "reference")
        cstate, fstate = self._split(self.initial_state(compensator_state))
        v, fstate = self.inverse_dynamics(r, fstate)
        res = simulate_chain(self.hysteresis_compensator, plant, v, cstate, plant_state)
        if res.diverged:
            return res
        return ChainResult(res.inputs, res.outputs, np.concatenate([res.compensator_state, fstate]),
                           res.plant_state)

    def run_reference(self, plant, reference, period_samples=None, fade_samples=0):
        """A whole reference record on a plant at rest: :meth:`start` then :meth:`chain`.

        Parameters
        ----------
        plant : HammersteinPlant
        reference : array_like, shape (p, n_samples)
            ``yr(t)`` [µm].
        period_samples : int, optional
            Period of a periodic reference (its continuation past the end).
        fade_samples : int
            Fade-in length [samples].

        Returns
        -------
        ChainResult
            Outputs aligned with ``reference``.
        """
        lead, state, _ = self.start(reference, period_samples, fade_samples)
        return self.chain(plant, lead, state)

    def fused_run(self, reference, period_samples=None, fade_samples=0):
        """What :meth:`run_reference` feeds the compiled chain kernel, for a batch of records.

        :meth:`start` (fade-in, preview, inverse at rest), then for
        ``'zpetc'`` this compensator's law with the ZPETC pre-filter on the
        lead reference; for ``'stable'`` the hysteresis compensator's law on
        ``V = G^-1 Yr`` of the whole record, exactly as :meth:`chain` does.
        :func:`hammerstein.simulation.simulate_chain_batch` on the three
        values, with the plant at rest, gives the inputs and outputs of
        :meth:`run_reference`.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            ``yr(t)`` [µm].
        period_samples : int, optional
            Period of a periodic reference [samples].
        fade_samples : int
            Fade-in length [samples].

        Returns
        -------
        tuple or None
            ``(law, kernel_reference, state)``: a
            :class:`hammerstein.simulation.CompensatorLaw`, its reference
            (p, n_samples) [µm] and its initial flat state (``law.n_states``,);
            None when the static part is the exact Preisach inverse (no fused law).
        """
        if self.exact_static:
            return None
        lead, state, _ = self.start(reference, period_samples, fade_samples)
        if self.inverse is not None:
            with self.previewed():
                return self.packed_law(), lead, state
        cstate, fstate = self._split(state)
        v, _ = self.inverse_dynamics(self.model.check_inputs(lead, "reference"), fstate)
        return self.hysteresis_compensator.packed_law(), v, cstate

    def fused_runs(self, references, period_samples, fade_samples):
        """:meth:`fused_run` of several records, their start-up computed together.

        For ``'zpetc'`` the fade-in, continuation and preview of all records
        run as a few numpy calls on all of them (:meth:`_starts`) instead of
        ~20 calls a record: the start-up of a 200-frequency sweep's cases
        took ~90 us a case one by one. Each result equals :meth:`fused_run`
        on its record, bit for bit. ``'stable'`` and the exact Preisach
        static part run :meth:`fused_run` record by record.

        Parameters
        ----------
        references : sequence of array_like, each shape (p, n_samples_b)
            ``yr(t)`` [µm] of each record.
        period_samples : sequence of (int or None)
            Period of each record [samples] (None: not periodic).
        fade_samples : sequence of int
            Fade-in length of each record [samples].

        Returns
        -------
        list of (tuple or None)
            One :meth:`fused_run` result per record, in order.

        Raises
        ------
        ValueError
            When the three sequences differ in length.
        """
        references = list(references)
        period_samples, fade_samples = list(period_samples), list(fade_samples)
        if not len(references) == len(period_samples) == len(fade_samples):
            raise ValueError(f"references, period_samples, fade_samples: expected one of each "
                             f"per record, found {len(references)}, {len(period_samples)} and "
                             f"{len(fade_samples)}")
        if self.exact_static or self.inverse is None or not references:
            return [self.fused_run(r, per, f)
                    for r, per, f in zip(references, period_samples, fade_samples)]
        starts = self._starts(references, period_samples, fade_samples)
        with self.previewed():
            law = self.packed_law()
        return [(law, lead, state) for lead, state, _ in starts]
