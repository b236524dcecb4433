"""Caching of identifications: one :class:`IdentificationCache` per run, plus the on-disk cache.

A scenario with many cases identifies each model once: the cache of the run
(made by :func:`hammerstein.scenario.resolve.resolve_scenario` and passed down
to the compensator builders) keeps every identified PI model and every
identified pair (PI, G) on a content key (:func:`plant_fingerprint` of the
plant and the validated identify tables, :func:`spec_key`). Entries also go
to the on-disk cache (:mod:`hammerstein.scenario.diskcache`), so a later run
does not identify them again. There is no module-global cache: two caches
share nothing but the disk.
"""

from __future__ import annotations

import hashlib

import numpy as np

from hammerstein.core.dynamics import DynamicsError
from hammerstein.core.presets import PresetError, model_from_table, model_to_table
from hammerstein.scenario import diskcache

__all__ = ["IdentificationCache", "plant_fingerprint", "spec_key", "round_trip_table"]


def plant_fingerprint(plant):
    """Content hash of a plant: PI model table, sampling period, dynamics matrices.

    Parameters
    ----------
    plant : hammerstein.core.plant.HammersteinPlant

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
    model : hammerstein.core.hysteresis.MultivariablePI

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
            value = compute()
            stored = dump(value) if self.disk and dump is not None else None
            if stored is not None:
                diskcache.store(kind, key, stored)
        self._entries[full] = value
        return value

    @staticmethod
    def _from_disk(kind, key, load):
        stored = diskcache.load(kind, key)
        if stored is None:
            return None
        try:
            return load(stored)
        except (KeyError, TypeError, ValueError, PresetError, DynamicsError):
            return None     # an entry of an older shape: identify again
