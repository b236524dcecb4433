"""Linear part G of the Hammerstein actuator: validation, identification, comparison.

The Hammerstein plant is ``U [V] -> Gamma (multivariable PI) -> H [µm] -> G -> Y
[µm]``. This module builds G from explicit matrices
(:func:`state_space_dynamics`), identifies a discrete G from records of the
PI outputs H (computed by an identified PI model) and the measured
displacements Y (:class:`DynamicsIdentifier`, :func:`identify_dynamics`),
designs broadband excitations (:func:`excitation`) and compares frequency
responses (:func:`compare_frequency_responses`).

Signals are arrays of shape (n_signals, n_samples) [µm]; a list of such
arrays is a list of records.

References
----------
.. [1] P. Van Overschee and B. De Moor, "N4SID: Subspace algorithms for the
   identification of combined deterministic-stochastic systems",
   Automatica 30(1), 75-93, 1994.
.. [2] M. Verhaegen and V. Verdult, *Filtering and System Identification: A
   Least Squares Approach*, Cambridge University Press, 2007 (PO-MOESP,
   Sections 9.6 and 10; estimation of B, D and x0 given A and C, Section 9.2.4).
.. [3] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
   Prentice Hall, 1999 (fit percentage, AIC, cross-validation, Section 16).
.. [4] R. Pintelon and J. Schoukens, *System Identification: A Frequency
   Domain Approach*, 2nd ed., Wiley-IEEE, 2012 (random-phase multisines;
   Section 6.3, a pure delay as the linear phase of a frequency response).
.. [5] G. F. Franklin, J. D. Powell and M. L. Workman, *Digital Control of
   Dynamic Systems*, 3rd ed., Addison-Wesley, 1998 (Section 4.3: the
   zero-order hold lags by half a sampling period).
"""

from __future__ import annotations

import numpy as np

from hammerstein.core.lazy import lazy_module

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")  # lazy: ~0.1 s CPU of `from hammerstein import ...`

# the implementation lives in three private modules; this module is the public face
from hammerstein.models._lti_systems import (align_dc_gain, continuous_system, dc_gain,
                                            excitation, hammerstein_records, modal_parameters,
                                            sensor_filter, state_space_dynamics)
from hammerstein.models._lti_delay import MeasurementDelay, estimate_measurement_delay, excited_band, frf_h1
from hammerstein.models._lti_subspace import DynamicsIdentifier, _simulate, identify_dynamics  # noqa: F401
from hammerstein.models._lti_delay_check import check_delay_by_fit

__all__ = [
    "state_space_dynamics",
    "dc_gain",
    "align_dc_gain",
    "modal_parameters",
    "continuous_system",
    "sensor_filter",
    "excitation",
    "hammerstein_records",
    "DynamicsIdentifier",
    "identify_dynamics",
    "excited_band",
    "frf_h1",
    "MeasurementDelay",
    "estimate_measurement_delay",
    "check_delay_by_fit",
    "compare_frequency_responses",
]

for _name in ("state_space_dynamics", "dc_gain", "align_dc_gain", "modal_parameters",
              "continuous_system", "sensor_filter", "excitation", "hammerstein_records",
              "DynamicsIdentifier", "identify_dynamics", "excited_band", "frf_h1",
              "MeasurementDelay", "estimate_measurement_delay", "check_delay_by_fit"):
    globals()[_name].__module__ = __name__      # documented (and pickled) as this module's
del _name



# -- comparison ----------------------------------------------------------------------
def compare_frequency_responses(identified, true, frequencies_hz=None):
    """Frequency responses of an identified and a reference system, all p x p entries.

    Parameters
    ----------
    identified, true : control.StateSpace or control.TransferFunction
        p x p systems (continuous or discrete; a discrete one is evaluated
        on ``z = exp(j w T)``).
    frequencies_hz : array_like, shape (n_freq,), optional
        [Hz]; default 200 log-spaced points from 1 Hz to 0.9 Nyquist (of
        the discrete systems, else 5 kHz).

    Returns
    -------
    dict
        ``frequency_hz`` (n_freq,); ``identified`` and ``true`` complex
        (p, p, n_freq); ``error`` ``|G_id - G_true|`` (p, p, n_freq);
        ``relative_error`` the error divided by the largest true gain of
        the same output row at that frequency (so that off-diagonal entries
        of a decoupled system have a meaningful scale) [-].
    """
    dts = [s.dt for s in (identified, true) if s.isdtime(strict=True)]
    if frequencies_hz is None:
        f_hi = 0.45 / min(dts) if dts else 5000.0
        frequencies_hz = np.logspace(0, np.log10(f_hi), 200)
    f = np.asarray(frequencies_hz, dtype=float)
    w = 2 * np.pi * f
    Gi = np.asarray(control.frequency_response(identified, w).complex).reshape(
        identified.noutputs, identified.ninputs, f.size)
    Gt = np.asarray(control.frequency_response(true, w).complex).reshape(
        true.noutputs, true.ninputs, f.size)
    err = np.abs(Gi - Gt)
    scale = np.max(np.abs(Gt), axis=1, keepdims=True)
    return {"frequency_hz": f, "identified": Gi, "true": Gt, "error": err,
            "relative_error": err / np.where(scale > 0, scale, 1.0)}
