"""Identification of the models from measured records: the PI fits (closed form, least
squares), records split by branch and amplitude, the Preisach and generalised-PI fits,
the linear dynamics (subspace identification, order selection), creep, the sensors of
simulated records, and the pipeline that ``hammerstein identify`` and scenario
identification tables share (hysteresis, dynamics, creep, refit), on least-squares
solvers reduced to their triangular factor.

Imports :mod:`hammerstein.core`, :mod:`hammerstein.models`, :mod:`hammerstein.io` and
:mod:`hammerstein.signals`; never compensation or above.
"""
