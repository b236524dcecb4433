"""Generalised plays and their derivatives in the envelope parameters (compiled kernel).

The generalised-PI fit (:mod:`hammerstein.identification.gpi_identification`)
adjusts seven normalised parameters ``theta = (b_l, a2_l, rho, b_r, a2_r, d,
q)`` per component; its variable-projection Jacobian needs the derivative of
every play output with respect to each of them. The play recursion

``s_j(t) = max(gamma_l(u_t) - r_j, min(gamma_r(u_t) + r_j, s_j(t - 1)))``,
``s_j(-1) = max(gamma_l(0) - r_j, min(gamma_r(0) + r_j, q A))``

is piecewise: on each sample a play either keeps its value or is set to one
of the two envelopes shifted by its threshold, so its derivative is carried
along the same branch (forward sensitivities; the kinks, where two branches
are equal, have measure zero). With ``gamma_l(u) = A tanh(b_l u / A + a2_l)``,
``gamma_r(u) = rho A tanh(b_r u / A + a2_r) + d A`` and ``r_j = S c_j``
(``S`` the half-span of the mean envelope, ``c_j`` the threshold fractions),

``d gamma_l = (u sech^2, A sech^2, 0, 0, 0, 0, 0)``,
``d gamma_r = (0, 0, A tanh, rho u sech^2, rho A sech^2, A, 0)``,
``d r_j = c_j dS``, ``d s_j(-1) / dq = A`` on the rest branch.

The play values are computed with the same expressions as
:func:`hammerstein.simulation.generalized_play_states` (bit for bit).
:func:`vp_jacobian` turns them into the Jacobian of the variable-projection
residual (Golub and Pereyra [1]_).

References
----------
.. [1] G. H. Golub and V. Pereyra, "Separable nonlinear least squares: the
   variable projection method and its applications", Inverse Problems 19(2),
   R1-R26, 2003.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numba import njit

from hammerstein.models.generalized_pi import envelope

__all__ = ["N_PARAMS", "envelope_gradient", "span_gradient", "play_sensitivities", "vp_jacobian"]

#: Parameters of a component: (b_l, a2_l, rho, b_r, a2_r, d, q).
N_PARAMS = 7


def envelope_gradient(theta, amplitude, u):
    """Derivatives of both envelopes in the normalised parameters at inputs ``u``.

    Parameters
    ----------
    theta : array_like, shape (7,)
        ``(b_l, a2_l, rho, b_r, a2_r, d, q)``
        (:func:`hammerstein.identification.gpi_identification.envelopes`).
    amplitude : float
        Input amplitude A [V].
    u : array_like, shape (n,)
        Inputs [V].

    Returns
    -------
    d_left, d_right : numpy.ndarray, shape (n, 7)
        ``d gamma_l(u) / d theta`` and ``d gamma_r(u) / d theta`` (module notes).
    """
    b_l, a2_l, rho, b_r, a2_r = (float(v) for v in np.asarray(theta, dtype=float)[:5])
    a = float(amplitude)
    u = np.atleast_1d(np.asarray(u, dtype=float))
    tl = np.tanh(b_l / a * u + a2_l)
    tr = np.tanh(b_r / a * u + a2_r)
    sl, sr = 1.0 - tl ** 2, 1.0 - tr ** 2
    dl = np.zeros((u.size, N_PARAMS))
    dr = np.zeros((u.size, N_PARAMS))
    dl[:, 0], dl[:, 1] = u * sl, a * sl
    dr[:, 2], dr[:, 3], dr[:, 4], dr[:, 5] = a * tr, rho * u * sr, rho * a * sr, a
    return dl, dr


def span_gradient(theta, amplitude, lo, hi):
    """``dS / d theta`` of the thresholds' scale ``S = max(0.5 (m(hi) - m(lo)), 1e-9)``.

    ``m = (gamma_l + gamma_r) / 2`` is the mean envelope
    (:func:`hammerstein.identification.gpi_identification.play_thresholds`).

    Parameters
    ----------
    theta : array_like, shape (7,)
        Normalised parameters.
    amplitude : float
        Input amplitude A [V].
    lo, hi : float
        Measured input range [V].

    Returns
    -------
    numpy.ndarray, shape (7,)
        The gradient; zeros where ``S`` is clamped at its floor.
    """
    b_l, a2_l, rho, b_r, a2_r, dd = (float(v) for v in np.asarray(theta, dtype=float)[:6])
    a = float(amplitude)
    gl = np.array([a, b_l / a, a2_l, 0.0])
    gr = np.array([rho * a, b_r / a, a2_r, dd * a])
    mid = lambda u: 0.5 * (envelope(gl, u) + envelope(gr, u))  # noqa: E731
    if 0.5 * float(mid(hi) - mid(lo)) <= 1e-9:
        return np.zeros(N_PARAMS)
    dl, dr = envelope_gradient(theta, amplitude, [lo, hi])
    return 0.25 * (dl[1] + dr[1] - dl[0] - dr[0])


@njit(cache=True, inline="always")
def _play_step(v, lo, hi, rj, cj, dlo, dhi, ds, d, j):
    """Play j's next state ``max(lo - r_j, min(hi + r_j, v))``; on a bound, its sensitivities
    ``d[j]`` become the bound's (the envelope's derivatives plus the threshold's, ``c_j ds``)."""
    if v > hi + rj:
        v = hi + rj
        for p in range(7):
            d[j, p] = dhi[p] + cj * ds[p]
    if v < lo - rj:
        v = lo - rj
        for p in range(7):
            d[j, p] = dlo[p] - cj * ds[p]
    return v


