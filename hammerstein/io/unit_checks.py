"""Records whose numbers look like another unit than declared, and the units a scenario
converts to its plant's (``identify`` converts nothing; a scenario's files table converts
records in a declared unit to its plant's).

Used by ``hammerstein identify`` and by the scenarios that identify from measured records
(``identify = { records = "files" }``, ``kind = "identification"``), which warn alike.
"""

from __future__ import annotations

import numpy as np

__all__ = ["unit_warnings", "PLAUSIBLE_RANGE_MAX_UM", "PLAUSIBLE_RANGE_MIN_UM",
           "PLAUSIBLE_GAIN_MIN_UM_PER_V", "PLAUSIBLE_PERIOD_MAX_S", "INPUT_UNIT_SCALES",
           "OUTPUT_UNIT_SCALES", "unit_scale"]

#: Input units a scenario converts between (its records' and its plant's): value in V of one
#: unit. (``identify`` converts nothing.)
INPUT_UNIT_SCALES = {"V": 1.0, "mV": 1e-3, "kV": 1e3}

#: Output units a scenario converts between: value in µm of one unit.
OUTPUT_UNIT_SCALES = {"µm": 1.0, "um": 1.0, "nm": 1e-3, "mm": 1e3, "m": 1e6}


def unit_scale(unit, to, role):
    """The factor that takes a value in ``unit`` to ``to``.

    Parameters
    ----------
    unit, to : str
        Unit names (e.g. ``"mV"`` and ``"V"``).
    role : {"input", "output"}
        Which table converts them (:data:`INPUT_UNIT_SCALES` or
        :data:`OUTPUT_UNIT_SCALES`).

    Returns
    -------
    float
        1 for the same name; ``scales[unit] / scales[to]`` otherwise.

    Raises
    ------
    ValueError
        Two different units of which one is not in the table (the message
        names both and the units that convert to ``to``).

    Examples
    --------
    >>> from hammerstein.io.unit_checks import unit_scale
    >>> unit_scale("nm", "µm", "output"), unit_scale("counts", "counts", "input")
    (0.001, 1.0)
    """
    if unit == to:
        return 1.0
    scales = INPUT_UNIT_SCALES if role == "input" else OUTPUT_UNIT_SCALES
    if unit not in scales or to not in scales:
        others = ", ".join(repr(u) for u in scales if u != to)
        raise ValueError(f"{role}s in {unit!r} for a plant whose {role}s are in {to!r}: expected "
                         f"{to!r}" + (f" or a unit converted to it ({others})" if to in scales
                                      else " (no other unit converts to it)"))
    return scales[unit] / scales[to]


#: An output range [µm] above this is not an actuator's (a column in nm read as µm?).
PLAUSIBLE_RANGE_MAX_UM = 1000.0

#: ... and below this is not a motion (a column in metres or mm read as µm?).
PLAUSIBLE_RANGE_MIN_UM = 0.01

#: A direct path's gain [µm/V] below this is not a piezo's (an output in mm read as µm?):
#: piezo stages and stacks move about 0.05-5 µm per volt (a 78 µm stage over 100 V: 0.78
#: µm/V), 50 times the threshold at the least; the same stage written in mm reads 7.8e-4.
#: Peak-to-peak of the output over that of the input driving it, in the records that vary it.
PLAUSIBLE_GAIN_MIN_UM_PER_V = 1e-3

#: A sampling period [s] at or above this is not a hysteresis record's (a time in ms?).
PLAUSIBLE_PERIOD_MAX_S = 0.01


