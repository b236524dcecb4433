"""C emitter of the exact per-sample inverse of a Preisach or generalised-PI model
(:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`) and of its
multiplicative law, step for step as :mod:`hammerstein.simulation._preisach_inverse`: the same
bracket, Illinois iterations, tolerances, Gauss-Seidel sweeps, per-cell evaluation and order
of additions; after optional linear stages (the dynamics and creep inverses of a Hammerstein
compensator).
"""

from __future__ import annotations

import numpy as np

from hammerstein.simulation._preisach import _cell_lists
from hammerstein.simulation._preisach_inverse import AITKEN_SWEEP, BRACKET_GROWTH, SECANT_OVERSHOOT
from hammerstein.export.c_base import (LIMIT_TOLERANCE, _lit, _mat, _limits_code, _ints_table,
                                       _reals_table, _stage_rest, _stages_source, _sections,
                                       _model_text)
from hammerstein.export.c_lookahead import _lookahead_code


_EXACT = """@RAMP<
/* ramp of a switching cell: -1 below lo, +1 above hi, linear across */
static {N}_real {N}_ramp({N}_real u, {N}_real lo, {N}_real hi)
{{
    if (u <= lo) return -{one};
    if (u >= hi) return {one};
    return {two} * (u - lo) / (hi - lo) - {one};
}}
@>RAMP
@COMPONENT<
/* output of component c at input u from the states h (which {N}_move moves) */
static {N}_real {N}_component(int c, {N}_real u, const {N}_real *h)
{{
    {N}_real acc = {zero}, poly = {zero};
    int n;
@HYST<
    if ({N}_q_off[c + 1] > {N}_q_off[c]) {{
        {N}_real rho[{N}_MAX_LEVELS];
        const int e0 = {N}_e_off[c], nlev = {N}_e_off[c + 1] - {N}_e_off[c] - 1;
        int q;
        const int base = {N}_s_off[c] - {N}_q_off[c];
        for (n = 0; n < nlev; ++n) rho[n] = {N}_ramp(u, {N}_E[e0 + n], {N}_E[e0 + n + 1]);
        for (q = {N}_q_off[c]; q < {N}_q_off[c + 1]; ++q) {{
            {N}_real up = rho[{N}_row[q]], down = rho[{N}_col[q]], v = h[base + q];
            if (v > down) v = down;
            if (v < up) v = up;
            acc += {N}_mu[q] * v;
        }}
    }}
@>HYST
@PLAY<
    if ({N}_p_off[c + 1] > {N}_p_off[c]) {{
        int j;
        const int base = {N}_s_off[c] + {N}_q_off[c + 1] - {N}_q_off[c] - {N}_p_off[c];
        {N}_real lo = {N}_env[c][0] * {tanh}({N}_env[c][1] * u + {N}_env[c][2]) + {N}_env[c][3];
        {N}_real hi = {N}_env[c][4] * {tanh}({N}_env[c][5] * u + {N}_env[c][6]) + {N}_env[c][7];
        for (j = {N}_p_off[c]; j < {N}_p_off[c + 1]; ++j) {{
            {N}_real v = h[base + j];
            if (v > hi + {N}_pr[j]) v = hi + {N}_pr[j];
            if (v < lo - {N}_pr[j]) v = lo - {N}_pr[j];
            acc += {N}_pw[j] * v;
        }}
    }}
@>PLAY
    for (n = {N}_N_POLY - 1; n >= 0; --n) poly = (poly + {N}_rev[c][n]) * u;
    return acc + poly + {N}_off[c];
}}
@>COMPONENT
"""

