"""The package's version, one constant (behind :mod:`hammerstein.core.files` and the package).

``pyproject.toml``'s ``[project] version`` and :data:`VERSION` are the same string (a
test holds it). Every file the project writes names it (the provenance line, a
report's marker, a learning's state file): read from here it is also right for a
source tree on ``sys.path`` that is not installed, where the installed
distribution's metadata is absent (files said "unknown") or another copy's.
"""

from __future__ import annotations

__all__ = ["VERSION"]

#: the version of this source tree
VERSION = "0.1.0"
