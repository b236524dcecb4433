"""What a longer smoothing window is worth, and whether the holds of a point-to-point move fit it.

:func:`~hammerstein.compensation.shaping.shape_reference` doubles its
smoothing window while that lowers the drive's excess over the amplifier's
limits. Some excess no window lowers: a jump of the drive where the
reference leaves what the model reaches (a staircase from 0 µm on an
actuator whose model starts at 5 µm at 0 V: the drive jumps by 12.5 V in
one sample whatever the window). :func:`excess_left_to_limiter` finds it,
so that it stops the doubling (a user's 10 µm / 50 ms
staircase was smoothed over 62.4 ms, 16 periods of its 258.5 Hz mode,
for one such jump, and never reached its levels). :func:`hold_note` says
when a hold of the reference is shorter than the window it was smoothed
over.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STUCK_FRACTION", "MIN_HOLD_SAMPLES", "excess_events", "excess_left_to_limiter",
           "hold_note"]

#: The fewest samples a run of equal reference samples needs to be a hold (a scan's ramps move
#: every sample, and a turn-around may repeat one: no hold)
MIN_HOLD_SAMPLES = 3

#: an excess whose peak over its event is more than this fraction of what it was with half the
#: window is not the window's to remove: a slope-driven excess, ``max(k s - S, 0)`` for a drive
#: slope ``k s``, peaks at less than half when the window doubles (the peak slope ``s`` halves)
STUCK_FRACTION = 0.5


def excess_events(mask, width):
    """Label the events of a mask: its True samples, merged when fewer than ``width`` apart.

    Parameters
    ----------
    mask : array_like of bool, shape (n_samples,)
    width : int
        Samples each True is widened by on either side [samples].

    Returns
    -------
    numpy.ndarray of int, shape (n_samples,)
        0 outside the events, ``1 .. n_events`` inside (the widened span).

    Examples
    --------
    >>> excess_events([0, 1, 0, 0, 0, 0, 0, 1, 0], 1).tolist()
    [1, 1, 1, 0, 0, 0, 2, 2, 2]
    """
    m = np.asarray(mask, dtype=bool)
    w = max(int(width), 0)
    near = np.convolve(m.astype(float), np.ones(2 * w + 1), "same") > 0.5
    starts = near & ~np.concatenate([[False], near[:-1]])
    return np.where(near, np.cumsum(starts), 0)


def excess_left_to_limiter(before, after, width):
    """Samples whose excess a doubled window does not remove: it did not halve.

    The events of ``before > 0`` (:func:`excess_events`, widened by the
    doubled window: its excess moves by up to that much) are compared with
    ``after`` over the same span. An event is left to the drive's slew
    limit when its peak excess with the doubled window is more than
    :data:`STUCK_FRACTION` of what it was (a jump no window lowers).

    Parameters
    ----------
    before, after : array_like, shape (n_samples,)
        The drive's excess over the limits per sample with the window and
        with the doubled window [V] (:func:`~hammerstein.compensation.shaping.limit_excess`).
    width : int
        The doubled window [samples].

    Returns
    -------
    numpy.ndarray of bool, shape (n_samples,)
        True over the events left to the limiter.

    Examples
    --------
    A jump of 11 V that a doubled window leaves as it is, and a 3 V excess it removes:

    >>> b = np.array([0, 11, 0, 0, 0, 0, 0, 0, 3.0, 0])
    >>> a = np.array([0, 0, 10.5, 0, 0, 0, 0, 0, 0, 0])
    >>> np.flatnonzero(excess_left_to_limiter(b, a, 2)).tolist()
    [0, 1, 2, 3]
    """
    b = np.asarray(before, dtype=float)
    a = np.asarray(after, dtype=float)
    events = excess_events(b > 0, width)
    out = np.zeros(b.size, dtype=bool)
    for k in range(1, int(events.max(initial=0)) + 1):
        span = events == k
        was, now = float(b[span].max()), float(a[span].max())
        if now > STUCK_FRACTION * was:
            out |= span
    return out


def hold_note(raw, shaped, window, sampling_period, names=None, lead=0, unit="µm"):
    """A note per output whose holds are shorter than the smoothing window, or none.

    A hold is a run of at least :data:`MIN_HOLD_SAMPLES` equal samples of
    ``raw`` between two moves (after the first ``lead`` samples at rest,
    before the last move). A zero-phase
    window of ``window`` samples reaches a level only where it is at least
    half a window from both moves: a hold shorter than the window is left
    before its level is reached.

    Parameters
    ----------
    raw, shaped : array_like, shape (p, n_samples)
        The reference asked for and the shaped one [µm].
    window : int
        The smoothing window [samples].
    sampling_period : float
        T [s].
    names : sequence of str, optional
        Output names (default ``output 1``, ...).
    lead : int
        Samples at rest before the reference moves.
    unit : str
        The reference's unit, the model's output unit (``HammersteinPlant.units[1]``): the
        miss's in the note.

    Returns
    -------
    list of str
        One line per output with a hold shorter than ``window`` whose end
        the shaped reference misses (the shortest hold, where, the window,
        and the largest miss at a hold's end [``unit``]).

    Examples
    --------
    >>> r = np.repeat([[0.0, 1.0, 2.0, 1.0]], 5, axis=1)
    >>> s = r + np.array([[0, 0, 0, 0, 0.1] * 3 + [0] * 5])
    >>> hold_note(r, s, 8, 0.001, ["x"])
    ['x: holds of 5 ms (at 0.005 s, and 1 more) are shorter than the 8 ms smoothing window: the shaped reference ends them up to 0.1 µm from their levels']
    """
    r = np.array(raw, dtype=float, ndmin=2)
    s = np.array(shaped, dtype=float, ndmin=2)
    T, n = float(sampling_period), r.shape[1]
    out = []
    for i in range(r.shape[0]):
        scale = max(1.0, float(np.max(np.abs(r[i])))) if n else 1.0
        moves = np.flatnonzero(np.abs(np.diff(r[i])) > 1e-9 * scale) + 1     # first sample after a move
        moves = moves[moves > lead]
        if moves.size < 2:
            continue
        starts, ends = moves[:-1], moves[1:]                  # holds [start, end) between moves
        held = ends - starts
        # a hold stays put for at least MIN_HOLD_SAMPLES samples: a scan's samples between two
        # moves (1 sample each) are none ("holds of 0.05 ms, and 1208 more" on a raster)
        short = (held < int(window)) & (held >= MIN_HOLD_SAMPLES)
        miss = np.abs(s[i, ends - 1] - r[i, ends - 1])
        hit = short & (miss > 1e-6 * scale)
        if not np.any(hit):
            continue
        name = names[i] if names is not None else f"output {i + 1}"
        k = np.flatnonzero(hit)
        first = k[np.argmin(held[k])]
        more = k.size - 1
        out.append(f"{name}: holds of {held[first] * T * 1e3:.3g} ms (at {starts[first] * T:.4g} s"
                   + (f", and {more} more" if more else "") + f") are shorter than the "
                   f"{window * T * 1e3:.3g} ms smoothing window: the shaped reference ends them up to "
                   f"{float(miss[k].max()):.3g} {unit} from their levels")
    return out
