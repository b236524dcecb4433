"""Exported C = the Python compensators, compiled with the system compiler(s).

Each compensator kind is exported, compiled with ``-std=c99 -Wall -Wextra
-Werror -O2`` and driven through the harness of conftest.py (which calls only
what the header documents) with long references: sine, circle, AFM raster,
random walk. Expectations: double C = Python ``simulate`` to 1e-12 relative
(max |u_C - u_py| / max |u_py|); the Hammerstein compensator's first PREVIEW
calls return 0 V and call k + P returns the voltages of sample k; a state
copied mid-run continues bit for bit (chunked = whole); Python run in two
chunks = the C whole run. Float: the relative error is printed (``-s``) and
bounded by a loose 1e-3.
"""

from __future__ import annotations

import contextlib
import copy
import warnings
from pathlib import Path

import numpy as np
import pytest

from hammerstein import (InverseMultiplicativeCompensator, MultivariablePI,
                         PerAxisInverseCompensator, PrandtlIshlinskii, StaticGainCompensator,
                         diagonal_compensator)
from hammerstein.compensation.drive import rest_output
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.models.creep import Creep
from hammerstein.models.hysteresis import OutputMap
from hammerstein.io.presets import load_plant
from hammerstein.exceptions import CompensatorDivergence
from hammerstein.simulation import is_fusable, simulate_compensator
from hammerstein.export import STATUS_DIVERGED, STATUS_LIMIT, STATUS_RANGE, AmplifierLimits, export_c

from conftest import COMPILERS, needs_cc
from random_models import random_direct_model

REPO = Path(__file__).resolve().parents[2]
T = 5e-5


# -- references (p = 2, µm) --------------------------------------------------------------
def sine(n, f=100.0, a=30.0):
    t = np.arange(n) * T
    return np.vstack([a * np.sin(2 * np.pi * f * t), np.zeros(n)])


def circle(n, f=150.0, radius=20.0):          # starts at rest (x = 0) with zero slope
    t = np.arange(n) * T
    return radius * np.vstack([1 - np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def raster(n, f=50.0, size=30.0, lines=16):
    t = np.arange(n) * T
    phase = (f * t) % 1.0
    fast = size * (1 - np.abs(2 * phase - 1))                 # 0 -> W -> 0 each period
    slow = size / (lines - 1) * np.minimum(np.floor(f * t), lines - 1)
    return np.vstack([fast, slow])


def random_walk(n, seed=0):
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(0.0, 0.15, (2, n)), axis=1)
    return 25 * np.tanh(walk / 25)                            # within the identified range


REFERENCES = {"sine": sine, "circle": circle, "raster": raster, "random": random_walk}


# -- compensators ----------------------------------------------------------------------------
def _preset():
    return load_plant("rakotondrabe-2dof")


def _coupled():
    return load_plant(REPO / "scenarios" / "presets" / "coupled-2dof.toml")


def _mapped_model():
    """A modified PI with an offset, an output map and a linear cross-coupling."""
    return MultivariablePI(
        [[PrandtlIshlinskii([0.0, 1.0, 2.0, 4.0], [1.0, 0.5, 0.25, 0.2]), 0.1],
         [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.1, 1.0, 3.0], [0.8, 0.4, 0.3])]],
        input_amplitude=[10.0, 10.0], output_offset=[0.5, -1.0],
        output_map=[OutputMap([5.0, 12.0], [1.0, 0.8, 0.6]), OutputMap([], [1.2])])


def build(kind):
    if kind == "hammerstein":
        p = _preset()
        return HammersteinCompensator(p.hysteresis, p.dynamics)
    if kind == "hammerstein-coupled":
        p = _coupled()
        return HammersteinCompensator(p.hysteresis, p.dynamics)
    if kind == "hammerstein-mapped":    # S^-1 after the inverse of G, in Python and in C
        return HammersteinCompensator(_mapped_model(), _preset().dynamics)
    if kind == "hammerstein-mapped-creep":   # the creep inverse too before S^-1
        return HammersteinCompensator(_mapped_model(), _preset().dynamics,
                                      creep=[Creep([0.01, 0.1], [0.02, 0.01]), None])
    if kind == "hammerstein-lowpass":
        p = _preset()
        return HammersteinCompensator(p.hysteresis, p.dynamics, feedback="lowpass", cutoff_hz=3000.0,
                                      iterations=1, sampling_period=T)
    model = _mapped_model() if kind.endswith("-mapped") else _preset().hysteresis
    base = kind.removesuffix("-mapped")
    return {
        "multivariable": lambda: InverseMultiplicativeCompensator(model),
        "multivariable-3it": lambda: InverseMultiplicativeCompensator(model, gain="midpoint", iterations=3),
        "lowpass": lambda: InverseMultiplicativeCompensator(model, feedback="lowpass", cutoff_hz=2000.0,
                                                            sampling_period=T),
        "diagonal": lambda: diagonal_compensator(model),
        "per-axis": lambda: PerAxisInverseCompensator(model),
        "per-axis-demagnetised": lambda: PerAxisInverseCompensator(
            model.replace(demagnetised=[20.0, 20.0])),
        "static-gain": lambda: StaticGainCompensator(model),
    }[base]()


