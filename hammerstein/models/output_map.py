"""The static output map of the modified Prandtl-Ishlinskii model (Kuhnen).

A monotone piecewise-linear map ``S`` after the classical PI, ``y = S(Gamma(u)) + c``:
:class:`OutputMap`, used by :class:`~hammerstein.models.hysteresis.MultivariablePI`
(``output_map``) and re-exported by :mod:`hammerstein.models.hysteresis`.
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import HysteresisError
from hammerstein.simulation import finite_array as _as_finite_array

__all__ = ["OutputMap"]


class OutputMap:
    """Monotone static output map of the modified PI: one-sided dead zones.

    ``S(h) = a_0 h + sum_j (a_j - a_{j-1}) (max(h - z_j, 0) - max(-z_j, 0))``,
    a continuous piecewise-linear, strictly increasing map with knots
    ``z_1 < ... < z_K`` and segment slopes ``a_0, ..., a_K > 0``, through
    the origin (``S(0) = 0``). It is the superposition of one-sided dead-zone
    operators of the modified Prandtl-Ishlinskii model of Kuhnen [3]_ written
    with the slope of each segment: ``y = S(Gamma(u))`` draws asymmetric and
    saturating loops that a classical PI cannot, and stays exactly
    invertible, ``S^-1`` being again piecewise linear with knots ``S(z_j)``
    and slopes ``1 / a_j``.

    Parameters
    ----------
    knots : array_like, shape (K,)
        Strictly increasing knots ``z_j`` in the unit of ``h`` (the PI
        output, e.g. [µm]); may be empty (a pure gain).
    slopes : array_like, shape (K + 1,)
        Positive slope of each segment [-]: left of ``z_1``, between the
        knots, right of ``z_K``.

    Raises
    ------
    HysteresisError
        If the knots are not finite and strictly increasing, or the slopes
        are not ``K + 1`` finite positive numbers.

    References
    ----------
    .. [3] K. Kuhnen, "Modeling, identification and compensation of complex
       hysteretic nonlinearities: a modified Prandtl-Ishlinskii approach",
       European Journal of Control 9(4) (2003), the superposition operator S.

    Examples
    --------
    A one-sided saturation: slope 1 below 5 µm, 0.7 above; the inverse
    undoes it exactly.

    >>> import numpy as np
    >>> from hammerstein.models.hysteresis import OutputMap
    >>> s = OutputMap([5.0], [1.0, 0.7])
    >>> s.apply(np.array([-2.0, 5.0, 10.0]))
    array([-2. ,  5. ,  8.5])
    >>> s.inverse(s.apply(np.array([-2.0, 5.0, 10.0])))
    array([-2.,  5., 10.])
    """

    def __init__(self, knots, slopes):
        z = np.atleast_1d(_as_finite_array(knots, "knots")).astype(float).ravel() \
            if np.size(knots) else np.zeros(0)
        a = np.atleast_1d(_as_finite_array(slopes, "slopes")).astype(float).ravel()
        if z.size > 1 and np.any(np.diff(z) <= 0):
            raise HysteresisError(f"knots: expected strictly increasing values, found {z.tolist()}")
        if a.size != z.size + 1:
            raise HysteresisError(f"slopes: expected {z.size + 1} values (one per segment around "
                                  f"{z.size} knots), found {a.size}")
        if np.any(a <= 0):
            raise HysteresisError(f"slopes: expected positive values (a strictly increasing, "
                                  f"invertible map), found {a.tolist()}")
        self.knots, self.slopes = z, a
        self.values = self._forward(z)          # S(z_j), the knots of the inverse

    def __repr__(self):
        return f"OutputMap(knots={self.knots.tolist()}, slopes={self.slopes.tolist()})"

    def __eq__(self, other):
        return (isinstance(other, OutputMap) and np.array_equal(self.knots, other.knots)
                and np.array_equal(self.slopes, other.slopes))

    def _forward(self, h):
        h = np.asarray(h, dtype=float)
        y = self.slopes[0] * h
        for z, da in zip(self.knots, np.diff(self.slopes)):
            y = y + da * (np.maximum(h - z, 0.0) - max(-z, 0.0))
        return y

    def apply(self, h):
        """``S(h)``, element-wise.

        Parameters
        ----------
        h : array_like, any shape
            PI outputs (e.g. [µm]).

        Returns
        -------
        numpy.ndarray, same shape
            Mapped outputs (same unit).
        """
        return self._forward(h)

    def inverse(self, y):
        """``S^-1(y)``, element-wise and exact (piecewise linear).

        Parameters
        ----------
        y : array_like, any shape
            Mapped outputs (e.g. [µm]).

        Returns
        -------
        numpy.ndarray, same shape
            ``h`` with ``S(h) = y``.
        """
        y = np.asarray(y, dtype=float)
        if not self.knots.size:
            return y / self.slopes[0]
        seg = np.searchsorted(self.values, y, side="right")   # 0 .. K
        anchor = np.maximum(seg - 1, 0)
        return self.knots[anchor] + (y - self.values[anchor]) / self.slopes[seg]

    def derivative(self, h):
        """Slope ``S'(h)`` [-] (the right derivative at a knot).

        Parameters
        ----------
        h : array_like, any shape
            PI outputs.

        Returns
        -------
        numpy.ndarray, same shape
        """
        return self.slopes[np.searchsorted(self.knots, np.asarray(h, dtype=float), side="right")]

    def to_table(self):
        """The map as a model-file table.

        Returns
        -------
        dict
            ``{"knots": [...], "slopes": [...]}`` (lists of floats).
        """
        return {"knots": [float(v) for v in self.knots], "slopes": [float(v) for v in self.slopes]}
