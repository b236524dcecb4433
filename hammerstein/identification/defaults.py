"""Defaults that ``hammerstein identify`` and scenario identification tables share.

A light module (no numerical import): the scenario schema reads it while it
validates a file, before anything is simulated.
"""

from __future__ import annotations

import math

__all__ = ["PREISACH_LEVELS", "CREEP_T_MIN", "smoothing_option"]

#: Cells of each input's switching grid of an identified Preisach model
#: (``N (N + 1) / 2`` hysterons per component): ``hammerstein identify --preisach-levels``,
#: a scenario table's ``preisach_levels`` and ``identify.model = "preisach"`` on simulated
#: records. 30 levels follow small loops closer than 20 (on the outside actuators of
#: ``benchmarks/route_defaults.py`` the Preisach-type members' worst feedforward circle
#: went from 4.3 to 2.7 % of the radius) and their exported exact inverse still steps
#: within 2 µs on a 2 x 2 model (``benchmarks/export_speed.py``).
PREISACH_LEVELS = 30

#: The shortest creep lag ``hammerstein identify --creep-records`` fits [s] (its
#: ``t_min``): ``hammerstein excitation`` warns of a ``--hold`` shorter than ten of them,
#: whose staircase shows almost none of the creep.
CREEP_T_MIN = 0.01


def smoothing_option(value):
    """``identify --preisach-smoothing`` / a scenario's ``preisach_smoothing``, read.

    Parameters
    ----------
    value : str or float
        ``"auto"`` (the search of
        :class:`~hammerstein.identification.preisach_identification.PreisachIdentifier`)
        or a smoothing weight lambda >= 0 [-], as a number or its text.

    Returns
    -------
    str or float
        ``"auto"`` or the weight.

    Raises
    ------
    ValueError
        Saying what was expected and what was found.

    Examples
    --------
    >>> smoothing_option("3e-5"), smoothing_option("auto")
    (3e-05, 'auto')
    """
    if isinstance(value, str) and value.strip() == "auto":
        return "auto"
    try:
        lam = float(value) if not isinstance(value, bool) else float("nan")
    except (TypeError, ValueError):
        lam = float("nan")
    if not (math.isfinite(lam) and lam >= 0):
        raise ValueError(f"expected auto or a smoothing weight >= 0 (the search chose 1e-5 "
                         f"to 1e-4 on outside actuators), found {value!r}")
    return lam
