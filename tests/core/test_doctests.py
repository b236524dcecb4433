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
