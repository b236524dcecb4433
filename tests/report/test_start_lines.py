"""report.md says how each compensated case starts: a step at t = 0 (where, how large) or a fade."""

from hammerstein.cli.main import main

SCENARIO = """
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
[[cases]]
name = "circle-abrupt"
reference = { kind = "circle", radius = 12.0, frequency = 50.0, periods = 2 }
[[cases]]
name = "circle-faded"
reference = { kind = "circle", radius = 12.0, frequency = 50.0, periods = 3 }
compensator = { kind = "multivariable", fade_in = 0.004 }
[[cases]]
name = "sine-from-rest"
reference = { kind = "sine", output = "x", amplitude = 5.0, frequency = 50.0, periods = 2 }
"""


def test_report_states_each_start(tmp_path):
    path = tmp_path / "starts.toml"
    path.write_text(SCENARIO)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    md = (tmp_path / "out" / "starts" / "report.md").read_text()
    lines = {ln.split(":")[0]: ln for ln in md.splitlines() if ln.startswith("- `")}
    abrupt = lines["- `circle-abrupt`"]
    # a circle x = R cos, y = R sin starts at (R, 0): a step of R from rest
    assert "step at t = 0" in abrupt and "x = 12 µm, y = 0 µm, 12 µm from rest" in abrupt
    # 4 ms at the preset's sampling period
    assert "faded in from rest over 4 ms" in lines["- `circle-faded`"]
    assert "at rest (its first sample is 0 µm)" in lines["- `sine-from-rest`"]
