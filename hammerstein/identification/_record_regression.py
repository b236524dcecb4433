"""The regressions of a classical PI on split records: least squares, closed form, output maps.

The private half of :mod:`hammerstein.identification.record_identification`:
the thresholds of each input, the play outputs over the training samples
(one regression of every output on the plays of every input, reduced to its
triangular factor), the Appendix closed form per component, and the modified
PI's monotone output map fitted by alternating least squares (Kuhnen).

References
----------
.. [1] K. Kuhnen, "Modeling, identification and compensation of complex
   hysteretic nonlinearities", Eur. J. Control 9 (2003) (least squares on
   play outputs, the modified PI's output operator).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from hammerstein.models.hysteresis import MultivariablePI, OutputMap, PrandtlIshlinskii, play
from hammerstein.identification.lsq import TallQR, bounded_lstsq, lstsq_bounded_below, r_factor
from hammerstein.identification.identification import (ClosedFormPI, IdentificationError,
                                                       partition_thresholds)
from hammerstein.identification._record_split import _branches

#: Output-map options of :func:`identify_records`.
OUTPUT_MAPS = ("auto", "none", "deadzone")
#: Knots of a fitted output map (at quantiles of the PI output).
MAP_KNOTS = 16
#: Alternations of the output-map fit (PI weights, then map slopes).
MAP_ITERATIONS = 8
#: Weight of the slope-change penalty of the output map (relative to the data rows).
MAP_SMOOTHING = 0.05
#: Relative drop of the score that makes ``output_map="auto"`` keep the map on a symmetric loop.
MAP_GAIN = 0.1
#: Least initial slope of a direct transfer's loops, as a fraction of its secant (the
#: least-squares slope of the output against the input): the first weight with every
#: ``bounds``, each cumulative sum of the weights with ``bounds="monotone"``.
MIN_SLOPE_FRACTION = 0.1


# -- least squares engine ----------------------------------------------------------------
def _thresholds(records, splits, k, n, partition, explicit):
    """Thresholds of input k from the record where it travels most.

    The time partition (the paper's Remark 5.1) starts above 0 (A (1 - cos(pi / (n + 1))) / 2,
    0.58 V at 60 V and n = 15): a model without a play of threshold 0 holds its output while
    the input reverses by twice that, a flat step at every reversal and about rest, which
    its inverse crosses in one jump (a per-axis drive stepped 1.15 V at every reversal and
    started at -0.58 V from rest). Here its first threshold is 0, a linear term, and the
    other n - 1 are the time partition of n - 1 (the input partition starts at 0 already).
    """
    if explicit is not None:
        return np.asarray(explicit, dtype=float), "explicit"
    spans = [np.ptp(r.u[k][s.train]) if s.train.any() else 0.0 for r, s in zip(records, splits)]
    j = int(np.argmax(spans))
    if not spans[j] > 0:
        raise IdentificationError(f"input {records[0].input_names[k]!r}: never excited in the "
                                  f"training samples; cannot identify its components")
    uk = records[j].u[k][splits[j].train]
    if partition == "time":
        for a, b, ok in _branches(uk):
            if ok:
                sign = 1.0 if uk[b] > uk[a] else -1.0
                try:
                    rest = partition_thresholds(sign * uk, n - 1, "time", (a, b)) if n > 1 \
                        else np.zeros(0)
                    return np.concatenate([[0.0], rest]), "time"
                except IdentificationError:
                    break
        # no complete branch of this input (broadband): uniform in input
    amplitude = np.ptp(uk) / 2.0
    return amplitude * np.arange(n) / n, "input"


def _plays(u, r, periodic):
    phi, final = play(u, r)
    if periodic:
        phi, _ = play(u, r, final)
    return phi


class _LeastSquares:
    """Joint least squares of every output on the play outputs of every input."""

    def __init__(self, records, splits, thresholds, bounds, offset=True):
        self.records, self.splits, self.r = records, splits, thresholds
        self.bounds = bounds
        self.offset = offset
        m = records[0].u.shape[0]
        self.m = m
        # regressors over the training samples, concatenated over the records
        self.phi = [np.concatenate([_plays(rec.u[k], thresholds[k], s.periodic)[:, s.train]
                                    for rec, s in zip(records, splits)], axis=1).T
                    for k in range(m)]
        self.lin = [np.concatenate([rec.u[k][s.train] for rec, s in zip(records, splits)])
                    for k in range(m)]
        self.y = np.concatenate([rec.y[:, s.train] for rec, s in zip(records, splits)], axis=1)
        self._qr = None          # TallQR of every column a fit may use, factored once
        self._projected = {}     # output -> (Q^T y_l, rho) of the current target

    def set_target(self, l, target):
        """Fit output l to ``target`` (n_train,) from now on (the output map's alternation)."""
        self.y[l] = target
        self._projected.pop(l, None)

    def _reduced(self, l):
        """R of every column, its column indices, and Q^T y_l, rho (None: too few rows).

        Every candidate structure of an output (which inputs act through a PI,
        a gain or not at all) uses a subset of the same columns ``A = [plays
        of input 0, ..., inputs, 1]``: with ``A = Q R`` factored once, the
        columns S give ``A_S = Q R_S``, so ``||A_S x - y||^2 = ||R_S x -
        Q^T y||^2 + rho^2`` and each fit is a small problem on ``R_S``.
        """
        n_rows = self.y.shape[1]
        width = sum(p.shape[1] for p in self.phi) + self.m + int(self.offset)
        if n_rows < width:
            return None
        if self._qr is None:
            ones = [np.ones(n_rows)] if self.offset else []
            self._qr = TallQR(list(self.phi) + list(self.lin) + ones)
            edges = np.cumsum([0] + [p.shape[1] for p in self.phi])
            self._index = {"pi": [np.arange(a, b) for a, b in zip(edges[:-1], edges[1:])],
                           "gain": [np.array([edges[-1] + k]) for k in range(self.m)],
                           "offset": np.array([width - 1])}
        if l not in self._projected:
            self._projected[l] = self._qr.project(self.y[l])
        return self._qr.R, self._index, *self._projected[l]

    def _secant(self, l, k):
        """Least-squares slope of output l against input k over the training samples."""
        return (float(np.polyfit(self.lin[k], self.y[l], 1)[0]) if np.ptp(self.lin[k]) > 0
                else 1.0)

    def fit_output(self, l, kinds):
        """Components and offset of output l for kinds[k]; returns (comps, offset, rms).

        The tall regression is reduced once per engine (:meth:`_reduced`);
        every call solves the small problem of its columns.
        """
        reduced = self._reduced(l)
        cols, layout = [], []
        lower, upper = [], []
        for k, kind in enumerate(kinds):
            if kind == "pi":
                X = self.phi[k] if reduced is None else reduced[0][:, reduced[1]["pi"][k]]
                n = X.shape[1]
                lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
                transform = None
                sec = (self._secant(l, k) if l == k else 0.0)
                if l == k and self.bounds == "nonnegative":
                    lo[:] = 0.0
                elif l == k and self.bounds == "monotone":
                    sign = 1.0 if sec >= 0 else -1.0
                    M = np.eye(n) - np.eye(n, k=-1)
                    transform = sign * M
                    X = X @ transform
                    lo[:] = MIN_SLOPE_FRACTION * abs(sec)
                if l == k and self.bounds != "monotone" and sec > 0 and self.r[k][0] == 0:
                    # the first play (threshold 0) is the initial slope of every loop: at 0
                    # the model holds its output while the input turns by 2 r_2 and no
                    # compensator inverts it (an outside stage's direct transfers came out
                    # at exactly 0 under the output map's nonnegative bounds)
                    lo[0] = max(lo[0], MIN_SLOPE_FRACTION * sec)
                cols.append(X)
                layout.append((k, "pi", n, transform))
                lower.append(lo)
                upper.append(hi)
            elif kind == "gain":
                cols.append(self.lin[k][:, None] if reduced is None
                            else reduced[0][:, reduced[1]["gain"][k]])
                layout.append((k, "gain", 1, None))
                lower.append([-np.inf])
                upper.append([np.inf])
        target = self.y[l]
        if self.offset:
            cols.append(np.ones((target.size, 1)) if reduced is None
                        else reduced[0][:, reduced[1]["offset"]])
            lower.append([-np.inf])
            upper.append([np.inf])
        if not cols:
            return [None] * self.m, float(np.mean(target)), float(np.std(target))
        lo, hi = np.concatenate(lower), np.concatenate(upper)
        # hi is +inf throughout; the problem reduced to its small triangular factor,
        # ||X c - t||^2 = ||R c - q||^2 + rho^2 (the tall matrix is never stacked)
        if reduced is None:
            R, c, rho = r_factor(cols, target)
        else:
            R, c, rho_s = r_factor(cols, reduced[2])
            rho = float(np.hypot(rho_s, reduced[3]))
        if np.all(np.isinf(lo)):
            coef, *_ = scipy.linalg.lstsq(R, c)
        else:
            coef = bounded_lstsq(R, c, lo)
        rms = float(np.sqrt(max(np.sum((R @ coef - c) ** 2) + rho ** 2, 0.0) / target.size))
        comps = [None] * self.m
        i = 0
        for k, kind, n, transform in layout:
            c = coef[i:i + n]
            i += n
            if kind == "pi":
                w = transform @ c if transform is not None else c
                comps[k] = PrandtlIshlinskii(self.r[k], w)
            else:
                comps[k] = float(c[0])
        offset = float(coef[-1]) if self.offset else 0.0
        return comps, offset, rms


class _ClosedForm:
    """Closed form of the Appendix per component (records exciting one input each)."""

    def __init__(self, records, splits, n_hysterons, partition):
        self.records, self.splits = records, splits
        self.m = records[0].u.shape[0]
        self.by_input = {}
        for j, rec in enumerate(records):
            spans = np.ptp(rec.u, axis=1)
            excited = np.flatnonzero(spans > 1e-9 * max(spans.max(), 1e-300))
            if excited.size != 1:
                raise IdentificationError(
                    f"{rec.source}: the closed form needs records that excite one input each, "
                    f"found {excited.size} excited inputs; use --method least-squares")
            self.by_input.setdefault(int(excited[0]), []).append(j)
        missing = [rec_name for k, rec_name in enumerate(records[0].input_names)
                   if k not in self.by_input]
        if missing:
            raise IdentificationError(f"inputs {missing}: no record excites them; the closed form "
                                      f"needs one record per input (Steps 1-4)")
        self.fits = {}
        p = records[0].y.shape[0]
        for k, js in self.by_input.items():
            j = js[0]
            rec, s = records[j], splits[j]
            for l in range(p):
                ident = ClosedFormPI(n_hysterons, partition)
                try:
                    ident.fit(rec.u[k], rec.y[l], branches=s.ascending(rec.u[k]))
                except IdentificationError as exc:
                    raise IdentificationError(f"{rec.source}: component ({records[0].output_names[l]}, "
                                              f"{rec.input_names[k]}): {exc}") from None
                self.fits[l, k] = ident
        self.thresholds = {k: self.fits[0, k].thresholds_ for k in self.by_input}

    def fit_output(self, l, kinds):
        comps = [None] * self.m
        offsets = []
        parts = []
        for k, kind in enumerate(kinds):
            for j in self.by_input[k]:
                rec, s = self.records[j], self.splits[j]
                if kind == "pi":
                    comps[k] = self.fits[l, k].model_
                elif kind == "gain":
                    uk, yk = rec.u[k][s.train], rec.y[l][s.train]
                    comps[k] = float(np.polyfit(uk, yk, 1)[0])
                break
        for j, (rec, s) in enumerate(zip(self.records, self.splits)):
            pred = np.zeros(rec.n_samples)
            for k, c in enumerate(comps):
                if isinstance(c, PrandtlIshlinskii):
                    pred += c.simulate(rec.u[k], _steady(c, rec.u[k]) if s.periodic else None)[0]
                elif c is not None:
                    pred += c * rec.u[k]
            parts.append(rec.y[l][s.train] - pred[s.train])
            offsets.append(parts[-1])
        res = np.concatenate(parts)
        offset = float(np.mean(res))
        return comps, offset, float(np.sqrt(np.mean((res - offset) ** 2)))


def _steady(pi, u):
    return pi.simulate(u)[1]


def _segment_basis(h, knots):
    """Columns whose coefficients are the segment slopes of a piecewise-linear map.

    ``sum_j a_j psi_j(h)`` is continuous, piecewise linear with knots ``z`` and
    slope ``a_j`` on segment j, equal to ``sum_j a_j psi_j(0)`` at 0.
    """
    z = np.asarray(knots, dtype=float)
    cols = [np.minimum(h, z[0])] if z.size else [h]
    for a, b in zip(z[:-1], z[1:]):
        cols.append(np.clip(h, a, b) - a)
    if z.size:
        cols.append(np.maximum(h - z[-1], 0.0))
    return np.column_stack(cols)


#: Largest condition number of the output map's segment basis solved through its normal
#: equations (their error grows as its square: 1e-16 * 1e5^2 = 1e-6 of the coefficients);
#: a worse one is factored by Householder QR.
SEGMENT_NORMAL_MAX_COND = 1e5


def _segment_factor(h, knots, y):
    """Triangular factor of the output map's regression ``[segment basis of h, 1] c ~ y``.

    Returns ``R`` (n, n), ``q`` (n,) and ``rho`` with ``||B c - y||^2 =
    ||R c - q||^2 + rho^2`` for every c, B = ``[_segment_basis(h, knots), 1]``
    (n = knots + 2 columns). A row of B with h in segment j is a constant row
    of that segment plus ``h - z_(j-1)`` in column j, so ``B^T B`` and ``B^T y``
    follow from five sums per segment (``np.bincount``, one pass over the
    samples, the tall basis never formed) and R is their Cholesky factor. The
    basis of a monotone map is well conditioned (about 2e3 on the realistic
    records: coefficients equal to a Householder QR's to 2e-11); above
    :data:`SEGMENT_NORMAL_MAX_COND`, or for a singular basis, the basis is
    formed and factored by :func:`r_factor`.
    """
    z = np.asarray(knots, dtype=float)
    nb = z.size + 1
    seg = np.searchsorted(z, h, side="right")
    v = h - np.r_[0.0, z][seg]            # the varying column's value (h itself below z_0)
    count = np.bincount(seg, minlength=nb).astype(float)
    s1, s2 = np.bincount(seg, v, nb), np.bincount(seg, v * v, nb)
    sy, svy = np.bincount(seg, y, nb), np.bincount(seg, v * y, nb)
    full = np.r_[z[:1], np.diff(z)]       # column i's value above its segment
    G, b = np.zeros((nb + 1, nb + 1)), np.zeros(nb + 1)
    for j in range(nb):
        a = np.zeros(nb + 1)
        a[:j], a[nb] = full[:j], 1.0
        G += count[j] * np.outer(a, a)
        G[j] += s1[j] * a
        G[:, j] += s1[j] * a
        G[j, j] += s2[j]
        b += sy[j] * a
        b[j] += svy[j]
    try:
        R = scipy.linalg.cholesky(G)
        ok = np.linalg.cond(R) <= SEGMENT_NORMAL_MAX_COND
    except np.linalg.LinAlgError:
        ok = False
    if not ok:
        return r_factor([_segment_basis(h, z), np.ones(h.size)], y)
    q = scipy.linalg.solve_triangular(R, b, trans="T")
    return R, q, float(np.sqrt(max(float(y @ y) - float(q @ q), 0.0)))


def _secant(h, y):
    """Slope [y unit / h unit] of the straight line fitted to (h, y) (centred sums)."""
    dh = h - np.mean(h)
    return float(dh @ (y - np.mean(y)) / (dh @ dh))


def _component_thresholds(model, k, default):
    for row in model.components:
        if isinstance(row[k], PrandtlIshlinskii):
            return row[k].thresholds
    return default


def _fit_output_maps(fit, bounds, n_knots=None, iterations=None):
    """Modified PI: the structure of ``fit`` plus a monotone output map per output.

    Alternating linear least squares (Kuhnen's modified PI, the operators
    fitted in turn): (a) given the map ``R(h) = c + S(h)``, the PI weights
    and an inner offset ``d`` by least squares on ``R^-1(y)`` (the direct
    transfers with non-negative weights, so that the PI draws the convex
    part of a branch and the map its saturation); (b) given
    ``h = Gamma(u) + d``, the segment slopes of ``S`` (knots at quantiles of
    h, slopes >= 1e-3 of the secant) and ``c`` by bounded least squares
    (:func:`hammerstein.identification.lsq.lstsq_bounded_below`). Starts from ``S`` = identity; keeps
    the iterate with the smallest training RMS error of ``y``.

    Returns
    -------
    (MultivariablePI, list of float)
        The model (map shifted so that ``y = S_m(Gamma(u)) + c_m`` with
        ``S_m(0) = 0``) and the training RMS per output.
    """
    n_knots = MAP_KNOTS if n_knots is None else n_knots
    iterations = MAP_ITERATIONS if iterations is None else iterations
    model, records, splits = fit.model, fit.records, fit.splits
    m, p = model.n_inputs, model.n_outputs
    r = [_component_thresholds(model, k, model.input_amplitude[k] * np.arange(3) / 3)
         for k in range(m)]
    engine = _LeastSquares(records, splits, r, bounds or "nonnegative")
    measured = engine.y.copy()
    grid, offsets, maps, rms_out = [], [], [], []
    for l in range(p):
        kinds = list(fit.structure[l])
        y = measured[l]
        target = y
        best = None
        for _ in range(iterations + 1):
            engine.set_target(l, target)
            comps, d, _ = engine.fit_output(l, kinds)
            h = np.full(y.size, d)
            for k, c in enumerate(comps):
                if isinstance(c, PrandtlIshlinskii):
                    h = h + engine.phi[k] @ c.weights
                elif c is not None:
                    h = h + c * engine.lin[k]
            if not np.ptp(h) > 0:
                break
            z = np.unique(np.quantile(h, np.arange(1, n_knots + 1) / (n_knots + 1)))
            # the data rows reduced to their factor first, the penalty rows stacked on it
            R, q, rho = _segment_factor(h, z, y)
            sec = max(_secant(h, y), 1e-12)
            lo = np.r_[np.full(z.size + 1, 1e-3 * sec), -np.inf]
            # smoothness prior: slope changes cost, so that S bends only where the PI cannot
            D = np.diff(np.eye(z.size + 1), axis=0)
            mu = MAP_SMOOTHING * np.sqrt(h.size) * np.ptp(h) / (z.size + 1)
            Ra = np.vstack([R, np.column_stack([mu * D, np.zeros(z.size)])])
            coef = lstsq_bounded_below(Ra, np.r_[q, np.zeros(z.size)], lo)
            err = float(np.sqrt((np.sum((R @ coef - q) ** 2) + rho ** 2) / y.size))
            smap = OutputMap(z, coef[:-1])
            c0 = float(coef[-1] + _segment_basis(np.zeros(1), z)[0] @ coef[:-1])   # R(0)
            if best is None or err < best[0]:
                best = (err, comps, d, smap, c0)
            target = smap.inverse(y - c0)
        engine.set_target(l, y)
        if best is None:
            raise IdentificationError(f"output {model.output_names[l]}: constant PI output, "
                                      f"no output map to fit")
        err, comps, d, smap, c0 = best
        grid.append(comps)
        maps.append(OutputMap(smap.knots - d, smap.slopes))
        offsets.append(c0 + float(smap.apply(np.array(d))))
        rms_out.append(err)
    return MultivariablePI(grid, model.input_names, model.output_names, model.input_amplitude,
                           output_offset=offsets, output_map=maps,
                           demagnetised=model.demagnetised,
                           demagnetised_centre=model.demagnetised_centre,
                           input_centre=model.input_centre), rms_out
