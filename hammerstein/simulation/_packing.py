"""Array validation, the compensator protocol and the packing of models for the kernels.

Plain numpy, no numba: the structures below are what the compiled kernels
(:mod:`hammerstein.simulation._kernels`) take as arguments, built here from
duck-typed models (see the protocol in :mod:`hammerstein.simulation`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from hammerstein.exceptions import CompensatorDivergence, CompensatorError, HysteresisError

__all__ = ["finite_array", "state_vector", "LANES", "PackedModel", "pack_model",
           "PIArrays", "LinearArrays", "LawArrays", "ChainState", "CompensatorLaw",
           "compensator_law_of", "identity_filter", "linear_arrays", "check_linear", "law_slopes",
           "STATUS_OK", "STATUS_NONFINITE", "STATUS_BOUND", "divergence_error"]

#: Largest magnitude of a model parameter or signal (the value of
#: ``hammerstein.core.numbers.MAX_MAGNITUDE``, which this lower layer cannot import).
MAX_MAGNITUDE = 1e150

#: status codes of the chain kernels: ok, non-finite input voltage, beyond the bound
STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_BOUND = 2


def divergence_error(u, bound, status, sample):
    """The :class:`CompensatorDivergence` of a failed sample.

    Parameters
    ----------
    u : numpy.ndarray, shape (m,)
        The offending input voltages [V].
    bound : float
        The divergence bound [V].
    status : int
        ``STATUS_NONFINITE`` or ``STATUS_BOUND``.
    sample : int
        Index of the sample.

    Returns
    -------
    CompensatorDivergence
    """
    if status == STATUS_NONFINITE:
        return CompensatorDivergence(sample, "the input voltage became non-finite")
    return CompensatorDivergence(
        sample, f"|U| = {np.max(np.abs(u)):.3g} V exceeds the bound {bound:.3g} V")


# -- validation ----------------------------------------------------------------------
def finite_array(value, name, ndim=None):
    """Float array of finite values, or an error naming the field.

    Parameters
    ----------
    value : array_like
        Any numbers.
    name : str
        Field name for the error message.
    ndim : int, optional
        Required number of dimensions.

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array (not copied when already one).

    Raises
    ------
    HysteresisError
        If ``value`` is None, not numeric (text or booleans included), has
        another number of dimensions, or holds NaN or inf.
    """
    if value is None:       # np.asarray(None, float) is NaN: "found NaN or inf" misled
        raise HysteresisError(f"{name}: expected an array of numbers, found None")
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    if kind in ("U", "S", "b"):     # text or True/False read as numbers: a loading mistake
        raise HysteresisError(f"{name}: expected numbers, found an array of "
                              f"{'text' if kind in 'US' else 'booleans'} ({value.dtype})")
    if np.iscomplexobj(value):
        raise HysteresisError(f"{name}: expected real numbers, found complex values")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise HysteresisError(f"{name}: expected numbers, got {_excerpt(value)}") from exc
    if ndim is not None and arr.ndim != ndim:
        raise HysteresisError(
            f"{name}: expected a {ndim}-D array, found shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise HysteresisError(f"{name}: expected finite values, found NaN or inf")
    if arr.size and np.max(np.abs(arr)) > MAX_MAGNITUDE:
        raise HysteresisError(f"{name}: {np.max(np.abs(arr)):.3g} is beyond the limit "
                              f"{MAX_MAGNITUDE:.0e} (its squares and products would overflow)")
    return arr


def _excerpt(value, n=80):
    """``repr(value)`` cut to ``n`` characters (a message stays one short line)."""
    text = repr(value)
    return text if len(text) <= n else text[:n] + "..."


def state_vector(initial_state, size, name="initial_state"):
    """Validated copy of a flat state vector, zeros when None.

    Every stateful object (play operators, plants, compensators) stores its
    memory as one flat float vector; this is the one check of it.

    Parameters
    ----------
    initial_state : array_like, shape (size,), or None
        State [units of the object: V for play states, µm for linear states].
    size : int
        Expected length.
    name : str
        Field name for error messages.

    Returns
    -------
    numpy.ndarray, shape (size,)
        A new array (the caller may update it in place).

    Raises
    ------
    HysteresisError
        If the state is not finite or not of shape (size,).
    """
    if initial_state is None:
        return np.zeros(size)
    s = finite_array(initial_state, name)
    if s.shape != (size,):
        raise HysteresisError(f"{name}: expected shape ({size},), found {s.shape}")
    return s.astype(float, copy=True)


# -- kernel argument structures (numba accepts these named tuples) --------------------
class PIArrays(NamedTuple):
    """Packed multivariable PI model, a kernel argument (see :func:`pack_model`).

    Each field gets a leading case axis for the batch kernels.

    Parameters
    ----------
    start : numpy.ndarray, shape (m + 1,), int64
        The play operators of input k are ``start[k]:start[k+1]``.
    r : numpy.ndarray, shape (n_plays,)
        Thresholds [V].
    W : numpy.ndarray, shape (p, n_plays)
        Weight of each play in each output [µm/V].
    G : numpy.ndarray, shape (p, m)
        Pure linear gains [µm/V].
    """

    start: np.ndarray
    r: np.ndarray
    W: np.ndarray
    G: np.ndarray


class LinearArrays(NamedTuple):
    """Discrete state space ``y = C x + D u``; ``x <- A x + B u``, a kernel argument.

    Units are those of the signals mapped (µm for the bending modes and the
    reference pre-filter). Each field gets a leading case axis for the batch
    kernels.

    Parameters
    ----------
    A : numpy.ndarray, shape (n, n)
        State matrix.
    B : numpy.ndarray, shape (n, k)
        Input matrix.
    C : numpy.ndarray, shape (q, n)
        Output matrix.
    D : numpy.ndarray, shape (q, k)
        Feedthrough matrix.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray


