"""Every `hammerstein.<module>[.<name>]` that README.md and docs/*.md name resolves.

Regression: after the move to hammerstein/core, scenario/, ... the docs still named
hammerstein.dynamics, hammerstein.hysteresis.play, ... which a user cannot import.
"""

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PATH = re.compile(r"`(hammerstein(?:\.[A-Za-z_]\w*)+)")


def _resolves(dotted):
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_dotted_paths_in_docs_import(doc):
    paths = sorted(set(PATH.findall(doc.read_text(encoding="utf-8"))))
    assert [p for p in paths if not _resolves(p)] == []
