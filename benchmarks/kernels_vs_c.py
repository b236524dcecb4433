"""The compiled kernels against a plain C reference of the same arithmetic (not a test).

Run: ``python benchmarks/kernels_vs_c.py [--quick] [--samples N] [--iterations I]
[--prefilter] [--sizes 2x2x5,6x6x50] [--markdown FILE]`` (from the repository root;
needs ``gcc``; by default the grid of issue 41, :data:`SIZES`).

It writes a plain C implementation of the three hot loops of
:mod:`hammerstein.simulation._kernels` on the same packed arrays (play
operators grouped by input and padded to ``LANES``, weights ``W`` (p, n_plays),
gains ``G`` (p, m), discrete state space ``A, B, C, D``):

* ``plant``: multivariable PI (eq. (1) and (4) of the paper) -> linear
  bending modes, per sample (:func:`~hammerstein.simulation._kernels.plant_kernel`);
* ``chain``: optional reference pre-filter (``--prefilter``: a state space
  shaped like a Hammerstein compensator's ZPETC inverse of G, the law's
  ``prefiltered`` branch, run ahead of the law 256 samples at a time, its
  delay lines read from the reference, the other terms summed over the block
  term by term and its dynamic states stepped sample by sample, as the
  kernel does) -> plant step of the previous sample, ahead of the law, as the
  kernel does -> compensator (delay law,
  ``iterations`` fixed-point steps with the play states frozen at the
  previous sample, each re-evaluation ``Gamma(U; s)`` taking the outputs in
  pairs, one pass over the plays per pair with each moved play in a
  register, each input's plays summed apart; a 2 x 2 model's law in
  scalars, U in registers, as the kernel's; divergence check, commit)
  -> PI -> bending modes
  (:func:`~hammerstein.simulation._kernels.chain_kernel`, called with
  ``slopes`` None: the iterations as written, which the C reference steps;
  a 2 x 2 law with 2-3 iterations otherwise runs in closed form, faster);
* ``batch``: the chain over several cases with ragged records, one after the
  other (:func:`~hammerstein.simulation._kernels.chain_batch` on one thread);

compiles it with ``gcc -O3 -march=native -fassociative-math -fno-signed-zeros
-fno-trapping-math -ffp-contract=off`` (the reassociation numba's
``fastmath={'reassoc'}`` allows, nothing more: exact non-finite semantics,
and no FMA contraction, which numba's flags do not allow either and which
gcc does by default in GNU C on a CPU with FMA: without
``-ffp-contract=off`` the reference has ~195 fused multiply-adds) and
calls it through ctypes on the same random data as the numba kernels. For
each size ``inputs x outputs x hysterons`` (hysterons = play operators per
input; every output weights every play, two bending-mode states per output)
it prints ns per sample of each, their ratio numba/C (target <= 1.3) and the
largest difference of the outputs (the two differ only by the order of the
weighted sums). Times are the best of several alternated calls, in CPU time
of the calling thread (``time.thread_time``: steadier than wall time on a
shared machine, and blind to other threads of the process; each call runs
``--samples`` samples); the load average is printed, other processes slow
both sides alike (shared caches). ``--markdown FILE`` appends the table,
with the settings, gcc version and load, to FILE.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hammerstein.simulation import _kernels as kernels  # noqa: E402
from hammerstein.simulation._packing import (LANES, ChainState, LawArrays,  # noqa: E402
                                             LinearArrays, PIArrays)

TARGET = 1.3
CFLAGS = ["-O3", "-march=native", "-fassociative-math", "-fno-signed-zeros",
          "-fno-trapping-math", "-ffp-contract=off", "-shared", "-fPIC"]
#: the grid of issue 41 (1 x 1 x 5 ... 6 x 6 x 50)
SIZES = [(1, 1, 5), (1, 1, 50), (2, 2, 5), (2, 2, 15), (2, 2, 50), (3, 3, 20), (4, 4, 30),
         (6, 6, 5), (6, 6, 50)]

C_SOURCE = r"""
#include <stdint.h>
#include <math.h>

static inline double play(double v, double u, double r) {
    double hi = u + r, lo = u - r;
    v = hi < v ? hi : v;
    return lo > v ? lo : v;
}

/* s <- play(s, u): the plays of input k are start[k]..start[k+1] */
static inline void commit(const double *u, int64_t m, const int64_t *start, const double *r,
                          double *s) {
    for (int64_t k = 0; k < m; k++) {
        double uk = u[k];
        for (int64_t j = start[k]; j < start[k + 1]; j++) s[j] = play(s[j], uk, r[j]);
    }
}

/* y = W s + G u */
static inline void output(const double *u, int64_t m, int64_t p, int64_t n, const double *W,
                          const double *G, const double *s, double *y) {
    for (int64_t l = 0; l < p; l++) {
        double a = 0.0;
        for (int64_t j = 0; j < n; j++) a += W[l * n + j] * s[j];
        for (int64_t k = 0; k < m; k++) a += G[l * m + k] * u[k];
        y[l] = a;
    }
}

