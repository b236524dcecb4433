"""The output range a classical PI model was identified on, and a reference beyond it.

:func:`check_reference_range` warns (:class:`~hammerstein.exceptions.RangeWarning`) when a
reference leaves the range of a square
:class:`~hammerstein.models.hysteresis.MultivariablePI`'s direct transfers over their
identified input range, where every compensator built on the model extrapolates. Used by
the compensators of :mod:`hammerstein.compensation.compensators` (which re-exports it) and
by the sweeps.
"""

from __future__ import annotations

import warnings

import numpy as np

from hammerstein.exceptions import CompensatorError, RangeWarning
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii

__all__ = ["check_reference_range"]


def _square(model, what):
    if not isinstance(model, MultivariablePI):
        raise CompensatorError(f"model: expected a MultivariablePI, found {type(model).__name__}")
    if model.n_outputs != model.n_inputs:
        raise CompensatorError(
            f"model: {what} needs a square model, found {model.n_outputs} outputs "
            f"and {model.n_inputs} inputs")


def _direct_name(model, l):
    return f"Gamma_{model.output_names[l]}{model.input_names[l]}"


def check_reference_range(model: MultivariablePI, reference, warn=True):
    """Compare a reference with the output range the model was identified on.

    The identified range of output l is the peak of its direct transfer at
    the identification amplitude, ``|Gamma_ll|`` peak ``sum_i w_i (A_l -
    r_i)`` (docs/multivariable-model.md; a linear direct gain g gives ``|g| A_l``),
    around the major loop's centre ``c_l sum_{r_i < A_l} w_i`` (``g c_l``) for an input
    range centred on ``c_l = input_centre[l]`` (0 by default): the plays the loop
    switches oscillate between ``c - A + r_i`` and ``c + A - r_i``; it is widened to
    hold the model's output at 0 V from its initial state, where a drive starts. Beyond
    it the model (hence every compensator) extrapolates.

    Parameters
    ----------
    model : MultivariablePI
        Square model with ``input_amplitude`` (otherwise nothing is checked).
    reference : array_like, shape (m, n_samples)
        Reference displacements [µm].
    warn : bool
        Emit a :class:`RangeWarning` when some ratio exceeds 1.

    Returns
    -------
    numpy.ndarray, shape (m,) or None
        Per output [-], the reference's largest distance from the middle of the
        identified range over its half-width (``max |Yr_l| / peak_l`` for a range
        symmetric about 0); None when the model has no ``input_amplitude``.

    Raises
    ------
    CompensatorError
        If the model is not square.
    HysteresisError
        If the reference is not a finite (m, n_samples) array.
    """
    _square(model, "the reference range check")
    yr = model.check_inputs(reference, "reference")
    if model.input_amplitude is None:
        return None
    peaks, centres = np.zeros(model.n_outputs), np.zeros(model.n_outputs)
    c_in = np.zeros(model.n_inputs) if model.input_centre is None else model.input_centre
    for l in range(model.n_outputs):
        comp, A = model.components[l][l], model.input_amplitude[l]
        if isinstance(comp, PrandtlIshlinskii):
            peaks[l] = abs(comp.peak_output(A))
            centres[l] = c_in[l] * float(np.sum(comp.weights[comp.thresholds < A]))
        elif comp is not None:
            peaks[l], centres[l] = abs(comp) * A, comp * c_in[l]
    # the range also holds the rest, the model's output at 0 V from its start (a drive fades
    # in from it): a unipolar stack's virgin 0 µm lies below its major loop's lower end
    rest = model.evaluate(np.zeros(model.n_inputs), model.initial_state())[0]
    low = np.minimum(centres - peaks, rest)
    high = np.maximum(centres + peaks, rest)
    mid, half = 0.5 * (low + high), 0.5 * (high - low)
    g = model.gamma_reference(yr)           # the range is that of Gamma: S^-1(Yr - c)
    far = np.abs(g - mid[:, None])
    reach = np.max(far, axis=1) if g.shape[1] else np.zeros(model.n_outputs)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(half > 0, reach / np.where(half > 0, half, 1.0), np.where(reach > 0, np.inf, 0.0))
    if warn and np.any(ratio > 1 + 1e-9):
        unit = getattr(model, "output_unit", "µm")      # a model read from a file: its own

        def beyond(l):
            if abs(mid[l]) <= 1e-12 * max(half[l], 1.0):      # a range symmetric about 0
                return f"{model.output_names[l]}: {reach[l]:.4g} {unit} > {half[l]:.4g} {unit}"
            worst = float(g[l, int(np.argmax(far[l]))])
            return (f"{model.output_names[l]}: {worst:.4g} {unit} outside "
                    f"{low[l]:.4g}..{high[l]:.4g} {unit}")

        bad = [beyond(l) for l in np.flatnonzero(ratio > 1 + 1e-9)]
        origin = getattr(model, "identified_from", None)   # core/presets.load_model
        where = f", identified from {origin}" if origin else ""
        warnings.warn("reference: beyond the range the model was identified on ("
                      + "; ".join(bad) + f"{where}); the compensator extrapolates", RangeWarning,
                      stacklevel=3)
    return ratio
