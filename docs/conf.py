"""Sphinx configuration of the hammerstein documentation.

Build (from the repository root, with ``pip install -e '.[docs]'``)::

    python -m sphinx -W -b html docs docs/_build/html

The chapters are the Markdown pages of this directory (myst-parser), the
example gallery runs the scripts of ``examples/`` (sphinx-gallery) and the API
reference is generated from the docstrings of the names ``hammerstein``
exports (autosummary + numpydoc); ``api.rst`` is written here, from
``hammerstein.__all__``, on every build.
"""

from __future__ import annotations

import collections
import re
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import hammerstein  # noqa: E402

project = "hammerstein"
author = "the hammerstein authors"
copyright = "the hammerstein authors, MIT licence"
release = version = hammerstein.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.md5", "auto_examples/*.codeobj.json"]
templates_path = []

# -- Markdown chapters ------------------------------------------------------------------
myst_heading_anchors = 4          # [text](page.md#a-heading) links between the chapters
myst_enable_extensions = ["colon_fence"]
myst_fence_as_directive = ["math"]   # GitHub's ```math blocks are the pages' displayed equations
# Links from a chapter to a file of the repository outside docs/ (a scenario, a
# benchmark) are not pages of the site: they stay plain text in the chapters.
suppress_warnings = ["myst.header"]

# -- API reference ----------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks = set()   # the docstring test (tests/test_docstrings.py) checks them

intersphinx_mapping = {}

# -- Example gallery --------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "image_scrapers": ("matplotlib",),
}

# -- HTML -------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"hammerstein {release}"
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path = []
html_show_sourcelink = False


def _write_api_page():
    """``api.rst``: every name of ``hammerstein.__all__``, grouped by the module defining it."""
    groups = collections.OrderedDict()
    exceptions = []
    for name in sorted(hammerstein.__all__):
        if name.startswith("_"):
            continue
        module = hammerstein._LAZY.get(name)
        if module is None:
            exceptions.append(name)
            continue
        groups.setdefault(module, []).append(name)
    lines = ["API reference", "=============", "",
             "Every name below is importable from ``hammerstein`` itself "
             "(``import hammerstein as hs; hs.load_plant(...)``); each is loaded "
             "on first use. The section titles name the module that defines it.", ""]
    for module in sorted(groups):
        lines += [f"``{module}``", "-" * (len(module) + 4), "",
                  ".. currentmodule:: hammerstein", "",
                  ".. autosummary::", "   :toctree: generated", ""]
        lines += [f"   {name}" for name in groups[module]] + [""]
    lines += ["Errors and warnings", "-------------------", "",
              ".. currentmodule:: hammerstein", "",
              ".. autosummary::", "   :toctree: generated", ""]
    lines += [f"   {name}" for name in exceptions] + [""]
    text = "\n".join(lines)
    path = HERE / "api.rst"
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


_write_api_page()

_LITERAL = re.compile(r"(``.*?``|`[^`]*`_{0,2})")


def _plain_text_docstring(app, what, name, obj, options, lines):
    """Docstrings are written to read well in a terminal (``help()``); make the few
    plain-text habits that reStructuredText reads as markup literal: a fitted
    attribute's trailing underscore (``order_``, a reference in rst), ``|x|``
    (a substitution) and a citation ``[1]_`` of the paper whose target lives in
    the module's docstring, not the object's."""
    text = "\n".join(lines)
    cites = {n for n in re.findall(r"\[(\d+)\]_", text) if f".. [{n}]" not in text}
    for i, line in enumerate(lines):
        parts = _LITERAL.split(line)
        for j in range(0, len(parts), 2):          # the text outside literals and roles
            seg = parts[j]
            for n in cites:
                seg = seg.replace(f"[{n}]_", f"[{n}]")
            seg = re.sub(r"(?<=\w)_(?=[^\w`]|$)", r"\\_", seg)
            seg = re.sub(r"\|([^|\s][^|]*)\|", r"\\|\1\\|", seg)
            parts[j] = seg
        lines[i] = "".join(parts)


def setup(app):
    app.connect("autodoc-process-docstring", _plain_text_docstring, priority=100)
