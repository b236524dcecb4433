"""Where the largest recorded loop closes: the inputs at which no hysteron switches any more.

A Preisach density that ends inside the recorded range (a material driven into saturation:
beyond some field every domain has switched, and the ascending and descending branches of
the major loop run together up to the tip) leaves the major loop closed over the ends of
the range. The hysterons of a switching grid placed there never switch within the records;
their cells are resolution taken from the open part of the loop, and the density's end falls
inside a cell, which the fit's smoothing penalty blurs over it. :func:`loop_closure` finds
the closed ends from the records (the gap between the two branches of the largest loop,
small and flat from the end of the density to the tip), and :func:`closure_grid_edges`
moves a cell edge of the switching grid to where the loop closes and spreads the cells
beyond evenly (Mayergoyz [1]_, ch. 1: the Preisach weight function vanishes outside the
triangle of the switching fields; its support is what the records must resolve).

Measured on the fifteen Preisach-type actuators of ``benchmarks/route_defaults.py`` (two
seeds; relay densities that end at +-10.5 V, records to +-20 V): the loops are found closed
beyond 10.3-10.4 V on every input, and the grid with an edge there took the worst raster of
seed 2026's ten from 3.55 to 1.71 % of half its size; an edge put 1 V outside the density's
end (11.5 V) made two members' circles and rasters worse than without any; a grid refined
over the open part (24 centred cells within the closure instead of the grid's own edges)
lost on the 15 µm circles of four members (``benchmarks/results/route-defaults.md``, stop
89). On fourteen of the fifteen generalised-PI-type actuators of the same benchmark and on a
real stack's record (150 V, 1 Hz) the loop stays open to its tips: the grid is the centred
one. The fifteenth (its y loop thins to nothing below -15 V) is found closed there once the
creep is removed from its records.

References
----------
.. [1] I. D. Mayergoyz, *Mathematical Models of Hysteresis and Their Applications*,
   Elsevier, 2003, ch. 1.
"""

from __future__ import annotations

import numpy as np

from hammerstein.identification._record_split import reversal_points

__all__ = ["loop_closure", "input_closure", "closure_grid_edges", "CLOSURE_BINS", "CLOSED_GAP", "CLOSED_SLOPE",
           "CLOSED_WIDTH", "SLOPE_BINS", "BIN_SAMPLES", "MIN_BINS", "TIP"]

#: Bins of the input range in which the branches of the largest loop are averaged.
CLOSURE_BINS = 400
#: Samples of the largest loop's branches per bin, on average (fewer bins on a coarse record).
BIN_SAMPLES = 8
#: ... but never fewer bins than this.
MIN_BINS = 40
#: A closed end's gap between the branches is at most this fraction of the loop's widest gap
#: (the creep's lag leaves a few % there at 1 Hz: 1-6 % on the benchmark's actuators).
CLOSED_GAP = 0.1
#: ... and flat: its slope against the input at most this, in widest gaps per input span
#: (noise and the creep's lag: up to 0.6 on the benchmark's records; inside the open loop near its
#: end: 3 or more; a classical PI's loop near its tips is open over more than CLOSED_WIDTH).
CLOSED_SLOPE = 1.0
#: A closed end counts when it spans at least this fraction of the input range (the tip
#: excluded), so that the last samples before a reversal, where every loop closes, are none.
CLOSED_WIDTH = 0.1
#: The gap's slope at a bin is taken against the bin this many further out (0.5 V of a +-20 V
#: record at :data:`CLOSURE_BINS`).
SLOPE_BINS = 5
#: The fraction of the range at each tip left out of the search: every loop closes at its tip.
TIP = 0.03


def _full_branches(u):
    """Samples of the branches (between reversals) that run from one end of ``u``'s range to
    the other (within 2 % of the span): the largest loop's; and whether each sample's branch
    rises. Reversals as the record splitter finds them
    (:func:`~hammerstein.identification._record_split.reversal_points`: a measured input's
    noise wiggles within its dead band are none)."""
    lo, hi = float(u.min()), float(u.max())
    span = hi - lo
    bounds = [0] + reversal_points(u) + [u.size - 1]
    sel = np.zeros(u.size, dtype=bool)
    rising = np.zeros(u.size, dtype=bool)
    for a, b in zip(bounds[:-1], bounds[1:]):
        seg = u[a:b + 1]
        if seg.min() <= lo + 0.02 * span and seg.max() >= hi - 0.02 * span:
            sel[a:b + 1] = True
            rising[a:b + 1] = u[b] > u[a]
    return sel, rising