/* outputs l and l1 of Gamma(u; s), the plays moved to u but not stored: one pass over the
   plays, each moved play (a register) weighted into both outputs, each input's plays summed
   apart and added, then G u (the kernel's _moved_pair) */
static inline void moved_pair(const double *u, int64_t m, int64_t n, const int64_t *start,
                              const double *r, const double *W, const double *G,
                              const double *s, int64_t l, int64_t l1, double *y0, double *y1) {
    double a0 = 0.0, a1 = 0.0;
    const double *w0 = W + l * n, *w1 = W + l1 * n;
    for (int64_t k = 0; k < m; k++) {
        double uk = u[k], b0 = 0.0, b1 = 0.0;
        for (int64_t j = start[k]; j < start[k + 1]; j++) {
            double vj = play(s[j], uk, r[j]);
            b0 += w0[j] * vj;
            b1 += w1[j] * vj;
        }
        a0 += b0;
        a1 += b1;
    }
    for (int64_t k = 0; k < m; k++) {
        a0 += G[l * m + k] * u[k];
        a1 += G[l1 * m + k] * u[k];
    }
    *y0 = a0;
    *y1 = a1;
}

/* Gamma(u; s) of a 2 x 2 model, u in registers: each input's plays summed apart, G u apart,
   added last (the kernel's _gamma2) */
static inline void gamma2(double u0, double u1, const int64_t *start, const double *r,
                          const double *W, const double *G, const double *s, int64_t n,
                          double *y0, double *y1) {
    double a0 = 0.0, a1 = 0.0, b0 = 0.0, b1 = 0.0;
    for (int64_t j = start[0]; j < start[1]; j++) {
        double vj = play(s[j], u0, r[j]);
        a0 += W[j] * vj;
        a1 += W[n + j] * vj;
    }
    for (int64_t j = start[1]; j < start[2]; j++) {
        double vj = play(s[j], u1, r[j]);
        b0 += W[j] * vj;
        b1 += W[n + j] * vj;
    }
    double g0 = G[0] * u0 + G[1] * u1, g1 = G[2] * u0 + G[3] * u1;
    *y0 = (a0 + b0) + g0;
    *y1 = (a1 + b1) + g1;
}

/* y = Gamma(u; s) without moving the plays: outputs in pairs, an odd last one paired with
   itself (the kernel's _evaluate) */
static inline void evaluate(const double *u, int64_t m, int64_t p, int64_t n,
                            const int64_t *start, const double *r, const double *W,
                            const double *G, const double *s, double *y) {
    for (int64_t l = 0; l < p; l += 2) {
        int64_t l1 = l + 1 < p ? l + 1 : l;
        double a0, a1;
        moved_pair(u, m, n, start, r, W, G, s, l, l1, &a0, &a1);
        y[l] = a0;
        y[l1] = a1;
    }
}

/* y = C x + D h; x <- A x + B h */
static inline void linear(const double *h, int64_t q, int64_t nx, const double *A,
                          const double *B, const double *C, const double *D, double *x,
                          double *xn, double *y) {
    for (int64_t l = 0; l < q; l++) {
        double a = 0.0;
        for (int64_t i = 0; i < nx; i++) a += C[l * nx + i] * x[i];
        for (int64_t i = 0; i < q; i++) a += D[l * q + i] * h[i];
        y[l] = a;
    }
    for (int64_t i = 0; i < nx; i++) {
        double a = 0.0;
        for (int64_t j = 0; j < nx; j++) a += A[i * nx + j] * x[j];
        for (int64_t j = 0; j < q; j++) a += B[i * q + j] * h[j];
        xn[i] = a;
    }
    for (int64_t i = 0; i < nx; i++) x[i] = xn[i];
}

#define MAXV 64
#define MAXX 256

#define BLOCK 256
#define MAXT ((MAXX + MAXV) * (MAXX + MAXV))

/* the pre-filter [[C, D], [A, B]] split into delay lines (a state whose update is a single
   1.0 on an input or on such a state, one per input and lag) and dynamic states; each
   computed row (outputs, then dynamic states) in column order, split at its first dynamic
   state into a head and a tail (the kernel's _prefilter_plan) */
static int64_t f_L, f_nd, f_lag[MAXX], f_src[MAXX], f_dyn[MAXX], f_hist[MAXV][MAXX + 1];
static int64_t f_sptr[MAXX + MAXV + 1], f_sin[MAXT], f_slag[MAXT];
static int64_t f_rptr[MAXX + MAXV + 1], f_rkind[MAXT], f_rcol[MAXT], f_rlag[MAXT];
static double f_sval[MAXT], f_rval[MAXT];

