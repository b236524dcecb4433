"""The warning of a rate-independent treatment at frequencies the linear dynamics shape.

Shared by the scenario cases (:func:`hammerstein.scenario.resolve.dynamics_warning`)
and the Monte-Carlo studies (:mod:`hammerstein.scenario.montecarlo`), which
ran rate-independent kinds at 20-100 Hz on a plant whose dynamics changed the
response by 18.7-71.8 % without a word, where a frequency sweep warned.
"""

from __future__ import annotations

import numpy as np

from hammerstein.models.lti import modal_parameters

__all__ = ["RESONANCE_FRACTION", "GAIN_DEVIATION", "dynamics_effect", "rate_independent_warning"]

#: a reference reaches the dynamics above this fraction of the first resonance ...
RESONANCE_FRACTION = 0.1
#: ... or where |G(f) G(0)^-1 - I| exceeds this
GAIN_DEVIATION = 0.02


def dynamics_effect(lin, frequency, what="the plant's linear dynamics", moved=slice(None)):
    """What the linear dynamics do at a frequency, when a rate-independent treatment should hear it.

    Parameters
    ----------
    lin : LinearDynamics
        The linear part (``frequency_response_hz``, and modal parameters).
    frequency : float
        The reference's (or drive's) highest frequency f [Hz].
    what : str
        How the dynamics are named in the text.
    moved : slice or list of int
        The columns (outputs a reference moves) judged.

    Returns
    -------
    str or None
        ``"at f Hz <what> (first resonance F Hz) change the response by D %"``
        when f is above :data:`RESONANCE_FRACTION` of the first resonance or
        ``|G(f) G(0)^-1 - I|_2`` exceeds :data:`GAIN_DEVIATION`; else None.

    Examples
    --------
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.scenario.rate_warning import dynamics_effect
    >>> lin = load_plant("rakotondrabe-2dof").sampled_dynamics
    >>> dynamics_effect(lin, 1.0) is None, dynamics_effect(lin, 200.0)[:10]
    (True, 'at 200 Hz ')
    """
    fn, zeta = modal_parameters(lin)
    resonant = fn[zeta < 1.0 / np.sqrt(2.0)]
    f_res = float(resonant.min()) if resonant.size else float(fn.min())
    c = lin.frequency_response_hz([1e-3, float(frequency)])
    change = c[:, :, 1] @ np.linalg.inv(np.real(c[:, :, 0])) - np.eye(c.shape[0])
    dev = float(np.linalg.norm(change[:, moved], 2))
    if frequency <= RESONANCE_FRACTION * f_res and dev <= GAIN_DEVIATION:
        return None
    return (f"at {frequency:g} Hz {what} (first resonance {f_res:.0f} Hz) "
            f"change the response by {100 * dev:.1f} %")


def rate_independent_warning(kind, effect):
    """The warning of a rate-independent compensator kind where the dynamics act.

    Parameters
    ----------
    kind : str
        The compensator kind.
    effect : str
        :func:`dynamics_effect`'s text.

    Returns
    -------
    str

    Examples
    --------
    >>> from hammerstein.scenario.rate_warning import rate_independent_warning
    >>> rate_independent_warning("diagonal", "at 100 Hz ...")[:47]
    "compensator kind = 'diagonal' is rate independe"
    """
    return (f"compensator kind = {kind!r} is rate independent: {effect}, which it does not "
            f"compensate; kind = \"hammerstein\" does (docs/hammerstein-plant.md)")
