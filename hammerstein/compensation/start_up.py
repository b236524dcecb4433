"""A start-up that steps faster than the settled drive, shaped in the reference.

A hardware drive's start-up (the fade-in and one period after it) must
never step faster than the settled drive's own largest step. An axis held
still beside a moving one (z and focus at mid-range under an x-y circle)
settles with tiny steps, but its fade-in from rest to mid-range asks for
much larger ones. Slew-limiting the drive after the compensator bounds
them, but the drive is then no longer what the compensator computes for
the written reference, and the exported C (and FMU), fed that reference,
do not reproduce it (measured on a four-axis preset: 17 V on the held
input during the start-up). :func:`start_up_in_reference` changes the
reference instead, by the model's prediction of what the limit changes,
until the compensator's own drive for it keeps within the bound.
"""

from __future__ import annotations

import numpy as np

from hammerstein.models.amplifier import slew_limit

#: the start-up is aimed at this fraction of the settled drive's largest step: the
#: compensator's drive for the corrected reference misses the aim by the model's
#: inversion error (measured: 5e-4 V on a 0.0131 V bound), and a margin settles it in
#: fewer passes (2-4 at 0.95; at 0.98, ten passes left it 1 % over)
START_UP_AIM = 0.95
#: most passes of the compensator over the record for the start-up's correction
START_UP_PASSES = 8


def _settled_steps(u, end):
    """Largest step per input from sample ``end`` on [V] (inf without two samples)."""
    if u.shape[1] - end < 2:
        return np.full(u.shape[0], np.inf)
    return np.max(np.abs(np.diff(u[:, end:], axis=1)), axis=1)


def _start_steps(u, end, rest):
    """Largest step per input of samples ``0 .. end - 1``, the first counted from ``rest``."""
    head = np.concatenate([rest[:, None], u[:, :max(end, 1)]], axis=1)
    return np.max(np.abs(np.diff(head, axis=1)), axis=1)


def start_up_in_reference(run, inputs, reference, end, rest, predict, tol=1e-6,
                          passes=START_UP_PASSES):
    """The reference corrected so that the compensator's start-up keeps within the settled steps.

    Per pass, the inputs whose start-up (samples before ``end``, the first
    step counted from ``rest``) steps more than ``(1 + tol)`` times the
    settled drive's largest step ``S`` (from ``end`` on) are slew-limited
    to ``START_UP_AIM * S`` before ``end``; the reference is changed by
    the model's predicted output change, ``predict(limited) -
    predict(drive)``, in full up to the sample where the limited drive
    has caught up, then faded out with a raised cosine by ``end``; and the
    compensator is run again (``run``). The reference from ``end`` on (the
    settled part, which is judged) is never changed.

    Parameters
    ----------
    run : callable
        ``run(reference) -> inputs (m, n_samples)``: the compensator's drive
        from rest [V].
    inputs : array_like, shape (m, n_samples)
        ``run(reference)`` [V].
    reference : array_like, shape (p, n_samples)
        The faded (and shaped) reference [µm].
    end : int
        First sample of the settled part (the fade-in's end plus one period).
    rest : array_like, shape (m,)
        The voltages before the first sample [V].
    predict : callable
        ``predict(inputs) -> outputs (p, n_samples)``: the model from rest [µm].
    tol : float
        Relative excess over ``S`` left as it is.
    passes : int
        Most compensator passes.

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        ``run(reference)`` for the returned reference [V]: the inputs given
        when nothing was changed.
    reference : numpy.ndarray, shape (p, n_samples)
        [µm].
    asked : numpy.ndarray, shape (m,)
        The start-up's largest step before the correction [V].
    bound : numpy.ndarray, shape (m,)
        ``S`` of the returned inputs [V].
    changed : bool
        Whether the reference was changed (the start-up's excess reduced;
        it may remain beyond ``tol`` after ``passes``, the best pass kept).

    Examples
    --------
    A static gain of 2 V/µm; the settled drive steps 0.1 V, the start-up 1 V.

    >>> r = np.r_[0.0, np.full(29, 0.5), 0.5 + 0.05 * (np.arange(10) % 2)][None, :]
    >>> u, ref, asked, S, changed = start_up_in_reference(
    ...     lambda x: 2 * x, 2 * r, r, 30, np.zeros(1), lambda v: v / 2)
    >>> changed, float(asked[0]), bool(np.max(np.abs(np.diff(np.r_[0.0, u[0]]))) <= S[0])
    (True, 1.0, True)
    >>> bool(np.array_equal(u, 2 * ref)), bool(np.array_equal(ref[:, 30:], r[:, 30:]))
    (True, True)
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    R = np.array(reference, dtype=float, ndmin=2)
    r0 = np.asarray(rest, dtype=float)
    N, end = u.shape[1], int(end)
    S = _settled_steps(u, end)
    asked = _start_steps(u, end, r0)
    excess = np.max(asked / S)
    if end >= N - 1 or not np.all(np.isfinite(S) & (S > 0)) or excess <= 1 + tol:
        return u, R, asked, S, False
    best = (excess, u, R, S)
    changed = False
    k = np.arange(N)
    for _ in range(int(passes)):
        bad = np.flatnonzero(_start_steps(u, end, r0) > S * (1 + tol))
        if bad.size == 0:
            break
        aim = u.copy()
        for i in bad:
            aim[i, :end] = slew_limit(u[i, :end], r0[i], START_UP_AIM * S[i])
        moved = np.flatnonzero(np.any(aim != u, axis=0))
        caught = int(moved[-1]) + 1
        if caught >= end:     # the limited drive never catches up within the start-up
            break
        w = np.clip((end - k) / (end - caught), 0.0, 1.0)
        w = 0.5 - 0.5 * np.cos(np.pi * w)          # 1 up to the catch-up, 0 from end on
        R = R + w * (np.asarray(predict(aim), dtype=float) - np.asarray(predict(u), dtype=float))
        u = np.asarray(run(R), dtype=float)
        S = _settled_steps(u, end)
        if not np.all(np.isfinite(S) & (S > 0)):
            break
        excess = np.max(_start_steps(u, end, r0) / S)
        if excess < best[0]:
            best, changed = (excess, u, R, S), True
        if excess <= 1 + tol:
            break
    _, u, R, S = best
    return u, R, asked, S, changed
