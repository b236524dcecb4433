"""Fixtures shared by the whole suite (one build of the bundled preset per session).

The bundled preset is the paper's 2-DOF piezocantilever: the de-garbled
multivariable PI of eq. (13) with (``preset_plant``) or without
(``static_plant``) the bending modes. Tests must not modify these objects.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hammerstein import load_plant

#: the repository root (scenarios/, baselines/, tests/corpus/ live below it)
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def repo_root():
    """The repository root directory."""
    return ROOT


@pytest.fixture(scope="session")
def static_plant():
    """The bundled preset without dynamics: the rate-independent 2x2 PI."""
    return load_plant("rakotondrabe-2dof", dynamics=False)


@pytest.fixture(scope="session")
def preset_plant():
    """The bundled preset with its bending modes: the Hammerstein actuator."""
    return load_plant("rakotondrabe-2dof", dynamics=True)
