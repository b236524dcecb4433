"""compensate's ``shaped:`` lines name the model's inputs (ux, uy), not "input 1/2",
also on a preset without an [amplifier] table (the start-up slew limit's notes)."""

from __future__ import annotations

import warnings

import hammerstein as hs
from hammerstein.scenario.hardware_route import compensate_reference


def test_start_up_notes_name_the_model_inputs():
    plant = hs.load_plant("rakotondrabe-2dof")
    assert plant.amplifier is None
    T = plant.sampling_period
    _, yr = hs.circle(T, radius=30.0, frequency=100.0, periods=20)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, drive = compensate_reference(plant, yr, period_samples=yr.shape[1] // 20,
                                        kind="per-axis")
    start = [line for line in drive.shaped if "start-up" in line]
    assert start, drive.shaped
    # per input ("ux: ... slew-limited ...") or, corrected in the reference, in its text
    assert all(line.split(":")[0] in ("ux", "uy") or
               (line.startswith("the start-up corrected in the reference") and
                ("ux " in line or "uy " in line)) for line in start), start
    assert not any("input 1" in line or "input 2" in line for line in drive.shaped)
