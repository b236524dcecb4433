"""Where the largest recorded loop closes, and the Preisach switching grid built on it.

Expectations from closed forms (a loop whose branches are ``2 u -+ (c - |u|)`` inside
``|u| < c`` runs closed beyond it), from the construction of a Preisach model (no hysteron
switches outside its grid, so a model on +-5 V driven to +-10 V has its loop closed beyond
+-5 V, and one driven inside its grid has none) and from a classical PI, whose loop is open
up to within twice its largest threshold of each tip.
"""

import numpy as np
import pytest

from hammerstein.identification.loop_closure import closure_grid_edges, loop_closure
from hammerstein.identification.preisach_identification import PreisachIdentifier, grid_edges
from hammerstein.io.datafiles import MultiRecord
from hammerstein.models.hysteresis import PrandtlIshlinskii
from hammerstein.models.preisach import PreisachModel
from hammerstein.signals.excitation import decreasing_sine

T = 1e-3


def _sine(amplitude=10.0):
    t = np.arange(0, 2.0, 5e-5)
    u = amplitude * np.sin(2 * np.pi * t)
    return u, np.r_[np.diff(u) > 0, False]


@pytest.mark.parametrize("c", [3.0, 5.0, 7.5])
def test_a_loop_closed_beyond_c_is_found_there(c):
    u, rising = _sine()
    y = 2.0 * u + np.where(rising, -1.0, 1.0) * np.clip(c - np.abs(u), 0.0, None)
    low, high = loop_closure(u, y)
    # at the end of the density or at most 1 % of the range inside it, never outside
    assert -c <= low <= -c + 0.2 and c - 0.2 <= high <= c


def test_a_loop_closed_on_one_side_only():
    """The gap 2 (3 - u) for u < 3 grows towards the lower tip: closed above 3 V only."""
    u, rising = _sine()
    y = 2.0 * u + np.where(rising, -1.0, 1.0) * 0.2 * np.clip(3.0 - u, 0.0, None)
    low, high = loop_closure(u, y)
    assert low is None and 3.0 - 0.2 <= high <= 3.0


@pytest.mark.parametrize("largest", [4.0, 8.0])
def test_a_classical_pi_loop_is_open_to_its_tips(largest):
    """A play of threshold r opens the loop everywhere but within 2 r of each tip."""
    pi = PrandtlIshlinskii(np.linspace(0.0, largest, 6), np.full(6, 0.4))
    u, _ = _sine()
    y, _ = pi.simulate(u)
    assert loop_closure(u, y) == (None, None)


def _density_model(end):
    return PreisachModel.from_density(np.linspace(-end, end, 31), total=20.0, tilt=0.4,
                                      bias_width=0.6 * end, coercivity_width=0.3 * end,
                                      reversible=[2.0, 0.02])


def test_a_preisach_model_closes_where_its_grid_ends():
    """Driven to +-10 V, a model whose hysterons switch within +-5 V is closed beyond +-5 V;
    driven within its grid it is open to the tips; noise of 0.2 % of the widest gap leaves
    the closure where it was."""
    model = _density_model(5.0)
    t, u, _ = decreasing_sine(T, 10.0)
    y, _ = model.simulate(u)
    low, high = loop_closure(u, y)
    assert -5.0 <= low <= -4.8 and 4.8 <= high <= 5.0
    noisy = y + 0.01 * np.random.default_rng(0).standard_normal(y.size)
    assert loop_closure(u, noisy) == pytest.approx((low, high), abs=0.2)
    t, u, _ = decreasing_sine(T, 4.5)
    assert loop_closure(u, model.simulate(u)[0]) == (None, None)


def test_the_grid_puts_an_edge_where_the_loop_closes():
    """The grid's own edges more than half a cell inside the open part stay, the closures
    become edges, and the cells left are equal over each closed end, shared by length."""
    shape = lambda a, b, n: grid_edges(a, b, n)          # noqa: E731
    full = shape(-12.0, 12.0, 20)
    edges = closure_grid_edges(-12.0, 12.0, 20, (-5.0, 4.5), shape)
    assert edges.size == 21 and np.all(np.diff(edges) > 0)
    assert edges[0] == -12.0 and edges[-1] == 12.0 and -5.0 in edges and 4.5 in edges
    width = np.gradient(full)
    kept = full[(full > -5.0 + 0.5 * width) & (full < 4.5 - 0.5 * width)]
    i, j = int(np.flatnonzero(edges == -5.0)[0]), int(np.flatnonzero(edges == 4.5)[0])
    np.testing.assert_array_equal(edges[i + 1:j], kept)
    for part in (edges[:i + 1], edges[j:]):
        np.testing.assert_allclose(np.diff(part), np.diff(part)[0])
    # 20 cells: the open part's, then the rest shared by the ends' lengths (7 V and 7.5 V)
    left = 20 - (j - i)
    assert i == round(left * 7.0 / 14.5) and 20 - j == left - i
    one = closure_grid_edges(-12.0, 12.0, 20, (None, 4.5), shape)
    j = int(np.flatnonzero(one == 4.5)[0])
    np.testing.assert_array_equal(one[:j], full[full < 4.5 - 0.5 * width])
    # open, out of range or crossed: the grid over the whole range
    for closure in ((None, None), (-13.0, 13.0), (3.0, -3.0)):
        np.testing.assert_array_equal(closure_grid_edges(-12.0, 12.0, 20, closure, shape), full)


def test_the_identified_model_follows_a_density_that_ends_inside_the_records():
    """A Preisach actuator on +-5 V recorded to +-10 V: the grid found on its loop (an edge at
    the closure) predicts the held-out levels better than the grid over the whole range."""
    true = _density_model(5.0)
    t, u, _ = decreasing_sine(T, 10.0, levels=(1.0, 0.8, 0.6, 0.4, 0.3, 0.2, 0.15, 0.1))
    y, _ = true.simulate(u)
    y = y + 0.005 * np.random.default_rng(1).standard_normal(y.size)
    rec = MultiRecord(t, u[np.newaxis], y[np.newaxis], ("u",), ("y",), T, "sim")
    loop = PreisachIdentifier(n_levels=20).fit(rec)
    centred = PreisachIdentifier(n_levels=20, grid="centred").fit(rec)
    low, high = loop.closure_[0]
    assert -5.0 <= low <= -4.8 and 4.8 <= high <= 5.0
    edges = loop.model_.components[0][0].edges
    assert low in edges and high in edges
    assert centred.closure_ == [(None, None)]
    assert any("closed below" in n for n in loop.notes_)
    rms = [np.mean([w["rms_percent"] for w in est.fit_.validation]) for est in (loop, centred)]
    assert rms[0] < 0.5 * rms[1], rms          # 0.34 times on noise seeds 1-3


def test_a_measured_inputs_noise_does_not_hide_the_closure():
    """A measured input wiggles by its noise at every sample; the branches between its true
    reversals still span the range, and the loop is found closed where the noiseless one is."""
    model = _density_model(5.0)
    t, u, _ = decreasing_sine(T, 10.0)
    y, _ = model.simulate(u)
    clean = loop_closure(u, y)
    noisy_u = u + 0.02 * np.random.default_rng(4).standard_normal(u.size)   # 0.1 % of the span
    assert clean[0] is not None and loop_closure(noisy_u, y) == pytest.approx(clean, abs=0.2)
