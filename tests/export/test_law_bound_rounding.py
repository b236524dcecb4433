"""The range bit of the law over a Preisach model at rest on a unipolar stage's 0 V.

The inverse multiplicative law over a Preisach model (kind ``multivariable``)
clips its voltages to the records' range (0..100 V here). At rest the reference
is the model's output at 0 V to within rounding (a firmware fed the drive
header's rest output), and the law computes ``0 + K^-1 (r - Gamma(0))``, a
rounding below 0 V, which it clips to 0 V as Python does. The C flagged that
clip with ``STATUS_RANGE`` on every sample at rest (an outside tester: 20 of 20
samples of an identified unipolar model's rest output). It is now flagged only
beyond the bound by more than the amplifier clamp's tolerance
(``LIMIT_TOLERANCE`` times the bound's largest magnitude, at least 1 V), as
the exact inverses and the amplifier limits already were.
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from hammerstein.compensation.mixed_compensators import mixed_compensator
from hammerstein.export import STATUS_RANGE, export_c
from hammerstein.export.c_base import LIMIT_TOLERANCE

from conftest import Harness, needs_cc
from test_c_equivalence import python_voltages, rel_error

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
from test_inverse_input_range import UNIPOLAR, unipolar_model  # noqa: E402

T = 5e-5


def law():
    model = unipolar_model()
    model.input_range = UNIPOLAR
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model, mixed_compensator(model, "multivariable", gain="midpoint", check="ignore")


@needs_cc
@pytest.mark.parametrize("precision", ["double", "float"])
def test_law_at_rest_on_the_bound_is_not_flagged(precision, tmp_path):
    model, comp = law()
    assert comp.method == "multiplicative" and comp.lo.tolist() == [0.0, 0.0]
    rest = model.simulate(np.zeros((2, 1)))[0]
    n = 100
    # at rest; at rest less 1e-9 um (the rounding of a printed rest: the law asks ~-3e-10 V);
    # 1 um below what 0 V reaches (the law asks ~-0.28 V: out of reach); at rest again
    offsets = np.r_[np.zeros(n), np.full(n, -1e-9), np.full(n, -1.0), np.zeros(n)]
    r = rest + np.vstack([offsets, offsets])
    # up to 5 um beyond what 100 V reaches, held: clipped at the upper bound, flagged
    top = model.simulate(np.tile(np.linspace(0.0, 100.0, 2000), (2, 1)))[0][:, -1:]
    ramp = np.linspace(0.0, 1.0, 2000)
    r = np.hstack([r, rest + (top + 5.0 - rest) * ramp, np.tile(top + 5.0, (1, n))])
    tol = LIMIT_TOLERANCE[precision] * 100.0
    u_py = python_voltages(comp, r)
    h = Harness(export_c(comp, "lb", T, precision=precision), tmp_path / "h")
    u_c, status, _ = h.run(r.astype(np.float32) if precision == "float" else r)
    if precision == "double":
        assert rel_error(u_c, u_py) <= 1e-12
    else:
        assert rel_error(u_c, u_py) <= 1e-4
    flagged = (status & STATUS_RANGE) != 0
    assert not flagged[:2 * n].any(), np.flatnonzero(flagged[:2 * n])[:5]      # rest: rounding
    assert np.all(u_c[:, :2 * n] >= 0.0) and np.all(u_c[:, :2 * n] <= tol)
    assert flagged[2 * n + 1:3 * n].all()                    # out of reach below 0 V (a sample late)
    assert np.all(u_c[:, 2 * n + 1:3 * n] == 0.0)
    assert not flagged[3 * n + 2:4 * n].any()                # back at rest
    assert flagged[-n // 2:].all() and np.all(u_c[:, -n // 2:] == 100.0)     # beyond 100 V
