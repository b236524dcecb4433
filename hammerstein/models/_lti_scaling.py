"""Outputs of unequal units balanced before the subspace step.

A tip-tilt platform's tip and tilt in µrad (spanning 1100) beside its piston
in µm (spanning 4): the Hankel matrices' SVD, the order's choice and the
fit of B and D weigh the outputs by their units, and the small output's
modes are lost (a tester's piston output fitted at 59 %, with two spurious
lags at 3-5 Hz; a linear plant with one output read in a unit 300 times
smaller fitted it at 68 % instead of 99.4 %). Scaling each signal to a
comparable size before a subspace identification is the usual remedy
(Verhaegen and Verdult [1]_, Section 9.2): each output and its input (the
hysteresis model's output of the same unit) are divided by the output's
RMS, ``G' = S G S^-1`` is identified, and ``G = S^-1 G' S`` returned (the
same poles; ``G(0) = I`` is kept, as ``S I S^-1 = I``).

References
----------
.. [1] M. Verhaegen and V. Verdult, *Filtering and System Identification:
   A Least Squares Approach*, Cambridge University Press, 2007.
"""

from __future__ import annotations

import numpy as np

from hammerstein.core.lazy import lazy_module

control = lazy_module("control")

#: Outputs whose RMS differ by this ratio or more are balanced; records of one unit and
#: similar ranges are fitted as they are (bit for bit as before the balancing).
OUTPUT_SCALE_RATIO = 10.0


def output_scales(outs):
    """Each output's RMS about its mean over all records, or None when they are alike.

    Parameters
    ----------
    outs : list of numpy.ndarray, shape (p, n_samples)
        The records' outputs [their units].

    Returns
    -------
    numpy.ndarray, shape (p,), or None
        [the outputs' units]; None when the largest RMS is below
        :data:`OUTPUT_SCALE_RATIO` times the smallest, or an output is constant.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.vstack([np.sin(np.arange(100.0)), 1e3 * np.cos(np.arange(100.0))])
    >>> np.round(output_scales([y]), 2).tolist(), output_scales([y[:1]])
    ([0.71, 707.01], None)
    """
    y = np.concatenate([np.asarray(o, dtype=float) for o in outs], axis=1)
    rms = np.sqrt(np.mean((y - y.mean(axis=1, keepdims=True)) ** 2, axis=1))
    if not np.all(np.isfinite(rms)) or np.min(rms) <= 0:
        return None
    return rms if np.max(rms) >= OUTPUT_SCALE_RATIO * np.min(rms) else None


def balanced_fit(identifier, ins, outs, sampling_period):
    """Fit ``identifier`` on balanced records; its ``system_`` in the outputs' own units.

    Parameters
    ----------
    identifier : hammerstein.models.lti.DynamicsIdentifier
        Fitted in place (its private ``_fit``).
    ins, outs : list of numpy.ndarray, shape (p, n_samples)
        The records' inputs (the hysteresis model's outputs) and outputs, validated.
    sampling_period : float
        T [s].

    Returns
    -------
    DynamicsIdentifier
        ``identifier``, with ``output_scales_`` (the RMS it divided by, or None) and
        ``system_``, ``dc_gain_unconstrained_`` in the records' units.
    """
    scale = output_scales(outs)
    if scale is None:
        identifier._fit(ins, outs, sampling_period)
        identifier.output_scales_ = None
        return identifier
    identifier._fit([u / scale[:, None] for u in ins], [y / scale[:, None] for y in outs],
                    sampling_period)
    G = identifier.system_
    S, Si = np.diag(scale), np.diag(1.0 / scale)
    identifier.system_ = control.ss(G.A, G.B @ Si, S @ G.C, S @ G.D @ Si, dt=G.dt, name=G.name)
    identifier.dc_gain_unconstrained_ = S @ identifier.dc_gain_unconstrained_ @ Si
    identifier.output_scales_ = scale
    return identifier
