"""Model-based iterative learning control (ILC) of a multivariable Hammerstein actuator.

For a trajectory that repeats (rasters, circles, Lissajous), each trial k
applies the drive ``u_k`` (m, N) [V], measures ``y_k`` (p, N) [µm] and
learns the next drive from the error ``e_k = y_r - y_k``. The learning
runs on the model's PI output ``v = Gamma(u)`` (the input of the linear
dynamics), where the Hammerstein model ``y = G Gamma(u)`` is linear::

    v_k     = Gamma(u_k)                                  (the model, from rest)
    v_{k+1} = v_k + Q( gamma G^-1 e_k )
    u_{k+1} = Gamma^c(v_{k+1})                            (the exact inverse PI)

To first order this is ``u_{k+1} = u_k + Q L e_k`` with ``L = J_k^-1
gamma G^-1``, the inverse of the model linearised along the trajectory
(``J_k`` the PI's slope matrix along ``u_k``, ascending and descending
branches each with their own slopes), which is the law
``u_{k+1} = Q(u_k + L e_k)`` with Q acting on the update only:

* ``G^-1`` is the inverse of the model's dynamics over the whole record
  (ZPETC or stable inversion,
  :func:`hammerstein.compensation.inversion.preview_inverse`); the error is
  continued past the record's end first (:meth:`IterativeLearning.step`).
* ``Gamma^c`` is, for a classical PI model, the inverse multiplicative law
  with 50 fixed-point iterations and the secant gain (exact to 1e-6 µm on
  the bundled model; 3 iterations leave 0.14 µm, which the learning would
  then have to fight); for a Preisach model (``identify --model preisach``
  or ``auto``), the exact per-sample root of
  :class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`
  (monotone direct paths), so that ``Gamma(u_{k+1}) = v_{k+1}`` to 1e-10 µm
  where reachable. ``J_k^-1`` is then the local gain of the Preisach
  inverse along the trajectory, the slope of the density integrated over
  the hysterons that switch at each sample, on the branch the input is
  on; it is taken exactly (the root of the next trial's PI output) rather
  than as a finite difference, which it equals to first order in ``dv``.
* ``Q`` is a zero-phase low-pass: a Butterworth filter of order ``q_order``
  and cut-off ``q_cutoff_hz`` run forward and backward
  (:func:`scipy.signal.filtfilt`), ``|Q(w)| = |B(w)|^2``, no phase. It
  filters the update, not the drive itself: ``Q(u_k + ...)`` would shave
  the trajectory's own harmonics on every trial (measured: a 1 kHz Q costs
  a 200 Hz circle 1.6 % of its radius after 10 trials).

This is the MIMO inversion-based iterative control of Tien, Zou and Devasia
[1] with the hysteresis of a Hammerstein model inverted along the
trajectory as in [2]. The learning of the linear part is monotonic in the 2-norm when, at
every frequency, ``||I - gamma Q(w) L(w) G(w)|| <= 1``, strictly below 1
where Q passes (:meth:`IterativeLearning.convergence`: per axis, the
diagonal entries; coupled, the largest singular value), G the actuator's
dynamics and ``L`` the inverse of the model's Ghat (exact for ``'stable'``,
the ZPETC's frequency response otherwise); with G = Ghat and Q = 1 it is
``|1 - gamma|`` < 1 for ``0 < gamma < 2``.

Where the model's local gain along the update is below ``slope_floor``
times the mean slope of the loop the drive runs (just after a reversal,
where an identified model can be much flatter than the actuator), the
drive's step is shortened so that no gain below that floor is inverted
(:meth:`IterativeLearning.limit_update`).

An optional integer ``delay`` [samples] advances the measurement before
learning (the measured response lags the drive by a transport delay the
model does not have, e.g. the sensor's or the data acquisition's):
``e(t) = y_r(t) - y_k(t + d)``; the last d samples (not measured) hold the
error of the sample before them.

References
----------
.. [1] S. Tien, Q. Zou and S. Devasia, "Iterative control of dynamics-coupling-caused
   errors in piezoscanners during high-speed AFM operation", IEEE Trans.
   Control Systems Technology 13(6), 921-931, 2005 (ACC 2004).
.. [2] D. A. Bristow, M. Tharayil and A. G. Alleyne, "A survey of iterative learning
   control", IEEE Control Systems Magazine 26(3), 96-114, 2006 (Q-filter,
   monotonic convergence condition).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from hammerstein.compensation.drive import apply_amplifier, drive_signal
from hammerstein.compensation.hammerstein_compensator import continuation
from hammerstein.compensation.inversion import preview_inverse
from hammerstein.compensation.model_classes import model_class
from hammerstein.core.numbers import MAX_ITERATIONS, check_integer
from hammerstein.exceptions import CompensatorError, ConvergenceWarning
from hammerstein.simulation import ChainResult


#: samples of error continued past the record's end before the inverse and Q
EXTENSION = 64

__all__ = ["IterativeLearning", "LearningCompensator", "ConvergenceCondition", "IterationRecord",
           "estimate_delay", "error_summary", "periodic_average", "periodic_error", "periodic_snr",
           "HarmonicGains", "harmonic_base_gains", "repeating_from"]


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
    """

    frequencies: np.ndarray
    per_axis: np.ndarray
    coupled: np.ndarray

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
        k = int(np.argmax(self.coupled))
        axes = ", ".join(f"{n} {v:.3f}" for n, v in zip(outputs, self.max_per_axis))
        return (f"max over frequency of ||I - gamma Q L G||: {axes}, coupled {self.max_coupled:.3f} "
                f"at {self.frequencies[k]:.4g} Hz ({'<= 1: monotonic' if self.holds else '> 1: NOT guaranteed'})")


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
        gains ``gamma |Q(f_h)|^2``): ``rho`` is then the weighted energy of
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


