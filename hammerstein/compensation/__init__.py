"""Compensators and learning: the multivariable inverse law and its convergence check, per-
axis and exact inverses (PI, Preisach, generalised PI), stable inversion and ZPETC of
the dynamics, the Hammerstein compensator, the registry of model classes and the
compensator kinds each takes, drive files, iterative learning control, and feedback
controllers around the actuator.

Imports :mod:`hammerstein.core`, :mod:`hammerstein.models`, :mod:`hammerstein.io` and
:mod:`hammerstein.signals`; never identification, the scenario engine or above.
"""
