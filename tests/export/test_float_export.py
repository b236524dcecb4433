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

from hammerstein.export import export_c
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
