"""Every model class exported: the exact Preisach / generalised-PI inverses, their law, the
static gain over them, the Hammerstein compensator with an exact static part (with and
without creep), compiled and compared sample by sample with the Python compensator.

Table-driven: ``CASES`` maps a label to a compensator factory. Expectations, derived outside
the generator: the C (``-std=c99 -Wall -Wextra -Werror -pedantic -O2``, through the harness of
conftest.py that uses only the header) equals the Python ``simulate`` to 1e-12 relative
(``max |u_C - u_py| / max |u_py|``); the float export compiles with ``-Wdouble-promotion``
(no double anywhere); NaN, inf and out-of-range references set ``STATUS_RANGE`` on every
class; the state size the header reports is ``sizeof(NAME_state)``.
"""

from __future__ import annotations

import subprocess
import warnings

import numpy as np
import pytest

from hammerstein import (InverseMultiplicativeCompensator, MultivariablePI,
                         PerAxisInverseCompensator, PrandtlIshlinskii, StaticGainCompensator)
from hammerstein.models.creep import Creep
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.mixed_compensators import mixed_compensator
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.cli.main import main
from hammerstein.io.presets import load_plant, save_model
from hammerstein.export import STATUS_DIVERGED, STATUS_RANGE, export_c
from hammerstein.export.fmu import build_fmu, platform_folder

from conftest import COMPILERS, Harness, needs_cc
from test_c_equivalence import (_mapped_model, circle, python_voltages, random_walk, raster,
                                rel_error, sine)

T = 5e-5


def preisach_model():
    """2x2: asymmetric Preisach direct paths, a Preisach and an even (u^2) cross-coupling;
    x's paths start after a demagnetising cycle (as identify writes them: ramp hysterons left
    part-way on the staircase), y's in the ideal demagnetised state."""
    e = np.linspace(-12.0, 12.0, 17)
    dx = PreisachModel.from_density(e, total=25.0, tilt=0.3, coercivity=1.0, coercivity_width=2.0,
                                    reversible=[1.2, 0.01]).replace(demagnetised=10.0)
    dy = PreisachModel.from_density(e, total=20.0, bias=0.5, coercivity=1.5, coercivity_width=2.5,
                                    reversible=[1.0])
    cxy = PreisachModel.from_density(e, total=2.0, coercivity=1.0,
                                     coercivity_width=2.0).replace(demagnetised=10.0)
    return MultivariableHysteresis([[dx, cxy], [Polynomial([0.02, 0.004]), dy]],
                                   input_names=["ux", "uy"], output_names=["x", "y"],
                                   input_amplitude=[10.0, 10.0])


def gpi_model():
    """2x2 generalised PI: asymmetric envelopes, a hysteretic and a gain cross-coupling."""
    r = np.linspace(0.0, 9.0, 10)
    w = np.linspace(0.5, 0.1, 10)
    # x starts after a demagnetising cycle (as identify writes it), y from its plays at rest
    dx = GeneralizedPI(r, w, [14.0, 0.08, 0.05, 0.1], [13.0, 0.09, -0.05, -0.1], reversible=[0.8],
                       demagnetised=10.0)
    dy = GeneralizedPI(r, 0.8 * w, [12.0, 0.1, 0.0, 0.0], [12.5, 0.1, 0.1, 0.0], reversible=[0.6, 0.01])
    cx = GeneralizedPI(r[:4], 0.05 * w[:4], [10.0, 0.1, 0.0, 0.0], [10.0, 0.1, 0.0, 0.0],
                       demagnetised=10.0)
    return MultivariableHysteresis([[dx, cx], [0.05, dy]], input_names=["ux", "uy"],
                                   output_names=["x", "y"], input_amplitude=[10.0, 10.0])


def classical_after_cycle():
    """The bundled 2x2 classical PI, its plays after demagnetising cycles of 10 and 8 V
    (centred on 1 V for y: the plays end near 1 V, not 0)."""
    return load_plant("rakotondrabe-2dof", dynamics=False).hysteresis.replace(
        demagnetised=[10.0, 8.0], demagnetised_centre=[0.0, 1.0])


def _dynamics():
    return load_plant("rakotondrabe-2dof").dynamics


def _creep():
    return [Creep.log_law(0.02, 0.01, 10.0), Creep.log_law(0.015, 0.01, 10.0)]


