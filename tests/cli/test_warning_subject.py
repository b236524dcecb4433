"""A stray warning in a multi-scenario ``run`` names the scenario it came from."""

from __future__ import annotations

import warnings

import pytest

from hammerstein import runner
from hammerstein.cli.main import main

SCENARIO = """name = "{name}"
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
model = "plant"
[[cases]]
name = "sine"
reference = {{ kind = "sine", output = "x", amplitude = 10.0, frequency = 50.0, periods = 2 }}
"""


@pytest.mark.parametrize("noisy", ["a.toml", "b.toml"])
def test_stray_warning_names_its_scenario(tmp_path, monkeypatch, capsys, noisy):
    paths = []
    for name in ("a", "b"):
        p = tmp_path / f"{name}.toml"
        p.write_text(SCENARIO.format(name=name))
        paths.append(str(p))
    start = runner.start_scenario

    def start_and_warn(path, *args, **kwargs):
        if str(path).endswith(noisy):          # a library's warning while this one runs
            warnings.warn("stray library warning", RuntimeWarning)
        return start(path, *args, **kwargs)

    monkeypatch.setattr(runner, "start_scenario", start_and_warn)
    code = main(["run", *paths, "--out", str(tmp_path / "reports"), "--figures", "none"])
    err = capsys.readouterr().err.splitlines()
    assert code == 0
    stray = [line for line in err if "stray library warning" in line]
    assert stray == [f"warning: {tmp_path / noisy}: stray library warning"]
