"""The Bode figure of G: unwrapped phase, physical labels, every panel lettered.

Regression: the phase jumped by 360 degrees (wrapped), the columns read
"From x_h" (python-control's signal names) and the panels had no letters.
"""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import hammerstein as hs  # noqa: E402
from hammerstein.report.dynamics_figure import dynamics_bode_figure  # noqa: E402


def _texts(fig):
    out = [t.get_text() for t in fig.texts]
    for ax in fig.axes:
        out += [ax.get_title()] + [t.get_text() for t in ax.texts]
    return out


def test_bode_figure_has_physical_labels_unwrapped_phase_and_letters():
    G = hs.load_plant("rakotondrabe-2dof").dynamics
    fig = dynamics_bode_figure(G, G, title="G")
    texts = _texts(fig)
    assert not any(t.startswith(("From ", "To ")) for t in texts)
    assert "from hysteresis output x_h [µm]" in texts
    assert any(t.startswith("to displacement y [µm]") for t in texts)
    letters = sorted(t.split(")")[0] + ")" for t in texts if t[:1] == "(" and ") " in t[:4])
    assert letters == ["(a)", "(b)", "(c)", "(d)"]
    for ax in fig.axes:
        if "Phase" in ax.get_ylabel():
            for line in ax.get_lines():
                y = np.asarray(line.get_ydata(), dtype=float)
                if y.size > 2:
                    assert np.max(np.abs(np.diff(y))) < 90, "wrapped phase"
