"""Splicing a learnt drive into the previous one: its start faded in, its end held.

An iterative-learning update is least informed at the record's two ends:
at the start the reference itself is faded in from rest (not judged), and
at the end the measurement's delay leaves samples unmeasured while the
update's filters read past the record. :func:`keep_start` and
:func:`keep_end` keep the previous drive's behaviour there, so that every
learnt drive starts at rest and takes no step of its own at its end.
"""

from __future__ import annotations

import numpy as np

__all__ = ["keep_start", "keep_end", "learning_onset"]


def learning_onset(n_samples, fade_samples, period_samples=None):
    """The first sample from which :func:`keep_start` passes the learnt drive whole.

    Before it the learnt change is blended in at a share below 1 (not at all
    at the end of the fade-in without a period): what the start-up's error is
    there is not what the learning corrects, and ``hammerstein learn`` judges
    a trial from this sample on at the earliest.

    Parameters
    ----------
    n_samples : int
        The record's length [samples].
    fade_samples : int
    period_samples : int, optional
        As for :func:`keep_start`; 0, 1 or None: no period.

    Returns
    -------
    int
        ``fade + period`` with a period, else ``fade + max(n_samples // 10, 1)``
        [samples] (beyond the record when the fade-in ends within its last
        tenth).

    Examples
    --------
    >>> learning_onset(80000, 20000), learning_onset(8000, 400, 800)
    (28000, 1200)
    """
    fade = max(int(fade_samples), 0)
    periodic = bool(period_samples) and int(period_samples) > 1
    blend = int(period_samples) if periodic else max(int(n_samples) // 10, 1)
    return fade + blend


def keep_start(previous, learnt, fade_samples, period_samples=None):
    """A learnt drive that starts as the previous one and is faded into the learning as the reference is.

    ``u = (1 - b) u_prev + b u_learnt``. For a periodic reference ``b`` is
    a raised cosine from 0 at the first sample to 1 one period after the
    fade-in: a learnt drive starts at rest as the first one did, and the
    learnt correction sets in as gently as the reference itself, over the
    fade-in that is not judged. Without a period, ``b`` rises from 0 at the
    end of the fade-in to 1 a tenth of the record (at least one sample)
    later (:func:`learning_onset`: the error before it is not all learnt, nor
    judged). Blended in over one period after the fade-in only
    (10 ms for a 100 Hz circle), the correction's onset rang the lightly
    damped modes into the judged periods; measured on an outside
    Preisach-type actuator (first mode 313 Hz, damping 0.035), 10 trials on
    a 30 µm circle at 100 Hz ended at 1.11 % of the radius, 0.31 of its
    0.33 µm a start-up transient, against 0.32 % with the correction faded in
    over the fade-in (generalised-PI actuator: 0.30 -> 0.26 %).

    Parameters
    ----------
    previous, learnt : array_like, shape (m, n_samples)
        [V].
    fade_samples : int
    period_samples : int, optional

    Returns
    -------
    numpy.ndarray, shape (m, n_samples)
        [V].

    Examples
    --------
    >>> np.round(keep_start([[0.0, 1.0, 2.0, 3.0]], [[9.0, 9.0, 9.0, 9.0]], 1, 2)[0], 9).tolist()
    [0.0, 3.0, 7.25, 9.0]
    """
    u0 = np.atleast_2d(np.asarray(previous, dtype=float))
    u1 = np.atleast_2d(np.asarray(learnt, dtype=float))
    N = u0.shape[1]
    fade = max(int(fade_samples), 0)
    periodic = bool(period_samples) and int(period_samples) > 1
    blend = learning_onset(N, fade, period_samples) - fade   # b reaches 1 at learning_onset
    k = np.arange(N)
    b = np.clip(k / (fade + blend) if periodic else (k - fade) / blend, 0.0, 1.0)
    b = 0.5 * (1.0 - np.cos(np.pi * b))
    return (1.0 - b) * u0 + b * u1


def keep_end(previous, learnt, bound):
    """A learnt drive whose last samples keep the learnt change of the last informed one.

    ``u = prev + d`` (``d = u_learnt - prev``), and over the last ``n``
    samples ``u = prev + d[N - n - 1]``: the previous drive's own steps
    with the learnt change held, no step of its own. ``n`` is at least 8
    samples, doubled (to at most a tenth of the record) while the learnt
    change steps by more than ``bound`` where it would be held. The last samples of a learnt update are its least
    informed: the measurement's delay leaves them unmeasured and the
    update's filters and inverse read past the record's end. Learnt sample
    by sample, a raster's drive ended with steps of 1.03 V per sample on an
    input whose settled steps were 0.07 V. Blended back to the previous
    drive itself (``d_n = 0``), a drive ending in a hold snapped back to the
    first trial's voltage over its last 40 samples (a pick-and-place move:
    6.9 -> 4.96 V, 3.7 µm off at the end).

    Parameters
    ----------
    previous, learnt : array_like, shape (m, n_samples)
        [V].
    bound : array_like, shape (m,)
        Largest step per input of the learnt change where it is held [V]
        (the settled drive's).

    Returns
    -------
    numpy.ndarray, shape (m, n_samples)
        [V].

    Examples
    --------
    A learnt change of 5 V that falls to 0 V in the last 5 samples (past
    the record's end): held at the 5 V it had, so a hold keeps its learnt
    voltage and the drive takes no step.

    >>> u = keep_end([[0.0] * 400], [[5.0] * 395 + [0.0] * 5], [1.0])
    >>> float(u[0, 383]), float(u[0, -1]), float(np.max(np.abs(np.diff(u[0]))))
    (5.0, 5.0, 0.0)
    """
    u0 = np.atleast_2d(np.asarray(previous, dtype=float))
    u1 = np.atleast_2d(np.asarray(learnt, dtype=float))
    N = u0.shape[1]
    top = max(N // 10, 1)
    if N < 2:
        return u1
    d = u1 - u0
    s = np.maximum(np.asarray(bound, dtype=float), 1e-12)

    n = min(8, N - 1)
    # the last informed sample: where the learnt change itself steps within the bound
    while n < top and np.any(np.abs(d[:, N - n - 1] - d[:, N - n - 2]) > s):
        n = min(2 * n, top)
    u = u0 + d
    u[:, N - n:] = u0[:, N - n:] + d[:, N - n - 1][:, None]
    return u
