"""``hammerstein list [--scenarios DIR]``: bundled presets, compensator kinds, scenario files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.cli._common import print_err
from hammerstein.core.files import escape
from hammerstein.models.lti import dc_gain
from hammerstein.io.presets import PresetError, bundled_presets, load_model, load_plant, read_toml
from hammerstein.signals.references import DRIVE_KINDS, REFERENCE_KINDS
from hammerstein.exceptions import HammersteinError
from hammerstein.compensation.model_classes import MODEL_CLASSES
from hammerstein.scenario.registry import COMPENSATORS

__all__ = ["add_parser", "handler"]

HELP = "list bundled presets, compensator kinds and scenarios"


def add_parser(subparsers):
    """Register `hammerstein list [--scenarios DIR]`: presets, compensator kinds and scenario files.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "list", help=HELP,
        description="List the bundled actuator presets, the compensator kinds and the "
                    "scenario files under DIR (default ./scenarios).")
    p.add_argument("--scenarios", default=None, metavar="DIR",
                   help="directory searched for *.toml scenarios (default: ./scenarios)")
    p.set_defaults(handler=handler)


def _dynamics_summary(path):
    """``; dynamics: n states, DC gain [[..]]`` of a preset (reported, not forced to I)."""
    try:
        plant = load_plant(path)
    except PresetError as exc:
        return f"; invalid: {exc}"
    except (HammersteinError, ValueError, TypeError, ArithmeticError) as exc:
        # one file the loader did not foresee is marked, the listing goes on
        return f"; invalid: {path}: {exc}"
    if plant.dynamics is None:
        return "; static (no dynamics)"
    gain = (np.round(dc_gain(plant.dynamics), 4) + 0.0).tolist()      # + 0.0: no "-0.0"
    return f"; dynamics: {plant.dynamics.nstates} states, DC gain {gain}"


def handler(args):
    """Print the presets, the compensator kinds and the scenario files; exit status 0.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments; ``args.scenarios`` is the directory searched
        recursively for ``*.toml`` scenario files (none listed when it is
        not a directory).

    Returns
    -------
    int
        Exit status: 0; 1 when ``--scenarios`` names no directory (printed on
        stderr before anything else; without it, ``./scenarios`` may be absent).
    """
    given = args.scenarios is not None
    root = Path(args.scenarios if given else "scenarios")
    if given and not root.is_dir():
        print_err(f"hammerstein list: error: --scenarios: {escape(str(root))}: "
                  f"{'not a directory' if root.exists() else 'no such directory'}")
        return 1
    print("presets:")
    for name, path in sorted(bundled_presets().items()):
        print(f"  {name}  ({path}){_dynamics_summary(path)}")
    print("compensator kinds:")
    for name, kind in COMPENSATORS.items():
        print(f"  {name}: {kind.description}")
    print("model classes and the compensator kinds that work with them (default: the "
          "first rule that applies; docs/models-and-kinds.md):")
    for name, entry in MODEL_CLASSES.items():
        print(f"  {name}: {entry.description}")
        dyn = [k for k in ("hammerstein", "ilc") if k in entry.kinds]
        need = f" ({' and '.join(dyn)} need{'s' if len(dyn) == 1 else ''} dynamics" if dyn else ""
        # a Monte-Carlo study refuses ilc (one drive for every drawn plant): said here too
        need += ("; ilc learns in [[cases]], not in a Monte-Carlo study)" if "ilc" in entry.kinds
                 else ")" if dyn else "")
        print(f"    kinds: {', '.join(entry.kinds)}{need}")
        exact = (f"else {entry.exact_inverse_kind} (exact inverse)" if entry.exact_inverse_kind
                 else "else per-axis for one transfer, multivariable with a convergent gain, "
                      "per-axis when none converges")
        print(f"    default: hammerstein with dynamics, {exact}")
    for title, kinds in (("reference kinds", REFERENCE_KINDS), ("drive kinds", DRIVE_KINDS)):
        print(f"{title}:")
        for name, kind in kinds.items():
            print(f"  {name}: {kind.description}")
    files = sorted(root.rglob("*.toml")) if root.is_dir() else []
    kinds = {f: _file_kind(f) for f in files}
    presets = [f for f in files if kinds[f] in ("preset", "dynamics")]
    models = [f for f in files if kinds[f] == "model"]
    scenarios = [f for f in files if kinds[f] == "scenario"]
    print(f"scenarios under {root}/:" if scenarios else
          f"scenarios: none found under {root}/ (run from the repository root)")
    for f in scenarios:
        print(f"  {f}")
    if presets:
        print(f"preset and dynamics files under {root}/ (preset = \"<path>\", "
              f"dynamics = \"<path>\"):")
        for f in presets:
            print(f"  {f}{_dynamics_summary(f) if kinds[f] == 'preset' else '; dynamics only'}")
    if models:
        print(f"model files under {root}/ (model = \"<path>\"):")
        for f in models:
            print(f"  {f}{_model_summary(f)}")
    return 0


#: top-level tables a saved file may carry beside its content (``identify --out``, saved models)
_SIDE_TABLES = {"identification", "amplifier", "creep"}


def _file_kind(path):
    """What a ``*.toml`` file is: ``'preset'``, ``'dynamics'``, ``'model'`` or ``'scenario'``.

    A preset has a ``[preset]`` table; a dynamics file only ``[dynamics]``, a
    model file (``identify --out``, a saved identified model) ``[model]``
    and maybe ``[dynamics]`` (each maybe with its ``[identification]``
    record, the ``[amplifier]`` limits and the ``[creep]`` identify writes); anything
    else, and a file that does not parse, is a scenario (``validate``
    reports its problem).
    """
    try:
        doc = read_toml(path)
    except PresetError:
        return "scenario"
    keys = set(doc) - _SIDE_TABLES
    if "preset" in doc:
        return "preset"
    if keys == {"dynamics"}:
        return "dynamics"
    if "model" in keys and keys <= {"model", "dynamics"}:
        return "model"
    return "scenario"


def _model_summary(path):
    """``; 2x2 PI (...), 60 hysterons`` of a model file, or why it does not load."""
    try:
        model = load_model(path)
    except HammersteinError as exc:
        return f"; invalid: {exc}"
    return f"; {model.size_text()}"
