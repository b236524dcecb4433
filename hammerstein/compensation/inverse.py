"""Analytic inverse of a classical Prandtl-Ishlinskii operator (Kuhnen & Janocha).

The paper's "existing technique" (its ref. [20]; docs/per-axis-inverse.md) inverts each direct
transfer of the actuator separately. For a PI operator with ``r_1 = 0`` and
cumulative weight sums ``S_i = sum_{j<=i} w_j > 0`` the inverse is again a PI
operator with

``r'_i = sum_{j<=i} w_j (r_i - r_j)``, ``w'_1 = 1/w_1``,
``w'_i = -w_i / (S_i S_{i-1})``.

The preset's thresholds start at ``r_1 = 0.07 V > 0``. Play operators form a
semigroup, ``play_a o play_b = play_{a+b}`` ([2]_, Prop. 2.3.7; [3]_, Ch. II;
the discrete-time proof is in :func:`kuhnen_inverse`), so
``Gamma = Gamma~ o play_{r_1}`` with ``Gamma~`` the PI operator of thresholds
``r_i - r_1`` (first one 0), and ``Gamma^-1 = play_{r_1}^-1 o Gamma~^-1``.
The right inverse of a play operator is not a play operator: it is the
:class:`InversePlay` below (a relay added to its input).

References
----------
.. [1] K. Kuhnen and H. Janocha, "Inverse feedforward controller for complex
   hysteretic nonlinearities in smart-material systems", Control and
   Intelligent Systems 29(3), 2001 (paper ref. [20]).
.. [2] M. Brokate and J. Sprekels, *Hysteresis and Phase Transitions*,
   Springer, 1996, Section 2.3 (play operator, semigroup property).
.. [3] M. A. Krasnosel'skii and A. V. Pokrovskii, *Systems with Hysteresis*,
   Springer, 1989.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.models.hysteresis import (HysteresisError, PrandtlIshlinskii, _as_finite_array,
                                           play)
from hammerstein.simulation import simulate_inverse_play

__all__ = ["InversePlay", "InversePI", "kuhnen_inverse", "kuhnen_inverse_parameters",
           "MOTION_TOLERANCE", "FLOAT_MOTION_TOLERANCE"]

#: Slack [V] allowed when checking that an inverse-play state is consistent.
_STATE_TOL = 1e-9

#: Motion the inverse play of :func:`kuhnen_inverse` ignores, relative to the operator's
#: voltage scale (its largest threshold, or what the shifted inverse sums if larger):
#: 1e-12, some 100 times the rounding of the shifted inverse's weighted sum.
MOTION_TOLERANCE = 1e-12

#: The same for an export in single precision: 5e-8, about one of float's roundings of the
#: scale (with 1e-8 random models with 100 µm offsets still jumped 2 r_1 at a held rest
#: output, 5 of 16; with 2e-7 the float inverse lagged a sample at the reversals of a slow
#: random walk; with 1e-12, below float's resolution, 8 of 21 demagnetised starts of the
#: bundled preset jumped).
FLOAT_MOTION_TOLERANCE = 5e-8


@dataclass(frozen=True)
class InversePlay:
    """Right inverse of a play (backlash) operator of threshold r.

    A play output y rises only with ``u = y + r`` and falls only with
    ``u = y - r``; while y stays constant, u can be anywhere in
    ``[y - r, y + r]``. The inverse keeps the last offset:

    ``u(t) = y(t) + d(t)``, ``d(t) = r sgn(y(t) - y(t-T))`` when y moves,
    ``d(t) = d(t-T)`` otherwise,

    so that ``play_r(inverse(y)) = y`` for every y, starting from the
    consistent states: play state ``y(-T)`` and inverse state
    ``(y(-T), u(-T))`` with ``|u(-T) - y(-T)| <= r``. (Check: if
    ``y(t) > y(t-T)``, ``play_r(y + r)`` = ``max(y, min(y + 2r, y(t-T)))`` =
    ``y``; symmetrically when falling; when constant ``|d| <= r`` keeps the
    play where it was.) Stepped by a compiled kernel
    (:func:`~hammerstein.simulation.simulate_inverse_play`).

    Any motion of y, however small, moves u by up to 2r. A y computed as a
    weighted sum (the shifted inverse's output) can move by a rounding error
    while the reference holds, and u would then jump. With a tolerance
    ``e > 0`` the inverse follows ``a`` instead of y: ``a = y`` when y moved by
    more than e from the last ``a``, else ``a`` holds. The play operator of
    threshold r then outputs ``a``: y itself while y moves, within e of y
    while it holds.

    Parameters
    ----------
    threshold : float
        Threshold r of the play operator to invert [V], >= 0 (r = 0 gives
        the identity).
    tolerance : float
        Motion of y ignored, e [V], >= 0 (0: every motion counts).
        :func:`kuhnen_inverse` sets :data:`MOTION_TOLERANCE` times the
        operator's voltage scale when r > 0.

    Raises
    ------
    HysteresisError
        If the threshold or the tolerance is negative or not finite.
    """

    threshold: float
    tolerance: float = 0.0

    def __post_init__(self):
        for name in ("threshold", "tolerance"):
            v = float(_as_finite_array(getattr(self, name), name, ndim=0))
            if v < 0:
                raise HysteresisError(f"{name}: expected >= 0 [V], found {v:g}")
            object.__setattr__(self, name, v)

    n_states = 2

    def initial_state(self, initial_state=None):
        """Validated state ``[y(-T), u(-T)]`` [V] (zeros by default).

        Parameters
        ----------
        initial_state : array_like, shape (2,), optional
            Play output and input before the first sample [V].

        Returns
        -------
        numpy.ndarray, shape (2,)
            A new array.

        Raises
        ------
        HysteresisError
            If the shape is wrong or ``|u(-T) - y(-T)| > r`` (no play input
            can be that far from its output).
        """
        if initial_state is None:
            return np.zeros(2)
        s = _as_finite_array(initial_state, "initial_state")
        if s.shape != (2,):
            raise HysteresisError(f"initial_state: expected [y_prev, u_prev], found shape {s.shape}")
        if abs(s[1] - s[0]) > self.threshold + _STATE_TOL:
            raise HysteresisError(
                f"initial_state: |u_prev - y_prev| = {abs(s[1] - s[0]):.6g} V exceeds the "
                f"threshold {self.threshold:g} V; no play input is that far from its output")
        return s.astype(float, copy=True)

    def simulate(self, y, initial_state=None):
        """Input that makes the play operator produce ``y``.

        Parameters
        ----------
        y : array_like, shape (n_samples,)
            Desired play output [V].
        initial_state : array_like, shape (2,), optional
            ``[y(-T), u(-T)]`` [V]: the play operator's state before the
            first sample and the input that led to it; zeros by default.

        Returns
        -------
        u : numpy.ndarray, shape (n_samples,)
            Play input [V].
        final_state : numpy.ndarray, shape (2,)
            ``[y(N-1), u(N-1)]``, to continue a chunked run.

        Raises
        ------
        HysteresisError
            On a non-finite or non-1-D ``y`` or an inconsistent state.
        """
        y = _as_finite_array(y, "y", ndim=1)
        s = self.initial_state(initial_state)
        if y.size == 0:
            return y.copy(), s
        u, (a, d) = simulate_inverse_play(y, self.threshold, self.tolerance,
                                          np.array([s[0], s[1] - s[0]]))
        return u, np.array([a, u[-1]])


def kuhnen_inverse_parameters(thresholds, weights, name="component"):
    """Thresholds and weights of the inverse of a PI operator with r_1 = 0.

    ``r'_i = sum_{j<=i} w_j (r_i - r_j)``, ``w'_1 = 1/w_1``,
    ``w'_i = -w_i / (S_i S_{i-1})``, ``S_i = sum_{j<=i} w_j`` (docs/per-axis-inverse.md,
    paper ref. [20]).

    Parameters
    ----------
    thresholds : array_like, shape (n,)
        Thresholds r_i [V], ``r_1 = 0``, strictly increasing.
    weights : array_like, shape (n,)
        Weights w_i [µm/V].
    name : str
        Name of the operator, used in error messages.

    Returns
    -------
    thresholds : numpy.ndarray, shape (n,)
        r'_i [µm], ``r'_1 = 0``.
    weights : numpy.ndarray, shape (n,)
        w'_i [V/µm].

    Raises
    ------
    HysteresisError
        If ``r_1 != 0`` or some ``S_i <= 0`` (the operator is then not
        invertible: a branch is flat or falling); the message names the
        operator and i (1-based).
    """
    op = PrandtlIshlinskii(thresholds, weights)
    r, w = op.thresholds, op.weights
    if r[0] != 0:
        raise HysteresisError(
            f"{name}: thresholds: the closed-form inverse needs r_1 = 0, found {r[0]:g} "
            f"(use kuhnen_inverse, which splits off play_r1)")
    S = np.cumsum(w)
    bad = np.flatnonzero(S <= 0)
    if bad.size:
        i = int(bad[0])
        raise HysteresisError(
            f"{name}: weights: the cumulative weight sum S_{i + 1} = {S[i]:.6g} µm/V is <= 0; "
            f"the Kuhnen-Janocha inverse needs S_i > 0 for every i (docs/per-axis-inverse.md)")
    r_inv = np.array([np.sum(w[:i + 1] * (r[i] - r[:i + 1])) for i in range(r.size)])
    w_inv = np.empty_like(w)
    w_inv[0] = 1.0 / w[0]
    w_inv[1:] = -w[1:] / (S[1:] * S[:-1])
    return r_inv, w_inv


@dataclass(frozen=True)
class InversePI:
    """Inverse of a classical PI operator, ``play_{r_1}^-1 o Gamma~^-1``.

    Built by :func:`kuhnen_inverse`. The state is one flat vector: the play
    states of ``Gamma~^-1`` (n values [µm]) then the :class:`InversePlay`
    state ``[v(-T), u(-T)]`` [V].

    Parameters
    ----------
    shifted_inverse : PrandtlIshlinskii
        ``Gamma~^-1``, thresholds r'_i [µm], weights w'_i [V/µm].
    play_inverse : InversePlay
        ``play_{r_1}^-1``.
    operator : PrandtlIshlinskii
        The operator that is inverted.
    """

    shifted_inverse: PrandtlIshlinskii
    play_inverse: InversePlay
    operator: PrandtlIshlinskii

    @property
    def n_states(self) -> int:
        """Length of the flat state: n play states + 2."""
        return self.shifted_inverse.n_hysterons + 2

    def initial_state(self, initial_state=None):
        """Validated copy of a flat state (zeros by default: virgin state).

        Zeros match a PI operator starting from zero play states, the paper's
        convention: both start on their virgin (initial loading) curves, which
        are inverse to each other, so the composition is the identity from the
        first sample.

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            Play states of ``Gamma~^-1`` [µm] then ``[v(-T), u(-T)]`` [V].

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array.

        Raises
        ------
        HysteresisError
            On a wrong shape, non-finite values or an inconsistent
            inverse-play state.
        """
        if initial_state is None:
            return np.zeros(self.n_states)
        s = _as_finite_array(initial_state, "initial_state")
        if s.shape != (self.n_states,):
            raise HysteresisError(
                f"initial_state: expected {self.n_states} values, found shape {s.shape}")
        self.play_inverse.initial_state(s[-2:])
        return s.astype(float, copy=True)

    def consistent_state(self, operator_state, last_input):
        """Inverse state matching a given state of the inverted operator.

        With ``z_i`` the play states of ``Gamma`` (thresholds r_i), equal to
        those of ``Gamma~`` driven by ``play_{r_1}(u)``, the inverse's play
        states are ``q_i = S_i z_i + sum_{j>i} w_j z_j`` and the inverse-play
        state is ``[z_1, u(-T)]`` (``z_1 = play_{r_1}(u)``).

        Parameters
        ----------
        operator_state : array_like, shape (n,)
            Play states of the inverted operator [V].
        last_input : float
            Its last input u(-T) [V]; ``|u(-T) - z_1| <= r_1``.

        Returns
        -------
        numpy.ndarray, shape (n_states,)

        Raises
        ------
        HysteresisError
            On a wrong shape or an input inconsistent with the states.
        """
        z = _as_finite_array(operator_state, "operator_state", ndim=1)
        n = self.operator.n_hysterons
        if z.shape != (n,):
            raise HysteresisError(f"operator_state: expected shape ({n},), found {z.shape}")
        w = self.operator.weights
        tail = np.concatenate([np.cumsum((w * z)[::-1])[::-1][1:], [0.0]])  # sum_{j>i} w_j z_j
        q = np.cumsum(w) * z + tail
        play_state = self.play_inverse.initial_state([z[0], float(last_input)])
        return np.concatenate([q, play_state])

    def simulate(self, y, initial_state=None):
        """Input that makes the inverted operator produce ``y``.

        Parameters
        ----------
        y : array_like, shape (n_samples,)
            Desired output [µm].
        initial_state : array_like, shape (n_states,), optional
            Zeros by default (consistent with zero operator states).

        Returns
        -------
        u : numpy.ndarray, shape (n_samples,)
            Input [V].
        final_state : numpy.ndarray, shape (n_states,)
        """
        s = self.initial_state(initial_state)
        plays, q = play(y, self.shifted_inverse.thresholds, s[:-2])
        # v summed term by term in the C's order, the same for every sample: a matrix product
        # may round two equal columns 1 ulp apart, which the inverse play read as a motion of
        # a held output and answered by jumping 2 r_1 (2.4 V on a held reference)
        w = self.shifted_inverse.weights
        v = np.zeros(plays.shape[1])
        for j in range(w.size):
            v += w[j] * plays[j]
        u, p = self.play_inverse.simulate(v, s[-2:])
        return u, np.concatenate([q, p])


def kuhnen_inverse(pi: PrandtlIshlinskii, name="component", output_scale=0.0) -> InversePI:
    """Analytic inverse of a PI operator, exact also when r_1 > 0.

    Splits ``Gamma = Gamma~ o play_{r_1}`` (thresholds ``r_i - r_1``), inverts
    ``Gamma~`` in closed form (:func:`kuhnen_inverse_parameters`) and the play
    operator with :class:`InversePlay`.

    The split is exact in discrete time: with ``z = play_b(u)`` and
    ``y = play_a(z)`` from states with ``|y(-T) - z(-T)| <= a``, each step
    ``y(t) = clamp(y(t-T), z(t) - a, z(t) + a)`` equals
    ``clamp(y(t-T), u(t) - a - b, u(t) + a + b)``: if ``y(t-T)`` lies in the
    wider interval, z either stays or moves towards u by less than the gap,
    so y stays; if ``y(t-T) < u - a - b`` then ``z(t-T) <= y(t-T) + a <
    u - b`` forces ``z = u - b`` and ``y = u - a - b`` (symmetrically above),
    and ``|y - z| <= a`` holds again. Zero states qualify.

    With ``r_1 > 0`` the inverse play ignores motions of the shifted
    inverse's output up to :data:`MOTION_TOLERANCE` times the operator's
    voltage scale ``max(r_n, sum_i |w'_i| (r'_n + Y))``, Y the ``output_scale``
    (e.g. 1e-11 V for 10 V):
    a held reference then holds the voltage although the weighted sum rounds
    differently from the state it started from (after a demagnetising cycle
    the plays sit at their bands' edges, and a 1-ulp difference of the
    reference moved the voltage by up to r_1). The output stays within that
    tolerance times ``S_n`` of the reference.

    Parameters
    ----------
    pi : PrandtlIshlinskii
        Operator to invert, thresholds [V], weights [µm/V].
    name : str
        Name used in error messages (e.g. ``"Gamma_xx"``).
    output_scale : float
        The largest output magnitude the inverse will be given [µm] (an
        output offset included), when it exceeds the operator's own range:
        the weighted sum rounds in proportion to its terms (a 92 µm offset
        over thresholds of 1.4 V rounded by more than the operator's scale
        alone allowed, in float).

    Returns
    -------
    InversePI

    Raises
    ------
    HysteresisError
        If some cumulative weight sum ``S_i <= 0`` (names the operator and i).
    """
    if not isinstance(pi, PrandtlIshlinskii):
        raise HysteresisError(f"{name}: expected a PrandtlIshlinskii operator, found {type(pi).__name__}")
    r1 = float(pi.thresholds[0])
    r_inv, w_inv = kuhnen_inverse_parameters(pi.thresholds - r1, pi.weights, name)
    scale = max(float(pi.thresholds[-1]),
                float(np.sum(np.abs(w_inv)) * (r_inv[-1] + abs(float(output_scale)))))
    tolerance = MOTION_TOLERANCE * scale if r1 > 0 else 0.0
    return InversePI(PrandtlIshlinskii(r_inv, w_inv), InversePlay(r1, tolerance), pi)
