"""Fixtures shared by the whole suite (one build of the bundled preset per session).

The bundled preset is the paper's 2-DOF piezocantilever: the de-garbled
multivariable PI of eq. (13) with (``preset_plant``) or without
(``static_plant``) the bending modes. Tests must not modify these objects.
"""

from __future__ import annotations

import os

# One OpenBLAS thread, as the CLI runs it (README "Performance"), set before numpy is
# imported: the identifications' least squares are small, and OpenBLAS threads spinning
# on a busy 2-core machine tripled their CPU time (tests/core/test_lti.py and
# tests/cli/test_identify_dynamics.py: 24-29 s of CPU with the default threads, 9-10 s
# with one). A value the user sets is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from hammerstein import InverseMultiplicativeCompensator, load_plant  # noqa: E402
from hammerstein import simulation as sim  # noqa: E402

#: the repository root (scenarios/, baselines/, tests/corpus/ live below it)
ROOT = Path(__file__).resolve().parents[1]

# Hermetic runs: no identification comes from (or goes to) the user's on-disk cache,
# in this process and in the CLI subprocesses the tests start. The cache's own tests
# point it at a temporary directory.
os.environ["HAMMERSTEIN_CACHE_DIR"] = "off"
# Scenario files may name files only under their own directory (core/files.py
# confined_path); the corpus reaches ../models and /dev/zero, and some tests name files
# of another temporary directory. The confinement's own tests remove this variable.
os.environ["HAMMERSTEIN_ALLOW_PATHS"] = os.pathsep.join(
    [str(ROOT / "tests" / "corpus"), "/dev", tempfile.gettempdir()])


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


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Compile (or load from numba's cache) every simulation kernel once, up front.

    On a fresh clone numba's cache is empty and the CLI announces each compilation
    with one stderr line ("compiling the simulation kernels once, ..."). Tests that
    count stderr lines would otherwise see that line in whichever test happens to
    compile first; compiling here, outside any CLI run, keeps them deterministic.
    """
    plant = load_plant("rakotondrabe-2dof", dynamics=True)
    static = load_plant("rakotondrabe-2dof", dynamics=False)
    model = plant.hysteresis
    u = np.zeros((model.n_inputs, 8))
    sim.simulate_plays(np.zeros(8), np.array([0.0, 0.5]), np.zeros(2))
    sim.simulate_hysteresis(model, u)
    sim.simulate_plant(plant, u)
    comp = InverseMultiplicativeCompensator(model)
    yr = np.zeros((model.n_outputs, 8))
    sim.simulate_compensator(comp, yr)
    sim.simulate_chain(comp, plant, yr)
    sim.simulate_chain(comp, static, yr)
    for parallel in (False, True):
        sim.simulate_chain_batch([comp, comp], [plant, static], [yr, yr], parallel=parallel)
