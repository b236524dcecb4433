"""The exact inverse keeps its inputs within the range the model was identified on.

A model identified on unipolar records (0..100 V) is defined beyond them only
by extrapolation. A four-axis user's identified cross-couplings had cubic
reversible terms that turned upward below 0 V (+28 µm each at -120 V): a
reference below the model's reach at rest drove every input of the exact
inverse to its old bound, -1.2 x 100 V, where the cross-couplings alone
exceeded the reference, and the Gauss-Seidel sweeps stayed on that spurious
solution after the reference came back within reach (a 0 -> 62 µm ramp was
answered with -120 V on every input and 102-124 µm). The inverse is now
bounded by the records' range, which ``identify`` writes in ``[amplifier]``
(``source = "records"``) and the file reader attaches to the model.
"""

import numpy as np
import pytest

from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import load_model, save_model
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel

UNIPOLAR = np.array([[0.0, 100.0], [0.0, 100.0]])


def unipolar_model():
    """2x2 over a +-100 V grid; cross-couplings 3e-3 u^2 - 3e-5 u^3: 0..4.4 µm on 0..100 V,
    +95 µm at -120 V (what an extrapolated cubic does below unipolar records)."""
    edges = np.linspace(-100.0, 100.0, 21)

    def direct():
        return PreisachModel.from_density(edges, total=60.0, coercivity=5.0, coercivity_width=10.0,
                                          reversible=[0.2])

    def cross():
        return Polynomial([0.0, 3e-3, -3e-5])

    return MultivariableHysteresis([[direct(), cross()], [cross(), direct()]],
                                   input_names=["ux", "uy"], output_names=["x", "y"],
                                   input_amplitude=[100.0, 100.0])


def below_then_ramp(n=2000, hold=200):
    """(2, n) µm: -100 µm (below the reach at 0 V) for `hold` samples, then 0 -> 15 µm."""
    return np.tile(np.r_[np.full(hold, -100.0), np.linspace(0.0, 15.0, n - hold)], (2, 1))


def test_the_records_range_keeps_the_inverse_off_the_spurious_solution():
    model = unipolar_model()
    r = below_then_ramp()
    # the old bound, +-1.2 x 100 V: the sweeps stay at -120 V after the reference is reachable
    u_old, _ = PreisachInverseCompensator(model).simulate(r)
    y_old = model.simulate(u_old)[0]
    assert np.all(u_old[:, 300] == -120.0)
    assert np.max(np.abs(y_old - r)[:, 400:]) > 5.0
    # the records' range: at 0 V while the reference is below the reach, then on it
    model.input_range = UNIPOLAR
    comp = PreisachInverseCompensator(model)
    assert comp.lo.tolist() == [0.0, 0.0] and comp.hi.tolist() == [100.0, 100.0]
    u, _ = comp.simulate(r)
    y = model.simulate(u)[0]
    assert np.all(u >= 0.0) and np.all(u <= 100.0)
    assert np.all(u[:, :200] == 0.0)
    assert np.max(np.abs(y - r)[:, 200:]) <= 1e-9


def test_the_secant_gains_are_taken_over_the_records_range():
    # the hysterons switch about 0 V (coercivity 5 V): over +-100 V the direct secant is the
    # reversible 0.2 µm/V plus 60 µm / 100 V; over 0..100 V, about its centre, none of them
    # moves after the first rise: the reversible slope alone
    model = unipolar_model()
    K_sym = PreisachInverseCompensator(model).K
    model.input_range = UNIPOLAR
    K = PreisachInverseCompensator(model).K
    assert np.allclose(np.diag(K_sym), 0.8, rtol=1e-3)
    assert np.allclose(np.diag(K), 0.2, rtol=1e-3)
    # the cross term spans 0..4.44 µm on 0..100 V (its maximum at 66.7 V): (max - min) / 100 V;
    # over a sine of 100 V about 0 V it is -0.3 µm/V (60 µm of u^2 - 60 µm of u^3, signed)
    assert K[0, 1] == pytest.approx((3e-3 * (200 / 3) ** 2 - 3e-5 * (200 / 3) ** 3) / 100.0,
                                    rel=1e-3)
    assert K_sym[0, 1] == pytest.approx(-0.3, rel=1e-3)


def test_a_model_file_from_records_carries_their_range(tmp_path):
    model = unipolar_model()
    path = tmp_path / "m.toml"
    save_model(model, path, extra={"amplifier": {"source": "records",
                                                 "ux": {"range": [0.0, 100.0], "slew_rate": 1e5},
                                                 "uy": {"range": [0.0, 100.0], "slew_rate": 1e5}}})
    loaded = load_model(path)
    assert loaded.input_range.tolist() == UNIPOLAR.tolist()
    comp = PreisachInverseCompensator(loaded)
    assert comp.lo.tolist() == [0.0, 0.0]
    # an amplifier the user wrote (not the records'): the model is bounded as before
    save_model(model, path, extra={"amplifier": {"range": [0.0, 100.0]}})
    assert load_model(path).input_range is None
    assert PreisachInverseCompensator(load_model(path)).lo.tolist() == [-120.0, -120.0]


def test_an_empty_range_is_refused():
    model = unipolar_model()
    model.input_range = np.array([[0.0, 100.0], [5.0, 5.0]])
    with pytest.raises(CompensatorError, match="model.input_range: expected 2 ranges"):
        PreisachInverseCompensator(model)
