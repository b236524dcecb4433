"""Defaults that ``hammerstein identify`` and scenario identification tables share.

A light module (no numerical import): the scenario schema reads it while it
validates a file, before anything is simulated.
"""

from __future__ import annotations

__all__ = ["PREISACH_LEVELS", "CREEP_T_MIN"]

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
