"""``hammerstein list [--scenarios DIR]``: bundled presets, compensator kinds, scenario files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.core.lti import dc_gain
from hammerstein.core.presets import PresetError, bundled_presets, load_plant, read_toml
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
        not a directory); files with a ``[preset]`` table there are listed
        as preset files (dynamics and DC gain), files with only a
        ``[dynamics]`` table as dynamics files.

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
    root = Path(args.scenarios)
    files = sorted(root.rglob("*.toml")) if root.is_dir() else []
    kinds = {f: _model_file_kind(f) for f in files}   # preset/dynamics files are not scenarios
    others = [f for f in files if kinds[f]]
    files = [f for f in files if not kinds[f]]
    if others:
        print(f"preset and dynamics files under {root}/:")
        for f in others:
            print(f"  {f}{_dynamics_summary(f) if kinds[f] == 'preset' else kinds[f]}")
    print(f"scenarios under {root}/:" if files else
          f"scenarios: none found under {root}/ (run from the repository root)")
    for f in files:
        print(f"  {f}")
    return 0


def _model_file_kind(path):
    """``"preset"`` ([preset] table), ``"; dynamics file ..."`` (a [dynamics] table and no
    scenario keys), or ``""`` (a scenario, or unreadable: left to ``validate``)."""
    try:
        doc = read_toml(path)
    except PresetError:
        return ""
    if isinstance(doc.get("preset"), dict):
        return "preset"
    if isinstance(doc.get("dynamics"), dict) and not {"cases", "sweeps", "stability_map",
                                                       "data", "plant"} & set(doc):
        return '; dynamics file ([compensator] dynamics = "<path>")'
    return ""
