"""Real-time targets: the compensators as dependency-free C99 code and as an FMU.

:func:`export_c` writes a compensator as ``NAME.h`` / ``NAME.c`` (C99, no
allocation, only the C standard library); :mod:`hammerstein.export.fmu`
wraps the same code as an FMI 2.0 co-simulation FMU. ``hammerstein export``
(:mod:`hammerstein.cli.export`) is the command; docs/real-time.md the guide.
This layer imports the models and compensators (:mod:`hammerstein.models`,
:mod:`hammerstein.compensation` and the layers below them) only.
"""

from __future__ import annotations

from hammerstein.export.c_code import (EMITTERS, MARKER, STATUS_DIVERGED, STATUS_LIMIT,
                                       STATUS_RANGE, AmplifierLimits, CExport, check_name, export_c)

__all__ = ["AmplifierLimits", "CExport", "export_c", "check_name", "MARKER", "STATUS_LIMIT",
           "STATUS_DIVERGED", "STATUS_RANGE", "EMITTERS"]
