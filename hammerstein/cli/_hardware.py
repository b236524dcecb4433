"""Shared parts of the hardware-loop commands (``compensate``, ``evaluate``, ``learn``).

The actuator file (a preset or a model file), the reference (an inline TOML
table as in scenarios, or a CSV file), column mappings and the drive file's
ownership check.
"""

from __future__ import annotations

import argparse
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np

from hammerstein.cli._common import add_column_options, is_drive_file, number_type
from hammerstein.core.files import PROVENANCE, carries_provenance, escape
from hammerstein.compensation.drive import read_signals
from hammerstein.compensation.drive_size import DRIVE_MARK, drive_changed
from hammerstein.models.amplifier import amplifier_from_table
from hammerstein.core.numbers import magnitude_problem, plausibility_problem
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.models.plant import HammersteinPlant
from hammerstein.io.presets import (load_creep, load_dynamics, load_model, load_plant, read_toml,
                                    records_sampling_period, resolve_preset)
from hammerstein.identification.identification_pipeline import (DYNAMICS_FIT_WARN_PERCENT,
                                                                 STATIC_GAIN_WARN)
from hammerstein.exceptions import DataFileError, HammersteinError, PresetError, RangeWarning
from hammerstein.io.unit_checks import unit_scale
from hammerstein.scenario.hardware_route import plant_units
from hammerstein.scenario.validate import _signal

__all__ = ["Reference", "dynamics_problem", "load_actuator", "load_reference", "check_reference_first", "mapping",
           "owned_problem",
           "add_actuator_arguments", "positive_float", "START_NOTE", "end_note"]

#: The drive files' header line on the state a drive starts from.
START_NOTE = ("from rest, demagnetised (the model's initial state): play the excitation's "
              "demagnetise.csv just before it")


def end_note(inputs, sampling_period, names, amplifier=None, unit="V"):
    """The drive file's line on how its last sample goes back to rest.

    A drive ends where its reference ends (a circle mid-turn): stopping the
    DAC there is a step. The line gives the last voltages and the shortest
    ramp to rest that steps no faster than the drive itself (its largest
    slew, or the amplifier's slew rate when lower); a drive whose last
    voltages are the rest voltages (0 V, or a unipolar range's end) is said
    to end at rest.

    Parameters
    ----------
    inputs : numpy.ndarray, shape (m, n_samples)
        The drive [``unit``].
    sampling_period : float
        T [s].
    names : list of str
        Input names.
    amplifier : hammerstein.models.amplifier.Amplifier, optional
    unit : str
        The drive's unit, the model's input unit (``HammersteinPlant.units[0]``), in which
        the line gives the last sample.

    Returns
    -------
    str
    """
    u = np.asarray(inputs, dtype=float)
    last = u[:, -1]
    rest = amplifier.rest_voltages() if amplifier is not None else np.zeros(u.shape[0])
    slew = np.max(np.abs(np.diff(u, axis=1)), axis=1) / sampling_period if u.shape[1] > 1 \
        else np.ones(u.shape[0])
    if amplifier is not None:
        rates = np.array([c.slew_rate for c in amplifier.channels], dtype=float)
        slew = np.minimum(slew, np.where(np.isfinite(rates), rates, np.inf))
    ramp = float(np.max(np.abs(last - rest) / np.maximum(slew, 1e-12)))
    at = ", ".join(f"{n} {v:.4g} {unit}" for n, v in zip(names, last))
    if np.all(np.abs(last - rest) <= 1e-9 * np.maximum(1.0, np.abs(rest))):
        # a unipolar stage's drive ending on 0 V: already where the amplifier rests
        return f"ends at {at}, every input at rest: nothing to ramp"
    return (f"ends at {at} (the reference's last sample, not at rest): hold it, then ramp every "
            f"input to rest in {max(ramp, sampling_period):.3g} s or more (no faster than the "
            f"drive's own largest slew), never a step")


class Reference:
    """A reference record: ``t`` (N,) [s], ``signal`` (p, N) [µm], ``period_samples``,
    ``scale`` (radius / amplitude [µm] or None), ``spec`` (the inline table or None),
    ``kind`` (e.g. ``"circle"``, ``"file"``), ``notes`` (lines saying how a CSV file at
    another rate was resampled)."""

    def __init__(self, t, signal, period_samples=1, scale=None, spec=None, kind="file",
                 loop_channel=None, notes=()):
        self.t, self.signal, self.period_samples = t, signal, int(period_samples)
        self.scale, self.spec, self.kind, self.loop_channel = scale, spec, kind, loop_channel
        self.notes = list(notes)


