"""The FMU: valid for fmpy, simulates, and matches the Python compensator.

fmpy applies the inputs set for communication point t_k, calls fmi2DoStep and
records the outputs at t_(k+1): output row k + 1 is the voltage of call k of
``NAME_step``, i.e. (with the preview) of sample k - P of the reference.
"""

from __future__ import annotations

import io
import shutil
import zipfile

import numpy as np
import pytest

from hammerstein.export import STATUS_RANGE, export_c
from hammerstein.export.fmu import build_fmu, find_compiler, platform_folder

from conftest import needs_cc
from test_c_equivalence import T, build, circle, python_voltages, raster, rel_error, within

fmpy = pytest.importorskip("fmpy", reason="fmpy (extra [export]) is needed to simulate the FMU")
validate_fmu = pytest.importorskip("fmpy.validation").validate_fmu


def simulate(path, code, yr):
    n = yr.shape[1]
    names = [f"reference_{nm}" for nm in code.output_names]
    sig = np.zeros(n, dtype=[("time", float)] + [(nm, float) for nm in names])
    sig["time"] = np.arange(n) * T
    for nm, row in zip(names, yr):
        sig[nm] = row
    outs = [f"voltage_{nm}" for nm in code.input_names] + ["status"]
    res = fmpy.simulate_fmu(str(path), start_time=0.0, stop_time=n * T, step_size=T,
                            output_interval=T, input=sig, output=outs)
    u = np.vstack([res[o] for o in outs[:-1]])
    return u[:, 1:n + 1], res["status"][1:n + 1]


@needs_cc
@pytest.mark.skipif(platform_folder() is None, reason="unknown platform for an FMU binary")
@pytest.mark.parametrize("kind", ["hammerstein", "per-axis-mapped"])
def test_fmu_simulates_like_python(kind, tmp_path):
    comp = build(kind)
    code = export_c(comp, "comp_fmu", T)
    data, binary = build_fmu(code, "test")
    assert binary.startswith(f"binaries/{platform_folder()}/comp_fmu.")
    path = tmp_path / "comp_fmu.fmu"
    path.write_bytes(data)
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    assert md.coSimulation.modelIdentifier == "comp_fmu"
    assert float(md.defaultExperiment.stepSize) == T
    assert [v.causality for v in md.modelVariables] == ["input"] * 2 + ["output"] * 3
    yr = circle(1500)
    u_fmu, status = simulate(path, code, yr)
    u_py = python_voltages(comp, yr)
    assert np.all((status & ~STATUS_RANGE) == 0)   # the range bit: voltages beyond 1.2 x amplitude
    assert within(u_fmu, comp, yr, u_py), rel_error(u_fmu, u_py)


@needs_cc
@pytest.mark.slow
@pytest.mark.skipif(shutil.which("cmake") is None, reason="fmpy builds source FMUs with cmake")
def test_fmpy_compiles_the_sources(tmp_path):
    """fmpy's own build of the source-code FMU (cmake, its FMI headers) simulates alike."""
    from fmpy.build import build_platform_binary
    comp = build("hammerstein-coupled")
    code = export_c(comp, "src_fmu", T)
    data, binary = build_fmu(code, "test", binary=False)
    assert binary is None
    unzipped = tmp_path / "fmu"
    zipfile.ZipFile(io.BytesIO(data)).extractall(unzipped)
    (tmp_path / "build").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "build")
    yr = raster(1500)
    u_fmu, _ = simulate(unzipped, code, yr)
    u_py = python_voltages(comp, yr)
    assert within(u_fmu, comp, yr, u_py), rel_error(u_fmu, u_py)


def test_source_fmu_contents(tmp_path):
    """Without a binary: the sources, the model description, nothing else needed."""
    comp = build("multivariable")
    code = export_c(comp, "only_src", T)
    data, binary = build_fmu(code, "9.9", binary=False)
    names = set(zipfile.ZipFile(io.BytesIO(data)).namelist())
    assert binary is None
    assert {"modelDescription.xml", "sources/only_src.c", "sources/only_src.h",
            "sources/fmi2.c"} <= names
    assert not any(n.startswith("binaries/") for n in names)
    path = tmp_path / "only_src.fmu"
    path.write_bytes(data)
    md = fmpy.read_model_description(str(path))
    xml = zipfile.ZipFile(io.BytesIO(data)).read("modelDescription.xml").decode()
    assert '<File name="only_src.c"/>' in xml and '<File name="fmi2.c"/>' in xml
    assert md.coSimulation.modelIdentifier == "only_src"
    assert md.generationTool == "hammerstein export 9.9"


def test_find_compiler_is_on_path_or_none():
    cc = find_compiler()
    assert cc is None or shutil.which(cc)


@needs_cc
@pytest.mark.skipif(platform_folder() is None, reason="unknown platform for an FMU binary")
def test_the_references_start_at_rest(tmp_path):
    """A model that rests away from 0 µm (an identified one carries the records' offset): the
    FMU's reference inputs start at its output at 0 V, so an importer that leaves them at their
    start values gets 0 V, not the step to 0 µm (14.65 V on a new user's stack)."""
    from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
    from hammerstein.compensation.drive import rest_output
    from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
    edges = np.linspace(-11.0, 11.0, 13)
    comps = [[PreisachModel.from_density(edges, total=8.0, tilt=0.3) if k == l else None
              for k in range(2)] for l in range(2)]
    comps[0][0] = PreisachModel(comps[0][0].edges, comps[0][0].weights, (1.5,), offset=2.0898)
    comps[1][1] = PreisachModel(comps[1][1].edges, comps[1][1].weights, (1.2,), offset=-0.75)
    model = MultivariableHysteresis(comps)
    rest = rest_output(model)
    assert np.abs(rest).min() > 0.1
    code = export_c(PreisachInverseCompensator(model), "rest_fmu", T)
    np.testing.assert_allclose(code.rest_reference, rest, rtol=0, atol=0)
    data, _ = build_fmu(code, "test")
    path = tmp_path / "rest_fmu.fmu"
    path.write_bytes(data)
    md = fmpy.read_model_description(str(path))
    starts = [float(v.start) for v in md.modelVariables if v.name.startswith("reference_")]
    np.testing.assert_array_equal(starts, rest)
    outs = [f"voltage_{nm}" for nm in code.input_names]
    res = fmpy.simulate_fmu(str(path), start_time=0.0, stop_time=50 * T, step_size=T,
                            output_interval=T, output=outs + ["status"])
    assert np.abs(np.vstack([res[o] for o in outs])).max() < 1e-9
    assert np.all(res["status"] == 0)
