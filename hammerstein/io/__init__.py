"""Files of models and data: bundled and user presets (read, validate, write), measured
data files (CSV records, drive files) and the interchange with python-control objects.

Imports :mod:`hammerstein.core` and :mod:`hammerstein.models` (and what they import),
never identification, compensation or above.
"""