def positive_float(text):
    """argparse type: a positive, finite, normal number (``5e-324`` and ``nan`` refused)."""
    return _POSITIVE(text)


def nonnegative_float(text):
    """argparse type: a finite number >= 0 (a subnormal refused)."""
    return _NONNEGATIVE(text)


def settle_periods(text):
    """argparse type: periods left out of the metrics, a finite number in [0, MAX_SETTLE].

    ``1e308`` periods, counted in samples, overflowed an integer; no record
    holds a billion periods.
    """
    return _SETTLE(text)


#: Largest ``--settle-periods`` accepted.
MAX_SETTLE = 1e9
_POSITIVE = number_type(0, low_open=True)
_NONNEGATIVE = number_type(0)
_SETTLE = number_type(0, MAX_SETTLE)


def fraction(text):
    """argparse type: a finite number in [0, 1]."""
    v = nonnegative_float(text)
    if v > 1:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], found {text!r}")
    return v


def mapping(text, names, option):
    """``"x=X_meas,y=Y_meas"`` -> ``{"x": "X_meas", ...}``; a bare list renames in order.

    Raises
    ------
    DataFileError
        A name that is not one of ``names``.
    """
    if not text:
        return {}
    out = {}
    items = [s.strip() for s in text.split(",") if s.strip()]
    for i, item in enumerate(items):
        if "=" in item:
            k, v = (s.strip() for s in item.split("=", 1))
        elif i < len(names):
            k, v = names[i], item
        else:
            raise DataFileError(f"{option}: more columns than the model's {len(names)} "
                                f"({', '.join(names)})")
        if k not in names:
            raise DataFileError(f"{option}: {k!r} is not one of the model's names "
                                f"({', '.join(names)})")
        out[k] = v
    return out


def load_actuator(path, sampling_period=None):
    """The plant of a preset (PI + dynamics + amplifier) or of a model file (static PI).

    Parameters
    ----------
    path : str
        Preset name or file, or model file.
    sampling_period : float, optional
        T [s]; for a model file without ``[preset]``, the sampling period of
        the records it was identified from (``[identification]
        sampling_period_s``) when not given and they all agree; for a preset,
        its dynamics are sampled again at T when it differs (its creep lags
        and amplifier kept, its measurement delay converted to samples of T).

    Returns
    -------
    HammersteinPlant
        With ``amplifier`` (None when the file has none) and
        ``measurement_delay`` [samples]: the ``[identification]
        measurement_delay_samples`` of a file written by ``identify --delay``,
        else None; ``delay_problem``: why ``identify --dynamics`` left its
        own estimate unused (the file's ``measurement_delay_estimate``), else
        None.

    Raises
    ------
    PresetError
        Also for a ``measurement_delay_samples`` that is not an integer >= 0.
    """
    p = Path(path)
    data = read_toml(p, "model file") if p.suffix == ".toml" or p.exists() else None
    scale = 1.0                 # the file's sampling period over the plant's
    if data is None or "preset" in data:
        plant = load_plant(path)
        if sampling_period is not None and not np.isclose(sampling_period, plant.sampling_period):
            scale = plant.sampling_period / float(sampling_period)
            dyn = None if plant.is_static else load_dynamics(
                resolve_preset(path), plant.hysteresis.output_names, sampling_period)
            amp, units = plant.amplifier, plant.units
            plant = HammersteinPlant(plant.hysteresis, float(sampling_period), dyn, plant.name,
                                     creep=plant.creep)     # the creep's lags are continuous
            plant.amplifier, plant.units = amp, units
    else:
        if sampling_period is None:
            sampling_period = records_sampling_period(data, path)
        model = load_model(p)
        dyn = load_dynamics(p, model.output_names, sampling_period) if "dynamics" in data else None
        # the file's creep and units, as load_plant reads a preset's (a model identified with
        # --creep-records but no --dynamics lost its creep here, and one in nm or mV had its
        # drive's header, notes and shaped columns labelled µm and V)
        plant = HammersteinPlant(model, float(sampling_period), dyn, p.stem,
                                 creep=load_creep(p, model.output_names) if "creep" in data else None)
        plant.units = _file_units(data)
        if "amplifier" in data:
            plant.amplifier = amplifier_from_table(data["amplifier"], model.input_names, str(p))
    problem = falling_direct_transfer(plant.hysteresis)
    if problem:
        raise PresetError(f"{path}: {problem}")
    delay = _measurement_delay(data, path)
    plant.measurement_delay = None if delay is None else int(round(delay * scale))
    plant.delay_problem = _delay_problem(data)
    plant.dynamics_problem = dynamics_problem(data, path) if not plant.is_static else None
    plant.identify_misfit = identify_misfit(data)
    return plant


