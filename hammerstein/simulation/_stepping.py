"""The public stepping functions: validate, pack, run a kernel or the numpy oracle.

Length: one wrapper per compiled kernel (play, PI, plant, chain, batch), each
validating and packing its arrays as scipy.signal's public faces do; they
share the packing and status handling and are read side by side with
``_kernels``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from hammerstein.exceptions import CompensatorDivergence, CompensatorError, HysteresisError
from hammerstein.simulation import _kernels as kernels
from hammerstein.simulation import _oracle as oracle
from hammerstein.simulation._compile import await_prefetch
from hammerstein.simulation._preisach import linear_steps
from hammerstein.simulation._packing import (EMPTY_PACKED, STATUS_OK, ChainState, CompensatorLaw,
                                             LawArrays,
                                             LinearArrays, PIArrays, check_linear,
                                             compensator_law_of, divergence_error, law_slopes,
                                             identity_filter, linear_arrays, pack_model,
                                             state_vector)

__all__ = [
    "BACKENDS",
    "ChainResult",
    "simulate_plays",
    "simulate_hysteresis",
    "simulate_plant",
    "simulate_compensator",
    "simulate_chain",
    "simulate_chain_batch",
    "compensator_law",
    "compensator_state",
    "is_fusable",
]

BACKENDS = ("numba", "numpy")


def _offset(model):
    """Output offset of a model as a (p, 1) column, or None (duck-typed ``output_offset``)."""
    off = getattr(model, "output_offset", None)
    return None if off is None else np.asarray(off, dtype=float)[:, None]


def _has_map(model):
    """True when a model has a static output map ``S`` (duck-typed ``has_output_map``)."""
    return bool(getattr(model, "has_output_map", False))


def _with_offset(model, y):
    """``S(y) + c``, in place: the output map (if any), then the offset (a sensor zero)."""
    if _has_map(model):
        y[...] = model.output_map_apply(y)
    off = _offset(model)
    if off is not None:
        y += off
    return y


def _without_offset(model, yr):
    """``S^-1(Yr - c)``: the reference of ``Gamma`` (offset and output map undone)."""
    off = _offset(model)
    yr = yr if off is None else yr - off
    return model.output_map_inverse(yr) if _has_map(model) else yr


def _law_reference(law, yr):
    """What a law's kernel takes: ``S^-1(Yr - c)``, or ``Yr - c`` for a law whose reference
    pre-filter (the inverse of the linear part) must run before the nonlinear ``S^-1``
    (:func:`_premapped`)."""
    if law.prefilter is not None and _has_map(law.model):
        off = _offset(law.model)
        return yr if off is None else yr - off
    return _without_offset(law.model, yr)


def _premapped(law, yr, cstate):
    """A law with a pre-filter over a model with an output map, on ``Yr - c``: the
    pre-filter run first (it is linear and open loop), then ``S^-1`` on its output.

    The plant is ``y = L(S(Gamma(U))) + c`` (L: creep and dynamics), so ``Gamma(U)`` must
    follow ``S^-1(L^-1(Yr - c))``; ``L^-1`` of ``S^-1(Yr - c)`` is wrong wherever ``S`` is
    not linear (0.11 um on a 50 Hz circle crossing a knot). Returns ``(law without its
    pre-filter, its reference, its state, the pre-filter's final state)``, or None when
    the law needs no such split.
    """
    if law.prefilter is None or not _has_map(law.model):
        return None
    nf = law.n_filter_states
    head, xf = cstate[:cstate.size - nf], cstate[cstate.size - nf:]
    v, xf = linear_steps(yr, tuple(law.prefilter), xf)
    return law._replace(prefilter=None), law.model.output_map_inverse(v), head, xf


def _mapped_plant(plant, u, state, backend):
    """Plant whose PI has an output map: ``H = S(Gamma(U))`` then the linear part (numpy)."""
    model = plant.hysteresis
    nh = model.n_hysterons
    h, plays = simulate_hysteresis(model, u, state[:nh], backend)
    off = _offset(model)
    h = h - off if off is not None else h          # S(Gamma(U)), offset after the dynamics
    A, B, C, D = plant.matrices
    x = state[nh:].copy()
    y = np.empty_like(h)
    for t in range(h.shape[1]):
        y[:, t] = C @ x + D @ h[:, t]
        x = A @ x + B @ h[:, t]
    return _with_offset_only(model, y), np.concatenate([plays, x])


def _packable(model):
    """False for hysteresis models the fused PI kernels cannot run (duck-typed ``packable``)."""
    return bool(getattr(model, "packable", True))


def _generic_plant(plant, u, state, backend):
    """Plant whose hysteresis steps itself (``model.simulate``), then the compiled linear part."""
    model = plant.hysteresis
    nh = model.n_hysterons
    h, hyst = model.simulate(u, state[:nh])
    if plant.is_static:
        return h, hyst
    y, x = linear_steps(h, plant.matrices, state[nh:])
    return y, np.concatenate([hyst, x])


def _with_offset_only(model, y):
    off = _offset(model)
    if off is not None:
        y += off
    return y


def _check_backend(backend):
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {BACKENDS}, found {backend!r}")


# -- play operators / multivariable PI ---------------------------------------------
def simulate_plays(u, thresholds, state, backend="numba"):
    """Play operators of one input, eq. (1), on validated arrays.

    Called by :func:`hammerstein.models.hysteresis.play` (which validates).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    thresholds : numpy.ndarray, shape (n_hysterons,)
        Thresholds [V].
    state : numpy.ndarray, shape (n_hysterons,)
        Play outputs before the first sample [V].
    backend : {'numba', 'numpy'}
        Compiled kernel or the numpy reference loop.

    Returns
    -------
    y : numpy.ndarray, shape (n_hysterons, n_samples)
        Play outputs [V].
    final_state : numpy.ndarray, shape (n_hysterons,)
        Play outputs after the last sample [V].

    Raises
    ------
    ValueError
        On an unknown backend.
    """
    _check_backend(backend)
    u = np.ascontiguousarray(u, dtype=float)
    r = np.ascontiguousarray(thresholds, dtype=float)
    s = np.array(state, dtype=float)
    if backend == "numpy":
        return oracle.plays(u, r, s)
    y = np.empty((r.size, u.size))
    kernels.play_kernel(u, r, s, y)
    return y, s


def simulate_inverse_play(v, threshold, tolerance, state, backend="numba"):
    """Right inverse of a play operator, motions up to a tolerance ignored.

    ``u(t) = a(t) + d(t)``, where ``a`` follows ``v`` when it moves by more than
    the tolerance e from where it last moved and holds otherwise, and
    ``d = r sgn(a(t) - a(t-T))`` when ``a`` moves, kept otherwise: the play of
    threshold r then outputs ``a``, within e of ``v`` (Kuhnen & Janocha's inverse
    play; :class:`~hammerstein.compensation.inverse.InversePlay` validates).

    Parameters
    ----------
    v : numpy.ndarray, shape (n_samples,)
        Desired play output [V].
    threshold : float
        Threshold r [V], >= 0.
    tolerance : float
        Motion ignored, e [V], >= 0.
    state : numpy.ndarray, shape (2,)
        ``[a(-T), d(-T)]``: the play output and the offset ``u - a`` before the
        first sample [V].
    backend : {'numba', 'numpy'}
        Compiled kernel or the numpy reference loop.

    Returns
    -------
    u : numpy.ndarray, shape (n_samples,)
        Play input [V].
    final_state : numpy.ndarray, shape (2,)
        ``[a, d]`` after the last sample [V].

    Raises
    ------
    ValueError
        On an unknown backend.
    """
    _check_backend(backend)
    v = np.ascontiguousarray(v, dtype=float)
    s = np.array(state, dtype=float)
    if backend == "numpy":
        return oracle.inverse_play(v, float(threshold), float(tolerance), s)
    u = np.empty(v.size)
    kernels.inverse_play_kernel(v, float(threshold), float(tolerance), s, u)
    return u, s


def simulate_hysteresis(model, inputs, initial_state=None, backend="numba"):
    """Outputs of a multivariable PI model for an input record, eq. (4).

    Parameters
    ----------
    model : MultivariablePI
        Duck-typed: ``check_inputs``, ``initial_state``, ``hysterons``,
        ``n_outputs``.
    inputs : array_like, shape (m, n_samples)
        Input voltages [V].
    initial_state : array_like, shape (n_hysterons,), optional
        Initial play outputs [V]; zeros by default.
    backend : {'numba', 'numpy'}
        Compiled kernel or the numpy reference loop.

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
    ValueError
        On an unknown backend.
    """
    _check_backend(backend)
    u = model.check_inputs(inputs)
    s = model.initial_state(initial_state)
    if backend == "numpy":
        y, final = oracle.hysteresis(model, u, s)
        return _with_offset(model, y), final
    pk = pack_model(model, s)
    sp = pk.plays(s)
    y = np.empty((model.n_outputs, u.shape[1]))
    kernels.pi_kernel(np.ascontiguousarray(u), pk.arrays, sp, y)
    return _with_offset(model, y), pk.hysteron_state(sp)


# -- plant -----------------------------------------------------------------------
def simulate_plant(plant, inputs, initial_state=None, backend="numba"):
    """Open-loop response of a Hammerstein plant.

    ``H(t) = Gamma(U(t))``; ``Y(t) = C x(t) + D H(t)``;
    ``x(t+T) = A x(t) + B H(t)`` (static plant: ``Y = H``).

    Parameters
    ----------
    plant : HammersteinPlant
        Duck-typed: ``hysteresis`` (the PI model), ``initial_state``,
        ``is_static`` and ``matrices`` ``(A, B, C, D)``.
    inputs : array_like, shape (m, n_samples)
        Input voltages [V].
    initial_state : array_like, shape (plant.n_states,), optional
        Play states [V] then linear states [µm]; zeros by default.
    backend : {'numba', 'numpy'}
        Compiled kernel or the numpy reference loop.

    Returns
    -------
    outputs : numpy.ndarray, shape (p, n_samples)
        Displacements [µm].
    final_state : numpy.ndarray, shape (plant.n_states,)
        Play states [V] then linear states [µm] after the last sample.

    Raises
    ------
    HysteresisError
        On a wrongly shaped or non-finite input or state.
    ValueError
        On an unknown backend.
    """
    _check_backend(backend)
    model = plant.hysteresis
    u = model.check_inputs(inputs)
    state = plant.initial_state(initial_state)
    nh = model.n_hysterons
    if not _packable(model):    # Preisach, generalised PI...: stepped by the model itself
        return _generic_plant(plant, u, state, backend)
    if _has_map(model) and not plant.is_static:
        return _mapped_plant(plant, u, state, backend)
    if backend == "numpy":      # the offset is a sensor zero, after the dynamics
        y, final = oracle.plant(plant, u, state)
        return _with_offset(model, y), final     # static here when the model has a map
    if plant.is_static:
        return simulate_hysteresis(model, u, state[:nh])
    pk = pack_model(model, state[:nh])
    sp = pk.plays(state[:nh])
    x = state[nh:].copy()
    y = np.empty((model.n_outputs, u.shape[1]))
    kernels.plant_kernel(np.ascontiguousarray(u), pk.arrays, sp, linear_arrays(plant.matrices),
                         x, y)
    return _with_offset(model, y), np.concatenate([pk.hysteron_state(sp), x])


# -- compensator -------------------------------------------------------------------
def _validated(law):
    if law is not None and law.prefilter is not None:
        law = law._replace(prefilter=check_linear(law.prefilter, law.model.n_outputs))
    return law


def _law(compensator):
    law = compensator_law_of(compensator)
    if law is None:
        raise CompensatorError(
            f"compensator: {type(compensator).__name__} declares no packed_law(); "
            f"run it with its own simulate()")
    return _validated(law)


def compensator_law(compensator):
    """Feedback law of a fusable compensator.

    Parameters
    ----------
    compensator : object with ``packed_law()``
        E.g. an :class:`~hammerstein.compensation.compensators.InverseMultiplicativeCompensator`.

    Returns
    -------
    (lowpass, a) : (bool, float)
        ``lowpass`` False for the one-sample delay of Theorem 4.1; True for
        the first-order low-pass of Section 6 with pole
        ``a = exp(-2 pi cutoff_hz T)``.

    Raises
    ------
    CompensatorError
        If the compensator declares no law, or its law is invalid.
    """
    law = _law(compensator)
    return law.lowpass, law.pole


def compensator_state(compensator, initial_state=None):
    """Validated flat state of a fusable compensator (its law's rest state by default).

    Parameters
    ----------
    compensator : object with ``packed_law()``
        A fusable compensator.
    initial_state : array_like, shape (n_states,), optional
        ``U(t-T)`` (m,) [V]; for the low-pass law the filtered correction
        ``v_f`` (m,) [V]; the play states (n_hysterons,) [V]; the pre-filter
        state (n_f,) [µm] (see :class:`CompensatorLaw`).

    Returns
    -------
    numpy.ndarray, shape (n_states,)
        A validated copy.

    Raises
    ------
    HysteresisError
        If the state has the wrong length or non-finite values.
    CompensatorError
        If the compensator declares no law.
    """
    return _law(compensator).state(initial_state)


def is_fusable(compensator):
    """True when the fused kernels can run this compensator.

    Parameters
    ----------
    compensator : object
        Anything.

    Returns
    -------
    bool
        Whether ``compensator.packed_law()`` exists and returns a law.
    """
    return compensator_law_of(compensator) is not None




def _law_arrays(law):
    return LawArrays(np.ascontiguousarray(law.K_inv, dtype=float), int(law.iterations),
                     float(law.divergence_bound), bool(law.lowpass), float(law.pole),
                     law.prefilter is not None)


def _run_chain_kernel(law, yr, cstate, plant=None, pstate=None):
    """Run the chain kernel; returns (u, y, cstate, pstate, status, sample)."""
    split = _premapped(law, yr, cstate)
    if split is not None:
        inner, h, head, xf = split
        u, y, c_final, p_final, status, sample = _run_chain_kernel(inner, h, head, plant, pstate)
        return u, y, np.concatenate([c_final, xf]), p_final, status, sample
    model = law.model
    m, p = model.n_inputs, model.n_outputs
    u_prev, vf, splay, xf = law.split_state(cstate)
    cpk = pack_model(model, splay)
    n = yr.shape[1]
    u = np.empty((m, n))
    if plant is None:
        ppk, ps, x = EMPTY_PACKED, np.zeros(0), np.zeros(0)
        linear = LinearArrays(*(np.zeros((0, 0)),) * 4)
        y = np.empty((0, n))
    else:
        nh = plant.hysteresis.n_hysterons
        ppk = pack_model(plant.hysteresis, pstate[:nh])
        ps, x = ppk.plays(pstate[:nh]), pstate[nh:].copy()
        linear = linear_arrays(plant.matrices)
        y = np.empty((plant.hysteresis.n_outputs, n))
    state = ChainState(u_prev.copy(), np.zeros(m) if vf is None else vf.copy(),
                       cpk.plays(splay), xf.copy(), ps, x)
    plan = None if law.prefilter is None else kernels.prefilter_plan(law.prefilter)
    await_prefetch()            # a cold cache: the kernel may be compiling in a helper process
    status, sample = kernels.chain_kernel(
        np.ascontiguousarray(yr), n, _law_arrays(law), cpk.arrays, plan,
        law_slopes(cpk.arrays, law.iterations, law.lowpass), ppk.arrays, linear, plant is not None,
        state, u, y)
    cs_h = cpk.hysteron_state(state.cs)
    c_final = np.concatenate([state.cu, state.cvf, cs_h, state.xf] if law.lowpass
                             else [state.cu, cs_h, state.xf])
    p_final = None if plant is None else np.concatenate([ppk.hysteron_state(ps), x])
    return u, y, c_final, p_final, status, sample


def _simulate_law(law, reference, initial_state, backend):
    yr = _law_reference(law, law.model.check_inputs(reference, "reference"))
    state = law.state(initial_state)
    if backend == "numpy":
        split = _premapped(law, yr, state)
        if split is not None:
            inner, h, head, xf = split
            u, c_final = oracle.compensator(inner, h, head)
            return u, np.concatenate([c_final, xf])
        return oracle.compensator(law, yr, state)
    u, _, c_final, _, status, sample = _run_chain_kernel(law, yr, state)
    if status != STATUS_OK:
        raise divergence_error(u[:, sample], law.divergence_bound, status, sample)
    return u, c_final


def simulate_compensator(compensator, reference, initial_state=None, backend="numba"):
    """Run a fusable compensator (its :class:`CompensatorLaw`) on a reference record.

    Delay law (Theorem 4.1, normalised by a gain K): for each sample,
    ``iterations`` fixed-point steps ``U <- U + K^-1 (Yr(t) - Gamma(U; s(t-T)))``
    start from ``U(t-T)``, with the model's play states s frozen at the
    previous sample; then the states are committed with the final U.

    Low-pass law (paper Section 6):
    ``v(t) = U(t) - K^-1 Gamma(U(t))``;
    ``v_f(t) = a v_f(t-T) + (1 - a) v(t-T)``, ``a = exp(-2 pi cutoff_hz T)``;
    ``U(t) = K^-1 Yr(t) + v_f(t)`` (``iterations`` ignored).

    With a reference pre-filter in the law, both track its output instead of
    ``Yr(t)``.

    Parameters
    ----------
    compensator : object with ``packed_law()``
        E.g. an :class:`~hammerstein.compensation.compensators.InverseMultiplicativeCompensator`.
    reference : array_like, shape (p, n_samples)
        Reference displacements [µm].
    initial_state : array_like, optional
        ``U(t-T)`` [V] (then ``v_f`` [V] for the low-pass law), play states
        [V], pre-filter state [µm]; by default 0 V, the model's default play states
        and the pre-filter at 0 (see :func:`compensator_state`).
    backend : {'numba', 'numpy'}
        Compiled kernel or the numpy reference loop.

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V].
    final_state : numpy.ndarray, shape (n_states,)
        State after the last sample, for a chunked continuation.

    Raises
    ------
    CompensatorDivergence
        When U is non-finite or beyond the law's ``divergence_bound``.
    CompensatorError
        If the compensator declares no law.
    HysteresisError
        On a wrongly shaped or non-finite reference or state.
    ValueError
        On an unknown backend.
    """
    _check_backend(backend)
    return _simulate_law(_law(compensator), reference, initial_state, backend)


# -- chain -------------------------------------------------------------------------
@dataclass
class ChainResult:
    """Result of a compensator -> plant simulation.

    Parameters
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        Compensator output [V] (NaN after a divergence).
    outputs : numpy.ndarray, shape (p, n_samples)
        Plant displacements [µm] (NaN after a divergence).
    compensator_state : numpy.ndarray or None
        Final compensator state (None after a divergence).
    plant_state : numpy.ndarray or None
        Final plant state (None after a divergence).
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


def simulate_chain(compensator, plant, reference, compensator_state=None, plant_state=None,
                   backend="numba"):
    """Feedforward chain: reference -> compensator -> Hammerstein plant.

    The compensator needs no sensor, so the chain is the compensator's output
    fed open loop to the plant. With the numba backend a compensator that
    declares a :class:`CompensatorLaw` (``packed_law()``) runs fused with the
    plant in one compiled loop; any other compensator is run by its own
    ``simulate``, then the plant.

    Parameters
    ----------
    compensator : object with ``simulate(reference, initial_state)``
        A compensator (inputs [V] from references [µm]), optionally with
        ``packed_law()`` (see :mod:`hammerstein.simulation`).
    plant : HammersteinPlant
        Duck-typed as in :func:`simulate_plant`.
    reference : array_like, shape (p, n_samples)
        Reference displacements [µm].
    compensator_state, plant_state : array_like, optional
        Initial states; by default the law's rest state
        (:meth:`CompensatorLaw.rest_state`) and the plant's default state.
    backend : {'numba', 'numpy'}
        Compiled kernels or the numpy reference loops.

    Returns
    -------
    ChainResult
        Divergence of the compensator is reported in the result, not raised.

    Raises
    ------
    HysteresisError
        On a wrongly shaped reference or state, or a plant whose number of
        inputs differs from the compensator's.
    ValueError
        On an unknown backend.

    Warns
    -----
    RangeWarning
        From the compensator's reference check (``check_reference`` of its
        law, or its ``simulate``).

    Examples
    --------
    A one-input PI model, the compensator built from it and the static plant
    of that model: the output follows a slow sine to within the reference's
    change over one sample (``2 pi 5 / 1000 = 0.031`` µm), the lag of the
    one-step fixed-point law:

    >>> import numpy as np
    >>> from hammerstein import (HammersteinPlant, InverseMultiplicativeCompensator,
    ...                          MultivariablePI, PrandtlIshlinskii, simulate_chain)
    >>> model = MultivariablePI([[PrandtlIshlinskii([0.0, 1.0], [1.0, 0.5])]],
    ...                         input_amplitude=[10.0])
    >>> plant = HammersteinPlant(model, sampling_period=1e-3)
    >>> reference = 5 * np.sin(2 * np.pi * np.arange(1000) / 1000)[np.newaxis]
    >>> result = simulate_chain(InverseMultiplicativeCompensator(model), plant, reference)
    >>> result.outputs.shape, result.diverged
    ((1, 1000), False)
    >>> print(f"{np.max(np.abs(result.outputs - reference)):.3f} um")
    0.014 um
    """
    _check_backend(backend)
    reference = np.asarray(reference, dtype=float)
    law = _validated(compensator_law_of(compensator))
    if law is not None and law.check_reference is not None:
        law.check_reference(reference)          # as the compensator's simulate does
    if (backend == "numba" and law is not None and not _has_map(plant.hysteresis)
            and _packable(plant.hysteresis)):
        yr = _law_reference(law, law.model.check_inputs(reference, "reference"))
        cstate = law.state(compensator_state)
        pstate = plant.initial_state(plant_state)
        if plant.hysteresis.n_inputs != law.model.n_inputs:
            raise HysteresisError(
                f"plant: expected {law.model.n_inputs} inputs to match the "
                f"compensator, found {plant.hysteresis.n_inputs}")
        u, y, c_final, p_final, status, sample = _run_chain_kernel(law, yr, cstate, plant, pstate)
        _with_offset(plant.hysteresis, y)
        if status == STATUS_OK:
            return ChainResult(u, y, c_final, p_final)
        div = divergence_error(u[:, sample], law.divergence_bound, status, sample)
        u[:, sample:] = np.nan
        y[:, sample:] = np.nan
        return ChainResult(u, y, None, None, div)
    if law is not None:
        def simulate_comp(r, s):
            return _simulate_law(law, r, s, backend)
    else:
        simulate_comp = compensator.simulate
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
    """Arrays of up to ``shape`` stacked on a leading case axis, zero padded."""
    if arrays and all(a.shape == shape for a in arrays):    # a sweep: one model size, no padding
        return np.stack(arrays).astype(dtype, copy=False)
    out = np.zeros((len(arrays),) + shape, dtype=dtype)
    for b, a in enumerate(arrays):
        out[(b,) + tuple(slice(0, n) for n in a.shape)] = a
    return out


def _ragged(arrays, offsets):
    """Records (rows, n_b) packed end to end: case b is ``flat[rows*off[b]:rows*off[b+1]]``."""
    rows = arrays[0].shape[0] if arrays else 0
    flat = np.empty(rows * int(offsets[-1]))
    for b, a in enumerate(arrays):
        flat[rows * offsets[b]:rows * offsets[b + 1]] = a.ravel()
    return flat


def _unpacked(flat, offsets, b, rows):
    """Case b's (rows, n_b) view of a ragged buffer (see :func:`_ragged`)."""
    return flat[rows * offsets[b]:rows * offsets[b + 1]].reshape(rows, -1)


def _balanced_order(lengths, n_threads):
    """Case order whose ``n_threads`` contiguous equal chunks hold similar work.

    The batch cuts the order into ``n_threads`` contiguous
    chunks of ``n // n_threads`` or one more iterations, one per thread.
    Cases sorted by length, longest first, go greedily to the chunk with the
    least work that still has room (longest processing time first, with
    the chunk sizes fixed), so each thread receives about the same number of
    samples however unequal the cases; every case appears once.
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    n_threads = max(1, min(int(n_threads), lengths.size))
    if n_threads == 1:
        return np.arange(lengths.size, dtype=np.int64)
    sizes = [len(c) for c in np.array_split(np.arange(lengths.size), n_threads)]
    chunks = [[] for _ in range(n_threads)]
    work = np.zeros(n_threads)
    for b in np.argsort(-lengths, kind="stable"):
        room = [k for k in range(n_threads) if len(chunks[k]) < sizes[k]]
        k = min(room, key=lambda j: work[j])
        chunks[k].append(b)
        work[k] += lengths[b]
    return np.concatenate([np.asarray(c, dtype=np.int64) for c in chunks])


def _stack_linear(systems, n, k):
    """Stack ``LinearArrays`` of up to n states, k inputs and outputs (zero padded)."""
    return LinearArrays(_stack([s.A for s in systems], (n, n)),
                        _stack([s.B for s in systems], (n, k)),
                        _stack([s.C for s in systems], (k, n)),
                        _stack([s.D for s in systems], (k, k)))


class _DeclaredLaw:
    """A compensator declaring a given :class:`CompensatorLaw` (the unfused batch fallback)."""

    def __init__(self, law):
        self.law = law

    def packed_law(self):
        return self.law


def simulate_chain_batch(compensators, plants, references, parallel=None, compensator_states=None):
    """Many independent compensator -> plant cases in one compiled call.

    Cases may differ by reference (frequency, amplitude, axis, length), by
    compensator model, gain and law, and by plant, as long as the numbers of
    inputs and outputs agree. Each case starts from zero plant states and
    from its own compensator state (its law's rest state by default). The
    records are packed end to end (memory in proportion to the samples, not
    to the number of cases times the longest case), and each case's result
    equals :func:`simulate_chain` on it bit for bit.

    Parameters
    ----------
    compensators : compensator or sequence of compensators
        Fusable (``packed_law()``) or a :class:`CompensatorLaw` itself (e.g.
        from ``HammersteinCompensator.fused_run``), one per case or one for
        all cases.
    plants : HammersteinPlant or sequence of them
        One per case, or one for all cases.
    references : sequence of array_like, each shape (m, n_samples_b)
        Reference displacements [µm] of each case (lengths may differ).
    parallel : bool, optional
        Spread the cases over ``numba.get_num_threads()`` Python threads
        running the compiled kernel without the GIL (cases in an order that
        gives each thread equal work); by
        default when there are several cases and at least
        ``PARALLEL_MIN_SAMPLES`` samples. Results do not depend on it (each
        case is computed alone).
    compensator_states : sequence of (array_like or None), optional
        Initial flat state of each case's compensator (``U(t-T)`` [V],
        ``v_f`` [V] for the low-pass law, play states [V], pre-filter state
        [µm]; see :func:`compensator_state`); None or a None entry: zeros.

    Returns
    -------
    list of ChainResult
        One per case, in order (divergences reported, not raised).

    Raises
    ------
    HysteresisError
        On mismatched sizes or invalid references.
    CompensatorError
        If a compensator declares no ``packed_law()``.
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
    checked = {}

    def validated(law):         # a pre-filter shared by many cases is checked once
        if law is None or law.prefilter is None:
            return law
        key = (id(law.prefilter), law.model.n_outputs)
        if key not in checked:
            checked[key] = (law.prefilter, _validated(law).prefilter)
        return law._replace(prefilter=checked[key][1])

    laws = [validated(c if isinstance(c, CompensatorLaw) else compensator_law_of(c))
            for c in comps]
    for c, law in zip(comps, laws):
        if law is None:
            raise CompensatorError(
                f"compensators: the batch kernel runs compensators with a packed_law() "
                f"(e.g. InverseMultiplicativeCompensator) only, found {type(c).__name__}")
    states = [None] * B if compensator_states is None else list(compensator_states)
    if len(states) != B:
        raise HysteresisError(f"compensator_states: expected {B} states (or None), "
                              f"found {len(states)}")
    states = [law.state(s, f"compensator_states[{b}]")
              for b, (s, law) in enumerate(zip(states, laws))]
    if (any(_has_map(pl.hysteresis) or not _packable(pl.hysteresis) for pl in plts)
            or any(law.prefilter is not None and _has_map(law.model) for law in laws)):  # unfused
        return [simulate_chain(_DeclaredLaw(law), pl, r, s)
                for law, pl, r, s in zip(laws, plts, references, states)]
    m = laws[0].model.n_inputs
    p = plts[0].hysteresis.n_outputs
    yrs = []
    for b, (law, pl, r) in enumerate(zip(laws, plts, references)):
        if law.model.n_inputs != m or pl.hysteresis.n_inputs != m or pl.hysteresis.n_outputs != p:
            raise HysteresisError(f"references[{b}]: case sizes differ from case 0 "
                                  f"(inputs {m}, outputs {p})")
        yrs.append(_without_offset(law.model, law.model.check_inputs(r, f"references[{b}]")))
    lengths = np.array([r.shape[1] for r in yrs], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    # pack each distinct model / plant (and initial play state: equal plays merge) once
    cache = {}

    def packed(model, plays=None):
        key = (id(model), None if plays is None or not plays.any() else plays.tobytes())
        if key not in cache:
            cache[key] = pack_model(model, None if key[1] is None else plays)
        return cache[key]

    splits = [law.split_state(s) for law, s in zip(laws, states)]
    cpk = [packed(law.model, sp[2]) for law, sp in zip(laws, splits)]
    ppk = [packed(pl.hysteresis) for pl in plts]
    nc = max(k.r.size for k in cpk)
    npl = max(k.r.size for k in ppk)
    lin = [linear_arrays(pl.matrices) for pl in plts]
    nx = max(L.A.shape[0] for L in lin)
    pc = laws[0].model.n_outputs               # references (and pre-filters) have pc signals
    filters = [identity_filter(pc) if law.prefilter is None else law.prefilter for law in laws]
    nf = max(f.A.shape[0] for f in filters)

    def stack_pi(packs, n_plays, n_out):
        return PIArrays(_stack([k.start for k in packs], (m + 1,), np.int64),
                        _stack([k.r for k in packs], (n_plays,)),
                        _stack([k.W for k in packs], (n_out, n_plays)),
                        _stack([k.G for k in packs], (n_out, m)))

    law_arrays = LawArrays(
        np.stack([np.asarray(law.K_inv, dtype=float) for law in laws]),
        np.array([law.iterations for law in laws], dtype=np.int64),
        np.array([law.divergence_bound for law in laws], dtype=float),
        np.array([law.lowpass for law in laws], dtype=np.bool_),
        np.array([law.pole for law in laws], dtype=float),
        np.array([law.prefilter is not None for law in laws], dtype=np.bool_))
    state = ChainState(np.zeros((B, m)), np.zeros((B, m)), np.zeros((B, nc)), np.zeros((B, nf)),
                       np.zeros((B, npl)), np.zeros((B, nx)))
    for b, (u_prev, vf, splay, xf) in enumerate(splits):
        state.cu[b] = u_prev
        if vf is not None:
            state.cvf[b] = vf
        state.cs[b, :cpk[b].r.size] = cpk[b].plays(splay)
        state.xf[b, :xf.size] = xf
    total = int(offsets[-1])
    u_out, y_out = np.full(m * total, np.nan), np.full(p * total, np.nan)
    status, sample = np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64)
    worker = np.zeros(B, dtype=np.int64)
    if parallel is None:
        parallel = B > 1 and total >= PARALLEL_MIN_SAMPLES
    n_threads = min(kernels.threads(), B) if parallel else 1
    order = _balanced_order(lengths, n_threads)
    # the closed-form 2 x 2 law's tables: None (a kernel without it) when no case takes it;
    # one table per distinct packed model and law (a sweep's cases share them)
    memo = {}
    for k, law in zip(cpk, laws):
        key = (id(k), law.iterations, law.lowpass)
        if key not in memo:
            memo[key] = law_slopes(k.arrays, law.iterations, law.lowpass)
    tables = [memo[(id(k), law.iterations, law.lowpass)] for k, law in zip(cpk, laws)]
    slopes = None
    if any(tab is not None for tab in tables):
        slopes = np.zeros((B, 2, nc + 2))
        for b, tab in enumerate(tables):
            if tab is not None:
                slopes[b, :, :tab.shape[1]] = tab
    prefilters = (_stack_linear(filters, nf, pc)
                  if any(law.prefilter is not None for law in laws) else None)
    args = (offsets, _ragged(yrs, offsets), law_arrays, stack_pi(cpk, nc, m),
            prefilters, slopes, stack_pi(ppk, npl, p),
            _stack_linear(lin, nx, p), True, state, u_out, y_out, status, sample, worker)
    chunks = np.array_split(order, n_threads)      # the equal-work chunks of _balanced_order
    await_prefetch()            # chain_batch links chain_kernel: load it if a helper compiles it
    if n_threads == 1:
        kernels.chain_batch(order, *args, 0)
    else:                   # disjoint cases on n threads; the kernel releases the GIL
        with ThreadPoolExecutor(n_threads) as pool:
            list(pool.map(lambda k: kernels.chain_batch(chunks[k], *args, k), range(n_threads)))
    results = []
    for b in range(B):
        u, y = _unpacked(u_out, offsets, b, m), _unpacked(y_out, offsets, b, p)
        _with_offset(plts[b].hysteresis, y)
        if status[b] != STATUS_OK:
            t = int(sample[b])
            div = divergence_error(u[:, t], laws[b].divergence_bound, status[b], t)
            u[:, t:] = np.nan
            results.append(ChainResult(u, y, None, None, div))
            continue
        cs_h = cpk[b].hysteron_state(state.cs[b, :cpk[b].r.size])
        xf = state.xf[b, :filters[b].A.shape[0]]
        c_final = np.concatenate([state.cu[b], state.cvf[b], cs_h, xf] if laws[b].lowpass
                                 else [state.cu[b], cs_h, xf])
        nxb = lin[b].A.shape[0]
        p_final = np.concatenate([ppk[b].hysteron_state(state.ps[b, :ppk[b].r.size]),
                                  state.x[b, :nxb]])
        results.append(ChainResult(u, y, c_final, p_final))
    return results
