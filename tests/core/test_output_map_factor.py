"""The output map's regression factored from per-segment sums equals the formed basis' QR.

Reference: the segment basis formed sample by sample (``_segment_basis``)
and factored by Householder QR (``r_factor``); both give the same
least-squares function ``||R c - q||^2 + rho^2`` of the coefficients, hence
the same minimiser.
"""

import numpy as np
import pytest

from hammerstein.identification._record_regression import (_secant, _segment_basis,
                                                           _segment_factor)
from hammerstein.identification.lsq import r_factor


def _loop(n, rng):
    t = np.linspace(0, 6 * np.pi, n)
    h = 40 * np.sin(t) * np.exp(-t / 20) + rng.normal(scale=0.2, size=n)
    y = np.tanh(h / 30) * 45 + 0.1 * h + rng.normal(scale=0.05, size=n)
    return h, y


@pytest.mark.parametrize("n_knots", [1, 4, 16])
def test_same_least_squares_function_as_the_formed_basis(n_knots):
    rng = np.random.default_rng(n_knots)
    h, y = _loop(20000, rng)
    z = np.unique(np.quantile(h, np.arange(1, n_knots + 1) / (n_knots + 1)))
    R, q, rho = _segment_factor(h, z, y)
    B = np.column_stack([_segment_basis(h, z), np.ones(h.size)])
    R0, q0, rho0 = r_factor(B, y)
    assert R.shape == (z.size + 2, z.size + 2)
    for _ in range(3):
        c = rng.normal(size=z.size + 2)
        assert np.isclose(np.sum((R @ c - q) ** 2) + rho ** 2, np.sum((B @ c - y) ** 2),
                          rtol=1e-9)
    x, x0 = np.linalg.solve(R, q), np.linalg.solve(R0, q0)
    assert np.allclose(x, x0, rtol=0, atol=1e-8 * np.abs(x0).max())
    assert np.isclose(rho, rho0, rtol=1e-8)


def test_empty_segment_falls_back_to_the_formed_basis():
    rng = np.random.default_rng(3)
    h, y = _loop(5000, rng)
    z = np.array([-10.0, 0.0, 10.0, h.max() + 5.0])    # no sample above the last knot
    R, q, rho = _segment_factor(h, z, y)
    R0, q0, rho0 = r_factor([_segment_basis(h, z), np.ones(h.size)], y)
    assert np.array_equal(R, R0) and np.array_equal(q, q0) and rho == rho0


def test_secant_is_the_least_squares_line_slope():
    rng = np.random.default_rng(4)
    h = rng.normal(size=1000) * 7 + 3
    y = 2.5 * h - 1 + rng.normal(size=1000)
    assert np.isclose(_secant(h, y), np.polyfit(h, y, 1)[0], rtol=1e-12)
