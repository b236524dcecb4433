"""The reference check of the Python compensators, the same as the exported C step's.

A reference sample that is not finite, or beyond
`NAME_reference_bound`, :func:`reference_bound` (10 x the model's largest
|output| over its input range), is no position the actuator can take but a
glitch (a wrong unit, an overflow). The exported step skips such a sample
and returns status 4; run in Python, one sample at 1e7 µm had left the
compensator's creep lags and dynamics saturating the amplifier (ux between
-12 and +12 V, still 1.85 V off 5.43 V 900 samples later) without a word.
:func:`check_reference` refuses it before anything runs, naming the first
offending sample: the caller's state is untouched, so a real-time loop can
skip the sample, as the C does, and carry on.
"""

from __future__ import annotations

import contextlib
import contextvars

import numpy as np

from hammerstein.core.numbers import MAX_MAGNITUDE
from hammerstein.exceptions import CompensatorError, HysteresisError

__all__ = ["check_reference", "reference_checked", "reference_bound", "REFERENCE_SPAN"]

#: a reference beyond this many times the model's largest |output| over its input range is a
#: glitch, skipped like NaN by the exported step and refused by :func:`check_reference`
#: (:func:`reference_bound`)
REFERENCE_SPAN = 10.0

#: Set while a compensator runs its inner compensator on its own intermediate signal (the
#: exported C checks the reference it is given, never what its inverse of G makes of it).
_INNER = contextvars.ContextVar("hammerstein_reference_checked", default=False)


@contextlib.contextmanager
def reference_checked():
    """Skip :func:`check_reference` inside (an outer compensator has checked its reference).

    Yields
    ------
    None
    """
    token = _INNER.set(True)
    try:
        yield
    finally:
        _INNER.reset(token)


def reference_bound(model, limits=None):
    """The largest |reference| a step takes: :data:`REFERENCE_SPAN` times the model's output scale.

    The output scale is the largest |output| of the hysteresis model along a
    path through the corners of its input range (``1.2 x input_amplitude``,
    widened to the amplifier's range where one is given), at least 1. A
    reference sample beyond it is no position the actuator can take but a
    glitch (a wrong unit, an overflow): the generated step skips it as it
    skips NaN, so that it neither poisons the compensator's state (a 1e200
    sample had left the inverse's creep lags and dynamics saturating the
    amplifier for good) nor runs the exact inverses' root search into
    overflow (a 1e306 sample had it never return).

    Parameters
    ----------
    model : object
        The compensator's hysteresis model (``n_inputs``, ``simulate``,
        ``input_amplitude`` or None).
    limits : AmplifierLimits, optional

    Returns
    -------
    float
        [output unit]; :data:`~hammerstein.core.numbers.MAX_MAGNITUDE` without an
        input range.
    """
    m = int(model.n_inputs)
    amp = getattr(model, "input_amplitude", None)
    U = None if amp is None else 1.2 * np.abs(np.broadcast_to(np.asarray(amp, dtype=float), (m,)))
    if limits is not None:
        lo, hi, _ = limits.arrays(m)
        wide = np.where(np.isfinite(lo) & np.isfinite(hi), np.maximum(np.abs(lo), np.abs(hi)), 0.0)
        U = wide if U is None else np.maximum(U, wide)
    if U is None or not np.all(np.isfinite(U)) or not np.any(U > 0):
        return MAX_MAGNITUDE
    corners = np.array([[1, 1], [-1, -1], [1, -1], [-1, 1], [0, 0]] if m == 2 else
                       [[1] * m, [-1] * m, [0] * m], dtype=float)
    path = np.vstack([np.zeros(m)] + list(corners))
    u = np.concatenate([np.linspace(a, b, 200, endpoint=False) for a, b in zip(path[:-1], path[1:])]).T
    y, _ = model.simulate(U[:, None] * u)
    scale = float(np.max(np.abs(y))) if np.all(np.isfinite(y)) else MAX_MAGNITUDE
    return float(min(REFERENCE_SPAN * max(scale, 1.0), MAX_MAGNITUDE))


def _bound(compensator, model):
    """The bound of :func:`reference_bound`, cached on the
    compensator for its model (computing it runs the model over 1000 samples)."""
    cached = getattr(compensator, "_reference_bound", None)
    if cached is not None and cached[0] is model:
        return cached[1]
    bound = reference_bound(model)
    try:
        object.__setattr__(compensator, "_reference_bound", (model, bound))
    except AttributeError:      # no instance dictionary: computed again next time
        pass
    return bound


def _where(model, arr, bad):
    k = int(np.flatnonzero(bad.any(axis=0))[0])
    i = int(np.flatnonzero(bad[:, k])[0])
    names = getattr(model, "output_names", None)
    name = f"{names[i]!r}" if names is not None and len(names) == arr.shape[0] else str(i)
    return k, i, f"sample {k} of output {name} is {arr[i, k]:.6g}"


def check_reference(compensator, reference):
    """Validate a reference for a compensator's ``simulate``; nothing is run on a bad one.

    Parameters
    ----------
    compensator : object
        A compensator with a ``model`` (its hysteresis model: ``n_outputs``,
        ``check_inputs``, ``simulate``, ``input_amplitude``).
    reference : array_like, shape (p, n_samples)
        The reference the compensator is given [µm, or the ``output_unit`` a
        model read from a file carries, in which the message gives it] (for
        a previewed Hammerstein compensator, the reference P samples ahead).

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
        The reference as a float array.

    Raises
    ------
    HysteresisError
        On a wrong shape, or a non-finite sample (the first one named).
    CompensatorError
        On a sample beyond the bound the exported C skips with status 4
        (:func:`reference_bound` of the compensator's model, without
        amplifier limits); the message names the
        first such sample, its output and value. The caller's state is not
        changed: skip the sample and call again.
    """
    model = compensator.model
    try:
        arr = np.asarray(reference, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.ndim == 2 and arr.shape[0] == model.n_outputs:
        finite = np.isfinite(arr)
        if not finite.all():
            raise HysteresisError(f"reference: expected finite values; {_where(model, arr, ~finite)[2]} "
                                  f"(nothing was run, the state is unchanged)")
    arr = model.check_inputs(reference, "reference")
    if _INNER.get() or arr.size == 0:
        return arr
    bound = _bound(compensator, model)
    beyond = np.abs(arr) > bound
    if beyond.any():
        unit = getattr(model, "output_unit", "µm")      # a model read from a file: its own
        raise CompensatorError(
            f"reference: {_where(model, arr, beyond)[2]} {unit}, beyond the {bound:.6g} {unit} a "
            f"compensator takes ({REFERENCE_SPAN:g} x the model's largest |output| over its input range; the "
            f"exported C skips such a sample with status 4): a glitch or a wrong unit, not a "
            f"position the actuator reaches; nothing was run (the state is unchanged)")
    return arr
