"""Where a reference asks for content at or above the first bending mode (behind
:mod:`hammerstein.compensation.shaping`, whose band limit smooths those samples)."""

from __future__ import annotations

import numpy as np

__all__ = ["faster_than_mode"]


def faster_than_mode(reference, first_mode, sampling_period):
    """Samples where a reference accelerates more than a sine at the first mode would.

    A sine of amplitude ``A`` at ``f`` accelerates at most ``(2 pi f)^2 A``;
    a reference whose acceleration (second difference over ``T^2``)
    exceeds ``(2 pi f_1)^2 A`` with ``A`` half its range asks for content
    at or above the first mode ``f_1``, which an inverse of the identified
    dynamics reproduces only as well as the mode was identified (a
    raster's line steps and corners; a circle below ``f_1`` never does).

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    first_mode : float
        [Hz].
    sampling_period : float
        T [s].

    Returns
    -------
    numpy.ndarray of bool, shape (n_samples,)
        True where any output exceeds the bound (never the first and last
        sample).

    Examples
    --------
    >>> T, f1 = 1e-4, 300.0
    >>> t = np.arange(400) * T
    >>> bool(np.any(faster_than_mode([np.sin(2 * np.pi * 250 * t)], f1, T)))
    False
    >>> np.flatnonzero(faster_than_mode([np.r_[np.zeros(5), np.ones(5)]], f1, T)).tolist()
    [4, 5]
    """
    r = np.array(reference, dtype=float, ndmin=2)
    out = np.zeros(r.shape[1], dtype=bool)
    if r.shape[1] < 3:
        return out
    acc = np.abs(r[:, 2:] - 2 * r[:, 1:-1] + r[:, :-2]) / float(sampling_period) ** 2
    half = 0.5 * (r.max(axis=1) - r.min(axis=1))
    bound = (2 * np.pi * float(first_mode)) ** 2 * half
    out[1:-1] = np.any(acc > bound[:, None] * (1 + 1e-9), axis=0)
    return out
