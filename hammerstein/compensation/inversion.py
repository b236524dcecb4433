"""Stable inversion of the discrete linear part G of the Hammerstein actuator.

Given references ``Yr`` (p, N) [µm], these functions return the desired PI
outputs ``V`` (p, N) [µm] such that ``G V ~ Yr``; an inverse of the PI
(e.g. :class:`hammerstein.compensation.compensators.InverseMultiplicativeCompensator`
fed with V) then turns V into voltages.

A ZOH-sampled actuator G has relative degree >= 1 (a one-sample delay at
least) and sampling zeros near z = -1 (one per continuous relative degree
above one; for a second-order bending mode sampled at 65 times its natural
frequency the zero is at z ~ -0.97); an identified or coupled G may also have
zeros outside the unit circle. Exact inversion would put those zeros into the
poles of the inverse: lightly damped at the Nyquist frequency or unstable.

Two variants:

* :class:`ZPETCInverse` -- causal, sample by sample, with a fixed preview of
  ``preview_samples`` samples (Tomizuka's zero-phase-error tracking
  controller, generalised to square MIMO systems);
* :func:`preview_inverse` -- whole record known in advance: exact stable
  inversion (causal stable part forward, anti-causal unstable part
  backward; Devasia, Chen & Paden), the ZPETC aligned on the record, or the
  exact periodic inverse by FFT.

MIMO inverse system (both variants). Let output i have relative degree
``r_i`` (first non-zero row of ``D, CB, CAB, ...``), decoupling matrix
``Delta`` (row i: ``C_i A^(r_i - 1) B``, or ``D_i`` when ``r_i = 0``) and
``Phi`` (row i: ``C_i A^(r_i)``). With the advanced reference
``yt_i(k) = yr_i(k + r_i)``, the exact inverse of ``(A, B, C, D)`` is

``x(k+1) = A_z x(k) + B Delta^-1 yt(k)``, ``v(k) = -Delta^-1 Phi x(k) + Delta^-1 yt(k)``,
``A_z = A - B Delta^-1 Phi``,

whose poles are the invariant zeros of G (plus ``sum r_i`` poles at 0). This
needs ``Delta`` invertible (true for the actuators considered: every PI
output acts on its own displacement within ``r_i`` samples); no
Smith-McMillan form or polynomial matrix is formed, which keeps the
computation well conditioned for identified models.

References
----------
.. [1] M. Tomizuka, "Zero phase error tracking algorithm for digital
   control", J. Dyn. Sys., Meas., Control 109(1), 65-68, 1987.
.. [2] S. Devasia, D. Chen and B. Paden, "Nonlinear inversion-based output
   tracking", IEEE Trans. Automatic Control 41(7), 930-942, 1996.
.. [3] Q. Zou and S. Devasia, "Preview-based stable-inversion for output
   tracking of linear systems", J. Dyn. Sys., Meas., Control 121(4),
   625-630, 1999.
.. [4] K. J. Astrom, P. Hagander and J. Sternby, "Zeros of sampled systems",
   Automatica 20(1), 31-38, 1984 (sampling zeros).
.. [5] L. M. Silverman, "Inversion of multivariable linear systems", IEEE
   Trans. Automatic Control 14(3), 270-276, 1969 (state-space inverse).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from hammerstein.core.lazy import lazy_module
from hammerstein.models.dynamics import DynamicsError, SampledSystem
from hammerstein.simulation._preisach import linear_steps

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

#: entries of the acceptable-mode filter's real Schur form below this are numerical zeros
SCHUR_ZERO = 1e-13

__all__ = ["InverseSystem", "inverse_system", "ZPETCInverse", "preview_inverse"]


class InverseSystem:
    """Exact state-space inverse of a square discrete system (see module docstring).

    Parameters
    ----------
    relative_degree : numpy.ndarray, shape (p,), int
        ``r_i`` per output.
    A, B, C, D : numpy.ndarray
        ``A_z`` (n, n), ``B Delta^-1`` (n, p), ``-Delta^-1 Phi`` (p, n),
        ``Delta^-1`` (p, p): from the advanced reference ``yt`` to v.

    Attributes
    ----------
    zeros : numpy.ndarray, shape (n,), complex
        Eigenvalues of ``A_z``: the invariant zeros of G and ``sum r_i`` zeros.
    """

    def __init__(self, A, B, C, D, relative_degree):
        self.A, self.B, self.C, self.D = A, B, C, D
        self.relative_degree = relative_degree
        self.zeros = np.linalg.eigvals(A) if A.size else np.zeros(0, dtype=complex)


def _discrete_square(system):
    # a SampledSystem (the plants' own dynamics) is taken as it is: python-control and
    # scipy.signal (~1 s of imports) are not needed to invert it
    if not isinstance(system, SampledSystem):
        if isinstance(system, control.TransferFunction):
            system = control.ss(system)
        if not isinstance(system, control.StateSpace):
            raise DynamicsError(f"dynamics: expected a control.StateSpace or a SampledSystem, "
                                f"found {type(system).__name__}")
    if not system.isdtime(strict=True):
        raise DynamicsError("dynamics: expected a discrete-time system (dt > 0); "
                            "discretise it first (hammerstein.models.dynamics.discretize)")
    if system.ninputs != system.noutputs:
        raise DynamicsError(f"dynamics: expected a square system, found {system.noutputs} outputs "
                            f"and {system.ninputs} inputs")
    A, B, C, D = (np.asarray(M, dtype=float) for M in (system.A, system.B, system.C, system.D))
    for key, M in zip("ABCD", (A, B, C, D)):
        if not np.all(np.isfinite(M)):
            raise DynamicsError(f"dynamics.{key}: expected finite values")
    return system, A, B, C, D


def inverse_system(system, tol=1e-9):
    """Exact state-space inverse of a square discrete system with invertible decoupling.

    Parameters
    ----------
    system : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        Discrete p x p system G (PI outputs [µm] -> displacements [µm]).
    tol : float
        A Markov-parameter row counts as zero below ``tol`` times the largest
        norm of the first n + 1 Markov parameters.

    Returns
    -------
    InverseSystem

    Raises
    ------
    DynamicsError
        If G is not discrete and square, an output is not reached by any
        input (infinite relative degree), or the decoupling matrix is
        singular (the system needs a dynamic, not a static, decoupling).
    """
    system, A, B, C, D = _discrete_square(system)
    n, p = A.shape[0], D.shape[0]
    markov = [D]
    Ak = np.eye(n)
    for _ in range(n):
        markov.append(C @ Ak @ B)
        Ak = Ak @ A
    scale = max(np.linalg.norm(M) for M in markov)
    if scale == 0:
        raise DynamicsError("dynamics: the system has zero gain (all Markov parameters are 0)")
    r = np.full(p, -1)
    for i in range(p):
        for k, M in enumerate(markov):
            if np.linalg.norm(M[i]) > tol * scale:
                r[i] = k
                break
        if r[i] < 0:
            raise DynamicsError(f"dynamics: output {i} is not reached by any input "
                                "(infinite relative degree)")
    Delta = np.vstack([markov[r[i]][i] for i in range(p)])
    Phi = np.vstack([C[i] @ np.linalg.matrix_power(A, int(r[i])) for i in range(p)])
    if np.linalg.cond(Delta) > 1e12:
        raise DynamicsError(f"dynamics: singular decoupling matrix (relative degrees {r.tolist()}, "
                            f"cond {np.linalg.cond(Delta):.3g}); the inverse needs a dynamic "
                            "decoupling that is not implemented")
    Dinv = np.linalg.inv(Delta)
    return InverseSystem(A - B @ Dinv @ Phi, B @ Dinv, -Dinv @ Phi, Dinv, r)


def _split(A, B, C, good):
    """Block-diagonalise A into good (first) and bad modes: Schur + Sylvester.

    Returns (Ag, Bg, Cg, Ab, Bb, Cb, S) with ``x = S [x_g; x_b]``.
    """
    n = A.shape[0]
    if n == 0:
        z = np.zeros((0, 0))
        return z, np.zeros((0, B.shape[1])), np.zeros((C.shape[0], 0)), z, \
            np.zeros((0, B.shape[1])), np.zeros((C.shape[0], 0)), z
    T, Z, sdim = scipy.linalg.schur(A, output="real", sort=lambda x, y: bool(good(complex(x, y))))
    T11, T12, T22 = T[:sdim, :sdim], T[:sdim, sdim:], T[sdim:, sdim:]
    X = scipy.linalg.solve_sylvester(T11, -T22, -T12) if 0 < sdim < n else np.zeros((sdim, n - sdim))
    S = Z @ np.block([[np.eye(sdim), X], [np.zeros((n - sdim, sdim)), np.eye(n - sdim)]])
    Sinv = np.linalg.inv(S)
    Bt, Ct = Sinv @ B, C @ S
    return T11, Bt[:sdim], Ct[:, :sdim], T22, Bt[sdim:], Ct[:, sdim:], S


def _check_reference(reference, p, name="reference"):
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    if r.ndim != 2 or r.shape[0] != p or not np.all(np.isfinite(r)):
        raise DynamicsError(f"{name}: expected a finite ({p}, n_samples) array [µm], "
                            f"found shape {np.shape(reference)}")
    return r


def _is_diagonal(A, B, C, D, tol):
    """True when every off-diagonal Markov parameter (D, CB, ..., C A^(2n) B) is negligible."""
    n, p = A.shape[0], D.shape[0]
    markov = [D]
    Ak = np.eye(n)
    for _ in range(2 * n + 1):
        markov.append(C @ Ak @ B)
        Ak = Ak @ A
    M = np.array(markov)
    off = M * (1 - np.eye(p))[None]
    return bool(np.max(np.abs(off)) <= tol * max(np.max(np.abs(M)), 1e-300))


def _minimal(system, tol=1e-9):
    """Controllable then observable part (orthonormal Krylov bases by SVD).

    Used on the diagonal channels of a decoupled system, whose other modes
    are uncontrollable or unobservable (python-control's ``minreal`` needs
    slycot).
    """
    A, B, C, D = (np.asarray(M, dtype=float) for M in (system.A, system.B, system.C, system.D))
    n = A.shape[0]

    def basis(K):
        U, s, _ = np.linalg.svd(K, full_matrices=False)
        return U[:, :int(np.sum(s > tol * s[0]))] if s.size and s[0] > 0 else U[:, :0]

    K = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(n)])
    Uc = basis(K)
    A1, B1, C1 = Uc.T @ A @ Uc, Uc.T @ B, C @ Uc
    n1 = A1.shape[0]
    O = np.vstack([C1 @ np.linalg.matrix_power(A1, k) for k in range(n1)])
    Vo = basis(O.T)
    n2 = Vo.shape[1]
    return SampledSystem(Vo.T @ A1 @ Vo, Vo.T @ B1, C1 @ Vo, D, system.dt,
                         [f"u[{j}]" for j in range(D.shape[1])],
                         [f"y[{i}]" for i in range(D.shape[0])],
                         [f"x[{k}]" for k in range(n2)], "minimal")


def _zpetc_design(system, good, tol):
    """FIR taps and acceptable-mode filter of the MIMO ZPETC (see ZPETCInverse)."""
    inv = inverse_system(system, tol)
    p = inv.D.shape[0]
    Ag, Bg, Cg, Ab, Bb, Cb, _ = _split(inv.A, inv.B, inv.C, good)
    # the real Schur form (orthonormal basis) leaves the inverse's poles at z = 0 (one per
    # unit of relative degree) as entries of ~1e-16 instead of 0: snapped to 0, such a
    # state is a delay, which the kernels' pre-filter reads from the reference instead
    # of stepping it (what it changes is below the rounding of the other terms)
    Ag = np.where(np.abs(Ag) <= SCHUR_ZERO, 0.0, Ag)
    nb = Ab.shape[0]
    c = np.real(np.poly(Ab))[::-1] if nb else np.ones(1)        # ascending, c[nb] = 1
    b1 = float(np.sum(c))
    s = np.correlate(c, c, mode="full") / b1 ** 2                  # s_l, l = -nb..nb (symmetric)
    # adj(zI - A_b) = sum_i z^i E_i, E_i = sum_{j>i} c_j A_b^(j-i-1)  (Cayley-Hamilton)
    powers = [np.eye(nb)]
    for _ in range(nb):
        powers.append(powers[-1] @ Ab)
    E = [sum(c[j] * powers[j - i - 1] for j in range(i + 1, nb + 1)) for i in range(nb)]
    rmax = int(np.max(inv.relative_degree))
    L = rmax + 2 * nb + 1                                           # reference window
    taps_v = np.zeros((L, p, p))
    taps_w = np.zeros((L, p, p))
    for ch in range(p):
        shift = rmax - int(inv.relative_degree[ch])
        for li, l in enumerate(range(-nb, nb + 1)):
            lag = shift + nb - l            # v(t - P) needs yr_ch(t - lag), P = rmax + nb
            taps_v[lag][:, ch] += inv.D[:, ch] * s[li]
            taps_w[lag][ch, ch] += s[li]
        for i in range(nb):                                         # C_b E_i B_b c_j z^(i-j)
            M = Cb @ E[i] @ Bb
            for j in range(nb + 1):
                taps_v[shift + nb - (i - j)][:, ch] += M[:, ch] * c[j] / b1 ** 2
    bad = np.linalg.eigvals(Ab) if nb else np.zeros(0, dtype=complex)
    return {"P": rmax + nb, "taps_v": taps_v, "taps_w": taps_w, "Ag": Ag, "Bg": Bg, "Cg": Cg,
            "r": inv.relative_degree, "bad": bad}


class ZPETCInverse:
    """Causal MIMO zero-phase-error tracking inverse with a fixed preview.

    Tomizuka's ZPETC [1] inverts the acceptable zeros of G exactly and
    replaces each unacceptable zero factor ``(z - beta)`` of G -- zeros
    outside the unit circle and sampling zeros near z = -1 -- by the
    zero-phase approximation ``1/(z - beta) ~ (z^-1 - beta) / (1 - beta)^2``,
    so that ``G F = |b(e^jw)|^2 / b(1)^2 I`` with ``b(z) = prod (z - beta)``:
    no phase error, unit DC gain, a gain error that grows towards Nyquist
    (``2 beta (1 - cos wT) / (1 - beta)^2``, 0.2 % at 300 Hz for beta = -0.97
    and T = 50 µs).

    MIMO generalisation: the exact inverse H of G (state-space inverse of
    the module docstring, poles = zeros of G) is block-diagonalised by an
    ordered real Schur form and a Sylvester equation into acceptable modes
    ``(A_g, B_g, C_g)`` and unacceptable modes ``(A_b, B_b, C_b)`` with
    characteristic polynomial b(z). Since ``b(z) (zI - A_b)^-1 = adj(zI - A_b)``
    is a polynomial (Cayley-Hamilton), ``H b`` has no unacceptable pole, and

    ``F(z) = H(z) b(z) b(1/z) / b(1)^2
    = (D_z + C_g (zI - A_g)^-1 B_g) S(z) / b(1)^2 + C_b adj(zI - A_b) B_b b(1/z) / b(1)^2``

    with the symmetric ``S(z) = b(z) b(1/z)``. F is a FIR part over the
    reference window plus a stable IIR part (the acceptable modes) driven by
    the S-filtered reference; for a diagonal G it reduces to per-channel
    ZPETC. F needs ``r_max + n_bad`` samples of future reference:
    ``preview_samples`` (the relative degree, 1 for a ZOH-sampled
    actuator, plus the number of unacceptable zeros, 1 per bending mode).

    A zero is unacceptable when ``|z| >= unstable_radius`` or when
    ``Re z < 0`` and ``|z| >= nyquist_radius`` (an oscillation above a
    quarter of the sampling frequency, i.e. a sampling zero).

    Parameters
    ----------
    system : control.StateSpace or hammerstein.models.dynamics.SampledSystem
        Discrete p x p system G (``dt`` = T); a ``SampledSystem`` (a plant's own
        dynamics) is inverted without importing python-control.
    nyquist_radius : float
        Radius beyond which a zero in the left half of the z-plane is
        unacceptable, in (0, 1].
    unstable_radius : float
        Radius beyond which any zero is unacceptable (default 1: the unstable
        zeros). Slightly below 1 also treats lightly damped zeros so.
    tol : float
        Relative tolerance of the relative-degree detection
        (:func:`inverse_system`).

    Attributes
    ----------
    preview_samples : int
        P: the filter's output is ``v(t - P)`` when fed ``yr(t)``; feed it
        the reference P samples ahead to get ``v(t)`` on time.
    relative_degree : numpy.ndarray, shape (p,)
    unacceptable_zeros : numpy.ndarray, complex
        The zeros of G approximated by zero-phase factors.
    n_states : int
        Length of the flat filter state: the ``window - 1`` past reference
        samples (p each) then the acceptable-mode state.

    Raises
    ------
    DynamicsError
        See :func:`inverse_system`.

    References
    ----------
    .. [1] M. Tomizuka, J. Dyn. Sys., Meas., Control 109(1), 65-68, 1987.
    .. [2] S. Devasia, D. Chen and B. Paden, IEEE TAC 41(7), 930-942, 1996.

    Examples
    --------
    >>> from hammerstein import ZPETCInverse
    >>> import numpy as np, control
    >>> from hammerstein.models.dynamics import bending_modes, discretize
    >>> G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2]), 5e-5)
    >>> inv = ZPETCInverse(G)
    >>> inv.preview_samples
    2
    >>> t = np.arange(2000) * 5e-5
    >>> yr = np.vstack([np.sin(2 * np.pi * 100 * t), np.cos(2 * np.pi * 100 * t)])
    >>> v = inv.apply(yr)
    >>> y = control.forced_response(G, U=v, X0=inv.plant_state(yr[:, 0])).outputs
    >>> bool(np.max(np.abs(y - yr)[:, 1000:-2]) < 1e-3)   # after start-up, before the held end
    True
    """

    def __init__(self, system, nyquist_radius=0.5, unstable_radius=1.0, tol=1e-9):
        if not 0 < nyquist_radius <= 1 or not unstable_radius > 0:
            raise DynamicsError(f"nyquist_radius, unstable_radius: expected in (0, 1] and > 0, found "
                                f"{nyquist_radius!r}, {unstable_radius!r}")
        system, A, B, C, D = _discrete_square(system)
        self.system = system
        self.p = p = D.shape[0]

        def good(z):
            return not (abs(z) >= unstable_radius or (z.real < 0 and abs(z) >= nyquist_radius))

        self.decoupled = p > 1 and _is_diagonal(A, B, C, D, tol)
        if self.decoupled:
            parts = [_zpetc_design(_minimal(system[i, i]), good, tol)
                     for i in range(p)]
            P = max(d["P"] for d in parts)
            L = max(d["taps_v"].shape[0] + P - d["P"] for d in parts)
            taps_v = np.zeros((L, p, p))
            taps_w = np.zeros((L, p, p))
            for i, d in enumerate(parts):
                sh = P - d["P"]
                taps_v[sh:sh + d["taps_v"].shape[0], i, i] = d["taps_v"][:, 0, 0]
                taps_w[sh:sh + d["taps_w"].shape[0], i, i] = d["taps_w"][:, 0, 0]
            Ag = scipy.linalg.block_diag(*[d["Ag"] for d in parts])
            Bg = scipy.linalg.block_diag(*[d["Bg"] for d in parts])
            Cg = scipy.linalg.block_diag(*[d["Cg"] for d in parts])
            self.relative_degree = np.concatenate([d["r"] for d in parts])
            self.unacceptable_zeros = np.concatenate([d["bad"] for d in parts])
        else:
            d = _zpetc_design(system, good, tol)
            P, taps_v, taps_w = d["P"], d["taps_v"], d["taps_w"]
            Ag, Bg, Cg = d["Ag"], d["Bg"], d["Cg"]
            self.relative_degree = d["r"]
            self.unacceptable_zeros = d["bad"]
        self.preview_samples = int(P)
        self.window = L = taps_v.shape[0]
        self._taps_v, self._taps_w = taps_v, taps_w
        self._Ag, self._Bg, self._Cg = Ag, Bg, Cg
        self.n_states = p * (L - 1) + Ag.shape[0]
        self._filter_matrices = None     # state_space(), built on the first filter call

    # -- states -----------------------------------------------------------------
    def initial_state(self, reference=None):
        """Flat filter state at rest for a constant reference.

        Parameters
        ----------
        reference : array_like, shape (p,), optional
            Constant reference held before the first sample [µm]; zeros by
            default (the all-zero state).

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            Past window filled with the reference, acceptable-mode state in
            its DC steady state.
        """
        p = self.p
        r0 = np.zeros(p) if reference is None else _check_reference(
            np.reshape(reference, (p, 1)), p)[:, 0]
        ng = self._Ag.shape[0]
        w0 = self._taps_w.sum(axis=0) @ r0
        xg = np.linalg.solve(np.eye(ng) - self._Ag, self._Bg @ w0) if ng else np.zeros(0)
        return np.concatenate([np.tile(r0, self.window - 1), xg])

    def plant_state(self, reference):
        """Linear-state of G at rest at a constant output (DC equilibrium) [µm].

        Parameters
        ----------
        reference : array_like, shape (p,)
            Output [µm].

        Returns
        -------
        numpy.ndarray, shape (n,)
            ``x = (I - A)^-1 B G(1)^-1 y``.
        """
        A, B = np.asarray(self.system.A), np.asarray(self.system.B)
        n = A.shape[0]
        G1 = np.asarray(self.system.C) @ np.linalg.solve(np.eye(n) - A, B) + np.asarray(self.system.D)
        v0 = np.linalg.solve(G1, np.asarray(reference, dtype=float))
        return np.linalg.solve(np.eye(n) - A, B @ v0)

    # -- filtering --------------------------------------------------------------
    def filter(self, reference, initial_state=None):
        """Run the causal inverse on a chunk of reference.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            ``yr(t)`` [µm] as it arrives (or ``yr(t + P)`` with preview).
        initial_state : array_like, shape (n_states,), optional
            State from :meth:`initial_state` or from a previous chunk; zeros
            by default.

        Returns
        -------
        v : numpy.ndarray, shape (p, n_samples)
            ``v(t - P)`` [µm]: the PI outputs that make ``G v`` follow the
            reference P samples later.
        final_state : numpy.ndarray, shape (n_states,)
            For the next chunk (chunked runs equal one run).

        Raises
        ------
        DynamicsError
            On a malformed reference or state.
        """
        r = _check_reference(reference, self.p)
        state = np.zeros(self.n_states) if initial_state is None else np.array(initial_state, dtype=float)
        if state.shape != (self.n_states,) or not np.all(np.isfinite(state)):
            raise DynamicsError(f"initial_state: expected {self.n_states} finite values, "
                                f"found shape {state.shape}")
        if self._filter_matrices is None:      # the inverse is fixed at construction: built once
            self._filter_matrices = tuple(np.ascontiguousarray(M, dtype=float)
                                          for M in self.state_space())
        return linear_steps(r, self._filter_matrices, state)

    def _filter_taps(self, reference, initial_state=None):
        """:meth:`filter` computed from the taps (the window's products, then the acceptable
        modes' recursion): the same operator, other roundings (2e-11 relative apart on a
        coupled 2 x 2 inverse); the tests' independent form of :meth:`state_space`."""
        p, L = self.p, self.window
        r = _check_reference(reference, p)
        state = np.zeros(self.n_states) if initial_state is None else np.array(initial_state, dtype=float)
        N = r.shape[1]
        past = state[:p * (L - 1)].reshape(L - 1, p).T
        xg = state[p * (L - 1):].copy()
        ext = np.concatenate([past, r], axis=1)                    # (p, L - 1 + N)
        v = np.zeros((p, N))
        w = np.zeros((p, N))
        for lag in range(L):
            seg = ext[:, L - 1 - lag:L - 1 - lag + N]
            v += self._taps_v[lag] @ seg
            w += self._taps_w[lag] @ seg
        if xg.size:
            Ag, Bg, Cg = self._Ag, self._Bg, self._Cg
            bw = Bg @ w
            xs = np.empty((xg.size, N))
            for k in range(N):
                xs[:, k] = xg
                xg = Ag @ xg + bw[:, k]
            v += Cg @ xs
        final = np.concatenate([ext[:, -(L - 1):].T.reshape(-1) if L > 1 else np.zeros(0), xg])
        return v, final

    def state_space(self):
        """The filter as one discrete state space on the flat filter state.

        ``v(k) = Cf s(k) + Df r(k)``, ``s(k+1) = Af s(k) + Bf r(k)`` with
        ``s`` the state of :meth:`filter` (past ``window - 1`` reference
        samples, oldest first, then the acceptable-mode state): the same
        outputs and final states as :meth:`filter`, in the form of a linear
        reference pre-filter of the compiled chain.

        Returns
        -------
        tuple of numpy.ndarray
            ``Af`` (n_states, n_states), ``Bf`` (n_states, p), ``Cf``
            (p, n_states), ``Df`` (p, p) [µm -> µm].
        """
        p, L = self.p, self.window
        nw, ng = p * (L - 1), self._Ag.shape[0]
        n = nw + ng
        Af, Bf = np.zeros((n, n)), np.zeros((n, p))
        Cf, Df = np.zeros((p, n)), self._taps_v[0].copy()
        for j in range(L - 1):                     # slot j holds r(k - (L - 1 - j))
            lag = L - 1 - j
            Cf[:, j * p:(j + 1) * p] = self._taps_v[lag]
            if ng:
                Af[nw:, j * p:(j + 1) * p] = self._Bg @ self._taps_w[lag]
            if j < L - 2:                          # shift the window by one sample
                Af[j * p:(j + 1) * p, (j + 1) * p:(j + 2) * p] = np.eye(p)
        if L > 1:
            Bf[(L - 2) * p:(L - 1) * p] = np.eye(p)
        if ng:
            Af[nw:, nw:] = self._Ag
            Bf[nw:] = self._Bg @ self._taps_w[0]
            Cf[:, nw:] = self._Cg
        return Af, Bf, Cf, Df

    def step(self, reference_sample, state):
        """One sample of :meth:`filter`.

        Parameters
        ----------
        reference_sample : array_like, shape (p,)
            [µm].
        state : array_like, shape (n_states,)

        Returns
        -------
        v : numpy.ndarray, shape (p,)
            ``v(t - P)`` [µm].
        new_state : numpy.ndarray, shape (n_states,)
        """
        v, s = self.filter(np.reshape(reference_sample, (self.p, 1)), state)
        return v[:, 0], s

    def apply(self, reference, hold=True, tail=None):
        """Whole record with full preview: v aligned with the reference.

        The filter starts at rest at ``reference[:, 0]`` (held before the
        record) and the last sample is held for the final P samples of
        preview.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            [µm].
        hold : bool
            Start at rest at the first reference sample (True) or from the
            zero state (False).
        tail : array_like, shape (p, preview_samples), optional
            Reference samples that follow the record (e.g. the periodic
            continuation); by default the last sample is held, which makes
            the last ``preview_samples`` outputs track the held value.

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            ``v`` [µm] with ``G v ~ reference`` (the plant starting at rest at
            ``reference[:, 0]``, see :meth:`plant_state`).

        Raises
        ------
        DynamicsError
            When ``reference`` or ``tail`` is not a finite array with p rows,
            or ``tail`` has fewer than ``preview_samples`` samples.
        """
        r = _check_reference(reference, self.p)
        P = self.preview_samples
        after = np.repeat(r[:, -1:], P, axis=1) if tail is None else \
            _check_reference(tail, self.p, "tail")[:, :P]
        if after.shape[1] != P:
            raise DynamicsError(f"tail: expected {P} samples, found {after.shape[1]}")
        padded = np.concatenate([r, after], axis=1)
        s0 = self.initial_state(r[:, 0]) if hold else None
        v, _ = self.filter(padded, s0)
        return v[:, P:]


