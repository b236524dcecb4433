"""C emitter of the Hammerstein compensator: the causal MIMO ZPETC inverse of the
linear dynamics (and the creep inverse) ahead of the exact inverse of a Preisach /
generalised-PI model (:mod:`hammerstein.export.c_exact`) or of the inverse multiplicative law
of a classical PI (:mod:`hammerstein.export.c_law`).
"""

from __future__ import annotations

from hammerstein.compensation.drive import rest_output
from hammerstein.compensation.inversion import ZPETCInverse
from hammerstein.exceptions import ExportError
from hammerstein.export.c_base import (_check_model, _model_text)
from hammerstein.export.c_exact import _exact_source
from hammerstein.export.c_law import _Law, _law_source


def _stable_lookahead(comp):
    """Look-ahead [samples] after which the anti-causal part of the stable inverse has decayed
    below 1e-12 (:meth:`HammersteinCompensator.stable_lookahead`); None when it cannot be
    computed."""
    try:
        return comp.stable_lookahead(1e-12)
    except Exception:        # noqa: BLE001 - only a figure in a message
        return None


def _refuse_stable(comp):
    """The reason the whole-record stable inversion has no C step function."""
    P = _stable_lookahead(comp)
    if P == 0:
        why = ("G has no zero outside the unit circle here, yet the stable inversion works on "
               "the record as a whole (it starts at the DC equilibrium of the first reference "
               "sample and extrapolates the record past its end), which a step function "
               "cannot know; 'zpetc' inverts such zeros exactly (it approximates only zeros "
               "outside the unit circle or near -1)")
    else:
        why = ("its anti-causal part (the zeros of G outside the unit circle) runs backward "
               "from the end of the record, started at the DC equilibrium of the last "
               "reference sample; a step function never knows where the record ends, so no "
               "finite look-ahead gives the same voltages" +
               ("" if P is None else f" (a look-ahead truncated after {P} samples, where "
                                     f"|z|^-P of the slowest such zero falls below 1e-12, would "
                                     f"match it except near the record's end)"))
    return (f"inversion: {comp.inversion!r} inverts the whole record at once and cannot be "
            f"one causal step function: {why}; export the Hammerstein compensator with "
            f"inversion 'zpetc' (the causal zero-phase-error inverse with "
            f"{_preview_text(comp)}, the closest exportable kind), or run 'hammerstein "
            f"compensate' with the stable inversion and play its drive file")


def _plan_hammerstein(comp):
    if comp.inverse is None:
        raise ExportError(_refuse_stable(comp))
    P = int(comp.preview_samples)
    creep = "" if comp.creep is None else " and the exact creep inverse"
    if comp.exact_static:
        hc = comp.hysteresis_compensator
        inv = comp.inverse
        stages = [inv.bending.state_space(), inv.creep_matrices] if comp.creep is not None \
            else [inv.state_space()]
        rest = rest_output(hc.model, comp.creep)    # where compensate's faded reference starts
        rest_states = inv.initial_state(rest)        # the inverse's state there, as start() has it
        return ("exact", hc.model, P,
                f"Hammerstein compensator U = Gamma^-1(G^-1 Yr): causal MIMO ZPETC inverse ({P} "
                f"samples of preview){creep} then the exact per-sample inverse of the "
                f"{_model_text(hc.model)}",
                lambda precision, N, limits, T: _exact_source(hc, stages, hc.model, precision, N,
                                                              limits, T, P, rest, rest_states))
    model = _check_model(comp.model)
    with comp.previewed():      # the C step receives the reference P samples ahead
        law = comp.packed_law()
    rest = rest_output(comp.model, comp.creep)       # where compensate's faded reference starts
    # the inverse filters S^-1(Yr - c): its state at rest in that frame, as start() has it
    rest = comp.prefilter_reference(rest[:, None])[:, 0]
    rest_states = comp.inverse.initial_state(rest)
    return ("law", model, P,
            f"Hammerstein compensator U = Gamma^c(G^-1 Yr): causal MIMO ZPETC inverse ({P} samples "
            f"of preview){creep} then the inverse multiplicative law",
            lambda precision, N, limits, T: _law_source(_Law(law, P, rest, rest_states), model,
                                                        precision, N, limits, T))


def _preview_text(comp):
    try:
        return f"{int(ZPETCInverse(comp.bending_dynamics).preview_samples)} samples of preview"
    except Exception:        # noqa: BLE001 - only a hint in a message
        return "a few samples of preview"
