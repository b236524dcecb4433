"""C of the stable inversion of G as a look-ahead filter
(:class:`hammerstein.compensation.lookahead.LookaheadInverse`): a ring buffer of the
reference ``PREVIEW`` samples ahead, the finite sum of the anti-causal part's terms over it
and the stable modes' recursion, in the order the Python filter takes them (the terms cancel:
the same order gives the same roundings).
"""

from __future__ import annotations

from hammerstein.export.c_base import _ints_table, _mat, _reals_table


def _lookahead_code(la, state, precision, N):
    """Declarations, the statement that pushes ``r[]`` and (once the buffer is full) replaces
    it by ``v``, the state's members, ``NAME_init`` lines and the state's reals.

    ``state``: the stable modes' state at rest (:meth:`LookaheadInverse.initial_state`).
    The statement opens a block ``if (s->received >= NAME_PREVIEW) {`` that the caller closes
    after the later linear stages, so that they start with the first voltage, as in Python.
    """
    p, L = la.p, la.preview_samples
    ns = la.A_s.shape[0]
    zero = "0.0f" if precision == "float" else "0.0"
    taps = la.taps.reshape(L + 1, p * p)
    decls = [f"#define {N}_LOOKAHEAD_TAPS {L + 1}",
             f"static const {N}_real {N}_M[{L + 1}][{p * p}] = {_mat(taps, precision)};"
             f"  /* the inverse's terms on the reference d = 0..{L} samples ahead, row-major */",
             _ints_table("rd", la.relative_degree, N) + "  /* relative degrees */"]
    if ns:
        decls += [f"static const {N}_real {N}_As[{ns}][{ns}] = {_mat(la.A_s, precision)};",
                  f"static const {N}_real {N}_Bs[{ns}][{p}] = {_mat(la.B_s, precision)};",
                  f"static const {N}_real {N}_Cs[{p}][{ns}] = {_mat(la.C_s, precision)};",
                  _reals_table("xs_rest", state, precision, N,
                               "  /* the stable modes at rest at the model's output at 0 V */")]
    members = [f"    {N}_real buf[{L + 1}][{p}];   /* the reference, the last {L + 1} samples */",
               "    int head;                      /* the buffer's oldest sample */",
               f"    {N}_real xs[{max(1, ns)}];   /* the stable modes of the inverse of G */"]
    init = [f"    for (j = 0; j < {L + 1}; ++j) for (k = 0; k < {p}; ++k) s->buf[j][k] = {zero};",
            "    s->head = 0;",
            (f"    for (j = 0; j < {ns}; ++j) s->xs[j] = {N}_xs_rest[j];" if ns else
             f"    s->xs[0] = {zero};")]
    stable = "" if not ns else f"""
        for (l = 0; l < {N}_N_OUTPUTS; ++l)     /* the stable modes, forward */
            for (i = 0; i < {ns}; ++i) v[l] += {N}_Cs[l][i] * s->xs[i];
        for (i = 0; i < {ns}; ++i) {{
            {N}_real a = {zero};
            for (j = 0; j < {ns}; ++j) a += {N}_As[i][j] * s->xs[j];
            for (j = 0; j < {p}; ++j) a += {N}_Bs[i][j] * s->buf[(s->head + {N}_rd[j]) % {L + 1}][j];
            xn[i] = a;
        }}"""
    code = f"""    for (l = 0; l < {N}_N_OUTPUTS; ++l) s->buf[s->head][l] = r[l];   /* the newest sample */
    s->head = s->head == {L} ? 0 : s->head + 1;            /* now the oldest: yr(k) */
    if (s->received >= {N}_PREVIEW) {{
    {{  /* the stable inversion of G: v(k) = Cs xs(k) + sum_d M_d yr(k + d) */
        {N}_real v[{N}_N_OUTPUTS], xn[{max(1, ns)}];
        int i, j, d, at;
        for (l = 0; l < {N}_N_OUTPUTS; ++l) v[l] = {zero};{stable}
        for (l = 0; l < {N}_N_OUTPUTS; ++l) {{  /* the look-ahead's terms, d ascending */
            {N}_real a = v[l];
            for (d = 0, at = s->head; d <= {L}; ++d, at = at == {L} ? 0 : at + 1)
                for (i = 0; i < {p}; ++i) a += {N}_M[d][l * {p} + i] * s->buf[at][i];
            v[l] = a;
        }}
        for (i = 0; i < {ns}; ++i) s->xs[i] = xn[i];
        for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = v[l];
        (void)xn; (void)j;
    }}"""
    reals = (L + 1) * p + max(1, ns)
    return decls, code, members, init, reals


def lookahead_cost(la):
    """Multiply-adds of one step of the look-ahead filter (for the export's note).

    Parameters
    ----------
    la : hammerstein.compensation.lookahead.LookaheadInverse

    Returns
    -------
    int
        ``(P + 1) p^2`` for the look-ahead's terms plus ``n_s (n_s + 2 p)`` for the stable modes.
    """
    ns = la.A_s.shape[0]
    return int((la.preview_samples + 1) * la.p * la.p + ns * (ns + 2 * la.p))