def _dc_equilibrium(A, B, C, D, y):
    n = A.shape[0]
    G1 = C @ np.linalg.solve(np.eye(n) - A, B) + D
    v0 = np.linalg.solve(G1, y)
    return np.linalg.solve(np.eye(n) - A, B @ v0)


def preview_inverse(system, reference, method="stable", initial_state=None, regularization=1e-9,
                    **zpetc_options):
    """Inverse of G for a reference known in advance (whole record).

    Parameters
    ----------
    system : control.StateSpace
        Discrete p x p system G.
    reference : array_like, shape (p, n_samples)
        ``yr`` [µm].
    method : {'stable', 'zpetc', 'fft'}
        ``'stable'``: exact stable inversion (Devasia, Chen & Paden [2], in
        discrete time): the inverse system of :func:`inverse_system` is split
        (ordered Schur + Sylvester) into its stable modes (|z| < 1, run
        forward from the initial state) and unstable modes (|z| > 1, run
        backward from the end of the record, where the reference is held at
        its last value and the unstable part at its DC equilibrium). Exact
        (``G v = yr``) from the first sample when G has no zero outside the
        unit circle and the plant starts in ``initial_state``; with unstable
        zeros the exact solution needs pre-actuation before t = 0, which is
        truncated (the start-up error then decays as ``|z_u|^-k``).
        Sampling zeros near -1 are inverted exactly: v then carries a
        Nyquist-rate oscillation that G cancels (model mismatch lets a small
        part through).
        ``'zpetc'``: :meth:`ZPETCInverse.apply`, the zero-phase approximation
        aligned on the record (no Nyquist oscillation, gain error
        ``<= 2 |beta| (1 - cos wT) / (1 - beta)^2``).
        ``'fft'``: exact periodic steady state; the record must be an integer
        number of periods of the reference: ``V(w_k) = G(e^(j w_k T))^+
        Yr(w_k)`` with Tikhonov regularisation where G is nearly singular
        (near Nyquist); the start-up transient of the plant is not included.
    initial_state : array_like, shape (n,), optional
        State of G at the first sample (``'stable'``); default the DC
        equilibrium at ``reference[:, 0]`` (at rest at the first reference
        value).
    regularization : float
        ``'fft'``: ``lambda = regularization * sigma_max(G(1))``.
    **zpetc_options
        Options of :class:`ZPETCInverse` (``'zpetc'``).

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
        ``v`` [µm].

    Raises
    ------
    DynamicsError
        On an invalid system, reference or method.

    References
    ----------
    .. [2] S. Devasia, D. Chen and B. Paden, IEEE TAC 41(7), 930-942, 1996.
    .. [3] Q. Zou and S. Devasia, J. Dyn. Sys., Meas., Control 121(4), 625-630, 1999.

    Examples
    --------
    >>> import numpy as np, control
    >>> from hammerstein.models.dynamics import bending_modes, discretize
    >>> G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2]), 5e-5)
    >>> t = np.arange(1000) * 5e-5
    >>> yr = np.vstack([np.sin(2 * np.pi * 200 * t), np.zeros_like(t)])
    >>> v = preview_inverse(G, yr)
    >>> y = control.forced_response(G, U=v).outputs
    >>> bool(np.max(np.abs(y - yr)) < 1e-9)
    True
    """
    if method == "zpetc":
        return ZPETCInverse(system, **zpetc_options).apply(reference)
    system, A, B, C, D = _discrete_square(system)
    p, n = D.shape[0], A.shape[0]
    r = _check_reference(reference, p)
    N = r.shape[1]
    if method == "fft":
        R = np.fft.rfft(r, axis=1)
        w = 2 * np.pi * np.fft.rfftfreq(N)                       # rad/sample
        Gw = np.asarray(control.frequency_response(system, w / system.dt).complex).reshape(p, p, -1)
        lam = regularization * np.linalg.norm(np.real(Gw[:, :, 0]), 2)
        V = np.empty_like(R)
        for k in range(w.size):
            Gk = Gw[:, :, k]
            V[:, k] = np.linalg.solve(Gk.conj().T @ Gk + lam ** 2 * np.eye(p), Gk.conj().T @ R[:, k])
        return np.fft.irfft(V, n=N, axis=1)
    if method != "stable":
        raise DynamicsError(f"method: expected 'stable', 'zpetc' or 'fft', found {method!r}")
    inv = inverse_system(system)
    rd = inv.relative_degree
    # advanced reference yt_i(k) = yr_i(k + r_i), last value held
    yt = np.empty_like(r)
    for i in range(p):
        yt[i] = np.concatenate([r[i, rd[i]:], np.repeat(r[i, -1], rd[i])])
    As, Bs, Cs, Au, Bu, Cu, S = _split(inv.A, inv.B, inv.C, lambda z: abs(z) < 1)
    x0 = _dc_equilibrium(A, B, C, D, r[:, 0]) if initial_state is None else \
        np.asarray(initial_state, dtype=float)
    if x0.shape != (n,):
        raise DynamicsError(f"initial_state: expected {n} values, found shape {x0.shape}")
    # coordinates of the split: x = S [xs; xu]; recover the stable part of x0
    ns = As.shape[0]
    v = inv.D @ yt
    if ns:
        xs = np.linalg.solve(S, x0)[:ns]
        bu = Bs @ yt
        for k in range(N):
            v[:, k] += Cs @ xs
            xs = As @ xs + bu[:, k]
    nu = Au.shape[0]
    if nu:
        # backward: xu(k) = Au^-1 (xu(k+1) - Bu yt(k)), terminal DC equilibrium
        xu = np.linalg.solve(np.eye(nu) - Au, Bu @ yt[:, -1])
        Auinv = np.linalg.inv(Au)
        bu = Bu @ yt
        for k in range(N - 1, -1, -1):
            xu = Auinv @ (xu - bu[:, k])
            v[:, k] += Cu @ xu
    return v
