"""Where a reference asks for content at or above the first bending mode (behind
:mod:`hammerstein.compensation.shaping`, whose band limit smooths those samples).

A signal with no content above ``f`` obeys Bernstein's inequalities: its
acceleration is at most ``2 pi f`` times its largest speed, which is at most
``2 pi f`` times its largest distance from mid-range. The second bound alone
(a sine at the mode of half the range) catches a step, never a turn of a
scan: a raster's fast axis reverses its speed ``v`` within one sample, a
sampled acceleration of ``2 v / T`` that stays below it for line rates below
``(2 pi f)^2 T / 8`` (16 Hz at a 180 Hz mode and 10 kHz, whatever the size);
only the turns where the slow axis stepped were smoothed, and each other turn
became a 12-33 V spike of the drive through the stable inverse of the
dynamics. The speed bound catches every such turn: ``2 v / T`` is ``1 / (pi f
T)`` times (18 times) ``2 pi f v``, and a turn between two samples at least half that.
"""

from __future__ import annotations

import numpy as np

__all__ = ["faster_than_mode", "FLAT_FRACTION", "SPEED_MARGIN"]

#: the speed bound is taken this many times: a reference faded in from rest, or growing (a
#: spiral), accelerates a little more than a sine of its largest speed (the raised cosine of a
#: fade of one period ends with a jump of its curvature worth up to ``pi^2 / (2 (2 pi)^2)``, an
#: eighth, of the sine's acceleration); a turn on a sample exceeds the bound without it ``1 /
#: tan(pi f_1 T)`` times (17.7 at a 180 Hz mode and 10 kHz), one between two samples at least
#: half that: above this margin for modes below 0.12 of the sampling rate (a window of 9
#: samples or more)
SPEED_MARGIN = 1.25

#: second differences below this fraction of an output's largest value [µm per µm] are rounding,
#: not motion: an output held still (to the last bits) is never flagged by its own speed bound
FLAT_FRACTION = 1e-9


def faster_than_mode(reference, first_mode, sampling_period):
    """Samples where a reference accelerates more than a signal below the first mode can.

    A sine of amplitude ``A`` at ``f`` accelerates at most ``(2 pi f)^2 A``
    and ``2 pi f`` times its largest speed. A reference whose acceleration
    (second difference over ``T^2``) exceeds either bound, per output, with
    ``A`` half its range and its largest speed (first difference over
    ``T``), asks for content at or above the first mode ``f_1``, which an
    inverse of the identified dynamics reproduces only as well as the mode
    was identified: a raster's line steps (the range bound) and every turn
    of its fast axis, where the slow axis steps or not (the speed bound); a
    circle below ``f_1`` never does. The speed bound is the sampled one,
    ``2 tan(pi f_1 T) / T`` times the largest sampled speed (a sampled sine
    at ``f <= f_1`` reaches at most ``2 tan(pi f T) / T`` times the largest
    speed its samples show: its peak speed falls between samples by up to
    half a sample's phase), times :data:`SPEED_MARGIN` (a fade-in).

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
        True where any output exceeds either bound (never the first and last
        sample, nor an output whose second differences are below
        :data:`FLAT_FRACTION` of its largest value).

    Examples
    --------
    >>> T, f1 = 1e-4, 300.0
    >>> t = np.arange(400) * T
    >>> bool(np.any(faster_than_mode([np.sin(2 * np.pi * 250 * t)], f1, T)))
    False
    >>> np.flatnonzero(faster_than_mode([np.r_[np.zeros(5), np.ones(5)]], f1, T)).tolist()
    [4, 5]

    A triangle of 400 samples a leg (12.5 Hz at 10 kHz) turns within one sample:

    >>> tri = np.r_[np.arange(400.0), 400.0 - np.arange(400.0)]
    >>> np.flatnonzero(faster_than_mode([tri], f1, T)).tolist()
    [400]
    """
    r = np.array(reference, dtype=float, ndmin=2)
    out = np.zeros(r.shape[1], dtype=bool)
    if r.shape[1] < 3:
        return out
    T, f = float(sampling_period), float(first_mode)
    d2 = np.abs(r[:, 2:] - 2 * r[:, 1:-1] + r[:, :-2])
    speed = np.max(np.abs(np.diff(r, axis=1)), axis=1)                   # [µm per sample]
    by_range = (2 * np.pi * f * T) ** 2 * 0.5 * (r.max(axis=1) - r.min(axis=1))
    by_speed = (SPEED_MARGIN * 2 * np.tan(np.pi * f * T) * speed if f * T < 0.5
                else np.full(r.shape[0], np.inf))
    bound = np.minimum(by_range, by_speed) * (1 + 1e-9)
    flat = FLAT_FRACTION * np.maximum(np.max(np.abs(r), axis=1), 1.0)
    out[1:-1] = np.any((d2 > bound[:, None]) & (d2 > flat[:, None]), axis=0)
    return out