KINDS = ["multivariable", "multivariable-3it", "lowpass", "diagonal", "per-axis",
         "per-axis-demagnetised", "static-gain",
         "hammerstein", "hammerstein-coupled", "hammerstein-lowpass", "hammerstein-mapped",
         "hammerstein-mapped-creep",
         "multivariable-mapped", "per-axis-mapped", "static-gain-mapped", "multivariable-3it-mapped"]


def leading(comp):
    """Context in which a Hammerstein compensator's law may run on a reference that leads by P."""
    return comp.previewed() if isinstance(comp, HammersteinCompensator) else contextlib.nullcontext()


def python_voltages(comp, yr, chunks=1, backend=None):
    """Python voltages aligned with the C calls (call k gets yr[:, k]), optionally in chunks;
    ``backend='numpy'``: the plain numpy reference loop of the fused law instead of ``simulate``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = getattr(comp, "preview_samples", 0)
        state = None
        if isinstance(comp, HammersteinCompensator):     # the filter at rest consumes the preview
            state = comp.initial_state()        # at rest (a Preisach model's rest states)
            nc = comp.hysteresis_compensator.n_states
            # the C starts its linear stages at rest at the model's output at 0 V (where
            # compensate's faded references start)
            rest = rest_output(comp.hysteresis_compensator.model if comp.exact_static
                               else comp.model, comp.creep)
            pre = comp.prefilter_reference       # the frame the inverse filters (Yr - c; S^-1 after it)
            _, state[nc:] = comp.inverse.filter(
                pre(yr[:, :P]), comp.inverse.initial_state(pre(rest[:, None])[:, 0]))
        lead = yr[:, P:]
        parts, edges = [], np.linspace(0, lead.shape[1], chunks + 1).astype(int)
        for a, b in zip(edges[:-1], edges[1:]):
            if backend is None:
                u, state = comp.simulate(lead[:, a:b], state)
            else:
                with leading(comp):               # the reference here already leads by P
                    u, state = simulate_compensator(comp, lead[:, a:b], state, backend=backend)
            parts.append(u)
        return np.hstack([np.zeros((yr.shape[0], P))] + parts)


def rel_error(u_c, u_py):
    return float(np.max(np.abs(u_c - u_py)) / np.max(np.abs(u_py)))


def within(u_c, comp, yr, u_py):
    """``rel_error(u_c, u_py) <= tolerance(...)`` (the numpy loop runs only when needed)."""
    err = rel_error(u_c, u_py)
    return err <= 1e-12 or err <= tolerance(comp, yr, u_py)


def tolerance(comp, yr, u_py):
    """1e-12, or 1.5 times the spread of Python's own two implementations (compiled kernel
    and numpy loop) when that is larger: with the coupled preset's ZPETC inverse the problem
    is conditioned so that any double evaluation order moves U by ~1e-12 relative (measured:
    numba vs numpy 1.26e-12, each 0.85-1.1e-12 from a long-double run of the C)."""
    with leading(comp):
        fusable = is_fusable(comp)
    if not fusable:
        return 1e-12
    return max(1e-12, 1.5 * rel_error(python_voltages(comp, yr, backend="numpy"), u_py))


@needs_cc
@pytest.mark.parametrize("kind", KINDS)
def test_double_equals_python(kind, harness):
    comp = build(kind)
    code = export_c(comp, "comp", T)
    h = harness(code)
    n = 3000
    for ref_name, make in REFERENCES.items():
        yr = make(n)
        u_c, status, size = h.run(yr)
        u_py = python_voltages(comp, yr)
        P = code.preview
        assert np.all((status & ~STATUS_RANGE) == 0), ref_name
        # the range bit exactly where the voltages leave 1.2 x the identified amplitude
        amp = comp.model.input_amplitude
        beyond = np.zeros(u_py.shape[1], bool) if amp is None else \
            np.any(np.abs(u_py) > 1.2 * np.asarray(amp)[:, None], axis=0)
        assert np.array_equal((status & STATUS_RANGE) != 0, beyond), ref_name
        assert np.all(u_c[:, :P] == 0.0)                       # rest voltages while the preview fills
        assert within(u_c, comp, yr, u_py), f"{kind} {ref_name}: {rel_error(u_c, u_py):.3g}"
        assert size <= 4096
    # chunked = whole: the state struct copied at an odd sample continues bit for bit
    u_split, _, _ = h.run(yr, split=1237)
    assert np.array_equal(u_split, u_c)
    # Python in three chunks (state continued) = C in one run
    u3 = python_voltages(comp, yr, chunks=3)
    assert within(u_c, comp, yr, u3)


def _held_rest(model, n, precision, harness):
    """The per-axis inverse's voltages [V] for ``n`` samples of the model's rest output, in
    Python and in its exported C, and the C's status."""
    comp = PerAxisInverseCompensator(model)
    yr = np.repeat(model.simulate(np.zeros((2, 1)))[0], n, axis=1)
    u_py, _ = comp.simulate(yr)
    u_c, status, _ = harness(export_c(comp, "comp", T, precision=precision)).run(yr)
    return u_py, u_c, status


