"""One meaning per option name across the subcommands.

Regression: `--inputs` meant input columns (identify), input names
(excitation) and a NAME=COL map of CSV columns (compensate, evaluate, learn).
The map is now `--input-columns` / `--output-columns`; `--inputs` / `--outputs`
name the actuator's inputs and outputs (in identify, by the columns that hold
them) and still parse as the old spelling of the map, hidden from --help.
"""

import argparse

from hammerstein.cli.main import build_parser


def _subparsers():
    parser = build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices


def test_each_visible_option_has_one_metavar_across_commands():
    seen = {}
    for command, sub in _subparsers().items():
        for action in sub._actions:
            if action.help == argparse.SUPPRESS:
                continue
            for option in action.option_strings:
                if option in ("--inputs", "--outputs", "--input-columns", "--output-columns"):
                    seen.setdefault(option, {})[command] = action.metavar
    for option in ("--input-columns", "--output-columns"):
        assert set(seen[option].values()) == {"NAME=COL,..."}, seen[option]
    assert all(m != "NAME=COL,..." for o in ("--inputs", "--outputs")
               for m in seen.get(o, {}).values()), seen


def test_the_old_spelling_of_the_column_map_still_parses():
    sub = _subparsers()["evaluate"]
    new = sub.parse_args(["--reference", "r.csv", "--measured", "m.csv", "--out", "e",
                          "--output-columns", "x=X", "--input-columns", "ux=U"])
    old = sub.parse_args(["--reference", "r.csv", "--measured", "m.csv", "--out", "e",
                          "--outputs", "x=X", "--inputs", "ux=U"])
    assert (new.outputs, new.inputs) == (old.outputs, old.inputs) == ("x=X", "ux=U")
    assert "--inputs" not in sub.format_help() and "--input-columns" in sub.format_help()