def unit_warnings(records, outputs, output_unit, time_column=None, inputs=None,
                  input_unit="V", converted=False):
    """One-line warnings for records whose numbers look like another unit than declared.

    A column without a unit in its name or a units row is taken in the declared unit;
    ``identify`` converts nothing (docs/records.md), a scenario's files table converts
    records in a declared unit to its plant's (``converted``), and the hints say which. An output in nm read as µm spans
    thousands of µm (a tester's x: 2.346e+04 µm), one in metres 1e-5 µm; a time column in
    ms read as s gives a sampling period of 0.1 s. An output in mm may span more than
    0.01 µm (a 78 µm stage: 0.078), but moves less than
    :data:`PLAUSIBLE_GAIN_MIN_UM_PER_V` µm per volt of the input that drives it
    (peak-to-peak over peak-to-peak in each record where an input varies, the largest
    over the records and inputs). The ranges and gains are checked only for outputs declared in µm (the
    default), the gains for inputs in V; the period always.

    Parameters
    ----------
    records : sequence of MultiRecord
        Every record read (``y`` (p, n) in ``output_unit``, ``sampling_period`` [s]).
    outputs : sequence of str
        Output column names, in the order of ``y``'s rows.
    output_unit : str
        The declared output unit (``--output-unit``).
    time_column : str, optional
        The time column's name (``--time``), None when the period was given.
    inputs : sequence of str, optional
        Input names, in the order of ``u``'s rows (each record's ``u`` (m, n) in
        ``input_unit``); without them the gains are not checked.
    input_unit : str
        The declared input unit (``--input-unit``).
    converted : bool
        Whether declaring the outputs' unit has them converted (a scenario's files table,
        which converts records to its plant's units), not only named (``identify``, the
        default: nothing is converted). Times are converted in neither.

    Returns
    -------
    list of str
        Without the ``warning:`` prefix, one per output or period that looks wrong.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> rec = SimpleNamespace(y=np.array([[9674.0, 33130.0]]), sampling_period=1e-4)
    >>> unit_warnings([rec], ["x"], "µm")[0][:40]
    "output 'x' spans 2.346e+04 µm over the r"
    >>> ms = SimpleNamespace(y=np.array([[1.0, 2.0]]), sampling_period=0.1, source="b.csv")
    >>> unit_warnings([rec, ms], ["x"], "mm", "t")[0][:52]
    "time column 't' of b.csv: sampling period 0.1 s, at "
    """
    lines = []
    if converted:
        fix = ("Outputs are read in µm: declare the column's unit with --output-unit (the "
               "records are then converted to the plant's units), or convert the column "
               "(docs/records.md)")
    else:
        fix = ("Outputs are read in µm and nothing is converted: convert the column, or "
               "declare its unit with --output-unit (docs/records.md)")
    if output_unit == "µm":
        for k, name in enumerate(outputs):
            spans = [float(np.ptp(np.asarray(r.y[k], dtype=float))) for r in records
                     if np.size(r.y[k])]
            span = max(spans) if spans else 0.0
            if not np.isfinite(span) or span <= 0:
                continue
            if span > PLAUSIBLE_RANGE_MAX_UM:
                guess = "in nm"
            elif span < PLAUSIBLE_RANGE_MIN_UM:
                guess = "in metres or mm"
            else:
                gain = _direct_gain(records, k, inputs, input_unit)
                if gain is not None and gain[0] < PLAUSIBLE_GAIN_MIN_UM_PER_V:
                    lines.append(
                        f"output '{name}' spans {span:.4g} µm over the records, {gain[0]:.3g} "
                        f"µm/V over {gain[1]}'s {gain[2]:.4g} V, below a piezo's "
                        f"{PLAUSIBLE_GAIN_MIN_UM_PER_V:g} µm/V (stages move 0.05-5 µm/V): a "
                        f"column in mm? {fix}")
                continue
            lines.append(f"output '{name}' spans {span:.4g} µm over the records, not an "
                         f"actuator's motion ({PLAUSIBLE_RANGE_MIN_UM:g}-"
                         f"{PLAUSIBLE_RANGE_MAX_UM:g} µm): a column {guess}? {fix}")
    periods = sorted({float(r.sampling_period) for r in records})
    if periods and periods[-1] >= PLAUSIBLE_PERIOD_MAX_S:
        col = f"time column '{time_column}'" if time_column is not None else "--sampling-period"
        slow = [getattr(r, "source", "") for r in records
                if float(r.sampling_period) >= PLAUSIBLE_PERIOD_MAX_S]
        if time_column is not None and any(slow):      # which file: one of several may be in ms
            col += (f" of {', '.join(s for s in slow[:3] if s)}"
                    f"{' and more' if len(slow) > 3 else ''}")
        lines.append(f"{col}: sampling period {periods[-1]:g} s, at least "
                     f"{PLAUSIBLE_PERIOD_MAX_S:g} s (a hysteresis record is sampled at kHz): a "
                     f"time in ms? Times are read in s and nothing is converted: convert the "
                     f"column to s, or give --sampling-period S (docs/records.md)")
    return lines


def _direct_gain(records, k, inputs, input_unit):
    """(gain [µm/V], input name, its span [V]) of output k on the input that moves it most.

    The largest over the records and inputs of the output's peak-to-peak over an input's
    (a record exciting one input leaves the others still, and they are left out), so
    that an output paired with another input than its k-th (a rectangular or coupled
    stage) is judged on the input that drives it; None without inputs, for inputs not in
    V, or when no record varies an input.
    """
    if not inputs or input_unit != "V":
        return None
    best = None
    for r in records:
        u = np.asarray(getattr(r, "u", ()), dtype=float)
        y = np.asarray(r.y, dtype=float)
        if u.ndim != 2 or y.ndim != 2 or k >= y.shape[0] or not u.shape[1] or not y.shape[1]:
            continue
        dy = float(np.ptp(y[k]))
        for j in range(min(u.shape[0], len(inputs))):
            du = float(np.ptp(u[j]))
            if not (np.isfinite(du) and np.isfinite(dy)) or du <= 0:
                continue
            if best is None or dy / du > best[0]:
                best = (dy / du, inputs[j], du)
    return best
