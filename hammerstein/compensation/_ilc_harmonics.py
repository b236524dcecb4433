"""Per-harmonic learning gains of a periodic reference (behind :mod:`hammerstein.compensation.ilc`).

A periodic reference's error lives on the harmonics of its fundamental; the
learning gain of each harmonic is set from the model's frequency response
there and cut where the model is not trusted.
"""

from __future__ import annotations

from __future__ import annotations


import numpy as np

from hammerstein.exceptions import CompensatorError
from hammerstein.compensation._ilc_errors import _scipy_signal, periodic_average, periodic_error


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




#: Largest gain of the identified dynamics' inverse at a learnt harmonic, relative to its static
#: gain (:func:`harmonic_base_gains`): beyond it the actuator barely moves (an anti-resonance).
#: The outside family's learnt harmonics reach 50 (100 Hz circles) and 90 (20 Hz periods).
INVERSE_GAIN_LIMIT = 100.0


def inverse_gain_ratio(dynamics, frequencies_hz, sampling_period):
    """Gain of the inverse of the dynamics at frequencies, relative to its static gain.

    ``sigma_max(G(z)^-1) / sigma_max(G(1)^-1)`` at ``z = exp(2 pi j f T)``:
    how many times more drive than at rest a µm needs there. Above 1 near
    an anti-resonance (a lightly damped transmission zero between two
    bending modes), where the exact inverse (ZPETC, stable inversion)
    multiplies the reference by up to ``1 / zeta`` of the zero.

    Parameters
    ----------
    dynamics : control.StateSpace or None
        The discrete dynamics G (p outputs, p inputs); None: ones.
    frequencies_hz : array_like, shape (n_f,)
        [Hz].
    sampling_period : float
        T [s].

    Returns
    -------
    numpy.ndarray, shape (n_f,)
        Ratios (inf where G(z) is singular).
    """
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    if dynamics is None:
        return np.ones(f.shape)
    mats = [np.asarray(getattr(dynamics, k), dtype=float) for k in "ABCD"]
    z = np.exp(2j * np.pi * np.r_[0.0, f] * float(sampling_period))
    smallest = np.linalg.svd(_frequency_response(*mats, z), compute_uv=False)[:, -1]
    with np.errstate(divide="ignore"):
        inverse = 1.0 / smallest
    return inverse[1:] / inverse[0]