static void prefilter_plan(int64_t q, int64_t nx, const double *A, const double *B,
                           const double *C, const double *D) {
    int64_t k = q, one[MAXX], where[MAXX];
    for (int64_t i = 0; i < nx; i++) {
        int64_t cnt = 0, c = -1, unit = 0;
        for (int64_t j = 0; j < nx + k; j++) {
            double a = j < nx ? A[i * nx + j] : B[i * k + j - nx];
            if (a != 0.0) { cnt++; c = j; unit = a == 1.0; }
        }
        one[i] = cnt == 1 && unit ? c : -1;
    }
    for (int again = 1; again;) {
        for (int64_t i = 0; i < nx; i++) f_lag[i] = 0;
        for (int changed = 1; changed;) {
            changed = 0;
            for (int64_t i = 0; i < nx; i++) {
                int64_t c = one[i];
                if (f_lag[i] == 0 && c >= 0) {
                    if (c >= nx) { f_lag[i] = 1; f_src[i] = c - nx; changed = 1; }
                    else if (f_lag[c] > 0) { f_lag[i] = f_lag[c] + 1; f_src[i] = f_src[c]; changed = 1; }
                }
            }
        }
        again = 0;
        for (int64_t i = 0; i < nx; i++)
            for (int64_t j = 0; j < i; j++)
                if (f_lag[i] > 0 && f_lag[j] == f_lag[i] && f_src[j] == f_src[i]) { one[i] = -1; again = 1; }
    }
    f_L = 0; f_nd = 0;
    for (int64_t i = 0; i < nx; i++) if (f_lag[i] > f_L) f_L = f_lag[i];
    for (int64_t l = 0; l < k; l++) for (int64_t d = 0; d <= f_L; d++) f_hist[l][d] = -1;
    for (int64_t i = 0; i < nx; i++) {
        if (f_lag[i] == 0) { f_dyn[f_nd] = i; where[i] = f_nd++; }
        else f_hist[f_src[i]][f_lag[i]] = i;
    }
    int64_t ns = 0, nr = 0;
    f_sptr[0] = f_rptr[0] = 0;
    for (int64_t w = 0; w < q + f_nd; w++) {
        int tail = 0;
        for (int64_t j = 0; j < nx + k; j++) {
            double a = w < q ? (j < nx ? C[w * nx + j] : D[w * k + j - nx])
                             : (j < nx ? A[f_dyn[w - q] * nx + j] : B[f_dyn[w - q] * k + j - nx]);
            if (a == 0.0) continue;
            int stat = j >= nx || f_lag[j] > 0;
            tail = tail || !stat;
            int64_t in = j >= nx ? j - nx : f_src[j], lg = j >= nx ? 0 : f_lag[j];
            if (!tail) { f_sin[ns] = in; f_slag[ns] = lg; f_sval[ns++] = a; }
            else {
                f_rkind[nr] = !stat; f_rcol[nr] = stat ? in : where[j]; f_rlag[nr] = stat ? lg : 0;
                f_rval[nr++] = a;
            }
        }
        f_sptr[w + 1] = ns;
        f_rptr[w + 1] = nr;
    }
}

/* pre-filter samples t0..t1 of yr (p rows of stride N) into vb (p rows of stride BLOCK):
   the delay lines read from a history of the reference, each row's head summed over the
   block term by term, the dynamic states stepped sample by sample, the outputs' tails added
   over the block term by term; z (nf,) the state after t1 (the kernel's _prefilter_block) */
static void prefilter_block(const double *yr, int64_t N, int64_t t0, int64_t t1, int64_t p,
                            int64_t nf, double *z, double *vb) {
    static double H[MAXV * (MAXX + 1 + BLOCK)], S[(MAXV + MAXX) * BLOCK], X[MAXX * (BLOCK + 1)];
    int64_t L = f_L, nd = f_nd, q = p, n = t1 - t0, HW = f_L + BLOCK, XW = BLOCK + 1;
    for (int64_t l = 0; l < p; l++) {
        for (int64_t d = 1; d <= L; d++) {
            int64_t i = f_hist[l][d];
            H[l * HW + L - d] = i >= 0 ? z[i] : 0.0;
        }
        for (int64_t k = 0; k < n; k++) H[l * HW + L + k] = yr[l * N + t0 + k];
    }
    for (int64_t w = 0; w < q + nd; w++) {
        double *Sw = S + w * BLOCK;
        for (int64_t k = 0; k < n; k++) Sw[k] = 0.0;
        for (int64_t m = f_sptr[w]; m < f_sptr[w + 1]; m++) {
            double a = f_sval[m];
            const double *Hl = H + f_sin[m] * HW + L - f_slag[m];
            for (int64_t k = 0; k < n; k++) Sw[k] += a * Hl[k];
        }
    }
    for (int64_t e = 0; e < nd; e++) X[e * XW] = z[f_dyn[e]];
    for (int64_t k = 0; k < n; k++)
        for (int64_t e = 0; e < nd; e++) {
            int64_t w = q + e;
            double a = S[w * BLOCK + k];
            for (int64_t m = f_rptr[w]; m < f_rptr[w + 1]; m++)
                a += f_rkind[m] ? f_rval[m] * X[f_rcol[m] * XW + k]
                                : f_rval[m] * H[f_rcol[m] * HW + L - f_rlag[m] + k];
            X[e * XW + k + 1] = a;
        }
    for (int64_t w = 0; w < q; w++) {
        double *Sw = S + w * BLOCK;
        for (int64_t m = f_rptr[w]; m < f_rptr[w + 1]; m++) {
            double a = f_rval[m];
            const double *src = f_rkind[m] ? X + f_rcol[m] * XW
                                           : H + f_rcol[m] * HW + L - f_rlag[m];
            for (int64_t k = 0; k < n; k++) Sw[k] += a * src[k];
        }
        for (int64_t k = 0; k < n; k++) vb[w * BLOCK + k] = Sw[k];
    }
    for (int64_t e = 0; e < nd; e++) z[f_dyn[e]] = X[e * XW + n];
    for (int64_t i = 0; i < nf; i++)
        if (f_lag[i] > 0) z[i] = H[f_src[i] * HW + L + n - f_lag[i]];
}

