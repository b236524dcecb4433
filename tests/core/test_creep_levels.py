"""Staircase step levels after a model and its creep (creep_identification.step_level_errors).

The reference is the definition: the creep simulated by
:meth:`hammerstein.models.creep.Creep.simulate` (the dense ZOH state space),
each level the mean of measured minus predicted from ``settle`` after the
step's start. The fit's kernels must give the same levels to rounding, and
outputs handed in must give the same as the model simulated inside.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.identification.creep_identification import step_level_errors
from hammerstein.models.creep import Creep


def _levels_by_definition(model, rec, creeps, settle):
    h = model.simulate(rec.u)[0].copy()
    off = model.output_offset
    for l, c in enumerate(creeps):
        h[l] = c.simulate((h[l] - off[l])[None, :], rec.sampling_period)[0][0] + off[l]
    change = np.flatnonzero(np.any(np.diff(rec.u, axis=1) != 0, axis=0)) + 1
    bounds = np.r_[0, change, rec.u.shape[1]]
    skip = int(round(settle / rec.sampling_period))
    return np.column_stack([np.mean(rec.y[:, a + skip:b] - h[:, a + skip:b], axis=1)
                            for a, b in zip(bounds[:-1], bounds[1:])])


@pytest.mark.parametrize("settle", [0.0, 0.05])
def test_levels_with_creep_and_handed_outputs_equal_the_definition(settle):
    rng = np.random.default_rng(7)
    T = 1e-3
    u = np.repeat(rng.uniform(-5, 5, 5), 400)[None, :]
    off = np.array([0.3, -1.0])
    model = SimpleNamespace(output_offset=off,
                            simulate=lambda v: (np.vstack([2.0 * v[0], np.tanh(v[0])])
                                                + off[:, None], None))
    rec = SimpleNamespace(u=u, y=rng.normal(size=(2, u.shape[1])) + 3.0, sampling_period=T)
    creeps = [Creep([0.01, 0.1, 1.0], [0.02, 0.01, 0.03], instantaneous=0.96),
              Creep([0.05, 0.5], [0.04, 0.0])]
    ref = _levels_by_definition(model, rec, creeps, settle)
    got = step_level_errors(model, [rec], creeps, settle)[0]
    handed = model.simulate(u)[0]
    kept = handed.copy()
    again = step_level_errors(model, [rec], creeps, settle, outputs=[handed])[0]
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert np.array_equal(got, again)
    assert np.array_equal(handed, kept)           # the handed outputs are not modified
