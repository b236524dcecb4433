"""The generalised PI's envelopes as identify prints them."""

import numpy as np
import pytest

from hammerstein.cli.identify import _envelope_text
from hammerstein.models.generalized_pi import envelope


@pytest.mark.parametrize("g", [[12.0, 0.1, -0.355, 0.2], [11.0, 0.1, 0.05, -2.0], [9.0, 0.2, 0.0, 0.0]])
def test_the_printed_envelope_evaluates_to_the_envelope(g):
    """Read back as Python, the text is the envelope (signs once, the rising a3 included:
    it printed "+ -0.355" and left the rising envelope's a3 out)."""
    text = _envelope_text(g)
    assert "+ -" not in text and "- -" not in text
    u = np.linspace(-10, 10, 7)
    expr = text.replace(" tanh", " * np.tanh").replace(" u", " * u")
    assert np.allclose(eval(expr, {"np": np, "u": u}), envelope(np.asarray(g), u), rtol=1e-3)
