"""Caching of identifications: one :class:`IdentificationCache` per run, plus the on-disk cache.

A scenario with many cases identifies each model once: the cache of the run
(made by :func:`hammerstein.scenario.resolve.resolve_scenario` and passed down
to the compensator builders) keeps every identified PI model and every
identified pair (PI, G) on a content key (:func:`plant_fingerprint` of the
plant and the validated identify tables, :func:`spec_key`). Entries also go
to the on-disk cache (:mod:`hammerstein.scenario.diskcache`), so a later run
does not identify them again. There is no module-global cache: two caches
share nothing but the disk.

A run uses the same numbers whether it identified or read the disk: an
identification that can be stored is used as read back from its stored form
(the JSON round trip of what :mod:`~hammerstein.scenario.diskcache` writes,
rebuilt by the entry's ``load``), also with the disk cache off. The value
computed in the run can differ from that in more than its digits: an
identified G's ``C`` matrix comes out of the subspace fit Fortran-ordered and
reads back C-ordered, and LAPACK's real Schur form of the ZPETC design,
given the two layouts of equal matrices, returned different (equally valid)
bases; the start drive of ``ilc-realistic-2dof`` then moved by 3e-12 V and
the learning's trial-by-trial decisions carried that to 1.5e-8 µm in the
metrics (measured; cold and warm caches now agree bit for bit).

An identification runs with one BLAS thread (:func:`threadpoolctl.threadpool_limits`
around ``compute``): OpenBLAS with 2 threads splits the least-squares products
otherwise, and the identified weights moved in their 13th digit (measured on
``hammerstein-trajectories``: ``OPENBLAS_NUM_THREADS=2`` changed every PI weight by
up to 1e-12 relative, the numba threads nothing), so that an entry written on one
machine gave other numbers than a fresh run on another. The command line sets one
BLAS thread already unless ``OPENBLAS_NUM_THREADS`` says otherwise.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
from threadpoolctl import threadpool_limits

from hammerstein.models.dynamics import DynamicsError
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.core.numbers import MAX_MAGNITUDE
from hammerstein.io.presets import PresetError, model_from_table, model_to_table
from hammerstein.scenario import diskcache

__all__ = ["IdentificationCache", "plant_fingerprint", "spec_key", "round_trip_table",
           "cached_model_problem"]


def plant_fingerprint(plant):
    """Content hash of a plant: PI model table, sampling period, dynamics matrices.

    Parameters
    ----------
    plant : hammerstein.models.plant.HammersteinPlant

    Returns
    -------
    str
        SHA-1 hex digest; equal for two plants built from the same preset.
    """
    h = hashlib.sha1(repr(model_to_table(plant.hysteresis)).encode())
    h.update(repr(float(plant.sampling_period)).encode())
    if not plant.is_static:  # the matrices: no python-control needed
        for mat in plant.matrices:
            h.update(np.ascontiguousarray(mat, dtype=float).tobytes())
    else:
        h.update(b"static")
    return h.hexdigest()


def _freeze(v):
    return tuple(_freeze(a) for a in v) if isinstance(v, list) else v


def spec_key(spec):
    """Hashable key of a validated table (sorted items, lists as tuples).

    Parameters
    ----------
    spec : dict
        A validated ``identify`` or ``identify_dynamics`` table.

    Returns
    -------
    tuple
    """
    return tuple(sorted((k, _freeze(v)) for k, v in spec.items()))


def round_trip_table(model):
    """``model_to_table(model)`` when it gives the same model back, else None (not stored).

    Parameters
    ----------
    model : hammerstein.models.hysteresis.MultivariablePI

    Returns
    -------
    dict or None
    """
    table = model_to_table(model)
    try:
        same = model_to_table(model_from_table(table)) == table
    except PresetError:
        same = False
    return table if same else None


def _bounds_of(key):
    """The ``bounds`` of the identify table inside a content key, or None."""
    if isinstance(key, tuple):
        if len(key) == 2 and key[0] == "bounds" and isinstance(key[1], str):
            return key[1]
        for part in key:
            found = _bounds_of(part)
            if found is not None:
                return found
    return None


def cached_model_problem(model, key=()):
    """Why an identified PI model read from the disk cache cannot be used (a phrase), or None.

    The checks of a model file (:func:`hammerstein.io.presets.model_from_table`
    already ran), plus what an identification guarantees and the compensators
    need: finite weights and gains within
    :data:`hammerstein.core.numbers.MAX_MAGNITUDE`; for a square model, a
    first slope ``S_1 = w_1 > 0`` of every direct transfer (a zero or
    negative one gives no compensator) and, when the identify table of the
    key asked for ``bounds = "monotone"`` or ``"nonnegative"``, every
    cumulative weight sum ``S_i > 0`` (Kuhnen's invertibility condition,
    paper Section 3).

    Parameters
    ----------
    model : hammerstein.models.hysteresis.MultivariablePI
        The model rebuilt from the entry.
    key : tuple
        The entry's content key (with the validated identify table).

    Returns
    -------
    str or None
        E.g. ``"direct transfer x <- ux: cumulative weight sum S_1 = 0 µm/V
        is not positive"``.
    """
    bounds = _bounds_of(key)
    for l in range(model.n_outputs):
        for k in range(model.n_inputs):
            comp = model.components[l][k]
            name = f"{model.output_names[l]} <- {model.input_names[k]}"
            weights = np.atleast_1d(np.asarray(getattr(comp, "weights", comp if comp is not None
                                                       else 0.0), dtype=float))
            if not np.all(np.isfinite(weights)) or np.any(np.abs(weights) > MAX_MAGNITUDE):
                return f"{name}: weights not finite or beyond {MAX_MAGNITUDE:.0e} µm/V"
            if l != k or model.n_outputs != model.n_inputs:
                continue
            sums = np.cumsum(weights)
            bad = np.flatnonzero(sums <= 0) if bounds in ("monotone", "nonnegative") \
                else np.flatnonzero(sums[:1] <= 0)
            if bad.size:
                i = int(bad[0])
                return (f"direct transfer {name}: cumulative weight sum S_{i + 1} = "
                        f"{sums[i]:.6g} µm/V is not positive")
    return None


def _model_in(value):
    """The PI model of a cached value (a model, or a tuple starting with one), or None."""
    first = value[0] if isinstance(value, tuple) and value else value
    return first if isinstance(first, MultivariablePI) else None


class IdentificationCache:
    """The identifications of one run: in memory, backed by the on-disk cache.

    Parameters
    ----------
    disk : bool
        Whether entries are read from and stored to
        :mod:`hammerstein.scenario.diskcache` (which has its own off switch,
        ``HAMMERSTEIN_CACHE_DIR=off``).

    Examples
    --------
    >>> from hammerstein.scenario.identification_cache import IdentificationCache
    >>> cache = IdentificationCache(disk=False)
    >>> cache.get("pi", ("k",), compute=lambda: 42, load=None, dump=None)
    42
    >>> cache.get("pi", ("k",), compute=lambda: 0, load=None, dump=None)   # remembered
    42
    """

    def __init__(self, disk=True):
        self.disk = disk
        self._entries = {}

    def __len__(self):
        return len(self._entries)

    def get(self, kind, key, compute, load, dump):
        """The entry of ``(kind, key)``: from memory, else the disk, else ``compute()``.

        Parameters
        ----------
        kind : str
            ``"pi"`` or ``"hammerstein"`` (a namespace of the disk cache).
        key : tuple
            Content key.
        compute : callable
            ``() -> value``: the identification.
        load : callable or None
            ``stored -> value`` rebuilding a value from its disk form; None
            for no disk.
        dump : callable or None
            ``value -> stored`` (a TOML/JSON-ready dict, or None not to store).

        Returns
        -------
        object
            The value (the same object for the same key within this cache).
        """
        full = (kind, key)
        if full in self._entries:
            return self._entries[full]
        value = self._from_disk(kind, key, load) if self.disk and load is not None else None
        if value is None:
            with threadpool_limits(limits=1, user_api="blas"):
                value = compute()
            stored = dump(value) if dump is not None and load is not None else None
            if stored is not None:
                if self.disk:
                    diskcache.store(kind, key, stored)
                value = self._as_stored(key, value, stored, load)
        self._entries[full] = value
        return value

    @staticmethod
    def _as_stored(key, value, stored, load):
        """``value`` as a later run would read it back from the disk (see the module docstring).

        The computed ``value`` itself when the stored form would not be used
        by a later run either (not JSON data that reads back equal, not
        loadable, or a model :func:`cached_model_problem` rejects): that run
        identifies again and uses what it computes.
        """
        try:
            data = json.loads(json.dumps(stored, allow_nan=True))
        except (TypeError, ValueError, RecursionError):
            return value
        if not diskcache.same_data(data, stored):
            return value
        try:
            again = load(data)
        except (KeyError, TypeError, ValueError, PresetError, DynamicsError):
            return value
        model = _model_in(again)
        if model is not None and cached_model_problem(model, key):
            return value
        return again

    @staticmethod
    def _from_disk(kind, key, load):
        stored = diskcache.load(kind, key)
        if stored is None:
            return None
        try:
            value = load(stored)
        except (KeyError, TypeError, ValueError, PresetError, DynamicsError):
            return None     # an entry of an older shape: identify again
        model = _model_in(value)
        problem = cached_model_problem(model, key) if model is not None else None
        if problem:         # re-validated like a model file: identify again, one -v note
            diskcache.note(f"identification cache entry ignored: "
                           f"{diskcache.entry_path(kind, key)}: its model: {problem}")
            return None
        return value
