"""C emitter of the Hammerstein compensator: the causal MIMO ZPETC inverse of the
linear dynamics (and the creep inverse) ahead of the exact inverse of a Preisach /
generalised-PI model (:mod:`hammerstein.export.c_exact`) or of the inverse multiplicative law
of a classical PI (:mod:`hammerstein.export.c_law`).
"""

from __future__ import annotations

from hammerstein.compensation.inversion import ZPETCInverse
from hammerstein.exceptions import ExportError
from hammerstein.export.c_base import (_check_model, _model_text)
from hammerstein.export.c_exact import _exact_source
from hammerstein.export.c_law import _Law, _law_source


def _plan_hammerstein(comp):
    if comp.inverse is None:
        raise ExportError(f"inversion: {comp.inversion!r} inverts the whole record at once "
                          f"(non-causal: each voltage depends on the whole future reference) and "
                          f"cannot run sample by sample; export the Hammerstein compensator with "
                          f"inversion 'zpetc' (the causal inverse with {_preview_text(comp)})")
    P = int(comp.preview_samples)
    creep = "" if comp.creep is None else " and the exact creep inverse"
    if comp.exact_static:
        hc = comp.hysteresis_compensator
        inv = comp.inverse
        stages = [inv.bending.state_space(), inv.creep_matrices] if comp.creep is not None \
            else [inv.state_space()]
        return ("exact", hc.model, P,
                f"Hammerstein compensator U = Gamma^-1(G^-1 Yr): causal MIMO ZPETC inverse ({P} "
                f"samples of preview){creep} then the exact per-sample inverse of the "
                f"{_model_text(hc.model)}",
                lambda precision, N, limits, T: _exact_source(hc, stages, hc.model, precision, N,
                                                              limits, T, P))
    model = _check_model(comp.model)
    with comp.previewed():      # the C step receives the reference P samples ahead
        law = comp.packed_law()
    return ("law", model, P,
            f"Hammerstein compensator U = Gamma^c(G^-1 Yr): causal MIMO ZPETC inverse ({P} samples "
            f"of preview){creep} then the inverse multiplicative law",
            lambda precision, N, limits, T: _law_source(_Law(law, P), model, precision, N, limits, T))


def _preview_text(comp):
    try:
        return f"{int(ZPETCInverse(comp.bending_dynamics).preview_samples)} samples of preview"
    except Exception:        # noqa: BLE001 - only a hint in a message
        return "a few samples of preview"