class HarmonicGains:
    """Per-harmonic learning gains of a periodic error, adapted from trial to trial.

    Each harmonic h of the trajectory's period learns with its own gain
    ``g_h`` (a Q given per harmonic instead of a low-pass): ``base`` where
    the monotonic-convergence condition holds (0 elsewhere), then, from the
    measured errors of successive trials,

    * a harmonic whose averaged error is within ``threshold`` times its
      noise amplitude (:func:`periodic_error`) is not learnt in this trial
      (learning it would only move noise into the drive: the error at the
      noise floor cannot fall, it can only grow);
    * a harmonic whose error grew by more than 10 % plus its noise in
      ``patience`` successive trials has its gain halved for the trials
      that follow (one growth alone is not enough: the hysteresis moves
      error between harmonics while the large ones are learnt)
      (the condition does not hold there for the actual actuator:
      a gain-scheduling safeguard in the spirit of the model-less,
      measurement-corrected inversion-based iterative control of Kim and
      Zou [1]_, which corrects the learning per frequency from the measured
      response of the previous trial);
    * once a trial learns no harmonic (every one within its noise floor),
      the learning has converged and a dead zone widens: from then on a
      harmonic is learnt only above ``resume`` times its floor. Near the
      floor a harmonic's measured amplitude is a noisy sample of a small
      true one; learning it shrinks that amplitude but turns its phase,
      and the peak of a sum of several such harmonics (the max Euclidean
      error) can grow: the dead-zone modification of ILC for bounded
      disturbances of Xu and Viswanathan [2]_ (a disturbance that rises
      above the wider zone is learnt again).

    Parameters
    ----------
    base : array_like, shape (n_h,)
        Starting gain per harmonic (``gamma`` where the condition holds).
    threshold : float
        Noise multiple below which a harmonic is not learnt.
    patience : int
        Successive growths that halve a harmonic's gain.
    resume : float
        After convergence, the multiple of the floor (``threshold`` times
        the noise) above which a harmonic is learnt again; 1 turns the dead
        zone off.

    Attributes
    ----------
    converged : bool
        True once an update learnt no harmonic (sticky).

    Raises
    ------
    CompensatorError
        ``resume`` not a number >= 1.

    References
    ----------
    .. [1] K.-S. Kim and Q. Zou, "Model-less inversion-based iterative
       control for output tracking: piezo actuator example", Proc. American
       Control Conference, 2710-2715, 2008.
    .. [2] J.-X. Xu and B. Viswanathan, "Adaptive robust iterative learning
       control with dead zone scheme", Automatica 36(1), 91-99, 2000.

    Examples
    --------
    >>> import numpy as np
    >>> g = HarmonicGains([0.5, 0.5, 0.5])
    >>> g.update(np.array([[1.0, 1e-3, 2.0]]), 0.01)
    array([0.5, 0. , 0.5])
    >>> g.update(np.array([[0.5, 1e-3, 3.0]]), 0.01)      # harmonic 2 grew once
    array([0.5, 0. , 0.5])
    >>> g.update(np.array([[0.2, 1e-3, 4.0]]), 0.01)      # twice in a row: halved
    array([0.5 , 0.  , 0.25])

    Converged (nothing above the floor 0.03), a harmonic just above the
    floor is not learnt; one above twice the floor is:

    >>> g.update(np.array([[0.02, 1e-3, 0.02]]), 0.01)
    array([0., 0., 0.])
    >>> g.update(np.array([[0.04, 1e-3, 0.07]]), 0.01)
    array([0.  , 0.  , 0.25])
    """

    def __init__(self, base, threshold=3.0, patience=2, resume=2.0):
        self.patience = int(patience)
        self.base = np.array(base, dtype=float)
        self.gains = self.base.copy()
        self.threshold = float(threshold)
        if not resume >= 1:
            raise CompensatorError(f"resume: expected a multiple of the noise floor >= 1, "
                                   f"found {resume!r}")
        self.resume = float(resume)
        self.previous = None
        self.converged = False

    def update(self, spectrum, noise):
        """The gains of the next update from this trial's averaged error.

        Parameters
        ----------
        spectrum : numpy.ndarray, shape (p, n_h)
            Harmonic amplitudes of the averaged error [µm] (:func:`periodic_error`).
        noise : float
            Noise amplitude of one harmonic of one axis [µm].

        Returns
        -------
        numpy.ndarray, shape (n_h,)
        """
        amp = np.linalg.norm(np.atleast_2d(spectrum), axis=0)
        floor = self.threshold * noise * np.sqrt(np.atleast_2d(spectrum).shape[0])
        if self.previous is not None and self.previous.shape == amp.shape:
            grew = amp > 1.1 * self.previous + floor
            self.growths = np.where(grew, self.growths + 1, 0)
            self.gains[self.growths >= self.patience] *= 0.5
        else:
            self.growths = np.zeros(amp.shape, dtype=int)
        self.previous = amp
        learnt = amp > (self.resume * floor if self.converged else floor)
        if not learnt.any():
            self.converged = True
        return np.where(learnt, self.gains, 0.0)


def _frequency_response(A, B, C, D, z):
    """G(z) of a discrete state space at points z: shape (n_z, p, p)."""
    n = A.shape[0]
    out = np.empty((z.size, C.shape[0], B.shape[1]), dtype=complex)
    for i, zi in enumerate(z):
        out[i] = D + (C @ np.linalg.solve(zi * np.eye(n) - A, B) if n else 0)
    return out


