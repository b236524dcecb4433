"""Progress bars: shown on a terminal only."""

import io

from hammerstein.scenario.progress import progress


def test_progress_is_quiet_when_stderr_is_not_a_terminal():
    sink = io.StringIO()                      # not a TTY, like a pipe or a CI log
    bar = progress(range(4), desc="sweep", file=sink)
    assert list(bar) == [0, 1, 2, 3]
    assert bar.disable and sink.getvalue() == ""


def test_progress_can_be_forced_on():
    sink = io.StringIO()
    assert sum(progress(range(4), desc="sweep", file=sink, disable=False)) == 6
    assert "sweep" in sink.getvalue() and "4/4" in sink.getvalue()
