"""`hammerstein list` names, for each reference kind, the paper figures that use it.

Regression: it said "spiral (paper Fig. 13)" and "circle (paper Fig. 10-12)";
the bundled scenarios/paper/figNN-*.toml are the ground truth.
"""

import re
import tomllib
from pathlib import Path

from hammerstein.signals.references import DRIVE_KINDS, REFERENCE_KINDS

PAPER = Path(__file__).resolve().parents[2] / "scenarios" / "paper"


def _kinds(doc, key):
    found = set()
    for case in doc.get("cases", []) + doc.get("sweeps", []):
        if isinstance(case.get(key), dict):
            found.add(case[key]["kind"])
    return found


def _figures(description):
    m = re.search(r"paper Fig\. (\d+)(?:-(\d+))?", description)
    if not m:
        return set()
    first, last = int(m.group(1)), int(m.group(2) or m.group(1))
    return set(range(first, last + 1))


def test_every_figure_named_uses_the_kind():
    uses = {"reference": {}, "drive": {}}
    for path in PAPER.glob("fig*.toml"):
        number = int(re.match(r"fig(\d+)", path.stem).group(1))
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
        for key in uses:
            for kind in _kinds(doc, key):
                uses[key].setdefault(kind, set()).add(number)
    for key, kinds in (("reference", REFERENCE_KINDS), ("drive", DRIVE_KINDS)):
        for name, kind in kinds.items():
            named = _figures(kind.description)
            assert named <= uses[key].get(name, set()), (key, name, kind.description)
    assert _figures(REFERENCE_KINDS["spiral"].description) == {11}
    assert _figures(REFERENCE_KINDS["lissajous"].description) == {12, 13}
