"""The Examples of hammerstein.export run (tests/core/test_doctests.py covers the other packages)."""

import doctest
import importlib
import pkgutil
import warnings

import pytest

import hammerstein.export

MODULES = ["hammerstein.export", "hammerstein.cli.export"] + sorted(
    info.name for info in pkgutil.iter_modules(hammerstein.export.__path__, "hammerstein.export."))


@pytest.mark.parametrize("name", MODULES)
def test_examples_run(name):
    module = importlib.import_module(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


def test_export_c_has_an_example():
    examples = doctest.DocTestFinder(recurse=False).find(hammerstein.export.export_c)
    assert examples and examples[0].examples
