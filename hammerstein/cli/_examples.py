"""The examples printed at the end of every subcommand's ``--help``.

One place for all of them, so that ``tests/cli/test_help_examples.py`` can parse
each example line with the real parser: an option renamed or removed fails there.
"""

from __future__ import annotations

import argparse

__all__ = ["EXAMPLES", "ExampleFormatter", "add_examples"]

#: Subcommand -> example command lines (each line one command; ``#`` starts a comment).
EXAMPLES = {
    "run": [
        "hammerstein run scenarios/default.toml                  # -> reports/default/",
        "hammerstein run scenarios/paper/*.toml --out /tmp/reports",
        "hammerstein run scenarios/robustness-monte-carlo.toml --workers 2   # extra [distributed]",
    ],
    "validate": [
        "hammerstein validate scenarios/*.toml scenarios/paper/*.toml",
    ],
    "list": [
        "hammerstein list                                        # bundled and ./scenarios",
        "hammerstein list --scenarios my-scenarios/",
    ],
    "identify": [
        "hammerstein identify hammerstein/data/piezo-stack-150V-1Hz.csv --input 2 --output 1 "
        "--time 0 --out model.toml --metrics fit.csv --plot fit.png",
        "hammerstein identify hysteresis-ux.csv hysteresis-uy.csv --inputs ux,uy --outputs x,y "
        "--time t --dynamics --dynamics-records multisine-ux.csv multisine-uy.csv "
        "multisine-ux-validation.csv multisine-uy-validation.csv "
        "--creep-records creep-ux.csv creep-uy.csv --out preset.toml",
    ],
    "excitation": [
        "hammerstein excitation --inputs ux,uy --amplitude 10 --sampling-period 5e-5 --out lab/",
    ],
    "check": [
        "hammerstein check scenarios/*.toml scenarios/paper/*.toml --baseline baselines/bundled.csv",
        "hammerstein check my-scenario.toml --baseline my-baseline.csv --update   # record on purpose",
    ],
    "replicate": [
        "hammerstein replicate                                   # -> reports/paper/",
        "hammerstein replicate --out /tmp/replication",
    ],
    "export": [
        "hammerstein export rakotondrabe-2dof --target c --name piezo --out generated/",
        "hammerstein export preset.toml --kind hammerstein --target fmu --out fmu/",
    ],
    "compensate": [
        "hammerstein compensate rakotondrabe-2dof --reference "
        "'{ kind = \"circle\", radius = 30, frequency = 100, periods = 20 }' --out drive.csv",
    ],
    "evaluate": [
        "hammerstein evaluate --reference "
        "'{ kind = \"circle\", radius = 30, frequency = 100, periods = 20 }' "
        "--drive drive.csv --measured measured.csv --out eval/",
    ],
    "learn": [
        "hammerstein learn rakotondrabe-2dof --reference "
        "'{ kind = \"circle\", radius = 30, frequency = 100, periods = 20 }' "
        "--drive drive.csv --measured measured.csv --out drive-1.csv --history ilc/",
    ],
    "warmup": [
        "hammerstein warmup          # once after installing: the first run then compiles nothing",
    ],
}


class ExampleFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that an epilog starting with ``examples:`` is printed as written."""

    def _fill_text(self, text, width, indent):
        if text.startswith("examples:"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def add_examples(parser, command):
    """Give a subcommand's parser its examples (an epilog printed as written).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    command : str
        Its name in :data:`EXAMPLES`; a command without examples is left alone.
    """
    lines = EXAMPLES.get(command)
    if not lines:
        return
    parser.formatter_class = ExampleFormatter
    parser.epilog = "examples:\n" + "\n".join(f"  {line}" for line in lines)
