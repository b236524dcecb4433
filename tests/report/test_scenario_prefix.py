"""A scenario title with ':' is kept whole in its figures' titles (only "Fig. N: ..." is shortened)."""

from types import SimpleNamespace

import pytest

from hammerstein.report.figures import PREFIX_CHARS, scenario_prefix


@pytest.mark.parametrize("title, expected", [
    ("Fig. 10: circles of radius 15, 30, 50 µm at 50 Hz", "Fig. 10"),
    ("Figure 3b: a panel", "Figure 3b"),
    ("Stage B: slow scans", "Stage B: slow scans"),            # was "Stage B"
    ("Piezo tube: x/y coupling: 2 Hz", "Piezo tube: x/y coupling: 2 Hz"),
    ("no colon at all", "no colon at all"),
    ("", "my-scenario"),
    ("x" * (PREFIX_CHARS + 1), "my-scenario"),                 # too long for a figure title
    ("Stage B:\n slow   scans", "Stage B: slow scans"),         # whitespace folded
])
def test_titles_are_kept_whole(title, expected):
    assert scenario_prefix(SimpleNamespace(title=title, name="my-scenario")) == expected
