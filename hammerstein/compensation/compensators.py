"""Feedforward compensators of the multivariable PI hysteresis.

Length: about 950 lines, most of them the numpydoc of four compensators that
share the convergence analysis above them (midpoint gains, the rho report);
splitting them would scatter one theorem's law over several modules.

The inverse multiplicative compensator of Theorem 4.1 of the paper,
``U(t) = Yr(t) + U(t-T) - Gamma(U(t-T))``, is a fixed-point iteration, one
step per sample, that converges only when ``rho(I - J) < 1`` for the slope
matrices J of the model (docs/compensator.md). Normalised by a static gain matrix K,

``U(t) = U(t-T) + K^-1 (Yr(t) - Gamma(U(t-T)))``,

it converges when ``rho(I - K^-1 J) < 1`` for every reachable J; K = I is
the paper's literal law.

The family, each built from an identified model with one call:

- :class:`InverseMultiplicativeCompensator` (multivariable, normalised; delay
  or first-order low-pass feedback; iterations per sample);
- :func:`diagonal_compensator`: the same law on the direct transfers only;
- :class:`PerAxisInverseCompensator`: the per-axis analytic inverse PI of
  Kuhnen & Janocha (paper ref. [20], docs/per-axis-inverse.md, :mod:`hammerstein.compensation.inverse`);
- :class:`StaticGainCompensator`: no hysteresis compensation, ``U = K^-1 Yr``.

All have ``simulate(reference (m, N) [µm], initial_state=None) -> (inputs
(m, N) [V], final_state)``, ``name``, ``n_states`` and ``initial_state()``.
"""

from __future__ import annotations

import functools
import itertools
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.compensation.inverse import kuhnen_inverse
from hammerstein.compensation.reference_range import _direct_name, _square, check_reference_range
from hammerstein.compensation.reference_check import check_reference
from hammerstein.core.numbers import MAX_ITERATIONS, check_integer
from hammerstein.exceptions import (CompensatorDivergence, CompensatorError, ConvergenceWarning,
                                    HysteresisError, RangeWarning)
from hammerstein.simulation import CompensatorLaw, simulate_compensator, state_vector

__all__ = [
    "CompensatorError",
    "CompensatorDivergence",
    "ConvergenceWarning",
    "ConvergenceReport",
    "convergence_report",
    "midpoint_gains",
    "InverseMultiplicativeCompensator",
    "diagonal_compensator",
    "PerAxisInverseCompensator",
    "StaticGainCompensator",
    "RangeWarning",
    "check_reference_range",
]


@dataclass
class ConvergenceReport:
    """Spectral radii of ``I - K^-1 J`` over the reachable slope matrices.

    Parameters
    ----------
    max_radius : float
        Largest ``rho(I - K^-1 J)`` over the slope matrices outside the dead
        band (every input past its first threshold) [-].
    min_radius : float
        Smallest such radius [-].
    worst_slopes : numpy.ndarray, shape (m, m)
        Slope matrix J [µm/V] where the radius is largest.
    radii : numpy.ndarray, shape (n_matrices,)
        All radii, in the order of the enumerated slope matrices.
    n_matrices : int
        Number of slope matrices examined.

    Attributes
    ----------
    converges : bool
        ``max_radius < 1``.
    """

    max_radius: float
    min_radius: float
    worst_slopes: np.ndarray
    radii: np.ndarray = field(repr=False)
    n_matrices: int = 0

    @property
    def converges(self) -> bool:
        """True when ``max_radius < 1``: the iteration contracts on every branch."""
        return bool(self.max_radius < 1.0)


def midpoint_gains(model: MultivariablePI):
    """Per-axis gains that minimise the direct part of ``rho(I - K^-1 J)``.

    For a scalar fixed-point step ``u <- u + (y_r - Gamma(u)) / K`` on a
    branch whose slope J lies in ``[S_min, S_max]`` (``S_min > 0``), the
    contraction factor ``max |1 - J/K|`` is smallest, and equal to
    ``(S_max - S_min) / (S_max + S_min) < 1``, at ``K = (S_min + S_max) / 2``
    (the classical optimal relaxation of a fixed-point iteration). The slopes
    are the cumulative weight sums of each direct transfer (docs/compensator.md),
    outside the dead band.

    Parameters
    ----------
    model : MultivariablePI
        Square model.

    Returns
    -------
    numpy.ndarray, shape (m,)
        ``K_ll`` [µm/V].

    Raises
    ------
    CompensatorError
        If a direct transfer has a non-positive reachable slope: no scalar
        gain makes the iteration contract there.
    """
    gains = []
    for k in range(model.n_inputs):
        slopes = model.slope_levels(k)[1:, k]
        lo, hi = float(slopes.min()), float(slopes.max())
        if lo <= 0:
            raise CompensatorError(
                f"gain: the direct transfer of input {model.input_names[k]} has a reachable "
                f"slope {lo:.3g} µm/V <= 0; no positive gain makes rho(I - K^-1 J) < 1")
        gains.append(0.5 * (lo + hi))
    return np.asarray(gains)


