"""Per-harmonic learning after convergence: a dead zone around the noise floor.

Expectations, derived independently of the code:

* the max Euclidean error of a periodic error is the peak of a sum of
  harmonics, which is not monotone in their amplitudes: shrinking one
  harmonic while turning its phase can raise the peak (checked here on two
  sinusoids in closed form). Near the noise floor a measured amplitude is a
  noisy sample of a small true one, so learning it after the learning has
  converged can make the next trial worse;
* hence, once an update learnt no harmonic, a harmonic just above the floor
  (``threshold * noise * sqrt(p)``) is no longer learnt, one above
  ``resume`` times the floor still is; before convergence every harmonic
  above the floor is learnt (unchanged), and ``resume = 1`` is the rule
  without a dead zone;
* the converged state survives the ``learn --history`` round trip.
"""

import numpy as np
import pytest

from hammerstein.cli import _learn_history as learn_cli
from hammerstein.compensation.ilc import HarmonicGains
from hammerstein.exceptions import CompensatorError, DataFileError

NOISE = 0.01                       # µm per harmonic per axis
FLOOR = 3.0 * NOISE * np.sqrt(2)   # p = 2 axes, default threshold 3


def _spectrum(amplitudes):
    """(2, n_h) spectrum whose per-harmonic norm over the axes is ``amplitudes``."""
    a = np.asarray(amplitudes, dtype=float)
    return np.vstack([a, np.zeros_like(a)])


def test_the_peak_of_two_harmonics_can_grow_while_one_shrinks():
    """sin t + a sin 3t = s (1 + 3a - 4a s^2), s = sin t: the peak over s in [-1, 1]
    is 2 (1 + 3a)^1.5 / (3 sqrt(12 a)) for a = 0.8 (interior maximum, ~1.349)
    and |1 - a| = 1.6 for a = -0.6 (at s = 1): harmonic 3 fell from 0.8 to 0.6
    and turned by pi, the peak rose by 19 %."""
    t = np.linspace(0.0, 2 * np.pi, 200001)
    before = np.max(np.abs(np.sin(t) + 0.8 * np.sin(3 * t)))
    after = np.max(np.abs(np.sin(t) + 0.6 * np.sin(3 * t + np.pi)))
    assert before == pytest.approx(2 * 3.4 ** 1.5 / (3 * np.sqrt(9.6)), rel=1e-6)
    assert after == pytest.approx(1.6, rel=1e-9)
    assert after > 1.15 * before


def _converged():
    g = HarmonicGains([0.5, 0.5, 0.5])
    assert np.all(g.update(_spectrum([10 * FLOOR, 5 * FLOOR, 3 * FLOOR]), NOISE) == 0.5)
    assert not g.converged
    assert np.all(g.update(_spectrum([0.9 * FLOOR, 0.5 * FLOOR, 0.2 * FLOOR]), NOISE) == 0.0)
    assert g.converged
    return g


@pytest.mark.parametrize("multiple, learnt", [(1.05, False), (1.9, False), (2.1, True), (4.0, True)])
def test_after_convergence_only_errors_above_the_dead_zone_are_learnt(multiple, learnt):
    g = _converged()
    gains = g.update(_spectrum([multiple * FLOOR, 0.5 * FLOOR, 0.5 * FLOOR]), NOISE)
    assert gains[0] == (0.5 if learnt else 0.0)
    assert np.all(gains[1:] == 0.0)


def test_before_convergence_the_floor_alone_decides():
    g = HarmonicGains([0.5, 0.5])
    gains = g.update(_spectrum([1.05 * FLOOR, 0.9 * FLOOR]), NOISE)
    assert list(gains) == [0.5, 0.0] and not g.converged


def test_resume_one_is_the_rule_without_a_dead_zone():
    g = HarmonicGains([0.5, 0.5], resume=1.0)
    g.update(_spectrum([0.5 * FLOOR, 0.5 * FLOOR]), NOISE)
    assert g.converged
    assert list(g.update(_spectrum([1.05 * FLOOR, 0.5 * FLOOR]), NOISE)) == [0.5, 0.0]


@pytest.mark.parametrize("bad", [0.5, 0.0, -1.0, float("nan")])
def test_resume_below_one_is_refused(bad):
    with pytest.raises(CompensatorError, match="resume"):
        HarmonicGains([0.5], resume=bad)


@pytest.mark.parametrize("converged", [False, True])
def test_the_converged_state_survives_the_history_round_trip(tmp_path, converged):
    (tmp_path / learn_cli.HISTORY_MARK).write_text("")
    g = HarmonicGains([0.5, 0.4, 0.3])
    g.update(_spectrum([10 * FLOOR, 5 * FLOOR, 3 * FLOOR]), NOISE)
    if converged:
        g.update(_spectrum([0.1 * FLOOR] * 3), NOISE)
    learn_cli._save_gains(tmp_path, g, "nm")
    # the previous errors' column is named in the model's unit
    assert (tmp_path / learn_cli.GAINS_FILE).read_text().startswith(
        "harmonic,gain,previous_error_nm,growths,converged\n")
    back = HarmonicGains([0.5, 0.4, 0.3])
    learn_cli._restore_gains(tmp_path, back)
    assert back.converged is converged
    np.testing.assert_array_equal(back.previous, g.previous)
    np.testing.assert_array_equal(back.gains, g.gains)


def test_a_history_written_before_the_dead_zone_restores_as_not_converged(tmp_path):
    (tmp_path / learn_cli.HISTORY_MARK).write_text("")
    (tmp_path / learn_cli.GAINS_FILE).write_text(
        "harmonic,gain,previous_error_um,growths\n0,0.5,0.1,0\n1,0.25,0.2,2\n")
    back = HarmonicGains([0.5, 0.5])
    learn_cli._restore_gains(tmp_path, back)
    assert not back.converged and list(back.gains) == [0.5, 0.25] and list(back.growths) == [0, 2]


@pytest.mark.parametrize("text", [b"harmonic,gain,previous_error_um,growths\n0,abc,0.1,0\n1,0.25,0.2,2\n",
                                  b"harmonic,gain,previous_error_um,growths\n0,0.5\n1,0.25,0.2,2\n",
                                  b"harmonic,gain\n0,0.5,0.1,0\n\xff,0.25,0.2,2\n"])
def test_a_harmonics_file_not_written_by_learn_is_refused_naming_it(tmp_path, text):
    """A gain that is no number, a short row or bytes that are not UTF-8: one line naming the
    file, not a bare 'could not convert string to float'."""
    (tmp_path / learn_cli.HISTORY_MARK).write_text("")
    (tmp_path / learn_cli.GAINS_FILE).write_bytes(text)
    with pytest.raises(DataFileError, match=f"{learn_cli.GAINS_FILE}: not the per-harmonic gains"):
        learn_cli._restore_gains(tmp_path, HarmonicGains([0.5, 0.5]))
