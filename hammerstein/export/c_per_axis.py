"""C emitter of the per-axis analytic inverse PI (Kuhnen & Janocha: the shifted
inverse PI, then the inverse play of threshold r_1) of a classical PI's direct transfers.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.inverse import FLOAT_MOTION_TOLERANCE, MOTION_TOLERANCE, InversePI
from hammerstein.export.c_base import (_lit, _vec, _check_model, _reference_transform,
                                       _limits_code, _PLAY)


def _tolerance(inv, precision):
    """The inverse play's motion tolerance [V]: Python's in double; in float, scaled to float's
    rounding (the weighted sum rounds 1e8 times coarser: a held reference jumped 2 r_1)."""
    e = inv.play_inverse.tolerance
    return e if precision == "double" else e * (FLOAT_MOTION_TOLERANCE / MOTION_TOLERANCE)


def _per_axis_source(comp, model, precision, N, limits, T):
    m = model.n_inputs
    decls, members, init = [], [f"    {N}_real u[{N}_N_INPUTS];   /* last voltages [V] */"], []
    zero = "0.0" if precision == "double" else "0.0f"
    reals = m
    code = []
    rest = comp.initial_state()     # each axis's inverse consistent with the model's start
    for l, inv in enumerate(comp.inverses):
        if isinstance(inv, InversePI):
            pi = inv.shifted_inverse
            n = pi.n_hysterons
            s0 = rest[comp._offsets[l]:comp._offsets[l + 1]]    # q, then [v(-T), u(-T)]
            decls += [f"static const {N}_real {N}_r{l}[{n}] = {_vec(pi.thresholds, precision)};  /* r'_i [um] */",
                      f"static const {N}_real {N}_w{l}[{n}] = {_vec(pi.weights, precision)};  /* w'_i [V/um] */",
                      f"static const {N}_real {N}_r1_{l} = {_lit(inv.play_inverse.threshold, precision)};  /* r_1 [V] */",
                      f"static const {N}_real {N}_e{l} = {_lit(_tolerance(inv, precision), precision)};"
                      f"  /* motion of v ignored [V] */"]
            members += [f"    {N}_real q{l}[{n}];      /* inverse PI plays of axis {l} [um] */",
                        f"    {N}_real v{l}, d{l};    /* last moved shifted-inverse output [V], inverse-play offset [V] */"]
            reals += n + 2
            if np.any(s0):   # after the demagnetising cycle: d = u(-T) - v(-T)
                decls.append(f"static const {N}_real {N}_q{l}_rest[{n}] = {_vec(s0[:n], precision)};"
                             f"  /* axis {l}'s inverse plays after the demagnetising cycle [um] */")
                init += [f"    for (j = 0; j < {n}; ++j) s->q{l}[j] = {N}_q{l}_rest[j];",
                         f"    s->v{l} = {_lit(s0[n], precision)}; "
                         f"s->d{l} = {_lit(s0[n + 1] - s0[n], precision)};"]
            else:
                init += [f"    for (j = 0; j < {n}; ++j) s->q{l}[j] = {zero};",
                         f"    s->v{l} = {zero}; s->d{l} = {zero};"]
            code.append(f"""    {{  /* axis {l}: inverse PI (Kuhnen & Janocha) then the inverse play of r_1 */
        {N}_real v = {zero};
        for (j = 0; j < {n}; ++j) s->q{l}[j] = {N}_play(s->q{l}[j], r[{l}], {N}_r{l}[j]);
        for (j = 0; j < {n}; ++j) v += {N}_w{l}[j] * s->q{l}[j];
        if (v > s->v{l} + {N}_e{l}) {{ s->v{l} = v; s->d{l} = {N}_r1_{l}; }}   /* within e: rounding, held */
        else if (v < s->v{l} - {N}_e{l}) {{ s->v{l} = v; s->d{l} = -{N}_r1_{l}; }}
        u[{l}] = s->v{l} + s->d{l};
    }}""")
        else:
            decls.append(f"static const {N}_real {N}_ginv{l} = {_lit(inv, precision)};  /* 1/g [V/um] */")
            code.append(f"    u[{l}] = {N}_ginv{l} * r[{l}];")
    tdecls, tcode = _reference_transform(model, precision, N)
    ldecls, lcode, _ = _limits_code(limits, m, T, precision, N)
    body = [_PLAY.format(N=N)] if any(isinstance(i, InversePI) for i in comp.inverses) else []
    init.append("    s->diverged = 0;")
    members.append("    int diverged;             /* latched divergence flag */")
    body.append(f"""void {N}_init({N}_state *s)
{{
    int j, k;
    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {zero};
{chr(10).join(init)}
    (void)j;
}}
""")
    body.append("\n".join([f"""int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS])
{{
    {N}_real r[{N}_N_OUTPUTS], u[{N}_N_INPUTS];
    int j, k, l, status = 0;
@REFERENCE_CHECK@
    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = reference[l];"""] + tcode + code + [
"@VOLTAGE_CHECK@"] + lcode + [f"""    (void)j;
    return status;
}}
"""]))
    return decls + tdecls + ldecls, body, members, [], reals


def _plan_per_axis(comp):
    model = _check_model(comp.model)
    return ("per-axis", model, 0,
            "per-axis analytic inverse PI (Kuhnen & Janocha) of the direct transfers",
            lambda precision, N, limits, T: _per_axis_source(comp, model, precision, N, limits, T))