def harmonic_base_gains(learning, period_samples, plant_dynamics=None, band_hz=None,
                        inverse_limit=None):
    """Starting gain per harmonic of the period: ``gamma |Q(f_h)|`` where the condition holds, else 0.

    Harmonic h (``f_h = h / (P T)``) learns with ``gamma |Q(f_h)| = gamma
    |B(f_h)|^2``, Q the time-domain law's zero-phase filter (the Butterworth B
    of cut-off ``band_hz`` run forward and backward, sampled at the harmonics)
    and, when the plant's dynamics G
    are known (a simulated actuator), only where
    ``||I - gamma |Q| Ghat(z_h)^-1 G(z_h)|| < 1`` at
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
    inverse_limit : float, optional
        Harmonics where the model dynamics' inverse gains more than this
        times its static gain (:func:`inverse_gain_ratio`) are not learnt:
        there the actuator barely moves (an anti-resonance), a correction
        needs that much more drive, and an error of the identified zero's
        place turns it the wrong way. Measured on a one-axis stage (modes
        900 and 2800 Hz, an identified zero at 2198 Hz of damping 1e-4): a
        20 Hz triangle's learnt drive reversed by up to 25 V from sample to
        sample around 2.2 kHz, and the next trial was 3.7 times worse
        (the harmonics at 2180 and 2200 Hz passed 118 and 1206 times;
        without them, 2.6 -> 0.59 µm in three trials). Above the modes the
        inverse's gain grows with their roll-off too, and there the learning
        works: the outside family's learnt 100 Hz circles pass up to 50 times
        (:data:`INVERSE_GAIN_LIMIT`, 100, is above).

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
    else:           # |Q| = |B|^2 of the time-domain law's forward-backward B at f_h
        b, a = _scipy_signal().butter(learning.q_order, band_hz, fs=1.0 / T)
        _, q = _scipy_signal().freqz(b, a, worN=fh, fs=1.0 / T)
        base = gamma * np.abs(q) ** 2
    if inverse_limit is not None:
        base[inverse_gain_ratio(learning.dynamics, fh, T) > inverse_limit] = 0.0
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


def reference_correction(target, followed, error, period_samples, steady_from, gains):
    """One period of the next correction of a repeating reference: learnt per harmonic, in the output.

    The drive of a repeating reference is the compensator's for a corrected
    reference ``y_r + c_k`` (``c_k`` periodic, faded in from rest with the
    reference itself), so that every trial's drive starts at rest as the
    first one and its start-up is the compensator's own, consistent with
    the model's dynamics: no learnt start-up ends in a step or a burst that
    rings the bending modes into the periods judged. The correction learns
    per harmonic h of the period P on the period-averaged error,

        ``C_{k+1,h} = C_{k,h} + g_h E_{k,h}``,

    ``g_h`` from :class:`HarmonicGains` (noise floor, dead zone, halving
    where an error grows). The compensator inverts the model's hysteresis,
    creep and dynamics, so a change of its reference moves the model's
    output by the same change: this is the inversion-based iterative
    control of [1] with the inverse inside the compensator (the reference
    of a feedforward compensator learnt, as e.g. in Bristow, Tharayil and
    Alleyne's survey [2], Sec. "ILC with feedforward"; references in
    :mod:`hammerstein.compensation.ilc`). It converges where the actuator's
    response to a change of the reference, relative to the model's, keeps
    ``|1 - g_h T_h| < 1`` at each harmonic.

    Parameters
    ----------
    target : array_like, shape (p, n_samples)
        The faded reference the trial is judged against [µm].
    followed : array_like, shape (p, n_samples)
        The reference the trial's drive was computed for (the faded
        corrected reference, ``target`` for the first drive) [µm].
    error : array_like, shape (p, n)
        ``e = y_r - y`` of the trial, aligned on the drive [µm] (``n`` at
        most ``n_samples``: the samples a measurement delay leaves).
    period_samples : int
        P.
    steady_from : int
        First sample of the repeating part (at least two periods before
        the end of ``error``).
    gains : HarmonicGains
        The per-harmonic gains, updated by this trial's error.

    Returns
    -------
    numpy.ndarray, shape (p, P)
        ``c_{k+1}`` over one period, sample ``i`` at sample
        ``steady_from + i`` (mod P) of the record [µm].

    Raises
    ------
    CompensatorError
        Less than two periods from ``steady_from`` on, or shapes that do
        not match.

    Examples
    --------
    A constant error of 1 µm on a reference followed as given, learnt at
    gain 0.5: the correction is 0.5 µm.

    >>> import numpy as np
    >>> g = HarmonicGains(np.full(51, 0.5), threshold=0.0)
    >>> r = np.zeros((1, 1000))
    >>> c = reference_correction(r, r, np.ones((1, 1000)), 100, 200, g)
    >>> c.shape, round(float(c.mean()), 6)
    ((1, 100), 0.5)
    """
    r = np.atleast_2d(np.asarray(target, dtype=float))
    f = np.atleast_2d(np.asarray(followed, dtype=float))
    e = np.atleast_2d(np.asarray(error, dtype=float))
    P, s0 = int(period_samples), int(steady_from)
    if f.shape != r.shape or e.shape[0] != r.shape[0] or e.shape[1] > r.shape[1]:
        raise CompensatorError(f"reference_correction: expected followed {r.shape} like the "
                               f"target and an error of {r.shape[0]} rows and at most "
                               f"{r.shape[1]} samples, found {f.shape} and {e.shape}")
    if P < 2 or e.shape[1] - s0 < 2 * P:
        raise CompensatorError(f"reference_correction: expected at least two periods of {P} "
                               f"samples from sample {s0} on, found {e.shape[1] - s0} samples")
    c = periodic_average(f - r, P, s0)[:, s0:s0 + P]
    E, noise = periodic_error(e, P, s0)
    g = gains.update(E, noise if np.isfinite(noise) else 0.0)
    return c + np.fft.irfft(E * g * (P / 2.0), n=P, axis=1)