CASES = {
    "preisach-root": lambda: PreisachInverseCompensator(preisach_model()),
    "gpi-root": lambda: PreisachInverseCompensator(gpi_model()),
    "preisach-multiplicative": lambda: mixed_compensator(preisach_model(), "multivariable",
                                                         gain="midpoint", check="ignore"),
    "gpi-diagonal": lambda: mixed_compensator(gpi_model(), "diagonal", check="ignore"),
    "preisach-per-axis": lambda: mixed_compensator(preisach_model(), "per-axis"),
    "gpi-static-gain": lambda: mixed_compensator(gpi_model(), "static-gain"),
    "preisach-hammerstein": lambda: HammersteinCompensator(preisach_model(), _dynamics()),
    "gpi-hammerstein-creep": lambda: HammersteinCompensator(gpi_model(), _dynamics(), creep=_creep()),
    "pi-hammerstein-creep": lambda: HammersteinCompensator(
        load_plant("rakotondrabe-2dof").hysteresis, _dynamics(), creep=_creep()),
    # a classical PI whose plays start after the demagnetising cycle (as identify writes it
    # from records after demagnetise.csv): every kind's C starts where Python's does
    "pi-demagnetised-multiplicative": lambda: InverseMultiplicativeCompensator(
        classical_after_cycle(), gain="midpoint", check="ignore"),
    "pi-demagnetised-iterations": lambda: InverseMultiplicativeCompensator(
        classical_after_cycle(), gain="midpoint", check="ignore", iterations=3),
    "pi-demagnetised-lowpass": lambda: InverseMultiplicativeCompensator(
        classical_after_cycle(), gain="midpoint", check="ignore", feedback="lowpass",
        cutoff_hz=500.0, sampling_period=T),
    "pi-demagnetised-per-axis": lambda: PerAxisInverseCompensator(classical_after_cycle()),
    "pi-demagnetised-hammerstein": lambda: HammersteinCompensator(
        classical_after_cycle(), _dynamics(), creep=_creep(), check="ignore"),
    # an identified PI's sensor offset and output map: the preview enters the inverse as given
    "pi-mapped-hammerstein-creep": lambda: HammersteinCompensator(
        _mapped_model(), _dynamics(), creep=_creep(), check="ignore"),
}
REFERENCES = {"sine": sine, "circle": circle, "raster": raster, "random": random_walk}
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]


def build(label):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return CASES[label]()