def _is_midpoint(gain):
    return isinstance(gain, str) and gain == "midpoint"


def _gain_words(gain):
    """A compensator's ``gain`` for its messages: ``gain='midpoint'``, ``gain K = diag(...) µm/V``
    (a matrix, given or chosen by default: its values, not who gave it)."""
    if isinstance(gain, str):
        return f"gain={gain!r}"
    K = np.atleast_2d(np.asarray(gain, dtype=float))
    if K.shape[0] == K.shape[1] and np.array_equal(K, np.diag(np.diag(K))):
        return "gain K = diag(" + ", ".join(f"{v:.4g}" for v in np.diag(K)) + ") µm/V"
    return "gain K = [" + "; ".join(", ".join(f"{v:.4g}" for v in row) for row in K) + "] µm/V"


def _inverse_gain(model, gain):
    m = model.n_inputs
    if model.n_outputs != m:
        raise CompensatorError(
            f"model: the inverse multiplicative compensator needs a square model, "
            f"found {model.n_outputs} outputs and {m} inputs (paper Section 4)")
    if gain is None or (isinstance(gain, str) and gain == "secant"):
        K = np.diag(np.diag(model.secant_gains()))
    elif isinstance(gain, str) and gain == "identity":
        K = np.eye(m)
    elif isinstance(gain, str) and gain == "midpoint":
        K = np.diag(midpoint_gains(model))
    elif isinstance(gain, str):
        raise CompensatorError(
            f"gain: expected 'secant', 'midpoint', 'identity' or an {m}x{m} matrix [µm/V], "
            f"found {gain!r}")
    else:
        K = np.asarray(gain, dtype=float)
        if K.ndim == 0:
            K = K * np.eye(m)
        elif K.ndim == 1 and K.size == m:
            K = np.diag(K)
        if K.shape != (m, m) or not np.all(np.isfinite(K)):
            found = f"shape {K.shape}" if K.shape != (m, m) else "non-finite values"
            raise CompensatorError(f"gain: expected a {m}x{m} finite matrix [µm/V], found {found}")
    try:
        Kinv = np.linalg.inv(K)
    except np.linalg.LinAlgError as exc:
        raise CompensatorError(f"gain: the gain matrix K is singular: {K.tolist()}") from exc
    return K, Kinv


def convergence_report(model: MultivariablePI, gain=None, max_matrices=100_000):
    """Check ``rho(I - K^-1 J) < 1`` over the reachable slope matrices.

    Column k of J steps through the cumulative weight sums of the components
    driven by input k as the travel of u_k since its last reversal grows
    (:meth:`MultivariablePI.slope_levels`). Every combination of columns is
    examined, except the dead band (an input that has not yet travelled past
    twice its smallest threshold), where the iteration integrates the error
    with ``rho = 1`` until the play operators move.

    Parameters
    ----------
    model : MultivariablePI
        Square model (m inputs, m outputs).
    gain : {'secant', 'midpoint', 'identity'} or array_like, shape (m, m), optional
        Normalisation K [µm/V]; default the diagonal secant gains of the
        direct transfers over the identified range (docs/compensator.md).
    max_matrices : int
        Upper bound on the number of combinations examined; beyond it a
        random subset (fixed seed) is used.

    Returns
    -------
    ConvergenceReport

    Raises
    ------
    CompensatorError
        If the model is not square or K is invalid.
    """
    K, Kinv = _inverse_gain(model, gain)
    m = model.n_inputs
    levels = [model.slope_levels(k)[1:] for k in range(m)]  # skip dead band
    total = int(np.prod([len(lv) for lv in levels]))
    if total <= max_matrices:
        combos = np.array(list(itertools.product(*[range(len(lv)) for lv in levels])),
                          dtype=np.int64).reshape(-1, m)
    else:
        rng = np.random.default_rng(0)
        combos = np.column_stack([rng.integers(len(lv), size=max_matrices) for lv in levels])
    # J[c, :, k] = levels[k][combos[c, k]]: every slope matrix at once, one
    # batched eigenvalue call instead of one per matrix
    J = np.stack([levels[k][combos[:, k]] for k in range(m)], axis=2)
    radii = np.max(np.abs(np.linalg.eigvals(np.eye(m) - Kinv @ J)), axis=1)
    worst = J[int(np.argmax(radii))]
    return ConvergenceReport(max_radius=float(radii.max()), min_radius=float(radii.min()),
                             worst_slopes=worst, radii=radii, n_matrices=radii.size)


