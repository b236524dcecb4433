"""The range bit of the exported C on a unipolar model (amplifier 0..100 V, amplitude 50 V).

A classical PI identified on records that drove 0..100 V has the input
amplitude 50 V: half the span, not a bound about 0 V. The range bit
(``NAME_STATUS_RANGE``) must mean "a voltage beyond the model's range"
(docs/real-time.md): within 0..100 V no sample is flagged, and a reference
beyond what the model reaches is. (The range check used to compare |u| with
1.2 x 50 = 60 V, flagging 11245 of 16000 samples of a tip-tilt circle that
peaked at 71 V.)
"""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein import MultivariablePI, PerAxisInverseCompensator, PrandtlIshlinskii
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.exceptions import RangeWarning
from hammerstein.export import STATUS_LIMIT, STATUS_RANGE, AmplifierLimits, export_c
from hammerstein.export.c_base import LIMIT_TOLERANCE

from conftest import Harness, needs_cc

T = 5e-5
AMPLITUDE = 50.0
UNIPOLAR = AmplifierLimits(0.0, 100.0)


def unipolar_model():
    """Two axes with a small hysteretic cross-coupling, identified amplitude 50 V."""
    return MultivariablePI(
        [[PrandtlIshlinskii([0.0, 5.0, 15.0, 30.0], [0.12, 0.03, 0.02, 0.01]), 0.002],
         [PrandtlIshlinskii([0.0, 10.0], [0.004, 0.001]),
          PrandtlIshlinskii([0.0, 5.0, 20.0], [0.11, 0.04, 0.02])]],
        input_amplitude=[AMPLITUDE, AMPLITUDE])


def drive(n, peak):
    """From rest (0 V) up a smooth ramp to a cycle between 0.05 x and peak V on both inputs."""
    t = np.arange(n) / n
    base = 0.5 * peak * (1 - np.cos(2 * np.pi * 3 * t))
    return np.vstack([base, 0.5 * peak * (1 - np.cos(2 * np.pi * 2 * t))])


def test_input_range_is_centred_in_a_unipolar_amplifier_range():
    from hammerstein.export.c_base import model_input_range
    model = unipolar_model()
    low, high = model_input_range(model, UNIPOLAR)
    assert low.tolist() == [-10.0, -10.0] and high.tolist() == [110.0, 110.0]
    low, high = model_input_range(model, AmplifierLimits(-100.0, 100.0))    # symmetric: about 0 V
    assert low.tolist() == [-60.0, -60.0] and high.tolist() == [60.0, 60.0]
    low, high = model_input_range(model, AmplifierLimits(0.0, 150.0))       # from rest at 0 V
    assert low.tolist() == [-10.0, -10.0] and high.tolist() == [110.0, 110.0]
    low, high = model_input_range(model, AmplifierLimits(0.0, 80.0))        # narrower: its middle
    assert low.tolist() == [-20.0, -20.0] and high.tolist() == [100.0, 100.0]


@needs_cc
@pytest.mark.parametrize("kind", ["per-axis", "hammerstein"])
def test_unipolar_reference_in_range_is_not_flagged(kind, tmp_path):
    from hammerstein.io.presets import load_plant
    model = unipolar_model()
    comp = PerAxisInverseCompensator(model) if kind == "per-axis" else \
        HammersteinCompensator(model, load_plant("rakotondrabe-2dof").dynamics)
    n = 4000
    yr, _ = model.simulate(drive(n, 95.0))           # what the model reaches with 0..95 V
    code = export_c(comp, "uni", T, limits=UNIPOLAR)
    h = Harness(code, tmp_path / "h")
    u_c, status, _ = h.run(yr)
    assert u_c.max() > 90.0 and u_c.min() >= 0.0       # well beyond the old 60 V bound
    assert np.all(status == 0), np.unique(status)
    # out of the model's range: the reference of a 130 V drive asks for voltages beyond
    # 50 + 1.2 x 50 = 110 V; the range bit is set where the compensator asks for them
    yr_far, _ = model.simulate(drive(n, 130.0))
    u_c, status, _ = h.run(yr_far)
    if kind == "per-axis":
        with pytest.warns(RangeWarning):                        # Python: extrapolated too
            u_py = np.asarray(comp.simulate(yr_far)[0])
        beyond = np.any(u_py > 110.0, axis=0)
        assert beyond.sum() > 100
        assert np.array_equal((status & STATUS_RANGE) != 0, beyond)
        assert np.all((status[beyond] & STATUS_LIMIT) != 0)     # clamped to 100 V as well
    else:
        assert np.sum((status & STATUS_RANGE) != 0) > 100


@needs_cc
@pytest.mark.parametrize("precision", ["double", "float"])
def test_limit_bit_ignores_rounding_at_rest_on_zero_volts(precision, tmp_path):
    """A per-axis inverse after a demagnetising cycle computes -2e-14 V, not 0, each time
    the reference returns to rest: clamped to 0 V but not flagged (it was, at every
    return, in double and float). A reference below the rest output asks for really
    negative voltages: those are flagged, every one of them."""
    model = unipolar_model().replace(demagnetised=[AMPLITUDE, AMPLITUDE],
                                     demagnetised_centre=[AMPLITUDE, AMPLITUDE])
    comp = PerAxisInverseCompensator(model)
    rest, _ = model.simulate(np.zeros((2, 1)))
    t = np.arange(3000) * T
    wave = 1 - np.cos(2 * np.pi * 100 * t)          # back to rest every 200 samples
    yr = rest + np.vstack([3.0 * wave, 2.0 * wave])
    yr[0, 2000:] -= 0.5 * wave[2000:]                # x's crest lowered, then below rest
    yr[0, 2000:] = np.where(wave[2000:] < 0.3, rest[0, 0] - 0.2 * wave[2000:], yr[0, 2000:])
    u_py, _ = comp.simulate(yr)
    u_py = np.asarray(u_py)
    rounding = (u_py < 0) & (u_py > -1e-9)
    assert np.any(rounding[:, :2000])               # the case: a rounding below 0 V at rest
    tol = LIMIT_TOLERANCE[precision] * 100.0        # of the range's largest bound
    beyond = np.any(u_py < -tol, axis=0)
    assert beyond.sum() > 50
    clear = ~np.any(np.abs(u_py + tol) < 0.5 * tol, axis=0)    # float rounding near -tol
    h = Harness(export_c(comp, "unr", T, precision=precision, limits=UNIPOLAR), tmp_path / "h")
    u_c, status, _ = h.run(yr.astype(np.float32) if precision == "float" else yr)
    assert u_c.min() >= 0.0
    limited = (status & STATUS_LIMIT) != 0
    assert np.array_equal(limited[clear], beyond[clear]), (
        np.flatnonzero(limited & ~beyond)[:5], np.flatnonzero(beyond & ~limited)[:5])