class LawArrays(NamedTuple):
    """Compensator law as a kernel argument (see :class:`CompensatorLaw`).

    Each field gets a leading case axis for the batch kernels.

    Parameters
    ----------
    K_inv : numpy.ndarray, shape (m, p)
        Inverse gain [V/µm].
    iterations : int
        Fixed-point iterations per sample (delay law).
    bound : float
        Divergence bound on |U| [V].
    lowpass : bool
        Low-pass feedback law instead of the delay.
    pole : float
        Pole ``a`` of the low-pass law [-].
    prefiltered : bool
        Run the reference pre-filter.
    """

    K_inv: np.ndarray
    iterations: Any
    bound: Any
    lowpass: Any
    pole: Any
    prefiltered: Any


class ChainState(NamedTuple):
    """States of a chain run, updated in place by the kernels.

    Each field gets a leading case axis for the batch kernels.

    Parameters
    ----------
    cu : numpy.ndarray, shape (m,)
        ``U(t-T)`` [V].
    cvf : numpy.ndarray, shape (m,)
        Low-pass correction ``v_f`` [V] (unused by the delay law).
    cs : numpy.ndarray, shape (n_plays,)
        Packed compensator play states [V].
    xf : numpy.ndarray, shape (n_f,)
        Pre-filter state [µm].
    ps : numpy.ndarray, shape (n_plays_plant,)
        Packed plant play states [V].
    x : numpy.ndarray, shape (n_x,)
        Linear plant state [µm].
    """

    cu: np.ndarray
    cvf: np.ndarray
    cs: np.ndarray
    xf: np.ndarray
    ps: np.ndarray
    x: np.ndarray


