"""Monte-Carlo studies: the order-independent quantiles of per-case metrics, the result.

:class:`QuantileAccumulator` reduces the chunks' metric values to quantiles
(exact up to :data:`hammerstein.scenario.montecarlo.EXACT_VALUES` values,
else log-spaced histograms of :data:`BINS_PER_DECADE` bins per decade,
relative error <= 0.3 %) in any order of arrival; :class:`MonteCarloResult`
holds a study's quantiles and writes its metric rows. Re-exported by
:mod:`hammerstein.scenario.montecarlo`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hammerstein.signals.metrics import UNITS
from hammerstein.scenario.montecarlo_spec import MonteCarloStudy


__all__ = ["QuantileAccumulator", "MonteCarloResult", "QUANTILES", "EXACT_VALUES",
           "BINS_PER_DECADE"]

#: Quantiles reported (with the maximum).
QUANTILES = (0.50, 0.95, 0.99)
#: Exact metric values kept by default (beyond: histogram quantiles).
EXACT_VALUES = 2_000_000
#: Histogram resolution (log-spaced bins per decade) and range [10**LO, 10**HI].
BINS_PER_DECADE = 400
_LO, _HI = -9, 6


def _diverged(values):
    """Diverged runs per frequency of a chunk's values (any metric not finite)."""
    return np.sum(~np.isfinite(values).all(axis=2), axis=0)


class QuantileAccumulator:
    """Order-independent reduction of per-case metric values to quantiles.

    Parameters
    ----------
    cases : int
        Number of cases that will be added.
    shape : tuple of int
        ``(n_frequencies, n_metrics)`` of one case's values.
    exact_limit : int, optional
        Keep the exact values when ``cases * prod(shape)`` is at most this
        (default :data:`EXACT_VALUES`).

    Notes
    -----
    Memory: ``prod(shape) * (n_bins + 1)`` counters (``n_bins`` =
    ``BINS_PER_DECADE * 15`` log-spaced bins on ``[1e-9, 1e6]``, plus
    under/overflow), independent of ``cases``, and the exact values when
    kept. Adding chunks in any order gives identical results (integer counts,
    maxima, values stored by case index).

    Examples
    --------
    The P50 of 1, 2, ..., 100 is 50 (inverted CDF: the smallest value with at
    least half of the values at or below it); the histogram gives it within
    its bin width.

    >>> import numpy as np
    >>> from hammerstein.scenario.montecarlo import QuantileAccumulator
    >>> v = np.arange(1.0, 101.0).reshape(100, 1, 1)
    >>> exact, hist = QuantileAccumulator(100, (1, 1)), QuantileAccumulator(100, (1, 1), exact_limit=0)
    >>> for start in (50, 0):                      # chunks in any order
    ...     exact.add(start, v[start:start + 50]); hist.add(start, v[start:start + 50])
    >>> exact.quantiles()[:, 0, 0].tolist()        # P50, P95, P99, max
    [50.0, 95.0, 99.0, 100.0]
    >>> bool(abs(hist.quantiles()[0, 0, 0] / 50.0 - 1) < 0.003)
    True
    """

    def __init__(self, cases, shape, exact_limit=None):
        exact_limit = EXACT_VALUES if exact_limit is None else exact_limit
        self.cases, self.shape = cases, tuple(shape)
        self.n_bins = BINS_PER_DECADE * (_HI - _LO)
        self.counts = np.zeros(self.shape + (self.n_bins + 2,), dtype=np.int64)
        self.maximum = np.full(self.shape, -np.inf)
        self.count = 0
        self.values = (np.full((cases,) + self.shape, np.nan)
                       if cases * int(np.prod(self.shape)) <= exact_limit else None)

    @staticmethod
    def bins(values):
        """Histogram bin of every value (0: underflow, ``n_bins + 1``: overflow and inf).

        Parameters
        ----------
        values : numpy.ndarray
            Non-negative metric values (any shape).

        Returns
        -------
        numpy.ndarray of int16, same shape
            Bin ``k`` (1 <= k <= n_bins) holds
            ``[10**(LO + (k-1)/BPD), 10**(LO + k/BPD))``.
        """
        n_bins = BINS_PER_DECADE * (_HI - _LO)
        with np.errstate(divide="ignore", invalid="ignore"):
            b = np.floor((np.log10(values) - _LO) * BINS_PER_DECADE)
        b = np.where(values <= 10.0 ** _LO, -1, b)
        b = np.where(~np.isfinite(b) & (values > 0), n_bins, b)
        return (np.clip(b, -1, n_bins) + 1).astype(np.int16)

    def add(self, start, values):
        """Add the values of cases ``start .. start + len(values) - 1``.

        Parameters
        ----------
        start : int
        values : numpy.ndarray, shape (n_cases, n_frequencies, n_metrics)
        """
        self.add_bins(self.bins(values), values.max(axis=0))
        if self.values is not None:
            self.values[start:start + values.shape[0]] = values

    def add_bins(self, bins, maximum):
        """Add cases given by their histogram bins only (exact values not kept).

        Parameters
        ----------
        bins : numpy.ndarray of int, shape (n_cases, n_frequencies, n_metrics)
            From :meth:`bins`.
        maximum : numpy.ndarray, shape (n_frequencies, n_metrics)
            Their maximum.
        """
        width = self.n_bins + 2
        flat = np.arange(int(np.prod(self.shape)), dtype=np.int64).reshape(self.shape) * width
        idx = (flat[None] + bins).ravel()
        self.counts += np.bincount(idx, minlength=self.counts.size).reshape(self.counts.shape)
        self.maximum = np.maximum(self.maximum, maximum)
        self.count += bins.shape[0]

    @property
    def exact(self):
        """Whether the quantiles are exact (all values kept)."""
        return self.values is not None

    def quantiles(self, q=QUANTILES):
        """Quantiles ``q`` and the maximum of every (frequency, metric).

        Parameters
        ----------
        q : sequence of float
            In [0, 1].

        Returns
        -------
        numpy.ndarray, shape (len(q) + 1, n_frequencies, n_metrics)
            Exact quantiles (inverted CDF: the smallest value with at least
            ``q n`` values at or below it) when :attr:`exact`, else the
            geometric centre of the histogram bin holding that value (0 for
            the underflow bin, inf for the overflow bin); last: the maximum.
        """
        out = np.empty((len(q) + 1,) + self.shape)
        if self.exact:
            out[:-1] = np.quantile(self.values[:self.count], q, axis=0, method="inverted_cdf")
        else:
            cum = np.cumsum(self.counts, axis=-1)
            edges = _LO + (np.arange(self.n_bins) + 0.5) / BINS_PER_DECADE
            centres = np.concatenate([[0.0], 10.0 ** edges, [np.inf]])
            for a, qq in enumerate(q):
                k = np.maximum(np.ceil(qq * self.count), 1)
                idx = np.argmax(cum >= k, axis=-1)
                out[a] = centres[idx]
        out[-1] = self.maximum
        return out