@njit(cache=True)
def _sensitivity_kernel(u, r, c, gl, gr, amp, rho, rest, ds, d_lo0, d_hi0, out, sens):
    n = r.size
    s = np.empty(n)
    d = np.zeros((n, 7))
    lo0 = gl[0] * np.tanh(gl[1] * 0.0 + gl[2]) + gl[3]
    hi0 = gr[0] * np.tanh(gr[1] * 0.0 + gr[2]) + gr[3]
    for j in range(n):              # the rest state: max(lo0 - r, min(hi0 + r, rest))
        v = rest
        for p in range(7):
            d[j, p] = 0.0
        d[j, 6] = amp
        s[j] = _play_step(v, lo0, hi0, r[j], c[j], d_lo0, d_hi0, ds, d, j)
    dlo = np.zeros(7)
    dhi = np.zeros(7)
    for t in range(u.size):
        x = u[t]
        tl = np.tanh(gl[1] * x + gl[2])
        th = np.tanh(gr[1] * x + gr[2])
        lo = gl[0] * tl + gl[3]
        hi = gr[0] * th + gr[3]
        sl = 1.0 - tl * tl
        sh = 1.0 - th * th
        dlo[0] = x * sl
        dlo[1] = amp * sl
        dhi[2] = amp * th
        dhi[3] = rho * x * sh
        dhi[4] = rho * amp * sh
        dhi[5] = amp
        for j in range(n):
            v = _play_step(s[j], lo, hi, r[j], c[j], dlo, dhi, ds, d, j)
            s[j] = v
            out[t, j] = v
            for p in range(7):
                sens[t, j, p] = d[j, p]


