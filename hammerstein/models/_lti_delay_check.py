"""The measurement delay checked against the held-out fit of G (behind :mod:`hammerstein.models.lti`).

The phase-slope estimate (:func:`hammerstein.models._lti_delay.estimate_measurement_delay`)
reads any group delay over its band as the acquisition's. Above a bending mode the
mode's own group delay falls with frequency but is not yet 0: on an outside stage
(one mode per axis at 2.5 kHz, damping 0.4, records at 20 kHz, band 3.75-5 kHz) it
was 0.66 samples beyond the zero-order hold, as the closed form of a second-order
mode at 1.75 times its natural frequency gives (0.67), and was taken as a delay of
one sample. G fitted the held-out multisines at 79.7 % with that sample and 93.0 %
without it, and every drive and every learning trial lagged by it (16.0 % of a 50 Hz
circle's radius instead of 5.5 %; learning converged to the lag, 2.1 % instead of
0.6 %). A delay of the records shifts the outputs by whole samples, which a linear
model of the records fits only with that shift; a mode's phase it fits either way.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from hammerstein.models.dynamics import DynamicsError
from hammerstein.models._lti_subspace import identify_dynamics

#: Held-out fit [percentage points] by which G of the records shifted by one sample less
#: must beat G with the estimated delay for the smaller delay to be taken. Measured: 88.7
#: against 78.8 % on the outside stage above (a linear model of the raw records); 0.5-1.6
#: points on a simulated 2.5 kHz mode (damping 0.4, 0.2-1 % noise) whose delay was
#: overestimated by one; where the estimate was right (modes at 0.4-1.5 kHz, delays 0-3)
#: one sample less never fitted better (0.00-0.06 points worse: a delay is a state of G).
DELAY_FIT_MARGIN = 1.0
#: Largest order of the linear models compared (the commands' default search).
DELAY_CHECK_MAX_ORDER = 10


def _best_fit(inputs, outputs, T, delay):
    ins = [u[:, :u.shape[1] - delay] for u in inputs]
    outs = [y[:, delay:] for y in outputs]
    ins = [u - u.mean(axis=1, keepdims=True) for u in ins]
    outs = [y - y.mean(axis=1, keepdims=True) for y in outs]
    fits = identify_dynamics(ins, outs, T, max_order=DELAY_CHECK_MAX_ORDER).validation_fit_
    fits = np.asarray(fits, dtype=float)
    return float(np.nanmax(fits)) if np.any(np.isfinite(fits)) else float("nan")


def check_delay_by_fit(inputs, outputs, sampling_period, estimate):
    """The phase-slope delay, or one sample less where G fits the records better with it.

    A linear model of the records (inputs to outputs, subspace identification with
    its order searched on held-out samples,
    :func:`hammerstein.models.lti.identify_dynamics`) is fitted with the outputs
    advanced by the estimated delay ``d`` and by ``d - 1``; when the second fits the
    held-out samples better by more than :data:`DELAY_FIT_MARGIN` points, the delay is
    ``d - 1`` (a bending mode's group delay above it read as a delay, module notes).
    Only a smaller delay is tried: a mode or a sensor's low-pass adds group delay,
    never removes it.

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        The broadband records' inputs [V].
    outputs : list of array_like, each shape (p, n_samples)
        Their measured outputs [µm].
    sampling_period : float
        T [s].
    estimate : MeasurementDelay
        :func:`hammerstein.models.lti.estimate_measurement_delay`'s.

    Returns
    -------
    MeasurementDelay
        ``estimate`` when refused or 0; else with ``delay`` kept or lowered by one
        and ``checked`` saying which and both fits.

    Raises
    ------
    DynamicsError
        On malformed records (as :func:`identify_dynamics`).
    """
    d = int(estimate.delay)
    if estimate.problem is not None or d < 1:
        return estimate
    ins = [np.atleast_2d(np.asarray(u, dtype=float)) for u in inputs]
    outs = [np.atleast_2d(np.asarray(y, dtype=float)) for y in outputs]
    T = float(sampling_period)
    try:
        with_d, with_less = _best_fit(ins, outs, T, d), _best_fit(ins, outs, T, d - 1)
    except DynamicsError as exc:
        return dataclasses.replace(estimate, checked=f"not checked against G's fit ({exc})")
    words = (f"a linear model of the records fits their held-out samples at {with_less:.1f} % "
             f"with {d - 1} sample(s), {with_d:.1f} % with {d}")
    if with_less > with_d + DELAY_FIT_MARGIN:
        return dataclasses.replace(
            estimate, delay=d - 1,
            checked=f"{words}: {d - 1} taken (the phase slope holds a bending mode's group "
                    f"delay, not only the acquisition's)")
    return dataclasses.replace(estimate, checked=f"{words}: {d} kept")
