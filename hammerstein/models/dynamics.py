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

import operator
from typing import Sequence

import numpy as np

from hammerstein.core.lazy import lazy_module
from hammerstein.exceptions import DynamicsError

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = ["DynamicsError", "bending_modes", "discretize", "bandwidths_hz", "zoh",
           "SampledSystem", "sampled_bending_modes"]


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
    A, B, C, D, labels = _bending_matrices(natural_frequency, damping_ratio, names)
    return control.ss(A, B, C, D, name="bending_modes", **labels)


def _bending_matrices(natural_frequency, damping_ratio, names):
    """Continuous (A, B, C, D) and signal names of :func:`bending_modes` (checked)."""
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
    return A, B, C, np.zeros((p, p)), {
        "inputs": [f"{n}_h" for n in names], "outputs": list(names),
        "states": [f"{n}_{s}" for n in names for s in ("pos", "vel")]}


def zoh(A, B, sampling_period):
    """Zero-order-hold discretisation of ``dx/dt = A x + B u``.

    ``expm(T [[A, B], [0, 0]]) = [[A_d, B_d], [0, I]]`` (the ZOH definition,
    e.g. Franklin, Powell & Workman, *Digital Control of Dynamic Systems*,
    Sec. 4.3.3), computed as :func:`scipy.signal.cont2discrete` does for
    ``method="zoh"``, so the matrices equal those of
    ``control.sample_system(..., method="zoh")`` without importing
    python-control.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous state matrix [1/s].
    B : array_like, shape (n, m)
        Continuous input matrix.
    sampling_period : float
        T [s], > 0.

    Returns
    -------
    A_d : numpy.ndarray, shape (n, n)
    B_d : numpy.ndarray, shape (n, m)

    Raises
    ------
    DynamicsError
        If the sampling period is not positive.

    Examples
    --------
    >>> A_d, B_d = zoh([[-1.0]], [[1.0]], 0.5)
    >>> bool(np.isclose(A_d[0, 0], np.exp(-0.5)) and np.isclose(B_d[0, 0], 1 - np.exp(-0.5)))
    True
    """
    import scipy.linalg  # lazy: only when a plant with dynamics is built

    if not (np.isfinite(sampling_period) and sampling_period > 0):
        raise DynamicsError(f"sampling_period: expected a positive time [s], found {sampling_period!r}")
    A, B = np.atleast_2d(np.asarray(A, dtype=float)), np.atleast_2d(np.asarray(B, dtype=float))
    n, m = B.shape
    em = np.vstack((np.hstack((A, B)), np.zeros((m, n + m))))
    ms = scipy.linalg.expm(sampling_period * em)[:n, :]
    return ms[:, :n], ms[:, n:]


