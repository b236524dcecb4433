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
#: a start-up stepping at most this much beyond the settled drive's largest step is left to
#: the slew limit after the compensator (a sample or two, a few mV): corrected in the
#: reference, a circle's start-up 0.5 % over (0.193 against 0.192 V per sample) moved the
#: reference by 1.3 µm over 0.04 s of the judged part, and the outside family's gpi-9 30 µm
#: circle at 100 Hz went from 0.97 to 3.61 % of the radius; a held axis's fade to mid-range
#: asks 40 times its settled step
START_UP_MIN_EXCESS = 0.05
#: an input whose settled steps stay within this fraction of the drive's largest settled
#: voltage is held (:func:`settled_bound`): rounding, or a law's last iterations, move it by
#: 1e-17-1e-11 of it, where a slow motion (a 1 V, 0.1 Hz sine on a 100 V offset at 20 kHz)
#: steps 3e-7 of it
HELD_STEP = 1e-8


def _settled_steps(u, end):
    """Largest step per input from sample ``end`` on [V] (inf without two samples)."""
    if u.shape[1] - end < 2:
        return np.full(u.shape[0], np.inf)
    return np.max(np.abs(np.diff(u[:, end:], axis=1)), axis=1)


def settled_bound(inputs, end):
    """The step each input's start-up must keep within: its settled drive's largest [V].

    An input held once settled (a reference that holds an axis away from rest, or a law
    whose held input moves by rounding only: 2.4e-11 V per sample on a 1.41 V hold) has
    no settled step of its own to reach its hold with; it takes the largest settled step
    of the inputs that move (``inf`` when none moves). Held: its settled steps at most
    :data:`HELD_STEP` of the drive's largest settled voltage (any input's). Measured: a
    diagonal law holding y at 5 µm beside a 50 Hz sine on x was slew-limited to its
    2.4e-11 V and never left rest (a 53 % miss), and the fade-in was doubled to a
    quarter of the record for it.

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        The drive [V].
    end : int
        First sample of the settled part.

    Returns
    -------
    numpy.ndarray, shape (m,)
        [V] per sample; ``inf`` with fewer than two settled samples.

    Examples
    --------
    >>> settled_bound([[0.0, 1.0, 1.5, 1.0], [0.0, 2.0, 2.0, 2.0]], 1).tolist()
    [0.5, 0.5]
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    S = _settled_steps(u, int(end))
    if not np.all(np.isfinite(S)):
        return S
    # against the drive's largest settled voltage: an input held at 0 V moves by rounding
    # of the others' (1e-17 V; its own level, 0, called that motion and kept a 0.5 V
    # start-up at rest, a reviewer's case)
    level = float(np.max(np.abs(u[:, int(end):])))
    held = S <= HELD_STEP * level
    S[held] = np.max(S[~held]) if not held.all() else np.inf
    return S


def _start_steps(u, end, rest):
    """Largest step per input of samples ``0 .. end - 1``, the first counted from ``rest``."""
    head = np.concatenate([rest[:, None], u[:, :max(end, 1)]], axis=1)
    return np.max(np.abs(np.diff(head, axis=1)), axis=1)


def start_up_in_reference(run, inputs, reference, fade, end, rest, predict, tol=1e-6,
                          passes=START_UP_PASSES, min_excess=START_UP_MIN_EXCESS):
    """The reference corrected so that the compensator's start-up keeps within the settled steps.

    Per pass, the inputs whose start-up (samples before ``stop``, at first
    ``end``; the first step counted from ``rest``) steps more than
    ``(1 + tol)`` times the settled drive's largest step ``S`` (from
    ``stop`` on) are slew-limited to ``START_UP_AIM * S`` until they catch
    up with the drive after its last step beyond that; the reference is changed by the model's predicted
    output change, ``predict(limited) - predict(drive)``, in full up to
    that catch-up, then faded out with a raised cosine over
    ``max(end - fade, fade // 2)`` samples (``stop``: never before
    ``end``); and the compensator is run again (``run``). The reference
    from ``stop`` on is never changed: from ``end`` on (the settled part,
    which is judged) only when the limited drive catches up after it (an
    axis held far from rest that the settled steps take longer to reach),
    as a drive slew-limited after the compensator would be changed there.

    Parameters
    ----------
    run : callable
        ``run(reference) -> inputs (m, n_samples)``: the compensator's drive
        from rest [V].
    inputs : array_like, shape (m, n_samples)
        ``run(reference)`` [V].
    reference : array_like, shape (p, n_samples)
        The faded (and shaped) reference [µm].
    fade : int
        The fade-in [samples].
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
    min_excess : float
        A start-up no more than ``1 + min_excess`` times ``S`` is returned
        unchanged (left to the slew limit after the compensator).

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
    stop : int
        The first sample from which the reference is unchanged (and ``S``
        measured).
    changed : bool
        Whether the reference was changed (the start-up's excess reduced;
        it may remain beyond ``tol`` after ``passes`` or a pass that does not
        reduce it, the best pass kept).

    Examples
    --------
    A static gain of 2 V/µm; the settled drive steps 0.1 V, the start-up 1 V.

    >>> r = np.r_[0.0, np.full(29, 0.5), 0.5 + 0.05 * (np.arange(10) % 2)][None, :]
    >>> u, ref, asked, S, stop, changed = start_up_in_reference(
    ...     lambda x: 2 * x, 2 * r, r, 20, 30, np.zeros(1), lambda v: v / 2)
    >>> changed, float(asked[0]), bool(np.max(np.abs(np.diff(np.r_[0.0, u[0]]))) <= S[0])
    (True, 1.0, True)
    >>> bool(np.array_equal(u, 2 * ref)), bool(np.array_equal(ref[:, 30:], r[:, 30:]))
    (True, True)
    """
    u = np.array(inputs, dtype=float, ndmin=2)
    R = np.array(reference, dtype=float, ndmin=2)
    r0 = np.asarray(rest, dtype=float)
    N, end = u.shape[1], int(end)
    taper = max(end - int(fade), int(fade) // 2, 1)
    stop = end
    S = settled_bound(u, stop)
    asked = _start_steps(u, stop, r0)
    # (an input held once settled, S = 0, stopped every correction with numpy's
    # divide-by-zero warning on compensate's stderr: settled_bound gives it the moving ones')
    if end >= N - 1 or not np.all(np.isfinite(S)):
        return u, R, asked, S, stop, False
    excess = np.max(asked / S)
    if excess <= 1 + max(tol, min_excess):
        return u, R, asked, S, stop, False
    best = (excess, u, R, S, stop)
    changed = False
    k = np.arange(N)
    for _ in range(int(passes)):
        bad = np.flatnonzero(_start_steps(u, stop, r0) > S * (1 + tol))
        if bad.size == 0:
            break
        aim, caught = u.copy(), 0
        for i in bad:
            aim[i], c = _limit_until_caught(u[i], r0[i], S[i] * (1 + tol), START_UP_AIM * S[i],
                                            stop)
            caught = max(caught, c)
        # the correction in full up to the catch-up, faded out over ``taper`` samples after it
        # and never before ``end``; what the drive then does from ``stop`` on bounds its steps
        stop = max(stop, caught + taper)
        if stop >= N - 1:     # the limited drive never catches up within the record
            break
        w = np.clip((stop - k) / (stop - caught), 0.0, 1.0)
        w = 0.5 - 0.5 * np.cos(np.pi * w)          # 1 up to the catch-up, 0 from stop on
        R = R + w * (np.asarray(predict(aim), dtype=float) - np.asarray(predict(u), dtype=float))
        u = np.asarray(run(R), dtype=float)
        S = settled_bound(u, stop)
        if not np.all(np.isfinite(S)):
            break
        excess = np.max(_start_steps(u, stop, r0) / S)
        if excess >= best[0]:     # no better than the best pass: stalled (a pass is a whole run)
            break
        best, changed = (excess, u, R, S, stop), True
        if excess <= 1 + tol:
            break
    _, u, R, S, stop = best
    return u, R, asked, S, stop, changed


def _limit_until_caught(x, rest, bound, step, end):
    """``x`` slew-limited to ``step`` from ``rest`` until it catches up with ``x`` after its
    last step beyond ``bound`` before ``end``; ``x`` itself from there on, and that sample."""
    steps = np.abs(np.diff(np.concatenate([[rest], x])))
    beyond = np.flatnonzero(steps[:end] > bound)
    if beyond.size == 0:
        return x.copy(), 0
    a = slew_limit(x, rest, step)
    met = np.flatnonzero(a[beyond[-1]:] == x[beyond[-1]:])
    c = x.size if met.size == 0 else int(beyond[-1] + met[0])
    out = x.copy()
    out[:c] = a[:c]
    return out, c


def export_slew_words(before, after, end, sampling_period, amplifier=None):
    """What makes the exported C reproduce a start-up slew-limited after the compensator.

    :func:`~hammerstein.compensation.drive.limit_start_up` slew-limits each
    input whose start-up steps faster than its settled part to ``S``, the
    settled part's largest step (from ``end`` on); the exported C applies
    the same limit, ``amp += clip(x - amp, -S, S)`` from the rest voltage
    (:func:`hammerstein.export.c_base._limits_code`), when exported with the
    slew rate ``S / T`` on those inputs. The other inputs keep the
    amplifier's slew rate, or without one a rate above their largest step
    (the limit never acts there); without an amplifier range, a range
    holding 0 V and the drive before and after the limit goes with it
    (``--slew-rate`` needs one).

    Parameters
    ----------
    before, after : array_like, shape (m, n_samples)
        The drive before and after the start-up's limit [V].
    end : int
        First sample of the settled part.
    sampling_period : float
        T [s].
    amplifier : hammerstein.models.amplifier.Amplifier, optional

    Returns
    -------
    str
        ``"; the exported C gives this drive, fed its reference, when exported
        with [--amplifier-range MIN MAX] --slew-rate R1,R2"`` (the end of the
        limit's note), or ``""`` when no input was limited.

    Examples
    --------
    >>> export_slew_words([[0.0, 3.0, 3.5, 3.0]], [[0.0, 0.5, 1.0, 1.5]], 1, 0.5)
    '; the exported C gives this drive, fed its reference, when exported with --amplifier-range 0 4 --slew-rate 1.0'
    """
    u = np.array(before, dtype=float, ndmin=2)
    v = np.array(after, dtype=float, ndmin=2)
    limited = np.any(u != v, axis=1)
    if not np.any(limited):
        return ""
    T = float(sampling_period)
    bound = settled_bound(u, end)
    rest = np.zeros(u.shape[0]) if amplifier is None else amplifier.rest_voltages()
    largest = np.max(np.abs(np.diff(np.concatenate([rest[:, None], v], axis=1), axis=1)), axis=1)
    rates = []
    for i in range(u.shape[0]):
        own = None if amplifier is None else amplifier.channels[i].slew_rate
        rates.append(bound[i] / T if limited[i] else
                     own if own is not None and np.isfinite(own) else 2.0 * max(largest[i], 1e-6) / T)
    ranged = amplifier is not None and all(np.isfinite(c.low) and np.isfinite(c.high)
                                           for c in amplifier.channels)
    # the C clips the compensator's voltages to the range before the slew limit: both held
    span = "" if ranged else (f" --amplifier-range {np.floor(min(0.0, u.min(), v.min())):.0f} "
                              f"{np.ceil(max(0.0, u.max(), v.max())):.0f}")
    return ("; the exported C gives this drive, fed its reference, when exported with"
            f"{span} --slew-rate " + ",".join(repr(float(r)) for r in rates))


def at_rest_while_previewing(reference, preview):
    """Whether the exported C's preview fills at rest: the reference holds its first value over
    ``preview + 1`` samples (a faded reference's rest lead).

    The exported C returns the rest voltages for its first ``preview`` calls
    (``NAME_PREVIEW``) and computes its first voltage at sample ``preview``;
    the compensator in Python, run from sample 0, would first compute the
    inverse of the rest output, which its root search's tolerance leaves up
    to about 3e-10 V from rest (a Preisach inverse on a bundled preset), and
    every later root starts from there: the C and the drive then differed by
    up to 1e-10 V while the fade-in left rest (4e-11 of the drive's peak).
    Where this holds, :func:`hammerstein.compensation.drive.hardware_drive`
    runs the compensator from sample ``preview`` and holds the rest voltages
    before it, as the C does.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    preview : int
        The compensator's ``preview_samples``.

    Returns
    -------
    bool

    Examples
    --------
    >>> at_rest_while_previewing(np.zeros((2, 5)), 3), at_rest_while_previewing(np.arange(5.0)[None], 3)
    (True, False)
    """
    r = np.asarray(reference, dtype=float)
    P = int(preview)
    return 0 < P < r.shape[1] and bool(np.all(r[:, :P + 1] == r[:, :1]))
