"""Judging one learning trial against another from noisy measured records.

``hammerstein learn --history`` keeps the best trial so far and does not
learn from a trial that is worse than it. On hardware only the measured
error ``e_m = e + n`` is known (``e`` the true tracking error, ``n`` the
sensor's noise): a judgement must call a trial worse only when it is worse
beyond what the noise can explain. For a reference that does not repeat
(a raster with a stepped slow axis) nothing can be averaged over periods,
and its max error is mostly noise near convergence: the max of ``|n|`` over
N samples of Gaussian noise grows like ``sigma sqrt(2 ln N)`` (4.6 sigma
for N = 3e4: 0.18 µm for 40 nm, against a true error of about 0.05 µm),
and two measurements of the same drive differ by a good part of it.

The judgement here is on the mean square instead, with the noise's power
removed (:func:`trial_error`, :func:`compare_trials`)::

    S^2 = mean_t ||e_m(t)||^2 - sum_l sigma_l^2        (an unbiased estimate of mean ||e||^2)

``sigma_l`` estimated from the measured record itself
(:func:`white_noise_sigma`: its content above the band the reference, the
actuator and the learning produce, white noise assumed). ``S`` is the RMS
Euclidean error less the noise; its own noise is small and known: for
white Gaussian noise ``Var(mean_t ||e_m||^2) = (4 sum_l sigma_l^2 mean e_l^2
+ 2 sum_l sigma_l^4) / N``, of relative size ``sqrt(2 / N)`` (1 % for
N = 3e4) where the max's is tens of per cent.

References
----------
.. [1] J. S. Bendat and A. G. Piersol, "Random data: analysis and measurement
   procedures", 4th ed., Wiley, 2010 (Sec. 8.2: variance of mean-square and
   spectral estimates, degrees of freedom of a filtered record).
.. [2] P. D. Welch, "The use of fast Fourier transform for the estimation of power
   spectra", IEEE Trans. Audio Electroacoustics 15(2), 70-73, 1967.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.exceptions import CompensatorError

__all__ = ["NoiseLevel", "TrialError", "TrialComparison", "white_noise_sigma", "trial_error",
           "compare_trials"]

#: samples per segment of the Welch spectrum of the noise estimate (78 Hz lines at 20 kHz)
SEGMENT = 256
#: asymptotic variance of a median over that of a mean of Gaussian estimates (pi / 2)
MEDIAN_EFFICIENCY = np.pi / 2.0


@dataclass(frozen=True)
class NoiseLevel:
    """White measurement noise estimated from a record.

    Parameters
    ----------
    sigma : numpy.ndarray, shape (p,)
        Standard deviation per output [µm] (the record's unit).
    dof : float
        Degrees of freedom of each ``sigma ** 2`` (the record's real samples
        in the band it was estimated from).
    band_hz : tuple of float
        The band ``(low, high)`` [Hz] it was estimated from.
    """

    sigma: np.ndarray
    dof: float
    band_hz: tuple


def white_noise_sigma(signal_, sampling_period, low_hz=None):
    """Standard deviation of white noise in a record, from its content above ``low_hz``.

    The record's Welch spectrum (Hann segments of :data:`SEGMENT` samples,
    half overlap, each segment's mean removed; Welch 1967) is taken per
    output; the median over the lines from ``low_hz`` to Nyquist of the
    one-sided density ``S(f)`` gives ``sigma^2 = S fs / 2`` (white noise
    has ``S = 2 sigma^2 / fs`` everywhere). What the reference, the
    actuator (its bending modes) or the learning put into that band is a
    few lines (harmonics, a mode's peak): the median leaves them out,
    where a mean over the band would count them as noise.

    Assumes white noise: a sensor that low-passes its noise within the
    band (e.g. a 2 kHz sensor bandwidth) makes ``sigma`` too small.

    Parameters
    ----------
    signal_ : array_like, shape (p, n_samples)
        The record (or the measured error) [µm].
    sampling_period : float
        T [s].
    low_hz : float, optional
        Lower edge of the band [Hz]; default ``fs / 4`` (the upper half of
        the Nyquist band).

    Returns
    -------
    NoiseLevel

    Raises
    ------
    CompensatorError
        Fewer than two segments of samples, or a band with fewer than 4
        lines (``low_hz`` too close to Nyquist).

    Examples
    --------
    >>> import numpy as np
    >>> n = np.random.default_rng(0).normal(0.0, 0.04, (2, 20000))
    >>> s = white_noise_sigma(n + 5.0 * np.sin(np.arange(20000) / 300.0), 5e-5)
    >>> bool(np.all(np.abs(s.sigma / 0.04 - 1.0) < 0.05))
    True
    """
    x = np.atleast_2d(np.asarray(signal_, dtype=float))
    fs = 1.0 / float(sampling_period)
    if x.shape[1] < 2 * SEGMENT:
        raise CompensatorError(f"noise estimate: expected at least {2 * SEGMENT} samples, found "
                               f"{x.shape[1]}")
    low = fs / 4.0 if low_hz is None else float(low_hz)
    f, S = _scipy_signal().welch(x, fs=fs, window="hann", nperseg=SEGMENT, noverlap=SEGMENT // 2,
                                 detrend="constant", axis=-1)
    band = (f >= low) & (f < fs / 2.0)
    if np.count_nonzero(band) < 4:
        raise CompensatorError(f"noise estimate: the band {low:g} Hz to Nyquist ({fs / 2:g} Hz) "
                               f"holds fewer than 4 spectral lines; choose a lower edge")
    sigma = np.sqrt(np.median(S[:, band], axis=1) * fs / 2.0)
    dof = x.shape[1] * float(np.count_nonzero(band)) / (SEGMENT // 2 + 1) / MEDIAN_EFFICIENCY
    return NoiseLevel(sigma, dof, (low, fs / 2.0))


@dataclass(frozen=True)
class TrialError:
    """The measured error of one trial over its judged window.

    Parameters
    ----------
    mean_square : numpy.ndarray, shape (p,)
        ``mean_t e_m,l(t)^2`` per output, noise included [µm^2].
    samples : int
        N, the samples of the window.
    noise : NoiseLevel
        The noise estimated from the same samples.
    """

    mean_square: np.ndarray
    samples: int
    noise: NoiseLevel

    @property
    def score(self):
        """``S``, the RMS Euclidean error less the noise [µm].

        ``sqrt(max(0, sum_l (m_l - sigma_l^2)))``, as
        :func:`compare_trials` scores a trial.
        """
        return float(np.sqrt(max(float(np.sum(self.mean_square - self.noise.sigma ** 2)), 0.0)))


def trial_error(error, sampling_period, low_hz=None):
    """The mean square and the noise of a trial's measured error.

    Parameters
    ----------
    error : array_like, shape (p, n_samples)
        ``e_m = y_r - y_measured`` over the judged window (after the
        settling) [µm].
    sampling_period : float
        T [s].
    low_hz : float, optional
        Lower edge of the noise band (:func:`white_noise_sigma`).

    Returns
    -------
    TrialError

    Raises
    ------
    CompensatorError
        A window too short for the noise estimate.
    """
    e = np.atleast_2d(np.asarray(error, dtype=float))
    return TrialError(np.mean(e ** 2, axis=1), int(e.shape[1]),
                      white_noise_sigma(e, sampling_period, low_hz))


@dataclass(frozen=True)
class TrialComparison:
    """A trial judged against the best one so far.

    Parameters
    ----------
    score, best_score : float
        ``S``: the RMS Euclidean error less the noise, ``sqrt(max(0, mean
        ||e_m||^2 - sum sigma^2))`` [µm], of the trial and of the best.
    margin : float
        [µm]: the trial is worse when ``score > worse * best_score + margin``.
    worse : bool
        Worse than ``worse`` times the best beyond the noise.
    better : bool
        Its noise-free mean square is below the best's (the new best).
    sigma : numpy.ndarray, shape (p,)
        The pooled noise per output [µm].
    """

    score: float
    best_score: float
    margin: float
    worse: bool
    better: bool
    sigma: np.ndarray


def compare_trials(trial, best, worse=1.1, z=3.0):
    """Is ``trial`` more than ``worse`` times ``best``'s error beyond the noise?

    On the mean squares (``w = worse``): with the noise's variance pooled
    over both records (one sensor), ``s^2 = sum_l (sigma_l,k^2 +
    sigma_l,b^2) / 2``, the statistic::

        D = (m_k - s^2) - w^2 (m_b - s^2)

    is ``mean ||e_k||^2 - w^2 mean ||e_b||^2`` in expectation, positive
    exactly when the trial's true RMS error is more than ``w`` times the
    best's. Its variance under white Gaussian noise (Bendat and Piersol
    2010, Sec. 8.2) is ``Var m_k + w^4 Var m_b + (1 - w^2)^2 Var s^2``, with
    ``Var m = (4 sum_l sigma_l^2 max(0, m_l - sigma_l^2) + 2 sum_l
    sigma_l^4) / N`` and ``Var s^2 = sum_l 2 sigma_l^4 / dof_l`` (the
    noise estimate's error enters with ``1 - w^2``, 0.21: it moves both
    trials alike). The trial is worse when ``D > z sqrt(Var D)``: noise
    alone calls a trial worse than an equal one with probability
    ``1 - Phi(z)`` (0.13 % for z = 3).

    Parameters
    ----------
    trial, best : TrialError
        Of the same outputs.
    worse : float
        w > 1 (default 1.1: 10 % worse in RMS).
    z : float
        Standard deviations of ``D`` that noise may explain (default 3).

    Returns
    -------
    TrialComparison

    Raises
    ------
    CompensatorError
        Records of different outputs.
    """
    mk, mb = np.asarray(trial.mean_square, float), np.asarray(best.mean_square, float)
    if mk.shape != mb.shape:
        raise CompensatorError(f"compare_trials: {mk.size} outputs against {mb.size}")
    s2 = (trial.noise.sigma ** 2 + best.noise.sigma ** 2) / 2.0        # per output
    dof = trial.noise.dof + best.noise.dof

    def var_m(m, n):
        return float(4.0 * np.sum(s2 * np.maximum(m - s2, 0.0)) + 2.0 * np.sum(s2 ** 2)) / n

    w2 = float(worse) ** 2
    dk, db = float(np.sum(mk - s2)), float(np.sum(mb - s2))
    var = var_m(mk, trial.samples) + w2 ** 2 * var_m(mb, best.samples) \
        + (1.0 - w2) ** 2 * float(np.sum(2.0 * s2 ** 2 / dof))
    sd = float(np.sqrt(var))
    score, best_score = float(np.sqrt(max(dk, 0.0))), float(np.sqrt(max(db, 0.0)))
    margin = float(np.sqrt(max(w2 * max(db, 0.0) + z * sd, 0.0)) - np.sqrt(w2) * best_score)
    return TrialComparison(score, best_score, margin, bool(dk - w2 * db > z * sd), dk < db,
                           np.sqrt(s2))


def _scipy_signal():
    """scipy.signal, imported on first use (about 0.3 s)."""
    import scipy.signal
    return scipy.signal
