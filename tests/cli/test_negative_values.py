"""Option values that start with a minus sign and a digit are values, not options.

argparse alone reads only ``-20`` and ``-0.5`` as numbers: ``--range -20,120`` (a stack
driven from -20 V) ended with "expected one argument", and only ``--range=-20,120`` worked.
"""

import pytest

from hammerstein.cli.main import build_parser


@pytest.mark.parametrize("value", ["-20,120", "-30,150", "-1e1,1e2", "-.5,10"])
def test_a_negative_lower_rail_is_read_as_the_ranges_value(value):
    args = build_parser("excitation").parse_args(
        ["excitation", "--inputs", "ux,uy", "--sampling-period", "5e-5", "--range", value,
         "--out", "records"])
    assert args.range == [value]         # one range for every input (or one per input)


def test_an_unknown_option_is_still_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        build_parser("excitation").parse_args(
            ["excitation", "--inputs", "ux", "--sampling-period", "5e-5", "--out", "records",
             "--rnage", "0,150"])
    assert info.value.code == 2
    assert "--rnage" in capsys.readouterr().err