def play_sensitivities(u, thresholds, fractions, theta, amplitude, d_span, prefix=()):
    """Play trajectories from the rest state and their derivatives in the parameters.

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    thresholds : numpy.ndarray, shape (n,)
        ``r_j = S c_j`` [V].
    fractions : numpy.ndarray, shape (n,)
        ``c_j``.
    theta : array_like, shape (7,)
        Normalised parameters ``(b_l, a2_l, rho, b_r, a2_r, d, q)``.
    amplitude : float
        Input amplitude A [V].
    d_span : numpy.ndarray, shape (7,)
        ``dS / d theta``, the derivative of the thresholds' scale.
    prefix : array_like, shape (n_prefix,)
        Input [V] played from the rest state before ``u`` (the turning points of
        the demagnetising cycle,
        :func:`hammerstein.models.demagnetisation.demagnetising_turning_points`);
        none by default.

    Returns
    -------
    states : numpy.ndarray, shape (n_samples, n)
        Play outputs after each sample (as
        :func:`hammerstein.simulation.generalized_play_states` from the rest
        state ``max(gamma_l(0) - r, min(gamma_r(0) + r, q A))`` driven through
        ``prefix``).
    sens : numpy.ndarray, shape (n_samples, n, 7)
        ``d states / d theta`` (module notes).
    """
    theta = np.asarray(theta, dtype=float)
    a = float(amplitude)
    b_l, a2_l, rho, b_r, a2_r, dd, q = (float(v) for v in theta[:7])
    gl = np.array([a, b_l / a, a2_l, 0.0])
    gr = np.array([rho * a, b_r / a, a2_r, dd * a])
    d_lo0, d_hi0 = envelope_gradient(theta, a, [0.0])
    pre = np.asarray(prefix, dtype=float).reshape(-1)
    u = np.ascontiguousarray(np.concatenate([pre, np.asarray(u, dtype=float)]))
    r = np.ascontiguousarray(thresholds, dtype=float)
    out = np.empty((u.size, r.size))
    sens = np.empty((u.size, r.size, N_PARAMS))
    _sensitivity_kernel(u, r, np.ascontiguousarray(fractions, dtype=float), gl, gr, a, rho,
                        q * a, np.ascontiguousarray(d_span, dtype=float), d_lo0[0], d_hi0[0],
                        out, sens)
    return out[pre.size:], sens[pre.size:]


def vp_jacobian(A, x, r, lower, col, Dx, DTr):
    """Jacobian of the variable-projection residual ``r = A x(theta) - y``.

    The weights ``x(theta)`` minimise ``||A(theta) x - y||`` subject to
    ``x >= lower``; those at their bound are held there (the active set), on
    the others (columns ``A_F``) the normal equations ``A_F^T r = 0`` hold, so
    ([1]_, eq. (2.4), with the active weights constants)

    ``dr / d theta_i = P (D_i x) - A_F (A_F^T A_F)^-1 D_{i,F}^T r``,

    ``D_i = dA / d theta_i`` and ``P = I - A_F A_F^+``, computed from a thin QR
    factorisation of the column-scaled ``A_F`` (an SVD on its numerical range
    when its columns are nearly dependent).

    Parameters
    ----------
    A : numpy.ndarray, shape (N, n)
        Regression matrix at theta.
    x : numpy.ndarray, shape (n,)
        The bounded least-squares weights.
    r : numpy.ndarray, shape (N,)
        ``A x - y``.
    lower : numpy.ndarray, shape (n,)
        Lower bounds of the weights (``-inf``: free).
    col : numpy.ndarray, shape (n,)
        Positive column scales of ``A`` (e.g. the column norms).
    Dx : numpy.ndarray, shape (N, P)
        ``D_i x`` per parameter i.
    DTr : numpy.ndarray, shape (n, P)
        ``D_i^T r`` per parameter i.

    Returns
    -------
    numpy.ndarray, shape (N, P)
        ``dr / d theta``.
    """
    at_bound = np.isfinite(lower) & ((x - lower) * col
                                     <= 1e-12 * max(np.linalg.norm(x * col), 1e-300))
    F = ~at_bound
    AF, DF = A[:, F] / col[F], DTr[F] / col[F, None]
    Q, RF = np.linalg.qr(AF)
    diag = np.abs(np.diag(RF))
    if diag.size and diag.min() > 1e-10 * diag.max():
        back = Q @ scipy.linalg.solve_triangular(RF, DF, trans="T")
    else:       # (nearly) dependent columns: the pseudo-inverse on their range
        U, sv, Vt = np.linalg.svd(AF, full_matrices=False)
        keep = sv > 1e-12 * sv[0] if sv.size else sv > 0
        Q = U[:, keep]
        back = Q @ ((Vt[keep] @ DF) / sv[keep, None])
    return Dx - Q @ (Q.T @ Dx) - back
