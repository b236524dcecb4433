"""TallQR (blocked Householder QR kept for many targets) against one dense QR.

The reference is numpy's thin QR of the whole matrix: R agrees up to the
signs of its rows, Q^T b up to the same signs, and the residual norm rho
is the distance of b from the columns' span, computed here by a dense
least-squares solve.
"""

import numpy as np
import pytest

from hammerstein.identification import lsq
from hammerstein.identification.lsq import TallQR


def _reference(A, b):
    Q = np.linalg.qr(A)[0]
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    return Q.T @ b, float(np.linalg.norm(A @ x - b))


@pytest.mark.parametrize("N, n, chunk", [
    (50, 3, 4096),          # one block
    (9000, 5, 4096),        # three blocks, the last one short
    (4100, 7, 4096),        # a last block of 4 rows (< n): merged into the one before
    (700, 40, 64),          # blocks of 2 n rows (the chunk smaller than that)
    (40, 40, 4096),         # square
])
def test_projection_equals_a_dense_qr(monkeypatch, N, n, chunk):
    monkeypatch.setattr(lsq, "CHUNK_ROWS", chunk)
    rng = np.random.default_rng(N + n)
    A = rng.normal(size=(N, n)) @ np.diag(np.logspace(0, 3, n))
    qr = TallQR(A)
    R0 = np.linalg.qr(A, mode="r")
    signs = np.sign(np.diag(qr.R)) * np.sign(np.diag(R0))
    assert np.allclose(signs[:, None] * qr.R, R0, rtol=0, atol=1e-10 * np.abs(R0).max())
    assert np.allclose(np.tril(qr.R, -1), 0.0)
    for _ in range(3):                       # several targets on the same factor
        b = rng.normal(size=N) + A @ rng.normal(size=n)
        c0, rho0 = _reference(A, b)
        c, rho = qr.project(b)
        # R = S R0 with S = diag(signs), so Q = Q0 S and Q^T b = S Q0^T b
        assert np.allclose(c, signs * c0, rtol=0, atol=1e-9 * np.abs(c0).max())
        # the least-squares identity holds for any x
        x = rng.normal(size=n)
        lhs = np.sum((A @ x - b) ** 2)
        assert np.isclose(np.sum((qr.R @ x - c) ** 2) + rho ** 2, lhs, rtol=1e-10)
        assert np.isclose(rho, rho0, rtol=1e-8, atol=1e-12 * np.linalg.norm(b))
        # the minimiser of the small problem is the tall one's
        assert np.allclose(np.linalg.solve(qr.R, c), np.linalg.lstsq(A, b, rcond=None)[0],
                           rtol=1e-8, atol=1e-10)


def test_column_blocks_give_the_stacked_matrix_factor():
    rng = np.random.default_rng(1)
    a, b1 = rng.normal(size=(5000, 4)), rng.normal(size=5000)
    ones = np.ones(5000)
    whole, parts = TallQR(np.column_stack([a, b1, ones])), TallQR([a, b1, ones])
    y = rng.normal(size=5000)
    assert np.array_equal(whole.R, parts.R)
    assert all(np.array_equal(u, v) for u, v in zip(whole.project(y), parts.project(y)))


@pytest.mark.parametrize("shape, target, match", [
    ((3, 5), 3, "at least as many rows as columns"),
    ((30, 2), 29, r"b: expected shape \(30,\)"),
])
def test_bad_shapes_are_named(shape, target, match):
    with pytest.raises(ValueError, match=match):
        TallQR(np.ones(shape)).project(np.ones(target))
