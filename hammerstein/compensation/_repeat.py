"""The lag at which a periodic record repeats itself, for its continuation past its end.

A reference of period ``T0`` sampled every ``T`` repeats a whole number of
samples earlier only when ``T0 / T`` is an integer. Otherwise (150 Hz at
50 kHz: 333.3 samples) it repeats ``m`` periods earlier, with ``m T0 / T``
the first integer multiple (``m = 3``: 1000 samples), exactly for a sampled
periodic function. :func:`repeat_lag` finds that lag from the record and the
rounded period the callers carry, so that the ZPETC preview and the stable
inversion read the record's own continuation instead of an extrapolation
whose error the inverse of the dynamics amplifies (±1 V over the last
samples of a 150 Hz circle at 50 kHz on a stage with modes at 2.1 and
2.6 kHz).
"""

import numpy as np

__all__ = ["MAX_PERIODS", "REPEAT_SAMPLES", "repeat_lag", "kept_samples", "continuation",
           "continuations", "record_period"]

#: The most periods :func:`repeat_lag` looks back (a frequency f at a sampling rate fs, both
#: whole hertz, repeats after ``f / gcd(f, fs)`` periods: 3 for 150 Hz at 50 kHz).
MAX_PERIODS = 32

#: The last samples that must repeat one lag earlier.
REPEAT_SAMPLES = 8


def kept_samples(period_samples):
    """Samples a streaming caller keeps for :func:`repeat_lag`: the longest lag it tests
    plus :data:`REPEAT_SAMPLES` (3 without a period: the quadratic extrapolation's)."""
    if not period_samples:
        return 3
    return int(MAX_PERIODS * (int(period_samples) + 0.5)) + REPEAT_SAMPLES


def repeat_lag(record, period_samples, samples):
    """The lag [samples] one or more periods back at which a record's end repeats.

    Parameters
    ----------
    record : numpy.ndarray, shape (p, n_samples)
        [µm].
    period_samples : int or None
        The reference's period rounded to whole samples ``P``.
    samples : int
        How many samples the continuation reads: the lag is at least that.

    Returns
    -------
    int or None
        ``P`` when the last :data:`REPEAT_SAMPLES` samples equal those ``P``
        samples earlier (to 1e-9 µm, or 1e-9 of the record's largest
        magnitude); else the smallest lag ``L`` within half a sample per
        period of ``m P`` (``m`` = 2 .. :data:`MAX_PERIODS`, the true period
        being within half a sample of ``P``) at which they do; None when
        there is no period, the record is too short or no lag repeats (a
        spiral, a record cut at an arbitrary sample).
    """
    r = record
    N = r.shape[1]
    K = REPEAT_SAMPLES
    if not period_samples or period_samples < samples or N < period_samples + K:
        return None
    P = int(period_samples)
    last = r[:, N - K:]
    d = np.abs(last - r[:, N - P - K:N - P])
    # |d| <= atol without np.allclose's overhead; the record's maximum (a pass over it) is
    # needed only when the differences are above 1e-9
    if np.all(d <= 1e-9):
        return P
    scale = max(max(r.max(), -r.min()), 1.0)
    if np.all(d <= 1e-9 * scale):
        return P
    m = np.arange(2, MAX_PERIODS + 1)
    lo, hi = np.ceil(m * (P - 0.5)).astype(int), np.floor(m * (P + 0.5)).astype(int)
    lags = np.unique(np.concatenate([np.arange(a, b + 1) for a, b in zip(lo, hi)]))
    lags = lags[(lags >= samples) & (lags + K <= N)]
    if lags.size == 0:
        return None
    idx = (N - K - lags)[:, None] + np.arange(K)                  # (n_lags, K)
    same = np.all(np.abs(r[:, idx] - last[:, None, :]) <= 1e-9 * scale, axis=(0, 2))
    hit = np.flatnonzero(same)
    return int(lags[hit[0]]) if hit.size else None


#: The most candidate lags :func:`record_period` checks over the whole record.
MAX_CANDIDATES = 16


