"""The discrete Preisach operator of one input-output pair (ramp hysterons).

:class:`PreisachModel`: the weights ``mu_ij`` of the hysterons of a switching grid
(explicit, from an Everett-function table or from a parametric density), their
staircase memory and where it starts (the ideal demagnetised state, or the state a
demagnetising cycle leaves). The model's notes, its table format and the multivariable
container of direct transfers and cross-couplings are in :mod:`hammerstein.models.preisach`,
which re-exports the class.
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.models.demagnetisation import CycleStart
from hammerstein.simulation import preisach_steps, state_vector

__all__ = ["PreisachModel"]


def _array(value, name, ndim=1):
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise HysteresisError(f"{name}: expected {'a list of numbers' if ndim == 1 else 'a table of numbers (list of rows)'}, "
                              f"found {str(value)[:80]}") from None
    if arr.ndim != ndim:
        raise HysteresisError(f"{name}: expected {ndim}-d finite numbers, found shape {arr.shape}")
    if not np.all(np.isfinite(arr)):    # the shape was right: "found shape (2,)" misled
        raise HysteresisError(f"{name}: expected finite values, found NaN or inf")
    return arr


def _number(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not np.isfinite(value):
        raise HysteresisError(f"{name}: expected a finite number, found {value!r}")
    return float(value)


def _poly(coefficients, u):
    """``sum_n c_n u^n`` for n = 1, 2, ... (Horner)."""
    acc = np.zeros_like(u)
    for c in coefficients[::-1]:
        acc = (acc + c) * u
    return acc


class PreisachModel(CycleStart):
    """Discrete Preisach model of one input-output pair (ramp hysterons).

    The hysterons, the grid and the three ways to give the weights are described in
    :mod:`hammerstein.models.preisach`.

    Parameters
    ----------
    edges : array_like, shape (n_levels + 1,)
        Cell edges of the switching grid [V], strictly increasing.
    weights : array_like, shape (n_levels, n_levels)
        ``weights[i, j]`` = mu_ij >= 0 [µm] of the hysteron with alpha cell i
        and beta cell j; the upper triangle (j > i) must be zero.
    reversible : array_like, shape (n_coef,), optional
        Coefficients ``c_1, c_2, ...`` of the reversible part
        ``c_1 u + c_2 u^2 + ...`` [µm/V^n].
    offset : float
        Constant added to the output [µm].
    signed : bool
        Allow negative weights (a cross-coupling whose hysteresis runs the
        other way or is not monotone; never for a path that must stay
        invertible). Default False: ``weights >= 0``.
    demagnetised : float
        Amplitude ``A`` [V] of the demagnetising cycle the default initial
        state follows (see Notes); 0 (the default): none.
    demagnetised_centre : float
        Centre ``c`` [V] of that cycle (default 0).

    Notes
    -----
    The state is one value in [-1, 1] per hysteron, hysterons ordered by
    row i then column j <= i (lower triangle, row-major). Without a cycle
    the default initial state is the ideal demagnetised one: +1 below the
    anti-diagonal (``i + j < n_levels - 1``), -1 above it, 0 on it (the
    state an infinitely slow decay leaves: Mayergoyz, *Mathematical Models
    of Hysteresis*, ch. 1).

    With ``demagnetised = A > 0`` it is that state driven through the
    turning points of the demagnetising cycle ``c + A (1 - t / D) sin(2 pi
    f t)`` that ``hammerstein excitation`` plays before every record
    (:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`):
    the first crest wipes the ideal state out below ``c + A``, and the
    cycle's 20 decreasing crests leave a staircase along the anti-diagonal
    instead of the ideal line. On a ``realistic-2dof`` plant the two starts
    differ by 0.017 µm on a centred 13 µm loop.

    Raises
    ------
    HysteresisError
        Naming the parameter that is wrong.

    Examples
    --------
    One hysteron with alpha cell [1, 2] V and beta cell [-2, -1] V, weight 1 µm,
    from the state -1: the output rises across 1 to 2 V, stays at +1 while the
    input falls back to -1 V, and drops across -1 to -2 V:

    >>> import numpy as np
    >>> from hammerstein.models.preisach import PreisachModel
    >>> w = np.zeros((4, 4)); w[3, 0] = 1.0
    >>> model = PreisachModel([-2.0, -1.0, 0.0, 1.0, 2.0], w)
    >>> y, state = model.simulate([0.0, 1.5, 3.0, -1.0, -1.5, -3.0], -np.ones(10))
    >>> y + 0.0
    array([-1.,  0.,  1.,  1.,  0., -1.])
    """

    def __init__(self, edges, weights, reversible=(), offset=0.0, signed=False,
                 demagnetised=0.0, demagnetised_centre=0.0):
        self.edges = _array(edges, "edges")
        n = self.edges.size - 1
        if n < 1 or np.any(np.diff(self.edges) <= 0):
            raise HysteresisError(f"edges: expected at least 2 strictly increasing values [V], "
                                  f"found {self.edges.tolist()[:8]}")
        w = _array(weights, "weights", ndim=2)
        if w.shape != (n, n):
            raise HysteresisError(f"weights: expected a {n} x {n} table (one row per alpha cell, "
                                  f"one column per beta cell), found {w.shape}")
        if np.any(np.triu(w, 1) != 0):
            raise HysteresisError("weights: expected zeros above the diagonal (alpha >= beta: "
                                  "column j <= row i)")
        if not isinstance(signed, (bool, np.bool_)):
            raise HysteresisError(f"signed: expected true or false, found {signed!r}")
        self.signed = bool(signed)
        if np.any(w < 0) and not self.signed:
            raise HysteresisError("weights: expected non-negative hysteron weights [µm] (or "
                                  "signed = true for a cross-coupling)")
        self.weights = w
        self.reversible = _array(list(reversible), "reversible") if len(reversible) else np.zeros(0)
        self.offset = _number(offset, "offset")
        self._row, self._col = (a.astype(np.int64) for a in np.tril_indices(n))
        self._mu = np.ascontiguousarray(w[self._row, self._col])
        self._set_cycle(demagnetised, demagnetised_centre)

    def __repr__(self):
        return (f"PreisachModel(n_levels={self.n_levels}, edges=[{self.edges[0]}, ..., "
                f"{self.edges[-1]}], total={self._mu.sum():.6g}, reversible="
                f"{self.reversible.tolist()}, offset={self.offset}"
                + self._cycle_text() + ")")

    def replace(self, **changes):
        """A copy with some parameters changed.

        Parameters
        ----------
        **changes
            Any of ``edges``, ``weights``, ``reversible``, ``offset``, ``signed``,
            ``demagnetised`` and ``demagnetised_centre``.

        Returns
        -------
        PreisachModel
            Built by the constructor, whose errors it raises.

        Raises
        ------
        HysteresisError
            On an unknown parameter.
        """
        args = {"edges": self.edges, "weights": self.weights, "reversible": self.reversible,
                "offset": self.offset, "signed": self.signed,
                "demagnetised": self.demagnetised,
                "demagnetised_centre": self.demagnetised_centre}
        unknown = sorted(set(changes) - set(args))
        if unknown:
            raise HysteresisError(f"{unknown[0]}: unknown parameter of a Preisach model "
                                  f"(expected one of {', '.join(args)})")
        return PreisachModel(**{**args, **changes})

    # -- construction -----------------------------------------------------------
    @property
    def n_levels(self) -> int:
        """Number of cells of the switching grid."""
        return self.edges.size - 1

    @property
    def n_states(self) -> int:
        """Number of hysterons (state values), ``n_levels (n_levels + 1) / 2``."""
        return self._mu.size

    @property
    def hysteron_arrays(self):
        """``(row, col, mu)`` of the hysterons in state order (int64, int64, float)."""
        return self._row, self._col, self._mu

    @classmethod
    def from_density(cls, edges, total, bias=0.0, bias_width=1.0, tilt=0.0, coercivity=0.0,
                     coercivity_width=1.0, reversible=(), offset=0.0):
        """Weights from the parametric density (:mod:`hammerstein.models.preisach` notes).

        Parameters
        ----------
        edges : array_like, shape (n_levels + 1,)
            Cell edges [V].
        total : float
            Sum of the weights [µm], > 0.
        bias, bias_width : float
            Centre and width (> 0) of the density in ``(alpha + beta) / 2`` [V].
        tilt : float
            Shift of the bias centre per volt of half width [-] (asymmetry).
        coercivity, coercivity_width : float
            Centre and width (> 0) of the density in ``(alpha - beta) / 2`` [V].
        reversible : array_like, optional
            Reversible polynomial coefficients [µm/V^n].
        offset : float
            Output offset [µm].

        Returns
        -------
        PreisachModel

        Raises
        ------
        HysteresisError
            On a non-positive total or width.
        """
        e = _array(edges, "edges")
        total = _number(total, "total")
        bw, cw = _number(bias_width, "bias_width"), _number(coercivity_width, "coercivity_width")
        if total <= 0 or bw <= 0 or cw <= 0:
            raise HysteresisError(f"density: expected total, bias_width and coercivity_width > 0, "
                                  f"found {total}, {bw}, {cw}")
        mid, width = (e[1:] + e[:-1]) / 2, np.diff(e)
        a, b = np.meshgrid(mid, mid, indexing="ij")
        bias_c, half = (a + b) / 2, (a - b) / 2
        dens = (np.exp(-(bias_c - _number(bias, "bias") - _number(tilt, "tilt") * half) ** 2
                       / (2 * bw ** 2))
                * np.exp(-(half - _number(coercivity, "coercivity")) ** 2 / (2 * cw ** 2)))
        area = np.outer(width, width)
        area[np.diag_indices_from(area)] /= 2
        w = np.tril(dens * area)
        if not w.sum() > 0:
            raise HysteresisError("density: no weight on the grid (density centred outside it)")
        return cls(e, w * (total / w.sum()), reversible, offset)

    @classmethod
    def from_everett(cls, edges, everett, reversible=(), offset=0.0):
        """Weights from an Everett-function table on the edges (``preisach`` notes).

        Parameters
        ----------
        edges : array_like, shape (n_levels + 1,)
            Cell edges [V].
        everett : array_like, shape (n_levels + 1, n_levels + 1)
            ``E[a][b]`` [µm] for ``a > b`` (other entries are ignored).
        reversible : array_like, optional
            Reversible polynomial coefficients [µm/V^n].
        offset : float
            Output offset [µm].

        Returns
        -------
        PreisachModel

        Raises
        ------
        HysteresisError
            On a wrong shape, or an Everett table that gives negative weights.
        """
        e = _array(edges, "edges")
        E = np.tril(_array(everett, "everett", ndim=2), -1)
        n = e.size - 1
        if E.shape != (n + 1, n + 1):
            raise HysteresisError(f"everett: expected a {n + 1} x {n + 1} table (one row and one "
                                  f"column per edge), found {E.shape}")
        mu = (E[1:, :-1] - E[:-1, :-1] - E[1:, 1:] + E[:-1, 1:]) / 2
        mu = np.tril(mu)
        if np.any(mu < -1e-12 * max(1.0, np.abs(E).max())):
            raise HysteresisError("everett: expected a table whose mixed differences are "
                                  "non-negative (non-negative hysteron weights)")
        return cls(e, np.maximum(mu, 0.0), reversible, offset)

    def everett(self):
        """Everett-function table of the hysteretic part on the edges.

        Returns
        -------
        numpy.ndarray, shape (n_levels + 1, n_levels + 1)
            ``E[a][b] = 2 sum_{b <= j <= i < a} mu_ij`` [µm] for ``a > b``, 0 elsewhere.
        """
        n = self.n_levels
        E = np.zeros((n + 1, n + 1))
        for a in range(1, n + 1):
            for b in range(a):
                E[a, b] = 2 * self.weights[b:a, b:a].sum()
        return E

    # -- simulation -------------------------------------------------------------
    def initial_state(self, initial_state=None):
        """Validated copy of a state, or the default (demagnetised) state (see Notes).

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            Hysteron states in [-1, 1].

        Returns
        -------
        numpy.ndarray, shape (n_states,)

        Raises
        ------
        HysteresisError
            On a wrong shape or values outside [-1, 1].
        """
        if initial_state is None:
            if self._start is None:
                s = -np.sign(self._row + self._col - (self.n_levels - 1)).astype(float)
                if self.demagnetised:
                    s = preisach_steps(self.demagnetising_input(), self.edges, self._row,
                                       self._col, self._mu, s)[1]
                self._start = s
            return self._start.copy()
        s = state_vector(initial_state, self.n_states, "initial_state")
        if np.any(np.abs(s) > 1):
            raise HysteresisError("initial_state: expected hysteron states in [-1, 1]")
        return s

    def reversible_part(self, u):
        """Reversible output ``sum_n c_n u^n + offset`` [µm].

        Parameters
        ----------
        u : array_like
            Input [V].

        Returns
        -------
        numpy.ndarray
            Same shape as ``u``.
        """
        return _poly(self.reversible, np.asarray(u, dtype=float)) + self.offset

    def simulate(self, u, initial_state=None):
        """Output for an input record (compiled kernel).

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            Input [V].
        initial_state : array_like, shape (n_states,), optional
            Hysteron states (see :meth:`initial_state`).

        Returns
        -------
        y : numpy.ndarray, shape (n_samples,)
            Output [µm].
        final_state : numpy.ndarray, shape (n_states,)
            Hysteron states after the last sample.

        Raises
        ------
        HysteresisError
            On a non-finite input or a wrong state.
        """
        u = _array(u, "u")
        s = self.initial_state(initial_state)
        y, s = preisach_steps(u, self.edges, self._row, self._col, self._mu, s)
        return y + self.reversible_part(u), s

    def to_table(self):
        """The component's TOML table (``kind = "preisach"``, explicit weights).

        Returns
        -------
        dict
        """
        table = {"kind": "preisach", "edges": self.edges.tolist(),
                 "weights": [row[:i + 1].tolist() + [0.0] * (self.n_levels - i - 1)
                             for i, row in enumerate(self.weights)]}
        if self.reversible.size:
            table["reversible"] = self.reversible.tolist()
        if self.offset:
            table["offset"] = self.offset
        if self.signed:
            table["signed"] = True
        for key in ("demagnetised", "demagnetised_centre"):
            if getattr(self, key):
                table[key] = getattr(self, key)
        return table