# -- the compensator protocol ------------------------------------------------------------
class CompensatorLaw(NamedTuple):
    """How a compensator runs in the fused chain kernel (its ``packed_law()``).

    The law, per sample t, from the reference ``Yr(t)`` [µm]:

    1. optional linear reference pre-filter ``v = Cf xf + Df Yr(t)``,
       ``xf <- Af xf + Bf Yr(t)`` (``v = Yr(t)`` without it);
    2. delay law (``lowpass`` False): from ``U = U(t-T)``, ``iterations``
       times ``U <- U + K^-1 (v - Gamma(U; s(t-T)))`` (play states frozen at
       the previous sample); low-pass law (``lowpass`` True):
       ``v_f <- a v_f + (1 - a) (U(t-T) - K^-1 Gamma(U(t-T)))``,
       ``U = K^-1 v + v_f`` with ``a = pole``;
    3. divergence check ``|U| <= divergence_bound``, then commit the model's
       play states with U.

    Flat state of such a compensator: ``U(t-T)`` (m,) [V], ``v_f`` (m,) [V]
    (low-pass law only), the model's play states (n_hysterons,) [V], the
    pre-filter state (n_f,) [µm].

    Parameters
    ----------
    model : object
        The hysteresis model Gamma, duck-typed like
        :class:`~hammerstein.models.hysteresis.MultivariablePI`
        (``n_inputs``, ``n_outputs``, ``n_hysterons``, ``hysterons()``,
        ``check_inputs()``, ``evaluate()``).
    K_inv : numpy.ndarray, shape (m, p)
        Inverse gain [V/µm].
    iterations : int
        Fixed-point iterations per sample (delay law), >= 1.
    divergence_bound : float
        |U| [V] beyond which the run stops as diverged.
    lowpass : bool
        Low-pass feedback law instead of the one-sample delay.
    pole : float
        ``a = exp(-2 pi f_c T)`` of the low-pass law [-] (0 for the delay).
    prefilter : LinearArrays or None
        Reference pre-filter (Af (n_f, n_f), Bf (n_f, p), Cf (p, n_f),
        Df (p, p)) [µm -> µm]; None for none. A 0-state filter with
        ``Df = I`` is the exact identity.
    check_reference : callable or None
        Called with the reference (p, n_samples) [µm] before a fused run
        (e.g. a range warning), as the compensator's ``simulate`` would.
    """

    model: Any
    K_inv: np.ndarray
    iterations: int
    divergence_bound: float
    lowpass: bool
    pole: float
    prefilter: LinearArrays | None = None
    check_reference: Callable | None = None

    @property
    def n_filter_states(self) -> int:
        """Number of pre-filter states n_f (0 without a pre-filter)."""
        return 0 if self.prefilter is None else int(self.prefilter.A.shape[0])

    @property
    def n_states(self) -> int:
        """Length of the flat compensator state."""
        m = self.model.n_inputs
        return m * (2 if self.lowpass else 1) + self.model.n_hysterons + self.n_filter_states

    def rest_state(self):
        """The default flat state: ``U(t-T)`` and ``v_f`` at 0 V, the model's default play
        states (``model.initial_state()``: zeros, or where a demagnetising cycle leaves
        them), the pre-filter at 0.

        Returns
        -------
        numpy.ndarray, shape (n_states,)
            A new array.
        """
        s = np.zeros(self.n_states)
        m = self.model.n_inputs
        off = 2 * m if self.lowpass else m
        s[off:off + self.model.n_hysterons] = self.model.initial_state()
        return s

    def state(self, initial_state=None, name="initial_state"):
        """A validated copy of a flat state, :meth:`rest_state` by default.

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
        name : str
            Field name for error messages.

        Returns
        -------
        numpy.ndarray, shape (n_states,)

        Raises
        ------
        HysteresisError
            On a wrong length or non-finite values.
        """
        if initial_state is None:
            return self.rest_state()
        return state_vector(initial_state, self.n_states, name)

    def split_state(self, state):
        """Views ``(U(t-T), v_f or None, play states, pre-filter state)`` of a flat state.

        Parameters
        ----------
        state : numpy.ndarray, shape (n_states,)
            Flat compensator state.

        Returns
        -------
        tuple of numpy.ndarray
            ``U(t-T)`` (m,) [V], ``v_f`` (m,) [V] or None for the delay
            law, play states (n_hysterons,) [V], pre-filter state (n_f,) [µm].
        """
        m, nh = self.model.n_inputs, self.model.n_hysterons
        off = 2 * m if self.lowpass else m
        return (state[:m], state[m:2 * m] if self.lowpass else None,
                state[off:off + nh], state[off + nh:])


