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
branches each with their own slopes): Q acts on the update only, not on
the drive as in the textbook law ``u_{k+1} = Q(u_k + L e_k)``:

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

For a periodic reference, ``hammerstein learn`` learns instead the
reference that the feedforward compensator is given,
``y_r + c_{k+1}`` with ``C_{k+1,h} = C_{k,h} + g_h E_{k,h}`` per harmonic
(:func:`reference_correction`). The next drive is that compensator's drive,
faded in from rest. The compensator holds the same inverse
``Gamma^c G^-1``, so each drive's start-up is consistent with the model.
The scenarios' :class:`LearningCompensator` learns the drive as above.

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

import numpy as np

from hammerstein.compensation.drive import apply_amplifier, drive_signal
from hammerstein.core.numbers import MAX_ITERATIONS, check_integer
from hammerstein.exceptions import CompensatorError
from hammerstein.simulation import ChainResult
# the trials' errors, the per-harmonic gains and the learning law live in private modules;
# this module is their public face and holds the scenario's learning compensator
from hammerstein.compensation._ilc_errors import (EXTENSION, ConvergenceCondition, IterationRecord,  # noqa: F401
                                                  error_summary, estimate_delay, periodic_average,
                                                  period_drift, periodic_error, periodic_snr,
                                                  repeating_from)
from hammerstein.compensation._ilc_harmonics import (INVERSE_GAIN_LIMIT, HarmonicGains,
                                                     harmonic_base_gains, inverse_gain_ratio,
                                                     reference_correction)
from hammerstein.compensation._ilc_law import IterativeLearning

__all__ = ["IterativeLearning", "LearningCompensator", "ConvergenceCondition", "IterationRecord",
           "estimate_delay", "error_summary", "periodic_average", "periodic_error", "periodic_snr",
           "period_drift", "HarmonicGains", "harmonic_base_gains", "reference_correction", "repeating_from",
           "inverse_gain_ratio", "INVERSE_GAIN_LIMIT"]

for _name in ("IterativeLearning", "ConvergenceCondition", "IterationRecord", "estimate_delay",
              "error_summary", "periodic_average", "periodic_error", "periodic_snr", "period_drift",
              "HarmonicGains", "harmonic_base_gains", "reference_correction", "repeating_from",
              "inverse_gain_ratio"):
    globals()[_name].__module__ = __name__      # documented (and pickled) as this module's
del _name


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
            u = self.learning.step(target, u, measured, period_samples, steady, gains, amp)
        self.learning.learning_gain = gamma0
        if best[0].iteration != self.history[-1].iteration:
            self.stopped += f" (kept iteration {best[0].iteration}, the best)"
        return ChainResult(best[1], best[2], None, None)

    def harmonic_base_gains(self, period_samples, plant_dynamics=None, band_hz=None,
                            inverse_limit=None):
        """:func:`harmonic_base_gains` of this learning.

        Parameters
        ----------
        period_samples : int
            P.
        plant_dynamics : control.StateSpace, optional
            G.
        band_hz : float, optional
            Cut-off of Q [Hz].
        inverse_limit : float, optional
            No learning where the dynamics' inverse gains more than this
            times its static gain.

        Returns
        -------
        numpy.ndarray, shape (P // 2 + 1,)
        """
        return harmonic_base_gains(self.learning, period_samples, plant_dynamics, band_hz,
                                   inverse_limit)

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