def loop_closure(u, y, bins=CLOSURE_BINS):
    """The inputs beyond which the largest recorded loop is closed, on each side.

    The samples of the branches that run across the whole input range (the largest loop)
    are averaged per input bin, rising and falling apart; their difference is the loop's
    gap ``g(u)``. From each tip inwards (the outermost :data:`TIP` of the range left out),
    the end is closed as long as ``g <= CLOSED_GAP * max g`` and the slope of ``g`` against
    the bin :data:`SLOPE_BINS` further out is at most ``CLOSED_SLOPE * max g / span``; a
    closed run shorter than :data:`CLOSED_WIDTH` of the range is no closure. The closure is
    found within a bin or two inside the end of the density (0.1-0.2 V of a +-20 V record).

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        One input of a hysteresis record [V] (a decreasing-amplitude sine whose first level
        spans the range, as ``hammerstein excitation`` writes).
    y : array_like, shape (n_samples,)
        Its direct output [µm].
    bins : int
        Bins of the input range, at most (fewer when the largest loop's branches hold fewer
        than :data:`BIN_SAMPLES` samples per bin, at least :data:`MIN_BINS`).

    Returns
    -------
    low, high : float or None
        The input [V] below which (``low``) and above which (``high``) the loop is closed,
        at a bin edge; None on a side where it stays open to the tip, and both None when no
        branch spans the range.

    Examples
    --------
    A loop whose hysterons switch within +-5 V, driven to +-10 V:

    >>> import numpy as np
    >>> t = np.linspace(0.0, 2.0, 40001)
    >>> u = 10.0 * np.sin(2 * np.pi * t)
    >>> rising = np.r_[np.diff(u) > 0, False]
    >>> y = 2.0 * u + np.where(rising, -1.0, 1.0) * np.clip(5.0 - np.abs(u), 0.0, None)
    >>> [round(v, 2) for v in loop_closure(u, y)]      # within a bin (0.05 V) of +-5 V
    [-4.95, 4.95]
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if u.size < 4 or not np.ptp(u) > 0:
        return None, None
    sel, rising = _full_branches(u)
    if not sel.any():
        return None, None
    lo, hi = float(u.min()), float(u.max())
    # a record sampled coarsely has fewer bins (about BIN_SAMPLES samples of the largest
    # loop's branches each), so that few are empty
    bins = int(np.clip(np.count_nonzero(sel) // BIN_SAMPLES, MIN_BINS, bins))
    edges = np.linspace(lo, hi, bins + 1)
    centres = 0.5 * (edges[1:] + edges[:-1])

    def branch(mask):
        idx = np.clip(np.digitize(u[mask], edges) - 1, 0, bins - 1)
        n = np.bincount(idx, minlength=bins)
        mean = np.bincount(idx, y[mask], minlength=bins) / np.maximum(n, 1)
        # an empty bin between two seen ones: the branch interpolated across it
        seen = n > 0
        inside = (centres >= centres[seen].min()) & (centres <= centres[seen].max())
        return np.where(inside, np.interp(centres, centres[seen], mean[seen]), np.nan)

    gap = np.abs(branch(sel & ~rising) - branch(sel & rising))
    seen = np.isfinite(gap)
    if not seen.any() or not np.nanmax(gap) > 0:
        return None, None
    widest = float(np.nanmax(gap))
    peak = int(np.nanargmax(gap))
    h = (hi - lo) / bins
    small = seen & (gap <= CLOSED_GAP * widest)
    tip = int(np.ceil(TIP * bins))
    out = []
    for outward in (range(peak, -1, -1), range(peak, bins)):
        # the slope against the bin SLOPE_BINS further out (towards the tip): a bin whose
        # inner side is still open is not taken for closed by a centred difference, and the
        # noise of two bins' means is spread over SLOPE_BINS of them
        further = np.roll(gap, SLOPE_BINS if outward.step < 0 else -SLOPE_BINS)
        slope = np.abs(gap - further) / (SLOPE_BINS * h) * (hi - lo) / widest
        closed = small & np.isfinite(further) & (slope <= CLOSED_SLOPE)
        inward = list(outward)[::-1][tip:]
        run = next((i for i, b in enumerate(inward) if not closed[b]), len(inward))
        if run >= CLOSED_WIDTH * bins and run < len(inward):
            out.append(float(edges[inward[run - 1] + (1 if outward.step < 0 else 0)]))
        else:
            out.append(None)
    return out[0], out[1]


def input_closure(records, k):
    """:func:`loop_closure` of input k on its direct output, in the record that excites k most.

    Parameters
    ----------
    records : sequence of MultiRecord
        Records whose inputs ``u`` have shape (m, n_samples) [V] and outputs ``y`` shape
        (p, n_samples) [µm]; each excites the input whose span is the largest.
    k : int
        The input (and its direct output, ``y[k]``).

    Returns
    -------
    low, high : float or None
        As :func:`loop_closure`; both None when the outputs do not pair with the inputs
        (``p != m``) or no record excites input k.
    """
    if records[0].y.shape[0] != records[0].u.shape[0]:
        return None, None
    own = [r for r in records if int(np.argmax(np.ptp(r.u, axis=1))) == k]
    if not own:
        return None, None
    rec = max(own, key=lambda r: float(np.ptp(r.u[k])))
    return loop_closure(rec.u[k], rec.y[k])


def closure_grid_edges(low, high, n_levels, closure, grid):
    """A switching grid's edges with an edge where the largest loop closes.

    The grid's own edges in the open part are kept (the centre's resolution, where a drive's
    small loops are, does not change), less one closer than half its cell to a closure; the
    closure becomes an edge, and the cells left over are spread evenly over each closed end
    (in proportion to its length, at least one each), where no hysteron switches.

    Parameters
    ----------
    low, high : float
        The grid's ends [V], ``low < high``.
    n_levels : int
        Cells in all.
    closure : tuple of (float or None)
        :func:`loop_closure`'s ``(low, high)`` [V]; None on an open side.
    grid : callable
        ``grid(low, high, n_levels)``: the grid's edges without a closure (``grid_edges``
        with the grid's shape).

    Returns
    -------
    numpy.ndarray, shape (n_levels + 1,)
        Increasing edges [V], the first ``low`` and the last ``high``; ``grid(low, high,
        n_levels)`` when neither side closes inside ``(low, high)`` or no cell is left for a
        closed end.

    Examples
    --------
    >>> edges = closure_grid_edges(-12.0, 12.0, 12, (-5.5, 5.5),
    ...                            lambda a, b, n: np.linspace(a, b, n + 1))
    >>> np.round(edges, 2).tolist()
    [-12.0, -9.83, -7.67, -5.5, -4.0, -2.0, 0.0, 2.0, 4.0, 5.5, 7.67, 9.83, 12.0]
    """
    a = closure[0] if closure[0] is not None and low < closure[0] < high else None
    b = closure[1] if closure[1] is not None and low < closure[1] < high else None
    if a is not None and b is not None and not a < b:
        a = b = None
    full = grid(low, high, n_levels)
    if a is None and b is None:
        return full
    width = np.gradient(full)
    keep = (full > (-np.inf if a is None else a + 0.5 * width)) & \
        (full < (np.inf if b is None else b - 0.5 * width))
    mid = np.concatenate([[] if a is None else [a], full[keep], [] if b is None else [b]])
    left = n_levels - (mid.size - 1)
    if left < (a is not None) + (b is not None):
        return full
    if a is None or b is None:
        n_lo = 0 if a is None else left
    else:
        n_lo = int(np.clip(round(left * (a - low) / (a - low + high - b)), 1, left - 1))
    parts = ([np.linspace(low, a, n_lo + 1)[:-1]] if a is not None else []) + [mid] + \
        ([np.linspace(b, high, left - n_lo + 1)[1:]] if b is not None else [])
    return np.concatenate(parts)
