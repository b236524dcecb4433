"""The turning points of the demagnetising cycle the records start after.

``hammerstein excitation`` writes ``demagnetise.csv``: every input at once, a sine
decaying linearly to its rest, ``u(t) = c + A (1 - t / D) sin(2 pi f t)`` for ``0 <= t <
D = P / f`` (``P`` periods), then the rest value (0 V, or the range's value nearest
0 V when the range is centred elsewhere). A rate-independent hysteresis model sees
only the cycle's turning points: a play operator's output after a monotone piece of
input depends on the piece's end alone (Brokate and Sprekels [1]_, Section 2.2), so
the state the cycle leaves is the state after its turning points, whatever the
sampling period or the frequency ``f``.

The turning points of ``g(s) = (1 - s / P) sin(2 pi s)`` (``s = f t``, periods) are the
zeros of ``g'(s) = 2 pi (1 - s / P) cos(2 pi s) - sin(2 pi s) / P``, one in each
``[j / 2, j / 2 + 1 / 4]``, ``j = 0 .. 2 P - 1``: ``g'`` is ``(-1)^j 2 pi (1 - j / (2P))``
at the left end and ``(-1)^(j + 1) / P`` at the right one.

References
----------
.. [1] M. Brokate, J. Sprekels, *Hysteresis and Phase Transitions*, Springer, 1996.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.optimize import brentq

from hammerstein.exceptions import HysteresisError

__all__ = ["DEMAGNETISING_PERIODS", "RECORD_STARTS", "CycleStart", "demagnetising_cycle_of_range",
           "demagnetising_turning_points"]

#: Periods of the decay of ``hammerstein excitation``'s ``demagnetise.csv``.
DEMAGNETISING_PERIODS = 20

#: What an identifier takes each record to start from (its ``record_start``): after the
#: demagnetising cycle, or at rest (records taken without it).
RECORD_STARTS = ("demagnetised", "rest")


@functools.lru_cache(maxsize=8)
def _unit_turning_points(periods):
    """Turning points of ``(1 - s / P) sin(2 pi s)``, ``s`` in ``[0, P)`` (read-only)."""
    P = float(periods)

    def slope(s):
        return 2 * np.pi * (1 - s / P) * np.cos(2 * np.pi * s) - np.sin(2 * np.pi * s) / P

    s = np.array([brentq(slope, j / 2, j / 2 + 0.25, xtol=1e-15) for j in range(2 * periods)])
    g = (1 - s / P) * np.sin(2 * np.pi * s)
    g.setflags(write=False)
    return g


def demagnetising_turning_points(amplitude, centre=0.0, periods=DEMAGNETISING_PERIODS):
    r"""Turning points of a demagnetising cycle, ending at its rest value.

    The crests and troughs of ``c + A (1 - t / D) sin(2 pi f t)`` (module notes; the
    cycle of :func:`hammerstein.signals.excitation.demagnetising_cycle`), then ``c``
    (the end of the decay) and the rest value ``clip(0, c - A, c + A)``, the range's
    value nearest 0 V where the cycle's amplifier rests. A rate-independent model
    driven through them reaches the state the whole cycle leaves.

    Parameters
    ----------
    amplitude : float
        ``A`` [V], the cycle's first amplitude (the records' full amplitude); > 0.
    centre : float
        ``c`` [V], the centre of the input's range (default 0).
    periods : int
        ``P``, periods of the decay (default 20, as ``hammerstein excitation``).

    Returns
    -------
    numpy.ndarray, shape (2 P + 2,)
        Input values [V] in the order played.

    Raises
    ------
    ValueError
        On a non-positive or non-finite amplitude, a non-finite centre or fewer than
        one period (the message names the parameter).

    Examples
    --------
    >>> from hammerstein.models.demagnetisation import demagnetising_turning_points
    >>> u = demagnetising_turning_points(10.0, periods=4)
    >>> u.round(3)
    array([ 9.383, -8.135,  6.886, -5.639,  4.393, -3.15 ,  1.916, -0.724,
            0.   ,  0.   ])
    """
    A, c = float(amplitude), float(centre)
    if not (np.isfinite(A) and A > 0):
        raise ValueError(f"amplitude: expected a positive voltage [V], found {amplitude!r}")
    if not np.isfinite(c):
        raise ValueError(f"centre: expected a finite voltage [V], found {centre!r}")
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) \
            or not 1 <= periods <= 1000:
        raise ValueError(f"periods: expected an integer from 1 to 1000, found {periods!r}")
    g = _unit_turning_points(int(periods))
    return np.concatenate([c + A * g, [c, min(max(0.0, c - A), c + A)]])


def demagnetising_cycle_of_range(low, high):
    """``(amplitude, centre)`` [V] of the demagnetising cycle over an input's range.

    ``hammerstein excitation`` demagnetises every input from its records' full amplitude
    around the centre of their range: ``A = (high - low) / 2``, ``c = (high + low) / 2``,
    and ``c = 0`` for a range symmetric within 1 % of ``A``.

    Parameters
    ----------
    low, high : float
        The input's recorded range [V].

    Returns
    -------
    tuple of float
        ``(A, c)`` [V]; ``(0, 0)`` for an input that never moves (``high <= low``).

    Examples
    --------
    >>> from hammerstein.models.demagnetisation import demagnetising_cycle_of_range
    >>> demagnetising_cycle_of_range(-20.0, 20.1)
    (20.05, 0.0)
    >>> demagnetising_cycle_of_range(0.0, 100.0)
    (50.0, 50.0)
    """
    amp, centre = 0.5 * (float(high) - float(low)), 0.5 * (float(high) + float(low))
    if not amp > 0:
        return 0.0, 0.0
    return amp, (0.0 if abs(centre) <= 0.01 * amp else centre)


def _volts(value, name):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise HysteresisError(f"{name}: expected a finite voltage [V], found {value!r}") from None
    if not np.isfinite(v):
        raise HysteresisError(f"{name}: expected a finite voltage [V], found {value!r}")
    return v


class CycleStart:
    """A hysteresis component whose default initial state may follow a demagnetising cycle.

    Shared by :class:`~hammerstein.models.generalized_pi.GeneralizedPI` and
    :class:`~hammerstein.models.preisach_operator.PreisachModel`: the cycle's amplitude
    ``demagnetised`` [V] (0: none) and centre ``demagnetised_centre`` [V], and the turning
    points the default state is driven through (:func:`demagnetising_turning_points`).
    The component computes that state once, in ``_start``.
    """

    demagnetised = 0.0
    demagnetised_centre = 0.0

    def _set_cycle(self, demagnetised, demagnetised_centre):
        """Validate and keep the cycle; forget a computed start."""
        amplitude = _volts(demagnetised, "demagnetised")
        if amplitude < 0:
            raise HysteresisError(f"demagnetised: expected the demagnetising cycle's amplitude "
                                  f">= 0 [V] (0: none), found {amplitude}")
        self.demagnetised = amplitude
        self.demagnetised_centre = _volts(demagnetised_centre, "demagnetised_centre")
        self._start = None              # the default initial state, computed once

    def _cycle_text(self):
        """The cycle's keyword arguments for ``repr`` (empty without one)."""
        return ((f", demagnetised={self.demagnetised}" if self.demagnetised else "")
                + (f", demagnetised_centre={self.demagnetised_centre}"
                   if self.demagnetised_centre else ""))

    def demagnetising_input(self):
        """The turning points the default initial state follows (empty without a cycle).

        Returns
        -------
        numpy.ndarray, shape (n_points,)
            Input [V] (:func:`demagnetising_turning_points`).
        """
        if not self.demagnetised:
            return np.zeros(0)
        return demagnetising_turning_points(self.demagnetised, self.demagnetised_centre)
