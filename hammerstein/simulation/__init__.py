"""The sample-by-sample stepping core.

All time stepping of the project lives here: the play operators, the
multivariable PI forward model, the open-loop Hammerstein plant, the
compensator, and the (pre-filter ->) compensator -> plant chain, single or
batched. This layer works on arrays and duck-typed models; it imports
nothing of :mod:`hammerstein.core` (which imports it).

Two backends compute the same thing:

* ``"numba"`` (default): compiled kernels (private ``_kernels``), one loop
  per record with no Python per sample, compiled on first use and cached
  (:func:`compile_notices` announces a compilation before it starts);
* ``"numpy"``: plain numpy loops (private ``_oracle``), the reference
  implementation and the test oracle of the kernels.

Every function takes explicit initial states and returns the final ones, so
a chunked run equals one long run.

Duck-typed models
-----------------
A *hysteresis model* is any object like
:class:`~hammerstein.models.hysteresis.MultivariablePI`: ``n_inputs``,
``n_outputs``, ``n_hysterons``, ``hysterons()`` (flat thresholds, weights,
input and output indices, linear gains), ``check_inputs(u, name)``,
``initial_state(s)`` and ``evaluate(u, s)``. A *plant* is any object like
:class:`~hammerstein.models.plant.HammersteinPlant`: ``hysteresis`` (a model),
``initial_state(s)``, ``is_static`` and ``matrices`` (discrete A, B, C, D).

The compensator protocol
------------------------
A compensator is any object with

``simulate(reference, initial_state=None) -> (inputs, final_state)``
    reference (p, n_samples) [µm] -> input voltages (m, n_samples) [V],
    raising :class:`~hammerstein.exceptions.CompensatorDivergence` when it
    diverges;

and, optionally,

``packed_law() -> CompensatorLaw or None``
    declares that the compensator *is* the law of :class:`CompensatorLaw`
    (model, ``K^-1``, iterations, divergence bound, delay or low-pass
    feedback and its pole, optional linear reference pre-filter, optional
    reference check), so the compiled chain kernels may run it fused with
    the plant, and :func:`simulate_chain_batch` may batch it. Returning None
    (or having no such method) makes :func:`simulate_chain` call the
    compensator's own ``simulate``, then the plant. A compensator that
    declares a law must compute exactly that law in its ``simulate``
    (typically by calling :func:`simulate_compensator`).

Examples
--------
>>> import numpy as np
>>> from hammerstein.simulation import simulate_plays
>>> y, final = simulate_plays(np.array([0.0, 2.0, 1.0]), np.array([0.0, 0.5]), np.zeros(2))
>>> y
array([[0. , 2. , 1. ],
       [0. , 1.5, 1.5]])
"""

from hammerstein._cache import use_user_numba_cache

use_user_numba_cache()  # before numba loads: compiled kernels go to the user's cache directory

from hammerstein.simulation._packing import (LANES, ChainState, CompensatorLaw, LawArrays,
                                             LinearArrays, PackedModel, PIArrays,
                                             compensator_law_of, finite_array, identity_filter,
                                             pack_model, state_vector)
from hammerstein.simulation._oracle import compensator_step
from hammerstein.simulation._compile import announce_compiles, compile_notices
from hammerstein.simulation._stepping import (BACKENDS, PARALLEL_MIN_SAMPLES, ChainResult,
                                              compensator_law, compensator_state, is_fusable,
                                              simulate_chain, simulate_chain_batch,
                                              simulate_compensator, simulate_hysteresis,
                                              simulate_inverse_play, simulate_plant,
                                              simulate_plays)
from hammerstein.simulation._closed_loop import (AW_BACK, AW_CLAMP, AW_NONE, ComponentArrays,
                                                 LoopArrays, LoopState, empty_components, empty_pi,
                                                 simulate_closed_loop)
from hammerstein.simulation._preisach import (generalized_play_states, generalized_play_steps,
                                              linear_steps, preisach_states, preisach_steps)
from hammerstein.simulation._preisach_inverse import preisach_inverse_kernel

__all__ = [
    "simulate_plays",
    "simulate_inverse_play",
    "simulate_hysteresis",
    "simulate_plant",
    "simulate_compensator",
    "simulate_chain",
    "simulate_chain_batch",
    "ChainResult",
    "BACKENDS",
    "CompensatorLaw",
    "LinearArrays",
    "compensator_law",
    "compensator_law_of",
    "compensator_state",
    "compensator_step",
    "is_fusable",
    "identity_filter",
    "finite_array",
    "state_vector",
    "pack_model",
    "PackedModel",
    "PIArrays",
    "LawArrays",
    "ChainState",
    "LANES",
    "PARALLEL_MIN_SAMPLES",
    "compile_notices",
    "announce_compiles",
    "preisach_steps",
    "preisach_states",
    "linear_steps",
    "generalized_play_steps",
    "generalized_play_states",
    "preisach_inverse_kernel",
    "simulate_closed_loop",
    "ComponentArrays",
    "LoopArrays",
    "LoopState",
    "empty_pi",
    "empty_components",
    "AW_NONE",
    "AW_BACK",
    "AW_CLAMP",
]
