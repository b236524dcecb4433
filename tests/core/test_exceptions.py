"""Every public error and warning of the package lives in hammerstein.exceptions.

The expectation is structural, derived from the package itself: every module
of hammerstein is imported, and every exception or warning class it exposes
under a public name must be defined in :mod:`hammerstein.exceptions` and derive
from HammersteinError / HammersteinWarning (while keeping its built-in base).
"""

import importlib
import inspect
import pkgutil

import pytest

import hammerstein
from hammerstein import exceptions


def _all_modules():
    names = ["hammerstein"]
    for info in pkgutil.walk_packages(hammerstein.__path__, "hammerstein."):
        if not info.name.endswith("__main__"):
            names.append(info.name)
    return [importlib.import_module(n) for n in names]


def _exposed_exception_classes():
    found = {}
    for module in _all_modules():
        for name, obj in vars(module).items():
            if (not name.startswith("_") and inspect.isclass(obj)
                    and issubclass(obj, BaseException)
                    and obj.__module__.startswith("hammerstein")):
                found.setdefault(obj, []).append(f"{module.__name__}.{name}")
    return found


def test_every_exposed_error_and_warning_is_defined_in_exceptions():
    found = _exposed_exception_classes()
    assert len(found) >= 15            # the package's errors and warnings were found
    for cls, where in found.items():
        assert cls.__module__ == "hammerstein.exceptions", (cls, where)
        if issubclass(cls, Warning):
            assert issubclass(cls, exceptions.HammersteinWarning), cls
            assert issubclass(cls, UserWarning), cls
        else:
            assert issubclass(cls, exceptions.HammersteinError), cls


@pytest.mark.parametrize("name", exceptions.__all__)
def test_exceptions_are_reexported_at_top_level(name):
    assert getattr(hammerstein, name) is getattr(exceptions, name)
    assert name in hammerstein.__all__


@pytest.mark.parametrize("name, builtin", [
    ("HysteresisError", ValueError), ("SignalError", ValueError),
    ("CompensatorError", ValueError), ("CompensatorDivergence", RuntimeError),
    ("DynamicsError", ValueError), ("PresetError", ValueError),
    ("IdentificationError", ValueError), ("DataFileError", ValueError),
    ("ScenarioError", ValueError), ("BaselineError", ValueError), ("Invalid", ValueError),
    ("ConvergenceWarning", UserWarning), ("RangeWarning", UserWarning)])
def test_builtin_bases_are_kept(name, builtin):
    assert issubclass(getattr(exceptions, name), builtin)


def test_names_stay_importable_from_their_former_modules():
    from hammerstein.compensation.compensators import CompensatorDivergence, RangeWarning
    from hammerstein.models.hysteresis import HysteresisError
    from hammerstein.scenario.regression import BaselineError
    from hammerstein.scenario.schema import ScenarioError
    assert CompensatorDivergence is exceptions.CompensatorDivergence
    assert RangeWarning is exceptions.RangeWarning
    assert HysteresisError is exceptions.HysteresisError
    assert BaselineError is exceptions.BaselineError
    assert ScenarioError is exceptions.ScenarioError


def test_one_except_clause_catches_the_package_errors():
    with pytest.raises(exceptions.HammersteinError, match="thresholds"):
        hammerstein.PrandtlIshlinskii([1.0, 0.5], [1.0, 1.0])
    div = exceptions.CompensatorDivergence(7, "the input voltage became non-finite")
    assert div.sample == 7 and "sample 7" in str(div)
    err = exceptions.ScenarioError(["a.toml: x: expected a number", "a.toml: y: unknown"])
    assert err.problems == ["a.toml: x: expected a number", "a.toml: y: unknown"]
    assert str(err).splitlines() == err.problems
