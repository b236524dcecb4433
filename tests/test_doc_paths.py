"""Every `hammerstein.<module>[.<name>]` named in README.md, docs/*.md and the package resolves.

Regression: after the move to hammerstein/core, scenario/, ... the docs and 23
docstrings still named hammerstein.dynamics, hammerstein.inverse,
hammerstein.scenarios.CaseSpec, hammerstein.presets.save_model, ... which a
user cannot import. A dotted name resolves when importlib imports its longest
module prefix and getattr reaches the rest (a dataclass field counts).
"""

import dataclasses
import importlib
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SOURCES = sorted((ROOT / "hammerstein").rglob("*.py"))
PATH = re.compile(r"`(hammerstein(?:\.[A-Za-z_]\w*)+)")
# any mention in a module's text (docstrings, comments, :func: roles), not a file name
NAMED = re.compile(r"(?<![\w./-])(hammerstein(?:\.[A-Za-z_]\w*)+)")
#: Dotted names that are not Python paths: the JUnit class name ``hammerstein check`` writes,
#: the logger the identification cache reports on.
NOT_PATHS = {"hammerstein.check", "hammerstein.cache"}


def _resolves(dotted):
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if hasattr(obj, name):
                obj = getattr(obj, name)
            elif dataclasses.is_dataclass(obj) and name in {f.name for f in dataclasses.fields(obj)}:
                obj = None  # an instance attribute: nothing further to reach
            else:
                return False
        return True
    return False


@pytest.mark.parametrize("dotted, expected", [
    ("hammerstein.io.presets.save_model", True),
    ("hammerstein.scenario.validate.CaseSpec.identified", True),     # a dataclass field
    ("hammerstein.presets.save_model", False),                       # a module that moved
    ("hammerstein.io.presets.no_such_function", False),
    ("hammerstein.inverse", False),
])
def test_the_resolver_tells_moved_names_from_real_ones(dotted, expected):
    assert _resolves(dotted) is expected


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_dotted_paths_in_docs_import(doc):
    paths = sorted(set(PATH.findall(doc.read_text(encoding="utf-8"))))
    assert [p for p in paths if not _resolves(p)] == []


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_dotted_name_in_docs_resolves(doc):
    names = set(NAMED.findall(doc.read_text(encoding="utf-8"))) - NOT_PATHS
    assert sorted(p for p in names if not _resolves(p)) == []


def test_every_dotted_name_in_the_package_resolves():
    stale = {}
    for path in SOURCES:
        for name in set(NAMED.findall(path.read_text(encoding="utf-8"))) - NOT_PATHS:
            if not _resolves(name):
                stale.setdefault(name, []).append(str(path.relative_to(ROOT)))
    assert stale == {}


TOML_BLOCK = re.compile(r"^```toml\n(.*?)^```", re.S | re.M)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_toml_example_in_docs_parses(doc):
    """A user copies these into a scenario: docs/models-and-kinds.md's records example was a
    multi-line inline table, which TOML 1.0 (tomllib) refuses ("Unclosed inline table")."""
    text = doc.read_text(encoding="utf-8")
    bad = []
    for m in TOML_BLOCK.finditer(text):
        try:
            tomllib.loads(m.group(1))
        except tomllib.TOMLDecodeError as exc:
            bad.append(f"line {text[:m.start()].count(chr(10)) + 1}: {exc}")
    assert bad == []