def _gain_text(K):
    """The compensator gain K in a few numbers: its diagonal [µm/V] (and 'full' when coupled)."""
    K = np.asarray(K, dtype=float)
    diag = ", ".join(f"{k:.4g}" for k in np.diag(K))
    full = np.any(K - np.diag(np.diag(K)) != 0)
    return f"K {'full, diagonal' if full else 'diagonal'} [{diag}] µm/V"


@dataclass
class InverseMultiplicativeCompensator:
    """Multivariable inverse multiplicative compensator, Theorem 4.1.

    ``U(t) = U(t-T) + K^-1 (Yr(t) - Gamma(U(t-T)))`` (docs/compensator.md); with
    ``gain='identity'`` it is the paper's literal law. The compensator is
    built from the model alone: no parameter is computed beyond K.

    Parameters
    ----------
    model : MultivariablePI
        Identified square model, m inputs [V], m outputs [µm].
    gain : {'secant', 'midpoint', 'identity'} or array_like, optional
        Normalisation K [µm/V]: ``'secant'`` (default) the diagonal secant
        gains of the direct transfers over ``model.input_amplitude``;
        ``'midpoint'`` the per-axis gains that minimise the contraction
        factor (:func:`midpoint_gains`), for models whose slopes spread over
        more than 3:1 (e.g. identified where phase lag steepens the branch
        ends); ``'identity'`` the literal law of the paper; or an explicit
        matrix.
    iterations : int
        Fixed-point iterations per sample (1 = the paper's law), 1 to
        :data:`~hammerstein.core.numbers.MAX_ITERATIONS` (100); further
        iterations use the play states frozen at the previous sample.
    check : {'error', 'warn', 'ignore'}
        What to do when :func:`convergence_report` finds
        ``rho(I - K^-1 J) >= 1``.
    divergence_bound : float, optional
        |U| [V] beyond which the simulation stops as diverged; default
        1000 times the largest identified input amplitude (or 1e4 V).
    name : str
        Label used in reports.
    feedback : {'delay', 'lowpass'}
        ``'delay'`` (default): the one-sample delay of Theorem 4.1.
        ``'lowpass'``: a first-order low-pass filter in the feedback path
        (paper Section 6), see Notes.
    cutoff_hz : float, optional
        Cut-off frequency of the low-pass feedback [Hz]; required for
        ``'lowpass'``, > 0 and below the Nyquist frequency ``1/(2T)``.
    sampling_period : float, optional
        Sampling period T [s]; required for ``'lowpass'``.

    Notes
    -----
    With ``v(t) = U(t) - K^-1 Gamma(U(t))`` the low-pass law is

    ``v_f(t) = a v_f(t-T) + (1-a) v(t-T)``, ``a = exp(-2 pi cutoff_hz T)``,
    ``U(t) = K^-1 Yr(t) + v_f(t)``;

    ``a = 0`` gives back the delay law; the low-pass law takes one
    iteration per sample. Flat state: ``U(t-T)`` (m) then, for
    ``'lowpass'``, ``v_f(t-T)`` (m) [V], then the play states [V].

    Attributes
    ----------
    K : numpy.ndarray, shape (m, m)
        Gain matrix [µm/V].
    K_inv : numpy.ndarray, shape (m, m)
        Its inverse [V/µm].
    convergence : ConvergenceReport
        The check made at construction.
    filter_coefficient : float
        ``a`` of the low-pass feedback (0 for the delay).

    Raises
    ------
    CompensatorError
        On a non-square model, an invalid gain, iteration count, feedback,
        cut-off or sampling period, or (with ``check='error'``) a law that
        cannot converge.

    Examples
    --------
    The compensator inverts the model it is built from; fed to that model
    (a static plant), its output follows the reference within the one-sample
    lag of the fixed-point step:

    >>> import numpy as np
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> model = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25]), 0.1],
    ...      [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.0, 1.0], [0.8, 0.4])]],
    ...     input_amplitude=[10.0, 10.0])
    >>> t = np.arange(400)
    >>> reference = np.vstack([8 * np.sin(2 * np.pi * t / 200), 4 * np.sin(2 * np.pi * t / 100)])
    >>> from hammerstein import InverseMultiplicativeCompensator
    >>> comp = InverseMultiplicativeCompensator(model)
    >>> np.round(comp.K, 3)                      # diagonal secant gains [µm/V]
    array([[1.65, 0.  ],
           [0.  , 1.16]])
    >>> print(f"rho(I - K^-1 J) <= {comp.convergence.max_radius:.3f}")
    rho(I - K^-1 J) <= 0.418
    >>> inputs, final_state = comp.simulate(reference)
    >>> y, _ = model.simulate(inputs)
    >>> print(f"{np.max(np.abs(y - reference)):.3f} um")
    0.115 um
    """

    model: MultivariablePI
    gain: object = "secant"
    iterations: int = 1
    check: str = "error"
    divergence_bound: float | None = None
    name: str = "multivariable"
    feedback: str = "delay"
    cutoff_hz: float | None = None
    sampling_period: float | None = None

    def __post_init__(self):
        self.iterations = check_integer(self.iterations, "iterations", 1, MAX_ITERATIONS,
                                        CompensatorError)
        self._check_feedback()
        if self.check not in ("error", "warn", "ignore"):
            raise CompensatorError(f"check: expected 'error', 'warn' or 'ignore', found {self.check!r}")
        self.K, self.K_inv = _inverse_gain(self.model, self.gain)
        self.convergence = convergence_report(self.model, self.K)
        if not self.convergence.converges and self.check != "ignore":
            msg = (f"gain: rho(I - K^-1 J) reaches {self.convergence.max_radius:.3g} >= 1 "
                   f"over the slopes of the model of this {self.name} compensator "
                   f"({_gain_words(self.gain)}): the iteration may diverge where they persist; "
                   + self._midpoint_advice())
            if self.check == "error":
                raise CompensatorError(msg)
            warnings.warn(msg, ConvergenceWarning, stacklevel=2)
        if self.divergence_bound is None:
            amp = self.model.input_amplitude
            self.divergence_bound = 1e3 * float(np.max(amp)) if amp is not None else 1e4


    def _midpoint_advice(self):
        """What the midpoint gain would do, named only where it lowers the radius.

        It was named for every gain but its own, also where it raised the radius or
        where no gain converges (a classical PI at rho 3.79 with every gain: "gain='midpoint'
        minimises the radius" beside the note that none converges).
        """
        if _is_midpoint(self.gain):
            return ("the midpoint gain makes each direct transfer contract on its own, so "
                    "the cross-couplings bring rho to 1 or more: an explicit gain matrix K "
                    "may do better (docs/compensator.md)")
        try:
            mid = convergence_report(self.model, _inverse_gain(self.model, "midpoint")[0])
        except (CompensatorError, HysteresisError, ValueError, np.linalg.LinAlgError) as exc:
            return f"no midpoint gain ({str(exc).removeprefix('gain: ')}) (docs/compensator.md)"
        if mid.max_radius < self.convergence.max_radius:
            return (f"gain='midpoint' lowers it to {mid.max_radius:.3g} "
                    f"(docs/compensator.md)")
        return (f"gain='midpoint' does not lower it ({mid.max_radius:.3g}): the cross-couplings "
                f"are too strong for a diagonal gain (docs/compensator.md)")
    def _check_feedback(self):
        if self.feedback not in ("delay", "lowpass"):
            raise CompensatorError(f"feedback: expected 'delay' or 'lowpass', found {self.feedback!r}")
        T = self.sampling_period
        if T is not None:
            if isinstance(T, bool) or not isinstance(T, (int, float, np.integer, np.floating)) \
                    or not (np.isfinite(T) and T > 0):
                raise CompensatorError(f"sampling_period: expected a positive time [s], found {T!r}")
            self.sampling_period = float(T)
        fc = self.cutoff_hz
        if self.feedback == "delay":
            if fc is not None:
                raise CompensatorError(
                    f"cutoff_hz: only used with feedback='lowpass', found {fc!r} with feedback='delay'")
            self.filter_coefficient = 0.0
            return
        if self.iterations != 1:
            raise CompensatorError(
                f"iterations: the low-pass feedback law takes 1 iteration per sample, found {self.iterations}")
        if fc is None or self.sampling_period is None:
            raise CompensatorError(
                "cutoff_hz, sampling_period: feedback='lowpass' needs a cut-off frequency [Hz] "
                "and the sampling period [s]")
        if isinstance(fc, bool) or not isinstance(fc, (int, float, np.integer, np.floating)) \
                or not np.isfinite(fc):
            raise CompensatorError(f"cutoff_hz: expected a frequency [Hz], found {fc!r}")
        nyquist = 0.5 / self.sampling_period
        if not 0 < fc < nyquist:
            raise CompensatorError(
                f"cutoff_hz: expected 0 < cutoff_hz < {nyquist:g} Hz (Nyquist for "
                f"T = {self.sampling_period:g} s), found {fc!r}")
        self.cutoff_hz = float(fc)
        self.filter_coefficient = float(np.exp(-2 * np.pi * self.cutoff_hz * self.sampling_period))

    @property
    def n_states(self) -> int:
        """Length of the flat state: U(t-T), [v_f(t-T) for 'lowpass'], play states."""
        m = self.model.n_inputs
        return m * (2 if self.feedback == "lowpass" else 1) + self.model.n_hysterons

    def __repr__(self):
        """Class, model size, gain, convergence radius and law options (no arrays)."""
        law = f"feedback={self.feedback!r}"
        if self.feedback == "lowpass":
            law += f", cutoff_hz={self.cutoff_hz:g}"
        gain = self.gain if isinstance(self.gain, str) else "given"
        return (f"InverseMultiplicativeCompensator(name={self.name!r}, model {self.model.size_text()}, "
                f"gain={gain!r}: {_gain_text(self.K)}, max rho {self.convergence.max_radius:.3g}, "
                f"iterations={self.iterations}, {law})")

    def initial_state(self, initial_state=None):
        """Validated copy of a flat compensator state (the rest state by default).

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            ``U(t-T)`` [V], (``v_f(t-T)`` [V] for ``'lowpass'``), play states [V].

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array; by default ``U(t-T)`` and ``v_f`` at 0 V and the model's
            default play states (zeros, or where the demagnetising cycle leaves
            them: ``MultivariablePI.demagnetised``).

        Raises
        ------
        HysteresisError
            On a wrong shape or non-finite values.
        """
        if initial_state is None:       # the fused law's own rest state
            return self.packed_law().rest_state()
        return state_vector(initial_state, self.n_states)

    def simulate(self, reference, initial_state=None):
        """Input voltages that make the model follow a reference.

        Parameters
        ----------
        reference : array_like, shape (m, n_samples)
            Reference displacements Yr [µm].
        initial_state : array_like, shape (n_states,), optional
            U(t-T) [V] then the model's play states [V]; :meth:`initial_state` by
            default.

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            Compensator output U [V].
        final_state : numpy.ndarray, shape (n_states,)
            State after the last sample, for a chunked continuation.

        Raises
        ------
        CompensatorDivergence
            If U becomes non-finite or exceeds ``divergence_bound``.
        CompensatorError
            On a reference sample the exported C skips with status 4, the first one
            named; nothing is run, the caller's state stays valid
            (:func:`~hammerstein.compensation.reference_check.check_reference`).
        HysteresisError
            On a wrongly shaped reference or a non-finite sample (named).

        Warns
        -----
        RangeWarning
            If the reference leaves the identified output range
            (:func:`check_reference_range`).
        """
        reference = check_reference(self, reference)
        check_reference_range(self.model, reference)
        return simulate_compensator(self, reference, initial_state)

    def packed_law(self):
        """The law this compensator computes, for the fused chain kernels.

        Read from the current attributes (``feedback``, ``cutoff_hz``,
        ``sampling_period``, ``K_inv``, ``iterations``, ``divergence_bound``)
        at every call.

        Returns
        -------
        hammerstein.simulation.CompensatorLaw
            No reference pre-filter; the reference check is
            :func:`check_reference_range` on the model.

        Raises
        ------
        CompensatorError
            On an unknown ``feedback`` or a low-pass law without a positive
            ``cutoff_hz`` [Hz] and ``sampling_period`` [s].
        """
        if self.feedback == "delay":
            lowpass, pole = False, 0.0
        elif self.feedback != "lowpass":
            raise CompensatorError(f"feedback: expected 'delay' or 'lowpass', found {self.feedback!r}")
        else:
            fc, T = self.cutoff_hz, self.sampling_period
            if fc is None or T is None or not (fc > 0 and T > 0):
                raise CompensatorError(
                    "feedback: the low-pass law needs cutoff_hz [Hz] > 0 and sampling_period [s] > 0, "
                    f"found cutoff_hz={fc!r}, sampling_period={T!r}")
            lowpass, pole = True, math.exp(-2.0 * math.pi * float(fc) * float(T))
        return CompensatorLaw(model=self.model, K_inv=self.K_inv, iterations=int(self.iterations),
                              divergence_bound=float(self.divergence_bound), lowpass=lowpass,
                              pole=pole, prefilter=None,
                              check_reference=functools.partial(check_reference_range, self.model))


