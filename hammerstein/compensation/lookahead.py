"""The stable inversion of G sample by sample: a causal filter of a look-ahead reference.

:func:`hammerstein.compensation.inversion.preview_inverse` (``method='stable'``)
inverts G over a whole record: the inverse system's stable modes run forward
from rest, its unstable modes (G's zeros outside the unit circle) backward
from the record's end (Devasia, Chen & Paden [1]_). Unrolled, the backward
part at sample k is a sum over the reference ahead,

``v_u(k) = sum_{j >= 0} H_j yt(k + j)``, ``H_j = -C_u A_u^-(j+1) B_u``,

whose terms decay as ``|z_u|^-j`` (``z_u`` the slowest such zero). Truncated
after P terms, where ``|z_u|^-P`` falls below ``decay``, it is a finite
impulse response of the reference P samples ahead: what a real-time loop (the
exported C) can compute each sample from a buffer of the reference, given
``preview_samples = P + max(r_i)`` samples ahead (``r_i`` the relative
degrees: ``yt_i(k) = yr_i(k + r_i)``). Zou and Devasia [2]_ give the bound of
such a preview-based stable inversion.

References
----------
.. [1] S. Devasia, D. Chen and B. Paden, IEEE TAC 41(7), 930-942, 1996.
.. [2] Q. Zou and S. Devasia, J. Dyn. Sys., Meas., Control 121(4), 625-630, 1999.
"""

from __future__ import annotations

import math

import numpy as np

from hammerstein.compensation.drive_files import fade_weight
from hammerstein.compensation.inversion import (_dc_equilibrium, _discrete_square, _split,
                                                inverse_system)
from hammerstein.models.dynamics import DynamicsError
from hammerstein.simulation import linear_steps

__all__ = ["LookaheadInverse", "creep_rest_state", "rest_output", "preactuation_samples",
           "EXPORT_DECAY", "MAX_LOOKAHEAD", "FIRST_SAMPLE_TOLERANCE", "taper_preactuation"]

#: What the truncated anti-causal part is left with, relative to its first term: the
#: exported C then equals the whole-record inversion to about 1e-13 relative.
EXPORT_DECAY = 1e-14
#: The longest look-ahead [samples] built (a zero at |z| = 1.0016 needs 20000 for 1e-14);
#: the buffer and the taps grow with it, and so does the time of a step.
MAX_LOOKAHEAD = 20000


