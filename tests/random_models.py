"""Random classical-PI models for the per-axis inverse's tests (test helper)."""

import numpy as np

from hammerstein import MultivariablePI, PrandtlIshlinskii


def random_direct_model(seed, offset):
    """A 2x2 classical PI with direct transfers only, drawn from ``seed``: 3-8 plays each,
    a first threshold of 0.05-1.5 V, rising loops (every cumulative weight > 0), a
    demagnetising cycle of 5-20 V and output offsets within +-``offset`` µm."""
    rng = np.random.default_rng(seed)
    direct = []
    for _ in range(2):
        n = int(rng.integers(3, 9))
        r = np.sort(np.concatenate([[rng.uniform(0.05, 1.5)], rng.uniform(0.1, 9.0, n - 1)]))
        w = rng.uniform(0.2, 2, n) * np.concatenate([[1.0], rng.choice([-0.3, 0.5, 1.0], n - 1)])
        direct.append(PrandtlIshlinskii(r, w if np.all(np.cumsum(w) > 0) else np.abs(w)))
    return MultivariablePI([[direct[0], None], [None, direct[1]]], input_amplitude=[10.0, 10.0],
                           demagnetised=[rng.uniform(5, 20)] * 2,
                           output_offset=rng.uniform(-offset, offset, 2))
