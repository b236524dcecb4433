"""Linear dynamics of the actuator, built with python-control.

The Hammerstein structure of the paper (Section 1 and 6) cascades the
rate-independent multivariable PI with a linear system of unit DC gain. For a
piezocantilever that system is dominated by its first bending mode on each
axis.

References
----------
.. [1] M. Rakotondrabe, C. Clévy and P. Lutz, "Complete open loop control of
   hysteretic, creeped and oscillating piezoelectric cantilevers", IEEE
   T-ASE 7(3), 2010 (ref. [6] of the paper).
"""

from __future__ import annotations

from typing import Sequence

import control
import numpy as np

from hammerstein.exceptions import DynamicsError

__all__ = ["DynamicsError", "bending_modes", "discretize", "bandwidths_hz"]


def bending_modes(natural_frequency, damping_ratio, names: Sequence[str] | None = None):
    """Decoupled second-order bending modes with unit DC gain, one per axis.

    ``G_l(s) = wn_l^2 / (s^2 + 2 zeta_l wn_l s + wn_l^2)``, ``wn_l = 2 pi f_l``.

    Parameters
    ----------
    natural_frequency : array_like, shape (p,)
        Undamped natural frequency of each axis [Hz], > 0.
    damping_ratio : array_like, shape (p,)
        Damping ratio of each axis [-], in (0, 1].
    names : sequence of str, optional
        Names of the p axes, used for the system's inputs (``<name>_h``, the
        hysteresis output) and outputs (``<name>``).

    Returns
    -------
    control.StateSpace
        Continuous-time MIMO system, p inputs [µm], p outputs [µm], 2p states.

    Raises
    ------
    DynamicsError
        If frequencies or damping ratios are non-positive, non-finite or of
        mismatched length.
    """
    fn = np.atleast_1d(np.asarray(natural_frequency, dtype=float))
    zeta = np.atleast_1d(np.asarray(damping_ratio, dtype=float))
    if fn.ndim != 1 or fn.shape != zeta.shape:
        raise DynamicsError(
            f"damping_ratio: expected {fn.size} values to match natural_frequency, "
            f"found {zeta.size}")
    if not np.all(np.isfinite(fn)) or np.any(fn <= 0):
        raise DynamicsError(f"natural_frequency: expected positive values [Hz], found {fn.tolist()}")
    if not np.all(np.isfinite(zeta)) or np.any(zeta <= 0) or np.any(zeta > 1):
        raise DynamicsError(f"damping_ratio: expected values in (0, 1], found {zeta.tolist()}")
    p = fn.size
    names = list(names) if names is not None else [f"y{i}" for i in range(p)]
    if len(names) != p:
        raise DynamicsError(f"names: expected {p} names, found {len(names)}")
    A = np.zeros((2 * p, 2 * p))
    B = np.zeros((2 * p, p))
    C = np.zeros((p, 2 * p))
    for l, (f, z) in enumerate(zip(fn, zeta)):
        wn = 2 * np.pi * f
        # states: position [µm] and velocity / wn [µm] (well scaled)
        A[2 * l:2 * l + 2, 2 * l:2 * l + 2] = [[0.0, wn], [-wn, -2 * z * wn]]
        B[2 * l + 1, l] = wn
        C[l, 2 * l] = 1.0
    return control.ss(A, B, C, np.zeros((p, p)),
                      inputs=[f"{n}_h" for n in names], outputs=list(names),
                      states=[f"{n}_{s}" for n in names for s in ("pos", "vel")],
                      name="bending_modes")


def discretize(system, sampling_period):
    """Zero-order-hold discretisation with python-control.

    Parameters
    ----------
    system : control.StateSpace
        Continuous-time system.
    sampling_period : float
        Sampling period T [s], > 0.

    Returns
    -------
    control.StateSpace
        Discrete-time system with ``dt = sampling_period``.

    Raises
    ------
    DynamicsError
        If the sampling period is not positive.
    """
    if not (np.isfinite(sampling_period) and sampling_period > 0):
        raise DynamicsError(f"sampling_period: expected a positive time [s], found {sampling_period!r}")
    return control.sample_system(system, sampling_period, method="zoh")


def bandwidths_hz(system):
    """-3 dB bandwidth of each diagonal channel of a continuous system [Hz].

    Parameters
    ----------
    system : control.StateSpace
        Continuous-time square system.

    Returns
    -------
    numpy.ndarray, shape (p,)
        First frequency where ``|G_ll(j w)|`` falls 3 dB below its DC gain
        (``control.bandwidth``) [Hz].
    """
    return np.array([control.bandwidth(system[l, l]) / (2 * np.pi)
                     for l in range(system.noutputs)])