void plant(int64_t m, int64_t p, int64_t n, int64_t nx, int64_t N, const double *u,
           const int64_t *start, const double *r, const double *W, const double *G, double *s,
           const double *A, const double *B, const double *C, const double *D, double *x,
           double *y) {
    double ut[MAXV], h[MAXV], yt[MAXV], xn[MAXX];
    for (int64_t t = 0; t < N; t++) {
        for (int64_t k = 0; k < m; k++) ut[k] = u[k * N + t];
        commit(ut, m, start, r, s);
        output(ut, m, p, n, W, G, s, h);
        linear(h, p, nx, A, B, C, D, x, xn, yt);
        for (int64_t l = 0; l < p; l++) y[l * N + t] = yt[l];
    }
}

/* reference pre-filter (if prefiltered: ref = Cf xf + Df yr(t), xf <- Af xf + Bf yr(t),
   e.g. a Hammerstein compensator's ZPETC inverse of G, run ahead of the law BLOCK samples at
   a time) -> delay law (a 2 x 2 model in scalars); returns the first failing sample (status
   in *status) or N */
int64_t chain(int64_t m, int64_t p, int64_t N, const double *yr, const double *Kinv,
              int64_t iterations, double bound, int64_t prefiltered, const double *Af,
              const double *Bf, const double *Cf, const double *Df, int64_t nf, double *xf,
              const int64_t *cstart, const double *cr, const double *cW, const double *cG,
              int64_t cn, const int64_t *pstart, const double *pr, const double *pW,
              const double *pG, int64_t pn, const double *A, const double *B, const double *C,
              const double *D, int64_t nx, double *cu, double *cs, double *ps, double *x,
              double *u_out, double *y_out, int64_t *status) {
    double u[MAXV], e[MAXV], yh[MAXV], yhat[MAXV], ref[MAXV], h[MAXV], yt[MAXV];
    double xn[MAXX];
    static double z[MAXX + MAXV], zb[MAXX];
    static double vb[MAXV * BLOCK];
    int two = m == 2 && p == 2;
    double k00 = two ? Kinv[0] : 0.0, k01 = two ? Kinv[1] : 0.0;
    double k10 = two ? Kinv[2] : 0.0, k11 = two ? Kinv[3] : 0.0;
    *status = 0;
    prefilter_plan(p, nf, Af, Bf, Cf, Df);
    for (int64_t i = 0; i < nf; i++) z[i] = xf[i];
    evaluate(cu, m, p, cn, cstart, cr, cW, cG, cs, yhat);
    for (int64_t t = 0; t < N; t++) {
        int64_t tb = t % BLOCK;
        if (prefiltered) {
            if (tb == 0) {
                for (int64_t i = 0; i < nf; i++) zb[i] = z[i];
                prefilter_block(yr, N, t, t + BLOCK < N ? t + BLOCK : N, p, nf, z, vb);
            }
            for (int64_t l = 0; l < p; l++) ref[l] = vb[l * BLOCK + tb];
        } else {
            for (int64_t l = 0; l < p; l++) ref[l] = yr[l * N + t];
        }
        if (t > 0) {             /* the plant's step of sample t - 1, ahead of the law's */
            commit(cu, m, pstart, pr, ps);
            output(cu, m, p, pn, pW, pG, ps, h);
            linear(h, p, nx, A, B, C, D, x, xn, yt);
            for (int64_t l = 0; l < p; l++) y_out[l * N + t - 1] = yt[l];
        }
        if (two) {
            double y0 = yhat[0], y1 = yhat[1], u0 = cu[0], u1 = cu[1];
            for (int64_t it = 0; it < iterations; it++) {
                if (it > 0) gamma2(u0, u1, cstart, cr, cW, cG, cs, cn, &y0, &y1);
                double e0 = ref[0] - y0, e1 = ref[1] - y1;
                u0 += k00 * e0 + k01 * e1;
                u1 += k10 * e0 + k11 * e1;
            }
            u[0] = u0;
            u[1] = u1;
        } else {
            for (int64_t k = 0; k < m; k++) u[k] = cu[k];
            for (int64_t it = 0; it < iterations; it++) {
                if (it == 0) {
                    for (int64_t l = 0; l < p; l++) e[l] = ref[l] - yhat[l];
                } else {
                    evaluate(u, m, p, cn, cstart, cr, cW, cG, cs, yh);
                    for (int64_t l = 0; l < p; l++) e[l] = ref[l] - yh[l];
                }
                for (int64_t k = 0; k < m; k++) {
                    double acc = 0.0;
                    for (int64_t l = 0; l < p; l++) acc += Kinv[k * p + l] * e[l];
                    u[k] += acc;
                }
            }
        }
        int64_t st = 0;
        for (int64_t k = 0; k < m; k++) {
            u_out[k * N + t] = u[k];
            if (!isfinite(u[k])) st = 1;
        }
        if (st == 0)
            for (int64_t k = 0; k < m; k++) if (fabs(u[k]) > bound) st = 2;
        if (st) {
            if (prefiltered) {
                for (int64_t i = 0; i < nf; i++) z[i] = zb[i];
                prefilter_block(yr, N, t - tb, t + 1, p, nf, z, vb);
            }
            for (int64_t i = 0; i < nf; i++) xf[i] = z[i];
            *status = st;
            return t;
        }
        commit(u, m, cstart, cr, cs);
        output(u, m, p, cn, cW, cG, cs, yhat);
        for (int64_t k = 0; k < m; k++) cu[k] = u[k];
    }
    if (N > 0) {                 /* the plant's step of the last sample */
        commit(cu, m, pstart, pr, ps);
        output(cu, m, p, pn, pW, pG, ps, h);
        linear(h, p, nx, A, B, C, D, x, xn, yt);
        for (int64_t l = 0; l < p; l++) y_out[l * N + N - 1] = yt[l];
    }
    for (int64_t i = 0; i < nf; i++) xf[i] = z[i];
    return N;
}