class SampledSystem:
    """Discrete-time state-space matrices with signal names, python-control on demand.

    What a simulation needs of sampled dynamics (``A, B, C, D, dt`` and the
    sizes) without importing python-control; :meth:`to_control` gives the
    ``control.StateSpace`` (as ``control.sample_system`` would) for analysis
    (Bode, interop, identification).

    Parameters
    ----------
    A : numpy.ndarray, shape (n, n)
    B : numpy.ndarray, shape (n, m)
    C : numpy.ndarray, shape (p, n)
    D : numpy.ndarray, shape (p, m)
    dt : float
        Sampling period T [s].
    inputs, outputs, states : list of str
        Signal names.
    name : str
        System name.
    """

    def __init__(self, A, B, C, D, dt, inputs, outputs, states, name):
        self.A, self.B, self.C, self.D = A, B, C, D
        self.dt, self.name = float(dt), name
        self.inputs, self.outputs, self.states = list(inputs), list(outputs), list(states)

    ninputs = property(lambda self: self.B.shape[1], doc="Number of inputs m.")
    noutputs = property(lambda self: self.C.shape[0], doc="Number of outputs p.")
    nstates = property(lambda self: self.A.shape[0], doc="Number of states n.")

    def isdtime(self, strict=False):
        """Always True: a discrete-time system (python-control's signature).

        Parameters
        ----------
        strict : bool
            Ignored.

        Returns
        -------
        bool
        """
        return True

    def __getitem__(self, key):
        """The subsystem from input j to output i, every state kept, as ``control.StateSpace[i, j]``.

        Parameters
        ----------
        key : tuple of (int, int)
            ``(i, j)``: output and input index.

        Returns
        -------
        SampledSystem
            1 input, 1 output, the same n states.

        Raises
        ------
        DynamicsError
            When ``key`` is not two indices within the outputs and inputs.
        """
        try:
            i, j = (operator.index(k) for k in key)
            if not (-self.noutputs <= i < self.noutputs and -self.ninputs <= j < self.ninputs):
                raise IndexError
        except (TypeError, ValueError, IndexError):
            raise DynamicsError(f"subsystem: expected (output, input) indices of a "
                                f"{self.noutputs}x{self.ninputs} system, found {key!r}") from None
        return SampledSystem(self.A, self.B[:, [j]], self.C[[i], :], self.D[[i]][:, [j]], self.dt,
                             [self.inputs[j]], [self.outputs[i]], self.states,
                             f"{self.name}$indexed")

    def poles(self):
        """Eigenvalues of ``A`` (discrete poles z), as ``control.StateSpace.poles``.

        Returns
        -------
        numpy.ndarray, shape (n,)
            Complex.
        """
        return np.linalg.eigvals(self.A).astype(complex)

    def frequency_response_hz(self, frequencies_hz):
        """``G(z) = C (z I - A)^-1 B + D`` at ``z = exp(j 2 pi f T)``.

        Parameters
        ----------
        frequencies_hz : array_like, shape (n_freq,)
            [Hz].

        Returns
        -------
        numpy.ndarray, shape (p, m, n_freq)
            Complex gains (as ``control.frequency_response(...).complex``).
        """
        f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
        eye = np.eye(self.nstates)
        return np.stack([self.C @ np.linalg.solve(np.exp(2j * np.pi * fk * self.dt) * eye - self.A,
                                                  self.B) + self.D for fk in f], axis=-1)

    @classmethod
    def from_system(cls, system):
        """The matrices and names of a discrete ``control.StateSpace``.

        Parameters
        ----------
        system : control.StateSpace
            Discrete-time.

        Returns
        -------
        SampledSystem
        """
        return cls(np.asarray(system.A), np.asarray(system.B), np.asarray(system.C),
                   np.asarray(system.D), system.dt, system.input_labels, system.output_labels,
                   system.state_labels, system.name)

    def to_control(self):
        """The same system as a ``control.StateSpace``.

        Returns
        -------
        control.StateSpace
            Discrete-time, ``dt`` = the sampling period, same signal names.
        """
        return control.ss(self.A, self.B, self.C, self.D, self.dt, inputs=self.inputs,
                          outputs=self.outputs, states=self.states, name=self.name)


def sampled_bending_modes(natural_frequency, damping_ratio, names, sampling_period):
    """:func:`bending_modes` discretised by zero-order hold, without python-control.

    Equals ``discretize(bending_modes(...), sampling_period)`` (matrices,
    sampling period and signal names; the system name is
    ``bending_modes$sampled`` as python-control names a sampled system).

    Parameters
    ----------
    natural_frequency : array_like, shape (p,)
        [Hz], > 0.
    damping_ratio : array_like, shape (p,)
        In (0, 1].
    names : sequence of str or None
        Names of the p axes.
    sampling_period : float
        T [s], > 0.

    Returns
    -------
    SampledSystem
        p inputs [µm], p outputs [µm], 2p states.

    Raises
    ------
    DynamicsError
        As :func:`bending_modes`, or for a non-positive sampling period.
    """
    A, B, C, D, labels = _bending_matrices(natural_frequency, damping_ratio, names)
    Ad, Bd = zoh(A, B, sampling_period)
    return SampledSystem(Ad, Bd, C, D, sampling_period, name="bending_modes$sampled", **labels)


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
