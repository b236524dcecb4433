"""The route of ``hammerstein compensate`` as a library function.

:func:`compensate_reference` chooses the kind for the model (when none is
given), builds the compensator from the actuator as the command does and
computes the drive the command writes
(:func:`hammerstein.compensation.drive.hardware_drive`) with its notes. The
command (:mod:`hammerstein.cli.compensate`) and ``learn`` call it; so can a
script. :func:`start_drive` is its drive for a compensator already built: a
scenario case on a :func:`~hammerstein.models.plant.hardware_start` plant (an amplifier, or an
identified model's output offset) runs it, so that the case starts as
``compensate`` starts the drive.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from hammerstein.compensation.drive import (FADE_DECAYS, MIN_FADE_S, apply_amplifier,
                                            compensator_rest, drive_signal, hardware_drive,
                                            starts_at_rest)
from hammerstein.compensation.lookahead import FIRST_SAMPLE_TOLERANCE
from hammerstein.compensation.model_classes import kind_problem, model_class
from hammerstein.compensation.kind_choice import choose_kind, explicit_law
from hammerstein.compensation.reach import (SCALE_MAX_SAMPLES, fitting_scale, output_reach,
                                            reach_centre, reach_note)
from hammerstein.compensation.shaping import (first_mode_hz, main_frequency, mode_decay_s,
                                              mode_note, relative_response)
from hammerstein.compensation.zpetc_notes import zpetc_note
from hammerstein.exceptions import AmplifierError, CompensatorDivergence, CompensatorError
from hammerstein.models.plant import HammersteinPlant, hardware_start
from hammerstein.scenario.registry import build_compensator

__all__ = ["compensate_reference", "start_drive", "compensator_plant", "hardware_start",
           "extrapolation_note", "plant_units",
           "unfollowed_problem",
           "model_miss", "LAW_KINDS", "REST_TOLERANCE", "UNFOLLOWED_SHARE", "MISS_WARNING",
           "MISS_REFUSE"]

#: A drive whose compensator asks for voltages beyond the amplifier's range by more than 1 % of
#: its span on more than this share of the samples after the fade-in is refused:
#: the limits then write a drive that follows nothing (a tester's tip-tilt platform: the exact
#: inverse at its -120 V bound on every sample, a drive of zeros written with exit 0)
UNFOLLOWED_SHARE = 0.5
#: The drive played through the model it was computed from misses the reference it follows by
#: more than this share of the reference's half-span on :data:`MISS_QUANTILE` of the samples
#: after the fade-in (a start-up's transient after the fade, or a raster's turn, is a few of
#: them): a note in the drive's notes ...
MISS_WARNING = 0.1
MISS_QUANTILE = 0.9
#: ... and by more than this share on half of those samples (its median), a refusal under
#: ``limits = "error"``: the drive follows nothing of the reference. An exact inverse held on its
#: input bounds answers every sample, and the limits see nothing beyond them (a Preisach model's
#: fitted dynamics, two lags at 12 and 16 Hz, made a 10 µm circle at 100 Hz a drive jumping
#: between 0 and 100 V that missed it by 91 % on the model itself, written with exit 0)
MISS_REFUSE = 0.5
#: Dynamics passing the reference's main frequency at less than this share of their static gain
#: are named as the cause of a miss.
MISS_ATTENUATION = 0.5

#: ``--fade-in 0`` takes a reference whose first sample is within this of the rest output [µm]
#: (the model's output at 0 V; the error message prints it to 7 digits)
REST_TOLERANCE = 1e-3
#: the kinds whose static part is the inverse multiplicative law (``--gain``, ``--check``)
LAW_KINDS = ("hammerstein", "multivariable", "diagonal")


def compensate_reference(plant, reference, period_samples=None, kind=None, inversion="zpetc",
                         fade_in=None, limits="error", gain=None, check=None, rest_lead=None,
                         shape=True, progress=None):
    """Compensator and drive of a reference on an actuator: what ``hammerstein compensate`` writes.

    The command's route from Python: the kind chosen for the model when
    none is given (:func:`hammerstein.compensation.kind_choice.choose_kind`
    says which and why), the compensator built from the actuator
    as the command builds it (its creep inverted with G), and the drive of
    :func:`hammerstein.compensation.drive.hardware_drive`: faded in from the
    model's output at 0 V over a duration, shaped into limits measured on
    the records, with the notes the command prints (modes amplifying a
    harmonic, the reach, the first sample).

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (its hysteresis model of any class, dynamics, creep and
        amplifier are the model).
    reference : array_like, shape (p, n_samples)
        The reference [µm], sampled at the actuator's sampling period.
    period_samples : int, optional
        Its period [samples] when it repeats (the continuation past its end,
        the default fade-in).
    kind : str, optional
        Compensator kind (default: :func:`hammerstein.compensation.kind_choice.choose_kind`).
    inversion : {'zpetc', 'stable'}
    fade_in : float, optional
        [s]; 0 only for a reference that starts at rest.
    limits : {'error', 'warn', 'clip'}
    gain : str or array_like, optional
        K of the inverse multiplicative law (default: the kind's, or the
        convergent gain of the default kind).
    check : {'error', 'warn', 'ignore'}, optional
        The law's convergence check (default the kind's, ``error``).
    rest_lead : int, optional
        With ``fade_in``: its first samples at rest [samples] (a drive file's, for ``learn``).
    shape : bool
        Shape the reference into the limits measured on the records (default); False
        shapes only the drive (:func:`hammerstein.compensation.drive.hardware_drive`).
    progress : callable, optional
        ``progress(line)`` as each pass of the compensator over the reference starts
        (:func:`hammerstein.compensation.drive.hardware_drive`).

    Returns
    -------
    comp : object
        The compensator.
    drive : hammerstein.compensation.drive.DriveResult
        Its ``notes`` name a harmonic of a periodic reference that the
        identified dynamics amplify at least twice over their static gain
        (:func:`hammerstein.compensation.shaping.mode_note`); its
        ``kind_note`` says which kind (and gain of the law) was taken and
        why, when the caller did not name both.

    Raises
    ------
    CompensatorError
        A kind that does not work with the model (naming those that do),
        ``fade_in = 0`` for a reference that does not start at rest, or a
        reference not of shape (n_outputs, n_samples) (a transposed record);
        ``period_samples`` not a whole number from 1 to n_samples, ``fade_in``
        negative or not finite, ``limits`` not one of the three.

    Examples
    --------
    >>> import numpy as np
    >>> import hammerstein as hs
    >>> plant = hs.load_plant("rakotondrabe-2dof")
    >>> _, r = hs.circle(plant.sampling_period, radius=20.0, frequency=50.0, periods=10)
    >>> comp, drive = hs.compensate_reference(plant, r, period_samples=400)
    >>> drive.inputs.shape, float(np.abs(drive.inputs[:, 0]).max()) < 1e-9
    ((2, 4000), True)
    """
    try:
        signal = np.atleast_2d(np.asarray(reference, dtype=float))
    except (TypeError, ValueError):
        raise CompensatorError("reference: expected numbers [µm]") from None
    p = plant.hysteresis.n_outputs      # the message drive_signal gives (a transposed record)
    if signal.ndim != 2 or signal.shape[1] < 1 or signal.shape[0] != p:
        raise CompensatorError(f"reference: expected shape ({p}, n_samples), one row per output "
                               f"[µm], found {np.shape(reference)}")
    _check_arguments(period_samples, fade_in, limits, signal.shape[1])
    kind, options, kind_note = _kind_and_options(plant, kind, gain, check, inversion)
    spec = {"kind": kind, "model": "plant", **options}
    if kind == "hammerstein":
        spec["inversion"] = inversion
        spec["creep"] = "plant"        # the actuator's creep (e.g. identified) is inverted with G
    comp = build_compensator(spec, plant, Path.cwd())
    drive = start_drive(plant, comp, signal, period_samples, fade_in, limits, rest_lead, shape,
                        progress)
    drive.kind_note = kind_note.removeprefix("note: ") if kind_note else None
    problem = unfollowed_problem(plant, drive)
    if problem:
        raise CompensatorError(problem)
    miss = model_miss(plant, drive, period_samples, kind)
    if miss is not None:
        if miss[0] > MISS_REFUSE and limits == "error":
            cause = f"{drive.reach}; " if drive.reach else ""
            raise CompensatorError(f"nothing written: {cause}{miss[1]} (--limits warn writes it "
                                   f"with this note)")
        drive.notes.append(miss[1])
    T, linear = plant.sampling_period, plant.matrices
    note = drive.reach
    if note:
        drive.notes.append(note)
    note = mode_note(linear, T, drive.reference, period_samples)
    if note:
        drive.notes.append(note)
    zeros = _zpetc_zeros(comp)
    note = None if zeros is None else zpetc_note(zeros, T, drive.reference,
                                                 period_samples)
    if note:
        drive.notes.append(note)
    note = _first_sample_note(plant, drive, inversion if kind == "hammerstein" else None)
    if note:
        drive.notes.append(note)
    note = extrapolation_note(plant, drive.inputs)
    if note:
        drive.notes.append(note)
    return comp, drive


def extrapolation_note(plant, inputs):
    """The note when a drive leaves the inputs the model was identified on, or None.

    Without an amplifier (a bundled preset, a model file) nothing keeps the
    drive within the model's inputs: ``compensate rakotondrabe-2dof`` on a
    300 µm circle wrote peaks of 31 and 39 V for a model identified within
    ±10 V, without a word, where the model (and so the drive) extrapolates.
    The inputs are the records' range when known (``input_range``), else
    ``input_centre ± input_amplitude``.

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (its ``amplifier``: with one, the drive is kept in its range).
    inputs : array_like, shape (m, n_samples)
        The drive [V].

    Returns
    -------
    str or None
    """
    model = plant.hysteresis
    amp = getattr(model, "input_amplitude", None)
    if getattr(plant, "amplifier", None) is not None or amp is None:
        return None
    u = np.asarray(inputs, dtype=float)
    span = getattr(model, "input_range", None)
    if span is not None:
        lo, hi = np.asarray(span, dtype=float)[:, 0], np.asarray(span, dtype=float)[:, 1]
    else:
        centre = getattr(model, "input_centre", None)
        centre = np.zeros(u.shape[0]) if centre is None else np.asarray(centre, dtype=float)
        lo, hi = centre - np.asarray(amp, dtype=float), centre + np.asarray(amp, dtype=float)
    tol = 1e-6 * np.maximum(hi - lo, 1e-300)
    beyond = [k for k in range(u.shape[0])
              if u[k].min() < lo[k] - tol[k] or u[k].max() > hi[k] + tol[k]]
    if not beyond:
        return None
    names = list(getattr(model, "input_names", [f"u{k}" for k in range(u.shape[0])]))
    unit = plant_units(plant)[0]          # the model's input unit
    said = ", ".join(f"{names[k]} {u[k].min():.4g}..{u[k].max():.4g} {unit} against "
                     f"{lo[k]:.4g}..{hi[k]:.4g} {unit}" for k in beyond)
    return (f"the drive leaves the inputs the model was identified on ({said}): there the model, "
            f"and with it the drive, extrapolates; no amplifier limits it (a preset's [amplifier] "
            f"range, or export's --amplifier-range), so check it against your amplifier, or "
            f"give a smaller reference")


def _check_arguments(period_samples, fade_in, limits, n):
    """Refuse what :func:`compensate_reference` cannot take, naming the argument.

    An outside check passed ``period_samples`` of 0, -5, 100.5, True and 1e9
    (silently taken as none, or a fade-in over the whole record), ``fade_in``
    of -1 (no fade) and NaN (a bare ``ValueError`` deep inside) and
    ``limits="bogus"`` (taken as ``"error"``).
    """
    if period_samples is not None and (
            isinstance(period_samples, (bool, np.bool_))
            or not isinstance(period_samples, (int, np.integer))
            or not 1 <= period_samples <= n):
        raise CompensatorError(f"period_samples: expected None or a whole number of samples "
                               f"from 1 to the reference's {n}, found {period_samples!r}")
    if fade_in is not None and (isinstance(fade_in, (bool, np.bool_))
                                or not isinstance(fade_in, (int, float, np.integer, np.floating))
                                or not np.isfinite(fade_in) or fade_in < 0):
        raise CompensatorError(f"fade_in: expected None or a duration >= 0 [s], found "
                               f"{fade_in!r}")
    if limits not in ("error", "warn", "clip"):
        raise CompensatorError(f"limits: expected one of 'error', 'warn', 'clip', found "
                               f"{limits!r}")


def start_drive(plant, comp, reference, period_samples=None, fade_in=None, limits="error",
                rest_lead=None, shape=True, progress=None, key="--fade-in"):
    """The drive of a built compensator as ``hammerstein compensate`` writes it (and the scenarios
    on a :func:`~hammerstein.models.plant.hardware_start` plant run it).

    The reference is faded in from the compensator's rest output
    (:func:`hammerstein.compensation.drive.compensator_rest`, the model's
    output at 0 V) over ``fade_in`` or the default duration, and the drive
    is shaped into the amplifier's limits
    (:func:`hammerstein.compensation.drive.hardware_drive`); the reach of a
    reference beyond the amplifier's range is added to its refusal.

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (hysteresis model, dynamics, creep, amplifier).
    comp : object
        The compensator (any kind).
    reference : array_like, shape (p, n_samples)
        [µm], sampled at the plant's sampling period.
    period_samples : int, optional
        Its period [samples] (None or 1: not periodic).
    fade_in : float, optional
        [s]; None: the default duration; 0 only for a reference that starts at rest.
    limits : {'error', 'warn', 'clip'}
    rest_lead : int, optional
        With ``fade_in``: its first samples at rest [samples].
    shape : bool
        Shape the reference into limits measured on the records (default).
    progress : callable, optional
        ``progress(line)`` as each pass over the reference starts.
    key : str
        The fade-in's name in the messages (a scenario's ``compensator.fade_in``).

    Returns
    -------
    hammerstein.compensation.drive.DriveResult
        ``inputs`` the drive [V], shape (m, n_samples), ``fade_samples`` its fade-in [samples].

    Raises
    ------
    CompensatorError
        ``fade_in`` longer than the reference, or 0 for a reference that does not start at rest.
    AmplifierError
        ``limits = "error"`` and the amplifier's own limits exceeded.
    CompensatorDivergence
        When the compensator diverges.
    """
    signal = np.atleast_2d(np.asarray(reference, dtype=float))
    n = signal.shape[1]
    if fade_in is not None and fade_in / plant.sampling_period > n:
        raise CompensatorError(
            f"{key}: {fade_in:g} s is longer than the reference ({n} samples, "
            f"{n * plant.sampling_period:g} s); expected at most {n * plant.sampling_period:g} s")
    fade = None if fade_in is None else int(round(fade_in / plant.sampling_period))
    rest = compensator_rest(plant.hysteresis, comp)
    if fade == 0 and not starts_at_rest(signal, rest, REST_TOLERANCE):
        names = plant.hysteresis.output_names
        unit_in, unit_out = plant.units      # the model's
        first = ", ".join(f"{n} = {v:.7g} {unit_out}" for n, v in zip(names, signal[:, 0]))
        at = ", ".join(f"{n} = {v:.7g} {unit_out}" for n, v in zip(names, rest))
        raise CompensatorError(
            f"{key} 0: the reference starts at {first}, not at rest ({at}: the model's "
            f"output at 0 {unit_in}, within {REST_TOLERANCE:g} {unit_out}); the drive would start "
            f"with a step "
            f"that the actuator (and the exported C, which starts there) cannot follow: give a "
            f"fade-in > 0 (the default: a duration, at least one period, {MIN_FADE_S:g} s and "
            f"{FADE_DECAYS:g} decay times of the slowest bending mode) or a reference that "
            f"starts at rest")
    T = plant.sampling_period

    at_rest = plant.rest_state()         # the actuator before the drive: settled at 0 V

    def predict(u):
        return plant.simulate(apply_amplifier(plant.amplifier, u, T), at_rest)[0]

    linear = plant.matrices              # creep then dynamics, built once
    names, unit_out = plant.hysteresis.output_names, plant.units[1]
    box = output_reach(plant.hysteresis, plant.amplifier, plant.creep)
    reach = reach_note(box, signal, names, unit_out)
    try:
        drive = hardware_drive(comp, signal, T, period_samples, fade,
                               plant.amplifier, limits, rest=rest,
                               first_mode=first_mode_hz(linear[0], T), predict=predict,
                               names=plant.hysteresis.output_names,
                               mode_decay=mode_decay_s(linear[0], T),
                               rest_lead=rest_lead, shape=shape,
                               input_names=list(plant.hysteresis.input_names),
                               progress=progress, input_unit=plant.units[0],
                               output_unit=plant.units[1])
    except AmplifierError as exc:
        if reach and "beyond the amplifier's range" in str(exc):
            # "lower the reference" alone: by how much, and where it fits, is the reach's
            raise AmplifierError(f"{exc}; {reach}") from None
        raise
    if reach and np.shape(signal)[-1] <= SCALE_MAX_SAMPLES:
        # the reach is a box per output; the outputs reached together are fewer (a 50 µm
        # circle centred in a 100 µm tall box held vy at 100 V on 10 % of its samples): the
        # size that fits about the centre advised is the compensator's, measured
        def inputs_of(ref):
            try:
                with warnings.catch_warnings():      # a trial's range warnings: not the reference's
                    warnings.simplefilter("ignore")
                    return drive_signal(comp, ref, T, period_samples, drive.fade_samples).inputs
            except (CompensatorError, CompensatorDivergence):
                return None              # no drive at that size: it does not fit
        scale = fitting_scale(inputs_of, signal, reach_centre(box, signal), plant.amplifier,
                              drive.fade_samples, rest)
        reach = reach_note(box, signal, names, unit_out, scale)
    drive.reach = reach            # the reach's note (None: within it), for compensate's notes
    return drive


def compensator_plant(plant, comp):
    """The actuator as a compensator models it: what ``compensate`` computes its drive on.

    A scenario's drive is the one ``hammerstein compensate`` writes from the
    compensator's model; the scenario's plant is only what it is played on. The
    drive's fade starts at that model's rest output and lasts for its modes'
    decay, and its shaping predicts that model's outputs, so
    :func:`start_drive` runs on this plant: the compensator's hysteresis model
    (its ``actuator_model`` where it inverts a part of it, else its ``model``),
    with, for a Hammerstein compensator, the G and creep it
    inverts, and otherwise the plant's linear part; the plant's amplifier (the
    scenario's hardware). A compensator identified with ``model =
    "generalized"`` on a Preisach plant faded in from the plant's rest output,
    -2.896 µm over 706 samples, instead of its own, -2.857 µm over 721 (drives
    0.245 V apart from ``compensate``'s on the identified preset).

    Parameters
    ----------
    plant : HammersteinPlant
        The scenario's plant (sampling period, amplifier).
    comp : object
        The compensator (any kind).

    Returns
    -------
    HammersteinPlant
        ``plant`` itself when the compensator's model is the plant's (or it has
        none of the plant's size), else a new plant.
    """
    # the whole model (per-axis and diagonal kinds invert only its diagonal: a fade from the
    # diagonal's rest output put the drive 0.045 V off compensate's)
    model = getattr(comp, "actuator_model", None) or getattr(comp, "model", None)
    hyst = plant.hysteresis
    if model is None or list(getattr(model, "input_names", ())) != list(hyst.input_names) \
            or list(getattr(model, "output_names", ())) != list(hyst.output_names):
        model = hyst
    if hasattr(comp, "bending_dynamics"):      # a Hammerstein compensator: its G and creep
        dynamics, creep = comp.bending_dynamics, comp.creep
    else:
        dynamics, creep = plant._dynamics, plant.creep
    if model is hyst and dynamics is plant._dynamics and creep is plant.creep:
        return plant
    out = HammersteinPlant(model, plant.sampling_period, dynamics, name=f"{plant.name} (model)",
                           creep=creep)
    out.amplifier, out.units = plant.amplifier, plant.units    # the scenario's, in its units
    return out


def _first_sample_note(plant, drive, inversion):
    """A note when the compensator's first sample is not the rest voltage (beyond
    :data:`FIRST_SAMPLE_TOLERANCE`), before the drive's taper faded it in, or None."""
    off = getattr(drive, "start_offset", None)
    tapered = off is not None
    if off is None:
        off = np.asarray(drive.inputs, dtype=float)[:, 0] - _rest_voltages(plant)
    if np.max(np.abs(off)) <= FIRST_SAMPLE_TOLERANCE:
        return None
    why = ("the stable inversion's anti-causal part, G's zeros outside the unit circle, starts "
           "acting before the reference moves and had not decayed over the fade's rest lead (a "
           "zero near the unit circle decays slowly: the default fade-in lengthens its rest "
           "lead up to a quarter of the record; a longer record, or a longer --fade-in, gives "
           "it room)"
           if inversion == "stable" else
           "the inverse's start at rest, within its tolerance")
    unit = plant_units(plant)[0]          # the model's input unit
    return (("the compensator's first sample was " if tapered else
             "the drive's first sample is ") + ", ".join(
        f"{n} {v:+.3g} {unit}" for n, v in zip(plant.hysteresis.input_names, off))
            + f" from rest: {why}" + (_taper_words(drive, unit) if tapered else ""))


def _taper_words(drive, unit="V"):
    """What the taper of a stable inversion's pre-actuation changed, for the note: the
    drive against the compensator's voltages (and the exported C's) over the rest lead,
    in ``unit`` (the model's input unit)."""
    # the first sample alone understated it: 2e-9 V named where the drive and the C then
    # differed by 1e-2 V, the pre-actuation growing over the lead towards the motion
    change = getattr(drive, "taper_change", None)
    lead = getattr(drive, "rest_lead", None) or getattr(drive, "fade_samples", 0) // 10
    return ("; the drive fades it in from rest over the fade's rest lead"
            + (f" ({lead} samples)" if lead else "")
            + (f", where it differs from the compensator's voltages by up to {change:.3g} {unit}"
               if change is not None else "")
            + ": the exported C, which does not fade them, gives the compensator's there")


def plant_units(plant):
    """The units in which the notes and problems give an actuator's voltages and outputs.

    Parameters
    ----------
    plant : HammersteinPlant or object
        The actuator (its ``units``, a preset's ``[model] input_unit`` and ``output_unit``).

    Returns
    -------
    tuple of str
        ``(input unit, output unit)``; ``("V", "µm")`` for an object without ``units``.
    """
    return tuple(getattr(plant, "units", ("V", "µm")))


def _rest_voltages(plant):
    """Each input's rest voltage [V]: the amplifier's, 0 without one."""
    return (np.zeros(plant.hysteresis.n_inputs) if plant.amplifier is None
            else plant.amplifier.rest_voltages())


def _zpetc_zeros(comp):
    """The zeros of G a Hammerstein compensator's ZPETC inverse approximates, or None."""
    return getattr(getattr(comp, "inverse", None), "unacceptable_zeros", None)


def _kind_and_options(plant, kind, gain, check, inversion="zpetc"):
    """(kind, options of the kind, the note of a chosen kind or None).

    A given kind is checked against the model's class (the message names the
    kinds that work); none given: :func:`hammerstein.compensation.kind_choice.choose_kind`.
    """
    note = None
    # bending modes G, not only creep: a preset with creep and no [dynamics] made the default
    # kind hammerstein, which then failed for want of a G ("the plant is static")
    has_dynamics = getattr(plant, "dynamics", None) is not None
    if kind is None:
        choice = choose_kind(plant.hysteresis, has_dynamics, gain, inversion or "zpetc", check,
                             plant_units(plant))
        kind, options, note = choice.kind, dict(choice.options), choice.note()
        if not has_dynamics:
            # a model from 1 Hz records drove a 20 Hz sine without a word on what it ignores
            note += ("; without dynamics the drive is right only well below the actuator's "
                     "first bending mode, which the model does not know (identify --dynamics "
                     "with the excitation's multisines identifies it)")
        if not has_dynamics and getattr(plant, "creep", None) is not None:
            note += ("; its creep is not inverted: the Hammerstein compensator inverts creep "
                     "with identified dynamics (identify --dynamics)")
    else:
        problem = kind_problem(plant.hysteresis, kind, has_dynamics)
        if problem:
            raise CompensatorError(problem)
        options, note = explicit_law(plant.hysteresis, kind, gain, check, plant_units(plant))
    entry = model_class(plant.hysteresis)
    # kind hammerstein runs the law over a classical PI only; over a Preisach or generalised-PI
    # model it inverts exactly per sample, and --gain identity was ignored without a word
    exact = kind == "hammerstein" and entry.exact_inverse_kind is not None
    if kind in LAW_KINDS and not exact:
        if gain is not None:
            options["gain"] = gain
        if check is not None:
            options["check"] = check
    elif gain is not None or check is not None:
        what = (f"kind {kind!r} over a {entry.label} model inverts it exactly per sample, without "
                f"the inverse multiplicative law" if exact else
                f"kind {kind!r} has no inverse multiplicative law")
        among = [k for k in LAW_KINDS if k != "hammerstein" or entry.exact_inverse_kind is None]
        raise CompensatorError(f"--gain/--check: {what} (they apply to {', '.join(among)})")
    return kind, options, note


def unfollowed_problem(plant, drive):
    """Why a drive follows nothing of its reference, or None.

    When the compensator's voltages (before any limit) leave the amplifier's
    range by more than 1 % of its span on more than
    :data:`UNFOLLOWED_SHARE` of the samples after the fade-in, the limits
    leave a drive that does not follow the reference: the model cannot give
    that reference, or the compensator's inverse does not solve it.

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator (its ``amplifier``; None: no check).
    drive : hammerstein.compensation.drive.DriveResult
        Its ``commanded`` voltages [V] and ``fade_samples``.

    Returns
    -------
    str or None
    """
    amp = plant.amplifier
    if amp is None:
        return None
    u = np.asarray(drive.commanded, dtype=float)[:, int(drive.fade_samples):]
    if u.shape[1] == 0:
        return None
    names = list(amp.inputs)
    worst = None
    for name, c, row in zip(names, amp.channels, u):
        span = c.high - c.low
        out = (row > c.high + 0.01 * span) | (row < c.low - 0.01 * span) | ~np.isfinite(row)
        share = float(np.mean(out))
        if share > UNFOLLOWED_SHARE and (worst is None or share > worst[1]):
            far = np.nanmax(np.maximum(row - c.high, c.low - row))
            worst = (name, share, far, c)
    if worst is None:
        return None
    name, share, far, c = worst
    unit = plant_units(plant)[0]          # the model's input unit
    text = (f"the compensator asks for {name} beyond the range [{c.low:g}, {c.high:g}] {unit} on "
            f"{100 * share:.3g} % of the samples after the fade-in (by up to {far:.4g} {unit}): the "
            f"limits would write a drive that does not follow the reference. The model cannot "
            f"give this reference within the range, or the compensator cannot solve it")
    # (an exact inverse whose sweeps over the direct paths cannot solve the model is refused
    # before any drive, naming the direct and cross gains: PreisachInverseCompensator)
    return text + ": make the reference smaller or move its center within what the model reaches"


#: Kinds that leave part of the model out by design: what they leave, for the miss note.
PARTIAL_KINDS = {"per-axis": "the model's cross-couplings", "diagonal": "the model's cross-couplings",
                 "static-gain": "the model's hysteresis and cross-couplings"}


def model_miss(plant, drive, period_samples=None, kind=None):
    """How far the drive, played through the model it was computed from, misses its reference.

    The drive (through the amplifier's limits) is simulated on the plant
    from rest, and the Euclidean distance over the outputs to the reference
    the drive follows (``drive.reference``, shaped) is taken after the
    fade-in, at its :data:`MISS_QUANTILE` quantile, in shares of the
    reference's largest half-span there. A compensator built on the model
    misses it by its own approximation only (an exact inverse by its
    tolerance); beyond :data:`MISS_WARNING`, the drive does not solve the
    model: an inverse held on its input bounds (the reference, through the
    identified dynamics, asks more than the range), or a law that does not
    converge.

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator the compensator was built from.
    drive : hammerstein.compensation.drive.DriveResult
        Its ``inputs`` [V], ``reference`` [µm] and ``fade_samples``.
    period_samples : int, optional
        The reference's period [samples]: the dynamics' gain at its main
        frequency is named when below :data:`MISS_ATTENUATION`.
    kind : str, optional
        The compensator's kind: one of :data:`PARTIAL_KINDS` misses by what it
        leaves out, which the note names instead of advising a smaller reference.

    Returns
    -------
    tuple of (float, str) or None
        The median miss as a share of the half-span (above
        :data:`MISS_REFUSE`, the drive follows nothing) and a line saying
        where and why; None when the :data:`MISS_QUANTILE` quantile is
        below :data:`MISS_WARNING`, or for a reference that does not move
        after the fade-in.
    """
    ref = np.asarray(drive.reference, dtype=float)
    F = int(drive.fade_samples)
    if ref.ndim != 2 or ref.shape[1] - F < 2:
        return None
    half = 0.5 * np.ptp(ref[:, F:], axis=1)
    scale = float(half.max())
    if not scale > 0 or not np.isfinite(scale):
        return None
    T = plant.sampling_period
    u = apply_amplifier(plant.amplifier, drive.inputs, T)
    y, _ = plant.simulate(u, plant.rest_state())
    miss = np.sqrt(np.sum((np.asarray(y, dtype=float)[:, F:] - ref[:, F:]) ** 2, axis=0))
    share = float(np.quantile(miss, MISS_QUANTILE)) / scale
    if not share > MISS_WARNING:        # NaN (a diverged model) is named by the limits
        return None
    median = float(np.median(miss)) / scale
    unit_in, unit_out = plant_units(plant)          # the model's
    text = (f"the drive, played through the model it was computed from, misses the reference "
            f"by more than {share * scale:.3g} {unit_out} ({100 * share:.3g} % of its half-span) "
            f"on {100 * (1 - MISS_QUANTILE):.3g} % of the samples after the fade-in and by "
            f"{median * scale:.3g} {unit_out} on half of them: the compensator does not solve the "
            f"model there")
    amp = plant.amplifier
    if amp is not None:
        held = []
        for name, c, row in zip(amp.inputs, amp.channels, np.asarray(u, dtype=float)[:, F:]):
            tol = 1e-6 * (c.high - c.low)
            on = float(np.mean((row <= c.low + tol) | (row >= c.high - tol)))
            if on > 0.05:
                held.append(f"{name} {100 * on:.3g} %")
        if held:
            text += (f"; the drive sits on the range's bounds [{unit_in}] ({', '.join(held)} of the "
                     f"samples): the reference asks more than the range gives")
    f0 = main_frequency(ref[:, F:], period_samples, T)
    gain = _dynamics_gain(plant.matrices, T, f0) if f0 else None
    if gain is not None and gain < MISS_ATTENUATION:
        text += (f"; the identified dynamics pass the reference's {f0:.4g} Hz at {gain:.2g} of "
                 f"their static gain, so the drive needs {1 / gain:.3g} times the voltages: "
                 f"check the dynamics identify fitted (their held-out fit, their modes) or "
                 f"lower the frequency")
    elif kind is not None and kind != "hammerstein" and (kind in PARTIAL_KINDS
                                                          or not plant.is_static):
        # a smaller or slower reference does not help these (an outside stage's per-axis drive
        # missed a 5 µm 5 Hz circle by 12.5 %, a 20 µm 50 Hz one by 11.8 %); nor do they invert
        # the dynamics and the creep (an identified stage's 30 µm 100 Hz circle, a mode at
        # 311 Hz, missed by 17.6 %, blamed on the couplings alone), which no kind but
        # hammerstein inverts (an outside stage's multivariable drive missed by 12.5 % and
        # was told the law does not solve the model: 0.6 % through its hysteresis alone)
        left = [PARTIAL_KINDS[kind]] if kind in PARTIAL_KINDS else []
        if getattr(plant, "sampled_dynamics", None) is not None:   # (is_static counts creep too)
            left.append("the model's linear dynamics (bending modes, lags)")
        if any(c is not None for c in (getattr(plant, "creep", None) or [])):
            left.append("the creep")
        said = left[0] if len(left) == 1 else ", ".join(left[:-1]) + " and " + left[-1]
        text = text.replace("the compensator does not solve the model there",
                            f"kind {kind!r} leaves out {said} by design")
        if not plant.is_static:
            static = HammersteinPlant(plant.hysteresis, T)
            ys, _ = static.simulate(u, static.rest_state())
            alone = np.sqrt(np.sum((np.asarray(ys, dtype=float)[:, F:] - ref[:, F:]) ** 2,
                                   axis=0))
            text += (f" (through the hysteresis model alone the drive misses by "
                     f"{100 * float(np.quantile(alone, MISS_QUANTILE)) / scale:.3g} % on "
                     f"{100 * (1 - MISS_QUANTILE):.3g} % of the samples)")
        if kind in PARTIAL_KINDS and len(left) == 1:
            text += ("; the multivariable law or the default kind (--kind left out) "
                     "compensate them")
        elif getattr(plant, "sampled_dynamics", None) is not None:
            text += "; the default kind (--kind left out) compensates them all"
        else:       # creep without dynamics: the default kind is one of these (a reviewer's)
            text += ("; no kind inverts creep without the dynamics: kind hammerstein inverts "
                     "it with the G that identify --dynamics identifies from the "
                     "excitation's multisines")
    else:
        text += "; make the reference smaller or slower, or look at it with --predicted"
    return median, text


def _dynamics_gain(matrices, sampling_period, frequency_hz):
    """Smallest singular value of ``G(z) G(1)^-1`` at ``frequency_hz``, or None (static, singular)."""
    if np.asarray(matrices[0]).size == 0:
        return None
    try:
        ratio = relative_response(matrices, sampling_period, [frequency_hz])[0]
    except np.linalg.LinAlgError:
        return None
    return float(np.linalg.svd(ratio, compute_uv=False).min())
