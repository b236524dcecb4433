"""What a Python caller is told when a signal is not an array of finite numbers.

From an outside check: ``simulate(None)`` was told "found NaN or inf" (numpy reads
None as NaN), a Preisach model told a NaN "expected 1-d finite numbers, found shape
(2,)" (the shape was right), and arrays of text or booleans were converted silently.
"""

import numpy as np
import pytest

from hammerstein.exceptions import HysteresisError
from hammerstein.io.presets import load_plant
from hammerstein.models.preisach import PreisachModel


@pytest.fixture(scope="module")
def pi():
    return load_plant("rakotondrabe-2dof").hysteresis


@pytest.mark.parametrize("value, words", [
    (None, "inputs: expected an array of numbers, found None"),
    (np.zeros((2, 5)).astype(str), "inputs: expected numbers, found an array of text"),
    (np.zeros((2, 5), dtype=bool), "inputs: expected numbers, found an array of booleans"),
    (np.full((2, 3), np.nan), "inputs: expected finite values, found NaN or inf"),
])
def test_a_multivariable_model_names_what_its_inputs_are(pi, value, words):
    with pytest.raises(HysteresisError, match=f"^{words}"):
        pi.simulate(value)
    # numbers as numbers still run, from a list or an integer array alike
    y_list, _ = pi.simulate([[0.0, 1.0, 2.0], [0.0, -1.0, 0.5]])
    y_int, _ = pi.simulate(np.array([[0, 1, 2], [0, -1, 0]]))
    assert y_list.shape == y_int.shape == (2, 3)


def test_a_preisach_model_tells_a_nan_from_a_wrong_shape():
    m = PreisachModel(np.linspace(-5.0, 5.0, 6), np.tri(5))
    with pytest.raises(HysteresisError, match=r"expected finite values, found NaN or inf$"):
        m.simulate([0.0, np.nan])
    with pytest.raises(HysteresisError, match=r"expected 1-d finite numbers, found shape \(2, 2\)"):
        m.simulate([[0.0, 1.0], [1.0, 0.0]])