@dataclass
class MonteCarloResult:
    """Quantiles of one study.

    Parameters
    ----------
    study : MonteCarloStudy
    quantiles : numpy.ndarray, shape (4, n_frequencies, n_metrics)
        P50, P95, P99, max [µm].
    diverged : numpy.ndarray, shape (n_frequencies,)
        Cases whose compensator diverged (or whose errors are not finite).
    exact : bool
        Exact quantiles (else histogram, relative error <= 0.3 %).
    values : numpy.ndarray or None, shape (cases, n_frequencies, n_metrics)
        Every case's metrics when kept (:data:`EXACT_VALUES`).
    warnings : list of str
    """

    study: MonteCarloStudy
    quantiles: np.ndarray
    diverged: np.ndarray
    exact: bool
    values: np.ndarray | None = None
    warnings: list = field(default_factory=list)

    @property
    def name(self):
        """The sweep's name."""
        return self.study.name

    @property
    def metrics(self):
        """Rows ``{channel, metric, value, unit}``: ``<metric>_p50/_p95/_p99/_max@<f>Hz``.

        Returns
        -------
        list of dict
        """
        rows = []
        for j, f in enumerate(self.study.frequencies):
            for c, (ch, met) in enumerate(self.study.columns):
                for a, tag in enumerate(("p50", "p95", "p99", "max")):
                    rows.append({"channel": ch, "metric": f"{met}_{tag}_at_{f:g}Hz",
                                 "value": float(self.quantiles[a, j, c]), "unit": UNITS.get(met, "µm")})
            rows.append({"channel": "-", "metric": f"diverged_cases_at_{f:g}Hz",
                         "value": float(self.diverged[j]), "unit": "cases"})
        return rows
