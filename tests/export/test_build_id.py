"""A header and a source of two export runs do not compile together (NAME_BUILD_ID)."""

from __future__ import annotations

import subprocess
import warnings

from hammerstein.export import export_c
from hammerstein.export.build import compensator_from_source, load_source

from conftest import COMPILERS, needs_cc


def _code(kind):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp, T = compensator_from_source(load_source("rakotondrabe-2dof"), kind)
    return export_c(comp, "act", T)


def _compile(tmp_path, header, source):
    (tmp_path / "act.h").write_text(header)
    (tmp_path / "act.c").write_text(source)
    return subprocess.run([COMPILERS[0], "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                           "-c", str(tmp_path / "act.c"), "-o", str(tmp_path / "act.o")],
                          capture_output=True, text=True)


@needs_cc
def test_a_header_of_another_run_is_a_compile_error(tmp_path):
    a, b = _code("multivariable"), _code("per-axis")
    assert "#define act_BUILD_ID" in a.header and a.header != b.header
    assert _compile(tmp_path, a.header, a.source).returncode == 0
    res = _compile(tmp_path, b.header, a.source)
    assert res.returncode != 0 and "not the header exported with this act.c" in res.stderr
