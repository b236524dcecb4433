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


def test_a_fade_from_0_um_off_the_models_rest_is_said_to_step(tmp_path):
    """A new user's identified model rests at 1.5 / -0.8 µm at 0 V: faded in from 0 µm, the
    drive's first voltages are those of 0 µm, a step from 0 V; the report said "faded in from
    rest". It now names the step, as large as the drive's first sample."""
    import copy

    import numpy as np
    import pandas as pd

    from hammerstein.io.presets import load_plant, save_model

    model = copy.deepcopy(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis)
    model.output_offset = np.array([1.5, -0.8])
    save_model(model, tmp_path / "offset.toml")
    path = tmp_path / "starts.toml"
    path.write_text(SCENARIO.replace('[compensator]\nkind = "multivariable"',
                                     '[compensator]\nkind = "multivariable"\nmodel = "offset.toml"')
                    .replace('compensator = { kind = "multivariable", fade_in = 0.004 }',
                             'compensator = { kind = "multivariable", fade_in = 0.004, '
                             'model = "offset.toml" }'))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    md = (tmp_path / "out" / "starts" / "report.md").read_text()
    faded = {ln.split(":")[0]: ln for ln in md.splitlines() if ln.startswith("- `")}["- `circle-faded`"]
    series = pd.read_csv(tmp_path / "out" / "starts" / "timeseries-circle-faded.csv", comment="#")
    u0 = float(np.max(np.abs(series[["ux_V", "uy_V"]].to_numpy()[0])))
    assert u0 > 0.1
    assert "faded in from 0 µm over 4 ms" in faded and f"jumps from 0 V to {u0:.3g} V in the first sample" in faded
    assert "which is not its compensator" not in faded


def test_a_preview_at_the_first_sample_is_not_blamed_on_the_models_rest(tmp_path):
    """The Hammerstein compensator on a model resting at 0 µm: its ZPETC inverse previews the
    fade from the first sample, so the drive starts off 0 V; the report said the model does
    not rest at 0 µm."""
    import numpy as np
    import pandas as pd

    from hammerstein.compensation.drive import rest_output
    from hammerstein.io.presets import load_plant

    assert np.max(np.abs(rest_output(load_plant("rakotondrabe-2dof").hysteresis))) <= 1e-9
    path = tmp_path / "starts.toml"
    path.write_text(SCENARIO.replace("dynamics = false\n", "")
                    .replace('[compensator]\nkind = "multivariable"', '[compensator]\nkind = "hammerstein"')
                    .replace('compensator = { kind = "multivariable", fade_in = 0.004 }',
                             'compensator = { kind = "hammerstein", fade_in = 0.004 }'))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    md = (tmp_path / "out" / "starts" / "report.md").read_text()
    faded = {ln.split(":")[0]: ln for ln in md.splitlines() if ln.startswith("- `")}["- `circle-faded`"]
    series = pd.read_csv(tmp_path / "out" / "starts" / "timeseries-circle-faded.csv", comment="#")
    u0 = float(np.max(np.abs(series[["ux_V", "uy_V"]].to_numpy()[0])))
    assert u0 > 1e-6
    assert "does not rest at 0 µm" not in faded
    assert f"previews the samples ahead, so the drive starts at {u0:.3g} V" in faded


def test_a_peak_slew_that_is_the_start_step_is_said_so(tmp_path):
    """A tester's abrupt circle: peak_slew was the first sample's step from 0 V (3525 V/s,
    the settled drive 2035 V/s) and the report did not say which. It names the cases whose
    peak_slew is the start step, with the largest slew over the settled window."""
    import numpy as np
    import pandas as pd

    path = tmp_path / "starts.toml"
    path.write_text(SCENARIO)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "-q", "--figures", "none"]) == 0
    out = tmp_path / "out" / "starts"
    md = (out / "report.md").read_text()
    line = next(ln for ln in md.splitlines() if ln.startswith("- `peak_slew` is this start"))
    ts = pd.read_csv(out / "timeseries-circle-abrupt.csv")
    u = ts[[c for c in ts.columns if c.endswith("_V")]].to_numpy().T
    T = float(ts.time_s[1] - ts.time_s[0])
    steps = np.abs(np.diff(np.column_stack([np.zeros(len(u)), u]), axis=1)) / T
    settled = steps[:, 1 + 400:].max()     # window from sample round(1 period x 400 samples)
    assert steps[:, 0].max() > steps[:, 1:].max()        # the start step is the peak
    assert f"`circle-abrupt` ({steps[:, 0].max():.4g} V/s at t = 0; at most {settled:.4g} V/s" \
        in line
    assert "sine-from-rest" not in line and "circle-faded" not in line