/* the chain over B cases of one model, records ragged (offsets), states per case */
void batch(int64_t B, const int64_t *offsets, int64_t m, int64_t p, const double *yr,
           const double *Kinv, int64_t iterations, double bound, int64_t prefiltered,
           const double *Af, const double *Bf, const double *Cf, const double *Df, int64_t nf,
           double *xf, const int64_t *cstart, const double *cr, const double *cW,
           const double *cG, int64_t cn, const int64_t *pstart, const double *pr,
           const double *pW, const double *pG, int64_t pn, const double *A, const double *B_,
           const double *C, const double *D, int64_t nx, double *cu, double *cs, double *ps,
           double *x, double *u_out, double *y_out, int64_t *status, int64_t *sample) {
    for (int64_t b = 0; b < B; b++) {
        int64_t a = offsets[b], n = offsets[b + 1] - a;
        sample[b] = chain(m, p, n, yr + p * a, Kinv + b * m * p, iterations, bound, prefiltered,
                          Af + b * nf * nf, Bf + b * nf * p, Cf + b * p * nf, Df + b * p * p, nf,
                          xf + b * nf,
                          cstart + b * (m + 1), cr + b * cn, cW + b * p * cn, cG + b * p * m, cn,
                          pstart + b * (m + 1), pr + b * pn, pW + b * p * pn, pG + b * p * m, pn,
                          A + b * nx * nx, B_ + b * nx * p, C + b * p * nx, D + b * p * p, nx,
                          cu + b * m, cs + b * cn, ps + b * pn, x + b * nx,
                          u_out + m * a, y_out + p * a, status + b);
    }
}
"""


def compile_reference(directory):
    """Compile :data:`C_SOURCE` into a shared library in ``directory``; return it (ctypes)."""
    src = Path(directory) / "kernels_ref.c"
    lib = Path(directory) / "kernels_ref.so"
    src.write_text(C_SOURCE)
    subprocess.run(["gcc", *CFLAGS, str(src), "-o", str(lib), "-lm"], check=True)
    cdll = ctypes.CDLL(str(lib))
    i, d, P = ctypes.c_int64, ctypes.c_double, ctypes.c_void_p
    cdll.plant.argtypes = [i, i, i, i, i] + [P] * 12
    cdll.plant.restype = None
    cdll.chain.argtypes = ([i, i, i, P, P, i, d, i, P, P, P, P, i, P, P, P, P, P, i, P, P, P, P,
                            i, P, P, P, P, i] + [P] * 7)
    cdll.chain.restype = i
    cdll.batch.argtypes = ([i, P, i, i, P, P, i, d, i, P, P, P, P, i, P, P, P, P, P, i, P, P, P,
                            P, i, P, P, P, P, i] + [P] * 8)
    cdll.batch.restype = None
    return cdll


def _ptr(a):
    return a.ctypes.data_as(ctypes.c_void_p)


def random_pi(rng, m, p, n, gain=1.0):
    """Packed PI: n plays per input (padded to LANES), dense positive weights, output gain ~ gain."""
    per = -(-n // LANES) * LANES
    start = np.arange(m + 1, dtype=np.int64) * per
    r = np.zeros(m * per)
    W = np.zeros((p, m * per))
    for k in range(m):
        r[k * per:k * per + n] = np.linspace(0.0, 3.0, n)
        W[:, k * per:k * per + n] = rng.uniform(0.5, 1.5, (p, n)) * gain / n
    for l in range(min(p, m)):          # a dominant direct transfer
        W[l, l * per:l * per + n] *= 4.0
    G = rng.uniform(-0.05, 0.05, (p, m))
    return PIArrays(start, r, W / m, G)


def bending_modes(rng, p, T=5e-5):
    """Two states per output: lightly damped modes near 300 Hz, unit DC gain (Euler-free, exact)."""
    nx = 2 * p
    A = np.zeros((nx, nx))
    B = np.zeros((nx, p))
    C = np.zeros((p, nx))
    D = np.zeros((p, p))
    for l in range(p):
        w = 2 * np.pi * rng.uniform(280, 320)
        z = 0.05
        rad = np.exp(-z * w * T)
        wd = w * np.sqrt(1 - z * z) * T
        a1, a2 = 2 * rad * np.cos(wd), -rad * rad
        i = 2 * l
        A[i, i], A[i, i + 1], A[i + 1, i] = a1, a2, 1.0
        B[i, l] = 1.0
        C[l, i] = 1.0 - a1 - a2                 # y(t) = (1 - a1 - a2) x1: unit DC gain
        if p > 1:
            C[l, (i + 2) % nx] = 0.01 * (1.0 - a1 - a2)   # a little cross-coupling
    return LinearArrays(A, B, C, D)


def zpetc_like_prefilter(rng, p, window=4):
    """A reference pre-filter shaped like a Hammerstein compensator's ZPETC inverse of G.

    :meth:`hammerstein.compensation.inversion.ZPETCInverse.state_space` of the bundled
    2x2 plant: a shift register of the ``window - 1`` past reference samples
    (p each) plus one acceptable-mode state per output (a stable pole), taps
    on the window (``Cf``, ``Df``) and on the modes' input; ``p * window``
    states, dense matrices as the kernels receive them (mostly zeros). Unit
    DC gain, so the filtered reference keeps the amplitude of ``yr``.
    """
    L = window
    nw = p * (L - 1)
    n = nw + p
    Af, Bf = np.zeros((n, n)), np.zeros((n, p))
    Cf, Df = np.zeros((p, n)), np.zeros((p, p))
    for l in range(p):
        taps = rng.uniform(-1.0, 1.0, L)
        taps[0] += 1.0 - taps.sum()                  # unit DC gain of the window part
        pole = rng.uniform(0.2, 0.6)
        Df[l, l] = taps[0]
        for j in range(L - 1):                       # slot j holds r(k - (L - 1 - j))
            Cf[l, j * p + l] = taps[L - 1 - j]
            Af[nw + l, j * p + l] = 0.05 * taps[L - 1 - j]
        Af[nw + l, nw + l] = pole
        Bf[nw + l, l] = 0.05 * taps[0]
        Cf[l, nw + l] = 1e-3
    for j in range(L - 2):                           # shift the window by one sample
        Af[j * p:(j + 1) * p, (j + 1) * p:(j + 2) * p] = np.eye(p)
    Bf[(L - 2) * p:(L - 1) * p] = np.eye(p)
    return LinearArrays(Af, Bf, Cf, Df)


def reference(rng, p, N, T=5e-5):
    t = np.arange(N) * T
    return np.vstack([3.0 * np.sin(2 * np.pi * (50 + 13 * l) * t + l) for l in range(p)])


def best_time(fn, repeats):
    """Least CPU time of this thread over ``repeats`` calls of ``fn`` [s]."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t0)
    return best