def identify_misfit(data):
    """What the model file's identification says the model missed in its own records, or None.

    Read from ``[identification.dynamics]``: a held-out broadband fit below
    :data:`~hammerstein.identification.identification_pipeline.DYNAMICS_FIT_WARN_PERCENT`,
    and a G(0) fitted without the unit-gain constraint (``dc_gain_unconstrained``)
    more than :data:`~hammerstein.identification.identification_pipeline.STATIC_GAIN_WARN`
    from the identity: the hysteresis model's gain on the multisines is not the
    records' (``identify`` warned of both). A measured response's gain against such a
    model is off from the first trial, on an actuator that did not change (a Bouc-Wen
    stage outside the model classes read 1.06-1.08 at 100-200 Hz).

    Parameters
    ----------
    data : dict or None
        The model or preset file's TOML data.

    Returns
    -------
    str or None
        A phrase naming each misfit (examples below).

    Examples
    --------
    >>> identify_misfit({"model": {"outputs": ["x", "y"]}, "identification": {"dynamics": {
    ...     "held_out_fit_percent": 89.56, "dc_gain_unconstrained": [[0.955, 0.0], [0.01, 0.835]]}}})
    "its dynamics fitted the held-out broadband records at 89.6 %, and the multisines showed 0.835 times the hysteresis records' static gain on y (G(0) fitted unconstrained)"
    >>> identify_misfit({"identification": {"dynamics": {"held_out_fit_percent": 97.0}}}) is None
    True
    """
    ident = (data or {}).get("identification")
    dyn = ident.get("dynamics") if isinstance(ident, dict) else None
    if not isinstance(dyn, dict):
        return None
    parts = []
    fit = dyn.get("held_out_fit_percent")
    if isinstance(fit, (int, float)) and not isinstance(fit, bool) and np.isfinite(fit) \
            and fit < DYNAMICS_FIT_WARN_PERCENT:
        parts.append(f"its dynamics fitted the held-out broadband records at {fit:.3g} %")
    try:
        G = np.asarray(dyn.get("dc_gain_unconstrained"), dtype=float)
    except (TypeError, ValueError):
        G = np.zeros(0)
    if G.ndim == 2 and G.shape[0] == G.shape[1] and G.size and np.all(np.isfinite(G)):
        dev = np.abs(G - np.eye(G.shape[0]))
        l, k = np.unravel_index(int(np.argmax(dev)), dev.shape)
        model = (data or {}).get("model")
        outs = model.get("outputs") if isinstance(model, dict) else None
        if not (isinstance(outs, list) and len(outs) == G.shape[0]):
            outs = [f"output {i + 1}" for i in range(G.shape[0])]
        if dev[l, k] > STATIC_GAIN_WARN:
            parts.append(f"the multisines showed {G[l, k]:.3g} times the hysteresis records' "
                         f"static gain on {outs[l]} (G(0) fitted unconstrained)" if l == k else
                         f"the multisines showed a static cross-coupling of {G[l, k]:.3g} from "
                         f"{outs[k]}'s path to {outs[l]} (G(0) fitted unconstrained)")
    return ", and ".join(parts) or None