_MOVE = """
@HYST<
/* the switching cell of u on component c's grid: the number of edges <= u, minus one */
static int {N}_cell_scan(int c, {N}_real u)
{{
    const int e0 = {N}_e_off[c], n = {N}_e_off[c + 1] - {N}_e_off[c] - 1;
    int i = -1, j;
    for (j = 0; j <= n; ++j)
        if ({N}_E[e0 + j] <= u) i = j;
    return i;
}}
@>HYST
/* move the states of component c to input u (the commit at the sample's solution):
   inside u's switching cell i the ramps of the other cells are exactly -1 (above) or +1
   (below), so only cell i's ramp is computed; and a hysteron whose two cells both lie
   outside the cells from the last move's (moved[c]) to u's has the same two ramps as at
   the last move, where it was clamped already (clamping again changes nothing): only the
   hysterons moving inside those cells are clamped (at the first move those of every cell,
   which are all of them) */
static void {N}_move(int c, {N}_real u, {N}_real *h, int *moved)
{{
@HYST<
    if ({N}_q_off[c + 1] > {N}_q_off[c]) {{
        const int e0 = {N}_e_off[c], nlev = {N}_e_off[c + 1] - {N}_e_off[c] - 1;
        const int base = {N}_s_off[c] - {N}_q_off[c];
        const int i = {N}_cell_scan(c, u), last = moved[c];
        {N}_real rhos[{N}_MAX_LEVELS];   /* every cell's ramp: +1 below u's cell, -1 above */
        int q, j, k, a, b;
        for (j = 0; j < nlev; ++j) rhos[j] = j < i ? {one} : -{one};
        if (0 <= i && i < nlev) rhos[i] = {N}_ramp(u, {N}_E[e0 + i], {N}_E[e0 + i + 1]);
        a = last < -1 ? 0 : (last < i ? last : i);           /* the first move: every cell */
        b = last < -1 ? nlev - 1 : (last < i ? i : last);
        if (a < 0) a = 0;
        if (b > nlev - 1) b = nlev - 1;
        for (j = a; j <= b; ++j)
            for (k = {N}_cstart[e0 + c + j + 1]; k < {N}_cstart[e0 + c + j + 2]; ++k) {{
                {N}_real up, down, v;
                q = {N}_cindex[k];
                up = rhos[{N}_row[q]];
                down = rhos[{N}_col[q]];
                v = h[base + q];
                v = v > down ? down : v;
                v = v < up ? up : v;
                h[base + q] = v;
            }}
        moved[c] = i;
    }}
@>HYST
@PLAY<
    if ({N}_p_off[c + 1] > {N}_p_off[c]) {{
        int j;
        const int base = {N}_s_off[c] + {N}_q_off[c + 1] - {N}_q_off[c] - {N}_p_off[c];
        {N}_real lo = {N}_env[c][0] * {tanh}({N}_env[c][1] * u + {N}_env[c][2]) + {N}_env[c][3];
        {N}_real hi = {N}_env[c][4] * {tanh}({N}_env[c][5] * u + {N}_env[c][6]) + {N}_env[c][7];
        for (j = {N}_p_off[c]; j < {N}_p_off[c + 1]; ++j) {{
            {N}_real v = h[base + j];
            if (v > hi + {N}_pr[j]) v = hi + {N}_pr[j];
            if (v < lo - {N}_pr[j]) v = lo - {N}_pr[j];
            h[base + j] = v;
        }}
    }}
@>PLAY
    (void)c; (void)u; (void)h; (void)moved;
}}
"""