def diagonal_compensator(model: MultivariablePI, **kwargs):
    """The inverse multiplicative compensator restricted to the direct transfers.

    Builds a copy of the model with every cross-coupling removed (off-diagonal
    components ``None``) and the same ``input_amplitude``, then an
    :class:`InverseMultiplicativeCompensator` on it: the direct transfers are
    linearised exactly as by the multivariable law, the cross-couplings are
    left, which isolates what cross-coupling compensation buys (issue 4).

    Parameters
    ----------
    model : MultivariablePI
        Identified square model.
    **kwargs
        Passed to :class:`InverseMultiplicativeCompensator` (gain,
        iterations, feedback, ...); ``name`` defaults to ``'diagonal'``.

    Returns
    -------
    InverseMultiplicativeCompensator
        On the model without its cross-couplings.

    Raises
    ------
    CompensatorError
        If the model is not square or a direct transfer is absent.

    Examples
    --------
    The cross-couplings of the model stay in the output (about 0.05 µm/V of
    ``ux`` on y):

    >>> import numpy as np
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> model = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25]), 0.1],
    ...      [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.0, 1.0], [0.8, 0.4])]],
    ...     input_amplitude=[10.0, 10.0])
    >>> t = np.arange(400)
    >>> reference = np.vstack([8 * np.sin(2 * np.pi * t / 200), 4 * np.sin(2 * np.pi * t / 100)])
    >>> from hammerstein import diagonal_compensator
    >>> comp = diagonal_compensator(model)
    >>> comp.name, comp.model.component(1, 0) is None
    ('diagonal', True)
    >>> y, _ = model.simulate(comp.simulate(reference)[0])
    >>> np.round(np.max(np.abs(y - reference), axis=1), 3)
    array([0.468, 0.402])
    """
    _square(model, "the diagonal compensator")
    comps = [[c if l == k else None for k, c in enumerate(row)] for l, row in enumerate(model.components)]
    for l in range(model.n_inputs):
        if not isinstance(comps[l][l], PrandtlIshlinskii):
            raise CompensatorError(
                f"model: {_direct_name(model, l)}: the diagonal compensator needs a hysteresis "
                f"direct transfer, found {comps[l][l]!r}")
    # everything but the cross-couplings: the output offset and the output map too (left
    # out, the law tracked Gamma(U) = Yr with the sensor offset in it: from a reference at
    # rest, an identified model's voltages crept 0.72 -> 1.64 V)
    diag = model.replace(components=comps)
    kwargs.setdefault("name", "diagonal")
    return InverseMultiplicativeCompensator(diag, **kwargs)


