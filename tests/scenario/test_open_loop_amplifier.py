"""An open-loop drive case goes through the plant's amplifier, as a compensated case does."""

from pathlib import Path

import numpy as np
import pandas as pd

from hammerstein.cli.main import main
from hammerstein.io.presets import resolve_preset


def test_an_open_loop_drive_beyond_the_amplifier_is_clipped_and_warned(tmp_path):
    # a +-40 V sine against a -20..120 V amplifier reached the plant whole, without a word
    text = Path(resolve_preset("rakotondrabe-2dof")).read_text()
    (tmp_path / "amp.toml").write_text(text + '\n[amplifier]\nrange = [-20.0, 120.0]\n'
                                       'slew_rate = 1e6\n')
    (tmp_path / "s.toml").write_text(
        '[plant]\npreset = "amp.toml"\n[[cases]]\nname = "sine40"\n'
        'drive = { kind = "sine", input = "ux", amplitude = 40.0, frequency = 10.0, periods = 2 }\n')
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o"), "-q",
                 "--figures", "none"]) == 0
    md = (tmp_path / "o" / "s" / "report.md").read_text()
    assert "input ux needs -40 V" in md and "beyond the amplifier's range [-20, 120] V" in md
    series = pd.read_csv(tmp_path / "o" / "s" / "timeseries-sine40.csv", comment="#")
    ux = series.filter(like="ux").to_numpy()[:, 0]
    assert ux.min() == -20.0 and np.isclose(ux.max(), 40.0, atol=1e-9)
