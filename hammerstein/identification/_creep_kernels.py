"""Compiled kernels of the creep identification: the lags of staircases, creep and its inverse.

The private implementation of
:mod:`hammerstein.identification.creep_identification` (the kernels work on
arrays only; their wrappers here and there validate and lay out the
arrays). The creep model is :class:`hammerstein.models.creep.Creep`: a
direct gain ``d`` plus ``K`` first-order lags with zero-order-hold poles
``a_k = exp(-T / tau_k)``,

``y[t] = d h[t] + sum_k w_k s_k[t]``,  ``s_k[t + 1] = a_k s_k[t] + (1 - a_k) h[t]``,

stepped lag by lag (K products per sample, where the dense state space
takes K^2), from rest. Its inverse ``h = (y - sum_k w_k s_k) / d`` drives the
lags by the recovered input, stable when the creep is minimum phase
(:func:`hammerstein.models.creep.minimum_phase_margin`).
"""

from __future__ import annotations

import numpy as np

import hammerstein.simulation  # noqa: F401  (sets numba's cache directory before numba loads)
from numba import njit

__all__ = ["lag_kernel", "creep_kernel", "creep_inverse_kernel", "creep_output", "lag_states"]


@njit(cache=True)
def lag_kernel(h, a, stride, x):
    """Lag states of every row of ``h`` at the samples 0, stride, 2 stride...; ``x`` out.

    ``h`` (n_series, N), ``a`` (K,), ``x`` (n_series, K, ceil(N / stride)): the
    state before the sample, from rest, ``s_k <- a_k s_k + (1 - a_k) h``.
    """
    K = a.size
    b = 1.0 - a
    s = np.empty(K)
    for i in range(h.shape[0]):
        s[:] = 0.0
        r, nxt = 0, 0
        for t in range(h.shape[1]):
            if t == nxt:
                for k in range(K):
                    x[i, k, r] = s[k]
                r += 1
                nxt += stride
            v = h[i, t]
            for k in range(K):
                s[k] = a[k] * s[k] + b[k] * v


@njit(cache=True)
def creep_kernel(h, a, w, d, y):
    """One output's creep ``y = d h + sum_k w_k s_k`` (lag states before the sample), from rest."""
    K = a.size
    b = 1.0 - a
    s = np.zeros(K)
    for t in range(h.size):
        v = h[t]
        acc = 0.0
        for k in range(K):
            acc += w[k] * s[k]
        y[t] = acc + d * v
        for k in range(K):
            s[k] = a[k] * s[k] + b[k] * v


@njit(cache=True)
def creep_inverse_kernel(y, a, w, d, v):
    """One output's creep removed: ``v = (y - sum_k w_k s_k) / d``, lags driven by v, from rest."""
    K = a.size
    b = 1.0 - a
    s = np.zeros(K)
    for t in range(y.size):
        acc = 0.0
        for k in range(K):
            acc += w[k] * s[k]
        e = (y[t] - acc) / d
        v[t] = e
        for k in range(K):
            s[k] = a[k] * s[k] + b[k] * e


def creep_output(creep, h, T, inverse=False):
    """One output's creep on ``h`` (n_samples,) from rest: ``c(h)``, or ``c^-1(h)`` if ``inverse``.

    The ZOH lags of :meth:`hammerstein.models.creep.Creep.simulate` (the same
    numbers to rounding), stepped one by one by a compiled kernel instead of
    through the dense state space (K instead of K^2 products per sample).
    """
    h = np.ascontiguousarray(h, dtype=float)
    a = np.exp(-float(T) / creep.time_constants)
    y = np.empty(h.size)
    kernel = creep_inverse_kernel if inverse else creep_kernel
    kernel(h, a, np.ascontiguousarray(creep.weights, dtype=float), float(creep.instantaneous), y)
    return y


def lag_states(h, tau, T, stride=1):
    """Lag states x_k of each row of ``h`` at every ``stride``-th sample, from rest.

    ``x_k[t] = a_k x_k[t - 1] + (1 - a_k) h[t - 1]``, ``a_k = exp(-T / tau_k)``
    (the lags of :class:`~hammerstein.models.creep.Creep`, the state before
    the sample; the same two products and one sum per sample as the diagonal
    state space), all lags of all rows in one pass of a compiled kernel over
    the samples, kept only at the samples ``0, stride, 2 stride...``.

    Returns
    -------
    numpy.ndarray, shape (n_series, K, ceil(N / stride))
    """
    h = np.ascontiguousarray(np.atleast_2d(h), dtype=float)
    a = np.exp(-T / np.asarray(tau, dtype=float))
    x = np.empty((h.shape[0], a.size, -(-h.shape[1] // stride)))
    lag_kernel(h, a, int(stride), x)
    return x