class LookaheadInverse:
    """Stable inversion of a square discrete G as a causal filter of the reference ahead.

    Parameters
    ----------
    system : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        Discrete p x p G (PI outputs [µm] -> displacements [µm]).
    decay : float
        Relative size of the first anti-causal term left out, in (0, 1).
    max_lookahead : int or None
        The longest truncation P allowed [samples]; None: no limit.

    Attributes
    ----------
    p : int
        Outputs.
    lookahead : int
        P, the anti-causal terms kept (0 when G has no zero outside the unit circle).
    preview_samples : int
        ``P + max(r_i)``: how far ahead the reference must be known [samples].
    relative_degree : numpy.ndarray, shape (p,), int
    taps : numpy.ndarray, shape (preview_samples + 1, p, p)
        ``M_d``: ``v(k) = C_s x_s(k) + sum_d M_d yr(k + d)``; the direct term ``Delta^-1``
        at ``d = r_i`` and ``H_{d - r_i}`` on column i.
    A_s, B_s, C_s : numpy.ndarray
        The stable modes, (n_s, n_s), (n_s, p), (p, n_s): ``x_s(k + 1) = A_s x_s(k) +
        B_s yt(k)``.
    anticausal_radius : float
        ``|z_u|`` of the slowest unstable mode of the inverse (0 when none).

    Raises
    ------
    DynamicsError
        G not discrete and square, not invertible (:func:`inverse_system`), or a
        look-ahead beyond ``max_lookahead`` (the message gives the zero and the length).

    Examples
    --------
    >>> from hammerstein import LookaheadInverse
    >>> import numpy as np, control
    >>> from hammerstein.compensation.inversion import preview_inverse
    >>> g = control.tf([1.0, -1.5], [1.0, -0.5, 0.06], 1e-4)
    >>> G = control.ss(control.append(control.ss(g / g.dcgain()), control.ss(g / g.dcgain())))
    >>> la = LookaheadInverse(G)
    >>> la.lookahead, la.preview_samples        # 1.5^-80 < 1e-14
    (80, 81)
    >>> yr = np.vstack([np.sin(np.arange(600) / 30.0), np.cos(np.arange(600) / 40.0)])
    >>> ahead = np.hstack([yr, np.repeat(yr[:, -1:], la.preview_samples, axis=1)])
    >>> v, _ = la.filter(ahead, la.initial_state(yr[:, 0]))
    >>> bool(np.max(np.abs(v - preview_inverse(G, yr))) < 1e-12)
    True
    """

    def __init__(self, system, decay=EXPORT_DECAY, max_lookahead=MAX_LOOKAHEAD):
        if not 0.0 < float(decay) < 1.0:
            raise DynamicsError(f"decay: expected a number in (0, 1), found {decay!r}")
        _, A, B, C, D = _discrete_square(system)
        self._G = (A, B, C, D)
        inv = inverse_system(system)
        p = D.shape[0]
        self.p = p
        rd = np.asarray(inv.relative_degree, dtype=int)
        self.relative_degree = rd
        As, Bs, Cs, Au, Bu, Cu, S = _split(inv.A, inv.B, inv.C, lambda z: abs(z) < 1)
        self.A_s, self.B_s, self.C_s, self._S = As, Bs, Cs, S
        nu = Au.shape[0]
        radius = float(np.min(np.abs(np.linalg.eigvals(Au)))) if nu else 0.0
        self.anticausal_radius = radius
        P = 0 if nu == 0 else int(math.ceil(math.log(1.0 / decay) / math.log(radius)))
        if max_lookahead is not None and P > max_lookahead:
            raise DynamicsError(
                f"dynamics: a zero of G at |z| = {radius:.6g}, outside the unit circle, decays "
                f"below {decay:g} only after {P} samples of look-ahead, beyond {max_lookahead}")
        self.lookahead = P
        L = P + int(rd.max())
        self.preview_samples = L
        taps = np.zeros((L + 1, p, p))
        H = np.zeros((P, p, p))
        if nu:
            Auinv = np.linalg.inv(Au)
            X = Auinv @ Bu
            for j in range(P):
                H[j] = -Cu @ X
                X = Auinv @ X
        for i in range(p):
            taps[rd[i], :, i] += inv.D[:, i]
            taps[rd[i]:rd[i] + P, :, i] += H[:, :, i]
        self.taps = taps

    def initial_state(self, reference=None):
        """The stable modes' state at rest, G at its DC equilibrium for ``reference``.

        Parameters
        ----------
        reference : array_like, shape (p,), optional
            The constant reference [µm]; zeros by default.

        Returns
        -------
        numpy.ndarray, shape (n_s,)
            As :func:`~hammerstein.compensation.inversion.preview_inverse` starts them.
        """
        ns = self.A_s.shape[0]
        if reference is None or ns == 0:
            return np.zeros(ns)
        x0 = _dc_equilibrium(*self._G, np.asarray(reference, dtype=float))
        return np.linalg.solve(self._S, x0)[:ns]

    def filter(self, reference, initial_state=None):
        """``v(k)`` for every k whose look-ahead the reference holds.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples + preview_samples)
            ``yr`` [µm], from the first sample to ``preview_samples`` past the last one wanted.
        initial_state : array_like, shape (n_s,), optional
            The stable modes' state at the first sample (:meth:`initial_state`); zeros by
            default.

        Returns
        -------
        v : numpy.ndarray, shape (p, n_samples)
            [µm].
        final_state : numpy.ndarray, shape (n_s,)

        Raises
        ------
        DynamicsError
            A reference of the wrong shape, too short for the look-ahead, or not finite.
        """
        r = np.atleast_2d(np.asarray(reference, dtype=float))
        L = self.preview_samples
        if r.shape[0] != self.p or r.shape[1] <= L or not np.all(np.isfinite(r)):
            raise DynamicsError(f"reference: expected a finite ({self.p}, n_samples + {L}) array "
                                f"[µm], found shape {r.shape}")
        N = r.shape[1] - L
        ns = self.A_s.shape[0]
        x = np.zeros(ns) if initial_state is None else np.asarray(initial_state, dtype=float)
        v = np.zeros((self.p, N))
        if ns:       # the stable modes first, forward from their state (compiled, in C's order)
            yt = np.vstack([r[i, k:k + N] for i, k in enumerate(self.relative_degree)])
            v, x = linear_steps(yt, (self.A_s, self.B_s, self.C_s, np.zeros((self.p, self.p))), x)
        # then the look-ahead's terms one by one, in the exported C's order: the terms cancel
        # (a zero near -1 alternates them), and the same order gives the same roundings
        for d in range(L + 1):
            for l in range(self.p):
                for i in range(self.p):
                    v[l] += self.taps[d, l, i] * r[i, d:d + N]
        return v, x


