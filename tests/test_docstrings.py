"""Every public function, class and method documents its interface (numpydoc).

The python-control ``docstrings_test.py`` idea with numpydoc's own validator:
each public callable of every public module of the package must document every
parameter it takes (PR01) and no parameter it does not take (PR02), have a
Returns section when it returns a value (RT01), and a Raises section when its
own body raises (checked here from the source, numpydoc has no such rule).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import pytest

numpydoc_validate = pytest.importorskip("numpydoc.validate")

import hammerstein  # noqa: E402

CHECKED = ("PR01", "PR02", "RT01")
_RAISE = re.compile(r"^\s+raise [A-Z]\w*\(", re.M)


def _public_modules():
    for info in pkgutil.walk_packages(hammerstein.__path__, "hammerstein."):
        if any(part.startswith("_") for part in info.name.split(".")[1:]):
            continue
        yield info.name


def _public_objects(module_name):
    """Objects a public module defines, and those its ``__all__`` re-exports
    from private implementation modules (e.g. ``hammerstein.simulation``)."""
    module = importlib.import_module(module_name)
    for name, obj in sorted(vars(module).items()):
        if name.startswith("_"):
            continue
        home = getattr(obj, "__module__", None) or ""
        if home == module_name:
            yield home, name, obj
        elif (name in getattr(module, "__all__", ()) and home.startswith(module_name + ".")
              and any(part.startswith("_") for part in home.split("."))):
            yield home, name, obj


def _public_callables():
    seen = set()
    for module_name in _public_modules():
        for home, name, obj in _public_objects(module_name):
            if (home, name) in seen:
                continue
            seen.add((home, name))
            module_name = home
            if inspect.isfunction(obj):
                yield f"{module_name}.{name}", obj
            elif inspect.isclass(obj):
                yield f"{module_name}.{name}", obj
                for attr, member in sorted(vars(obj).items()):
                    if attr.startswith("_") or not inspect.isfunction(member):
                        continue
                    yield f"{module_name}.{name}.{attr}", member


CALLABLES = list(_public_callables())


def test_the_walk_finds_the_public_api():
    names = {n for n, _ in CALLABLES}
    for expected in ("hammerstein.models.hysteresis.MultivariablePI",
                     "hammerstein.simulation.simulate_chain",
                     "hammerstein.runner.run_scenario"):
        assert any(n.endswith("." + expected.rsplit(".", 1)[1]) for n in names), expected


@pytest.mark.parametrize("name,obj", CALLABLES, ids=[n for n, _ in CALLABLES])
def test_docstring_documents_the_interface(name, obj):
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        pytest.skip("exception classes take a message only")
    result = numpydoc_validate.validate(name)
    problems = [f"{code}: {msg}" for code, msg in result["errors"] if code in CHECKED]
    doc = inspect.getdoc(obj) or ""
    if not inspect.isclass(obj):
        try:
            source = inspect.getsource(obj)
        except (OSError, TypeError):
            source = ""
        body = source.split('"""', 2)[-1] if source.count('"""') >= 2 else source
        if _RAISE.search(body) and not re.search(r"^Raises\n-+$", doc, re.M):
            problems.append("RS01: raises but has no Raises section")
    assert not problems, f"{name}: " + "; ".join(problems)
