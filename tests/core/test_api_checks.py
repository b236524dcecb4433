"""Bad input to the Python API gets an error naming the argument (a new user's calls).

``drive_signal`` took a negative sampling period and returned a drive; a transposed
reference failed inside numpy ("cannot reshape array of size 800 into shape (2,1)").
The convergence condition's repr printed its thousands of values.
"""

import numpy as np
import pytest

from hammerstein.compensation.compensators import InverseMultiplicativeCompensator
from hammerstein.compensation.drive import drive_signal
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.ilc import ConvergenceCondition
from hammerstein.exceptions import CompensatorError
from hammerstein.io.presets import load_plant

REF = np.zeros((2, 400))


@pytest.mark.parametrize("reference, period, message", [
    (REF, -1e-4, "sampling_period: expected a positive time [s], found -0.0001"),
    (REF, float("nan"), "sampling_period: expected a positive time [s], found nan"),
    (REF, "5e-5", "sampling_period: expected a positive time [s], found '5e-5'"),
    (REF.T, 5e-5, "reference: expected shape (2, n_samples), one row per output [µm], found (400, 2)"),
    (REF[0], 5e-5, "reference: expected shape (2, n_samples), one row per output [µm], found (400,)"),
])
def test_drive_signal_names_the_bad_argument(reference, period, message):
    comp = InverseMultiplicativeCompensator(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis)
    with pytest.raises(CompensatorError) as err:
        drive_signal(comp, reference, period)
    assert str(err.value) == message


def test_the_hammerstein_compensator_refuses_a_negative_sampling_period(preset_plant):
    with pytest.raises(CompensatorError, match="sampling_period: expected a positive time"):
        HammersteinCompensator(preset_plant.hysteresis, preset_plant.dynamics, feedback="lowpass",
                               cutoff_hz=500.0, sampling_period=-1e-4)


def test_the_convergence_condition_prints_its_maxima():
    f = np.linspace(0.0, 10_000.0, 3001)
    cond = ConvergenceCondition(f, np.vstack([0.5 + 0.3 * np.sin(f), np.full(f.size, 0.6)]),
                                np.full(f.size, 0.9))
    text = repr(cond)
    assert len(text) < 200 and "3001 frequencies up to 10000 Hz" in text
    assert "max per axis [0.8, 0.6]" in text and "max coupled 0.9" in text and "holds=True" in text
