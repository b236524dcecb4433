"""Module sizes: a room for each concern.

No module of the package is longer than 1000 lines, and one longer than 800
lines says why at the top: a line starting with ``Length:`` in its module
docstring (read with :func:`ast.get_docstring`, independent of the code it
describes).
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "hammerstein"
MODULES = sorted(PACKAGE.rglob("*.py"))
HARD_LIMIT = 1000
REASON_LIMIT = 800


def _lines(path):
    return len(path.read_text(encoding="utf-8").splitlines())


def _size_problem(path):
    """Why ``path`` breaks the rule (one line), or None."""
    n = _lines(path)
    if n > HARD_LIMIT:
        return f"{path.name}: {n} lines; split it by concept"
    if n > REASON_LIMIT:
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
        if not any(line.startswith("Length:") for line in doc.splitlines()):
            return f"{path.name}: {n} lines and no 'Length:' line giving the reason in its docstring"
    return None


def test_the_package_is_found():
    assert len(MODULES) > 50 and (PACKAGE / "__init__.py") in MODULES


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_over_1000_lines_and_a_reason_above_800(path):
    assert _size_problem(path) is None, _size_problem(path)


def test_the_rule_catches_a_long_module_without_a_reason(tmp_path):
    """The rule on synthetic modules: 900 lines fail without a reason and pass with one; 1005 fail."""
    body = "x = 1\n" * 900
    bare, reasoned = tmp_path / "bare.py", tmp_path / "reasoned.py"
    bare.write_text('"""A module."""\n' + body)
    reasoned.write_text('"""A module.\n\nLength: generated table.\n"""\n' + body)
    long = tmp_path / "long.py"
    long.write_text('"""A module.\n\nLength: generated table.\n"""\n' + "x = 1\n" * 1001)
    assert "no 'Length:' line" in _size_problem(bare)
    assert _size_problem(reasoned) is None
    assert "1005 lines; split it" in _size_problem(long)
