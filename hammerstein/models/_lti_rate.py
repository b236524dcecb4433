"""Records faster than their dynamics need: decimation before the subspace fit.

At a high sampling rate the bending modes sit close to z = 1 and the Hankel
matrices of the subspace step (a few tens of block rows) span a small
fraction of a mode's period: the modes of one output are not separated (the
singular values show half of the states) and the fitted modes are wrong
(measured: a plant with modes at 350 and 520 Hz in each output, records at
50 kHz, 14 block rows = 0.28 ms, modes found at 365 and 515 Hz with twice the
damping; the same records decimated to 10 kHz give 350.0 and 519.8 Hz). The
usual remedy of system identification (Ljung [1], Section 13.7; Pintelon
and Schoukens [2], Section 2.6) is applied here: low-pass filter (zero
phase) and decimate inputs and outputs alike, identify at the lower rate,
and return the model at the records' own sampling period through its
continuous-time (ZOH) equivalent.

References
----------
.. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
   Prentice Hall, 1999.
.. [2] R. Pintelon, J. Schoukens, *System Identification: A Frequency
   Domain Approach*, 2nd ed., Wiley-IEEE Press, 2012.
"""

from __future__ import annotations

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.models._lti_systems import continuous_system

control = lazy_module("control")

#: The rate [Hz] the bending modes are identified at, at most (``DynamicsIdentifier``'s
#: default ``max_rate_hz``): faster records are decimated near it (:func:`decimation_factor`).
DYNAMICS_RATE_HZ = 1e4


def decimation_factor(sampling_period, max_rate_hz=DYNAMICS_RATE_HZ):
    """The odd integer factor that brings records near ``max_rate_hz``, or 1.

    Records are decimated only when their rate is at least 2.5 times
    ``max_rate_hz`` (so records at 20 kHz and below are identified as they
    are with the default 10 kHz); the factor is the largest odd integer
    ``q <= rate / max_rate_hz`` (odd: the half-sample delay of the ZOH is
    then corrected by a whole number of samples, :func:`decimate_records`).

    Parameters
    ----------
    sampling_period : float
        T of the records [s].
    max_rate_hz : float or None
        Rate the identification needs at most [Hz] (default
        :data:`DYNAMICS_RATE_HZ`); None: never decimate.

    Returns
    -------
    int
        q >= 1; the identification runs at ``q T``.

    Examples
    --------
    >>> decimation_factor(2e-5, 1e4), decimation_factor(1e-5, 1e4), decimation_factor(5e-5, 1e4)
    (5, 9, 1)
    """
    if max_rate_hz is None or not max_rate_hz > 0:
        return 1
    ratio = 1.0 / (float(sampling_period) * float(max_rate_hz))
    if ratio < 2.5 - 1e-9:
        return 1
    q = int(np.floor(ratio + 1e-9))
    return q if q % 2 else q - 1


def decimate_records(ins, outs, q):
    """Inputs and outputs low-pass filtered (zero phase) and decimated by ``q``.

    Both are filtered by the same FIR (:func:`scipy.signal.decimate`,
    ``ftype="fir"``, ``zero_phase=True``): the filter is scalar, so it commutes
    with G and the decimated pairs hold G in the band kept. The records' ZOH
    inputs give outputs that lag the sampled continuous response by half a
    sample, while a ZOH model at ``q T`` assumes a lag of ``q T / 2``: the
    outputs are delayed by ``(q - 1) / 2`` samples (q odd) before the
    decimation (their first sample repeated), so that the model found at
    ``q T``, mapped to continuous time, is the actuator's.

    Parameters
    ----------
    ins, outs : list of numpy.ndarray, each shape (p, n_samples)
        Records at T (inputs [µm], outputs [µm]).
    q : int
        Odd decimation factor (>= 3).

    Returns
    -------
    ins, outs : list of numpy.ndarray, each shape (p, ceil(n_samples / q))
        The records at ``q T``.
    """
    from scipy import signal   # lazy: only when fast records are identified

    m = (q - 1) // 2
    dec = lambda x: signal.decimate(x, q, ftype="fir", zero_phase=True, axis=1)
    late = [np.concatenate([np.repeat(y[:, :1], m, axis=1), y[:, :y.shape[1] - m]], axis=1)
            for y in outs]
    return [dec(u) for u in ins], [dec(y) for y in late]


def at_rate(system, sampling_period):
    """A discrete system resampled (exact ZOH through continuous time) to another period.

    Parameters
    ----------
    system : control.StateSpace
        Discrete system (``dt`` > 0), no real pole at z <= 0.
    sampling_period : float
        New period [s].

    Returns
    -------
    control.StateSpace
        ``c2d(d2c(system), sampling_period, "zoh")`` with the same state
        coordinates (initial states carry over), DC gain unchanged.
    """
    return control.c2d(continuous_system(system), float(sampling_period), "zoh")


def fit_decimated(identifier, ins, outs, sampling_period, q):
    """Fit an identifier at ``q T`` on decimated records, its ``system_`` returned at T.

    Parameters
    ----------
    identifier : DynamicsIdentifier
        Fitted in place (its ``sensor`` filter already applied to ``ins``).
    ins, outs : list of numpy.ndarray, each shape (p, n_samples)
        Records at T (inputs [µm], outputs [µm]).
    sampling_period : float
        T [s].
    q : int
        Odd factor from :func:`decimation_factor`.

    Returns
    -------
    DynamicsIdentifier
        ``identifier``: ``system_`` at T (:func:`at_rate`), ``decimation_ = q``,
        ``sampling_period_ = T``; the candidates, held-out fits, singular
        values and initial states are those of the fit at ``q T`` (the
        held-out fit measured in the band kept, without the noise above it).
    """
    from dataclasses import replace

    T = float(sampling_period)
    di, do = decimate_records(ins, outs, q)
    inner = replace(identifier, sensor=None, max_rate_hz=None).fit(di, do, q * T)
    for key, value in vars(inner).items():
        if key.endswith("_"):
            setattr(identifier, key, value)
    identifier.system_ = at_rate(inner.system_, T)
    identifier.system_.name = inner.system_.name
    identifier.sampling_period_ = T
    identifier.decimation_ = q
    identifier.validation_ = (f"{inner.validation_}, on the records low-pass filtered and "
                              f"decimated by {q} to {1 / (q * T):.4g} Hz")
    return identifier
