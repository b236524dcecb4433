"""C emitter of the Hammerstein compensator: the causal MIMO ZPETC inverse of the
linear dynamics (and the creep inverse) ahead of the exact inverse of a Preisach /
generalised-PI model (:mod:`hammerstein.export.c_exact`) or of the inverse multiplicative law
of a classical PI (:mod:`hammerstein.export.c_law`).
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.drive import rest_output
from hammerstein.compensation.inversion import ZPETCInverse
from hammerstein.compensation.hammerstein_compensator import creep_inverse
from hammerstein.compensation.lookahead import EXPORT_DECAY, MAX_LOOKAHEAD, creep_rest_state
from hammerstein.exceptions import ExportError
from hammerstein.export.c_base import (_check_model, _model_text)
from hammerstein.export.c_exact import _exact_source
from hammerstein.export.c_law import _Law, _law_source
from hammerstein.export.c_lookahead import lookahead_cost


def _refuse_stable(comp):
    """Why this stable inversion has no C step function: its look-ahead is too long."""
    P = comp.stable_lookahead(EXPORT_DECAY)
    return (f"inversion: {comp.inversion!r} cannot be exported here: its anti-causal part (G's "
            f"zeros outside the unit circle, the slowest at |z| = {comp.anticausal_radius:.6g}) "
            f"decays below {EXPORT_DECAY:g} only after {P} samples, and a look-ahead of more "
            f"than {MAX_LOOKAHEAD} samples is not built (its buffer, its terms and the time of a "
            f"step grow with it); export the Hammerstein compensator with inversion 'zpetc' "
            f"(the causal zero-phase-error inverse with {_preview_text(comp)}), or run "
            f"'hammerstein compensate' with the stable inversion and play its drive file")


def _plan_stable(comp):
    """The stable inversion of G as a look-ahead filter (:class:`LookaheadInverse`), then the
    creep inverse, then the exact inverse of a Preisach or generalised-PI model or the inverse
    multiplicative law of a classical PI (on the reference as given: the law's own transform
    after, as :meth:`HammersteinCompensator.simulate` runs them)."""
    la = comp.lookahead_inverse
    if la is None:
        raise ExportError(_refuse_stable(comp))
    hc, L = comp.hysteresis_compensator, la.preview_samples
    model = hc.model if comp.exact_static else _check_model(comp.model)
    rest = rest_output(model, comp.creep)          # where compensate's faded reference starts
    if not comp.exact_static and model.output_offset is not None:
        rest = rest - model.output_offset          # the inverse of L takes Yr - c (a sensor zero)
    stages, states = [], None
    if comp.creep is not None:
        mats = creep_inverse(comp.creep, comp.dynamics.dt)
        stages, states = [mats], creep_rest_state(mats, comp.bending_dynamics, rest)
    creep = "" if comp.creep is None else ", the exact creep inverse"
    state = la.initial_state(rest)
    what = (f"the exact per-sample inverse of the {_model_text(model)}" if comp.exact_static else
            f"the inverse multiplicative law ({int(hc.iterations)} iteration(s) per sample)")

    def build(precision, N, limits, T):
        if precision == "float":
            raise ExportError(_float_refusal(la))
        if comp.exact_static:
            return _exact_source(hc, stages, model, precision, N, limits, T, L, rest, states,
                                 lookahead=(la, state))
        return _law_source(_Law(hc.packed_law(), L), model, precision, N, limits, T,
                           lookahead=(la, state), stages=stages,
                           stage_states=None if states is None else [states])
    return ("exact" if comp.exact_static else "law", model, L,
            f"Hammerstein compensator U = Gamma^-1(G^-1 Yr): stable inversion of G over a "
            f"look-ahead of {L} sample{'s' if L != 1 else ''} ({lookahead_cost(la)} multiply-adds a step; the "
            f"anti-causal part truncated where |z|^-k of G's slowest zero outside the unit "
            f"circle, |z| = {la.anticausal_radius:.6g}, falls below {EXPORT_DECAY:g}){creep}, "
            f"then {what}", build)


def _float_refusal(la):
    """Why the look-ahead filter is not exported in float: its terms cancel."""
    terms = float(np.max(np.sum(np.abs(la.taps), axis=(0, 2))))
    return (f"precision: 'float': the stable inversion's look-ahead sums {la.preview_samples + 1} "
            f"terms that cancel (their absolute sum is {terms:.3g} times the reference); float's "
            f"rounding, 6e-8 of that sum, would leave about {terms * 6e-8:.2g} of the reference "
            f"in error; export it in double, or with inversion 'zpetc'")


def _plan_hammerstein(comp):
    if comp.inverse is None:
        return _plan_stable(comp)
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
    # the inverse filters Yr - c (S^-1(Yr - c) without a map): its state at rest in that
    # frame, as start() has it
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
