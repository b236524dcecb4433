"""Reference trajectories and open-loop voltage drives.

Every function returns ``(time, signal)`` sampled at the sampling period T:
``time`` has shape (n_samples,) [s] and ``signal`` has shape
(n_channels, n_samples). References are displacements [µm] for the
compensator; drives are voltages [V] applied open loop for characterisation.
The sine, circle, spiral and Lissajous trajectories are those of the paper,
Section 5 (Fig. 5, 8, 10-13); :func:`triangle` (and :func:`triangle_drive`),
:func:`raster` (AFM-style scans) and :func:`from_file` (a trajectory read
from a CSV file) are the references people scan with. The generators live in
two private modules (periodic trajectories; triangles, rasters and files);
this module is their public face and holds the registry of the kinds a
scenario names (:data:`REFERENCE_KINDS`, :data:`DRIVE_KINDS`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from hammerstein.signals.metrics import raster_line_metrics
from hammerstein.core.schema import Field, Invalid, choice, integer, is_number, name_list, number, string
from hammerstein.exceptions import SignalError
# the signal generators live in two private modules; this module is their public face and
# holds the registry of kinds that scenarios name
from hammerstein.signals._periodic import (MAX_FILE_BYTES, MAX_SAMPLES, MIN_SAMPLES_PER_PERIOD,  # noqa: F401
                                           circle, lissajous, lissajous_period, sine, sine_drive,
                                           spiral, time_vector)
from hammerstein.signals._scans import (from_file, raster, raster_line_index, triangle,
                                        triangle_drive, triangle_wave)

__all__ = [
    "SignalError",
    "MIN_SAMPLES_PER_PERIOD",
    "time_vector",
    "sine",
    "sine_drive",
    "triangle_wave",
    "triangle",
    "triangle_drive",
    "raster",
    "raster_line_index",
    "from_file",
    "MAX_FILE_BYTES",
    "circle",
    "spiral",
    "lissajous",
    "lissajous_period",
    "ReferenceKind",
    "REFERENCE_KINDS",
    "DRIVE_KINDS",
    "words_number",
]

for _name in ("time_vector", "sine", "sine_drive", "triangle_wave", "triangle", "triangle_drive",
              "raster", "raster_line_index", "from_file", "circle", "spiral", "lissajous",
              "lissajous_period"):
    globals()[_name].__module__ = __name__      # documented as this module's
del _name
# -- the registry of signal kinds: ``reference = { kind = ... }`` / ``drive = { kind = ... }`` --
def _pair(what):
    def check(v):
        if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
            return [float(a) for a in v]
        raise Invalid(f"expected {what}, found {v!r}")
    return check


def _point(v):
    if isinstance(v, list) and len(v) >= 2 and all(is_number(a) for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected two numbers [x, y] [µm] (the figure's outputs at its centre), or "
                  f"one per output of the plant, found {v!r}")


def _amplitudes(v):
    if is_number(v) and v > 0:
        return float(v)
    if isinstance(v, list) and len(v) == 2 and all(is_number(a) and a > 0 for a in v):
        return [float(a) for a in v]
    raise Invalid(f"expected a positive number or two [µm], found {v!r}")


def _fraction(upper):
    def check(v):
        if not is_number(v) or not 0 <= v <= upper:
            raise Invalid(f"expected a fraction of the period in [0, {upper:g}], found {v!r}")
        return float(v)
    return check


def _column_map(v):
    if isinstance(v, dict) and v and all(isinstance(c, str) and c for c in v.values()):
        return dict(v)
    raise Invalid(f"expected a table {{ <output> = \"<column>\" }} of column names, found {v!r}")


def words_number(v, unit=""):
    """A number for people: ``50 µm``, ``0.25 s``, ``33.3333 Hz``.

    Parameters
    ----------
    v : float
    unit : str
        Appended after a space when given.

    Returns
    -------
    str
        ``v`` with 6 significant digits.
    """
    return f"{float(v):.6g}{' ' + unit if unit else ''}"


def _length(s):
    if "periods" in s:
        return f"{words_number(s['periods'])} period{'' if s['periods'] == 1 else 's'}"
    return words_number(s["duration"], "s") if "duration" in s else ""


def _common_words(s, unit):
    """Phase and offset when not zero, then the record length."""
    parts = [f"phase {words_number(s['phase'], '°')}"] if s.get("phase") else []
    if s.get("offset"):
        parts.append(f"offset {words_number(s['offset'], unit)}")
    if s.get("center"):
        parts.append("centre (" + ", ".join(words_number(v) for v in s["center"]) + f") {unit}")
    return parts + [_length(s)]


@dataclass
class ReferenceKind:
    """An entry of a signal registry (:data:`REFERENCE_KINDS`, :data:`DRIVE_KINDS`).

    Adding a kind is one entry: its keys are checked by ``hammerstein
    validate``, its generator runs there (so a signal beyond Nyquist is
    reported before any run), its summary is the "signal" column of
    ``report.md``, its metrics and scan geometry (raster-style extras) are
    added by the execution and the report.

    Parameters
    ----------
    fields : dict of str to hammerstein.core.schema.Field
        The keys of the table besides ``kind``.
    generate : callable
        ``generate(table, T, names, base_dir) -> (time, signal, period, extras)``:
        ``table`` the checked table (defaults filled, no ``kind``), ``T`` the
        sampling period [s], ``names`` the plant's outputs (references) or
        inputs (drives); ``time`` shape (n_samples,) [s], ``signal`` shape
        (len(names), n_samples) [µm or V], ``period`` [s] (what
        ``settle_periods`` counts), ``extras`` a dict of ``loop_channel``
        (index of a single-axis loop), ``driven_input`` (drives) and
        ``scale`` [µm] (percent metrics). Raises SignalError naming the key.
    summary : callable
        ``summary(table, unit) -> list of str``: the table in words for the
        report (``["circle", "radius 50 µm", "50 Hz", "3 periods"]``).
    description : str
        One line for ``hammerstein list`` and the README.
    period : callable, optional
        ``period(table) -> float or None`` [s] before generating (the sample
        budget); default ``1 / frequency`` when the table has one.
    metrics : callable, optional
        ``metrics(time, table, reference, outputs) -> list of dict``: rows
        added to the tracking metrics (e.g. per scan line).
    scan : callable, optional
        ``scan(time, table, names) -> dict`` of a scanned (raster-style)
        reference: ``line`` (scan line per sample), ``trace`` (bool per
        sample), ``fast``, ``slow`` (output names), ``extent`` (fast-axis
        length [µm]) and ``start`` (where the fast axis starts [µm]); the
        report draws the error per scan line from it.
    """

    fields: dict
    generate: Callable
    summary: Callable
    description: str = ""
    period: Callable | None = None
    metrics: Callable | None = None
    scan: Callable | None = None

    def period_of(self, table):
        """The period [s] of a checked table before generating it, or None.

        Parameters
        ----------
        table : dict

        Returns
        -------
        float or None
        """
        if self.period is not None:
            return self.period(table)
        return 1.0 / table["frequency"] if "frequency" in table else None


def _placed(xy, outs, names, held=None):
    """A (2, N) planar trajectory on outputs ``outs`` of ``names``: (p, N); the other
    outputs at ``held`` (p,) [µm] (a full ``center``), else 0."""
    sig = np.zeros((len(names), xy.shape[1]))
    if held is not None:
        sig += np.asarray(held, dtype=float)[:, None]
    for row, o in zip(xy, outs):
        sig[list(names).index(o)] = row
    return sig


def _centre_split(c, outs, names):
    """A planar table's ``center`` as the figure's (2 values) and the held outputs' (p values).

    ``center`` gives the two outputs of the figure (``[x, y]``), or every
    output of the plant in its order (``[x, y, z]`` on a three-axis stage:
    the outputs outside the figure are held there instead of at 0 µm).
    """
    centre = c.get("center")
    if centre is None or len(centre) == 2:
        return None
    if len(centre) != len(names):
        raise SignalError(f"center: expected two values (the figure's outputs {list(outs)}) or "
                          f"one per output of the plant {list(names)}, found {len(centre)}")
    c["center"] = [centre[list(names).index(o)] for o in outs]
    return centre


def _planar_outputs(table, names):
    outs = table.pop("outputs", None) or list(names[:2])
    missing = [o for o in outs if o not in names]
    if not missing and len(set(outs)) < len(outs):
        raise SignalError(f"outputs: expected two different outputs of the plant {list(names)}, "
                          f"found {outs}")
    if len(names) < 2:
        raise SignalError(f"outputs: a planar reference needs two outputs; the plant has one "
                          f"({names[0]}): use a sine, triangle or a file reference on it")
    if missing:
        raise SignalError(f"outputs: expected two of the plant's outputs {list(names)}, found {outs}")
    return outs


def _single_axis(fn):
    def generate(c, T, names, base_dir):
        t, sig = fn(T, names, **c)
        return t, sig, 1.0 / c["frequency"], {"loop_channel": list(names).index(c["output"]),
                                              "scale": c["amplitude"]}
    return generate


def _single_axis_words(kind):
    def summary(s, unit):
        return [f"{kind} on {s.get('output', s.get('input'))}", words_number(s["amplitude"], unit),
                words_number(s["frequency"], "Hz")] + _common_words(s, unit)
    return summary


def _drive(fn):
    def generate(c, T, names, base_dir):
        t, sig = fn(T, names, **c)
        return t, sig, 1.0 / c["frequency"], {"driven_input": list(names).index(c["input"])}
    return generate


def _circle(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    held = _centre_split(c, outs, names)
    t, xy = circle(T, **c)
    return t, _placed(xy, outs, names, held), 1.0 / c["frequency"], {"scale": c["radius"]}


def _spiral(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    held = _centre_split(c, outs, names)
    t, xy = spiral(T, **c)
    return t, _placed(xy, outs, names, held), 1.0 / c["frequency"], {"scale": c["radius"]}


def _lissajous_period(c):
    try:
        return lissajous_period(*c["frequencies"])
    except SignalError:
        return 1.0 / min(c["frequencies"])


def _lissajous(c, T, names, base_dir):
    outs = _planar_outputs(c, names)
    held = _centre_split(c, outs, names)
    t, xy = lissajous(T, **c)
    return (t, _placed(xy, outs, names, held), _lissajous_period(c),
            {"scale": float(np.max(c["amplitude"]))})


def _lissajous_words(s, unit):
    a = s["amplitude"]
    amp = (" × ".join(words_number(x) for x in a) + f" {unit}") if isinstance(a, list) \
        else words_number(a, unit)
    return (["Lissajous", amp, " / ".join(words_number(f) for f in s["frequencies"]) + " Hz"]
            + _common_words(s, unit))


def _raster(c, T, names, base_dir):
    outs = c.pop("outputs")
    if len(set(outs)) != 2 or any(o not in names for o in outs):
        raise SignalError(f"outputs: expected two different outputs [fast, slow] of the plant "
                          f"{list(names)}, found {outs}")
    held = _centre_split(c, outs, names)
    t, xy = raster(T, **c)
    return (t, _placed(xy, outs, names, held), 1.0 / c["frequency"],
            {"scale": float(max(c["size"]))})


def _raster_words(s, unit):
    fast, slow = s["outputs"]
    size = s["size"]
    parts = [f"raster, fast {fast}, slow {slow}",
             f"{words_number(size[0])} × {words_number(size[1])} {unit}", f"{s['lines']} lines",
             f"{words_number(s['frequency'], 'Hz')} line rate", f"slow axis {s.get('slow', 'step')}"]
    if s.get("smoothing"):
        parts.append(f"turns rounded over {words_number(100 * s['smoothing'])} % of a period")
    return parts + _common_words(s, unit)


def _raster_metrics(time, s, reference, outputs):
    return raster_line_metrics(reference, outputs, raster_line_index(time, s["frequency"]))


def _raster_scan(time, s, names):
    return {"line": raster_line_index(time, s["frequency"]),
            "trace": np.mod(np.asarray(time) * float(s["frequency"]), 1.0) < 0.5,
            "fast": s["outputs"][0], "slow": s["outputs"][1], "extent": float(s["size"][0]),
            "start": (float(s["center"][0]) - 0.5 * float(s["size"][0])
                      if s.get("center") is not None else 0.0)}


def _file(c, T, names, base_dir):
    period = c.pop("period", None) or T
    t, sig = from_file(T, names, base_dir=base_dir, **c)
    return t, sig, period, {}


def _file_words(s, unit):
    cols = ", ".join(f"{o} = {c!r}" for o, c in s.get("columns", {}).items())
    return [f"file {s.get('file')}", f"time {s.get('time', 'time')!r}", cols]


_PHASE = Field(number("deg"), default=0.0)
_LENGTH = {"periods": Field(number("periods", 0)), "duration": Field(number("s", 0))}
_SINE_REFERENCE = {"output": Field(string(), required=True),
                   "amplitude": Field(number("µm", 0), required=True),
                   "frequency": Field(number("Hz", 0), required=True),
                   "phase": _PHASE, "offset": Field(number("µm"), default=0.0), **_LENGTH}
_SINE_DRIVE = {"input": Field(string(), required=True),
               "amplitude": Field(number("V", 0), required=True),
               "frequency": Field(number("Hz", 0), required=True),
               "phase": _PHASE, "offset": Field(number("V"), default=0.0), **_LENGTH}

#: Reference kinds (``[[cases]] reference = { kind = ... }``): name -> :class:`ReferenceKind`.
#: Add a kind by adding an entry (see docs/python-api.md, "Where things go").
REFERENCE_KINDS: dict[str, ReferenceKind] = {
    "sine": ReferenceKind(_SINE_REFERENCE, _single_axis(sine), _single_axis_words("sine"),
                          "sine on one output (paper Fig. 8)"),
    "triangle": ReferenceKind(dict(_SINE_REFERENCE), _single_axis(triangle),
                              _single_axis_words("triangle"), "triangle on one output"),
    "circle": ReferenceKind(
        {"radius": Field(number("µm", 0), required=True),
         "frequency": Field(number("Hz", 0), required=True),
         "phase": _PHASE, "outputs": Field(name_list(2)), "center": Field(_point), **_LENGTH},
        _circle, lambda s, unit: ["circle", f"radius {words_number(s['radius'], unit)}",
                                  words_number(s["frequency"], "Hz")] + _common_words(s, unit),
        "circle on two outputs (paper Fig. 10)"),
    "spiral": ReferenceKind(
        {"radius": Field(number("µm", 0), required=True),
         "frequency": Field(number("Hz", 0), required=True),
         "tau": Field(number("s", 0), required=True),
         "duration": Field(number("s", 0), required=True),
         "circle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
         "phase": _PHASE, "outputs": Field(name_list(2)), "center": Field(_point)},
        _spiral, lambda s, unit: ["spiral", f"radius {words_number(s['radius'], unit)}",
                                  words_number(s["frequency"], "Hz"),
                                  f"decay τ {words_number(s['tau'], 's')} after "
                                  f"{words_number(s.get('circle_periods', 1.0))} circle(s)"]
        + _common_words(s, unit),
        "circle whose radius decays (paper Fig. 11)"),
    "lissajous": ReferenceKind(
        {"amplitude": Field(_amplitudes, required=True),
         "frequencies": Field(_pair("two positive frequencies [f_x, f_y] [Hz]"), required=True),
         "phase": _PHASE, "outputs": Field(name_list(2)), "center": Field(_point), **_LENGTH},
        _lissajous, _lissajous_words, "Lissajous figure on two outputs (paper Fig. 12-13)",
        period=_lissajous_period),
    "raster": ReferenceKind(
        {"outputs": Field(name_list(2), required=True),     # [fast, slow]
         "size": Field(_pair("two positive extents [fast, slow] [µm]"), required=True),
         "lines": Field(integer(2), required=True),
         "frequency": Field(number("Hz", 0), required=True),  # fast axis (line rate)
         "slow": Field(choice("step", "ramp"), default="step"),
         "smoothing": Field(_fraction(0.5), default=0.0), "center": Field(_point)},
        _raster, _raster_words, "AFM-style raster scan (trace and retrace, per-line metrics)",
        metrics=_raster_metrics, scan=_raster_scan),
    "file": ReferenceKind(
        {"file": Field(string(), required=True),
         "time": Field(string(), default="time"),
         "columns": Field(_column_map, required=True),
         "duration": Field(number("s", 0)),
         "period": Field(number("s", 0))},   # what settle_periods counts (default: T)
        _file, _file_words, "trajectory read from a CSV file",
        period=lambda c: None),
}

#: Drive kinds (``[[cases]] drive = { kind = ... }``, open-loop voltages): name -> :class:`ReferenceKind`.
DRIVE_KINDS: dict[str, ReferenceKind] = {
    "sine": ReferenceKind(_SINE_DRIVE, _drive(sine_drive), _single_axis_words("sine"),
                          "sine voltage on one input (paper Fig. 5)"),
    "triangle": ReferenceKind(dict(_SINE_DRIVE), _drive(triangle_drive),
                              _single_axis_words("triangle"), "triangle voltage on one input"),
}
