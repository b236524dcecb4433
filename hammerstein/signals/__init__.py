"""Signals: reference trajectories (circles, rasters, spirals, Lissajous, files),
excitation designs for identification, tracking metrics and trial-to-trial noise.

Imports :mod:`hammerstein.core`, :mod:`hammerstein.models` and :mod:`hammerstein.io` (a
reference read from a CSV file); never identification, compensation or above.
"""
