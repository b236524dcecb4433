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
from hammerstein.io.datafiles import MultiRecord
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


class _CountingModel:
    """h = 2 u on each output, counting its simulations."""

    n_outputs, output_names, output_offset = 2, ["x", "y"], None

    def __init__(self):
        self.calls = 0

    def simulate(self, u):
        self.calls += 1
        return np.vstack([2.0 * u[0], 2.0 * u[1]]), None


def test_auto_scoring_simulates_the_model_once_and_the_chosen_creep_reuses_it():
    from hammerstein.identification import identification_pipeline as pipeline
    from hammerstein.identification.record_identification import identify_record_creep

    rng = np.random.default_rng(11)
    T = 1e-3
    recs = []
    for k in range(2):
        u = np.zeros((2, 3000))
        u[k] = np.repeat([0.0, 4.0, -3.0, 1.0, 0.0, 2.0], 500)
        y = 2.0 * u
        y = np.vstack([Creep([0.05, 0.5], [0.02, 0.03]).simulate(y[l:l + 1], T)[0][0]
                       for l in range(2)]) + 0.01 * rng.normal(size=y.shape)
        recs.append(MultiRecord(np.arange(u.shape[1]) * T, u, y, ("ux", "uy"), ("x", "y"), T,
                                f"stairs-{k}"))
    sine = SimpleNamespace(u=np.vstack([np.sin(2 * np.pi * np.arange(2000) * T)] * 2),
                           sampling_period=T)
    model = _CountingModel()
    fit = SimpleNamespace(model=model, records=[sine])
    pipeline._step_level_error(fit, recs)
    assert model.calls == len(recs)
    creep = pipeline._creep(fit, recs, None)
    assert model.calls == len(recs)                  # the scored outputs were reused
    fresh = identify_record_creep(SimpleNamespace(model=_CountingModel(), records=[sine]), recs)
    assert np.array_equal(creep.weights_, fresh.weights_)
    pipeline._creep(fit, recs, None)                 # still that model's outputs
    assert model.calls == len(recs)
    fit.model = _CountingModel()                     # another model: simulated
    pipeline._creep(fit, recs, None)
    assert fit.model.calls == len(recs)
    other = [MultiRecord(r.timepts[:2000], r.u[:, :2000], r.y[:, :2000], r.input_names,
                         r.output_names, T, r.source) for r in recs]
    pipeline._step_level_error(fit, recs)            # other records than the scored ones
    pipeline._creep(fit, other, None)
    assert fit.model.calls == 2 * len(recs) + len(other)