def record_period(record, min_repeats=2):
    """The shortest lag [samples] by which a whole record repeats itself, or None.

    A reference file that holds a pattern several times over (a 1 s spiral
    played four times) is periodic whether or not its period was given. The
    lags at which the last :data:`REPEAT_SAMPLES` samples recur earlier are
    the candidates (one vectorised pass per sample of that window); the
    shortest of the first :data:`MAX_CANDIDATES` at which every sample
    equals the one that lag earlier (to 1e-9 of the record's largest
    magnitude) is returned. Held ends (the window constant: a staircase that
    ends on a hold would match every earlier hold) are not periodic here.

    Parameters
    ----------
    record : numpy.ndarray, shape (p, n_samples)
        [µm].
    min_repeats : int
        The pattern must fill the record at least this many times.

    Returns
    -------
    int or None
        The lag L (``record[:, L:] == record[:, :-L]``), at most
        ``n_samples / min_repeats``; None when there is none.

    Examples
    --------
    >>> t = np.arange(1000) / 250.0
    >>> record_period(np.vstack([np.sin(2 * np.pi * t), t % 1.0]))
    250
    >>> record_period(np.vstack([t, t])) is None
    True
    """
    r = np.asarray(record, dtype=float)
    N = r.shape[1]
    K = REPEAT_SAMPLES
    longest = N // max(int(min_repeats), 1)
    if N < 2 * K or longest < K:
        return None
    tol = 1e-9 * max(float(np.max(np.abs(r))), 1.0)
    last = r[:, N - K:]
    if np.all(np.abs(last - last[:, :1]) <= tol):
        return None
    # window starts i with r[:, i:i+K] == last, for lags N - K - i from K to `longest`
    starts = np.arange(N - K - longest, N - 2 * K + 1)
    starts = starts[starts >= 0]
    hit = np.ones(starts.size, dtype=bool)
    for k in range(K):
        hit &= np.all(np.abs(r[:, starts + k] - last[:, k:k + 1]) <= tol, axis=0)
    for lag in np.sort(N - K - starts[hit])[:MAX_CANDIDATES]:
        if np.all(np.abs(r[:, lag:] - r[:, :N - lag]) <= tol):
            return int(lag)
    return None


def continuation(reference, samples, period_samples=None):
    """The ``samples`` reference samples that follow a record.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].
    samples : int
        How many.
    period_samples : int, optional
        Period of a periodic reference, rounded to whole samples: the
        continuation is the record one period earlier when its last 8
        samples repeat those one period earlier, or as many periods earlier
        as a period of a fractional number of samples needs
        (:func:`~hammerstein.compensation._repeat.repeat_lag`: 3 periods for
        150 Hz at 50 kHz); otherwise (a spiral) a quadratic extrapolation of
        the last three samples (exact for polynomials of degree 2).

    Returns
    -------
    numpy.ndarray, shape (p, samples)
    """
    r = np.asarray(reference, dtype=float)
    N = r.shape[1]
    if samples <= 0:
        return np.zeros((r.shape[0], 0))
    lag = repeat_lag(r, period_samples, samples)
    if lag is not None:
        return r[:, N - lag:N - lag + samples].copy()
    if N < 3:
        return np.repeat(r[:, -1:], samples, axis=1)
    k = np.arange(1, samples + 1)
    a, b, c = r[:, -3], r[:, -2], r[:, -1]
    # Newton forward form through (-2, a), (-1, b), (0, c)
    return (c[:, None] + np.outer(c - b, k)
            + np.outer((c - 2 * b + a) / 2.0, k * (k + 1)))


def continuations(records, samples, period_samples=None):
    """:func:`continuation` of several records at once (the same values, bit for bit).

    Parameters
    ----------
    records : sequence of numpy.ndarray, each shape (p, n_samples_b)
        [µm]; the same p for all, lengths may differ.
    samples : int
        How many samples follow each record.
    period_samples : sequence of (int or None), optional
        Period of each record (None: not periodic); None for none of them.

    Returns
    -------
    list of numpy.ndarray, each shape (p, samples)
        In the order of ``records``.
    """
    B = len(records)
    periods = [None] * B if period_samples is None else list(period_samples)
    out = [None] * B
    if samples <= 0:
        return [np.zeros((r.shape[0], 0)) for r in records]
    # periodic records whose last 8 samples repeat one or more periods earlier
    for b in range(B):
        lag = repeat_lag(records[b], periods[b], samples)
        if lag is not None:
            N = records[b].shape[1]
            out[b] = records[b][:, N - lag:N - lag + samples].copy()
    rest = [b for b in range(B) if out[b] is None]
    short = [b for b in rest if records[b].shape[1] < 3]
    for b in short:
        out[b] = np.repeat(records[b][:, -1:], samples, axis=1)
    quad = [b for b in rest if records[b].shape[1] >= 3]
    if quad:
        last3 = np.stack([records[b][:, -3:] for b in quad])      # (Q, p, 3)
        a, b_, c = last3[:, :, 0, None], last3[:, :, 1, None], last3[:, :, 2, None]
        k = np.arange(1, samples + 1)
        # Newton forward form through (-2, a), (-1, b), (0, c), as continuation()
        ext = c + (c - b_) * k + ((c - 2 * b_ + a) / 2.0) * (k * (k + 1))
        for i, b in enumerate(quad):
            out[b] = ext[i]
    return out