def rest_output(model, creep=None):
    """The static output of a hysteresis model at rest (0 V from its initial state) [µm].

    An identified model carries the records' output offset: 0 µm is not
    what the actuator shows at 0 V, and a reference faded in from 0 µm
    would start the drive at the voltage of 0 µm instead of at rest. With
    ``creep``, the output after the creep has settled at rest (each
    output times its creep's static gain, ``Creep.static_gain``, the model's
    ``output_offset`` added after it, as the plant adds it): the inverse
    of the dynamics with the creep starts in that steady state, so a
    reference faded in from it starts the drive at exactly 0 V.

    Parameters
    ----------
    model : object
        A hysteresis model with ``n_inputs`` and ``simulate(u)`` returning
        ``(outputs (p, n), state)``.
    creep : sequence of (Creep or None), length p, optional
        The plant's creep per output (``HammersteinPlant.creep``).

    Returns
    -------
    numpy.ndarray, shape (p,)
        [µm].

    Examples
    --------
    >>> from hammerstein.io.presets import load_plant
    >>> rest_output(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis)
    array([0., 0.])
    """
    y, _ = model.simulate(np.zeros((model.n_inputs, 1)))
    y = np.asarray(y, dtype=float)[:, 0]
    if creep is not None:    # the output offset is a sensor zero, after creep (as the plant has it)
        off = getattr(model, "output_offset", None)
        off = np.zeros_like(y) if off is None else np.asarray(off, dtype=float)
        y = (y - off) * np.array([1.0 if c is None else c.static_gain for c in creep]) + off
    return y



def creep_rest_state(matrices, system, reference):
    """The creep inverse's state at rest after the stable inversion of G, for a constant
    reference: its input ``G(1)^-1 reference`` held (the DC steady state).

    Parameters
    ----------
    matrices : tuple of numpy.ndarray
        ``(A, B, C, D)`` of the creep inverse
        (:func:`hammerstein.compensation.hammerstein_compensator.creep_inverse`).
    system : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        G (p x p).
    reference : array_like, shape (p,)
        [µm].

    Returns
    -------
    numpy.ndarray, shape (n,)
        ``(I - A)^-1 B G(1)^-1 reference``.
    """
    _, A, B, C, D = _discrete_square(system)
    v0 = np.linalg.solve(C @ np.linalg.solve(np.eye(A.shape[0]) - A, B) + D,
                         np.asarray(reference, dtype=float))
    Ac, Bc = (np.asarray(M, dtype=float) for M in matrices[:2])
    return np.linalg.solve(np.eye(Ac.shape[0]) - Ac, Bc @ v0)


#: The first sample's distance from rest [V] a hardware drive keeps below.
FIRST_SAMPLE_TOLERANCE = 1e-9


