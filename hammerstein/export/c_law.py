"""C emitter of the inverse multiplicative law (Theorem 4.1 of Rakotondrabe's paper,
normalised by K) over a classical PI: delay law with fixed-point iterations on frozen play
states, or the low-pass law of its Section 6; with the ZPETC pre-filter of a Hammerstein
compensator when given one (:mod:`hammerstein.export.c_hammerstein`).
"""

from __future__ import annotations

import numpy as np

from hammerstein.export.c_base import (_float_realization, _lit, _vec, _mat, _ints, _check_model, _packed_plays,
                                       _packed_start,
                                       _reference_transform_parts, _limits_code, _reals_table, _stage_rest,
                                       _stages_source)
from hammerstein.export.c_lookahead import _lookahead_code


__all__ = ["law_preview"]


def _law_source(law, model, precision, N, limits, T, lookahead=None, stages=(), stage_states=None):
    """The law's C; ``lookahead``: ``(la, state)``, the stable inversion of G ahead of it
    (:func:`hammerstein.export.c_lookahead._lookahead_code`), then the linear ``stages`` (the
    creep inverse) started at ``stage_states``, before the law's own reference transform, as
    :meth:`HammersteinCompensator.simulate` runs them."""
    start, r, W, G = _packed_plays(model)
    m, p = model.n_inputs, model.n_outputs
    nplays = r.size
    prefilter = law.prefilter
    if precision == "float" and prefilter is not None:     # a realization float can carry
        prefilter = _float_realization(*prefilter)
    nf = 0 if prefilter is None else int(np.asarray(prefilter[0]).shape[0])
    decls = [f"#define {N}_N_PLAYS {nplays}",
             f"#define {N}_ITERATIONS {int(law.iterations)}",
             f"static const int {N}_play_start[{N}_N_INPUTS + 1] = {_ints(start)};",
             f"static const {N}_real {N}_play_r[{N}_N_PLAYS] = {_vec(r, precision)};  /* thresholds [V] */",
             f"static const {N}_real {N}_WT[{N}_N_PLAYS][{N}_N_OUTPUTS] = {_mat(W.T, precision)};  /* weights [um/V], one row per play */",
             f"static const {N}_real {N}_G[{N}_N_OUTPUTS][{N}_N_INPUTS] = {_mat(G, precision)};  /* linear components [um/V] */",
             f"static const {N}_real {N}_K_inv[{N}_N_INPUTS][{N}_N_OUTPUTS] = {_mat(law.K_inv, precision)};  /* K^-1 [V/um] */",
             f"static const {N}_real {N}_bound = {_lit(law.divergence_bound, precision)};  /* divergence bound [V] */"]
    if law.lowpass:
        decls.append(f"static const {N}_real {N}_pole = {_lit(law.pole, precision)};  /* exp(-2 pi fc T) */")
    if nf:
        Af, Bf, Cf, Df = (np.atleast_2d(np.asarray(M, dtype=float)) for M in prefilter)
        decls += [f"static const {N}_real {N}_Af[{N}_N_FILTER][{N}_N_FILTER] = {_mat(Af, precision)};",
                  f"static const {N}_real {N}_Bf[{N}_N_FILTER][{N}_N_OUTPUTS] = {_mat(Bf, precision)};",
                  f"static const {N}_real {N}_Cf[{N}_N_OUTPUTS][{N}_N_FILTER] = {_mat(Cf, precision)};",
                  f"static const {N}_real {N}_Df[{N}_N_OUTPUTS][{N}_N_OUTPUTS] = {_mat(Df, precision)};"]
    tdecls, tcode, tmap = _reference_transform_parts(model, precision, N)
    if not nf or lookahead is not None:   # no linear inverse in the law: S^-1(r - c) at once
        tcode, tmap = tcode + tmap, []      # (ZPETC: r - c, its inverse, then S^-1, nonlinear)
    ldecls, lcode, _ = _limits_code(limits, m, T, precision, N)
    one = "1.0" if precision == "double" else "1.0f"
    zero = "0.0" if precision == "double" else "0.0f"
    body = []
    # The play loops: W transposed (one row of p weights per play, contiguous), the play
    # update and the weighted sum fused, the p sums in local accumulators: the same additions
    # in the same order as the kernels (ascending plays, then G u), so the same result.
    acc_decl = ", ".join(f"y{l} = {zero}" for l in range(p))
    acc_add = " ".join(f"y{l} += w[{l}] * v;" for l in range(p))
    play_loop = f"""    for (k = 0; k < {N}_N_INPUTS; ++k) {{
        const {N}_real uk = u[k];
        const int end = {N}_play_start[k + 1];
        for (j = {N}_play_start[k]; j < end; ++j) {{
            const {N}_real *w = {N}_WT[j];
            {N}_real v = s[j];
            const {N}_real hi = uk + {N}_play_r[j], lo = uk - {N}_play_r[j];
            v = hi < v ? hi : v;
            v = lo > v ? lo : v;
@STORE@            {acc_add}
        }}
    }}"""
    if not law.lowpass and int(law.iterations) > 1:
        gu = "\n".join(f"    y{l} = {zero};" + "".join(f" y{l} += {N}_G[{l}][{k}] * u[{k}];" for k in range(m))
                       for l in range(p))
        body.append(f"""/* Gamma(u; s) with the play states frozen (no commit): G u, then the plays */
static void {N}_evaluate(const {N}_real u[], const {N}_real s[], {N}_real y[])
{{
    int k, j;
    {N}_real {acc_decl};
{gu}
{play_loop.replace("@STORE@", "")}
{chr(10).join(f"    y[{l}] = y{l};" for l in range(p))}
}}
""")
    gu = "\n".join(f"    y[{l}] = y{l};" + "".join(f" y[{l}] += {N}_G[{l}][{k}] * u[{k}];" for k in range(m))
                   for l in range(p))
    body.append(f"""/* move the plays to u, then y = W s + G u */
static void {N}_commit(const {N}_real u[], {N}_real s[], {N}_real y[])
{{
    int k, j;
    {N}_real {acc_decl};
{play_loop.replace("@STORE@", "            s[j] = v;" + chr(10))}
{gu}
}}
""")
    plays0 = _packed_start(model)
    if np.any(plays0):   # the plays where the demagnetising cycle leaves them, Gamma(0 V) there
        decls += [_reals_table("plays_rest", plays0, precision, N,
                               "  /* play states after the demagnetising cycle [V] */"),
                  _reals_table("gamma_rest", W @ plays0, precision, N,
                               "  /* Gamma(0 V) from them [um] */")]
        init = [f"    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {zero};",
                f"    for (j = 0; j < {N}_N_PLAYS; ++j) s->plays[j] = {N}_plays_rest[j];",
                f"    for (l = 0; l < {N}_N_OUTPUTS; ++l) s->gamma[l] = {N}_gamma_rest[l];"]
    else:
        init = [f"    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {zero};",
                f"    for (j = 0; j < {N}_N_PLAYS; ++j) s->plays[j] = {zero};",
                f"    for (l = 0; l < {N}_N_OUTPUTS; ++l) s->gamma[l] = {zero};"]
    if law.lowpass:
        init.append(f"    for (k = 0; k < {N}_N_INPUTS; ++k) s->v_f[k] = {zero};")
    if nf:
        x0 = _stage_rest([prefilter], getattr(law, "rest", None), precision,
                         getattr(law, "rest_states", None))[0]
        if np.any(x0):     # in steady state at the model's output at 0 V, as Python's start
            decls.append(_reals_table("x_f_rest", x0, precision, N,
                                      "  /* the dynamics inverse at rest at the model's output at 0 V */"))
            init.append(f"    for (j = 0; j < {N}_N_FILTER; ++j) s->x_f[j] = {N}_x_f_rest[j];")
        else:
            init.append(f"    for (j = 0; j < {N}_N_FILTER; ++j) s->x_f[j] = {zero};")
    if nf and law_preview(law):
        init.append("    s->received = 0;")
    init.append("    s->diverged = 0;")
    fill = f"""    if (s->received < {N}_PREVIEW) {{  /* filling the preview: the actuator stays at rest */
        s->received += 1;
        for (k = 0; k < {N}_N_INPUTS; ++k) voltage[k] = s->u[k];
        return 0;
    }}"""
    more, extra_reals, la_step = [], 0, []
    if lookahead is not None:     # G^-1 on Yr - c, then creep, + c, then S^-1(. - c)
        d, c, more, first, extra_reals = _lookahead_code(lookahead[0], lookahead[1], precision, N)
        decls += d
        init = first + init
        d, codes, stage_members, stage_init, n = _stages_source(
            stages, stage_states or [None] * len(stages), precision, N)
        decls += d
        la_step = [c] + codes
        if model.output_offset is not None:    # L^-1 of Yr - c, c back for S^-1(. - c) below
            la_step = ([f"    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = r[l] - {N}_offset[l];"]
                       + la_step
                       + [f"    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = r[l] + {N}_offset[l];"])
        more += stage_members
        init += stage_init
        extra_reals += n
        la_step += ["    }", fill]
        init.insert(0, "    s->received = 0;")
    body.append(f"""void {N}_init({N}_state *s)
{{
    int k, j, l;
{chr(10).join(init)}
    (void)k; (void)j; (void)l;
}}
""")
    step = [f"""int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS])
{{
    {N}_real r[{N}_N_OUTPUTS], u[{N}_N_INPUTS], e[{N}_N_OUTPUTS];
    int k, l, status = 0;
@REFERENCE_CHECK@
    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = reference[l];"""]
    step += la_step
    step += tcode
    if nf:   # the preview samples too enter the inverse as Yr - c, as Python's start-up
        step.append(f"""    {{  /* ZPETC inverse of the linear dynamics: v = Cf x + Df r, x <- Af x + Bf r */
        {N}_real v[{N}_N_OUTPUTS], xn[{N}_N_FILTER];
        int i, j;
        for (l = 0; l < {N}_N_OUTPUTS; ++l) {{
            {N}_real a = {zero};
            for (i = 0; i < {N}_N_FILTER; ++i) a += {N}_Cf[l][i] * s->x_f[i];
            for (i = 0; i < {N}_N_OUTPUTS; ++i) a += {N}_Df[l][i] * r[i];
            v[l] = a;
        }}
        for (i = 0; i < {N}_N_FILTER; ++i) {{
            {N}_real a = {zero};
            for (j = 0; j < {N}_N_FILTER; ++j) a += {N}_Af[i][j] * s->x_f[j];
            for (j = 0; j < {N}_N_OUTPUTS; ++j) a += {N}_Bf[i][j] * r[j];
            xn[i] = a;
        }}
        for (i = 0; i < {N}_N_FILTER; ++i) s->x_f[i] = xn[i];
        for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = v[l];
    }}""")
        step += tmap      # the output map's inverse on the dynamics inverse's output
        if law_preview(law):
            step.append(fill)
    if law.lowpass:
        step.append(f"""    /* low-pass law (Section 6): v_f <- a v_f + (1 - a)(U(t-T) - K^-1 Gamma(U(t-T))), U = K^-1 r + v_f */
    for (k = 0; k < {N}_N_INPUTS; ++k) {{
        {N}_real acc = {zero};
        for (l = 0; l < {N}_N_OUTPUTS; ++l) acc += {N}_K_inv[k][l] * s->gamma[l];
        e[k] = s->u[k] - acc;
    }}
    for (k = 0; k < {N}_N_INPUTS; ++k) s->v_f[k] = {N}_pole * s->v_f[k] + ({one} - {N}_pole) * e[k];
    for (k = 0; k < {N}_N_INPUTS; ++k) {{
        {N}_real acc = {zero};
        for (l = 0; l < {N}_N_OUTPUTS; ++l) acc += {N}_K_inv[k][l] * r[l];
        u[k] = acc + s->v_f[k];
    }}""")
    elif int(law.iterations) == 1:
        step.append(f"""    /* delay law (Theorem 4.1, normalised): U = U(t-T) + K^-1 (r - Gamma(U(t-T))) */
    for (l = 0; l < {N}_N_OUTPUTS; ++l) e[l] = r[l] - s->gamma[l];
    for (k = 0; k < {N}_N_INPUTS; ++k) {{
        {N}_real acc = {zero};
        for (l = 0; l < {N}_N_OUTPUTS; ++l) acc += {N}_K_inv[k][l] * e[l];
        u[k] = s->u[k] + acc;
    }}""")
    else:
        step.append(f"""    /* delay law (Theorem 4.1, normalised): U <- U + K^-1 (r - Gamma(U; s(t-T))), from U(t-T) */
    for (k = 0; k < {N}_N_INPUTS; ++k) u[k] = s->u[k];
    {{
        int it;
        for (it = 0; it < {N}_ITERATIONS; ++it) {{
            if (it == 0) {{
                for (l = 0; l < {N}_N_OUTPUTS; ++l) e[l] = r[l] - s->gamma[l];
            }} else {{
                {N}_real yh[{N}_N_OUTPUTS];
                {N}_evaluate(u, s->plays, yh);
                for (l = 0; l < {N}_N_OUTPUTS; ++l) e[l] = r[l] - yh[l];
            }}
            for (k = 0; k < {N}_N_INPUTS; ++k) {{
                {N}_real acc = {zero};
                for (l = 0; l < {N}_N_OUTPUTS; ++l) acc += {N}_K_inv[k][l] * e[l];
                u[k] += acc;
            }}
        }}
    }}""")
    step.append(f"""    for (k = 0; k < {N}_N_INPUTS; ++k)  /* divergence: non-finite or beyond the bound */
        if (!isfinite(u[k]) || u[k] > {N}_bound || u[k] < -{N}_bound) {{
            s->diverged = 1;
            for (k = 0; k < {N}_N_INPUTS; ++k) voltage[k] = s->u[k];
            return {N}_STATUS_DIVERGED;
        }}
@RANGE_CHECK@""")
    step.append(f"""    {N}_commit(u, s->plays, s->gamma);""")
    step += lcode
    step.append("""    return status;
}
""")
    body.append("\n".join(step))
    members = [f"    {N}_real u[{N}_N_INPUTS];        /* U(t-T): last voltages [V] */",
               f"    {N}_real plays[{N}_N_PLAYS];     /* play-operator states [V] */",
               f"    {N}_real gamma[{N}_N_OUTPUTS];   /* Gamma(U(t-T)) [um] */"]
    reals = m + nplays + p
    if law.lowpass:
        members.append(f"    {N}_real v_f[{N}_N_INPUTS];      /* low-pass feedback state [V] */")
        reals += m
    if nf:
        members.append(f"    {N}_real x_f[{N}_N_FILTER];      /* ZPETC inverse state [um] */")
        reals += nf
    if (nf and law_preview(law)) or lookahead is not None:
        members.append("    int received;                  /* references received, up to PREVIEW */")
    members += more
    reals += extra_reals
    members.append("    int diverged;                  /* latched divergence flag */")
    defines = [f"#define {N}_N_PLAYS {nplays}"] + ([f"#define {N}_N_FILTER {nf}"] if nf else [])
    return decls[1:] + tdecls + ldecls, body, members, defines, reals


def law_preview(law):
    """Preview samples of a law's ZPETC pre-filter (stored by :func:`export_c`).

    Parameters
    ----------
    law : object
        A ``CompensatorLaw`` (``packed_law()`` of a compensator), possibly
        with a ``_preview`` attribute set by :func:`export_c`.

    Returns
    -------
    int
        ``NAME_PREVIEW`` [samples].
    """
    return int(getattr(law, "_preview", 0) or 0)


class _Law:
    """A CompensatorLaw's fields plus the preview (the law is a NamedTuple)."""

    def __init__(self, law, preview, rest=None, rest_states=None):
        for key in ("model", "K_inv", "iterations", "divergence_bound", "lowpass", "pole", "prefilter"):
            setattr(self, key, getattr(law, key))
        self._preview = preview
        self.rest, self.rest_states = rest, rest_states     # where NAME_init starts the prefilter


def _plan_law(comp):
    model = _check_model(comp.model)
    law = comp.packed_law()
    fb = "low-pass feedback" if law.lowpass else f"{int(law.iterations)} iteration(s) per sample"
    return ("law", model, 0, f"inverse multiplicative compensator ({comp.name}, {fb})",
            lambda precision, N, limits, T: _law_source(_Law(law, 0), model, precision, N, limits, T))
