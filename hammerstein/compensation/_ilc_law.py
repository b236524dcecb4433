"""The iterative learning law (behind :mod:`hammerstein.compensation.ilc`).

:class:`IterativeLearning`: the model-inverse update with a zero-phase
Q-filter, its convergence condition, and the learning trials (Tien, Zou and
Devasia 2005; Bristow, Tharayil and Alleyne 2006; the references of
:mod:`hammerstein.compensation.ilc`).
"""

from __future__ import annotations

from __future__ import annotations

import warnings

import numpy as np

from hammerstein.compensation.hammerstein_compensator import continuation
from hammerstein.compensation.inversion import preview_inverse
from hammerstein.compensation.model_classes import model_class
from hammerstein.exceptions import CompensatorError, ConvergenceWarning
from hammerstein.compensation._ilc_errors import (EXTENSION, ConvergenceCondition, _scipy_signal,
                                                  periodic_average, periodic_error, periodic_snr)
from hammerstein.compensation._ilc_harmonics import _frequency_response


class IterativeLearning:
    """The ILC law ``u_{k+1} = u_k + Q(L e_k)`` of a Hammerstein model (see the module docstring).

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

    >>> from hammerstein import IterativeLearning
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
             harmonic_gains=None, amplifier=None):
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
        amplifier : Amplifier, optional
            The next drive is clipped to its range and slew-limited
            (:meth:`~hammerstein.models.amplifier.Amplifier.limit`): what the
            actuator cannot receive is not learnt into the drive, which would
            otherwise wind up trial after trial beyond the rails (-8 V on a
            0-150 V stage, its circle's error 12.3 -> 4.0 -> 5.0 %).

        Returns
        -------
        numpy.ndarray, shape (m, n_samples)
            ``u_{k+1}`` [V], learnt on every sample. A drive faded in from
            rest has a start-up that is no tracking: keep it as it was
            (:func:`hammerstein.compensation.drive.keep_start`) and the last
            samples too (:func:`~hammerstein.compensation.drive.keep_end`),
            as ``hammerstein learn`` does; learnt, the start-up moved the
            drive's peak into it and a user's settled error rose at the
            fourth trial (0.25 -> 0.36 µm, monotone with both kept).

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
        u_next = self.limit_update(u, u_next)
        if amplifier is not None:       # anti-windup: only what the amplifier passes is learnt
            u_next, _ = amplifier.limit(u_next, self.sampling_period)
        return u_next

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
        return ConvergenceCondition(f, per_axis, coupled, q >= 0.5)

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