_ROOT = """#define {N}_ABS(x) ((x) < {zero} ? -(x) : (x))

/* within one sample the states do not move until the commit: the last two values of each
   component (a repeated input returns the value computed before, bit for bit), and per
   component the switching cell last summed with the sum of its input-independent hysterons */
typedef struct {{
    {N}_real x[{N}_N_COMPONENTS][2], y[{N}_N_COMPONENTS][2], cst[{N}_N_COMPONENTS];
    int n[{N}_N_COMPONENTS], last[{N}_N_COMPONENTS], cell[{N}_N_COMPONENTS];
}} {N}_memo;
@HYST<
/* the cell of u, tried first in the cell summed last (the same answer as the scan) */
static int {N}_cell({N}_memo *mm, int c, {N}_real u)
{{
    const int i = mm->cell[c], e0 = {N}_e_off[c], n = {N}_e_off[c + 1] - {N}_e_off[c] - 1;
    if (0 <= i && i < n && {N}_E[e0 + i] <= u && u < {N}_E[e0 + i + 1]) return i;
    return {N}_cell_scan(c, u);
}}
@>HYST

@HYST<
/* the term of hysteron q of cell i at the cell's ramp value rho */
static {N}_real {N}_moving(int q, int i, {N}_real rho, int base, const {N}_real *h)
{{
    const {N}_real up = {N}_row[q] == i ? rho : -{one}, down = {N}_col[q] == i ? rho : {one};
    {N}_real v = h[base + q];
    if (v > down) v = down;
    if (v < up) v = up;
    return {N}_mu[q] * v;
}}

/* the term of hysteron q that keeps its state in the cell */
static {N}_real {N}_kept(int q, int base, const {N}_real *h)
{{
    {N}_real v = h[base + q];
    if (v > {one}) v = {one};
    if (v < -{one}) v = -{one};
    return {N}_mu[q] * v;
}}
@>HYST

/* output of component c at input u, the states frozen (hammerstein.simulation._preisach_inverse.
   _frozen, in its order): in u's switching cell i the ramps of the other cells are exactly
   +1 (below) or -1 (above), so the hysterons that do not move add a constant per cell
   (the fixed table plus the kept states, summed once per sample and cell), and only the
   cell's moving hysterons are evaluated at u; then the plays and the polynomial */
static {N}_real {N}_frozen({N}_memo *mm, int c, {N}_real u, const {N}_real *h)
{{
    {N}_real acc = {zero}, poly = {zero};
    int n;
    (void)mm;
@HYST<
    if ({N}_q_off[c + 1] > {N}_q_off[c]) {{
        const int e0 = {N}_e_off[c], nlev = {N}_e_off[c + 1] - {N}_e_off[c] - 1;
        const int base = {N}_s_off[c] - {N}_q_off[c];
        const int i = {N}_cell(mm, c, u), g = e0 + c + i + 1;
        int k;
        if (mm->cell[c] != i) {{
            const int k0 = {N}_kstart[g], k1 = {N}_kstart[g + 1];
            {N}_real a0 = {zero}, a1 = {zero}, a2 = {zero}, a3 = {zero};  /* four sums */
            for (k = k0; k + 4 <= k1; k += 4) {{
                a0 += {N}_kept({N}_kindex[k], base, h);
                a1 += {N}_kept({N}_kindex[k + 1], base, h);
                a2 += {N}_kept({N}_kindex[k + 2], base, h);
                a3 += {N}_kept({N}_kindex[k + 3], base, h);
            }}
            if (k < k1) a0 += {N}_kept({N}_kindex[k++], base, h);
            if (k < k1) a1 += {N}_kept({N}_kindex[k++], base, h);
            if (k < k1) a2 += {N}_kept({N}_kindex[k++], base, h);
            mm->cst[c] = {N}_fixed[g] + ((a0 + a1) + (a2 + a3));
            mm->cell[c] = i;
        }}
        acc = mm->cst[c];
        if (0 <= i && i < nlev) {{
            const int k1 = {N}_cstart[g + 1];
            {N}_real b0 = {zero}, b1 = {zero};    /* two sums (position even, odd) */
            const {N}_real rho = {N}_ramp(u, {N}_E[e0 + i], {N}_E[e0 + i + 1]);  /* the one ramp not -1 or +1 */
            for (k = {N}_cstart[g]; k + 2 <= k1; k += 2) {{
                b0 += {N}_moving({N}_cindex[k], i, rho, base, h);
                b1 += {N}_moving({N}_cindex[k + 1], i, rho, base, h);
            }}
            if (k < k1) b0 += {N}_moving({N}_cindex[k], i, rho, base, h);
            acc += b0 + b1;
        }}
    }}
@>HYST
@PLAY<
    if ({N}_p_off[c + 1] > {N}_p_off[c]) {{
        int j;
        const int base = {N}_s_off[c] + {N}_q_off[c + 1] - {N}_q_off[c] - {N}_p_off[c];
        {N}_real lo = {N}_env[c][0] * {tanh}({N}_env[c][1] * u + {N}_env[c][2]) + {N}_env[c][3];
        {N}_real hi = {N}_env[c][4] * {tanh}({N}_env[c][5] * u + {N}_env[c][6]) + {N}_env[c][7];
        for (j = {N}_p_off[c]; j < {N}_p_off[c + 1]; ++j) {{
            {N}_real v = h[base + j];
            if (v > hi + {N}_pr[j]) v = hi + {N}_pr[j];
            if (v < lo - {N}_pr[j]) v = lo - {N}_pr[j];
            acc += {N}_pw[j] * v;
        }}
    }}
@>PLAY
    for (n = {N}_N_POLY - 1; n >= 0; --n) poly = (poly + {N}_rev[c][n]) * u;
    return acc + poly + {N}_off[c];
}}

static {N}_real {N}_eval({N}_memo *mm, int c, {N}_real u, {N}_real *h)
{{
    int i;
    for (i = 0; i < mm->n[c]; ++i)
        if (mm->x[c][i] == u) return mm->y[c][i];
    i = mm->n[c] < 2 ? mm->n[c]++ : 1 - mm->last[c];
    mm->last[c] = i;
    mm->x[c][i] = u;
    mm->y[c][i] = {N}_frozen(mm, c, u, h);
    return mm->y[c][i];
}}

/* u in [lo, hi] with component c = target: a Newton probe on the secant of the component's
   last two values, then a bracket from the guess (or the probe) by steps to the secant root
   of the last two probes, then Illinois false position (the Python kernel's search, step
   for step); *beyond = 1 when the target is beyond the bound returned (out of reach) */
static {N}_real {N}_root({N}_memo *mm, int c, {N}_real target, {N}_real guess, {N}_real lo, {N}_real hi, {N}_real *h, int *beyond)
{{
    {N}_real x = guess, fx, step, a = {zero}, fa = {zero}, b = {zero}, fb = {zero};
    int side = 0, it, bracketed = 0;
    *beyond = 0;
    if (x < lo) x = lo;
    if (x > hi) x = hi;
    fx = {N}_eval(mm, c, x, h) - target;
    if ({N}_ABS(fx) <= {tol}) return x;
    if (mm->n[c] == 2 && mm->x[c][0] != mm->x[c][1]) {{
        const {N}_real slope = (mm->y[c][1] - mm->y[c][0]) / (mm->x[c][1] - mm->x[c][0]);
        if (slope > {zero}) {{
            {N}_real z = x - fx / slope, fz;
            if (z < lo) z = lo;
            if (z > hi) z = hi;
            if (z != x) {{
                fz = {N}_eval(mm, c, z, h) - target;
                if ({N}_ABS(fz) <= {tol}) return z;
                if ((fz < {zero}) == (fx < {zero})) {{ x = z; fx = fz; }}   /* on the guess's side */
                else {{
                    bracketed = 1;
                    if (z > x) {{ a = x; fa = fx; b = z; fb = fz; }}
                    else {{ a = z; fa = fz; b = x; fb = fx; }}
                }}
            }}
        }}
    }}
    if (!bracketed) {{
        step = {N}_BRACKET_STEP * (hi - lo);
        if (fx < {zero}) {{
            a = x; fa = fx;
            for (;;) {{
                {N}_real grown, sec;
                b = x + step;
                if (b >= hi) {{
                    b = hi;
                    fb = {N}_eval(mm, c, hi, h) - target;
                    if (fb <= {zero}) {{ *beyond = fb < -{N}_BEYOND; return hi; }}
                    break;
                }}
                fb = {N}_eval(mm, c, b, h) - target;
                if (fb >= {zero}) break;
                grown = step * {N}_BRACKET_GROWTH;
                if (fb > fa) {{
                    sec = (b - x) + (b - a) * (-fb) / (fb - fa) * {N}_SECANT_OVERSHOOT;
                    step = sec > step ? sec : grown;
                }} else step = grown;
                a = b; fa = fb;
            }}
        }} else {{
            b = x; fb = fx;
            for (;;) {{
                {N}_real grown, sec;
                a = x - step;
                if (a <= lo) {{
                    a = lo;
                    fa = {N}_eval(mm, c, lo, h) - target;
                    if (fa >= {zero}) {{ *beyond = fa > {N}_BEYOND; return lo; }}
                    break;
                }}
                fa = {N}_eval(mm, c, a, h) - target;
                if (fa <= {zero}) break;
                grown = step * {N}_BRACKET_GROWTH;
                if (fb > fa) {{
                    sec = (x - a) + (b - a) * fa / (fb - fa) * {N}_SECANT_OVERSHOOT;
                    step = sec > step ? sec : grown;
                }} else step = grown;
                b = a; fb = fa;
            }}
        }}
        if ({N}_ABS(fa) <= {tol}) return a;
        if ({N}_ABS(fb) <= {tol}) return b;
    }}
    for (it = 0; it < 200; ++it) {{
        x = (a * fb - b * fa) / (fb - fa);
        if (!(a < x && x < b)) x = {half} * (a + b);
        fx = {N}_eval(mm, c, x, h) - target;
        if ({N}_ABS(fx) <= {tol} || b - a <= {N}_BRACKET_END * ({one} + {N}_ABS(x))) return x;
        if (fx < {zero}) {{
            a = x; fa = fx;
            if (side == -1) fb *= {half};
            side = -1;
        }} else {{
            b = x; fb = fx;
            if (side == 1) fa *= {half};
            side = 1;
        }}
    }}
    return x;
}}
"""