def strict_harness(code, path, extra=()):
    h = Harness.__new__(Harness)
    h.code, h.dir, h.exe = code, path, path / "harness"
    path.mkdir(parents=True, exist_ok=True)
    Harness.__init__(h, code, path)          # compiles with the suite's flags
    for fname, text in code.files().items():  # and once more with -pedantic (+ extra)
        (path / fname).write_text(text)
    res = subprocess.run([COMPILERS[0], *STRICT, *extra, "-c", "-o", str(path / "x.o"),
                          str(path / f"{code.name}.c")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return h


@needs_cc
@pytest.mark.parametrize("label", list(CASES))
def test_double_equals_python(label, tmp_path):
    comp = build(label)
    code = export_c(comp, "ex", T)
    h = strict_harness(code, tmp_path / "h")
    assert f"#define ex_STATE_REALS {code.state_reals}" in code.header
    worst = 0.0
    for name, make in REFERENCES.items():
        yr = 0.6 * make(2000)
        u_c, status, size = h.run(yr)
        u_py = python_voltages(comp, yr)
        err = rel_error(u_c, u_py)
        worst = max(worst, err)
        assert err <= 1e-12, f"{label} {name}: {err:.3g}"
        assert np.all((status & ~STATUS_RANGE) == 0)
    u_split, _, _ = h.run(yr, split=777)        # a state copied mid-run continues bit for bit
    assert np.array_equal(u_split, u_c)
    print(f"{label}: max relative error {worst:.2e}, state {size} bytes, "
          f"{code.state_reals} reals")


PI_KINDS = ["multivariable", "per-axis", "static-gain", "hammerstein"]


@needs_cc
@pytest.mark.parametrize("label", PI_KINDS + ["preisach-root", "gpi-root", "pi-hammerstein-creep",
                                              "gpi-static-gain", "preisach-multiplicative",
                                              "pi-demagnetised-multiplicative",
                                              "pi-demagnetised-per-axis"])
def test_float_has_no_double(label, tmp_path):
    """A float export has no double anywhere: -Wdouble-promotion -Wfloat-conversion -Werror."""
    comp = _pi_kind(label) if label in PI_KINDS else build(label)
    code = export_c(comp, "exf", T, precision="float")
    h = strict_harness(code, tmp_path / "h", extra=["-Wdouble-promotion", "-Wfloat-conversion"])
    yr = 0.6 * circle(2000)
    u_c, status, _ = h.run(yr)
    err = rel_error(u_c, python_voltages(comp, yr))
    print(f"float {label}: relative error {err:.2e}")
    # the exact inverses' root search ends a few float epsilons from the root (its tolerance
    # the epsilon times the component's scale): a few 1e-7 per sample, carried by the states
    assert err < (5e-6 if label.endswith("-root") else 1e-2)


def _pi_kind(kind):
    m = load_plant("rakotondrabe-2dof").hysteresis
    return {"multivariable": InverseMultiplicativeCompensator, "per-axis": PerAxisInverseCompensator,
            "static-gain": StaticGainCompensator,
            "hammerstein": lambda m: HammersteinCompensator(m, _dynamics())}[kind](m)


def _all_kinds():
    return {**{k: _pi_kind(k) for k in PI_KINDS}, **{k: build(k) for k in CASES}}


@needs_cc
def test_status_flag_on_every_class(tmp_path):
    """NaN, inf and a glitch beyond ten times the model's output range (1e306 and -1e200 um,
    which had the exact inverses' root search never return, or their state saturate for
    good): flagged, sample skipped (voltages held); a reference far beyond the model's
    range (1e5 um): flagged on every sample (range, or the law's latched divergence); the
    voltages before stay those of the clean reference, and with the bad samples left out
    the voltages are those of the clean reference without them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comps = _all_kinds()
    for i, (label, comp) in enumerate(comps.items()):
        h = Harness(export_c(comp, f"st{i}", T), tmp_path / f"h{i}")
        yr = 0.5 * circle(400)
        bad = yr.copy()
        bad[0, 300], bad[1, 310], bad[0, 320] = np.nan, np.inf, -np.inf
        bad[0, 330], bad[1, 340] = 1e306, -1e200
        u_c, status, _ = h.run(bad)
        P = h.code.preview
        skipped = (300, 310, 320, 330, 340)
        for k in skipped:
            assert status[k] & STATUS_RANGE, (label, k)
            assert np.array_equal(u_c[:, k], u_c[:, k - 1]), (label, k)
        clean, _, _ = h.run(yr)
        assert np.array_equal(u_c[:, :300], clean[:, :300]), label
        kept = np.setdiff1d(np.arange(yr.shape[1]), skipped)
        without, _, _ = h.run(yr[:, kept])
        assert np.array_equal(u_c[:, kept], without), label
        far = yr.copy()
        far[:, 350:] = 1e5
        _, status, _ = h.run(far)
        # every sample from the jump on is flagged: out of range, or the law diverged (latched)
        assert np.all(status[350 + P:] & (STATUS_RANGE | STATUS_DIVERGED)), label


@needs_cc
@pytest.mark.parametrize("label, precision", [("preisach-root", "double"),
                                              ("gpi-hammerstein-creep", "double"),
                                              ("gpi-root", "float")])
def test_fmu_of_every_class(label, precision, tmp_path):
    """The FMU of the new classes simulates (fmpy) like Python; a float export too (the FMI
    wrapper converts at its boundary, the compensator stays float)."""
    pytest.importorskip("fmpy", reason="fmpy (extra [export]) is needed to simulate the FMU")
    from fmpy.validation import validate_fmu
    from test_fmu import simulate
    if platform_folder() is None:
        pytest.skip("unknown platform for an FMU binary")
    comp = build(label)
    code = export_c(comp, "xfmu", T, precision=precision)
    data, binary = build_fmu(code, "test")
    path = tmp_path / "xfmu.fmu"
    path.write_bytes(data)
    assert binary is not None and validate_fmu(str(path)) == []
    yr = 0.6 * circle(1500)
    u_fmu, status = simulate(path, code, yr)
    err = rel_error(u_fmu, python_voltages(comp, yr))
    assert np.all((np.asarray(status) & ~STATUS_RANGE) == 0)
    assert err <= (1e-12 if precision == "double" else 1e-5), err


@needs_cc
@pytest.mark.parametrize("factory", [preisach_model, gpi_model])
def test_cli_exports_a_model_file_of_every_class_with_defaults(factory, tmp_path, capsys):
    """``hammerstein export MODEL --target c`` without --kind on a Preisach / generalised-PI
    model file: the exact inverse, said on stderr; the written C equals the Python one."""
    model = factory()
    path = tmp_path / "m.toml"
    save_model(model, path)
    out = tmp_path / "gen"
    assert main(["export", str(path), "--target", "c", "--out", str(out), "--name", "m",
                 "--sampling-period", repr(T)]) == 0
    err = capsys.readouterr().err
    assert "kind = preisach-inverse" in err
    comp = PreisachInverseCompensator(model)
    h = Harness(export_c(comp, "m", T), tmp_path / "h")
    assert (out / "m.c").read_text().split("\n", 1)[1] == h.code.source.split("\n", 1)[1]
    yr = 0.6 * raster(1500)
    u_c, _, _ = h.run(yr)
    assert rel_error(u_c, python_voltages(comp, yr)) <= 1e-12