def falling_direct_transfer(model):
    """Why a classical PI's direct transfer cannot be inverted by any kind (a phrase), or None.

    A direct transfer (output l from input l of a square model) whose first
    weight, the initial slope of every loop from a reversal, is ``w_1 <= 0``
    moves its output the wrong way (or not at all) as its input turns: no
    compensator inverts it. A hand-written model with ``w_1 = -0.05 µm/V``
    was told the multivariable gain diverges ("gain = 'secant'", a gain the
    user never chose) and then that the amplifier was too slow.

    Parameters
    ----------
    model : object
        The plant's hysteresis model; only a classical PI
        (:class:`~hammerstein.models.hysteresis.MultivariablePI`) is checked.

    Returns
    -------
    str or None
        E.g. ``"model: direct transfer x <- ux: weights: ..."``.
    """
    if not isinstance(model, MultivariablePI) or model.n_inputs != model.n_outputs:
        return None
    for l in range(model.n_outputs):
        weights = getattr(model.components[l][l], "weights", None)
        if weights is None or not np.size(weights):
            continue
        w = np.asarray(weights, dtype=float).ravel()
        w1 = float(w[0])
        if not w1 > 0:
            out, inp = model.output_names[l], model.input_names[l]
            # every loop falls (the weights' sum, the slope of the largest loops, < 0 too): the
            # records' sensor, not the actuator (identify warned of it)
            sensor = (f" (its loops fall as {inp} rises: a sensor of inverted sign? invert the "
                      f"{out} column of the records, y -> -y, and identify again)"
                      if float(np.sum(w)) < 0 else "")
            motion = ("would not move while {inp} turns by twice the second threshold (a "
                      "dead band at every reversal), and no compensator inverts that"
                      if w1 == 0 else "would move the wrong way as {inp} turns, and no "
                      "compensator inverts that").format(inp=inp)
            advice = ("" if sensor else
                      "; identify's least squares (the default method) keep a rising "
                      "transfer's first weight at a tenth of its secant or more, and "
                      "--bounds monotone every slope (identify the records again; the closed "
                      "form is not bounded)")
            return (f"model: direct transfer {out} <- {inp}: weights: the first weight (the "
                    f"initial slope of its loops) is {w1:.6g}; expected > 0: {out} {motion}"
                    f"{sensor}{advice}")
    return None


def dynamics_problem(data, path):
    """A warning line when a preset's dynamics fitted their held-out records poorly, or None.

    ``identify --dynamics`` keeps G even when it fits the held-out broadband records below
    :data:`hammerstein.identification.identification_pipeline.DYNAMICS_FIT_WARN_PERCENT`
    (``[identification.dynamics] held_out_fit_percent``) and warns then; ``compensate`` and
    ``learn``, which invert that G, say it again. Measured on a simulated 5 kHz stage whose
    G fitted at -13.5 % (noisy multisines, first modes at 0.66 and 0.74 of Nyquist): a 5 Hz
    10 µm circle missed by 17.3-19.5 % of its radius with that G and 16.9-18.6 % without it
    (three noise seeds): far below the first mode G hardly matters, the hysteresis model
    decides; closer to the modes a wrong G is inverted as it is.

    Parameters
    ----------
    data : dict or None
        The model or preset file's TOML data.
    path : str
        The file, for the message.

    Returns
    -------
    str or None
    """
    ident = (data or {}).get("identification")
    dyn = ident.get("dynamics") if isinstance(ident, dict) else None
    fit = dyn.get("held_out_fit_percent") if isinstance(dyn, dict) else None
    if isinstance(fit, bool) or not isinstance(fit, (int, float)) or not np.isfinite(fit) \
            or fit >= DYNAMICS_FIT_WARN_PERCENT:
        return None
    return (f"{Path(str(path)).name}: its dynamics fitted the held-out broadband records at only "
            f"{fit:.3g} % when identified (below {DYNAMICS_FIT_WARN_PERCENT:g} %; identify said "
            f"why): the drive inverts a G that may not be the actuator's. Well below its first "
            f"mode this hardly matters; near it the drive follows that G's errors. Identify "
            f"again from better broadband records, or correct on the measured response "
            f"(hammerstein learn)")


def _delay_problem(data):
    """Why ``identify --dynamics`` did not use its delay estimate (the model file's
    ``[identification.measurement_delay_estimate] problem``), or None."""
    ident = (data or {}).get("identification")
    est = ident.get("measurement_delay_estimate") if isinstance(ident, dict) else None
    if not isinstance(est, dict) or est.get("used", True) is not False:
        return None
    problem = est.get("problem")
    return " ".join(problem.split())[:400] if isinstance(problem, str) else None


def _measurement_delay(data, path):
    """``[identification] measurement_delay_samples`` of a model file, or None."""
    ident = (data or {}).get("identification")
    if not isinstance(ident, dict) or "measurement_delay_samples" not in ident:
        return None
    value = ident["measurement_delay_samples"]
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise PresetError(f"{path}: [identification] measurement_delay_samples: expected an "
                          f"integer >= 0 [samples], found {value!r}")
    return value


def _file_units(data):
    """A model file's ``(input unit, output unit)``: its ``[model]`` table's, V and µm by default."""
    return (str(data["model"].get("input_unit", "V")), str(data["model"].get("output_unit", "µm")))