def compensator_law_of(compensator):
    """The fused law a compensator declares, or None.

    Parameters
    ----------
    compensator : object
        Anything; a compensator declares that it can be fused by a method
        ``packed_law()`` returning a :class:`CompensatorLaw` (or None).

    Returns
    -------
    CompensatorLaw or None
        None when the compensator declares no law.

    Raises
    ------
    CompensatorError
        If ``packed_law()`` returns something else.
    """
    method = getattr(compensator, "packed_law", None)     # optional part of the protocol
    law = None if method is None else method()
    if law is not None and not isinstance(law, CompensatorLaw):
        raise CompensatorError(
            f"packed_law: expected a CompensatorLaw or None from {type(compensator).__name__}, "
            f"found {type(law).__name__}")
    return law


def identity_filter(p):
    """The empty pre-filter: no state, ``D = I`` (exactly ``v = Yr``).

    Parameters
    ----------
    p : int
        Number of reference signals.

    Returns
    -------
    LinearArrays
        ``A`` (0, 0), ``B`` (0, p), ``C`` (p, 0), ``D`` (p, p) identity.
    """
    return LinearArrays(np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p))


def check_linear(system, p, name="prefilter"):
    """Validate a square discrete state space of p inputs and p outputs.

    Parameters
    ----------
    system : LinearArrays or sequence of 4 array_like
        ``(A, B, C, D)``.
    p : int
        Number of inputs and outputs.
    name : str
        Field name for error messages.

    Returns
    -------
    LinearArrays
        Contiguous float arrays.

    Raises
    ------
    HysteresisError
        If the matrices are not finite or their shapes do not chain.
    """
    try:
        mats = [np.ascontiguousarray(finite_array(M, f"{name}.{key}"), dtype=float)
                for key, M in zip("ABCD", system, strict=True)]
    except (TypeError, ValueError) as exc:
        if isinstance(exc, HysteresisError):
            raise
        raise HysteresisError(f"{name}: expected the 4 matrices (A, B, C, D)") from None
    n = mats[0].shape[0] if mats[0].ndim == 2 else -1
    shapes = {"A": (n, n), "B": (n, p), "C": (p, n), "D": (p, p)}
    out = []
    for key, M in zip("ABCD", mats):
        if M.shape != shapes[key]:
            raise HysteresisError(f"{name}.{key}: expected shape {shapes[key]}, found {M.shape}")
        out.append(M)
    return LinearArrays(*out)


def linear_arrays(matrices):
    """Contiguous float ``LinearArrays`` from ``(A, B, C, D)``.

    Parameters
    ----------
    matrices : sequence of 4 array_like
        ``(A, B, C, D)`` of a discrete state space.

    Returns
    -------
    LinearArrays
    """
    return LinearArrays(*(np.ascontiguousarray(M, dtype=float) for M in matrices))


def law_slopes(comp, iterations, lowpass):
    """The table of the chain kernel's closed-form 2 x 2 delay law, or None where it does not apply.

    For a 2-input, 2-output law with 2 or 3 iterations and delay feedback,
    the kernel steps the law in closed form wherever ``Gamma`` is linear
    around the last input (see :func:`hammerstein.simulation._kernels.chain_kernel`):
    the slope of output l in input k when the first ``a`` plays of input k
    move with it is ``sum(W[l, start[k]:start[k] + a]) + G[l, k]``, read from
    ``table[l, start[k] + k + a]``. Any other law runs without it, and
    passing None compiles the kernel without that code (a shorter cold
    compile for the laws that never use it).

    Parameters
    ----------
    comp : PIArrays
        The packed compensator model.
    iterations : int
        The law's fixed-point iterations.
    lowpass : bool
        True for the low-pass feedback law.

    Returns
    -------
    numpy.ndarray, shape (2, n_plays + 2), or None
        [µm/V] (prefix sums of the weights, G added).
    """
    start, _, W, G = comp
    if G.shape != (2, 2) or iterations not in (2, 3) or lowpass:
        return None
    out = np.empty((2, W.shape[1] + 2))
    for k in range(2):
        lo, hi = int(start[k]), int(start[k + 1])
        out[:, lo + k] = G[:, k]
        out[:, lo + k + 1:hi + k + 1] = np.cumsum(W[:, lo:hi], axis=1) + G[:, k:k + 1]
    return out


