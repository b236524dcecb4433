"""The stable inversion exported: a look-ahead filter equal to `compensate`'s drive.

G here has zeros outside the unit circle (z = 1.25 on x, a non-minimum-phase zero, and
z = -1.1 on y, which alternates the anti-causal terms at the Nyquist rate so that they
cancel), so the stable inversion needs a look-ahead. The C (compiled with the documented
flags) is fed what `compensate`'s stable inversion reads: the faded reference, its periodic
continuation past the end, then its last value held; its voltages must be those of
`HammersteinCompensator.simulate`, sample for sample.
"""

from __future__ import annotations

import math
import warnings

import control
import numpy as np
import pytest

from hammerstein.compensation.drive import hardware_fade, rest_output
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.inversion import preview_inverse
from hammerstein.compensation.lookahead import EXPORT_DECAY, LookaheadInverse
from hammerstein.exceptions import ExportError
from hammerstein.export import STATUS_RANGE, export_c
from hammerstein.io.presets import load_plant
from hammerstein.models.creep import Creep

from conftest import Harness, needs_cc
from test_exact_export import gpi_model, preisach_model

T = 5e-5
ZEROS = (1.25, -1.1)


def non_minimum_phase_g(zeros=ZEROS):
    """The bundled 2x2 modes (coupled) after a first-order factor per output with one zero
    each, ``(z - z0) / ((1 - z0) z)`` (unit DC gain)."""
    G = load_plant("rakotondrabe-2dof").dynamics
    G = control.ss(G.A, G.B, G.C, G.D, T)
    f = [control.ss(control.tf([1.0, -z0], [1.0 - z0, 0.0], T)) for z0 in zeros]
    return control.series(G, control.append(*f))


def periodic_circle(comp, rest, n=4000, f=100.0, radius=8.0, fade=800):
    """A circle around the rest output, faded in from rest as compensate fades it, and
    one period [samples]."""
    period = int(round(1.0 / (f * T)))
    t = np.arange(n) * T
    yr = rest[:, None] + radius * np.vstack([np.cos(2 * np.pi * f * t) - 1.0,
                                             np.sin(2 * np.pi * f * t)])
    return hardware_fade(yr, fade, rest), period


def fed_to_c(comp, faded, period):
    """What the stable inversion read: the record, its continuation, the last value held."""
    L = comp.lookahead_inverse.preview_samples
    n = faded.shape[1]
    ext = np.concatenate([faded, comp._stable_continuation(faded)], axis=1)
    hold = max(0, n + L - ext.shape[1])
    return np.concatenate([ext, np.repeat(ext[:, -1:], hold, axis=1)], axis=1)[:, :n + L]


def test_lookahead_length_is_the_closed_form_and_its_filter_is_the_whole_record_inversion():
    la = LookaheadInverse(non_minimum_phase_g())
    slowest = min(abs(z) for z in ZEROS)
    assert la.anticausal_radius == pytest.approx(slowest, rel=1e-9)
    assert la.lookahead == math.ceil(math.log(1 / EXPORT_DECAY) / math.log(slowest))
    rng = np.random.default_rng(3)
    yr = np.cumsum(rng.normal(size=(2, 3000)), axis=1) * 0.05
    ahead = np.hstack([yr, np.repeat(yr[:, -1:], la.preview_samples, axis=1)])
    v, _ = la.filter(ahead, la.initial_state(yr[:, 0]))
    # the independent whole-record inversion (forward and backward recursions)
    v_ref = preview_inverse(non_minimum_phase_g(), yr, method="stable")
    assert np.max(np.abs(v - v_ref)) <= 1e-11 * np.max(np.abs(v_ref))
    # and it inverts G: G v = yr (G at rest at the first sample), once what the truncated
    # pre-actuation left has rung out of G's modes (pole radius 0.986: 5e-13 after 2000)
    y = control.forced_response(non_minimum_phase_g(), U=v, X0=_dc_state(yr[:, 0])).outputs
    assert np.max(np.abs(y - yr)[:, 2000:]) <= 1e-9 * np.max(np.abs(yr))


def _dc_state(y0):
    G = non_minimum_phase_g()
    A, B, C, D = (np.asarray(M) for M in (G.A, G.B, G.C, G.D))
    n = A.shape[0]
    v0 = np.linalg.solve(C @ np.linalg.solve(np.eye(n) - A, B) + D, y0)
    return np.linalg.solve(np.eye(n) - A, B @ v0)


CASES = {
    "preisach": lambda: HammersteinCompensator(preisach_model(), non_minimum_phase_g(),
                                               inversion="stable"),
    "gpi": lambda: HammersteinCompensator(gpi_model(), non_minimum_phase_g(), inversion="stable"),
    "preisach with creep": lambda: HammersteinCompensator(
        preisach_model(), non_minimum_phase_g(), inversion="stable",
        creep=[Creep([0.01, 0.3], [0.02, 0.03], instantaneous=0.95)] * 2),
    "classical PI law": lambda: HammersteinCompensator(
        load_plant("rakotondrabe-2dof").hysteresis, non_minimum_phase_g(), inversion="stable"),
    "classical PI law with creep": lambda: HammersteinCompensator(
        load_plant("rakotondrabe-2dof").hysteresis, non_minimum_phase_g(), inversion="stable",
        creep=[Creep([0.01, 0.3], [0.02, 0.03], instantaneous=0.95)] * 2),
    "classical PI with offset and map, with creep": lambda: HammersteinCompensator(
        _offset_mapped_model(), non_minimum_phase_g(), inversion="stable",
        creep=[Creep([0.01, 0.3], [0.02, 0.03], instantaneous=0.95)] * 2),
}