@needs_cc
@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("kind, amplitude, offset", [
    ("per-axis", 5.0, None), ("per-axis", 15.0, [3.1, -7.3]), ("per-axis", 17.5, [12.7, 0.3]),
    ("per-axis-mapped", 15.0, None)])
def test_per_axis_holds_the_rest_after_the_cycle(kind, amplitude, offset, precision, harness):
    """A reference held at the model's rest output leaves every voltage at 0 V, in Python
    and in C (the cross-couplings, which the per-axis inverse leaves alone, dropped). After
    the demagnetising cycle the inverse plays sit at their bands' edges: the rest output
    rounded 1 ulp away moved them, and the inverse play answered the rounding by jumping
    up to 2 r_1 (0.068 V from a 5 V cycle, 0.14 V from a 15 V one with an offset, on the
    preset's 0.07 V r_1). In float the weighted sum rounds coarser: its band too (0.14 V
    from the 17.5 V cycle with the band of double)."""
    model = build(kind).model
    c = model.components
    model = model.replace(components=[[c[0][0], None], [None, c[1][1]]],
                          demagnetised=[amplitude] * 2,
                          output_offset=model.output_offset if offset is None else offset)
    u_py, u_c, status = _held_rest(model, 40, precision, harness)
    # (an axis with r_1 = 0 has no inverse play: its voltage is the weighted sum, ~1e-16 V)
    assert np.max(np.abs(u_py)) <= 1e-12
    assert np.max(np.abs(u_c)) <= (1e-12 if precision == "double" else 1e-6)
    assert np.all(u_py == u_py[:, :1]) and np.all(u_c == u_c[:, :1]) and np.all(status == 0)


@needs_cc
@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("make", [
    lambda: random_direct_model(1, 100.0), lambda: random_direct_model(6, 100.0),
    lambda: random_direct_model(12, 100.0),
    lambda: MultivariablePI([[PrandtlIshlinskii([0.002, 0.004, 0.006, 0.008], [0.1, 0.05, 0.03, 0.02]),
                              None], [None, PrandtlIshlinskii([0.002, 0.005], [0.1, 0.02])]],
                            input_amplitude=[10.0, 10.0], demagnetised=[6.0, 6.0],
                            output_offset=[41.3, -37.9])], ids=["seed1", "seed6", "seed12", "mV"])
def test_the_motion_band_scales_with_the_offset(make, precision, harness):
    """The band of the per-axis inverse play was scaled by the operator's thresholds alone;
    the rounding at a held rest output scales with what is summed, an output offset of
    ~100 µm included: a reviewer's random models (offsets within +-100 µm) still jumped up
    to 1.63 V in float, and thresholds of a few mV with a 40 µm offset 2 r_1 in double too."""
    model = make()
    u_py, u_c, _ = _held_rest(model, 10, precision, harness)
    assert np.max(np.abs(u_py)) <= 1e-12
    assert np.max(np.abs(u_c)) <= (1e-12 if precision == "double" else 1e-5), np.abs(u_c).max(axis=1)


@needs_cc
@pytest.mark.parametrize("kind", ["multivariable", "per-axis", "hammerstein", "multivariable-mapped"])
def test_float_error_reported(kind, harness):
    comp = build(kind)
    h = harness(export_c(comp, "compf", T, precision="float"))
    yr = circle(3000)
    u_c, status, size = h.run(yr)
    err = rel_error(u_c, python_voltages(comp, yr))
    print(f"float {kind}: relative error {err:.2e}, state {size} bytes")
    assert err < 1e-3 and np.all((status & ~STATUS_RANGE) == 0)


