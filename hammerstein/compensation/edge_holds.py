"""A drive held on its amplifier's range: where the reference asks more than the actuator reaches.

The exact inverses of the Preisach and generalised-PI models are defined over the
input range the amplifier allows (for an identified model, the records' range): a
reference beyond what that range reaches is met by a drive that sits on the range's
edge, exactly, and no limit is exceeded, so neither the reference shaping nor the
amplifier's check said anything. Measured on an outside actuator: a 50 µm circle at
20 Hz whose top lies beyond the records' travel held ``uy`` at +20 V on 240 of 5000
samples without a word; only the exported C's range status showed it.
:func:`edge_hold_note` names such holds. An edge that is the input's rest (a unipolar
stage's 0 V) is where a reference at the rest output is met exactly; away from the rest
output it is a hold too: on an outside 0..100 V stage a learnt drive sat on vy = 0 V for a
stretch of a circle that never came near the rest output, and learning stalled there.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.shaping import time_intervals

__all__ = ["EDGE_TOLERANCE", "AT_REST_FRACTION", "edge_hold_note", "edge_holds",
           "reference_at_rest"]

#: A sample within this fraction of the range's width from an edge is on it (the inverses
#: return the edge itself; the slew limit's arithmetic may leave a few ulps)
EDGE_TOLERANCE = 1e-9
#: Of each output's span over the reference: how near the rest output a sample of it is at rest
AT_REST_FRACTION = 1e-3


def reference_at_rest(reference, rest_output):
    """The samples where the reference is at the rest output, on every output.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        The reference the drive aims at (faded in) [µm].
    rest_output : array_like, shape (p,)
        The output at the rest voltages [µm].

    Returns
    -------
    numpy.ndarray of bool, shape (n_samples,)
        Within :data:`AT_REST_FRACTION` of each output's span over the reference (and
        its rest output) of that rest output.

    Examples
    --------
    >>> reference_at_rest([[0.0, 0.0, 5.0, 10.0]], [0.0]).tolist()
    [True, True, False, False]
    """
    r = np.array(reference, dtype=float, ndmin=2)
    y0 = np.asarray(rest_output, dtype=float).reshape(-1, 1)
    span = np.maximum(r.max(axis=1, keepdims=True), y0) - np.minimum(r.min(axis=1, keepdims=True),
                                                                      y0)
    return np.all(np.abs(r - y0) <= AT_REST_FRACTION * span, axis=0)


def edge_holds(inputs, amplifier, start, rest=None, at_rest=None):
    """The inputs on their range's edge after the fade-in: (input, edge, samples on it).

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        The drive.
    amplifier : hammerstein.models.amplifier.Amplifier or None
        Its ranges; None: none held.
    start : int
        First sample judged (the fade-in's end) [samples].
    rest : array_like, shape (m,), optional
        The rest voltages (default 0).
    at_rest : array_like of bool, shape (n_samples,), optional
        Where the reference is at the rest output (:func:`reference_at_rest`); None: a rest
        edge is never held.

    Returns
    -------
    list of (int, float, numpy.ndarray of bool)
        Per input and edge held: the input's index, the edge [``unit``] and the samples
        from ``start`` on on it, excluding a rest edge where the reference is at rest.

    Examples
    --------
    >>> from hammerstein.models.amplifier import Amplifier, AmplifierChannel
    >>> amp = Amplifier([AmplifierChannel(0.0, 100.0)], ["vy"])
    >>> u = np.array([[0.0, 0.0, 40.0, 0.0]])
    >>> edge_holds(u, amp, 1)                                        # 0 V: its rest
    []
    >>> [(i, e, on.tolist()) for i, e, on in edge_holds(u, amp, 1, at_rest=[1, 0, 0, 0])]
    [(0, 0.0, [True, False, True])]
    """
    if amplifier is None:
        return []
    u = np.asarray(inputs, dtype=float)[:, int(start):]
    r0 = np.zeros(u.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    away = None if at_rest is None else ~np.asarray(at_rest, dtype=bool)[int(start):]
    held = []
    for i, c in enumerate(amplifier.channels):
        width = c.high - c.low
        if not np.isfinite(width) or u.shape[1] == 0:
            continue
        for edge in (c.low, c.high):
            on = np.abs(u[i] - edge) <= EDGE_TOLERANCE * width
            if abs(edge - r0[i]) <= EDGE_TOLERANCE * width:
                if away is None:
                    continue
                on = on & away
            if np.any(on):
                held.append((i, float(edge), on))
    return held


def edge_hold_note(inputs, amplifier, start, sampling_period, rest=None, unit="V",
                   at_rest=None):
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
        stage's 0 V) is where a reference at the rest output is met exactly.
    unit : str
        The inputs' unit, the model's (``HammersteinPlant.units[0]``; a preset's
        ``input_unit``), in which the note gives the edges.
    at_rest : array_like of bool, shape (n_samples,), optional
        The samples where the reference the drive aims at is at the rest output
        (:func:`reference_at_rest`): on the others an input on its rest edge is held too.
        None: a rest edge is never named.

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
    >>> stage = Amplifier([AmplifierChannel(0.0, 100.0)], ["vy"])        # unipolar: rests at 0 V
    >>> edge_hold_note([[0.0, 0.0, 40.0, 0.0]], stage, 1, 0.001,
    ...                at_rest=[True, False, False, False])[:66]
    'vy holds the range edge 0 V on 2 of the 3 samples after the fade-i'
    """
    held = edge_holds(inputs, amplifier, start, rest, at_rest)
    if not held:
        return None
    r0 = np.zeros(len(amplifier.channels)) if rest is None else np.asarray(rest, dtype=float)
    lines = []
    for i, edge, on in held:
        width = amplifier.channels[i].high - amplifier.channels[i].low
        at = ("; its rest, where the reference is away from the rest output"
              if abs(edge - r0[i]) <= EDGE_TOLERANCE * width else "")
        when = time_intervals(np.concatenate([np.zeros(int(start), bool), on]), sampling_period)
        lines.append(f"{amplifier.inputs[i]} holds the range edge {edge:g} {unit} on "
                     f"{int(on.sum())} of the {on.size} samples after the fade-in "
                     f"({100 * on.mean():.3g} %; {when}{at})")
    return ("; ".join(lines) + ": the reference asks beyond what the model reaches within the "
            "range there, and the output falls short of it on those samples; centre or shrink "
            "the reference, or widen the preset's [amplifier] range if the amplifier and the "
            "stage allow more than the records used (docs/drives.md)")
