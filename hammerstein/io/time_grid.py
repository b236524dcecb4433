"""The time grid of a record's stamps: its period, its rounding and its gaps.

A logger stamps uniform samples with rounded times (printed to a few
digits, or single-precision floats). :func:`uniform_period` finds the
period and how far each stamp is off the grid, allowing for the rounding
the stamps show (:func:`step_resolution`); :func:`step_gaps` finds the
dropped samples that rounding cannot explain, and :func:`gap_text` names
them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["uniform_period", "step_resolution", "step_gaps", "gap_text"]


def step_resolution(t):
    """How much the steps between time stamps vary through their rounding [s].

    The largest departure of a step from the median step, among the steps
    within half a median step of it (a gap is not rounding): about one unit
    in the last place of float32 stamps, a few 1e-13 s for stamps printed
    with enough digits, the jitter of a jittery clock.

    Parameters
    ----------
    t : numpy.ndarray, shape (n_samples,)
        Increasing time stamps [s], at least two.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> t = 1234.5 + np.round(np.arange(1000) * 1e-4, 6)
    >>> bool(step_resolution(np.delete(t, 500)) < 1e-9)        # a dropped sample is no rounding
    True
    >>> t = (1000.0 + np.arange(1000) * 1e-3).astype(np.float32).astype(float)
    >>> float(step_resolution(t))                               # float32 steps: 1e-3 s +- 61 µs
    6.103515625e-05
    """
    d = np.diff(np.asarray(t, dtype=float))
    step = float(np.median(d))
    dev = np.abs(d - step)
    dev = dev[dev < 0.5 * step]
    return float(dev.max()) if dev.size else 0.0


def step_gaps(t):
    """Steps of more than 1.5 median steps, in stamps whose rounding could not hide one sample.

    Parameters
    ----------
    t : numpy.ndarray, shape (n_samples,)
        Increasing time stamps [s], at least two.

    Returns
    -------
    numpy.ndarray of int
        The indices ``i`` of the steps ``t[i + 1] - t[i]`` that skip samples
        (empty when the stamps' own rounding, :func:`step_resolution`,
        reaches a quarter of a step: they cannot show a sample).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.delete(np.arange(100) * 1e-4, 50)
    >>> step_gaps(t).tolist()
    [49]
    """
    t = np.asarray(t, dtype=float)
    d = np.diff(t)
    step = float(np.median(d))
    if step_resolution(t) >= 0.25 * step:
        return np.zeros(0, dtype=int)
    return np.flatnonzero(d > 1.5 * step)


def uniform_period(t):
    """The sampling period of time stamps taken on a uniform grid, and how far they are off it.

    A logger stamps uniform samples with rounded times: printed to a few
    digits, or single-precision floats (``np.float32(k T)``: half a unit in the
    last place, 2^-24 of the time, 0.48 µs at 8 s, more than 1 % of a 40 µs
    period). The step between two stamps then varies by up to twice that
    rounding, but every stamp stays within it of ``t_0 + k T``. The period
    is the line through the first and last stamps, ``(t_(n-1) - t_0) / (n - 1)``
    (the median step is biased by the rounding: 4.005e-5 s for float32
    stamps of 4e-5 s), written with the fewest significant digits (4 to 12)
    that keep every stamp within the tolerance of the grid.

    Parameters
    ----------
    t : numpy.ndarray, shape (n_samples,)
        Increasing time stamps [s], at least two.

    Returns
    -------
    period : float
        ``T`` [s].
    offset : numpy.ndarray, shape (n_samples,)
        ``t_k - (t_0 + k T)`` [s].
    tolerance : float
        What rounded stamps of uniform samples may be off the grid [s]: 1 %
        of ``T``, or single precision's half unit at the largest time
        (``2^-24 max |t|``) when the stamps' steps vary that much
        (:func:`step_resolution`), whichever is larger. Stamps written with
        more digits than single precision's (a record starting at 1234.5 s,
        stamped to the µs) are allowed their own rounding only: a dropped
        sample at 10 kHz is off by 50 µs, single precision's half unit at
        1234.5 s is 74 µs. A record with a gap, a changing rate or a clock
        that drifts is off by more.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(250000, dtype=float) * 4e-5
    >>> T, off, tol = uniform_period(np.float32(t).astype(float))   # a float32 logger's stamps
    >>> T, bool(np.max(np.abs(off)) <= tol)
    (4e-05, True)
    """
    t = np.asarray(t, dtype=float)
    k = np.arange(t.size)
    T = float((t[-1] - t[0]) / (t.size - 1))
    tol = max(0.01 * T, min(2.0 ** -24 * float(np.max(np.abs(t))) * 1.01,
                            2 * step_resolution(t)))
    for digits in range(4, 13):
        Ts = float(f"{T:.{digits}g}")
        off = t - t[0] - k * Ts
        if np.max(np.abs(off)) <= tol:
            return Ts, off, tol
    return T, t - t[0] - k * T, tol


def gap_text(t, gaps):
    """The gaps of time stamps in words: how many, the samples missing, the first one's row and time.

    Parameters
    ----------
    t : numpy.ndarray, shape (n_samples,)
        Increasing time stamps [s].
    gaps : numpy.ndarray of int
        :func:`step_gaps` of ``t`` (not empty).

    Returns
    -------
    str

    Examples
    --------
    >>> import numpy as np
    >>> t = np.delete(np.arange(100) * 1e-4, [50, 70, 71])
    >>> gap_text(t, step_gaps(t))
    '2 gaps (3 samples missing), the first at data row 51 (t = 0.0051 s, a step of 0.0002 s, 2 periods of 0.0001 s)'
    """
    d = np.diff(t)
    step = float(np.median(d))
    missing = int(np.sum(np.maximum(np.rint(d[gaps] / step) - 1, 1)))
    i = int(gaps[0])
    return (f"{gaps.size} gap{'s' if gaps.size > 1 else ''} ({missing} sample"
            f"{'s' if missing > 1 else ''} missing), the first at data row {i + 2} (t = "
            f"{t[i + 1]:.10g} s, a step of {d[i]:.6g} s, {d[i] / step:.3g} periods of "
            f"{step:.6g} s)")