@needs_cc
@pytest.mark.skipif(len(COMPILERS) < 2, reason="only one C compiler on PATH (clang not found)")
@pytest.mark.parametrize("kind", ["hammerstein", "per-axis-mapped", "lowpass"])
def test_second_compiler(kind, harness):
    comp = build(kind)
    code = export_c(comp, "comp", T)
    yr = raster(2000)
    outs = [harness(code, cc).run(yr)[0] for cc in COMPILERS]
    u_py = python_voltages(comp, yr)
    for u in outs:
        assert within(u, comp, yr, u_py)


# -- amplifier limits and divergence: naive references written here -----------------------
def naive_amplifier(u, lo, hi, step):
    """Range clip, then ``a[k] = a[k-1] + clip(x[k] - a[k-1], -step, step)`` from rest
    (the range value nearest 0); flags where either acted (numpy, one sample at a time)."""
    a = np.clip(np.zeros(u.shape[0]), lo, hi)
    out, flags = np.empty_like(u), np.zeros(u.shape[1], dtype=int)
    for t in range(u.shape[1]):
        x = np.clip(u[:, t], lo, hi)
        d = np.clip(x - a, -step, step)
        flags[t] = int(np.any(x != u[:, t]) or np.any(d != x - a))
        a = np.where(d != x - a, a + d, x)
        out[:, t] = a
    return out, flags


@needs_cc
@pytest.mark.parametrize("kind", ["multivariable", "hammerstein", "per-axis"])
def test_amplifier_limits(kind, harness):
    """The law runs as in Python; the amplifier clips its voltages after it."""
    comp = build(kind)
    lo, hi, slew = np.array([-2.0, 0.5]), np.array([4.0, np.inf]), np.array([4000.0, np.inf])  # V, V/s
    h = harness(export_c(comp, "lim", T, limits=AmplifierLimits(lo, hi, slew)))
    yr = sine(2000, f=200.0, a=30.0) + circle(2000)
    u_c, status, _ = h.run(yr)
    u_ref, flags = naive_amplifier(python_voltages(comp, yr), lo, hi, slew * T)
    P = getattr(comp, "preview_samples", 0)
    assert np.all(u_c[:, :P] == np.clip(0.0, lo, hi)[:, None])      # the amplifier's rest
    assert np.all(u_c >= lo[:, None]) and np.all(u_c <= hi[:, None])
    assert np.all(np.abs(np.diff(u_c[0])) <= slew[0] * T * (1 + 1e-12))
    assert np.max(np.abs(u_c - u_ref)) <= 1e-12 * np.max(np.abs(u_ref))
    assert np.array_equal((status & STATUS_LIMIT)[P:], flags[P:]) and flags.any()


@needs_cc
def test_divergence_flag_and_hold(harness):
    """The literal law (K = I) diverges on the preset; C flags the sample Python raises at."""
    model = _preset().hysteresis
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = InverseMultiplicativeCompensator(model, gain="identity", check="ignore")
    yr = sine(4000, f=50.0, a=40.0)
    with pytest.raises(CompensatorDivergence) as info, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp.simulate(yr)
    k = info.value.sample
    bad = k + 50                                               # a NaN after the latch
    yr[0, bad] = np.nan
    u_c, status, _ = harness(export_c(comp, "lit", T)).run(yr)
    first = int(np.flatnonzero(status & STATUS_DIVERGED)[0])
    assert first == k
    # latched from then on; the NaN sets the range bit too (it returned 2 alone)
    assert status[bad] == STATUS_DIVERGED | STATUS_RANGE
    assert np.all(np.delete(status[k:], bad - k) == STATUS_DIVERGED)
    assert np.all(u_c[:, k:] == u_c[:, [k - 1]])               # held at the last valid voltages
    u_py = python_voltages(comp, yr[:, :k])
    assert rel_error(u_c[:, :k], u_py) <= 1e-12


@needs_cc
@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_long_references(kind, harness):
    """200 000 samples (10 s at 20 kHz) per reference: the error does not grow."""
    comp = build(kind)
    h = harness(export_c(comp, "comp", T))
    n = 200_000
    for ref_name, make in REFERENCES.items():
        yr = make(n)
        u_c, status, _ = h.run(yr)
        u_py = python_voltages(comp, yr)
        if not within(u_c, comp, yr, u_py):
            # the random walk through the ZPETC inverse over 200 000 samples: measured C vs
            # Python 2.66e-12, Python's two backends 2.4e-12 from a long-double run of the C,
            # the double C 0.99e-12 from it. Then the C must be at least as accurate as Python.
            code = copy.copy(h.code)
            code.header = code.header.replace("typedef double comp_real;", "typedef long double comp_real;")
            u_ld, _, _ = harness(code).run(yr)
            assert rel_error(u_c, u_ld) <= max(1e-12, rel_error(u_py, u_ld)), ref_name
        u_split, _, _ = h.run(yr, split=n // 2 + 7)
        assert np.array_equal(u_split, u_c)
