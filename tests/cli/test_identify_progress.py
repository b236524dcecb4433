"""identify says each phase as it starts, on a terminal.

A 2-axis identification at 50 kHz sat silent for 22-88 s, then printed everything at once.
Redirected to a file or a pipe (logs, tests) it stays as quiet as before.
"""

import io
import sys
from pathlib import Path

from hammerstein.cli import identify
from hammerstein.cli._output import tty_progress
from hammerstein.cli.main import main

DATA = Path(__file__).resolve().parents[2] / "hammerstein" / "data" / "piezo-stack-150V-1Hz.csv"


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_only_on_a_terminal(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert tty_progress("identify") is None
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    tty_progress("identify")("fitting the hysteresis")
    assert term.getvalue() == "identify: fitting the hysteresis ...\n"


def test_the_phases_in_the_order_they_run(tmp_path, monkeypatch, capsys):
    lines = []
    monkeypatch.setattr(identify, "tty_progress", lambda command: lines.append)
    assert main(["identify", str(DATA), "--input", "2", "--output", "1", "--time", "0",
                 "--out", str(tmp_path / "m.toml")]) == 0, capsys.readouterr().err
    assert lines == ["fitting the hysteresis (every model class) on 1 record(s), 50001 samples"]
