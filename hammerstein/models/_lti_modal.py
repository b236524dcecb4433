"""The modal realisation of an identified G (behind :mod:`hammerstein.models.lti`).

The subspace step (:mod:`hammerstein.models._lti_subspace`) returns A and C
in the basis its SVD happened to give; the identified dynamics are written
in real modal form instead, one 1 x 1 block per real pole and one 2 x 2
block per complex pair, with each mode's basis fixed by its output shape
(:func:`canonical_mode`), so that the same G is written with the same
numbers. :func:`keep_modes` and :func:`mode_shares` serve the removal of
near-cancelled modes (Verhaegen and Verdult 2007, modal reduction).
"""

from __future__ import annotations

import numpy as np

__all__ = ["canonical_mode", "real_modal", "keep_modes", "mode_shares"]


def canonical_mode(v, C):
    """Eigenvector ``v`` (n,) times the complex number that fixes the mode's state basis.

    An eigenvector is defined up to a complex factor: LAPACK returns it of
    unit norm in the state basis at hand, with its largest component real,
    a choice that flips with the last digits when two components are nearly
    equal, so that the modal realisation's B and C changed sign or rotated
    between identifications of the same G. Here the factor is fixed by the
    mode's output shape ``u = C v``, which a change of state basis leaves
    as it is (``v`` itself when C does not see the mode): ``u`` as real as
    possible (``sum u_j^2`` real and positive, the maximally real mode
    shape), of unit norm, and signed by ``sum_j Re(u_j) |Re(u_j)| > 0``; all
    continuous in ``v``, so the basis changes only where those sums vanish.
    A and the transfer function do not depend on the choice.
    """
    u = C @ v
    if not np.linalg.norm(u) > 1e-12 * np.linalg.norm(C) * np.linalg.norm(v):
        u = v
    s = np.sum(u * u)
    if abs(s) > 0:
        phase = np.exp(-0.5j * np.angle(s))
        v, u = v * phase, u * phase
    scale = 1.0 / np.linalg.norm(u)
    v, u = v * scale, u * scale
    return -v if np.sum(u.real * np.abs(u.real)) < 0 else v


def real_modal(A, C, T):
    """Real modal form: ``(A_m, C_m, mode_of_state, frequency_hz, damping)`` or None.

    One 1 x 1 block per real pole, one 2 x 2 block ``[[sigma, omega], [-omega,
    sigma]]`` per complex pair; None when the eigenvectors are ill-conditioned.
    Natural frequency ``|s| / 2 pi`` [Hz] and damping ``-Re s / |s|`` of
    each mode from ``s = ln(z) / T``.
    """
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        return None
    cols, mode_of, poles = [], [], []
    for i in np.argsort(np.abs(lam)):
        if lam[i].imag < -1e-12:
            continue
        v = canonical_mode(V[:, i].astype(complex), C)
        if lam[i].imag > 1e-12:
            cols += [v.real, v.imag]
            mode_of += [len(poles)] * 2
        else:
            cols.append(v.real)
            mode_of.append(len(poles))
        poles.append(lam[i])
    Tm = np.column_stack(cols)
    if Tm.shape != A.shape or np.linalg.cond(Tm) > 1e10:
        return None
    Am = np.linalg.solve(Tm, A @ Tm)
    s = np.log(np.asarray(poles, dtype=complex)) / T
    wn = np.abs(s)
    zeta = np.where(wn > 0, -s.real / np.where(wn > 0, wn, 1), 1.0)
    return Am, C @ Tm, np.asarray(mode_of), wn / (2 * np.pi), zeta


def keep_modes(A, C, mode_of, freq, zeta, keep):
    idx = np.flatnonzero(np.isin(mode_of, keep))
    renum = {int(old): new for new, old in enumerate(keep)}
    return (A[np.ix_(idx, idx)], C[:, idx], np.array([renum[int(m)] for m in mode_of[idx]], int),
            freq[keep], zeta[keep])


def mode_shares(A, B, C, D, mode_of, band, T):
    """Largest gain of each mode's term in the band over the largest gain of G there."""
    f = np.logspace(np.log10(max(band[0], 1e-3)), np.log10(min(band[1], 0.49 / T)), 200)
    z = np.exp(2j * np.pi * f * T)
    n_modes = int(mode_of.max()) + 1 if mode_of.size else 0
    total = np.zeros(f.size)
    share = np.zeros(n_modes)
    terms = []
    for i in range(n_modes):      # (z I - A_i)^-1 B_i at every z: one stacked solve
        idx = np.flatnonzero(mode_of == i)
        Ai, Bi, Ci = A[np.ix_(idx, idx)], B[idx], C[:, idx]
        G = Ci @ np.linalg.solve(z[:, None, None] * np.eye(idx.size) - Ai, Bi)
        terms.append(np.linalg.norm(G, 2, axis=(1, 2)))
    Gall = C @ np.linalg.solve(z[:, None, None] * np.eye(A.shape[0]) - A, B) + D
    total = np.linalg.norm(Gall, 2, axis=(1, 2))
    for i, g in enumerate(terms):
        share[i] = g.max() / max(total.max(), 1e-300)
    return share
