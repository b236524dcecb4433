"""Errors of learning trials: summaries, delays, periodic averages and signal-to-noise (behind :mod:`hammerstein.compensation.ilc`).

The error of a trial is ``e(t) = y_r(t) - y_k(t + d)`` [µm], arrays of shape
(n_outputs, n_samples); a periodic reference's error is averaged over its
periods to separate what repeats (what learning can remove) from the noise
(Bristow, Tharayil and Alleyne 2006; the references of
:mod:`hammerstein.compensation.ilc`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.exceptions import CompensatorError


#: samples of error continued past the record's end before the inverse and Q
EXTENSION = 64


@dataclass
class ConvergenceCondition:
    """The monotonic-convergence condition ``||I - gamma Q L G|| <= 1`` over frequency.

    Parameters
    ----------
    frequencies : numpy.ndarray, shape (n_f,)
        [Hz], up to Nyquist.
    per_axis : numpy.ndarray, shape (p, n_f)
        ``|I - gamma Q L G|_ll``.
    coupled : numpy.ndarray, shape (n_f,)
        Largest singular value of ``I - gamma Q L G``.
    passband : numpy.ndarray of bool, shape (n_f,), optional
        Where Q passes (``|Q|^2 >= 1/2``): the band the summary reports.
        Above it ``gamma Q`` vanishes and the condition is 1 whatever the
        learning does, so its maximum over every frequency said nothing
        (1.000 at Nyquist on every trial). None: every frequency.
    """

    frequencies: np.ndarray
    per_axis: np.ndarray
    coupled: np.ndarray
    passband: np.ndarray | None = None

    def __repr__(self):
        # the arrays hold thousands of frequencies: their maxima, not every value
        return (f"ConvergenceCondition({self.frequencies.size} frequencies up to "
                f"{float(np.max(self.frequencies)) if self.frequencies.size else 0.0:g} Hz, "
                f"max per axis {np.round(self.max_per_axis, 4).tolist()}, "
                f"max coupled {self.max_coupled:.4g}, holds={self.holds})")

    @property
    def max_per_axis(self):
        """numpy.ndarray, shape (p,): the largest value over frequency, per axis."""
        return np.max(self.per_axis, axis=1)

    @property
    def max_coupled(self) -> float:
        """The largest value of the coupled condition over frequency."""
        return float(np.max(self.coupled))

    @property
    def holds(self) -> bool:
        """True when the coupled condition is at most 1 at every frequency (below 1 where Q passes)."""
        return self.max_coupled <= 1.0 + 1e-6

    @property
    def exceeds(self):
        """(lowest, highest) frequency [Hz] where the coupled condition exceeds 1, or None."""
        f = self.frequencies[self.coupled > 1.0 + 1e-6]
        return (float(f.min()), float(f.max())) if f.size else None

    def summary(self, outputs):
        """One line: the maxima per axis and coupled, and where the coupled one is.

        Parameters
        ----------
        outputs : list of str
            Output names.

        Returns
        -------
        str
        """
        band = (np.ones(self.frequencies.shape, dtype=bool) if self.passband is None
                 else np.asarray(self.passband, dtype=bool))
        if not band.any():
            band = np.ones(self.frequencies.shape, dtype=bool)
        idx = np.flatnonzero(band)
        k = int(idx[np.argmax(self.coupled[idx])])
        top = float(self.coupled[k])
        axes = ", ".join(f"{n} {v:.3f}" for n, v in zip(outputs, np.max(self.per_axis[:, idx],
                                                                          axis=1)))
        where = ("over frequency" if band.all() else
                 f"over the harmonics Q passes (the highest at "
                 f"{float(self.frequencies[idx].max()):.4g} Hz, below Q's cutoff)")
        if not self.holds:      # the verdict's own quantity: the maximum over every frequency
            k = int(np.argmax(self.coupled))
            axes = ", ".join(f"{n} {v:.3f}" for n, v in zip(outputs, self.max_per_axis))
            lo, hi = self.exceeds
            outside = ("" if band[k] else
                       f"; above Q's passband, where |Q|^2 < 1/2; at most {top:.3f} where Q passes")
            return (f"max over frequency of ||I - gamma Q L G||: {axes}, coupled "
                    f"{self.max_coupled:.3f} at {self.frequencies[k]:.4g} Hz (> 1: NOT "
                    f"guaranteed: above 1 from {lo:.4g} to {hi:.4g} Hz{outside})")
        if top < 1.0 - 1e-6:
            verdict = "<= 1: monotonic"
        else:
            verdict = "= 1 where Q passes: no contraction there"
        return (f"max {where} of ||I - gamma Q L G||: {axes}, coupled {top:.3f} "
                f"at {self.frequencies[k]:.4g} Hz ({verdict})")


@dataclass
class IterationRecord:
    """Error of one trial.

    Parameters
    ----------
    iteration : int
        k (0 = the initial drive).
    max_error : numpy.ndarray, shape (p,)
        ``max |e_l|`` over the evaluation window [µm].
    rms_error : numpy.ndarray, shape (p,)
        [µm].
    max_euclidean_error : float
        ``max ||e||`` [µm].
    """

    iteration: int
    max_error: np.ndarray
    rms_error: np.ndarray
    max_euclidean_error: float




def error_summary(reference, outputs, window=slice(None), iteration=0):
    """Max and RMS tracking error per axis and the max Euclidean error over a window.

    Parameters
    ----------
    reference, outputs : array_like, shape (p, n_samples)
        [µm].
    window : slice
        Samples evaluated.
    iteration : int

    Returns
    -------
    IterationRecord
    """
    e = (np.asarray(reference, dtype=float) - np.asarray(outputs, dtype=float))[:, window]
    return IterationRecord(int(iteration), np.max(np.abs(e), axis=1), np.sqrt(np.mean(e ** 2, axis=1)),
                           float(np.max(np.linalg.norm(e, axis=0))))


def estimate_delay(reference, measured, max_lag):
    """Delay of a measured record behind a reference, by normalised cross-correlation [samples].

    The lag ``k`` in ``-L..L`` (``L = min(max_lag, (n - 1) // 3)``) that
    maximises the normalised cross-correlation over one fixed window of the
    reference, ``t = L .. n - L - 1``::

        rho(k) = sum_t a(t) b(t + k) / sqrt(sum_t b(t + k)^2)

    ``a``, ``b`` the channels (stacked) with their means over the window
    removed. By the Cauchy-Schwarz inequality ``rho(k)`` is largest where
    ``b(t + k)`` is proportional to ``a(t)``: a record that is the reference
    delayed by ``d`` samples (``d <= L``, the first samples held at rest)
    gives exactly ``d``. The plain sum ``sum_t a(t) b(t + k)`` over the
    overlap ``n - |k|`` is biased towards 0 by the shrinking overlap, by
    ``P^2 / (4 pi^2 n)`` samples for a sinusoid of P samples (2 samples
    found short for a 10 Hz circle of 12 periods at 20 kHz). Cross-correlation
    delay estimation: C. H. Knapp and G. C. Carter, IEEE Trans. ASSP 24(4),
    320-327, 1976.

    For a reference that repeats with period P, a delay is found only
    modulo P: keep ``max_lag`` below P / 2.

    Parameters
    ----------
    reference, measured : array_like, shape (p, n_samples)
        [any unit, the same for both]; ``measured`` at least as long as
        ``reference`` (only its first n_samples are used).
    max_lag : int
        Largest delay searched (both signs) [samples].

    Returns
    -------
    int
        d > 0 when ``measured(t) ~ reference(t - d)``; 0 for a constant record.

    Examples
    --------
    >>> import numpy as np
    >>> r = np.sin(np.arange(500) / 7.0)[None] * np.hanning(500)
    >>> estimate_delay(r, np.roll(r, 4, axis=1), 20)
    4
    """
    a = np.atleast_2d(np.asarray(reference, dtype=float))
    n = a.shape[1]
    b = np.atleast_2d(np.asarray(measured, dtype=float))[:, :n]
    L = int(max(0, min(int(max_lag), (n - 1) // 3)))
    W = n - 2 * L
    if W < 2:
        return 0
    aw = a[:, L:n - L]
    aw = aw - aw.mean(axis=1, keepdims=True)
    # sum over channels and window of a(t) b(t + k), k = -L..L: one 'valid' correlation per channel
    cross = sum(_scipy_signal().correlate(b[i], aw[i], mode="valid") for i in range(a.shape[0]))
    c1 = np.concatenate([np.zeros((b.shape[0], 1)), np.cumsum(b, axis=1)], axis=1)
    c2 = np.concatenate([np.zeros((b.shape[0], 1)), np.cumsum(b * b, axis=1)], axis=1)
    s1 = c1[:, W:] - c1[:, :-W]                 # window sums of b from each start s = 0..2L
    s2 = c2[:, W:] - c2[:, :-W]
    energy = np.sum(np.maximum(s2 - s1 * s1 / W, 0.0), axis=0)    # of b minus its window mean
    scale = np.max(energy) if energy.size else 0.0
    if not scale > 0:
        return 0
    rho = np.where(energy > 1e-12 * scale, cross / np.sqrt(np.maximum(energy, 1e-300)), -np.inf)
    return int(np.argmax(rho)) - L


def periodic_average(signal_, period_samples, start):
    """The part of a record from ``start`` on replaced by its average over the periods.

    Parameters
    ----------
    signal_ : array_like, shape (p, n_samples)
    period_samples : int
        P.
    start : int
        First sample of the periodic part.

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
        Samples before ``start`` unchanged; sample ``start + j P + i`` = the
        mean of the samples ``start + j' P + i`` over every j' in the record.

    Examples
    --------
    >>> periodic_average([[9.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]], 2, 1)
    array([[9., 3., 4., 3., 4., 3., 4.]])
    """
    x = np.array(signal_, dtype=float)
    P, s = int(period_samples), int(start)
    n = x.shape[1] - s
    if P < 1 or n < 2 * P:
        return x
    idx = np.arange(n) % P
    part = x[:, s:]
    sums = np.zeros((x.shape[0], P))
    counts = np.bincount(idx, minlength=P)
    for r in range(x.shape[0]):
        sums[r] = np.bincount(idx, weights=part[r], minlength=P)
    x[:, s:] = (sums / counts)[:, idx]
    return x


def periodic_snr(error, period_samples, start, weights=None):
    """Energy of the period-averaged error over the energy the noise alone would leave in it.

    The record from ``start`` on holds ``n_p`` whole periods; their mean
    ``ebar`` (p, P) is the repeatable error, the residuals about it the
    non-periodic part (noise), of variance ``sigma^2`` per sample
    (``n_p - 1`` degrees of freedom). Averaging leaves ``sigma^2 / n_p``
    of noise per sample of ``ebar``, so

        ``rho = mean(ebar^2) / (sigma^2 / n_p)``

    is 1 in expectation when the record is noise only, ``1 + SNR`` otherwise.
    ``1 - 1 / rho`` is then the Wiener factor of the update (the share of
    the averaged error that is not noise; Wiener, "Extrapolation,
    interpolation and smoothing of stationary time series", 1949): learning
    ``(1 - 1/rho)`` of a measured error ``E + N`` leaves, in expectation,
    ``|E|^2 |N|^2 / (|E|^2 + |N|^2)``, less than both the error and the
    noise (exact model), so a trial at the noise floor moves the drive
    little and the next trial cannot get much worse.

    Parameters
    ----------
    error : array_like, shape (p, n_samples)
        ``e = y_r - y`` [µm].
    period_samples : int
        P.
    start : int
        First sample of the periodic part.
    weights : array_like, shape (P // 2 + 1,), optional
        Weight per harmonic of the period (the learning's band, e.g. its
        gains ``gamma |Q(f_h)|``): ``rho`` is then the weighted energy of
        the averaged error's harmonics over that of the noise
        (:func:`periodic_error`), so that the noise outside the band the
        learning acts on does not hide the error inside it. Default: every
        harmonic alike (the time-domain form above).

    Returns
    -------
    float
        ``rho`` (``inf`` with fewer than two periods or no residual).

    Examples
    --------
    >>> import numpy as np
    >>> n = np.random.default_rng(0).normal(0.0, 1.0, (2, 100 * 400))
    >>> bool(abs(periodic_snr(n, 400, 0) - 1.0) < 0.1)
    True
    >>> i = np.arange(100 * 400)
    >>> bool(periodic_snr(n + 0.3 * np.cos(2 * np.pi * i / 400), 400, 0) > 4.0)
    True
    """
    e = np.asarray(error, dtype=float)
    P, s = int(period_samples), int(start)
    n_p = (e.shape[1] - s) // P if P > 0 else 0
    if P < 2 or n_p < 2:
        return np.inf
    seg = e[:, s:s + n_p * P].reshape(e.shape[0], n_p, P)
    mean = seg.mean(axis=1)
    sigma2 = float(np.sum((seg - mean[:, None, :]) ** 2) / (e.shape[0] * P * (n_p - 1)))
    if sigma2 <= 0.0:
        return np.inf
    if weights is None:
        return float(np.mean(mean ** 2) / (sigma2 / n_p))
    w = np.asarray(weights, dtype=float)
    spectrum = np.fft.rfft(mean, axis=1) * (2.0 / P)
    noise2 = 4.0 * sigma2 / (P * n_p)               # expected |E_h|^2 of noise, per output
    denominator = float(np.sum(w) * e.shape[0] * noise2)
    if denominator <= 0.0:
        return np.inf
    return float(np.sum(w * np.sum(np.abs(spectrum) ** 2, axis=0)) / denominator)


def periodic_error(error, period_samples, start):
    """One period of a periodic error averaged over the periods, its spectrum and its noise.

    The record from ``start`` on holds ``n_p`` whole periods (a partial last
    one is left out); their mean is the periodic (repeatable) error, what
    is left is the non-periodic part: measurement noise and whatever does
    not repeat from one period to the next.

    Parameters
    ----------
    error : array_like, shape (p, n_samples)
        ``e = y_r - y`` [µm].
    period_samples : int
        P.
    start : int
        First sample of the periodic part.

    Returns
    -------
    spectrum : numpy.ndarray, shape (p, P // 2 + 1), complex
        ``E_h = (2 / P) sum_i ebar_i exp(-2 pi j h i / P)``: harmonic h of the
        averaged period, amplitude [µm] (``E_0 / 2`` is the mean).
    noise : float
        Expected amplitude [µm] of a harmonic of the averaged period due to
        the non-periodic part alone, ``2 sigma / sqrt(P n_p)`` for white
        noise of standard deviation ``sigma`` (estimated from the residuals
        with ``n_p - 1`` degrees of freedom); ``inf`` with fewer than two
        periods.

    Raises
    ------
    CompensatorError
        Less than one period from ``start`` on.

    Examples
    --------
    >>> import numpy as np
    >>> i = np.arange(400)
    >>> E, noise = periodic_error([3.0 * np.cos(2 * np.pi * i / 100)], 100, 0)
    >>> round(float(abs(E[0, 1])), 6), bool(noise < 1e-12)
    (3.0, True)
    """
    e = np.asarray(error, dtype=float)
    P, s = int(period_samples), int(start)
    n_p = (e.shape[1] - s) // P
    if P < 2 or n_p < 1:
        raise CompensatorError(f"periodic_error: expected at least one period of {P} samples "
                               f"from sample {s}, found {e.shape[1] - s} samples")
    seg = e[:, s:s + n_p * P].reshape(e.shape[0], n_p, P)
    mean = seg.mean(axis=1)
    spectrum = np.fft.rfft(mean, axis=1) * (2.0 / P)
    if n_p < 2:
        return spectrum, np.inf
    sigma = float(np.sqrt(np.sum((seg - mean[:, None, :]) ** 2) / (e.shape[0] * P * (n_p - 1))))
    return spectrum, 2.0 * sigma / np.sqrt(P * n_p)




def period_drift(error, period_samples, start):
    """How much of the periods' spread about their mean is a slow drift over the periods [µm].

    The whole periods from ``start`` on, ``e_k(i)`` (period k, sample i of
    the period), spread about their mean by ``s`` (RMS over the samples and
    periods, the non-periodic part :func:`periodic_error` takes for noise).
    Fitting each sample's values over the periods with a polynomial in k
    (degree 2 from six periods on, 1 from four; least squares) leaves ``d``:
    what changes from one period to the next without a trend. Noise,
    white or coloured, independent from period to period, gives ``s ~ d``;
    creep or a transient still settling (the same in every trial, so no
    noise to learning over trials) gives ``s >> d``.

    Parameters
    ----------
    error : array_like, shape (p, n_samples)
        ``e = y_r - y`` [µm].
    period_samples : int
        P.
    start : int
        First sample of the periodic part.

    Returns
    -------
    tuple of float or None
        ``(s, d)`` [µm], the largest over the outputs; None with fewer
        than four whole periods.

    Examples
    --------
    >>> import numpy as np
    >>> i = np.arange(800)
    >>> e = [0.5 * np.sin(2 * np.pi * i / 100) + 1e-3 * i]       # a drift of 0.1 um a period
    >>> s, d = period_drift(e, 100, 0)          # s = 0.1 sqrt(sum (k - 3.5)^2 / 7) = 0.1 sqrt(6)
    >>> round(s, 4), d < 1e-12
    (0.2449, True)
    """
    e = np.atleast_2d(np.asarray(error, dtype=float))
    P, s0 = int(period_samples), int(start)
    n_p = (e.shape[1] - s0) // P if P > 1 else 0
    if n_p < 4:
        return None
    seg = e[:, s0:s0 + n_p * P].reshape(e.shape[0], n_p, P)
    spread = seg - seg.mean(axis=1, keepdims=True)
    degree = 2 if n_p >= 6 else 1
    q, _ = np.linalg.qr(np.vander(np.arange(n_p) - (n_p - 1) / 2.0, degree + 1))
    left = seg - np.einsum("kj,lj,plq->pkq", q, q, seg)
    s = np.sqrt(np.sum(spread ** 2, axis=(1, 2)) / (P * (n_p - 1)))
    d = np.sqrt(np.sum(left ** 2, axis=(1, 2)) / (P * (n_p - degree - 1)))
    return float(np.max(s)), float(np.max(d))


def repeating_from(target, period_samples, fade_samples):
    """First sample of the periodic learning of a reference that repeats after its fade-in, or None.

    Parameters
    ----------
    target : array_like, shape (p, n_samples)
        The faded reference [µm].
    period_samples : int or None
        P.
    fade_samples : int
        Fade-in [samples].

    Returns
    -------
    int or None
        ``max(fade, P) + 2 P`` (two periods after the fade-in: the start-up
        transient is learnt in the time domain) when the reference repeats
        from ``max(fade, P)`` on with at least five periods there; else None.

    Examples
    --------
    >>> import numpy as np
    >>> c = np.vstack([np.cos(2 * np.pi * np.arange(1000) / 100)])
    >>> repeating_from(c, 100, 100), repeating_from(c[:, :500], 100, 100)
    (300, None)
    """
    r = np.atleast_2d(np.asarray(target, dtype=float))
    n = r.shape[1]
    if not period_samples or period_samples < 2:
        return None
    P = int(period_samples)
    w0 = int(min(max(fade_samples, P), n - 1))
    if n < w0 + 5 * P or not np.allclose(r[:, w0 + P:], r[:, w0:n - P], rtol=0,
                                         atol=1e-9 * max(float(np.max(np.abs(r))), 1.0)):
        return None
    return w0 + 2 * P




def _scipy_signal():
    """scipy.signal, imported on first use (about 0.3 s; a plain preset simulation never needs it)."""
    import scipy.signal
    return scipy.signal