#: In float, the root search's ends in units of the float epsilon: the root's tolerance on
#: the component's value (times the largest sum of that component's terms' magnitudes over
#: the input range, the scale of its rounding: ``NAME_tol[c]``), the bracket's relative width and a sweep's largest input change (times the
#: largest input bound). Double keeps the Python kernel's ends (1e-12 um, 1e-13, 1e-11 V),
#: which float cannot resolve: its search then ran to its last bracket step every time
#: (the test models' exact inverses 2.7-4.2 us per step in float, 0.5-0.8 us with these
#: ends; relative error against the double Python 0.6-0.9e-6 before, 1.1-1.5e-6 with them;
#: 8 epsilons on the tolerance: 0.5-0.6 us, 0.7-1.3e-5).
FLOAT_ENDS_EPS = (1.0, 2.0, 1.0)


#: How far [µm] a reference must lie beyond what an input's bound reaches for ``STATUS_RANGE``
#: (double, float): a reference at rest sits on a bound (a unipolar stage's 0 V) to within the
#: arithmetic's rounding, which the root search's tolerance is finer than (flagged on 299 of
#: 300 samples at rest: 1.17e-9 V on the other input moved its target by more than 1e-12 µm)
BEYOND_UM = (1e-6, 1e-3)


def _beyond(tol, precision):
    """``NAME_BEYOND`` [µm]: :data:`BEYOND_UM` for the precision, at least the tolerance (ten
    times it in float)."""
    return max(tol, BEYOND_UM[0]) if precision != "float" else max(10.0 * tol, BEYOND_UM[1])


