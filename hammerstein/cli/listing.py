"""``hammerstein list [--scenarios DIR]``: bundled presets, compensator kinds, scenario files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.core.lti import dc_gain
from hammerstein.core.presets import PresetError, bundled_presets, load_plant, read_toml
from hammerstein.core.references import DRIVE_KINDS, REFERENCE_KINDS
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
    p.add_argument("--scenarios", default="scenarios", metavar="DIR",
                   help="directory searched for *.toml scenarios (default: ./scenarios)")
    p.set_defaults(handler=handler)


def _dynamics_summary(path):
    """``; dynamics: n states, DC gain [[..]]`` of a preset (reported, not forced to I)."""
    try:
        plant = load_plant(path)
    except PresetError as exc:
        return f"; invalid: {exc}"
    if plant.dynamics is None:
        return "; static (no dynamics)"
    gain = np.round(dc_gain(plant.dynamics), 4).tolist()
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
        Exit status, always 0.
    """
    print("presets:")
    for name, path in sorted(bundled_presets().items()):
        print(f"  {name}  ({path}){_dynamics_summary(path)}")
    print("compensator kinds:")
    for name, kind in COMPENSATORS.items():
        print(f"  {name}: {kind.description}")
    for title, kinds in (("reference kinds", REFERENCE_KINDS), ("drive kinds", DRIVE_KINDS)):
        print(f"{title}:")
        for name, kind in kinds.items():
            print(f"  {name}: {kind.description}")
    root = Path(args.scenarios)
    files = sorted(root.rglob("*.toml")) if root.is_dir() else []
    presets = [f for f in files if _is_preset(f)]
    scenarios = [f for f in files if f not in presets]
    print(f"scenarios under {root}/:" if scenarios else
          f"scenarios: none found under {root}/ (run from the repository root)")
    for f in scenarios:
        print(f"  {f}")
    if presets:
        print(f"preset and dynamics files under {root}/ (preset = \"<path>\", "
              f"dynamics = \"<path>\"):")
        for f in presets:
            print(f"  {f}{_dynamics_summary(f) if _is_full_preset(f) else '; dynamics only'}")
    return 0


def _is_full_preset(path):
    """True when the file has a ``[preset]`` table (a plant, not only dynamics)."""
    return "preset" in read_toml(path)


def _is_preset(path):
    """True for a preset (``[preset]``) or dynamics-only file, not a scenario."""
    try:
        doc = read_toml(path)
        return "preset" in doc or set(doc) == {"dynamics"}
    except PresetError:
        return False       # listed as a scenario: validate reports its problem