def check_reference_first(path, sampling_period, text, time="t", outputs=None, period=None):
    """Generate the reference at ``sampling_period`` before the actuator is re-sampled.

    Re-sampling a preset's dynamics at another sampling period loads
    python-control (seconds); a reference too large for the record budget
    (:func:`hammerstein.core.numbers.check_samples`) is refused first, at once.

    Parameters
    ----------
    path : str
        Preset name or file, or model file (as :func:`load_actuator`).
    sampling_period : float or None
        ``--sampling-period`` [s]; None: nothing to check before loading.
    text, time, outputs, period
        As :func:`load_reference`.

    Raises
    ------
    DataFileError, PresetError
        As :func:`load_reference` and :func:`load_actuator`.
    """
    if sampling_period is None:
        return
    p = Path(path)
    data = read_toml(p, "model file") if p.suffix == ".toml" or p.exists() else None
    if data is None or "preset" in data:
        plant = load_plant(path, dynamics=False)
        model, units = plant.hysteresis, plant_units(plant)
    else:
        model, units = load_model(p), _file_units(data)
    shell = argparse.Namespace(sampling_period=float(sampling_period), hysteresis=model,
                               units=units)
    load_reference(text, shell, time, outputs, period)


def inline_table(text, option="--reference"):
    """The value of an inline TOML table given on the command line (``--reference '{ ... }'``).

    Parsed as the value of one key: nesting too deep for the parser is told as
    the scenario loader tells it, and anything after the table (a ``[table]``,
    another key) is refused rather than silently dropped.

    Parameters
    ----------
    text : str
        The option's text, starting with ``{``.
    option : str
        The option, for messages.

    Returns
    -------
    object
        The parsed value (a dict for an inline table).

    Raises
    ------
    DataFileError
        Not valid TOML, nested too deeply, or followed by more TOML.
    """
    try:
        doc = tomllib.loads("reference = " + text)
    except tomllib.TOMLDecodeError as exc:
        raise DataFileError(f"{option}: not an inline TOML table ({exc})") from None
    except RecursionError:  # the parser recurses once per level of [ or {
        raise DataFileError(f"{option}: invalid TOML: arrays or inline tables nested too "
                            f"deeply") from None
    extra = [key for key in doc if key != "reference"]
    if extra:
        raise DataFileError(f"{option}: {escape(repr(extra[0]), 60)} after the inline table; "
                            f"expected one inline TOML table and nothing after it")
    return doc["reference"]


def load_reference(text, plant, time="t", outputs=None, period=None):
    """The reference of ``--reference``: an inline TOML table or a CSV file.

    Parameters
    ----------
    text : str
        ``'{ kind = "circle", radius = 30, frequency = 100, periods = 20 }'``
        (the keys of a scenario's ``reference``) or a CSV path (``t`` and one
        column per output; resampled onto the plant's period, said in
        ``Reference.notes`` when the file is at another rate). Either is in the
        plant's output unit (``plant.units[1]``, µm by default), in which its
        problems and warnings are worded.
    plant : HammersteinPlant
    time : str
        Time column of a CSV file.
    outputs : str, optional
        ``--output-columns`` mapping of a CSV file.
    period : float, optional
        Period of a periodic CSV reference [s] (``--period``): the ZPETC
        preview's continuation past the end and the settling window.

    Returns
    -------
    Reference

    Raises
    ------
    DataFileError
        Bad table or file (one line naming the key or column).
    """
    names = list(plant.hysteresis.output_names)
    unit = plant_units(plant)[1]
    if text.lstrip().startswith("{"):
        spec = inline_table(text)
        if isinstance(spec, dict) and len(names) == 1 and "output" not in spec \
                and spec.get("kind") in ("sine", "triangle"):
            spec = {**spec, "output": names[0]}      # the one output: nothing to choose
        problems = []
        # bounded as a CSV reference is (a record's limit), not by a scenario case's 2e6 samples:
        # a 60 s circle at 50 kHz was refused inline and accepted as a file
        got = _signal("reference", "reference", spec, plant, problems, "--reference", Path.cwd(),
                      case_limit=None)
        if got is None:
            # a reference table's lengths are in the model's output unit, not the scenarios' µm
            msg = "; ".join(p.replace("--reference: reference.", "--reference: ", 1)
                            .replace(" [µm]", f" [{unit}]") for p in problems) \
                or "--reference: cannot generate the reference"
            raise DataFileError(msg)
        t, sig, period, extras = got
        problem = magnitude_problem(sig, unit)
        if problem:
            raise DataFileError(f"--reference: {problem} (its squares "
                                f"would overflow the metrics); expected displacements in {unit}")
        _warn_implausible(sig, "--reference", unit)
        return Reference(t, sig, period, extras.get("scale"), spec, spec.get("kind"),
                         extras.get("loop_channel"))
    notes = []
    t, sig, _ = read_signals(text, names, time, mapping(outputs, names, "--output-columns"),
                             plant.sampling_period, "--reference", notes=notes, period=period,
                             units=getattr(plant, "units", None))
    _warn_implausible(sig, text, unit)
    T = plant.sampling_period
    if period is not None and not 2 * T <= period <= sig.shape[1] * T * (1 + 1e-9):
        raise DataFileError(f"--period: {period:g} s; expected a period of the reference between "
                            f"two sampling periods ({2 * T:g} s) and its length "
                            f"({sig.shape[1] * T:g} s)")
    period_samples = 1 if period is None else max(int(round(period / T)), 1)
    return Reference(t, sig, period_samples, None, None, "file", notes=notes)