def _direct_secant(model):
    if model.input_amplitude is None:
        raise CompensatorError("model: input_amplitude: needed for the secant gains of the direct transfers")
    K = np.diag(model.secant_gains())
    for l, k in enumerate(K):
        if not (np.isfinite(k) and k != 0):
            raise CompensatorError(
                f"model: {_direct_name(model, l)}: the secant gain is {k!r} µm/V; cannot invert it")
    return K


@dataclass
class StaticGainCompensator:
    """No hysteresis compensation: ``U = K^-1 Yr`` (the reference case).

    K is the diagonal matrix of the secant gains of the direct transfers over
    the identified range, ``K_ll = sum_i w_i (A_l - r_i) / A_l`` (docs/compensator.md).

    Parameters
    ----------
    model : MultivariablePI
        Identified square model with ``input_amplitude``.
    name : str
        Label used in reports.

    Attributes
    ----------
    K : numpy.ndarray, shape (m, m)
        Diagonal gain matrix [µm/V].

    Raises
    ------
    CompensatorError
        If the model is not square, has no ``input_amplitude`` or a zero
        secant gain.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> model = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25]), 0.1],
    ...      [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.0, 1.0], [0.8, 0.4])]],
    ...     input_amplitude=[10.0, 10.0])
    >>> t = np.arange(400)
    >>> reference = np.vstack([8 * np.sin(2 * np.pi * t / 200), 4 * np.sin(2 * np.pi * t / 100)])
    >>> from hammerstein import StaticGainCompensator
    >>> comp = StaticGainCompensator(model)
    >>> np.round(np.diag(comp.K), 3)             # secant gains over +-10 V [µm/V]
    array([1.65, 1.16])
    >>> y, _ = model.simulate(comp.simulate(reference)[0])
    >>> np.round(np.max(np.abs(y - reference), axis=1), 3)   # the hysteresis remains
    array([1.203, 0.754])
    """

    model: MultivariablePI
    name: str = "static gain"

    def __post_init__(self):
        _square(self.model, "the static-gain compensator")
        self.K = np.diag(_direct_secant(self.model))
        self.K_inv = np.diag(1.0 / np.diag(self.K))

    n_states = 0

    def __repr__(self):
        """Class, model size and the secant gains (no arrays)."""
        return f"StaticGainCompensator(name={self.name!r}, model {self.model.size_text()}, {_gain_text(self.K)})"

    def initial_state(self, initial_state=None):
        """The (empty) state; anything but None or an empty array is an error.

        Parameters
        ----------
        initial_state : None or array_like, shape (0,)
            No state.

        Returns
        -------
        numpy.ndarray, shape (0,)
            An empty array.

        Raises
        ------
        HysteresisError
            If a non-empty state is given.
        """
        s = np.zeros(0) if initial_state is None else np.asarray(initial_state, dtype=float)
        if s.shape != (0,):
            raise HysteresisError(f"initial_state: the static-gain compensator has no state, found shape {s.shape}")
        return s

    def simulate(self, reference, initial_state=None):
        """Input voltages ``U = K^-1 Yr``.

        Parameters
        ----------
        reference : array_like, shape (m, n_samples)
            Reference displacements [µm].
        initial_state : None or empty array
            The compensator has no state.

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            Voltages [V].
        final_state : numpy.ndarray, shape (0,)

        Warns
        -----
        RangeWarning
            If the reference leaves the identified range.
        """
        self.initial_state(initial_state)
        yr = self.model.check_inputs(reference, "reference")
        check_reference_range(self.model, yr)
        yr = self.model.gamma_reference(yr)        # Gamma(U) = S^-1(Yr - c)
        return self.K_inv @ yr, np.zeros(0)

    def packed_law(self):
        """None: the fused chain kernels do not run this compensator (see
        :mod:`hammerstein.simulation`); :func:`~hammerstein.simulation.simulate_chain`
        calls :meth:`simulate`.

        Returns
        -------
        None
        """
        return None


