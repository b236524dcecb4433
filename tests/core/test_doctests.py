"""The Examples sections of every module run and print what they say."""

import doctest
import importlib
import pkgutil
import warnings

import pytest

import hammerstein.cli
import hammerstein.core
import hammerstein.compensation
import hammerstein.identification
import hammerstein.io
import hammerstein.models
import hammerstein.report
import hammerstein.signals
import hammerstein.scenario
import hammerstein.simulation

PACKAGES = (hammerstein.core, hammerstein.models, hammerstein.io, hammerstein.signals,
            hammerstein.identification, hammerstein.compensation, hammerstein.simulation,
            hammerstein.scenario, hammerstein.report, hammerstein.cli)
MODULES = ["hammerstein.exceptions", "hammerstein.simulation", "hammerstein.runner"] + sorted(
    info.name for pkg in PACKAGES for info in pkgutil.iter_modules(pkg.__path__, pkg.__name__ + "."))


@pytest.mark.parametrize("name", MODULES)
def test_examples_run(name):
    module = importlib.import_module(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


@pytest.mark.parametrize("name", [
    "MultivariablePI", "simulate_chain", "InverseMultiplicativeCompensator",
    "PerAxisInverseCompensator", "StaticGainCompensator", "diagonal_compensator",
    "MultivariableIdentifier", "run_scenario"])
def test_main_objects_have_examples(name):
    import hammerstein
    examples = doctest.DocTestFinder(recurse=False).find(getattr(hammerstein, name))
    assert examples and examples[0].examples, name


def _public_examples():
    import hammerstein
    import inspect
    for name in hammerstein.__all__:
        obj = getattr(hammerstein, name)
        members = [obj] + ([m for _, m in inspect.getmembers(obj)
                            if (inspect.isfunction(m) or isinstance(m, property)) and m.__doc__]
                           if inspect.isclass(obj) else [])
        if any(">>> " in (m.__doc__ or "") for m in members):
            yield name


@pytest.mark.parametrize("name", list(_public_examples()))
def test_a_public_example_runs_as_help_shows_it(name):
    """An outside user copied examples from ``help(hammerstein.X)``: eight failed with a
    NameError (``triangle(1e-3, ...)``: name 'triangle' is not defined), the module's own
    names in scope only when the module's doctests ran them. Each runs here alone."""
    import inspect

    import hammerstein
    obj = getattr(hammerstein, name)
    members = [obj] + ([m for _, m in inspect.getmembers(obj)
                        if (inspect.isfunction(m) or isinstance(m, property)) and m.__doc__]
                       if inspect.isclass(obj) else [])
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    finder = doctest.DocTestFinder(recurse=False)
    for member in members:
        for test in finder.find(member, name, globs={}):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                failed = runner.run(test, out=lambda s: None).failed
            assert failed == 0, f"{name}: {test.name} fails in a fresh namespace"