def _bound_tolerance(comp, precision):
    """Per input [V]: how far the law's voltage must lie beyond an input bound for
    ``STATUS_RANGE``, the amplifier clamp's rule (:data:`~hammerstein.export.c_base.LIMIT_TOLERANCE`
    times the bound's largest magnitude, at least 1 V). At rest on a unipolar stage's 0 V the law
    computes ``u + K^-1 (r - Gamma(u))`` = -1e-14 V or so, clipped to 0 V as in Python: it was
    flagged on every sample at rest."""
    scale = np.maximum(1.0, np.maximum(np.abs(comp.lo), np.abs(comp.hi)))
    return LIMIT_TOLERANCE[precision] * scale


def _search_ends(comp, precision):
    """The root search's tolerance [um], bracket end (relative) and sweep end [V]: the Python
    kernel's in double; in float, ``FLOAT_ENDS_EPS`` times the float epsilon of the scale,
    the tolerance per component (an array of ``p m``: each direct path's root ends at its own
    rounding). It was one tolerance, from the largest scale of any component: an identified
    generalised PI's cross-coupling y <- ux (a play weight of -128 µm against a reversible
    46 µm/V, 3547 µm over +-20 V) set 4.2e-4 µm for the direct path x (104 µm, 1.2e-5 µm), whose
    root then stalled by up to 1e-4 V near 0 V; through that cross-coupling's 46 µm/V after a
    reversal of ux, 8 mV on uy (2.3e-3 relative on a 5 Hz circle, 3.5e-5 per component)."""
    if precision != "float":
        return float(comp.tolerance), 1e-13, 1e-11
    (E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, present) = comp._arrays
    eps = float(np.finfo(np.float32).eps)
    scales = np.zeros(present.size)
    for c in range(present.size):
        if not present[c]:
            continue
        terms = float(np.sum(np.abs(mu[q_off[c]:q_off[c + 1]])))
        if p_off[c + 1] > p_off[c]:
            edge = max(abs(env[c, 0]) + abs(env[c, 3]), abs(env[c, 4]) + abs(env[c, 7]))
            terms += float(np.sum(np.abs(pw[p_off[c]:p_off[c + 1]])
                                  * (np.abs(pr[p_off[c]:p_off[c + 1]]) + edge)))
        k = c % comp.model.n_inputs
        reach = max(abs(comp.lo[k]), abs(comp.hi[k]))
        terms += float(np.sum(np.abs(rev[c]) * reach ** np.arange(1, rev.shape[1] + 1)))
        scales[c] = terms + abs(float(off[c]))
    bound = float(max(np.max(np.abs(comp.lo)), np.max(np.abs(comp.hi))))
    t, b, w = FLOAT_ENDS_EPS
    return np.maximum(float(comp.tolerance), t * eps * scales), b * eps, w * eps * bound


