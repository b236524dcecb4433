"""The provenance mark names the version that wrote a file (pyproject.toml's, not "unknown")."""

import tomllib
from pathlib import Path

import pytest

from hammerstein.core.files import png_provenance, provenance_line

PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"


def _declared_version():
    return tomllib.loads(PYPROJECT.read_text())["project"]["version"]


@pytest.mark.parametrize("mark", [
    lambda: provenance_line("identify"),
    lambda: provenance_line("export", style="xml"),
    lambda: png_provenance("run")["Comment"],
])
def test_the_mark_names_the_installed_version(mark):
    # the package is installed (pip install -e .) from this pyproject.toml
    assert f" {_declared_version()}" in mark()
    assert "unknown" not in mark()
