"""Third-party modules loaded on first use (python-control): a run that needs none of them
does not pay their import (python-control pulls in scipy.signal, about 1 s).

:func:`lazy_module` is the recipe of the :mod:`importlib` documentation
("Implementing lazy imports", :class:`importlib.util.LazyLoader`): the module
object exists at once, its code runs on the first attribute access
(``control.ss``, ``isinstance(x, control.StateSpace)``).
"""

from __future__ import annotations

import importlib.util
import sys

__all__ = ["lazy_module"]


def lazy_module(name):
    """The module ``name``, executed on the first attribute access.

    Parameters
    ----------
    name : str
        Absolute module name, e.g. ``"control"``.

    Returns
    -------
    module
        ``sys.modules[name]`` when already imported; otherwise a lazy module
        registered there (a later ``import name`` returns it).

    Raises
    ------
    ModuleNotFoundError
        If the module is not installed.

    Examples
    --------
    >>> colorsys = lazy_module("colorsys")
    >>> colorsys.rgb_to_hsv(1.0, 0.0, 0.0)
    (0.0, 1.0, 1.0)
    """
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    loader.exec_module(module)
    return module