def preactuation_samples(compensator, inputs, rest, fade, n_samples):
    """Samples to add to a fade-in's rest lead so that a stable inversion's drive starts at
    rest, or 0.

    The stable inversion of G acts before the reference moves (its anti-causal part, G's
    zeros outside the unit circle), decaying backward in time as ``|z|^-k`` for the slowest
    such zero (Devasia, Chen & Paden, IEEE TAC 41(7), 1996): a first sample ``d`` from rest
    falls below a tenth of :data:`FIRST_SAMPLE_TOLERANCE` after
    ``ceil(ln(10 d / tol) / ln |z|)`` more samples at rest. At most up to a quarter of the
    record, fade included (the default fade's own cap: the rest is what is judged).

    Parameters
    ----------
    compensator : object
        The compensator; only a :class:`HammersteinCompensator` with ``'stable'`` counts.
    inputs : numpy.ndarray, shape (m, n_samples)
        Its drive with the plain fade-in [V].
    rest : numpy.ndarray, shape (m,) or None
        The rest voltages [V] (None: 0 V).
    fade : int
        That fade-in [samples].
    n_samples : int
        The record's length [samples].

    Returns
    -------
    int
        The samples to add (0 when the drive already starts within the tolerance).
    """
    lookahead = getattr(compensator, "stable_lookahead", None)
    if lookahead is None or getattr(compensator, "inverse", True) is not None:
        return 0
    r0 = np.zeros(inputs.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    off = float(np.max(np.abs(np.asarray(inputs, dtype=float)[:, 0] - r0)))
    if not off > FIRST_SAMPLE_TOLERANCE:
        return 0
    # a tenth of the tolerance: the decay is the slowest zero's, the hysteresis inverse's
    # slope at rest scales it (1.16e-9 V was left aiming at the tolerance itself)
    return int(max(0, min(lookahead(FIRST_SAMPLE_TOLERANCE / (10.0 * off)) + 1,
                          n_samples // 4 - fade)))


def taper_preactuation(inputs, rest, lead):
    """A drive whose first sample is away from rest, faded in from rest over its rest lead.

    A stable inversion's anti-causal part acts before the reference moves; from a zero
    of G near the unit circle it decays so slowly backward in time that the rest lead
    :func:`preactuation_samples` may add (at most up to a quarter of the record) does
    not hold it: the drive would start with a step (0.13 V on an outside XY stage with a
    zero at ``|z| = 1.0005``). Over the ``lead`` samples, in which the reference is held at
    rest, the departure from rest is weighted by
    :func:`~hammerstein.compensation.drive_files.fade_weight` (value, slope, acceleration
    and jerk continuous), so that the drive starts at rest and joins the inversion's own
    drive at the lead's end; what that costs is an output away from rest during the lead,
    before the reference moves, whose response has the rest of the fade-in to decay.

    Parameters
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        The drive [V].
    rest : numpy.ndarray, shape (m,) or None
        The rest voltages [V] (None: 0 V).
    lead : int
        The rest lead [samples].

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        The drive, unchanged (the same array) when its first sample is within
        :data:`FIRST_SAMPLE_TOLERANCE` of rest or there is no lead.
    off : float
        The first sample's largest distance from rest before the taper [V].

    Examples
    --------
    >>> import numpy as np
    >>> u, off = taper_preactuation(np.full((1, 6), 0.5), None, 4)
    >>> u.round(4).tolist(), off
    ([[0.0, 0.0353, 0.25, 0.4647, 0.5, 0.5]], 0.5)
    """
    u = np.asarray(inputs, dtype=float)
    r0 = np.zeros(u.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    off = float(np.max(np.abs(u[:, 0] - r0))) if u.shape[1] else 0.0
    lead = int(min(max(int(lead or 0), 0), u.shape[1]))
    if not off > FIRST_SAMPLE_TOLERANCE or lead == 0:
        return u, off
    u = u.copy()
    w = fade_weight(np.arange(lead) / lead)
    u[:, :lead] = r0[:, None] + w * (u[:, :lead] - r0[:, None])
    return u, off