def _warn_implausible(signal, what, unit="µm"):
    """A RangeWarning (one ``warning:`` line) when a reference's peak is no actuator's (a unit slip).

    The peak is in ``unit``, the model's output unit: judged in µm when the unit converts to
    it (nm, mm, m: 30 000 nm is a 30 µm circle), not judged in a unit of the lab's own
    (``counts``), whose scale nothing states.
    """
    if not signal.size:
        return
    peak = float(np.max(np.abs(signal)))
    try:
        scale = unit_scale(unit, "µm", "output")
    except ValueError:
        return
    problem = plausibility_problem(peak * scale, "µm", "reference peak")
    if problem and unit != "µm":
        problem = (f"reference peak {peak:g} {unit} ({problem.split(';')[0].split(' ', 2)[2]}); "
                   f"is it in the model's output unit, {unit}?")
    if problem:
        warnings.warn(f"{what}: {problem}", RangeWarning, stacklevel=2)


def owned_problem(out, force):
    """Why ``out`` must not be replaced (a file this project did not write, or a drive file
    changed since it was written: its digest line, :func:`drive_changed`), or None."""
    p = Path(out)
    if force or not p.is_file():
        return None
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            first = fh.read(200)            # the first line's start, bounded
    except OSError:
        return None
    if is_drive_file(p):
        if not drive_changed(p):            # as written, or an earlier version's (no digest)
            return None
        m = re.match(rf"{DRIVE_MARK} ([a-z-]+) drive", first.lstrip("\ufeff"))
        by = f"hammerstein {m.group(1)}" if m else "hammerstein"
        return (f"--out: {escape(out)} changed since {by} wrote it (a measured column added?); "
                f"nothing was written: choose another name, move it away, or pass --force to "
                f"replace it")
    if carries_provenance(p):       # a model, metrics or report file of another command
        m = re.match(rf"# {PROVENANCE} ([a-z-]+)", first.lstrip("\ufeff"))
        by = f"hammerstein {m.group(1)}" if m else "another hammerstein command"
        return (f"--out: {out} exists and was written by {by}: it is not a drive file; choose "
                f"another name or pass --force to replace it")
    return (f"--out: {out} exists and was not written by hammerstein; choose another name or "
            f"pass --force to replace it")


def add_actuator_arguments(p, time_help=None):
    """The arguments shared by the hardware commands: actuator, reference, time, mappings.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    time_help : str, optional
        The command's own help of ``--time`` (default: the shared wording).
    """
    p.add_argument("actuator", metavar="MODEL_OR_PRESET",
                   help="preset name or file (PI + dynamics + optional [amplifier]), or a model "
                        "file written by identify (classical PI, Preisach or generalised PI; it "
                        "carries the records' sampling period, a model file without one needs "
                        "--sampling-period)")
    p.add_argument("--reference", required=True, metavar="SPEC_OR_CSV",
                   help="inline TOML table as a scenario's reference, e.g. '{ kind = \"circle\", "
                        "radius = 30, frequency = 100, periods = 20 }', or a CSV file with t [s] "
                        "and one column per output, in the model's output unit (µm unless "
                        "identify --output-unit named another)")
    p.add_argument("--sampling-period", type=positive_float, metavar="S",
                   help="sampling period [s] (default: the preset's, or the model file's)")
    p.add_argument("--period", type=positive_float, metavar="S",
                   help="period of a periodic CSV reference [s] (continuation past its end, "
                        "settling window)")
    if time_help is None:
        add_column_options(p)
    else:
        add_column_options(p, time_help=time_help)


def catch():
    """The errors of bad input the hardware commands report as one line (exit 1)."""
    return (HammersteinError, ValueError, OSError)