def case(lib, m, p, n, N, repeats, iterations=1, n_cases=8, prefilter=False):
    """ns per sample of numba and C for the plant, chain and batch loops; max |dy|.

    ``prefilter``: the chain and batch run a Hammerstein compensator's law
    (:func:`zpetc_like_prefilter` before the law); otherwise the inverse
    multiplicative law alone (the identity pre-filter, skipped).
    """
    rng = np.random.default_rng(m * 10000 + p * 100 + n)
    pi = random_pi(rng, m, p, n)
    comp = random_pi(rng, m, p, n)
    lin = bending_modes(rng, p)
    nx = lin.A.shape[0]
    pn, cn = pi.r.size, comp.r.size
    u = np.ascontiguousarray(reference(rng, m, N))
    yr = np.ascontiguousarray(reference(rng, p, N))
    # compensator gain: the inverse of the model's secant gain (direct transfer dominant)
    Kmat = np.zeros((p, m))
    for l in range(p):
        for k in range(m):
            Kmat[l, k] = comp.W[l, comp.start[k]:comp.start[k + 1]].sum() + comp.G[l, k]
    K_inv = np.ascontiguousarray(np.linalg.inv(Kmat))
    out = {}

    # plant ---------------------------------------------------------------------
    def nb_plant():
        s, x, y = np.zeros(pn), np.zeros(nx), np.empty((p, N))
        kernels.plant_kernel(u, pi, s, lin, x, y)
        return y

    def c_plant():
        s, x, y = np.zeros(pn), np.zeros(nx), np.empty((p, N))
        lib.plant(m, p, pn, nx, N, _ptr(u), _ptr(pi.start), _ptr(pi.r), _ptr(pi.W), _ptr(pi.G),
                  _ptr(s), _ptr(lin.A), _ptr(lin.B), _ptr(lin.C), _ptr(lin.D), _ptr(x), _ptr(y))
        return y

    out["plant"] = _compare(nb_plant, c_plant, N, repeats)

    # chain ---------------------------------------------------------------------
    law = LawArrays(K_inv, iterations, 1e6, False, 0.0, bool(prefilter))
    filt = (zpetc_like_prefilter(rng, p) if prefilter else
            LinearArrays(np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p)))
    nf = filt.A.shape[0]
    # the C reference steps the law's iterations as written: the kernel is compared without
    # the closed-form 2 x 2 law (slopes None), with the pre-filter's plan only when it has one
    plan = kernels.prefilter_plan(filt) if prefilter else None

    def nb_chain():
        st = ChainState(np.zeros(m), np.zeros(m), np.zeros(cn), np.zeros(nf), np.zeros(pn),
                        np.zeros(nx))
        uo, yo = np.empty((m, N)), np.empty((p, N))
        status, _ = kernels.chain_kernel(yr, N, law, comp, plan, None, pi, lin, True, st, uo,
                                         yo)
        assert status == 0, "the benchmark's compensator diverged"
        return yo

    def c_chain():
        cu, cs, ps, x = np.zeros(m), np.zeros(cn), np.zeros(pn), np.zeros(nx)
        xf = np.zeros(nf)
        uo, yo = np.empty((m, N)), np.empty((p, N))
        status = np.zeros(1, dtype=np.int64)
        lib.chain(m, p, N, _ptr(yr), _ptr(K_inv), iterations, ctypes.c_double(1e6),
                  int(prefilter), _ptr(filt.A), _ptr(filt.B), _ptr(filt.C), _ptr(filt.D), nf,
                  _ptr(xf), _ptr(comp.start), _ptr(comp.r), _ptr(comp.W), _ptr(comp.G), cn,
                  _ptr(pi.start), _ptr(pi.r), _ptr(pi.W), _ptr(pi.G), pn,
                  _ptr(lin.A), _ptr(lin.B), _ptr(lin.C), _ptr(lin.D), nx,
                  _ptr(cu), _ptr(cs), _ptr(ps), _ptr(x), _ptr(uo), _ptr(yo), _ptr(status))
        assert status[0] == 0
        return yo

    out["chain"] = _compare(nb_chain, c_chain, N, repeats)

    # batch (one thread) ----------------------------------------------------------
    B = n_cases
    lengths = np.full(B, N // B, dtype=np.int64)
    lengths[: N - lengths.sum()] += 1
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    flat = np.concatenate([yr[:, offsets[b]:offsets[b + 1]].ravel() for b in range(B)])

    def tile(a):
        return np.ascontiguousarray(np.broadcast_to(a, (B,) + np.shape(a)))

    blaw = LawArrays(tile(K_inv), np.full(B, iterations, dtype=np.int64), np.full(B, 1e6),
                     np.zeros(B, dtype=np.bool_), np.zeros(B), np.full(B, bool(prefilter)))
    bcomp = PIArrays(*(tile(a) for a in comp))
    bpi = PIArrays(*(tile(a) for a in pi))
    blin = LinearArrays(*(tile(a) for a in lin))
    bfilter = LinearArrays(*(tile(a) for a in filt))    # (the C reference reads it always)
    order = np.arange(B, dtype=np.int64)

    def nb_batch():
        st = ChainState(np.zeros((B, m)), np.zeros((B, m)), np.zeros((B, cn)), np.zeros((B, nf)),
                        np.zeros((B, pn)), np.zeros((B, nx)))
        uo, yo = np.empty(m * N), np.empty(p * N)
        status, sample, worker = (np.zeros(B, dtype=np.int64) for _ in range(3))
        kernels.chain_batch(order, offsets, flat, blaw, bcomp, bfilter if prefilter else None,
                            None, bpi, blin, True, st, uo, yo, status, sample, worker, 0)
        assert not status.any()
        return yo

    def c_batch():
        cu, cs, ps, x, xf = (np.zeros((B, k)) for k in (m, cn, pn, nx, nf))
        uo, yo = np.empty(m * N), np.empty(p * N)
        status, sample = np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64)
        lib.batch(B, _ptr(offsets), m, p, _ptr(flat), _ptr(blaw.K_inv), iterations,
                  ctypes.c_double(1e6), int(prefilter), _ptr(bfilter.A), _ptr(bfilter.B),
                  _ptr(bfilter.C), _ptr(bfilter.D), nf, _ptr(xf), _ptr(bcomp.start), _ptr(bcomp.r), _ptr(bcomp.W),
                  _ptr(bcomp.G), cn, _ptr(bpi.start), _ptr(bpi.r), _ptr(bpi.W), _ptr(bpi.G), pn,
                  _ptr(blin.A), _ptr(blin.B), _ptr(blin.C), _ptr(blin.D), nx,
                  _ptr(cu), _ptr(cs), _ptr(ps), _ptr(x), _ptr(uo), _ptr(yo), _ptr(status),
                  _ptr(sample))
        assert not status.any()
        return yo

    out["batch"] = _compare(nb_batch, c_batch, N, repeats)
    return out