def _exact_source(comp, stages, model, precision, N, limits, T, preview=0, rest=None,
                  rest_states=None, lookahead=None):
    """The exact inverse (or its multiplicative law) of a PreisachInverseCompensator, after
    optional linear stages (the dynamics inverse, the creep inverse), which ``NAME_init``
    starts at rest for the constant reference ``rest`` (the model's output at 0 V; None: 0;
    ``rest_states`` the Python inverse's states there, stacked). ``lookahead``: ``(la,
    state)``, the stable inversion of G as a look-ahead filter ahead of the stages
    (:func:`hammerstein.export.c_lookahead._lookahead_code`; ``preview`` its samples)."""
    (E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off, present) = comp._arrays
    m = p = model.n_inputs
    nh = int(model.n_hysterons)
    exact = comp.method == "root"
    f = "f" if precision == "float" else ""
    lit = {"zero": "0.0" + f, "one": "1.0" + f, "two": "2.0" + f, "half": "0.5" + f,
           "tanh": "tanh" + f, "N": N,
           "tol": f"{N}_TOLERANCE" if precision != "float" else f"{N}_tol[c]"}
    nlev = int(max(1, np.max(np.diff(e_off)) - 1))
    h0 = comp.initial_state()[m:]
    tol, bracket_end, sweep_end = _search_ends(comp, precision)
    decls = [f"#define {N}_N_HYSTERONS {nh}", f"#define {N}_MAX_LEVELS {nlev}",
             f"#define {N}_N_COMPONENTS {p * m}",
             f"#define {N}_N_POLY {rev.shape[1]}",
             *([f"#define {N}_TOLERANCE {_lit(tol, precision)}"] if np.ndim(tol) == 0 else []),
             f"#define {N}_BEYOND {_lit(_beyond(float(np.max(tol)), precision), precision)}",
             f"#define {N}_BRACKET_STEP {_lit(1e-5, precision)}",
             f"#define {N}_BRACKET_GROWTH {_lit(BRACKET_GROWTH, precision)}",
             f"#define {N}_SECANT_OVERSHOOT {_lit(SECANT_OVERSHOOT, precision)}",
             f"#define {N}_AITKEN_SWEEP {AITKEN_SWEEP}",
             f"#define {N}_BRACKET_END {_lit(bracket_end, precision)}",
             f"#define {N}_SWEEP_END {_lit(sweep_end, precision)}",
             f"#define {N}_MAX_SWEEPS {int(comp.max_sweeps)}",
             _ints_table("q_off", q_off, N), _ints_table("s_off", s_off, N)]
    if q_off[-1] > 0:
        decls += [_reals_table("E", E, precision, N, "  /* switching-cell edges [V] */"),
                  _ints_table("e_off", e_off, N), _ints_table("row", row, N),
                  _ints_table("col", col, N),
                  _reals_table("mu", mu, precision, N, "  /* hysteron weights [um] */")]
    if p_off[-1] > 0:
        decls += [_reals_table("pr", pr, precision, N, "  /* generalised play thresholds */"),
                  _reals_table("pw", pw, precision, N, "  /* generalised play weights [um] */"),
                  _ints_table("p_off", p_off, N),
                  f"static const {N}_real {N}_env[{p * m}][8] = {_mat(env, precision)};  /* envelopes */"]
    decls += [
             f"static const {N}_real {N}_rev[{p * m}][{rev.shape[1]}] = {_mat(rev, precision)};"
             f"  /* reversible polynomials, u^1 first */",
             _reals_table("off", off, precision, N, "  /* component offsets [um] */"),
             _ints_table("present", present.astype(int), N),
             _reals_table("lo", comp.lo, precision, N, "  /* input bounds [V] */"),
             _reals_table("hi", comp.hi, precision, N),
             _reals_table("h0", h0, precision, N, "  /* hysteron states at rest */")]
    if not exact:
        decls.append(f"static const {N}_real {N}_K_inv[{m}][{m}] = {_mat(comp.K_inv, precision)};")
        decls.append(_reals_table("bound_tol", _bound_tolerance(comp, precision), precision, N,
                                  "  /* a clip by less is rounding: not flagged [V] */"))
    members = [f"    {N}_real u[{N}_N_INPUTS];        /* last voltages [V] */",
               f"    {N}_real h[{max(1, nh)}];   /* hysteron and play states of the model */"]
    reals = m + nh
    d, scode, more, init, n = _stages_source(
        stages, _stage_rest(stages, rest, precision, rest_states), precision, N)
    decls += d
    members += more
    reals += n
    if lookahead is not None:      # the stages start with the first voltage, after the buffer
        d, c, more, first, n = _lookahead_code(lookahead[0], lookahead[1], precision, N)
        decls += d
        scode = [c] + scode + ["    }"]
        members += more
        init = first + init
        reals += n
    keep = {"HYST": q_off[-1] > 0, "RAMP": q_off[-1] > 0, "PLAY": p_off[-1] > 0,
            "COMPONENT": not exact}
    body = [_sections(_EXACT.format(**lit) + _MOVE.format(**lit), keep)]
    if q_off[-1] > 0:
        cstart, cindex, kstart, kindex, fixed = _cell_lists(e_off, row, col, mu, q_off)
        decls += [_ints_table("cstart", cstart, N), _ints_table("cindex", cindex, N)
                  + "  /* hysterons moving inside each switching cell */"]
    if exact:
        if np.ndim(tol):
            decls.append(_reals_table("tol", tol, precision, N, "  /* the root's tolerance per "
                                      "component: its float rounding [um] */"))
        if q_off[-1] > 0:
            decls += [_ints_table("kstart", kstart, N), _ints_table("kindex", kindex, N)
                      + "  /* hysterons keeping their state inside each cell */",
                      _reals_table("fixed", fixed, precision, N, "  /* per cell: sum of +1 and "
                                   "-1 hysteron weights [um] */")]
        body.append(_sections(_ROOT.format(**lit), keep))
        law = f"""    {{  /* Gauss-Seidel over the outputs, a monotone root per direct path; sweeps that
           do not settle are repeated under-relaxed (omega 1/2 ... 1/16) */
        int round, sweep, converged = 0, beyond[{N}_N_INPUTS] = {{0}};
        {N}_real omega = {lit['one']}, h0[{N}_N_INPUTS], h1[{N}_N_INPUTS], h2[{N}_N_INPUTS];
        {N}_memo mm;
        for (k = 0; k < {N}_N_COMPONENTS; ++k) {{ mm.n[k] = mm.last[k] = 0; mm.cell[k] = -2; }}
        for (round = 0; round < 5 && !converged; ++round) {{
            for (sweep = 0; sweep < {N}_MAX_SWEEPS; ++sweep) {{
                {N}_real delta = {lit['zero']};
                for (l = 0; l < {N}_N_OUTPUTS; ++l) {{
                    {N}_real target = r[l], nw, dd;
                    for (k = 0; k < {N}_N_INPUTS; ++k)
                        if (k != l && {N}_present[l * {N}_N_INPUTS + k])
                            target -= {N}_eval(&mm, l * {N}_N_INPUTS + k, u[k], s->h);
                    nw = {N}_root(&mm, l * {N}_N_INPUTS + l, target, u[l], {N}_lo[l], {N}_hi[l], s->h,
                                  &beyond[l]);
                    dd = {N}_ABS(nw - u[l]);
                    if (dd > delta) delta = dd;
                    u[l] = omega == {lit['one']} ? nw : u[l] + omega * (nw - u[l]);
                }}
                if (delta <= {N}_SWEEP_END) {{ converged = 1; break; }}
                if (round == 0) {{   /* Aitken's extrapolation, once, from the last three sweeps */
                    for (k = 0; k < {N}_N_INPUTS; ++k) {{ h2[k] = h1[k]; h1[k] = h0[k]; h0[k] = u[k]; }}
                    if (sweep == {N}_AITKEN_SWEEP)
                        for (k = 0; k < {N}_N_INPUTS; ++k) {{
                            const {N}_real d1 = h0[k] - h1[k], d0 = h1[k] - h2[k];
                            if (d1 != d0 && {N}_ABS(d1) < {N}_ABS(d0)) {{
                                const {N}_real ua = h0[k] - d1 * d1 / (d1 - d0);
                                if ({N}_lo[k] < ua && ua < {N}_hi[k]) u[k] = ua;
                            }}
                        }}
                }}
            }}
            omega *= {lit['half']};
        }}
        for (k = 0; k < {N}_N_INPUTS; ++k)   /* the reference is out of reach: the input bound */
            if (beyond[k] && (u[k] == {N}_lo[k] || u[k] == {N}_hi[k])) status |= {N}_STATUS_RANGE;
    }}"""
    else:
        law = f"""    {{  /* inverse multiplicative law: u = clip(u(t-T) + K^-1 (r - Gamma(u(t-T)))) */
        {N}_real g[{N}_N_OUTPUTS];
        for (l = 0; l < {N}_N_OUTPUTS; ++l) {{
            g[l] = {lit['zero']};
            for (k = 0; k < {N}_N_INPUTS; ++k)
                if ({N}_present[l * {N}_N_INPUTS + k])
                    g[l] += {N}_component(l * {N}_N_INPUTS + k, u[k], s->h);
        }}
        for (k = 0; k < {N}_N_INPUTS; ++k) {{
            {N}_real a = u[k];
            for (l = 0; l < {N}_N_OUTPUTS; ++l) a += {N}_K_inv[k][l] * (r[l] - g[l]);
            if (a < {N}_lo[k]) {{ if (a < {N}_lo[k] - {N}_bound_tol[k]) status |= {N}_STATUS_RANGE; a = {N}_lo[k]; }}
            if (a > {N}_hi[k]) {{ if (a > {N}_hi[k] + {N}_bound_tol[k]) status |= {N}_STATUS_RANGE; a = {N}_hi[k]; }}
            u[k] = a;
        }}
    }}"""
    ldecls, lcode, _ = _limits_code(limits, m, T, precision, N)
    body.append(f"""void {N}_init({N}_state *s)
{{
    int j, k;
    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {lit['zero']};
    for (j = 0; j < {max(1, nh)}; ++j) s->h[j] = {N}_h0[j];
{chr(10).join(init)}
    for (j = 0; j < {p * m}; ++j) s->moved[j] = -2;   /* no move yet: the first moves every state */
    s->diverged = 0;
}}
""")
    body.append("\n".join([f"""int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS])
{{
    {N}_real r[{N}_N_OUTPUTS], u[{N}_N_INPUTS];
    int k, l, status = 0;
@REFERENCE_CHECK@
    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = reference[l];"""] + scode + [
        *([f"""    if (s->received < {N}_PREVIEW) {{  /* filling the preview: the actuator stays at rest */
        s->received += 1;
        for (k = 0; k < {N}_N_INPUTS; ++k) voltage[k] = s->u[k];
        return status;
    }}"""] if preview else []),
        f"    for (k = 0; k < {N}_N_INPUTS; ++k) u[k] = s->u[k];", law,
        f"""    for (l = 0; l < {N}_N_OUTPUTS; ++l)   /* move every state to the solution */
        for (k = 0; k < {N}_N_INPUTS; ++k)
            if ({N}_present[l * {N}_N_INPUTS + k]) {N}_move(l * {N}_N_INPUTS + k, u[k], s->h, s->moved);"""]
        + lcode + ["""    return status;
}
"""]))
    if preview:
        members.append("    int received;                  /* references received, up to PREVIEW */")
        body = [b.replace("    s->diverged = 0;\n", "    s->received = 0;\n    s->diverged = 0;\n") for b in body]
    members.append(f"    int moved[{p * m}];   /* per component: the switching cell its states were moved to last */")
    members.append("    int diverged;                  /* latched divergence flag (unused: the root is bounded) */")
    return decls + ldecls, body, members, [], reals


def _plan_preisach_inverse(comp):
    if comp.method == "root":
        what = f"exact per-sample inverse of the {_model_text(comp.model)} (monotone root per " \
               f"direct path, Gauss-Seidel over the cross-couplings)"
    else:
        what = f"inverse multiplicative law ({comp.name}) over the {_model_text(comp.model)}"
    return ("exact", comp.model, 0, what,
            lambda precision, N, limits, T: _exact_source(comp, [], comp.model, precision, N,
                                                          limits, T, 0))
