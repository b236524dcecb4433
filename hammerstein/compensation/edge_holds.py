"""A drive held on its amplifier's range: where the reference asks more than the actuator reaches.

The exact inverses of the Preisach and generalised-PI models are defined over the
input range the amplifier allows (for an identified model, the records' range): a
reference beyond what that range reaches is met by a drive that sits on the range's
edge, exactly, and no limit is exceeded, so neither the reference shaping nor the
amplifier's check said anything. Measured on an outside actuator: a 50 µm circle at
20 Hz whose top lies beyond the records' travel held ``uy`` at +20 V on 240 of 5000
samples without a word; only the exported C's range status showed it.
:func:`edge_hold_note` names such holds.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.shaping import time_intervals

__all__ = ["EDGE_TOLERANCE", "edge_hold_note"]

#: A sample within this fraction of the range's width from an edge is on it (the inverses
#: return the edge itself; the slew limit's arithmetic may leave a few ulps)
EDGE_TOLERANCE = 1e-9


def edge_hold_note(inputs, amplifier, start, sampling_period, rest=None, unit="V"):
    """A note naming the inputs that sit on their range's edge after the fade-in, or None.

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        The drive [``unit``].
    amplifier : hammerstein.models.amplifier.Amplifier or None
        Its ranges (``channels[i].low``, ``.high`` [``unit``]) and input names; None: no note.
    start : int
        First sample judged (the fade-in's end) [samples].
    sampling_period : float
        T [s].
    rest : array_like, shape (m,), optional
        The rest voltages [``unit``] (default 0): an edge that is an input's rest (a unipolar
        stage's 0 V) is where a reference at the rest output is met exactly, not a hold.
    unit : str
        The inputs' unit, the model's (``HammersteinPlant.units[0]``; a preset's
        ``input_unit``), in which the note gives the edges.

    Returns
    -------
    str or None
        Per input held: the edge, the samples and their share of those judged, the time
        intervals; then what to do.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.models.amplifier import Amplifier, AmplifierChannel
    >>> amp = Amplifier([AmplifierChannel(-20.0, 20.0)], ["ux"])
    >>> u = np.array([[0.0, 10.0, 20.0, 20.0, 12.0]])
    >>> edge_hold_note(u, amp, 1, 0.001)[:62]
    'ux holds the range edge 20 V on 2 of the 4 samples after the f'
    >>> mv = Amplifier([AmplifierChannel(-500.0, 500.0)], ["ux"])      # a model in mV
    >>> edge_hold_note(25 * u, mv, 1, 0.001, unit="mV")[:33]
    'ux holds the range edge 500 mV on'
    """
    if amplifier is None:
        return None
    u = np.asarray(inputs, dtype=float)[:, int(start):]
    if u.shape[1] == 0:
        return None
    r0 = np.zeros(u.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    held = []
    for i, (name, c) in enumerate(zip(amplifier.inputs, amplifier.channels)):
        width = c.high - c.low
        if not np.isfinite(width):
            continue
        for edge in (c.low, c.high):
            if abs(edge - r0[i]) <= EDGE_TOLERANCE * width:
                continue
            on = np.abs(u[i] - edge) <= EDGE_TOLERANCE * width
            if np.any(on):
                held.append(f"{name} holds the range edge {edge:g} {unit} on {int(on.sum())} of the "
                            f"{u.shape[1]} samples after the fade-in "
                            f"({100 * on.mean():.3g} %; "
                            f"{time_intervals(np.concatenate([np.zeros(int(start), bool), on]), sampling_period)})")
    if not held:
        return None
    return ("; ".join(held) + ": the reference asks more than the model reaches within the "
            "range there, and the output falls short of it on those samples; centre or shrink "
            "the reference, or widen the preset's [amplifier] range if the amplifier and the "
            "stage allow more than the records used (docs/drives.md)")
