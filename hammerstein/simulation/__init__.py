"""The sample-by-sample stepping core.

All time stepping of the project lives here: the play operators, the
multivariable PI forward model, the open-loop Hammerstein plant, the
compensator, and the compensator -> plant chain, single or batched.

Two backends compute the same thing:

* ``"numba"`` (default): compiled kernels of :mod:`hammerstein.kernels`, one
  loop per record with no Python per sample;
* ``"numpy"``: plain numpy loops, the reference implementation and the test
  oracle of the kernels.

Every function takes explicit initial states and returns the final ones, so
a chunked run equals one long run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hammerstein.simulation import _kernels as kernels
from hammerstein.core.compensators import CompensatorDivergence, CompensatorError
from hammerstein.core.hysteresis import HysteresisError, state_vector

__all__ = [
    "simulate_plays",
    "simulate_hysteresis",
    "simulate_plant",
    "simulate_compensator",
    "simulate_chain",
    "simulate_chain_batch",
    "ChainResult",
    "BACKENDS",
]

BACKENDS = ("numba", "numpy")


def _offset(model):
    """Output offset of a model as a (p, 1) column, or None."""
    off = getattr(model, "output_offset", None)
    return None if off is None else np.asarray(off, dtype=float)[:, None]


def _check_backend(backend):
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {BACKENDS}, found {backend!r}")


# -- packing ---------------------------------------------------------------------
#: plays of each input are padded to a multiple of this (AVX: 4 doubles)
LANES = 4


@dataclass
class PackedModel:
    """Multivariable PI model as kernel arrays (see :mod:`hammerstein.kernels`).

    Hysterons with the same input, threshold and initial play state are one
    play operator (they evolve identically), so the kernels update each play
    once and weight it into every output.

    Attributes
    ----------
    start : numpy.ndarray, shape (m + 1,), int64
    r : numpy.ndarray, shape (n_plays,) [V]
    W : numpy.ndarray, shape (p, n_plays) [µm/V]
    G : numpy.ndarray, shape (p, m) [µm/V]
    index : numpy.ndarray, shape (n_hysterons,), int64
        Play operator of each hysteron (flat state order of the model).
    rep : numpy.ndarray, shape (n_plays,), int64
        One hysteron of each play operator (-1 for the padding plays that
        round each input's plays up to a multiple of ``LANES``).
    """

    start: np.ndarray
    r: np.ndarray
    W: np.ndarray
    G: np.ndarray
    index: np.ndarray
    rep: np.ndarray

    def plays(self, hysteron_state):
        """Play states (n_plays,) from the flat hysteron state (n_hysterons,)."""
        s = np.zeros(self.rep.size)
        used = self.rep >= 0
        s[used] = np.asarray(hysteron_state, dtype=float)[self.rep[used]]
        return s

    def hysteron_state(self, play_state):
        """Flat hysteron state (n_hysterons,) from the play states."""
        return play_state[self.index]


def pack_model(model, state=None):
    """Pack a :class:`MultivariablePI` for the kernels, merging shared plays.

    Parameters
    ----------
    model : MultivariablePI
    state : numpy.ndarray, shape (n_hysterons,), optional
        Initial play states [V]; hysterons are merged only when equal here.

    Returns
    -------
    PackedModel
    """
    f = model.hysterons()
    nh = f["thresholds"].size
    s0 = np.zeros(nh) if state is None else np.asarray(state, dtype=float)
    keys = np.column_stack([f["input_index"].astype(float), f["thresholds"], s0])
    _, rep, index = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    index = np.asarray(index, dtype=np.int64).ravel()
    p, m = f["gain"].shape
    # pad every input's plays to a multiple of LANES (zero threshold and
    # weight: they follow u and add nothing) so the vector loops have no tail
    play_input = f["input_index"][rep]
    counts = np.bincount(play_input, minlength=m)
    padded = -(-counts // LANES) * LANES
    start = np.concatenate([[0], np.cumsum(padded)]).astype(np.int64)
    slot = start[play_input] + (np.arange(rep.size) - np.searchsorted(play_input, play_input))
    r = np.zeros(start[-1])
    r[slot] = f["thresholds"][rep]
    W = np.zeros((p, start[-1]))
    np.add.at(W, (f["output_index"], slot[index]), f["weights"])
    rep_padded = np.full(start[-1], -1, dtype=np.int64)
    rep_padded[slot] = rep
    return PackedModel(start=start, r=r, W=W, G=np.ascontiguousarray(f["gain"], dtype=float),
                       index=slot[index].astype(np.int64), rep=rep_padded)


# -- play operators / multivariable PI ---------------------------------------------
def simulate_plays(u, thresholds, state, backend="numba"):
    """Play operators of one input, eq. (1), on validated arrays.

    Called by :func:`hammerstein.hysteresis.play` (which validates).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    thresholds : numpy.ndarray, shape (n_hysterons,)
        Thresholds [V].
    state : numpy.ndarray, shape (n_hysterons,)
        Play outputs before the first sample [V].
    backend : {'numba', 'numpy'}

    Returns
    -------
    y : numpy.ndarray, shape (n_hysterons, n_samples)
    final_state : numpy.ndarray, shape (n_hysterons,)
    """
    _check_backend(backend)
    u = np.ascontiguousarray(u, dtype=float)
    r = np.ascontiguousarray(thresholds, dtype=float)
    s = np.array(state, dtype=float)
    if backend == "numpy":
        y = np.empty((r.size, u.size))
        for t in range(u.size):
            s = np.maximum(u[t] - r, np.minimum(u[t] + r, s))
            y[:, t] = s
        return y, s.copy()
    y = np.empty((r.size, u.size))
    kernels.play_kernel(u, r, s, y)
    return y, s


def simulate_hysteresis(model, inputs, initial_state=None, backend="numba"):
    """Outputs of a multivariable PI model for an input record, eq. (4).

    Parameters
    ----------
    model : MultivariablePI
    inputs : array_like, shape (m, n_samples)
        Input voltages [V].
    initial_state : array_like, shape (n_hysterons,), optional
        Initial play outputs [V]; zeros by default.
    backend : {'numba', 'numpy'}

    Returns
    -------
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm].
    final_state : numpy.ndarray, shape (n_hysterons,)
        Play outputs after the last sample [V].

    Raises
    ------
    HysteresisError
        On a wrongly shaped or non-finite input or state.
    """
    _check_backend(backend)
    u = model.check_inputs(inputs)
    s = model.initial_state(initial_state)
    if backend == "numpy":
        f = model.hysterons()
        y = np.empty((model.n_outputs, u.shape[1]))
        for t in range(u.shape[1]):
            ut = u[f["input_index"], t]
            s = np.maximum(ut - f["thresholds"], np.minimum(ut + f["thresholds"], s))
            y[:, t] = np.bincount(f["output_index"], weights=f["weights"] * s,
                                  minlength=model.n_outputs) + f["gain"] @ u[:, t]
    else:
        pk = pack_model(model, s)
        sp = pk.plays(s)
        y = np.empty((model.n_outputs, u.shape[1]))
        kernels.pi_kernel(np.ascontiguousarray(u), pk.start, pk.r, pk.W, pk.G, sp, y)
        s = pk.hysteron_state(sp)
    if _offset(model) is not None:
        y += _offset(model)
    return y, s


# -- plant -----------------------------------------------------------------------
def _linear_matrices(plant):
    return tuple(np.ascontiguousarray(M, dtype=float) for M in plant.matrices)


def simulate_plant(plant, inputs, initial_state=None, backend="numba"):
    """Open-loop response of a :class:`~hammerstein.plant.HammersteinPlant`.

    ``H(t) = Gamma(U(t))``; ``Y(t) = C x(t) + D H(t)``;
    ``x(t+T) = A x(t) + B H(t)`` (static plant: ``Y = H``).

    Parameters
    ----------
    plant : HammersteinPlant
    inputs : array_like, shape (m, n_samples)
        Input voltages [V].
    initial_state : array_like, shape (plant.n_states,), optional
        Play states [V] then linear states [µm]; zeros by default.
    backend : {'numba', 'numpy'}

    Returns
    -------
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm].
    final_state : numpy.ndarray, shape (plant.n_states,)

    Raises
    ------
    HysteresisError
        On a wrongly shaped or non-finite input or state.
    """
    _check_backend(backend)
    model = plant.hysteresis
    u = model.check_inputs(inputs)
    state = plant.initial_state(initial_state)
    nh = model.n_hysterons
    if backend == "numpy":
        h, play_final = simulate_hysteresis(model, u, state[:nh], backend="numpy")
        if plant.is_static:
            return h, play_final
        A, B, C, D = plant.matrices
        x = state[nh:]
        y = np.empty_like(h)
        off = _offset(model)
        if off is not None:   # the offset is a sensor zero, after the dynamics
            h = h - off
        for t in range(h.shape[1]):
            y[:, t] = C @ x + D @ h[:, t]
            x = A @ x + B @ h[:, t]
        if off is not None:
            y += off
        return y, np.concatenate([play_final, x])
    if plant.is_static:
        return simulate_hysteresis(model, u, state[:nh])
    pk = pack_model(model, state[:nh])
    sp = pk.plays(state[:nh])
    x = state[nh:].copy()
    A, B, C, D = _linear_matrices(plant)
    y = np.empty((model.n_outputs, u.shape[1]))
    kernels.plant_kernel(np.ascontiguousarray(u), pk.start, pk.r, pk.W, pk.G, sp,
                         A, B, C, D, x, y)
    if _offset(model) is not None:   # a sensor zero, after the dynamics
        y += _offset(model)
    return y, np.concatenate([pk.hysteron_state(sp), x])


# -- compensator -------------------------------------------------------------------
def compensator_law(compensator):
    """Feedback law of an inverse multiplicative compensator.

    Returns
    -------
    (lowpass, a) : (bool, float)
        ``lowpass`` False for the one-sample delay of Theorem 4.1; True for
        the first-order low-pass of Section 6 with pole
        ``a = exp(-2 pi cutoff_hz T)``.

    Raises
    ------
    CompensatorError
        On an unknown ``feedback`` or a low-pass without ``cutoff_hz`` /
        ``sampling_period``.
    """
    feedback = getattr(compensator, "feedback", "delay")
    if feedback == "delay":
        return False, 0.0
    if feedback != "lowpass":
        raise CompensatorError(f"feedback: expected 'delay' or 'lowpass', found {feedback!r}")
    fc = getattr(compensator, "cutoff_hz", None)
    T = getattr(compensator, "sampling_period", None)
    if T is None:
        T = getattr(getattr(compensator, "plant", None), "sampling_period", None)
    if fc is None or T is None or not (fc > 0 and T > 0):
        raise CompensatorError(
            "feedback: the low-pass law needs cutoff_hz [Hz] > 0 and sampling_period [s] > 0, "
            f"found cutoff_hz={fc!r}, sampling_period={T!r}")
    return True, math.exp(-2.0 * math.pi * float(fc) * float(T))


def compensator_state(compensator, initial_state=None):
    """Validated flat compensator state (zeros by default).

    Delay law: ``U(t-T)`` (m,) then play states (n_hysterons,). Low-pass law:
    ``U(t-T)``, the filtered correction ``v_f`` (m,), then the play states.

    Raises
    ------
    HysteresisError
        If the state has the wrong length or non-finite values.
    """
    lowpass, _ = compensator_law(compensator)
    model = compensator.model
    n = model.n_inputs * (2 if lowpass else 1) + model.n_hysterons
    return state_vector(initial_state, n)


_compensator_state = compensator_state


def _divergence(u, bound, status, sample):
    if status == kernels.STATUS_NONFINITE:
        return CompensatorDivergence(sample, "the input voltage became non-finite")
    return CompensatorDivergence(
        sample, f"|U| = {np.max(np.abs(u)):.3g} V exceeds the bound {bound:.3g} V")


def compensator_step(compensator, state, reference):
    """One sample of the compensator law (numpy), without divergence checks.

    The body of the numpy oracle loop, also the update of the python-control
    compensator system (:func:`hammerstein.interop.compensator_system`).

    Parameters
    ----------
    compensator : InverseMultiplicativeCompensator
    state : numpy.ndarray, shape (n_states,)
        ``U(t-T)`` [V], (``v_f(t-T)`` [V] for the low-pass law), play states [V].
    reference : numpy.ndarray, shape (m,)
        ``Yr(t)`` [µm].

    Returns
    -------
    inputs : numpy.ndarray, shape (m,)
        ``U(t)`` [V].
    new_state : numpy.ndarray, shape (n_states,)
        State committed with ``U(t)``.
    """
    model = compensator.model
    m = model.n_inputs
    lowpass, a = compensator_law(compensator)
    if _offset(model) is not None:   # Gamma(U) = Yr - c
        reference = reference - _offset(model)[:, 0]
    u_prev = state[:m]
    s = state[2 * m:] if lowpass else state[m:]
    Kinv = compensator.K_inv
    if lowpass:
        y_prev, _ = model.evaluate(u_prev, s)
        vf = a * state[m:2 * m] + (1.0 - a) * (u_prev - Kinv @ y_prev)
        u = Kinv @ reference + vf
    else:
        u = u_prev
        for _ in range(compensator.iterations):
            y_hat, _ = model.evaluate(u, s)
            u = u + Kinv @ (reference - y_hat)
    if not np.all(np.isfinite(u)):
        return u, state.copy()
    _, s = model.evaluate(u, s)
    return u, np.concatenate([u, vf, s] if lowpass else [u, s])


def _simulate_compensator_numpy(compensator, yr, state):
    bound = compensator.divergence_bound
    u_out = np.empty_like(yr)
    for t in range(yr.shape[1]):
        u, new_state = compensator_step(compensator, state, yr[:, t])
        if not np.all(np.isfinite(u)):
            raise CompensatorDivergence(t, "the input voltage became non-finite")
        if np.max(np.abs(u)) > bound:
            raise _divergence(u, bound, kernels.STATUS_BOUND, t)
        u_out[:, t] = u
        state = new_state
    return u_out, state


def _run_chain_kernel(compensator, yr, cstate, plant=None, pstate=None):
    """Run :func:`kernels.chain_kernel`; returns (u, y, cstate, pstate, status, sample)."""
    model = compensator.model
    m = model.n_inputs
    lowpass, a = compensator_law(compensator)
    if _offset(model) is not None:   # Gamma(U) = Yr - c
        yr = yr - _offset(model)
    off = 2 * m if lowpass else m
    cpk = pack_model(model, cstate[off:])
    cu = cstate[:m].copy()
    cvf = cstate[m:2 * m].copy() if lowpass else np.zeros(m)
    cs = cpk.plays(cstate[off:])
    n = yr.shape[1]
    u = np.empty((m, n))
    if plant is None:
        ppk = PackedModel(np.zeros(1, dtype=np.int64), np.zeros(0), np.zeros((0, 0)),
                          np.zeros((0, 0)), np.zeros(0, dtype=np.int64),
                          np.zeros(0, dtype=np.int64))
        ps, x = np.zeros(0), np.zeros(0)
        A, B, C, D = (np.zeros((0, 0)),) * 4
        y = np.empty((0, n))
    else:
        nh = plant.hysteresis.n_hysterons
        ppk = pack_model(plant.hysteresis, pstate[:nh])
        ps, x = ppk.plays(pstate[:nh]), pstate[nh:].copy()
        A, B, C, D = _linear_matrices(plant)
        y = np.empty((plant.hysteresis.n_outputs, n))
    status, sample = kernels.chain_kernel(
        np.ascontiguousarray(yr), n, cpk.start, cpk.r, cpk.W, cpk.G,
        np.ascontiguousarray(compensator.K_inv, dtype=float), int(compensator.iterations),
        float(compensator.divergence_bound), lowpass, a, cu, cvf, cs,
        plant is not None, ppk.start, ppk.r, ppk.W, ppk.G, A, B, C, D, ps, x, u, y)
    if plant is not None and _offset(plant.hysteresis) is not None:
        y += _offset(plant.hysteresis)
    cs_h = cpk.hysteron_state(cs)
    c_final = np.concatenate([cu, cvf, cs_h] if lowpass else [cu, cs_h])
    p_final = None if plant is None else np.concatenate([ppk.hysteron_state(ps), x])
    return u, y, c_final, p_final, status, sample


def simulate_compensator(compensator, reference, initial_state=None, backend="numba"):
    """Run the inverse multiplicative compensator on a reference record.

    Delay law (Theorem 4.1, normalised as in NOTES §4): for each sample,
    ``iterations`` fixed-point steps ``U <- U + K^-1 (Yr(t) - Gamma(U; s(t-T)))``
    start from ``U(t-T)``, with the model's play states s frozen at the
    previous sample; then the states are committed with the final U.

    Low-pass law (paper Section 6, ``compensator.feedback == 'lowpass'``):
    ``v(t) = U(t) - K^-1 Gamma(U(t))``;
    ``v_f(t) = a v_f(t-T) + (1 - a) v(t-T)``, ``a = exp(-2 pi cutoff_hz T)``;
    ``U(t) = K^-1 Yr(t) + v_f(t)`` (``iterations`` ignored).

    Parameters
    ----------
    compensator : InverseMultiplicativeCompensator
    reference : array_like, shape (m, n_samples)
        Reference displacements [µm].
    initial_state : array_like, optional
        ``U(t-T)`` [V] (then ``v_f`` [V] for the low-pass law) then play
        states [V]; zeros by default (see :func:`compensator_state`).
    backend : {'numba', 'numpy'}

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V].
    final_state : numpy.ndarray, shape (n_states,)

    Raises
    ------
    CompensatorDivergence
        When U is non-finite or beyond ``compensator.divergence_bound``.
    """
    _check_backend(backend)
    yr = compensator.model.check_inputs(reference, "reference")
    state = compensator_state(compensator, initial_state)
    if backend == "numpy":
        return _simulate_compensator_numpy(compensator, yr, state)
    u, _, c_final, _, status, sample = _run_chain_kernel(compensator, yr, state)
    if status != kernels.STATUS_OK:
        raise _divergence(u[:, sample], compensator.divergence_bound, status, sample)
    return u, c_final


# -- chain -------------------------------------------------------------------------
@dataclass
class ChainResult:
    """Result of a compensator -> plant simulation.

    Attributes
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        Compensator output [V] (NaN after a divergence).
    outputs : numpy.ndarray, shape (p, n_samples)
        Plant displacements [µm] (NaN after a divergence).
    compensator_state, plant_state : numpy.ndarray or None
        Final states (None after a divergence).
    divergence : CompensatorDivergence or None
        Set when the compensator diverged; the arrays are valid before
        ``divergence.sample``.
    """

    inputs: np.ndarray
    outputs: np.ndarray
    compensator_state: np.ndarray | None
    plant_state: np.ndarray | None
    divergence: CompensatorDivergence | None = None

    @property
    def diverged(self) -> bool:
        """True when the compensator diverged (see ``divergence``)."""
        return self.divergence is not None


def _fusable(compensator):
    """True when the fused chain kernel implements this compensator exactly."""
    from hammerstein.core.compensators import InverseMultiplicativeCompensator
    return (isinstance(compensator, InverseMultiplicativeCompensator)
            and type(compensator).simulate is InverseMultiplicativeCompensator.simulate
            and all(hasattr(compensator, a) for a in ("model", "K_inv", "iterations",
                                                     "divergence_bound")))


def simulate_chain(compensator, plant, reference, compensator_state=None, plant_state=None,
                   backend="numba"):
    """Feedforward chain: reference -> compensator -> Hammerstein plant.

    The compensator needs no sensor, so the chain is the compensator's output
    fed open loop to the plant. With the numba backend an
    :class:`InverseMultiplicativeCompensator` runs fused with the plant in one
    compiled loop; any other compensator is run by its own ``simulate``.

    Parameters
    ----------
    compensator : object with ``simulate(reference, initial_state)``
        A compensator (inputs [V] from references [µm]).
    plant : HammersteinPlant
    reference : array_like, shape (p, n_samples)
        Reference displacements [µm].
    compensator_state, plant_state : array_like, optional
        Initial states; zeros by default.
    backend : {'numba', 'numpy'}

    Returns
    -------
    ChainResult
        Divergence of the compensator is reported in the result, not raised.
    """
    _check_backend(backend)
    reference = np.asarray(reference, dtype=float)
    if _fusable(compensator):
        from hammerstein.core import compensators
        if hasattr(compensators, "check_reference_range"):   # as compensator.simulate does
            compensators.check_reference_range(compensator.model, reference)
    if backend == "numba" and _fusable(compensator):
        yr = compensator.model.check_inputs(reference, "reference")
        cstate = _compensator_state(compensator, compensator_state)
        pstate = plant.initial_state(plant_state)
        if plant.hysteresis.n_inputs != compensator.model.n_inputs:
            raise HysteresisError(
                f"plant: expected {compensator.model.n_inputs} inputs to match the "
                f"compensator, found {plant.hysteresis.n_inputs}")
        u, y, c_final, p_final, status, sample = _run_chain_kernel(
            compensator, yr, cstate, plant, pstate)
        if status == kernels.STATUS_OK:
            return ChainResult(u, y, c_final, p_final)
        div = _divergence(u[:, sample], compensator.divergence_bound, status, sample)
        u[:, sample:] = np.nan
        y[:, sample:] = np.nan
        return ChainResult(u, y, None, None, div)
    kw = {"backend": backend} if _fusable(compensator) else {}
    simulate_comp = (lambda r, s: simulate_compensator(compensator, r, s, **kw)) if kw \
        else compensator.simulate
    try:
        u, comp_final = simulate_comp(reference, compensator_state)
    except CompensatorDivergence as div:
        m = plant.hysteresis.n_inputs
        n = reference.shape[-1]
        u = np.full((m, n), np.nan)
        # re-run the valid part to show the trajectory up to the divergence
        if div.sample > 0:
            u[:, :div.sample], _ = simulate_comp(reference[:, :div.sample], compensator_state)
        y = np.full((plant.hysteresis.n_outputs, n), np.nan)
        if div.sample > 0:
            y[:, :div.sample], _ = simulate_plant(plant, u[:, :div.sample], plant_state,
                                                  backend=backend)
        return ChainResult(u, y, None, None, div)
    y, plant_final = simulate_plant(plant, u, plant_state, backend=backend)
    return ChainResult(u, y, comp_final, plant_final)


# -- batch -------------------------------------------------------------------------
#: below this many samples in a batch the serial kernel is used (threads cost more)
PARALLEL_MIN_SAMPLES = 20_000


def _stack(arrays, shape, dtype=float):
    out = np.zeros((len(arrays),) + shape, dtype=dtype)
    for b, a in enumerate(arrays):
        out[(b,) + tuple(slice(0, n) for n in a.shape)] = a
    return out


def _balanced_order(lengths, n_threads):
    """Case order whose ``n_threads`` contiguous equal chunks hold similar work.

    Cases sorted by length are dealt round-robin to the chunks (numba splits
    a ``prange`` into equal contiguous chunks, one per thread).
    """
    by_length = np.argsort(-np.asarray(lengths), kind="stable")
    return np.concatenate([by_length[i::n_threads] for i in range(n_threads)]).astype(np.int64)


def simulate_chain_batch(compensators, plants, references, parallel=None):
    """Many independent compensator -> plant cases in one compiled call.

    Cases may differ by reference (frequency, amplitude, axis, length), by
    compensator model and gain, and by plant, as long as the numbers of
    inputs and outputs agree. Each case starts from zero states.

    Parameters
    ----------
    compensators : InverseMultiplicativeCompensator or sequence of them
        One per case, or one for all cases.
    plants : HammersteinPlant or sequence of them
        One per case, or one for all cases.
    references : sequence of array_like, each shape (m, n_samples_b)
        Reference displacements [µm] of each case (lengths may differ).
    parallel : bool, optional
        Spread the cases over the cores (numba ``prange``); by default when
        there are several cases and at least ``PARALLEL_MIN_SAMPLES`` samples.

    Returns
    -------
    list of ChainResult
        One per case, in order (divergences reported, not raised).

    Raises
    ------
    HysteresisError
        On mismatched sizes or invalid references.
    CompensatorError
        If a compensator is not an inverse multiplicative compensator.
    """
    references = list(references)
    B = len(references)
    if B == 0:
        return []
    comps = list(compensators) if isinstance(compensators, (list, tuple)) else [compensators] * B
    plts = list(plants) if isinstance(plants, (list, tuple)) else [plants] * B
    if len(comps) != B or len(plts) != B:
        raise HysteresisError(
            f"compensators/plants: expected 1 or {B} of each, found {len(comps)} and {len(plts)}")
    for c in comps:
        if not _fusable(c):
            raise CompensatorError(
                f"compensators: the batch kernel runs InverseMultiplicativeCompensator "
                f"only, found {type(c).__name__}")
    m = comps[0].model.n_inputs
    p = plts[0].hysteresis.n_outputs
    yrs = []
    for b, (c, pl, r) in enumerate(zip(comps, plts, references)):
        if c.model.n_inputs != m or pl.hysteresis.n_inputs != m or pl.hysteresis.n_outputs != p:
            raise HysteresisError(f"references[{b}]: case sizes differ from case 0 "
                                  f"(inputs {m}, outputs {p})")
        yr_b = c.model.check_inputs(r, f"references[{b}]")
        yrs.append(yr_b if _offset(c.model) is None else yr_b - _offset(c.model))
    lengths = np.array([r.shape[1] for r in yrs], dtype=np.int64)
    N = int(lengths.max())
    # pack each distinct model / plant once
    cache = {}

    def packed(model):
        if id(model) not in cache:
            cache[id(model)] = pack_model(model)
        return cache[id(model)]

    cpk = [packed(c.model) for c in comps]
    ppk = [packed(pl.hysteresis) for pl in plts]
    nc = max(k.r.size for k in cpk)
    npl = max(k.r.size for k in ppk)
    lin = [_linear_matrices(pl) for pl in plts]
    nx = max(L[0].shape[0] for L in lin)
    laws = [compensator_law(c) for c in comps]
    yr = _stack(yrs, (m, N))
    args = (
        yr, lengths,
        _stack([k.start for k in cpk], (m + 1,), np.int64), _stack([k.r for k in cpk], (nc,)),
        _stack([k.W for k in cpk], (m, nc)), _stack([k.G for k in cpk], (m, m)),
        np.stack([np.asarray(c.K_inv, dtype=float) for c in comps]),
        np.array([c.iterations for c in comps], dtype=np.int64),
        np.array([c.divergence_bound for c in comps], dtype=float),
        np.array([lw[0] for lw in laws], dtype=np.bool_),
        np.array([lw[1] for lw in laws], dtype=float),
        np.zeros((B, m)), np.zeros((B, m)), np.zeros((B, nc)),
        _stack([k.start for k in ppk], (m + 1,), np.int64), _stack([k.r for k in ppk], (npl,)),
        _stack([k.W for k in ppk], (p, npl)), _stack([k.G for k in ppk], (p, m)),
        _stack([L[0] for L in lin], (nx, nx)), _stack([L[1] for L in lin], (nx, p)),
        _stack([L[2] for L in lin], (p, nx)), _stack([L[3] for L in lin], (p, p)),
        np.zeros((B, npl)), np.zeros((B, nx)),
        np.full((B, m, N), np.nan), np.full((B, p, N), np.nan),
        np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64),
    )
    if parallel is None:
        parallel = B > 1 and int(lengths.sum()) >= PARALLEL_MIN_SAMPLES and kernels.threads() > 1
    if parallel:
        kernels.chain_batch_parallel(_balanced_order(lengths, kernels.threads()), *args)
    else:
        kernels.chain_batch_serial(*args)
    cu, cvf, cs, ps, xs, u_out, y_out, status, sample = args[11:14] + args[22:]
    results = []
    for b in range(B):
        n = lengths[b]
        u, y = u_out[b, :, :n], y_out[b, :, :n]
        if _offset(plts[b].hysteresis) is not None:
            y += _offset(plts[b].hysteresis)
        if status[b] != kernels.STATUS_OK:
            t = int(sample[b])
            div = _divergence(u[:, t], comps[b].divergence_bound, status[b], t)
            u[:, t:] = np.nan
            results.append(ChainResult(u, y, None, None, div))
            continue
        cs_h = cpk[b].hysteron_state(cs[b, :cpk[b].r.size])
        c_final = np.concatenate([cu[b], cvf[b], cs_h] if laws[b][0] else [cu[b], cs_h])
        nxb = lin[b][0].shape[0]
        p_final = np.concatenate([ppk[b].hysteron_state(ps[b, :ppk[b].r.size]), xs[b, :nxb]])
        results.append(ChainResult(u, y, c_final, p_final))
    return results
