"""What a model reaches over the amplifier's range, and a reference beyond it.

A reference outside the outputs the actuator reaches (a circle or raster
whose ``center`` was left at 0 on an actuator driven from -20 or 0 V) has
no drive: the exact inverse sits at the edge of its model, or alternates
there (a drive that chatters, :func:`hammerstein.compensation.shaping.chatter_warnings`),
or the range stage of :func:`hammerstein.compensation.shaping.shape_reference`
cuts it. :func:`output_reach` measures the reach quasi-statically and
:func:`reach_note` names the cause, with the reach's middle as a centre and,
when centring alone does not fit the reference, the largest size that fits
about it (:func:`fitting_scale`: the reach is a box per output, and the
outputs a drive reaches together are fewer: a circle as tall as the box
does not fit it).
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.edge_holds import reference_at_rest

__all__ = ["output_reach", "reach_note", "reach_centre", "fitting_scale", "REACH_NOTE_START",
           "MAX_REACH_CORNERS", "REACH_RAMP", "REACH_MARGIN", "SCALE_STEPS", "SCALE_EDGE",
           "SCALE_MAX_SAMPLES"]

#: Corners of the input box a reach is measured at, at most (2 ** m; beyond: the two diagonals).
MAX_REACH_CORNERS = 16
#: Samples of each ramp of :func:`reach_note`'s path (the model is rate-independent).
REACH_RAMP = 64
#: Of the reach's span: how far beyond it a reference must go to be named.
REACH_MARGIN = 0.01
#: Halvings of :func:`fitting_scale`'s search (its scale to within 2 ** -SCALE_STEPS).
SCALE_STEPS = 10
#: Longest reference [samples] :func:`fitting_scale` is run on: its search runs the
#: compensator up to SCALE_STEPS + 1 times over the whole reference; a longer one (a
#: measured scan of minutes) gets the advice from the extents alone.
SCALE_MAX_SAMPLES = 200_000
#: Of an input's range: how far from a non-rest edge :func:`fitting_scale` keeps the drive
#: (the drive written is shaped after the compensator's, by a few thousandths of the range)
SCALE_EDGE = 0.005
#: How :func:`reach_note` begins (a command refusing a chattering drive puts it first).
REACH_NOTE_START = "the reference leaves what the model reaches"


def output_reach(model, amplifier, creep=None):
    """The outputs the model reaches over the amplifier's range, quasi-statically [µm].

    The model is driven from rest along ramps to every corner of the range
    box and back (at most :data:`MAX_REACH_CORNERS` corners: with more
    inputs, all-low and all-high), twice, and the second pass is kept: the
    steady cycle a repeating reference runs in (its virgin rest is reached
    once only); the output is scaled by each creep's static gain as
    :func:`hammerstein.compensation.drive.rest_output` does.

    Parameters
    ----------
    model : object
        A hysteresis model (``n_inputs``, ``simulate(u) -> (outputs (p, n), state)``).
    amplifier : hammerstein.models.amplifier.Amplifier or None
    creep : sequence of (Creep or None), length p, optional

    Returns
    -------
    numpy.ndarray, shape (p, 2), or None
        Lowest and highest output [µm]; None without an amplifier or with
        an input whose range is not finite.

    Examples
    --------
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.models.amplifier import amplifier_from_table
    >>> plant = load_plant("rakotondrabe-2dof", dynamics=False)
    >>> amp = amplifier_from_table({"range": [-10.0, 10.0]}, ["ux", "uy"])
    >>> reach = output_reach(plant.hysteresis, amp)
    >>> bool(reach[0, 0] < 0 < reach[0, 1])
    True
    """
    if amplifier is None:
        return None
    low = np.array([c.low for c in amplifier.channels], dtype=float)
    high = np.array([c.high for c in amplifier.channels], dtype=float)
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        return None
    m = low.size
    if 2 ** m <= MAX_REACH_CORNERS:
        bits = (np.arange(2 ** m)[:, None] >> np.arange(m)[None, :]) & 1
        corners = np.where(bits == 1, high, low)
    else:
        corners = np.array([low, high])
    rest = amplifier.rest_voltages()
    ramp = np.linspace(0.0, 1.0, REACH_RAMP)[None, :]
    legs = [rest[:, None] + ramp * (c - rest)[:, None] for c in corners]
    path = np.concatenate([np.concatenate([leg, leg[:, ::-1]], axis=1) for leg in legs], axis=1)
    # twice: the second pass is the steady cycle. A stack's virgin rest (0 V from the
    # demagnetised state) is reached once; after its first rise 0 V leaves it 2.8 µm higher,
    # and a reference centred on the virgin range was refused as needing -14 V
    n = path.shape[1]
    y, _ = model.simulate(np.concatenate([path, path], axis=1))
    y = np.asarray(y, dtype=float)[:, n:]
    if creep is not None:
        y = y * np.array([1.0 if c is None else c.static_gain for c in creep])[:, None]
    return np.column_stack([y.min(axis=1), y.max(axis=1)])


def reach_centre(reach, reference):
    """Where :func:`reach_note` advises to centre the reference: the reach's middle [µm].

    An output the reference holds, inside the reach (a tube's z at 0 under
    a raster on x, y), keeps its value: the middle of its reach would move it.

    Parameters
    ----------
    reach : array_like, shape (p, 2)
        :func:`output_reach` [µm].
    reference : array_like, shape (p, n_samples)
        [µm].

    Returns
    -------
    numpy.ndarray, shape (p,)

    Examples
    --------
    >>> reach_centre([[-30, 30], [-4.3, 6.8]], [[0, 50], [0, 0]]).tolist()
    [0.0, 0.0]
    """
    reach = np.asarray(reach, dtype=float)
    r = np.array(reference, dtype=float, ndmin=2)
    span = reach[:, 1] - reach[:, 0]
    lo, hi = r.min(axis=1), r.max(axis=1)
    out = (lo < reach[:, 0] - REACH_MARGIN * span) | (hi > reach[:, 1] + REACH_MARGIN * span)
    held = (hi - lo <= 1e-9 * np.maximum(1.0, np.abs(hi))) & ~out
    return np.where(held, lo, reach.mean(axis=1))


def fitting_scale(inputs_of, reference, centre, amplifier, start, rest_output=None):
    """The largest size of the reference, about ``centre``, whose drive stays off the range's edges.

    The reference is moved to ``centre`` (the middle of its extent on each
    output goes there) and scaled about it by s <= 1; s is halved towards
    the largest value at which the compensator's drive, after ``start``,
    keeps :data:`SCALE_EDGE` of each input's range from every edge that is
    not the input's rest (there a reference at the rest output is met) and,
    given ``rest_output``, off the rest edge where the reference is away
    from the rest output.

    Parameters
    ----------
    inputs_of : callable
        ``inputs_of(reference) -> (m, n_samples)`` the compensator's drive [V], or None
        when there is none (a law that diverges there): that size does not fit.
    reference : array_like, shape (p, n_samples)
        [µm].
    centre : array_like, shape (p,)
        [µm], e.g. :func:`reach_centre`.
    amplifier : hammerstein.models.amplifier.Amplifier
        Its ranges and rest voltages.
    start : int
        First sample judged (the fade-in's end) [samples].
    rest_output : array_like, shape (p,), optional
        The output at the rest voltages [µm]; None: a rest edge is never a hold.

    Returns
    -------
    float
        s in [0, 1], to within ``2 ** -SCALE_STEPS`` below the largest that fits; 1: the
        reference fits at its size about ``centre``.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.models.amplifier import Amplifier, AmplifierChannel
    >>> amp = Amplifier([AmplifierChannel(0.0, 100.0)], ["u"])
    >>> r = np.array([[0.0, 80.0, 20.0, 80.0]])        # 80 µm about 40 µm, on a 1 V/µm stage
    >>> float(fitting_scale(lambda y: np.clip(y, 0, 100), r, [50.0], amp, 1))
    1.0
    >>> s = fitting_scale(lambda y: np.clip(y, 0, 100), r, [70.0], amp, 1)
    >>> round(float(s), 2)      # 70 + 40 s <= 99.5: 0.7375
    0.74
    >>> clip = lambda y: np.clip(y, 0, 100)        # about 30, its low at -10: on 0 V, its rest
    >>> low = np.array([[40.0, 80.0, 0.0, 80.0]])
    >>> float(fitting_scale(clip, low, [30.0], amp, 1)), round(float(fitting_scale(
    ...     clip, low, [30.0], amp, 1, rest_output=[0.0])), 2)      # 30 - 40 s >= 0
    (1.0, 0.75)
    """
    r = np.array(reference, dtype=float, ndmin=2)
    middle = 0.5 * (r.min(axis=1) + r.max(axis=1))
    centre = np.asarray(centre, dtype=float)
    low = np.array([c.low for c in amplifier.channels], dtype=float)
    high = np.array([c.high for c in amplifier.channels], dtype=float)
    rest = amplifier.rest_voltages()
    width = high - low
    tol = 1e-9 * width
    keep = SCALE_EDGE * width

    def fits(s):
        ref = centre[:, None] + s * (r - middle[:, None])
        u = inputs_of(ref)
        if u is None:
            return False
        u = np.asarray(u, dtype=float)[:, int(start):]
        away = (np.zeros(u.shape[1], bool) if rest_output is None else
                ~reference_at_rest(ref, rest_output)[int(start):])
        on_low = (np.abs(low - rest) <= tol)[:, None]
        on_high = (np.abs(high - rest) <= tol)[:, None]
        below = (u < (low + keep)[:, None]) & (~on_low | (np.abs(u - low[:, None]) <= tol[:, None])
                                               & away)
        above = (u > (high - keep)[:, None]) & (~on_high | (np.abs(u - high[:, None])
                                                             <= tol[:, None]) & away)
        return not (np.any(below) or np.any(above))

    if fits(1.0):
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(SCALE_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def reach_note(reach, reference, names=None, unit="µm", scale=None):
    """A note when the reference asks for outputs beyond the model's reach, or None.

    A reference outside what the range reaches (a circle or raster whose
    ``center`` was left at 0 on a unipolar actuator) makes the exact
    inverse sit at the edge of its model, or alternate there (a drive that
    chatters): the note names the cause and where to centre the reference
    (:func:`reach_centre`) and, when centring it does not suffice, the size
    that fits there: an output whose extent is larger than its reach's
    fits at no centre, and ``scale`` (:func:`fitting_scale` about the
    centre) bounds the size for all outputs together.

    Parameters
    ----------
    reach : array_like, shape (p, 2), or None
        :func:`output_reach` [µm].
    reference : array_like, shape (p, n_samples)
        [µm].
    names : sequence of str, optional
        Output names.
    unit : str
        The outputs' unit, the model's (``HammersteinPlant.units[1]``): the note's.
    scale : float, optional
        The largest size that fits about the centre, a fraction of the reference's
        (:func:`fitting_scale`); None: the extents against the reach's spans alone.

    Returns
    -------
    str or None

    Examples
    --------
    >>> reach_note([[1.5, 99.8]], [[-30.0, 30.0]], ["x"])[:46]
    'the reference leaves what the model reaches ov'
    >>> reach_note([[1.5, 99.8]], [[20.0, 80.0]], ["x"]) is None
    True
    >>> reach_note([[-30, 30], [-30, 30], [-4.3, 6.8]], [[0, 50], [0, 50], [0, 0]],
    ...            ["x", "y", "z"]).split("center = ")[1][:9]     # z held at 0: kept there
    '[0, 0, 0]'
    >>> reach_note([[1.5, 99.8]], [[-30.0, 90.0]], ["x"]).split("there; ")[1][:52]
    'x spans 120 µm, more than the 98.3 µm it reaches: no'
    """
    if reach is None:
        return None
    reach = np.asarray(reach, dtype=float)
    r = np.array(reference, dtype=float, ndmin=2)
    span = reach[:, 1] - reach[:, 0]
    lo, hi = r.min(axis=1), r.max(axis=1)
    out = (lo < reach[:, 0] - REACH_MARGIN * span) | (hi > reach[:, 1] + REACH_MARGIN * span)
    if not np.any(out):
        return None
    names = list(names) if names is not None else [f"output {i + 1}" for i in range(r.shape[0])]
    asks = "; ".join(f"{names[i]} asks {lo[i]:.4g}..{hi[i]:.4g} {unit}, the model reaches "
                     f"{reach[i, 0]:.4g}..{reach[i, 1]:.4g} {unit}" for i in np.flatnonzero(out))
    mid = reach_centre(reach, r)
    held = (hi - lo <= 1e-9 * np.maximum(1.0, np.abs(hi))) & ~out
    where = (f"a sine's or triangle's offset = {mid[0]:.4g}" if mid.size == 1 else
             f"a circle's or raster's center = [{', '.join(f'{v:.4g}' for v in mid)}], a sine's "
             f"or triangle's offset on its output")
    extent = hi - lo
    wide = extent > span * (1.0 + 1e-9)
    fit = min(1.0, float(np.min(span[wide] / extent[wide]))) if np.any(wide) else 1.0
    if scale is not None:
        fit = min(fit, float(scale))
    # the size advised is rounded down: the note's numbers fit as written
    fit = np.floor(fit * 1000.0) / 1000.0
    wider = "".join(f"; {names[i]} spans {extent[i]:.4g} {unit}, more than the "
                    f"{span[i]:.4g} {unit} it reaches: no centre fits it" for i in np.flatnonzero(wide))
    centre = (f"centre it inside the reach ({where} is the reach's "
              f"middle{', the held outputs where they are held' if np.any(held) else ''})")
    if fit < 1.0:
        sizes = ", ".join(f"{names[i]} {fit * extent[i]:.4g} {unit}"
                          for i in range(extent.size) if extent[i] > 0)
        advice = (f"{centre} and make it at most {fit:.3g} times its size about that centre "
                  f"({sizes} across: a circle's radius, a raster's width and height, a "
                  f"sine's or triangle's amplitude times {fit:.3g})"
                  + ("; at that size, centre and rate the compensator's drive stays off the "
                     "range's edges" if scale is not None else "; the outputs a drive reaches together "
                     "may ask less still"))
    else:
        advice = f"{centre} or make it smaller"
    return (f"{REACH_NOTE_START} over the amplifier's range ({asks}): "
            f"no drive can follow it there{wider}; {advice}")
