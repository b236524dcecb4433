"""Layering and weight of the core: what each layer imports, and when.

Expectations come from the architecture (exceptions < simulation < core < models < io <
signals < identification < compensation < scenario < report < runner < cli):
the modules' import statements are read with ``ast`` and fresh interpreters
show which third-party packages a given use loads.
"""

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "hammerstein"
HEAVY = ("numpy", "numba", "control", "pandas", "scipy", "matplotlib", "tqdm")


def _imports(path):
    """(module imported, inside a function?) for every import statement of a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []

    def visit(node, in_function):
        for child in ast.iter_child_nodes(node):
            inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
            if isinstance(child, ast.Import):
                out.extend((a.name, inner) for a in child.names)
            elif isinstance(child, ast.ImportFrom) and child.level == 0:
                out.append((child.module, inner))
            visit(child, inner)

    visit(tree, False)
    return out


#: The layers below the scenario engine, lowest first: a module may import its own layer
#: and the layers before it, never one after it (each sub-package's docstring says so).
LAYERS = ("exceptions", "simulation", "core", "models", "io", "signals", "identification",
          "compensation")
#: leaf modules any layer may import (``_cache`` sets numba's cache before numba loads)
LEAVES = ("hammerstein.exceptions", "hammerstein._cache")


def _files(layer):
    return sorted((PACKAGE / layer).glob("*.py"))


def _layer_of(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_simulation_never_imports_core_or_higher_layers():
    for path in _files("simulation"):
        for module, _ in _imports(path):
            if module.startswith("hammerstein"):
                assert (module in LEAVES
                        or module.startswith("hammerstein.simulation")), (path.name, module)


@pytest.mark.parametrize("layer", LAYERS[2:])
def test_each_layer_imports_only_downward(layer):
    allowed = LAYERS[:LAYERS.index(layer) + 1]
    assert _files(layer), layer
    for path in _files(layer):
        for module, _ in _imports(path):
            if module.startswith("hammerstein.") and module not in LEAVES:
                assert _layer_of(module) in allowed, (layer, path.name, module)


@pytest.mark.parametrize("layer", LAYERS[1:])
def test_no_function_level_imports_of_the_package(layer):
    for path in _files(layer):
        inner = [m for m, in_function in _imports(path) if in_function and m.startswith("hammerstein")]
        assert inner == [], (path.name, inner)


def test_no_package_directory_holds_more_than_30_percent_of_the_lines():
    def lines(d):
        return sum(len(f.read_text(encoding="utf-8").splitlines()) for f in d.rglob("*.py"))
    total = lines(PACKAGE)
    for d in PACKAGE.iterdir():
        if d.is_dir() and (d / "__init__.py").exists():
            assert lines(d) <= 0.30 * total, (d.name, lines(d), total)


def _fresh(code):
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=PACKAGE.parent, timeout=300)
    return json.loads(res.stdout.strip().splitlines()[-1])


# One fresh interpreter goes through five steps, each a snapshot of what it has loaded:
# `import hammerstein`, then one name of the lazy face, then the core used with matplotlib
# and tqdm made unimportable (they are not loaded yet: the second snapshot says so), then a
# bundled preset with its bending modes simulated (python-control still not loaded), then a
# ZPETC Hammerstein compensator of that preset's own dynamics run on it (still not loaded).
_STEPS = """
import json, sys
heavy = set(%r)
def loaded():
    return sorted({k.split('.')[0] for k in sys.modules} & heavy)
snapshots = {}
import hammerstein
snapshots["import hammerstein"] = loaded()
from hammerstein import MultivariablePI
snapshots["MultivariablePI"] = loaded()
sys.modules["matplotlib"] = None          # importing them now raises ImportError
sys.modules["tqdm"] = None
import numpy as np
from hammerstein import (HammersteinPlant, InverseMultiplicativeCompensator, MultivariablePI,
                         PrandtlIshlinskii, simulate_chain)
model = MultivariablePI([[PrandtlIshlinskii([0.0, 1.0], [1.0, 0.5]), 0.05],
                         [None, PrandtlIshlinskii([0.0, 2.0], [1.0, 0.3])]],
                        input_amplitude=[10.0, 10.0])
