"""The drive of a compensator over a Preisach model starts from the model's rest (demagnetised) memory.

A Preisach model at rest holds a memory (the demagnetised staircase of its
hysterons, see :mod:`hammerstein.models.preisach`); its exact inverse must start
from the same memory as the model it inverts, or every level it tracks
afterwards is offset by the hysterons the reference never switches. The
expectation is independent of the compensator: the model, driven from its own
rest state by the drive's voltages, follows the reference to the root
tolerance, whole or in chunks.
"""

import control
import numpy as np
import pytest

from hammerstein.compensation.drive import DriveStream, drive_signal
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator

T = 1e-4


def _asymmetric_model():
    """A 2 x 2 Preisach model with tilted densities: its rest output is not zero."""
    edges = np.linspace(-12.0, 12.0, 17)
    x = PreisachModel.from_density(edges, total=20.0, tilt=0.6, bias=1.0, bias_width=4.0,
                                   coercivity=2.0, coercivity_width=2.0, reversible=[1.5])
    y = PreisachModel.from_density(edges, total=15.0, tilt=-0.5, bias=-1.5, bias_width=3.0,
                                   coercivity=1.0, coercivity_width=2.0, reversible=[1.0, 0.02])
    xy = PreisachModel.from_density(edges, total=0.8, tilt=0.3, bias_width=4.0, reversible=[0.05])
    return MultivariableHysteresis([[x, xy], [None, y]], ("ux", "uy"), ("x", "y"), [10.0, 10.0])


def _staircase(levels, hold):
    """Held levels (p, n) [µm], smoothed steps, well inside the grid (minor loops only)."""
    r = np.repeat(np.asarray(levels, dtype=float), hold, axis=1)
    return r


def test_the_model_at_rest_is_not_at_zero():
    # what makes the start state matter: the demagnetised memory of a tilted density
    y, _ = _asymmetric_model().simulate(np.zeros((2, 3)))
    assert np.max(np.abs(y[:, -1])) > 0.5


@pytest.mark.parametrize("chunks", [None, 37])
def test_exact_inverse_drive_tracks_the_model_from_its_rest_state(chunks):
    model = _asymmetric_model()
    comp = PreisachInverseCompensator(model)
    ref = _staircase([[0.0, 8.0, 2.0, -6.0, 1.0], [1.0, -4.0, 3.0, 5.0, 0.0]], 50)
    if chunks is None:
        u = drive_signal(comp, ref, T, fade_samples=0).inputs
    else:
        stream = DriveStream(comp)
        u = np.concatenate([stream.push(ref[:, i:i + chunks]) for i in range(0, ref.shape[1], chunks)]
                           + [stream.finish()], axis=1)
    y, _ = model.simulate(u)           # the model from its own default (rest) state
    assert np.max(np.abs(y - ref)) < 1e-7


def test_hammerstein_drive_over_a_preisach_model_holds_the_levels():
    # G with G(0) = I: once the ringing has died out the held levels are the static inverse's
    model = _asymmetric_model()
    w, z = 2 * np.pi * np.array([400.0, 900.0]), 0.05
    A = np.zeros((4, 4))
    for i in range(2):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-w[i] ** 2, -2 * z * w[i]]]
    B = np.array([[0.0, 0.0], [w[0] ** 2, 0.0], [0.0, 0.0], [0.0, w[1] ** 2]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    G = control.c2d(control.ss(A, B, C, np.zeros((2, 2))), T, "zoh")
    comp = HammersteinCompensator(model, G)
    hold = 1500
    ref = _staircase([[0.0, 8.0, 2.0, -6.0], [1.0, -4.0, 3.0, 5.0]], hold)
    u = drive_signal(comp, ref, T, fade_samples=0).inputs
    h, _ = model.simulate(u)
    for j in range(4):
        k = j * hold + hold // 2          # ringing gone, the next step not yet previewed
        assert np.max(np.abs(h[:, k] - ref[:, k])) < 1e-3, (j, h[:, k], ref[:, k])