@dataclass
class PerAxisInverseCompensator:
    """Per-axis inverse PI of Kuhnen & Janocha, the paper's "existing technique".

    Input l is the analytic inverse of the direct transfer ``Gamma_ll``
    applied to reference l (:func:`hammerstein.compensation.inverse.kuhnen_inverse`,
    docs/per-axis-inverse.md, paper ref. [20]); the cross-couplings are not compensated
    (paper Fig. 9). A linear direct gain g is inverted as ``1/g``.

    Parameters
    ----------
    model : MultivariablePI
        Identified square model.
    name : str
        Label used in reports.

    Attributes
    ----------
    inverses : list
        Per axis, an :class:`~hammerstein.compensation.inverse.InversePI` or the float
        ``1/g`` [V/µm].

    Notes
    -----
    The flat state concatenates the axes' inverse states; by default the state
    consistent with the model's default play states (:meth:`consistent_state`;
    zeros for zero play states). No per-sample loop here: each axis
    is a PI operator simulation then a vectorised inverse play.

    Raises
    ------
    CompensatorError
        If the model is not square, a direct transfer is absent or zero, or
        not invertible (some cumulative weight sum ``S_i <= 0``; the message
        names the component and i).

    Examples
    --------
    Each direct transfer is inverted exactly; what remains is the
    uncompensated cross-coupling:

    >>> import numpy as np
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii
    >>> model = MultivariablePI(
    ...     [[PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25]), 0.1],
    ...      [PrandtlIshlinskii([0.0, 1.5], [0.05, 0.02]), PrandtlIshlinskii([0.0, 1.0], [0.8, 0.4])]],
    ...     input_amplitude=[10.0, 10.0])
    >>> t = np.arange(400)
    >>> reference = np.vstack([8 * np.sin(2 * np.pi * t / 200), 4 * np.sin(2 * np.pi * t / 100)])
    >>> from hammerstein import PerAxisInverseCompensator
    >>> comp = PerAxisInverseCompensator(model)
    >>> y, _ = model.simulate(comp.simulate(reference)[0])
    >>> np.round(np.max(np.abs(y - reference), axis=1), 3)
    array([0.367, 0.33 ])
    """

    model: MultivariablePI
    name: str = "per-axis inverse"

    def __post_init__(self):
        _square(self.model, "the per-axis inverse compensator")
        self.inverses = []
        for l in range(self.model.n_inputs):
            comp, label = self.model.components[l][l], _direct_name(self.model, l)
            if isinstance(comp, PrandtlIshlinskii):
                try:
                    self.inverses.append(kuhnen_inverse(comp, name=label,
                                                        output_scale=self._output_scale(l)))
                except HysteresisError as exc:
                    raise CompensatorError(f"model: {exc}") from None
            elif comp is None or comp == 0:
                raise CompensatorError(f"model: {label}: no direct transfer to invert, found {comp!r}")
            else:
                self.inverses.append(1.0 / comp)
        sizes = [inv.n_states if not isinstance(inv, float) else 0 for inv in self.inverses]
        self._offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)

    def _output_scale(self, l):
        """The largest magnitude of output l's references [µm]: its offset plus the direct
        transfer's output over the identified input range (when known)."""
        m = self.model
        offset = 0.0 if m.output_offset is None else abs(float(m.output_offset[l]))
        if m.input_amplitude is None:
            return offset
        volts = float(m.input_amplitude[l]) + (0.0 if m.input_centre is None
                                               else abs(float(m.input_centre[l])))
        return offset + float(np.sum(np.abs(m.components[l][l].weights))) * volts

    @property
    def n_states(self) -> int:
        """Sum of the axes' inverse state lengths."""
        return int(self._offsets[-1])

    def __repr__(self):
        """Class, model size and the inverse of each axis (no arrays)."""
        axes = ", ".join(
            f"{name} {'gain ' + format(inv, '.4g') if isinstance(inv, float) else 'inverse PI'}"
            for name, inv in zip(self.model.input_names, self.inverses))
        return (f"PerAxisInverseCompensator(name={self.name!r}, model {self.model.size_text()}; "
                f"{axes}; {self.n_states} states)")

    def initial_state(self, initial_state=None):
        """Validated copy of the flat state (consistent with the model's start by default).

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            The axes' inverse states, concatenated (see
            :meth:`~hammerstein.compensation.inverse.InversePI.initial_state`).

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array.

        Raises
        ------
        HysteresisError
            On a wrong shape, non-finite values or an inconsistent
            inverse-play state.
        """
        if initial_state is None:      # the model's default plays, the inputs at rest (0 V)
            return self.consistent_state(self.model.initial_state(),
                                         np.zeros(self.model.n_inputs))
        s = state_vector(initial_state, self.n_states)
        for l, inv in enumerate(self.inverses):
            if not isinstance(inv, float):
                inv.initial_state(s[self._offsets[l]:self._offsets[l + 1]])
        return s.copy()

    def consistent_state(self, model_state, last_inputs):
        """Compensator state matching a state of the model (plant play states).

        Parameters
        ----------
        model_state : array_like, shape (model.n_hysterons,)
            Flat play states of the model [V] (ordered output, input,
            threshold; :meth:`MultivariablePI.hysterons`).
        last_inputs : array_like, shape (m,)
            The inputs that led to it [V].

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            So that the direct outputs follow the reference from the first
            sample (:meth:`~hammerstein.compensation.inverse.InversePI.consistent_state`).

        Raises
        ------
        HysteresisError
            On wrong shapes or inputs inconsistent with the play states.
        """
        z = self.model.initial_state(model_state)
        u_last = np.asarray(last_inputs, dtype=float)
        if u_last.shape != (self.model.n_inputs,):
            raise HysteresisError(
                f"last_inputs: expected shape ({self.model.n_inputs},), found {u_last.shape}")
        out = np.zeros(self.n_states)
        start = 0
        for l, row in enumerate(self.model.components):
            for k, comp in enumerate(row):
                if not isinstance(comp, PrandtlIshlinskii):
                    continue
                if l == k:
                    a, b = self._offsets[l], self._offsets[l + 1]
                    out[a:b] = self.inverses[l].consistent_state(
                        z[start:start + comp.n_hysterons], u_last[l])
                start += comp.n_hysterons
        return out

    def simulate(self, reference, initial_state=None):
        """Input voltages that invert each direct transfer.

        Parameters
        ----------
        reference : array_like, shape (m, n_samples)
            Reference displacements [µm].
        initial_state : array_like, shape (n_states,), optional
            :meth:`initial_state` by default.

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            Voltages [V].
        final_state : numpy.ndarray, shape (n_states,)

        Raises
        ------
        CompensatorError
            On a reference sample the exported C skips with status 4, the first one
            named; nothing is run, the caller's state stays valid
            (:func:`~hammerstein.compensation.reference_check.check_reference`).
        HysteresisError
            On a wrongly shaped reference or a non-finite sample (named).

        Warns
        -----
        RangeWarning
            If the reference leaves the identified range.
        """
        yr = check_reference(self, reference)
        s = self.initial_state(initial_state)
        check_reference_range(self.model, yr)
        yr = self.model.gamma_reference(yr)        # Gamma(U) = S^-1(Yr - c)
        u = np.empty_like(yr)
        final = s.copy()
        for l, inv in enumerate(self.inverses):
            if isinstance(inv, float):
                u[l] = inv * yr[l]
                continue
            a, b = self._offsets[l], self._offsets[l + 1]
            u[l], final[a:b] = inv.simulate(yr[l], s[a:b])
        return u, final

    def packed_law(self):
        """None: the fused chain kernels do not run this compensator (see
        :mod:`hammerstein.simulation`); :func:`~hammerstein.simulation.simulate_chain`
        calls :meth:`simulate`.

        Returns
        -------
        None
        """
        return None