def _compare(nb, c, N, repeats):
    y_nb, y_c = nb(), c()                      # compile / warm up, and the outputs
    scale = max(1.0, float(np.max(np.abs(y_c))))
    diff = float(np.max(np.abs(y_nb - y_c))) / scale
    t_nb = t_c = np.inf
    for _ in range(repeats):                   # alternated, best of each
        t_nb = min(t_nb, best_time(nb, 1))
        t_c = min(t_c, best_time(c, 1))
    return {"numba_ns": t_nb / N * 1e9, "c_ns": t_c / N * 1e9, "ratio": t_nb / t_c,
            "rel_diff": diff}


def main(argv=None):
    """Print numba/C per kernel and size.

    Parameters
    ----------
    argv : list of str, optional
        ``--quick``, ``--samples N``, ``--repeat R``, ``--iterations I``, ``--prefilter``,
        ``--sizes 2x2x5,6x6x50``, ``--markdown FILE``.

    Returns
    -------
    int
        0 when every ratio is within the target, else 1.
    """
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer samples and repeats")
    ap.add_argument("--samples", type=int, default=None)
    ap.add_argument("--repeat", type=int, default=None)
    ap.add_argument("--iterations", type=int, default=1,
                    help="fixed-point iterations of the compensator (default 1)")
    ap.add_argument("--sizes", default=None,
                    help="comma-separated m x p x n sizes, e.g. 2x2x5,6x6x50 (default: the "
                         "grid of issue 41)")
    ap.add_argument("--prefilter", action="store_true",
                    help="chain and batch with a ZPETC-shaped reference pre-filter (the law of "
                         "a Hammerstein compensator, p * 4 states)")
    ap.add_argument("--markdown", default=None, metavar="FILE",
                    help="append the table (markdown) to FILE")
    args = ap.parse_args(argv)
    N = args.samples or (20_000 if args.quick else 100_000)
    repeats = args.repeat or (3 if args.quick else 7)
    import numba
    gcc = subprocess.run(["gcc", "--version"], capture_output=True,
                         text=True).stdout.splitlines()[0]
    settings = (f"numba {numba.__version__}, {gcc} {' '.join(CFLAGS[:6])}, {N} samples a "
                f"call, best of {repeats} alternated, compensator iterations {args.iterations}, "
                f"pre-filter {'ZPETC-shaped' if args.prefilter else 'none'}")
    print(f"kernels vs C  {settings}")
    load0 = os.getloadavg()[0]
    c0 = time.thread_time()
    worst = 0.0
    rows = []
    with tempfile.TemporaryDirectory(prefix="hammerstein-c-") as tmp:
        lib = compile_reference(tmp)
        print(f"{'size m x p x n':<15}" + "".join(
            f"{k + ' nb/C [ns]':>22}{'ratio':>7}" for k in ("plant", "chain", "batch"))
            + f"{'max rel |dy|':>14}")
        sizes = SIZES if not args.sizes else [tuple(int(v) for v in t.lower().split("x"))
                                              for t in args.sizes.split(",")]
        for m, p, n in sizes:
            res = case(lib, m, p, n, N, repeats, args.iterations, prefilter=args.prefilter)
            worst = max(worst, *(r["ratio"] for r in res.values()))
            rows.append(((m, p, n), res))
            row = f"{f'{m} x {p} x {n}':<15}"
            for k in ("plant", "chain", "batch"):
                r = res[k]
                row += f"{r['numba_ns']:>11.1f} /{r['c_ns']:>8.1f}{r['ratio']:>8.2f}"
            row += f"{max(r['rel_diff'] for r in res.values()):>14.1e}"
            print(row, flush=True)
    cpu = time.thread_time() - c0
    load1 = os.getloadavg()[0]
    tail = (f"worst ratio {worst:.2f} (target <= {TARGET}); thread CPU {cpu:.1f} s; "
            f"load average {load0:.2f} -> {load1:.2f} on {os.cpu_count()} cores")
    print(tail)
    if args.markdown:
        with open(args.markdown, "a", encoding="utf-8") as f:
            f.write(markdown_table(settings, rows, tail))
    return 0 if worst <= TARGET else 1


def markdown_table(settings, rows, tail):
    """The results of :func:`main` as a markdown table (ns per sample, numba / C, ratio).

    Parameters
    ----------
    settings : str
        The run's settings (one line).
    rows : list of (tuple, dict)
        ``((m, p, n), result of case())`` per size.
    tail : str
        The closing line (worst ratio, CPU, load).

    Returns
    -------
    str
    """
    out = [f"{settings}\n", "| size m x p x n | plant nb / C [ns] | ratio | chain nb / C [ns] | "
           "ratio | batch nb / C [ns] | ratio | max rel \\|dy\\| |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for (m, p, n), res in rows:
        cells = [f"{m} x {p} x {n}"]
        for k in ("plant", "chain", "batch"):
            r = res[k]
            cells += [f"{r['numba_ns']:.1f} / {r['c_ns']:.1f}", f"{r['ratio']:.2f}"]
        cells.append(f"{max(r['rel_diff'] for r in res.values()):.1e}")
        out.append("| " + " | ".join(cells) + " |")
    out.append(f"\n{tail}\n\n")
    return "\n".join(out)


if __name__ == "__main__":
    sys.exit(main())
