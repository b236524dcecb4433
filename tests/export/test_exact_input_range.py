"""The exported exact inverse within the records' range: equal to Python, flagged only out of reach.

A model identified on unipolar records is bounded to 0..100 V
(tests/core/test_inverse_input_range.py). Its rest, 0 V, is then a bound
of the root search, and the range bit must still mean "the reference is out
of reach" (docs/real-time.md): the C used to raise it whenever an input sat
on a bound, so a unipolar stage at rest would have been flagged on every
sample.
"""

import numpy as np

from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.export import STATUS_RANGE, export_c

from conftest import Harness, needs_cc
from test_c_equivalence import python_voltages, rel_error

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
from test_inverse_input_range import UNIPOLAR, unipolar_model  # noqa: E402

T = 5e-5


@needs_cc
def test_rest_on_the_bound_is_not_out_of_reach(tmp_path):
    model = unipolar_model()
    model.input_range = UNIPOLAR
    comp = PreisachInverseCompensator(model)
    # 100 samples at rest (0 µm, the output at 0 V), 100 below the reach at 0 V, then a ramp
    r = np.tile(np.r_[np.zeros(100), np.full(100, -100.0), np.linspace(0.0, 15.0, 1800)], (2, 1))
    h = Harness(export_c(comp, "ur", T), tmp_path / "h")
    u_c, status, _ = h.run(r)
    assert rel_error(u_c, python_voltages(comp, r)) <= 1e-12
    assert np.all(u_c[:, :200] == 0.0)
    flagged = np.flatnonzero(status & STATUS_RANGE)
    assert flagged.tolist() == list(range(100, 200))


@needs_cc
def test_rest_within_rounding_of_the_bound_is_not_out_of_reach(tmp_path):
    # a firmware fed the drive header's rest output: at rest on 0 V the reference sits on the
    # bound's output to within rounding (the other input's 1.17e-9 V moved it by more than the
    # root's 1e-12 µm tolerance); flagged on 299 of 300 samples, a power-up fault for a user
    # who treats the bit as one. Beyond by 0.1 nm (act_BEYOND 1 pm in double) it is flagged.
    model = unipolar_model()
    model.input_range = UNIPOLAR
    comp = PreisachInverseCompensator(model)
    r = np.tile(np.r_[np.full(100, -2e-9), np.full(100, -1e-4), np.zeros(100)], (2, 1))
    h = Harness(export_c(comp, "ub", T), tmp_path / "h")
    u_c, status, _ = h.run(r)
    flagged = np.flatnonzero(status & STATUS_RANGE)
    assert flagged.tolist() == list(range(100, 200))
    assert np.all(u_c == 0.0)
