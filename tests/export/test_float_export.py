"""``--precision float``: the linear stages of the Hammerstein compensators are emitted in a
balanced realization (increment form for the state update), so the float C stays close to the
double Python compensator on the coupled preset too (the shift-register realization of its
ZPETC inverse lost 1e-2 relative in float)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import needs_cc
from test_c_equivalence import circle, python_voltages, random_walk, raster, rel_error
from test_exact_export import strict_harness

from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.export import export_c
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.export.build import compensator_from_source, load_source
from hammerstein.export.c_base import _float_realization


def _compensator(preset):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return compensator_from_source(load_source(preset), "hammerstein")


def test_balanced_realization_has_the_same_transfer():
    """Same Markov parameters (impulse response) as the original stage, to 1e-9 relative."""
    comp, _ = _compensator("realistic-2dof")
    A, B, C, D = (np.asarray(M, float) for M in comp.inverse.bending.state_space())
    Ab, Bb, Cb, Db = _float_realization(A, B, C, D)
    assert Ab.shape[0] <= A.shape[0] and np.array_equal(Db, D)
    Mk, Mb = B.copy(), Bb.copy()
    for _ in range(200):
        h, hb = C @ Mk, Cb @ Mb
        assert np.max(np.abs(h - hb)) <= 1e-9 * max(1.0, np.max(np.abs(h)))
        Mk, Mb = A @ Mk, Ab @ Mb
    assert np.max(np.abs(Ab)) < 10.0          # entries of order 1 (the original: ~1.5e4)


@needs_cc
@pytest.mark.parametrize("preset, bound", [("realistic-2dof", 1e-4), ("rakotondrabe-2dof", 1e-3)])
def test_float_hammerstein_close_to_double_python(preset, bound, tmp_path):
    comp, T = _compensator(preset)
    code = export_c(comp, "fl", T, precision="float")
    h = strict_harness(code, tmp_path / "h", extra=["-Wdouble-promotion", "-Wfloat-conversion"])
    for yr in (0.5 * circle(3000), 0.5 * raster(3000), 0.5 * random_walk(3000)):
        u_c, _, _ = h.run(yr)
        err = rel_error(u_c, python_voltages(comp, yr))
        assert err <= bound, err


@needs_cc
def test_float_export_has_no_double_even_in_the_sampling_period_macro(tmp_path):
    """docs/real-time.md: a float export has no double anywhere, its header's macros included:
    ``(float)k * NAME_SAMPLING_PERIOD`` compiles with -Wdouble-promotion -Wfloat-conversion."""
    import subprocess
    from conftest import COMPILERS
    comp, T = _compensator("rakotondrabe-2dof")
    code = export_c(comp, "fl", T, precision="float")
    for fname, text in code.files().items():
        (tmp_path / fname).write_text(text)
    (tmp_path / "user.c").write_text(
        '#include "fl.h"\nfloat elapsed(unsigned k);\n'
        "float elapsed(unsigned k) { return (float)k * fl_SAMPLING_PERIOD; }\n")
    for src in ("user.c", "fl.c"):
        res = subprocess.run([COMPILERS[0], "-std=c99", "-Wall", "-Wextra", "-Wpedantic",
                              "-Wdouble-promotion", "-Wfloat-conversion", "-Werror", "-O2",
                              "-I", str(tmp_path), "-c", str(tmp_path / src), "-o",
                              str(tmp_path / (src + ".o"))], capture_output=True, text=True)
        assert res.returncode == 0, res.stderr


def identified_gpi_model():
    """2x2 generalised PI, the parameters (to 6 digits) of one identified from an outside
    stage's records (``hammerstein identify --model generalized``, 16 plays per component,
    records over +-20 V). Its cross-coupling y <- ux cancels a play of weight -128 µm on an
    envelope of slope 0.36 against a reversible 46 µm/V: 3547 µm of terms over +-20 V for a
    path of a few µm, and after each reversal of ux, while that play crosses the narrow band
    between its envelopes (1 mV near 0 V), y moves by 46 µm/V of ux."""
    def gpi(step, w, gl, gr, rev, centre, offset=0.0):
        return GeneralizedPI(step * np.arange(16), w, gl, gr, offset=offset, reversible=rev,
                             demagnetised=20.0, demagnetised_centre=centre)

    xx = gpi(1.19650, [0.843018, 0.269178, 0.0946459, 0.102123, 0.0555935, 0.0673822, 0.0343828, 0,
                       0.00340763, 0, 0, 0, 0.00746093, 0.0856613, 0.0497437, 0.121583],
             [20, 0.105796, 0.095475, 0], [19.1685, 0.121272, 0.0139446, 0.845912],
             [2.8545, 0.0137829], -0.160296, offset=0.411245)
    xy = gpi(1.16078, [0.107031, 0.0156831, 0.000741672, -0.00526344, 0.00988716, -0.00886699,
                       -0.00201139, 0.0109961, -0.0125039, 0.0233509, -0.0369164, 0.0299027,
                       -0.0130593, 0.0138953, -0.00323381, 0.00478975],
             [20, 0.106008, 0.184308, 0], [18.4255, 0.100946, 0.173256, 0.803619],
             [-0.0809455, 0.00040109, -1.03299e-05], -4.86628)
    yx = gpi(0.433661, [-127.978, -0.0727385, -0.0115671, 0.000812558, -0.019972, 0.025861,
                        -0.0517337, 0.0627492, -0.0462135, -0.0236311, 0.0508125, -0.0348424,
                        -0.0498017, 0.089583, -0.0950449, 0.132795],
             [20, 0.018108, 0.00484971, 0], [19.7459, 0.0183423, 0.00776417, -0.0559378],
             [46.0364, -0.0294477, -0.00457469], 1.68239)
    yy = gpi(1.23227, [0, 0.893762, 0.207222, 0.0827414, 0.0961171, 0, 0, 0, 0, 0, 0, 0.00913701,
                       0.0271096, 0, 0, 0.124655],
             [20, 0.0949774, -0.18524, 0], [22.6813, 0.0733348, 0.0778896, -2.96629],
             [2.5486, -0.00351263], -0.118702, offset=15.1815)
    model = MultivariableHysteresis([[xx, xy], [yx, yy]], input_names=["ux", "uy"],
                                    output_names=["x", "y"], input_amplitude=[20.0, 20.0])
    model.input_range = np.array([[-20.0, 20.0], [-20.0, 20.0]])
    return model


#: docs/real-time.md, Float: the exact inverse of the identified-like generalised PI in float,
#: against the double Python compensator on a faded-in circle
IDENTIFIED_GPI_FLOAT_BOUND = 1e-4
T_IDENTIFIED = 5e-5


@needs_cc
@pytest.mark.parametrize("f_hz", [5.0, 50.0])
def test_float_exact_inverse_of_an_identified_gpi(f_hz, tmp_path):
    """The float root's tolerance is each direct path's own rounding (one float epsilon of
    its terms' magnitudes), not the largest of any component's: the cross-coupling's 3547 µm
    set 4.2e-4 µm for x's root (its own: 1.2e-5 µm), which stalled ux by up to 1e-4 V near
    0 V, and the cross-coupling's 46 µm/V made that 8 mV on uy: 2.3e-3 relative on a 5 Hz
    circle faded in from rest (an outside tester's measurement on the identified model)."""
    from hammerstein.compensation.drive import hardware_fade
    model = identified_gpi_model()
    comp = PreisachInverseCompensator(model)
    n = 4000
    t = np.arange(n) * T_IDENTIFIED
    rest = model.simulate(np.zeros((2, 1)))[0]
    circle15 = 15.0 * np.vstack([np.cos(2 * np.pi * f_hz * t), np.sin(2 * np.pi * f_hz * t)])
    yr = hardware_fade(circle15, n if f_hz < 10 else n // 2, rest[:, 0])
    h = strict_harness(export_c(comp, "fg", T_IDENTIFIED, precision="float"), tmp_path / "h",
                       extra=["-Wdouble-promotion", "-Wfloat-conversion"])
    u_c, _, _ = h.run(yr)
    err = rel_error(u_c, python_voltages(comp, yr))
    assert err <= IDENTIFIED_GPI_FLOAT_BOUND, err
