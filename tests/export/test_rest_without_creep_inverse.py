"""Kinds that do not invert creep, on a model with creep: the C equals compensate from sample 0.

realistic-2dof has creep. The static-gain and per-axis compensators invert the hysteresis
alone, so their reference must fade in from the output they map to 0 V, not from the
creep's settled output: faded from that one, compensate's drive started away from 0 V
and was tapered back to rest over the fade's rest lead, while the C fed the documented
faded reference started with a step (0.085 V) and differed by 3e-2 relative.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import hammerstein as hs
from hammerstein.compensation.drive import hardware_fade
from hammerstein.export import export_c
from hammerstein.scenario.hardware_route import compensate_reference

from conftest import Harness, needs_cc


@needs_cc
@pytest.mark.parametrize("kind", ["static-gain", "per-axis"])
def test_c_fed_the_documented_fade_equals_compensate_from_sample_0(kind, tmp_path):
    plant = hs.load_plant("realistic-2dof")
    assert plant.creep is not None and any(c is not None for c in plant.creep)
    T, periods = plant.sampling_period, 10
    _, yr = hs.circle(T, radius=15.0, frequency=100.0, periods=periods)
    _, longer = hs.circle(T, radius=15.0, frequency=100.0, periods=periods + 1)
    period = yr.shape[1] // periods
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp, drive = compensate_reference(plant, yr, period_samples=period, kind=kind)
        code = export_c(comp, "rk", T)
    n = yr.shape[1]
    u_py = drive.inputs
    assert np.all(u_py[:, 0] == 0.0)
    # docs/real-time.md: the reference faded from the rest output (the C's, the header's)
    faded = hardware_fade(longer, drive.fade_samples, np.array(code.rest_reference),
                          drive.rest_lead)
    np.testing.assert_allclose(faded[:, :n], drive.reference, rtol=0, atol=1e-12)
    u_c, status, _ = Harness(code, tmp_path / "h").run(faded[:, code.preview:n + code.preview])
    assert np.all(status == 0)
    assert np.max(np.abs(u_c[:, 0])) == 0.0                 # the C starts at rest
    assert np.max(np.abs(u_c - u_py)) <= 1e-12 * np.max(np.abs(u_py))
    assert drive.start_offset is None                       # nothing tapered back to rest
