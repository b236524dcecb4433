"""Whether a scenario's plant and its compensator share one model, and the report's words for it.

A scenario whose ``[plant]`` is the very model its compensator inverts (the
default ``model = "plant"``, the same preset file given as ``model``, or an
``identify`` table whose records produced the plant's preset) measures the
compensator solving its own model: its errors (0.002 % where the actuator
shows several percent) are no estimate of the actuator's. The report says so
(:func:`shared_model_lines`, used by :mod:`hammerstein.report.scenario` and
the dynamics section of :mod:`hammerstein.report.identified`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["shares_model", "shared_model_cases", "shared_model_lines", "one_model_lines",
           "SHARED_MODEL_WORDS"]

#: The report's sentence on a plant that is its compensator's model.
SHARED_MODEL_WORDS = (
    "the plant and the compensator share one model (the plant is the model the compensator "
    "inverts), so the errors below show the compensator solving its own model, not the "
    "error it would leave on the actuator; `hammerstein evaluate` and `learn` on measured "
    "responses measure that (docs/hardware.md)")


def _probe(model, n=400):
    """A drive of every input in turn: a triangle 0 -> +A -> -A -> 0 [V], shape (m, m n)."""
    m = int(model.n_inputs)
    amp = getattr(model, "input_amplitude", None)
    amp = np.full(m, 10.0) if amp is None else np.broadcast_to(np.asarray(amp, float), (m,))
    s = np.linspace(0.0, 1.0, n, endpoint=False)
    wave = np.interp(s, [0.0, 0.25, 0.75, 1.0], [0.0, 1.0, -1.0, 0.0])
    u = np.zeros((m, m * n))
    for k in range(m):
        u[k, k * n:(k + 1) * n] = amp[k] * wave
    return u


def shares_model(plant, compensator, rtol=1e-9, atol=1e-9):
    """Whether a compensator's hysteresis model is its plant's (same responses to a probe drive).

    Parameters
    ----------
    plant : HammersteinPlant or None
        The case's plant (its ``hysteresis`` model).
    compensator : object or None
        The built compensator (its ``model``).
    rtol, atol : float
        Tolerances of the comparison of the two models' outputs [µm].

    Returns
    -------
    bool
        True when the compensator's model is the plant's model object, or
        answers every input's triangle drive (each input in turn to its
        ``input_amplitude``, 10 V without one, and back) as the plant's
        does; False without a model, for models of other sizes, or when
        either cannot be simulated.
    """
    model = getattr(compensator, "model", None)
    mine = getattr(plant, "hysteresis", None)
    if model is None or mine is None or not hasattr(model, "simulate"):
        return False
    if model is mine:
        return True
    try:
        if (model.n_inputs, model.n_outputs) != (mine.n_inputs, mine.n_outputs):
            return False
        u = _probe(mine)
        a, b = model.simulate(u)[0], mine.simulate(u)[0]
    except (AttributeError, TypeError, ValueError):
        return False
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=rtol, atol=atol))


def shared_model_cases(results):
    """Names of the cases whose plant is their compensator's model.

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult

    Returns
    -------
    list of str
    """
    return [r.name for r in results
            if r.spec.mode == "reference" and shares_model(r.spec.plant, r.spec.compensator)]


def shared_model_lines(results):
    """The report's paragraph on the cases whose plant is their compensator's model, or [].

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult

    Returns
    -------
    list of str
        ``["One model: ...", ""]`` naming the cases (all, or the first six
        and how many more), or empty when no case shares its model.
    """
    return one_model_lines(shared_model_cases(results),
                           sum(r.spec.mode == "reference" for r in results))


def one_model_lines(names, n_compensated, more=""):
    """The **One model:** paragraph naming the cases that share their plant's model, or [].

    Parameters
    ----------
    names : list of str
        The cases whose plant is their compensator's model.
    n_compensated : int
        How many compensated cases there are (all named: "every compensated case").
    more : str
        Words appended to the paragraph's sentence (e.g. what a feedback report adds).

    Returns
    -------
    list of str
        ``["**One model:** ...", ""]`` naming the cases (all, or the first six and how
        many more), or empty when ``names`` is.
    """
    if not names:
        return []
    which = ("in every compensated case" if len(names) == n_compensated else
             "in " + ", ".join(f"`{c}`" for c in names[:6])
             + (f" and {len(names) - 6} more" if len(names) > 6 else ""))
    return [f"**One model:** {which}, {SHARED_MODEL_WORDS}{more}.", ""]
