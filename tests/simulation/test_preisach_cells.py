"""The Preisach kernel's switching-cell steps against the plain loop over every hysteron.

:func:`hammerstein.simulation._preisach.ramp_preisach_kernel` steps only the
hysterons of the input's cell while the input stays in it; the reference here
steps every hysteron every sample (numpy, the definition of the module
docstring). States must be equal exactly, outputs to rounding, and a record
cut into chunks must give the whole record's numbers bit for bit.
"""

import numpy as np
import pytest

from hammerstein.simulation._preisach import ramp_preisach_kernel


def _reference(u, edges, row, col, mu, s):
    s = s.copy()
    y = np.empty(u.size)
    for t in range(u.size):
        rho = np.clip(2 * (u[t] - edges[:-1]) / (edges[1:] - edges[:-1]) - 1, -1, 1)
        s = np.maximum(rho[row], np.minimum(rho[col], s))
        y[t] = mu @ s
    return y, s


def _grid(n, seed):
    rng = np.random.default_rng(seed)
    edges = np.sort(rng.uniform(-10, 10, n + 1))
    row, col = np.array([(i, j) for i in range(n) for j in range(i + 1)]).T
    return rng, edges, row.astype(np.int64), col.astype(np.int64), rng.uniform(0, 1, row.size)


@pytest.mark.parametrize("n, seed", [(1, 0), (4, 1), (12, 2), (28, 3)])
def test_cell_steps_equal_every_hysteron_stepped(n, seed):
    """A decaying sine with jumps across several cells, below and above the grid."""
    rng, edges, row, col, mu = _grid(n, seed)
    t = np.arange(6000) * 5e-5
    u = 11 * np.sin(2 * np.pi * 4 * t) * np.exp(-t / 0.2) + 12 * (t > 0.25) - 30 * (t > 0.28)
    u = u + 3 * rng.standard_normal(t.size) * (rng.uniform(size=t.size) < 0.01)
    u[::997] = edges[rng.integers(0, n + 1, u[::997].size)]          # exactly on edges
    s0 = rng.uniform(-1, 1, row.size)
    want_y, want_s = _reference(u, edges, row, col, mu, s0)
    s, y = s0.copy(), np.empty(u.size)
    ramp_preisach_kernel(u, edges, row, col, mu, s, y)
    np.testing.assert_array_equal(s, want_s)
    np.testing.assert_allclose(y, want_y, rtol=0, atol=1e-12 * np.sum(mu))


@pytest.mark.parametrize("cut", [1, 2500, 5999])
def test_chunked_equals_whole_bit_for_bit(cut):
    rng, edges, row, col, mu = _grid(20, 7)
    u = 9 * np.sin(2 * np.pi * 3 * np.arange(6000) * 5e-5)
    s0 = rng.uniform(-1, 1, row.size)
    s, y = s0.copy(), np.empty(u.size)
    ramp_preisach_kernel(u, edges, row, col, mu, s, y)
    s2, ya, yb = s0.copy(), np.empty(cut), np.empty(u.size - cut)
    ramp_preisach_kernel(u[:cut], edges, row, col, mu, s2, ya)
    ramp_preisach_kernel(u[cut:], edges, row, col, mu, s2, yb)
    np.testing.assert_array_equal(np.concatenate([ya, yb]), y)
    np.testing.assert_array_equal(s2, s)


@pytest.mark.parametrize("n, seed", [(1, 0), (12, 5), (20, 6)])
def test_held_samples_repeat_the_output_of_the_record_without_them(n, seed):
    """A sample equal to the previous one moves no state: the output of a record with held
    (repeated) samples is the output of the record without the repeats, bit for bit, and the
    states those of the numpy loop."""
    rng, edges, row, col, mu = _grid(n, seed)
    base = 9 * np.sin(2 * np.pi * 3 * np.arange(3000) * 5e-5) + 0.3 * rng.standard_normal(3000)
    base[::211] = edges[rng.integers(0, n + 1, base[::211].size)]
    reps = rng.integers(1, 4, base.size) * (rng.uniform(size=base.size) < 0.3) + 1
    u = np.repeat(base, reps)
    s0 = rng.uniform(-1, 1, row.size)
    s, y = s0.copy(), np.empty(u.size)
    ramp_preisach_kernel(u, edges, row, col, mu, s, y)
    s1, y1 = s0.copy(), np.empty(base.size)
    ramp_preisach_kernel(base, edges, row, col, mu, s1, y1)
    np.testing.assert_array_equal(y, np.repeat(y1, reps))
    np.testing.assert_array_equal(s, s1)
    np.testing.assert_array_equal(s, _reference(u, edges, row, col, mu, s0)[1])


@pytest.mark.parametrize("n, seed", [(1, 0), (5, 1), (20, 2)])
def test_states_of_all_hysterons_equal_each_hysteron_stepped_alone(n, seed):
    """preisach_states: one pass over the record, the states of stepping hysteron by hysteron."""
    from hammerstein.simulation import preisach_states, preisach_steps

    rng, edges, row, col, _ = _grid(n, seed)
    t = np.arange(3000) * 1e-4
    u = 11 * np.sin(2 * np.pi * 5 * t) * np.exp(-t / 0.15) + 0.2 * rng.standard_normal(t.size)
    u[::401] = edges[rng.integers(0, n + 1, u[::401].size)]          # exactly on edges
    s0 = rng.choice([-1.0, 1.0, 0.3], row.size)
    states, final = preisach_states(u, edges, row, col, s0)
    expected = np.empty((u.size, row.size))
    for q in range(row.size):       # the naive loop: one hysteron, weight 1, its output = its state
        expected[:, q], fq = preisach_steps(u, edges, row[q:q + 1], col[q:q + 1], np.ones(1),
                                            s0[q:q + 1])
        assert final[q] == fq[0]
    assert np.array_equal(states, expected)
    assert np.array_equal(states, _reference_states(u, edges, row, col, s0))
    assert np.array_equal(final, states[-1])


def _reference_states(u, edges, row, col, s):
    out = np.empty((u.size, s.size))
    for t in range(u.size):
        rho = np.clip(2 * (u[t] - edges[:-1]) / (edges[1:] - edges[:-1]) - 1, -1, 1)
        s = np.maximum(rho[row], np.minimum(rho[col], s))
        out[t] = s
    return out


@pytest.mark.parametrize("args, match", [
    ((np.zeros(3), np.array([1.0, 0.0]), [0], [0], [0.0]), "increasing"),
    ((np.zeros(3), np.array([0.0, 1.0]), [1], [0], [0.0]), "col <= row"),
    ((np.zeros(3), np.array([0.0, 1.0]), [0], [0], [0.0, 1.0]), "one shape"),
    ((np.array([0.0, np.nan]), np.array([0.0, 1.0]), [0], [0], [0.0]), "finite"),
])
def test_states_wrapper_names_bad_arguments(args, match):
    from hammerstein.simulation import preisach_states

    with pytest.raises(ValueError, match=match):
        preisach_states(*args)