class IterativeLearning:
    """The ILC law ``u_{k+1} = Q(u_k + L e_k)`` of a Hammerstein model (see the module docstring).

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Hysteresis of the model (m inputs [V], p outputs [µm]): a classical
        PI, or a Preisach model with monotone direct paths (its exact
        inverse, :class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`).
    dynamics : control.StateSpace or None
        Discrete p x p linear part of the model (None: static, ``G = I``).
    sampling_period : float
        T [s].
    learning_gain : float
        gamma, in (0, 2); 1 learns the whole modelled error in one trial, and
        passes the whole measurement noise into the next drive; 0.5
        (default) halves both.
    q_cutoff_hz : float or None
        Cut-off of the zero-phase low-pass Q [Hz], below Nyquist; None: no Q.
    q_order : int
        Butterworth order of each pass of Q.
    inversion : {'zpetc', 'stable'}
        The inverse of G (:func:`~hammerstein.compensation.inversion.preview_inverse`).
    delay : int
        Samples by which the measurement is advanced (its transport delay
        not in the model).
    gain, iterations : str, int
        Options of the hysteresis compensator
        (:class:`~hammerstein.compensation.compensators.InverseMultiplicativeCompensator`).
    significance : float
        z, in standard deviations of the noise-power estimate: the
        time-domain update learns only an error whose power exceeds what
        noise alone would leave by ``z sqrt(2 / dof)`` (a chi-square test;
        :meth:`noise_shrink_profile`, and the period-averaged factor of
        :meth:`step`). The default 6 is exceeded by noise alone with a
        probability of about 1e-5 per window, so a trial at the noise floor
        leaves the drive where it is (on a deterministic actuator the next
        trial is then the same); 0 is the plain Wiener factor, which passes
        a share of the noise into every drive.
    slope_floor : float, optional
        In [0, 1]: the model's local gain the learning inverts is bounded
        below by this fraction of the mean slope of the loop the drive runs,
        per direct path (:meth:`limit_update`; a trust region just after
        input reversals, where an identified model can be far flatter than
        the actuator). 0: the exact inverse everywhere. Default: 0 for a
        classical PI model (its slope after a reversal is its zero-threshold
        play's weight, and on the bundled actuator with its own model a
        floor of 0.7 slows the exact learning: the error after two trials
        falls by 9 instead of 30), 0.7 for a Preisach or generalised-PI
        model. The 0.7:
        measured on ``realistic-gpi`` through ``learn``, 0.2, 0.3, 0.5 and
        1.0 left the 15 µm, 10 Hz circle at 0.38, 0.43, 0.32 and 0.40 %
        after 10 trials, 0.7 at 0.28 % (no growth above x1.02 with any of
        them; x1.73 without the floor). Its cost there: the 50 µm, 10 Hz
        circle ends at 0.234 % instead of 0.075 % (0.146 % at 0.5).

    Raises
    ------
    CompensatorError
        Gain outside (0, 2), a cut-off not below Nyquist, a negative delay,
        a significance that is not a number >= 0, a slope floor outside [0, 1],
        dynamics that are not p x p, a Preisach model its exact inverse
        refuses (not square, a direct path that is not increasing).

    Examples
    --------
    Two trials on the bundled actuator with its own model: the first error
    (rate-independent drive) falls by two orders of magnitude.

    >>> import numpy as np
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
    >>> plant = load_plant("rakotondrabe-2dof")
    >>> ilc = IterativeLearning(plant.hysteresis, plant.dynamics, plant.sampling_period,
    ...                         learning_gain=1.0, q_cutoff_hz=3000.0)
    >>> t = np.arange(2000) * plant.sampling_period
    >>> yr = 20 * np.vstack([np.sin(2 * np.pi * 50 * t) ** 2, np.sin(2 * np.pi * 50 * t) ** 3])
    >>> u, _ = InverseMultiplicativeCompensator(plant.hysteresis).simulate(yr)
    >>> errors = []
    >>> for k in range(3):
    ...     y, _ = plant.simulate(u)
    ...     errors.append(np.abs(yr - y).max())
    ...     u = ilc.step(yr, u, y)
    >>> bool(errors[2] < errors[0] / 100)
    True
    """

    def __init__(self, model, dynamics, sampling_period, learning_gain=0.5, q_cutoff_hz=None,
                 q_order=2, inversion="zpetc", delay=0, gain="secant", iterations=50,
                 significance=6.0, slope_floor=None):
        if not (0 < learning_gain < 2):
            raise CompensatorError(f"learning_gain: expected a number in (0, 2), found {learning_gain!r}")
        nyquist = 0.5 / sampling_period
        if q_cutoff_hz is not None and not (0 < q_cutoff_hz < nyquist):
            raise CompensatorError(f"q_cutoff_hz: expected a frequency in (0, {nyquist:g}) Hz "
                                   f"(below Nyquist), found {q_cutoff_hz!r}")
        if inversion not in ("zpetc", "stable"):
            raise CompensatorError(f"inversion: expected 'zpetc' or 'stable', found {inversion!r}")
        if int(delay) != delay or delay < 0:
            raise CompensatorError(f"delay: expected an integer >= 0 [samples], found {delay!r}")
        p = model.n_outputs
        if dynamics is not None and (dynamics.ninputs != p or dynamics.noutputs != p):
            raise CompensatorError(f"dynamics: expected a {p}x{p} system (the model's outputs)")
        self.model, self.dynamics, self.sampling_period = model, dynamics, float(sampling_period)
        self.learning_gain, self.q_cutoff_hz, self.q_order = float(learning_gain), q_cutoff_hz, int(q_order)
        self.inversion, self.delay = inversion, int(delay)
        if not (np.isfinite(significance) and significance >= 0):
            raise CompensatorError(f"significance: expected a number >= 0 (standard deviations), "
                                   f"found {significance!r}")
        self.significance = float(significance)
        entry = model_class(model)       # the model's class: its exact inverse, or the law
        #: True when the class has an exact inverse (Preisach, generalised PI): Gamma^c is it
        self.exact_static = entry.exact_inverse_kind is not None
        if slope_floor is None:        # the Preisach / generalised-PI inverse: 0.7; a classical PI: 0
            slope_floor = 0.7 if self.exact_static else 0.0
        if not (np.isfinite(slope_floor) and 0 <= slope_floor <= 1):
            raise CompensatorError(f"slope_floor: expected a fraction in [0, 1] of the loop's mean "
                                   f"slope, found {slope_floor!r}")
        self.slope_floor = float(slope_floor)
        if self.exact_static:
            try:
                self.hysteresis_compensator = entry.exact_inverse(model)   # exact root
            except CompensatorError as exc:
                raise CompensatorError(f"model: the learning inverts the hysteresis exactly, which "
                                       f"refuses this {entry.label} model: {exc}") from None
        else:
            self.hysteresis_compensator = entry.compensator(
                model, "multivariable", gain=gain, iterations=iterations,
                check="ignore")   # Gamma^c: the exact inverse
        self._ba = None
        if q_cutoff_hz is not None:
            self._ba = _scipy_signal().butter(self.q_order, q_cutoff_hz, fs=1.0 / sampling_period)

    # -- the parts of the law -------------------------------------------------------------
    def q_filter(self, x):
        """Q: the zero-phase low-pass of every row (identity without a cut-off).

        Parameters
        ----------
        x : array_like, shape (k, n_samples)

        Returns
        -------
        numpy.ndarray, shape (k, n_samples)
        """
        x = np.asarray(x, dtype=float)
        if self._ba is None or x.shape[1] < 3 * (self.q_order + 1) + 1:
            return x.copy()
        return _scipy_signal().filtfilt(*self._ba, x, axis=1, padtype="odd")

    def inverse_dynamics(self, error):
        """``G^-1 e`` over the whole record, G at rest at the first sample.

        Parameters
        ----------
        error : array_like, shape (p, n_samples)
            [µm].

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            PI outputs [µm] (the error itself without dynamics).
        """
        if self.dynamics is None:
            return np.array(error, dtype=float)
        e = np.asarray(error, dtype=float)
        return preview_inverse(self.dynamics, e, method=self.inversion, initial_state=None)

    def pi_output(self, drive):
        """``v_k = Gamma(u_k)``: the model's PI output along the applied drive, from rest.

        Parameters
        ----------
        drive : array_like, shape (m, n_samples)
            [V].

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            [µm].
        """
        v, _ = self.model.simulate(np.asarray(drive, dtype=float))
        return v

    def harmonic_inverse(self, spectrum, gains, period_samples):
        """One period of ``g_h Ghat(z_h)^-1 E_h``: the exact inverse of the model's dynamics per harmonic.

        A periodic error is learnt per harmonic of its period: at
        ``z_h = exp(2 pi j h / P)`` the inverse of the (square) model dynamics
        is exact, minimum phase or not (no ZPETC approximation, no preview
        truncation): the periodic form of the inversion-based iterative
        control of [1] (module references).

        Parameters
        ----------
        spectrum : numpy.ndarray, shape (p, P // 2 + 1), complex
            Harmonics of one period of the error (:func:`periodic_error`) [µm].
        gains : array_like, shape (P // 2 + 1,)
            Learning gain per harmonic.
        period_samples : int
            P.

        Returns
        -------
        numpy.ndarray, shape (p, P)
            PI-output update over one period [µm].
        """
        E = np.asarray(spectrum, dtype=complex)
        P = int(period_samples)
        g = np.asarray(gains, dtype=float)
        dV = np.zeros_like(E)
        on = np.flatnonzero(g)
        if on.size:
            if self.dynamics is None:
                dV[:, on] = E[:, on]
            else:
                z = np.exp(2j * np.pi * on / P)
                Gh = _frequency_response(*(np.asarray(getattr(self.dynamics, k), dtype=float)
                                           for k in "ABCD"), z)
                dV[:, on] = np.linalg.solve(Gh, E[:, on].T[:, :, None])[:, :, 0].T
            dV[:, on] *= g[on]
        return np.fft.irfft(dV * (P / 2.0), n=P, axis=1)

    def noise_shrink(self, error):
        """Factor in [0, 1] on the time-domain update: the share of the error Q passes that is not noise.

        The measurement noise is estimated from the part of the error above
        Q, ``e - Q e`` (white noise assumed: its variance is
        ``mean((e - Q e)^2) / mean((1 - |Q|)^2)`` over the frequencies up
        to Nyquist), its power within Q follows (``sigma^2 mean(|Q|^2)``)
        and the factor is ``max(0, 1 - noise power / power of Q e)``: the
        Wiener shrinkage of the update (1 far above the noise floor, 0 at
        it), so that a trial at the noise floor does not feed the noise
        back into the drive. An error above Q that is not noise makes the
        estimate larger, the factor smaller: the learning slows, it never
        speeds up. 1 without Q.

        Parameters
        ----------
        error : array_like, shape (p, n_samples)
            [µm].

        Returns
        -------
        float
        """
        if self._ba is None:
            return 1.0
        e = np.asarray(error, dtype=float)
        if e.shape[1] < 3 * (self.q_order + 1) + 1:
            return 1.0
        low = self.q_filter(e)
        f = np.linspace(0.0, 0.5 / self.sampling_period, 512)
        _, h = _scipy_signal().freqz(*self._ba, worN=f, fs=1.0 / self.sampling_period)
        q = np.abs(h) ** 2
        sigma2 = float(np.mean((e - low) ** 2)) / max(float(np.mean((1.0 - q) ** 2)), 1e-12)
        power = float(np.mean(low ** 2))
        return float(max(0.0, 1.0 - sigma2 * float(np.mean(q ** 2)) / power)) if power > 0 else 0.0

    def noise_shrink_profile(self, error, window=None, significance=None):
        """Per-sample factor in [0, 1] on the time-domain update: :meth:`noise_shrink`, local in time.

        The noise variance ``sigma^2`` is estimated as in :meth:`noise_shrink`
        (from ``e - Q e``); the power of ``Q e`` (summed over the outputs) is
        averaged over a sliding window of ``window`` samples (default 8
        periods of the cut-off, ``8 / (q_cutoff_hz T)``) and the factor is
        ``max(0, 1 - c p sigma^2 mean(|Q|^2) / local power)``: the Wiener
        shrinkage where the error is, 0 where what Q passes is noise alone
        (a raster at the noise floor keeps its error at the line turns;
        elsewhere its update would only be noise). All ones without Q.

        Noise alone makes the window's power ``p sigma^2 mean(|Q|^2)`` times
        a chi-square variable over its ``dof`` degrees of freedom,
        ``dof = p n_w mean(|Q|^4)^-1 mean(|Q|^2)^2`` (white noise through the
        power response ``|Q|^2`` of the zero-phase Q, averaged over ``n_w``
        samples; e.g. Bendat and Piersol, "Random data", 4th ed., 2010,
        Sec. 8.2), whose relative spread is ``sqrt(2 / dof)``. The plain
        Wiener factor (``c = 1``) therefore learns noise wherever a window
        happens to hold more of it than average (on a large share of the
        samples of a trial at the noise floor, which is what made rasters
        grow there); ``c = 1 + z sqrt(2 / dof)`` learns only a local error
        that noise alone would reach with a z-standard-deviation chance.

        Parameters
        ----------
        error : array_like, shape (p, n_samples)
            [µm].
        window : int, optional
            Samples of the sliding average.
        significance : float, optional
            z (default the learning's :attr:`significance`).

        Returns
        -------
        numpy.ndarray, shape (n_samples,)
        """
        e = np.asarray(error, dtype=float)
        if self._ba is None or e.shape[1] < 3 * (self.q_order + 1) + 1:
            return np.ones(e.shape[1])
        low = self.q_filter(e)
        f = np.linspace(0.0, 0.5 / self.sampling_period, 512)
        _, h = _scipy_signal().freqz(*self._ba, worN=f, fs=1.0 / self.sampling_period)
        q = np.abs(h) ** 2
        sigma2 = float(np.mean((e - low) ** 2)) / max(float(np.mean((1.0 - q) ** 2)), 1e-12)
        noise = e.shape[0] * sigma2 * float(np.mean(q ** 2))
        n_w = int(window or max(16, round(8.0 / (self.q_cutoff_hz * self.sampling_period))))
        n_w = min(n_w, e.shape[1])
        power = np.convolve(np.sum(low ** 2, axis=0), np.ones(n_w) / n_w, mode="same")
        # noise alone makes the window's power a chi-square of dof degrees of freedom
        dof = e.shape[0] * n_w * float(np.mean(q ** 2)) ** 2 / max(float(np.mean(q ** 4)), 1e-300)
        z = self.significance if significance is None else float(significance)
        noise = noise * (1.0 + z * np.sqrt(2.0 / dof))
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(power > 0, 1.0 - noise / power, 0.0)
        return np.clip(out, 0.0, 1.0)

    def step(self, reference, drive, measured, period_samples=None, steady_from=None,
             harmonic_gains=None):
        """One trial's update (see the module docstring).

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            ``y_r`` [µm].
        drive : array_like, shape (m, n_samples)
            ``u_k`` [V], the drive that was applied (from rest).
        measured : array_like, shape (p, n_samples)
            ``y_k`` [µm], its measured response (aligned with the drive).
        period_samples : int, optional
            Period of a periodic reference [samples]. The error is continued
            past the record's end (periodically, else by extrapolation,
            :func:`~hammerstein.compensation.hammerstein_compensator.continuation`)
            before the inverse and Q, which need samples beyond it: the
            last samples' error depends on drive samples after the record
            (without this, measured, the end of a 200 Hz circle grows by a
            factor 1.35 per trial).
        steady_from : int, optional
            With ``period_samples``, for a reference that repeats from this
            sample on: the error from it on is replaced by its average over
            the periods (:func:`periodic_average`, blended in by a raised
            cosine over the first period, so that no step enters the
            inverse), which divides the
            measurement noise that reaches the next drive by the square root
            of the number of periods (a repetitive trajectory has one error
            per period to learn).
        harmonic_gains : HarmonicGains, optional
            With ``steady_from``: the periodic part learns per harmonic of
            the period (:meth:`harmonic_inverse`, gains from
            :meth:`HarmonicGains.update` on this trial's averaged error,
            kept in :attr:`last_gains`) instead of through the time-domain
            inverse and the low-pass Q, which then shape only the start-up.

        Returns
        -------
        numpy.ndarray, shape (m, n_samples)
            ``u_{k+1}`` [V].

        Raises
        ------
        CompensatorError
            Shapes that do not match.
        """
        r = self.model.check_inputs(reference, "reference")
        y = np.asarray(measured, dtype=float)
        if y.shape != r.shape:
            raise CompensatorError(f"measured: expected shape {r.shape} like the reference, "
                                   f"found {y.shape}")
        u = np.asarray(drive, dtype=float)
        if u.shape != (self.model.n_inputs, r.shape[1]):
            raise CompensatorError(f"drive: expected shape {(self.model.n_inputs, r.shape[1])}, "
                                   f"found {u.shape}")
        d = self.delay
        if d:                          # y_k(t) ~ model(t - d): align the measurement
            y = np.concatenate([y[:, d:], np.zeros((y.shape[0], d))], axis=1)
        e = r - y
        if d:                          # the last d samples were not measured: hold the error
            e[:, -d:] = e[:, -d - 1:-d]
        e_raw = e
        if period_samples and steady_from is not None:    # blended in over one period
            avg = periodic_average(e, period_samples, steady_from)
            b = np.clip((np.arange(e.shape[1]) - steady_from) / period_samples, 0.0, 1.0)
            b = 0.5 * (1.0 - np.cos(np.pi * b))
            e = (1.0 - b) * e + b * avg
        v = self.pi_output(u)
        N = e.shape[1]
        if period_samples and N >= period_samples + EXTENSION:
            ext = e[:, N - period_samples:N - period_samples + EXTENSION]
        else:
            ext = continuation(e, EXTENSION)
        dv = self.inverse_dynamics(np.concatenate([e, ext], axis=1))
        # the Wiener factor of a repeating reference, from its averaged error (periodic_snr)
        self.last_scale = 1.0
        if period_samples and steady_from is not None:
            rho = periodic_snr(e_raw, period_samples, steady_from)
            # noise alone: rho ~ chi-square / dof with dof = p P (the averaged period's samples)
            c = 1.0 + self.significance * np.sqrt(2.0 / (e_raw.shape[0] * int(period_samples)))
            self.last_scale = float(max(0.0, 1.0 - c / rho)) if np.isfinite(rho) else 1.0
        shrink = self.noise_shrink_profile(e_raw)
        self.last_shrink = float(np.mean(shrink))
        shrink = np.concatenate([shrink, np.full(dv.shape[1] - N, shrink[-1])]) * self.last_scale
        dv = self.q_filter(self.learning_gain * shrink * dv)[:, :N]
        self.last_gains = None
        if harmonic_gains is not None and period_samples and steady_from is not None \
                and N - steady_from >= period_samples:
            P, s0 = int(period_samples), int(steady_from)
            E, noise = periodic_error(e_raw, P, s0)
            g = harmonic_gains.update(E, noise if np.isfinite(noise) else 0.0)
            self.last_gains = g
            harm = self.harmonic_inverse(E, g, P)[:, (np.arange(N) - s0) % P]
            b = np.clip((np.arange(N) - s0 + P) / P, 0.0, 1.0)     # periodic from s0 on
            b = 0.5 * (1.0 - np.cos(np.pi * b))
            dv = (1.0 - b) * dv + b * harm
        v_next = v + dv
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")      # range warnings: the learning extrapolates
            u_next, _ = self.hysteresis_compensator.simulate(v_next)
        return self.limit_update(u, u_next)

    def limit_update(self, drive, next_drive):
        """The drive update with the model's local gain bounded below (a trust region at reversals).

        Per direct path l (input l to output l) the model's chord gain over
        the update is ``g_l(t) = dGamma_ll(t) / du_l(t)``, ``dGamma_ll`` the
        change of that path's output when only input l moves from
        ``u_l`` to ``u_{k+1,l}`` (the other inputs held on ``u_k``). Where
        it is below ``slope_floor`` times the mean slope of the loop the
        drive runs, ``S_l = ptp(Gamma_ll(u_l)) / ptp(u_l)``, the update is
        shortened to ``|du_l| = max(sign(du_l) dGamma_ll, 0) / (slope_floor S_l)``:
        the learning then inverts no local gain below that floor.

        Why: per sample, a static-gain learning ``du = gamma dv / g_model``
        on an actuator of local gain ``g`` contracts the error by
        ``|1 - gamma g / g_model|``, below 1 only while
        ``g / g_model < 2 / gamma`` (the convergence condition of ILC on a
        hysteretic actuator whose slopes are bounded, Leang and Devasia
        [1]_). Just after an input reversal an identified model can be far
        flatter than the actuator: measured on ``realistic-gpi`` with its
        identified generalised-PI model (asymmetric envelopes: the zero-
        threshold play holds its output until the other envelope reaches
        it), the model's slope is 0-0.8 µm/V over the first ~10 samples
        after u_x turns back where the actuator's is 4.4-5.2 µm/V; the
        exact inverse turns a request of -0.04 µm there into -0.05 V, the
        actuator moves by -0.28 µm, and the error at the turning point
        flips sign and grows (x1.73 in one trial on a 15 µm, 10 Hz circle;
        x1.67 on a 10 Hz raster, at the line ends). With the floor the
        ratio there is bounded by ``g / (slope_floor S_l)`` (about 1.25 for
        5 µm/V over 0.7 x 5.7 µm/V: a factor 0.37 per trial), and no trial of that actuator grows by more than
        x1.05 (docs/hardware.md). Elsewhere, where the model's gain is at
        or above the floor, the update is the exact inverse's.

        Parameters
        ----------
        drive : array_like, shape (m, n_samples)
            ``u_k`` [V].
        next_drive : array_like, shape (m, n_samples)
            ``u_{k+1}`` from the exact inverse of the model [V].

        Returns
        -------
        numpy.ndarray, shape (m, n_samples)
            ``u_{k+1}`` with the shortened steps [V]; ``next_drive``
            unchanged when :attr:`slope_floor` is 0 or the model is not
            square. :attr:`last_limited` holds the share of the samples
            (over inputs and time) that were shortened.

        References
        ----------
        .. [1] K. K. Leang and S. Devasia, "Design of hysteresis-compensating
           iterative learning control for piezo-positioners: application to
           atomic force microscopes", Mechatronics 16(3-4), 141-158, 2006.
        """
        u = np.asarray(drive, dtype=float)
        un = np.array(next_drive, dtype=float)
        self.last_limited = 0.0
        if self.slope_floor <= 0 or self.model.n_inputs != self.model.n_outputs:
            return un
        du = un - u
        v0 = self.pi_output(u)
        limited = np.zeros(du.shape, dtype=bool)
        for l in range(self.model.n_inputs):
            span = float(np.ptp(u[l]))
            if span <= 0:
                continue
            alone = np.zeros_like(u)
            alone[l] = u[l]
            mean_slope = float(np.ptp(self.pi_output(alone)[l])) / span
            floor = self.slope_floor * mean_slope
            if not floor > 0:
                continue
            mixed = u.copy()
            mixed[l] = un[l]
            dg = self.pi_output(mixed)[l] - v0[l]           # the direct path's change
            bound = np.maximum(dg * np.sign(du[l]), 0.0) / floor
            over = np.abs(du[l]) > bound
            limited[l] = over
            un[l] = np.where(over, u[l] + np.sign(du[l]) * bound, un[l])
        self.last_limited = float(np.mean(limited))
        return un

    # -- the monotonic-convergence condition --------------------------------------------------
    def convergence(self, plant_dynamics=None, n_frequencies=400):
        """``||I - gamma Q(w) L(w) G(w)||`` from 1 Hz to Nyquist.

        Parameters
        ----------
        plant_dynamics : control.StateSpace, optional
            The actuator's dynamics G when known (a simulated plant); the
            model's by default (then only Q, gamma, the ZPETC gain error and
            the delay shape the condition).
        n_frequencies : int

        Returns
        -------
        ConvergenceCondition
        """
        T = self.sampling_period
        f, LG = self._loop(plant_dynamics, n_frequencies)
        I = np.eye(self.model.n_outputs)
        if self._ba is not None:
            _, h = _scipy_signal().freqz(*self._ba, worN=f, fs=1.0 / T)
            q = np.abs(h) ** 2
        else:
            q = np.ones(f.size)
        M = I - self.learning_gain * q[:, None, None] * LG
        per_axis = np.abs(np.diagonal(M, axis1=1, axis2=2)).T
        coupled = np.linalg.svd(M, compute_uv=False)[:, 0]
        return ConvergenceCondition(f, per_axis, coupled)

    def set_q_cutoff(self, q_cutoff_hz):
        """Change the cut-off of Q [Hz] (None: no Q).

        Parameters
        ----------
        q_cutoff_hz : float or None

        Raises
        ------
        CompensatorError
            A cut-off not below Nyquist.
        """
        nyquist = 0.5 / self.sampling_period
        if q_cutoff_hz is not None and not (0 < q_cutoff_hz < nyquist):
            raise CompensatorError(f"q_cutoff_hz: expected a frequency in (0, {nyquist:g}) Hz "
                                   f"(below Nyquist), found {q_cutoff_hz!r}")
        self.q_cutoff_hz = q_cutoff_hz
        self._ba = None if q_cutoff_hz is None else _scipy_signal().butter(
            self.q_order, q_cutoff_hz, fs=1.0 / self.sampling_period)

    def _loop(self, plant_dynamics, n_frequencies):
        """Frequencies and ``L(w) G(w)`` (n_f, p, p), cached per plant."""
        key = (n_frequencies, self.delay)
        cache = getattr(self, "_loop_cache", None)
        if cache is not None and cache[0] == key and cache[3] is plant_dynamics:
            return cache[1], cache[2]
        T = self.sampling_period
        f = np.geomspace(1.0, 0.5 / T * 0.999, n_frequencies)
        z = np.exp(2j * np.pi * f * T)
        p = self.model.n_outputs
        I = np.eye(p)
        if self.dynamics is None:
            Gh = np.broadcast_to(I, (f.size, p, p)).astype(complex)
        else:
            Gh = _frequency_response(*(np.asarray(getattr(self.dynamics, k), dtype=float)
                                       for k in "ABCD"), z)
        Gt = Gh if plant_dynamics is None else _frequency_response(
            *(np.asarray(getattr(plant_dynamics, k), dtype=float) for k in "ABCD"), z)
        Linv = np.linalg.pinv(Gh)
        if self.inversion == "zpetc" and self.dynamics is not None:
            # ZPETC: zero phase, gain error of the approximated zeros: L = Ghat^-1 * gain
            Linv = self._zpetc_response(f, Gh)
        if plant_dynamics is None and self.delay:    # the measured response: Ghat z^-d
            Gt = Gt * (z ** -self.delay)[:, None, None]
        Linv = Linv * (z ** self.delay)[:, None, None]
        self._loop_cache = (key, f, Linv @ Gt, plant_dynamics)
        return f, Linv @ Gt

    def _zpetc_response(self, f, Gh):
        """Frequency response of the whole-record ZPETC inverse, measured on unit sines."""
        T = self.sampling_period
        p = self.model.n_outputs
        out = np.empty((f.size, p, p), dtype=complex)
        n = 4096
        k = np.arange(n)
        picks = np.unique(np.clip(np.round(f * n * T).astype(int), 1, n // 2 - 1))
        resp = {}
        for j in range(p):
            x = np.zeros((p, n))
            for b in picks:
                x[j] += np.cos(2 * np.pi * b * k / n)
            v = preview_inverse(self.dynamics, np.tile(x, 3), method="zpetc")[:, n:2 * n]
            V = np.fft.rfft(v, axis=1)
            resp[j] = V[:, picks] / (n / 2)
        fb = picks / (n * T)
        for j in range(p):
            for i in range(p):
                re = np.interp(f, fb, resp[j][i].real)
                im = np.interp(f, fb, resp[j][i].imag)
                out[:, i, j] = re + 1j * im
        return out

    def check(self, plant_dynamics=None, outputs=None):
        """The condition, with one :class:`ConvergenceWarning` when it fails.

        Parameters
        ----------
        plant_dynamics : control.StateSpace, optional
            See :meth:`convergence`.
        outputs : list of str, optional
            Names for the message (default the model's).

        Returns
        -------
        ConvergenceCondition

        Warns
        -----
        ConvergenceWarning
            When ``max_w ||I - gamma Q L G|| > 1``.
        """
        cond = self.convergence(plant_dynamics)
        if not cond.holds:
            warnings.warn("ILC: " + cond.summary(outputs or self.model.output_names)
                          + "; lower learning_gain or q_cutoff_hz", ConvergenceWarning, stacklevel=2)
        return cond




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


def harmonic_base_gains(learning, period_samples, plant_dynamics=None, band_hz=None):
    """Starting gain per harmonic of the period: ``gamma |Q(f_h)|^2`` where the condition holds, else 0.

    Harmonic h (``f_h = h / (P T)``) learns with ``gamma |Q(f_h)|^2``, Q
    the zero-phase Butterworth of cut-off ``band_hz`` (the time-domain
    law's Q, sampled at the harmonics) and, when the plant's dynamics G
    are known (a simulated actuator), only where
    ``||I - gamma |Q|^2 Ghat(z_h)^-1 G(z_h)|| < 1`` at
    ``z_h = exp(2 pi j h / P)`` (the per-harmonic monotonic-convergence
    condition of the exact periodic inverse); 0 elsewhere.

    Parameters
    ----------
    learning : IterativeLearning
        Its gain, Q order, model dynamics and sampling period.
    period_samples : int
        P.
    plant_dynamics : control.StateSpace, optional
        G.
    band_hz : float, optional
        Cut-off of Q [Hz] (default: no Q, every harmonic up to Nyquist).

    Returns
    -------
    numpy.ndarray, shape (P // 2 + 1,)
    """
    P = int(period_samples)
    T = learning.sampling_period
    h = np.arange(P // 2 + 1)
    fh = h / (P * T)
    gamma = learning.learning_gain
    if band_hz is None:
        base = np.full(fh.shape, gamma)
    else:                                       # |Q|^2 of the time-domain law at f_h
        b, a = _scipy_signal().butter(learning.q_order, band_hz, fs=1.0 / T)
        _, q = _scipy_signal().freqz(b, a, worN=fh, fs=1.0 / T)
        base = gamma * np.abs(q) ** 2
    if plant_dynamics is not None:
        z = np.exp(2j * np.pi * h / P)
        p = learning.model.n_outputs
        Gt = _frequency_response(*(np.asarray(getattr(plant_dynamics, k), dtype=float)
                                   for k in "ABCD"), z)
        Gh = np.broadcast_to(np.eye(p), Gt.shape).astype(complex) if learning.dynamics is None \
            else _frequency_response(*(np.asarray(getattr(learning.dynamics, k), dtype=float)
                                       for k in "ABCD"), z)
        M = np.eye(p) - base[:, None, None] * np.linalg.solve(Gh, Gt)
        base[np.linalg.svd(M, compute_uv=False)[:, 0] >= 1.0] = 0.0
    return base


class LearningCompensator:
    """ILC against a (simulated) actuator, starting from another compensator's drive.

    The scenarios' ``kind = "ilc"``: :meth:`run_reference` computes the start
    compensator's drive (:func:`hammerstein.compensation.drive.drive_signal`: fade-in,
    preview), then runs ``iterations`` trials against the plant (through its
    amplifier), each measured with white sensor noise of ``sensor_noise``
    µm RMS (seeded), and learns with :class:`IterativeLearning`. It keeps the
    error of every trial (:attr:`history`, on the noise-free outputs over
    the window after the fade-in and one period).

    A reference that repeats after its fade-in is learnt, from two periods
    after the fade-in on, per harmonic of its period
    (:meth:`IterativeLearning.harmonic_inverse`, gains
    :meth:`harmonic_base_gains` adapted by :class:`HarmonicGains`: no
    learning at the noise floor, halved where an error keeps growing); the
    start-up before it, and references that do not repeat, through the
    time-domain inverse and Q, scaled by the noise shrinkage
    (:meth:`IterativeLearning.noise_shrink_profile`, with its significance test). A trial more than 10 % worse
    than the best one so far is not learnt from: the next trial learns
    again from the best drive with half the gain (:attr:`notes`). The drive
    returned is the best trial's.

    Parameters
    ----------
    start : object
        The start compensator (any kind); its ``model`` and, when it has
        one, its ``dynamics`` are the model the learning inverts (identity
        dynamics otherwise).
    sampling_period : float
        T [s].
    iterations : int
        Learning trials after the start drive, 1 to
        :data:`~hammerstein.core.numbers.MAX_ITERATIONS` (100).
    learning_gain, q_cutoff_hz, inversion, slope_floor
        Of :class:`IterativeLearning` (``slope_floor`` None: its default by
        model class, 0.7 for a Preisach or generalised-PI model, 0 for a
        classical PI).
    sensor_noise : float
        RMS of the measurement noise [µm].
    seed : int
        Of the noise.
    name : str
    harmonics : bool
        Learn a repeating reference per harmonic (default); False: the
        time-domain law over the whole record.

    Attributes
    ----------
    history : list of IterationRecord
    stopped : str
    notes : list of str
        What the learning changed on its own (gain halved after a worse
        trial); reported as warnings of the case.
    condition : ConvergenceCondition
        Against the plant's dynamics, computed before iterating (a
        :class:`~hammerstein.exceptions.ConvergenceWarning` when it fails).
    """

    def __init__(self, start, sampling_period, iterations=10, learning_gain=0.5,
                 q_cutoff_hz=500.0, inversion="zpetc", sensor_noise=0.0, seed=0, name="ilc",
                 harmonics=True, slope_floor=None):
        iterations = check_integer(iterations, "iterations", 1, MAX_ITERATIONS, CompensatorError)
        self.start_compensator = start
        self.sampling_period = float(sampling_period)
        self.iterations, self.sensor_noise, self.seed, self.name = int(iterations), float(
            sensor_noise), int(seed), name
        self.learning = IterativeLearning(start.model, getattr(start, "dynamics", None),
                                          sampling_period, learning_gain, q_cutoff_hz,
                                          inversion=inversion, slope_floor=slope_floor)
        self.history, self.stopped, self.condition = [], "", None
        self.harmonics, self.notes, self.q_cutoff_hz = bool(harmonics), [], q_cutoff_hz

    @property
    def model(self):
        """The hysteresis model of the learning (classical PI or Preisach)."""
        return self.learning.model

    def simulate(self, reference, initial_state=None):
        """Refused: the learning needs the plant; use :meth:`run_reference`.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            [µm].
        initial_state : array_like, optional
            Unused.

        Raises
        ------
        CompensatorError
            Always.
        """
        raise CompensatorError("kind 'ilc' learns against a plant: call "
                               "run_reference(plant, reference, period_samples, fade_samples)")

    def run_reference(self, plant, reference, period_samples=None, fade_samples=0):
        """The start drive, then the learning trials against ``plant``.

        Parameters
        ----------
        plant : HammersteinPlant
            The actuator (with its ``amplifier``, if any).
        reference : array_like, shape (p, n_samples)
            [µm].
        period_samples : int, optional
        fade_samples : int

        Returns
        -------
        hammerstein.simulation.ChainResult
            The best trial's drive (commanded) and the plant's outputs.
        """
        T = self.sampling_period
        d = drive_signal(self.start_compensator, reference, T, period_samples, fade_samples)
        target, u = d.reference, d.inputs
        n = target.shape[1]
        w0 = int(min(max(fade_samples, period_samples or 0), n - 1))
        G = getattr(plant, "dynamics", None)
        self.notes = []
        self.learning.set_q_cutoff(self.q_cutoff_hz)
        q0 = self.learning.q_cutoff_hz
        self.condition = self.learning.check(G)
        steady = None                   # a reference that repeats after the fade: averaged error
        if period_samples and n >= w0 + 5 * period_samples and np.allclose(
                target[:, w0 + period_samples:], target[:, w0:n - period_samples],
                rtol=0, atol=1e-9 * max(float(np.max(np.abs(target))), 1.0)):
            steady = w0 + 2 * period_samples     # after the start-up transient: learnt raw
            w0 = steady + period_samples          # the errors reported: the averaged part
        gains = None
        if self.harmonics and steady is not None:
            gains = HarmonicGains(self.harmonic_base_gains(period_samples, G, q0))
        rng = np.random.default_rng(self.seed)
        amp = getattr(plant, "amplifier", None)
        self.history, best = [], None
        self.stopped = f"after {self.iterations} iterations"
        gamma0, halvings = self.learning.learning_gain, 0
        for k in range(self.iterations + 1):
            y, _ = plant.simulate(apply_amplifier(amp, u, T))
            measured = y + rng.normal(0.0, self.sensor_noise, y.shape) if self.sensor_noise else y
            rec = error_summary(target, y, slice(w0, None), k)
            self.history.append(rec)
            if best is None or rec.max_euclidean_error < best[0].max_euclidean_error:
                best = (rec, u, y, measured)
            elif rec.max_euclidean_error > 1.1 * best[0].max_euclidean_error:
                # worse than the best trial: learn again from the best one with half the gain
                halvings += 1
                self.learning.learning_gain = gamma0 * 0.5 ** halvings
                if gains is not None:
                    gains.gains *= 0.5
                    gains.previous = None
                u, measured = best[1], best[3]
                self.notes.append(f"trial {k} worse than trial {best[0].iteration}: learning "
                                  f"again from it with gain x{0.5 ** halvings:g}")
            if k == self.iterations:
                break
            u = self.learning.step(target, u, measured, period_samples, steady, gains)
        self.learning.learning_gain = gamma0
        if best[0].iteration != self.history[-1].iteration:
            self.stopped += f" (kept iteration {best[0].iteration}, the best)"
        return ChainResult(best[1], best[2], None, None)

    def harmonic_base_gains(self, period_samples, plant_dynamics=None, band_hz=None):
        """:func:`harmonic_base_gains` of this learning.

        Parameters
        ----------
        period_samples : int
            P.
        plant_dynamics : control.StateSpace, optional
            G.
        band_hz : float, optional
            Cut-off of Q [Hz].

        Returns
        -------
        numpy.ndarray, shape (P // 2 + 1,)
        """
        return harmonic_base_gains(self.learning, period_samples, plant_dynamics, band_hz)

    def history_rows(self, names):
        """Metric rows of the trials: channel ``iteration-<k>``, per-axis and Euclidean errors.

        Parameters
        ----------
        names : list of str
            Output names.

        Returns
        -------
        list of dict
        """
        rows = []
        for rec in self.history:
            ch = f"iteration-{rec.iteration}"
            for l, n in enumerate(names):
                rows.append({"channel": ch, "metric": f"max_abs_error_{n}",
                             "value": float(rec.max_error[l]), "unit": "µm"})
                rows.append({"channel": ch, "metric": f"rms_error_{n}",
                             "value": float(rec.rms_error[l]), "unit": "µm"})
            rows.append({"channel": ch, "metric": "max_euclidean_error",
                         "value": rec.max_euclidean_error, "unit": "µm"})
        return rows


def _scipy_signal():
    """scipy.signal, imported on first use (about 0.3 s; a plain preset simulation never needs it)."""
    import scipy.signal
    return scipy.signal