# -- packing -----------------------------------------------------------------------------
#: plays of each input are padded to a multiple of this (AVX: 4 doubles)
LANES = 4


@dataclass
class PackedModel:
    """Multivariable PI model as kernel arrays (built by :func:`pack_model`).

    Hysterons with the same input, threshold and initial play state are one
    play operator (they evolve identically, Def. 3.2 of the paper), so the
    kernels update each play once and weight it into every output.

    Parameters
    ----------
    start : numpy.ndarray, shape (m + 1,), int64
        The play operators of input k are ``start[k]:start[k+1]``.
    r : numpy.ndarray, shape (n_plays,)
        Thresholds [V].
    W : numpy.ndarray, shape (p, n_plays)
        Weight of each play in each output [µm/V] (0 where absent).
    G : numpy.ndarray, shape (p, m)
        Pure linear components [µm/V].
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

    @property
    def arrays(self) -> PIArrays:
        """The kernel argument ``PIArrays(start, r, W, G)``."""
        return PIArrays(self.start, self.r, self.W, self.G)

    def plays(self, hysteron_state):
        """Play states from the flat hysteron state.

        Parameters
        ----------
        hysteron_state : array_like, shape (n_hysterons,)
            Play outputs of the model's hysterons [V].

        Returns
        -------
        numpy.ndarray, shape (n_plays,)
            States of the packed play operators [V] (0 for padding plays).
        """
        s = np.zeros(self.rep.size)
        used = self.rep >= 0
        s[used] = np.asarray(hysteron_state, dtype=float)[self.rep[used]]
        return s

    def hysteron_state(self, play_state):
        """Flat hysteron state from the packed play states.

        Parameters
        ----------
        play_state : numpy.ndarray, shape (n_plays,)
            States of the packed play operators [V].

        Returns
        -------
        numpy.ndarray, shape (n_hysterons,)
            Play outputs of the model's hysterons [V].
        """
        return play_state[self.index]


#: the packing of "no model" (chain without a plant)
EMPTY_PACKED = PackedModel(np.zeros(1, dtype=np.int64), np.zeros(0), np.zeros((0, 0)),
                           np.zeros((0, 0)), np.zeros(0, dtype=np.int64),
                           np.zeros(0, dtype=np.int64))


def pack_model(model, state=None):
    """Pack a multivariable PI model for the kernels, merging shared plays.

    Parameters
    ----------
    model : MultivariablePI
        Or any object with ``hysterons()`` returning the flat description
        (``input_index``, ``output_index``, ``thresholds``, ``weights``,
        ``gain``, see :meth:`~hammerstein.models.hysteresis.MultivariablePI.hysterons`).
    state : numpy.ndarray, shape (n_hysterons,), optional
        Initial play states [V]; hysterons are merged only when equal here.

    Returns
    -------
    PackedModel
        Plays merged and padded; ``arrays`` is the kernel argument.
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

# fastmath={'reassoc'} only: lets LLVM vectorise the weighted sums (summation
# order changes, ~1e-15 relative; tests check 1e-9 against the numpy oracle).
# No 'nnan'/'ninf': the divergence checks need exact non-finite semantics;
# no 'contract' (FMA): an identity pre-filter stays exact.
# The helpers are inlined by numba (inline='always') and take these flags
# from the kernel that calls them.
FASTMATH = {"reassoc"}
