"""An inline reference of a hardware command is bounded as a record, not as a scenario case.

``compensate --reference '{ kind = "circle", ..., periods = 600 }'`` at 50 kHz (3 million
samples, 60 s) was refused with "expected at most 2e+06 per case", a scenario case's limit,
while the same samples given as a CSV file were accepted: docs/limits.md gives a reference the
record's limit (10 million, HAMMERSTEIN_MAX_RECORD_SAMPLES).
"""

import pytest

from hammerstein.cli._hardware import load_reference
from hammerstein.exceptions import DataFileError
from hammerstein.io.presets import load_plant


def test_a_sixty_second_reference_at_fifty_kilohertz_is_a_record():
    plant = load_plant("rakotondrabe-2dof", dynamics=False)
    plant.sampling_period = 2e-5
    ref = load_reference('{ kind = "circle", radius = 20, frequency = 10, periods = 600 }', plant)
    assert ref.signal.shape == (2, 3_000_000)


def test_beyond_the_records_limit_it_is_still_refused(monkeypatch):
    monkeypatch.setenv("HAMMERSTEIN_MAX_RECORD_SAMPLES", "1000000")
    plant = load_plant("rakotondrabe-2dof", dynamics=False)
    plant.sampling_period = 2e-5
    with pytest.raises(DataFileError, match="HAMMERSTEIN_MAX_RECORD_SAMPLES"):
        load_reference('{ kind = "circle", radius = 20, frequency = 10, periods = 600 }', plant)
