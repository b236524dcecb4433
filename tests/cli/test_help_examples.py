"""Every subcommand's --help ends with examples, and every example parses.

Regression: no subcommand's --help had an example; `identify --help` said
"classical PI" while its default (--model auto) may choose another class.
"""

import shlex

import pytest

from hammerstein.cli._examples import EXAMPLES
from hammerstein.cli.main import COMMANDS, build_parser


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_help_has_examples(command, capsys):
    assert EXAMPLES.get(command), f"{command}: no example in hammerstein/cli/_examples.py"
    with pytest.raises(SystemExit):
        build_parser(command).parse_args([command, "--help"])
    text = capsys.readouterr().out
    assert "examples:\n" in text
    for line in EXAMPLES[command]:
        assert f"  {line}\n" in text        # printed as written, not re-wrapped


@pytest.mark.parametrize("command, line", [(c, l) for c in sorted(EXAMPLES) for l in EXAMPLES[c]])
def test_every_example_parses(command, line):
    words = shlex.split(line, comments=True)
    assert words[:2] == ["hammerstein", command]
    args = build_parser(command).parse_args(words[1:])
    assert args.command == command


def test_identify_help_states_the_real_default_class(capsys):
    with pytest.raises(SystemExit):
        build_parser("identify").parse_args(["identify", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--model auto" in text and "Preisach" in text and "generalised PI" in text
    assert "Identify a multivariable classical" not in text