def _offset_mapped_model():
    """A modified PI with a sensor zero c (the inverse of L takes Yr - c) and an output map
    (its inverse after L^-1)."""
    from hammerstein import MultivariablePI, PrandtlIshlinskii
    from hammerstein.models.hysteresis import OutputMap
    return MultivariablePI(
        [[PrandtlIshlinskii([0.0, 1.0, 2.0, 4.0], [1.0, 0.5, 0.25, 0.2]), 0.1],
         [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.1, 1.0, 3.0], [0.8, 0.4, 0.3])]],
        input_amplitude=[10.0, 10.0], output_offset=[0.5, -1.0],
        output_map=[OutputMap([5.0, 12.0], [1.0, 0.8, 0.6]), OutputMap([], [1.2])])


@needs_cc
@pytest.mark.parametrize("case", list(CASES))
def test_exported_stable_inversion_equals_compensate(case, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = CASES[case]()
        model = comp.hysteresis_compensator.model
        rest = rest_output(model, comp.creep)      # the classical PI's offset: not 0 here
        faded, period = periodic_circle(comp, rest)
        lead, state, _ = comp.start(faded, period)     # compensate's: it reads on periodically
        u_py, _ = comp.simulate(lead, state)
        code = export_c(comp, "st", T)
    L = comp.lookahead_inverse.preview_samples
    assert code.preview == L
    ahead = fed_to_c(comp, faded, period)
    harness = Harness(code, tmp_path / "h")
    u_c, status, _ = harness.run(ahead)
    assert np.all(u_c[:, :L] == 0.0)                 # the rest voltages while the buffer fills
    assert np.all((status & ~STATUS_RANGE) == 0)
    # the same operations in the same order: equal to the last bit here, 1e-12 promised
    assert np.max(np.abs(u_c[:, L:] - u_py)) <= 1e-12 * np.max(np.abs(u_py))
    u_split, _, _ = harness.run(ahead, split=L + 1234)  # the state copied mid-record
    np.testing.assert_array_equal(u_split, u_c)


def test_a_look_ahead_too_long_is_refused_naming_the_zero_and_its_length():
    comp = HammersteinCompensator(preisach_model(), non_minimum_phase_g((1.0005, -1.1)),
                                  inversion="stable")
    P = math.ceil(math.log(1 / EXPORT_DECAY) / math.log(1.0005))
    with pytest.raises(ExportError, match=rf"\|z\| = 1\.0005.*after {P} samples.*'zpetc'"):
        export_c(comp, "x", T)


def test_float_is_refused_saying_why():
    exact = HammersteinCompensator(preisach_model(), non_minimum_phase_g(), inversion="stable")
    with pytest.raises(ExportError, match="precision: 'float'.*cancel.*double"):
        export_c(exact, "x", T, precision="float")


@needs_cc
def test_the_fmu_plays_the_same_voltages(tmp_path):
    fmpy = pytest.importorskip("fmpy", reason="fmpy (extra [export]) simulates the FMU")
    from hammerstein.export.fmu import build_fmu, platform_folder
    from test_fmu import simulate
    if platform_folder() is None:
        pytest.skip("unknown platform for an FMU binary")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = CASES["gpi"]()
        rest = rest_output(comp.hysteresis_compensator.model, comp.creep)
        faded, period = periodic_circle(comp, rest, n=1600)
        lead, state, _ = comp.start(faded, period)
        u_py, _ = comp.simulate(lead, state)
        code = export_c(comp, "st_fmu", T)
    data, _ = build_fmu(code, "test")
    path = tmp_path / "st_fmu.fmu"
    path.write_bytes(data)
    assert fmpy.validation.validate_fmu(str(path)) == []
    L = code.preview
    u_fmu, status = simulate(path, code, fed_to_c(comp, faded, period))
    assert np.all((status.astype(int) & ~STATUS_RANGE) == 0)
    assert np.max(np.abs(u_fmu[:, L:] - u_py)) <= 1e-12 * np.max(np.abs(u_py))


@needs_cc
@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e5])
def test_a_bad_reference_sets_the_status_and_never_enters_the_buffer(bad, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = CASES["preisach"]()
        rest = rest_output(comp.hysteresis_compensator.model, comp.creep)
        faded, period = periodic_circle(comp, rest, n=1200)
        comp.start(faded, period)
        code = export_c(comp, "st", T)
    ahead = fed_to_c(comp, faded, period)
    L, at = code.preview, code.preview + 500
    harness = Harness(code, tmp_path / "h")
    u_ok, status_ok, _ = harness.run(ahead)
    spoilt = ahead.copy()
    spoilt[0, at] = bad
    u, status, _ = harness.run(spoilt)
    assert status[at] & STATUS_RANGE
    if not np.isfinite(bad):       # skipped: voltages held, the state kept
        np.testing.assert_array_equal(u[:, at], u[:, at - 1])
        assert np.all(status_ok[L:] == 0)
    assert np.all(np.isfinite(u))
