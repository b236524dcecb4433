"""The result of a drive computation: the voltages for a reference and what they ask of the
amplifier (:func:`hammerstein.compensation.drive.drive_signal`,
:func:`hammerstein.compensation.drive.hardware_drive`).

Documented and re-exported as :class:`hammerstein.compensation.drive.DriveResult`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["DriveResult"]


@dataclass
class DriveResult:
    """Voltages for a reference and what they ask of the amplifier.

    Parameters
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        The drive [V]: the commanded voltages, range-clipped and slew-limited
        when an amplifier is given and ``limits`` is not ``"error"``.
    commanded : numpy.ndarray, shape (m, n_samples)
        The compensator's voltages before any limit [V].
    reference : numpy.ndarray, shape (p, n_samples)
        The faded reference the actuator should follow [µm].
    peak_input : numpy.ndarray, shape (m,)
        ``max |u|`` of ``commanded`` [V].
    peak_slew : numpy.ndarray, shape (m,)
        ``max |du| / T`` of ``commanded`` from rest [V/s].
    fade_samples : int
        The fade-in used [samples].
    problems : list of str
        The limits exceeded (empty without an amplifier).
    shaped : list of str
        Where and by how much the drive was shaped into the limits measured on
        the identification records (:func:`shape_drive`; empty when not).
    notes : list of str
        What the drive cannot do, named for the user (e.g. a harmonic of the reference
        at a bending mode: :func:`hammerstein.compensation.shaping.mode_note`).
    rest_lead : int or None
        The fade-in's first samples at rest (:func:`hardware_fade`'s ``lead``) when more
        than a tenth of it (a stable inversion's pre-actuation); None otherwise.
    start_offset : numpy.ndarray or None, shape (m,)
        The compensator's first sample minus the rest voltages [V], when
        :func:`~hammerstein.compensation.lookahead.taper_preactuation` faded it in.
    taper_change : float or None
        The largest change that fade made to any voltage over the rest lead [V]: what the
        drive differs there from the compensator's own voltages, which the exported C
        gives (it does not fade them); None when nothing was faded.
    limited, range_limited : bool
        Whether the limits measured on the records shaped the reference (not only the
        band limit below the first mode), and whether their range stage did.
    kind_note : str or None
        Which compensator kind and gain of the inverse multiplicative law
        :func:`hammerstein.scenario.hardware_route.compensate_reference` took
        for the model and why (the line ``compensate`` prints as ``note:``);
        None when the kind and its gain were the caller's own.
    """

    inputs: np.ndarray
    commanded: np.ndarray
    reference: np.ndarray
    peak_input: np.ndarray
    peak_slew: np.ndarray
    fade_samples: int
    problems: list = field(default_factory=list)
    shaped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    rest_lead: int = None
    start_offset: np.ndarray = None
    taper_change: float = None
    limited: bool = False
    range_limited: bool = False
    kind_note: str = None