reference = np.vstack([np.linspace(0, 4, 50), np.linspace(0, -3, 50)])
result = simulate_chain(InverseMultiplicativeCompensator(model), HammersteinPlant(model, 1e-4),
                        reference)
snapshots["tracking error"] = float(np.max(np.abs(result.outputs - reference)))
from hammerstein.io.presets import load_plant
plant = load_plant("rakotondrabe-2dof", dynamics=True)
y, _ = plant.simulate(np.zeros((2, 50)))
snapshots["preset plant simulated"] = [type(sys.modules.get("control")).__name__,
                                       "scipy.signal" in sys.modules]
from hammerstein import HammersteinCompensator
comp = HammersteinCompensator(plant.hysteresis, plant.sampled_dynamics)
t = np.arange(1200) * plant.sampling_period          # 3 periods, the first faded in
sine = np.vstack([10.0 * np.sin(2 * np.pi * 50.0 * t), np.zeros_like(t)])
res = comp.run_reference(plant, sine, period_samples=400, fade_samples=400)
snapshots["zpetc compensator run"] = [type(sys.modules.get("control")).__name__,
                                      "scipy.signal" in sys.modules,
                                      float(np.max(np.abs(res.outputs[:, 800:] - sine[:, 800:])))]
print(json.dumps(snapshots))
""" % (HEAVY,)


@pytest.fixture(scope="module")
def fresh_steps():
    return _fresh(_STEPS)


def test_import_hammerstein_loads_no_third_party_package(fresh_steps):
    assert fresh_steps["import hammerstein"] == []


def test_lazy_face_loads_what_a_name_needs(fresh_steps):
    loaded = fresh_steps["MultivariablePI"]
    assert "numpy" in loaded
    assert not {"control", "pandas", "matplotlib", "tqdm"} & set(loaded)


def test_every_public_name_resolves_and_dir_lists_it():
    import hammerstein
    for name in hammerstein.__all__:
        assert getattr(hammerstein, name) is not None, name
    assert set(hammerstein.__all__) <= set(dir(hammerstein))
    with pytest.raises(AttributeError, match="no_such_name"):
        hammerstein.no_such_name


def test_core_runs_without_matplotlib_and_tqdm(fresh_steps):
    # the compensator inverts its own model: the static plant tracks the ramp
    assert fresh_steps["tracking error"] < 0.5


def test_simulating_a_preset_plant_does_not_import_python_control(fresh_steps):
    # the preset's modes are simulated from its state-space matrices: python-control stays
    # the lazy module the package installs, scipy.signal is never imported
    assert fresh_steps["preset plant simulated"] == ["_LazyModule", False]


def test_a_zpetc_compensator_of_a_plants_own_dynamics_does_not_import_python_control(fresh_steps):
    # the ZPETC inverse is designed from the SampledSystem's matrices (numpy and scipy.linalg):
    # python-control and scipy.signal (~1 s of imports) stay unloaded; the inverse works: a
    # 10 um, 50 Hz sine (the modes at ~300 Hz) is tracked in its last period to 0.02 um,
    # where the rate-independent compensator, blind to the modes' phase lag, leaves 0.7 um
    control_type, signal_loaded, error = fresh_steps["zpetc compensator run"]
    assert (control_type, signal_loaded) == ("_LazyModule", False)
    assert error < 0.1


def test_the_hardware_commands_and_validation_do_not_load_python_control():
    # python-control and scipy.signal take ~1 s of CPU to import: commands that do not
    # re-sample or design a loop (validate, compensate's checks, feedback tables) must not
    # load them (a feedback controller module imported them at module level)
    loaded = _fresh("import json, sys\n"
                    "import hammerstein.cli.compensate, hammerstein.cli.learn\n"
                    "import hammerstein.scenario.validate, hammerstein.scenario.feedback\n"
                    "print(json.dumps(['control.statesp' in sys.modules, "
                    "'scipy.signal' in sys.modules]))")
    assert loaded == [False, False]
