"""Models of the actuator: the play operator and the (multivariable) Prandtl-Ishlinskii
model, the Preisach and generalised-PI models, creep, the linear dynamics (bending
modes, sampled state space) and the Hammerstein plant that cascades them, and the
amplifier's limits.

Imports only :mod:`hammerstein.exceptions`, :mod:`hammerstein.simulation` and
:mod:`hammerstein.core`.
"""
