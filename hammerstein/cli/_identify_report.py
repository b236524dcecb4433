"""The printed report and the metrics rows of ``hammerstein identify``.

The private half of :mod:`hammerstein.cli.identify` (which re-exports the
public names): the fit per output and window, the amplitude levels, the
measurement delay, the identified dynamics and creep, as report lines and as
``(case, channel, metric, value, unit)`` rows of the ``--metrics`` CSV.
"""

from __future__ import annotations

from pathlib import Path

from hammerstein.compensation.shaping import RESONANT_DAMPING


def _line(label, name, rep, unit):
    return (f"{label}{name}: RMS {rep['rms']:.4g} {unit} = {rep['rms_percent']:.3g} % of the "
            f"{rep['range']:.4g} {unit} range, max |error| {rep['max_abs']:.4g} {unit} "
            f"({rep['n_samples']} samples)")


def metrics_rows(fit, output_unit):
    """Rows ``(case, channel, metric, value, unit)`` of a fit (train, validation).

    Parameters
    ----------
    fit : RecordFit
        Result of :func:`hammerstein.identification.record_identification.identify_records`.
    output_unit : str
        Unit of the outputs (e.g. ``"µm"``), written in the unit column of the
        absolute errors.

    Returns
    -------
    list of tuple
        Per window (``"train"``, then ``"validation"`` when something was
        held out) and output: ``rms_error`` [output unit],
        ``rms_error_percent`` [%] of the measured range and ``max_abs_error``
        [output unit].
    """
    rows = []
    for case, reps in (("train", fit.train), ("validation", fit.validation)):
        for name, rep in zip(fit.model.output_names, reps or []):
            rows += [(case, name, "rms_error", rep["rms"], output_unit),
                     (case, name, "rms_error_percent", rep["rms_percent"], "%"),
                     (case, name, "max_abs_error", rep["max_abs"], output_unit)]
    return rows


def delay_report_lines(delay, estimate, sampling_period, given=True):
    """Report lines of the measurement delay: its value and how it was chosen.

    Parameters
    ----------
    delay : int
        The delay used [samples].
    estimate : hammerstein.models.lti.MeasurementDelay or None
        The ``--delay auto`` estimate (None when ``--delay N`` was given).
    sampling_period : float
        T [s].
    given : bool
        Whether ``--delay`` was on the command line (else auto was the default).

    Returns
    -------
    list of str
        Empty when no delay was given and none estimated.
    """
    T = float(sampling_period)
    advanced = (f"every record's outputs advanced by it, so G is the actuator's; the model file "
                f"keeps it for `learn --delay auto`" if delay else
                f"the records taken as they are; the model file keeps 0 for `learn --delay auto`")
    if estimate is None:
        return [f"measurement delay {delay} samples ({delay * T:.4g} s, --delay {delay}): "
                + advanced] if delay else []
    how = "--delay auto" if given else "auto, the default with --dynamics"
    if estimate.problem is not None:
        return [f"measurement delay not estimated ({how}): {estimate.problem}; taken as 0, "
                f"not written (learn estimates its own; give --delay N when you know it)"]
    return [f"measurement delay {delay} samples ({delay * T:.4g} s, {how}): " + advanced,
            f"  estimated from the {estimate.method}"]


def _level_key(row):
    return row["source"], row.get("level", row["percent"])


def _level_names(rows):
    """``{(source, level): (percent text, repeat text)}``: a record that repeats an amplitude
    gets ``k of n`` on each of that amplitude's levels, in record order."""
    levels = {}
    for r in rows:
        levels.setdefault(_level_key(r), f"{r['percent']:.0f}")
    count, names = {}, {}
    for (source, _), pct in levels.items():
        count[source, pct] = count.get((source, pct), 0) + 1
    seen = {}
    for (source, level), pct in levels.items():
        seen[source, pct] = seen.get((source, pct), 0) + 1
        n = count[source, pct]
        names[source, level] = (pct, f"{seen[source, pct]} of {n}" if n > 1 else "")
    return names


def level_report_lines(fit, output_unit):
    """One line per amplitude level of the multi-amplitude records: errors per output.

    Parameters
    ----------
    fit : RecordFit
        With ``levels`` (:func:`hammerstein.identification.record_identification.level_errors`).
    output_unit : str
        Unit of the outputs.

    Returns
    -------
    list of str
        ``<source> level <p> % (held out|trained): <output> RMS ... %, loop amplitude ... %``;
        where a record repeats an amplitude, ``level <p> % (k of n, held out|trained)``.
    """
    names = _level_names(fit.levels)
    lines, seen = [], {}
    for row in fit.levels:
        seen.setdefault((_level_key(row), row["held_out"]), []).append(row)
    for ((source, level), held), rows in seen.items():
        pct, repeat = names[source, level]
        parts = [f"{r['output']} RMS {r['rms_percent']:.3g} %, loop amplitude "
                 f"{r['amplitude_error_percent']:+.3g} % of {r['measured_peak_to_peak']:.4g} "
                 f"{output_unit}" for r in rows]
        which = ("held out" if held else "trained") if not repeat else \
            f"{repeat}, {'held out' if held else 'trained'}"
        lines.append(f"{Path(source).name} level {pct} % ({which}): " + "; ".join(parts))
    return lines


def level_metrics_rows(fit, output_unit):
    """Rows ``(case, channel, metric, value, unit)`` per amplitude level.

    Parameters
    ----------
    fit : RecordFit
        With ``levels``.
    output_unit : str
        Unit of the outputs.

    Returns
    -------
    list of tuple
        Case ``<file stem>:level-<p>-<held-out|trained>`` (``level-<p>-<k>of<n>-...``
        where a record repeats an amplitude), channel the output:
        ``rms_error_percent`` [%], ``loop_amplitude_error_percent`` [%],
        ``peak_to_peak`` [output unit].
    """
    names = _level_names(fit.levels)
    rows = []
    for r in fit.levels:
        pct, repeat = names[_level_key(r)]
        case = (f"{Path(r['source']).stem}:level-{pct}-"
                + (repeat.replace(" ", "") + "-" if repeat else "")
                + ('held-out' if r['held_out'] else 'trained'))
        rows += [(case, r["output"], "rms_error_percent", r["rms_percent"], "%"),
                 (case, r["output"], "loop_amplitude_error_percent", r["amplitude_error_percent"], "%"),
                 (case, r["output"], "peak_to_peak", r["measured_peak_to_peak"], output_unit)]
    return rows


def _matrix_text(M):
    return "[" + ", ".join("[" + ", ".join(f"{v:.4g}" for v in row) + "]" for row in M) + "]"


def dynamics_report_lines(summary, output_names, input_names):
    """Printed report of identified dynamics (order, fits, modes, G(0)).

    Parameters
    ----------
    summary : dict
        ``RecordDynamics.summary`` (:func:`hammerstein.identification.record_identification.identify_record_dynamics`).
    output_names, input_names : sequence of str
        Names of the p outputs and p inputs of the model.

    Returns
    -------
    list of str
        One line per item.
    """
    s = summary
    # the order kept is the chosen candidate's, less the states it dropped: a bender's "order 4
    # (candidate order 5)" above an "order 4" candidate line with other modes read as a
    # contradiction
    removed = int(s["candidate_order"]) - int(s["order"])
    kept = (f"order {s['order']} (the order-{s['candidate_order']} candidate below, {removed} "
            f"state{'s' if removed > 1 else ''} dropped)" if removed > 0 else
            f"order {s['order']}")
    lines = [f"dynamics: {kept}, chosen on "
             f"{s['chosen_on']}; excited band {s['band_hz'][0]:.3g}-{s['band_hz'][1]:.4g} Hz"]
    for c in s["candidates"]:
        if "held_out_fit_percent" in c:
            text = (f"  order {c['order']}: held-out fit {c['held_out_fit_percent']:.2f} %, modes "
                    + ", ".join(f"{f:.4g}" for f in c["modes_hz"]) + " Hz"
                    + (f"; not chosen: {c['rejected']}" if c.get("rejected") else ""))
        else:
            text = f"  order {c['order']}: rejected, {c.get('rejected', 'no mode left')}"
        if c.get("dropped"):
            text += "; dropped " + "; ".join(c["dropped"])
        lines.append(text)
    for i, mode in enumerate(s["modes"], start=1):
        share = ", ".join(f"{n} {100 * v:.0f} %" for n, v in mode["axis_share"].items())
        lag = ("; no resonance: a lag, not a bending mode (first mode, fade-in and shaping leave "
               "it out)" if mode["damping_ratio"] >= RESONANT_DAMPING else "")
        lines.append(f"  mode {i}: {mode['frequency_hz']:.5g} Hz, damping "
                     f"{mode['damping_ratio']:.4g} ({share}{lag})")
    step = s.get("dc_gain_step")
    step_text = ("more than 5 % from I" if step is None else
                 f"{100 * step:.3g} % from I at most, in the outputs' balanced units, more than 5 %")
    lines.append(f"  G(0) unconstrained {_matrix_text(s['dc_gain_unconstrained'])} (rows "
                 f"{','.join(output_names)}, columns {','.join(input_names)}); "
                 + (f"chosen with the records' gain (the first fit's G(0) {step_text}: "
                    f"fitted with G(0) = I the order would make the step with slow pole pairs), "
                    f"then scaled to G(0) = I: the static gain belongs to the hysteresis model"
                    if s.get("dc_gain_scaled")
                    else "fitted with G(0) = I: the static gain belongs to the hysteresis model, "
                    "identified quasi-statically" if s["unit_dc_gain"]
                    else f"kept as identified: {_matrix_text(s['dc_gain'])}"))
    lines.append(f"  held-out fit {s['held_out_fit_percent']:.2f} %, fit over all broadband "
                 f"records " + ", ".join(f"{n} {v:.2f} %" for n, v in
                                         zip(output_names, s["fit_percent"])))
    return lines


def modes_above_band_warning(summary):
    """A warning when the identified dynamics put a bending mode above the excited band.

    The multisines measure G over ``band_hz`` only; a resonant mode (damping
    below :data:`~hammerstein.compensation.shaping.RESONANT_DAMPING`) fitted
    above the band's top is extrapolated from the band. On a clean linear
    response that extrapolation finds the modes (1647 and 1864 Hz from a band
    to 230 Hz, the true 1650 and 1850 Hz); behind a hysteresis model that
    misses the multisines' small loops it invents them at the band's edge (a
    stack whose slew rate narrowed the multisines to 242 Hz: a mode at 263 Hz,
    damping 0.18, where its only mode is at 1.2 kHz, damping 0.05).
    ``compensate`` inverts them and shapes references below the first.

    Parameters
    ----------
    summary : dict
        ``RecordDynamics.summary``: ``band_hz`` ([low, high] [Hz]) and ``modes``
        (each ``frequency_hz`` [Hz], ``damping_ratio`` [-]).

    Returns
    -------
    str or None
        One line without the ``warning:`` prefix; None when every resonant mode
        lies within the band.

    Examples
    --------
    >>> s = {"band_hz": [4.5, 242.5], "modes": [{"frequency_hz": 6.9, "damping_ratio": 1.0},
    ...      {"frequency_hz": 263.0, "damping_ratio": 0.18}]}
    >>> modes_above_band_warning(s)[:58]
    'the identified dynamics put a bending mode at 263 Hz (damp'
    >>> modes_above_band_warning({"band_hz": [5, 5000], "modes": s["modes"]}) is None
    True
    """
    band = summary.get("band_hz") if summary else None
    if not band or len(band) != 2:
        return None
    top = float(band[1])
    above = [m for m in summary.get("modes", [])
             if m["damping_ratio"] < RESONANT_DAMPING and m["frequency_hz"] > top]
    if not above:
        return None
    modes = ", ".join(f"{m['frequency_hz']:.4g} Hz (damping {m['damping_ratio']:.2g})"
                      for m in above)
    one = len(above) == 1
    it = "it" if one else "them"
    return (f"the identified dynamics put {'a bending mode' if one else 'bending modes'} at "
            f"{modes} above the band the multisines excited (to {top:.4g} Hz): extrapolated "
            f"from the band, not measured (right for a clean linear response; a hysteresis "
            f"model that misses the multisines' small loops leaves the fit a residual it puts "
            f"in modes at the band's edge); compensate inverts {it} and shapes references below "
            f"the first. To measure {it}, record multisines through the actuator's first mode "
            f"(hammerstein excitation --f-max, at a lower amplitude where a slew rate narrowed "
            f"the band), or give --order to keep fewer modes")


def dynamics_metrics_rows(summary, output_names, input_names):
    """Rows ``(case, channel, metric, value, unit)`` of identified dynamics.

    Parameters
    ----------
    summary : dict
        ``RecordDynamics.summary``.
    output_names, input_names : sequence of str
        Names of the p outputs and p inputs.

    Returns
    -------
    list of tuple
        Case ``dynamics``: ``order``, ``held_out_fit_percent`` (channel
        ``G``), ``fit_percent`` per output, ``dc_gain_unconstrained`` per
        ``<output>:<input>``, ``frequency`` [Hz], ``damping_ratio`` and
        ``share_<output>`` per ``mode-<i>``; case ``dynamics-order-<N>``:
        ``held_out_fit_percent`` per candidate order that gave a model.
    """
    s = summary
    rows = [("dynamics", "G", "order", s["order"], ""),
            ("dynamics", "G", "held_out_fit_percent", s["held_out_fit_percent"], "%")]
    rows += [("dynamics", n, "fit_percent", v, "%") for n, v in zip(output_names, s["fit_percent"])]
    for l, out in enumerate(output_names):
        for k, inp in enumerate(input_names):
            rows.append(("dynamics", f"{out}:{inp}", "dc_gain_unconstrained",
                         s["dc_gain_unconstrained"][l][k], ""))
    for i, mode in enumerate(s["modes"], start=1):
        rows += [("dynamics", f"mode-{i}", "frequency", mode["frequency_hz"], "Hz"),
                 ("dynamics", f"mode-{i}", "damping_ratio", mode["damping_ratio"], "")]
        rows += [("dynamics", f"mode-{i}", f"share_{n}", v, "") for n, v in mode["axis_share"].items()]
    rows += [(f"dynamics-order-{c['order']}", "G", "held_out_fit_percent",
              c["held_out_fit_percent"], "%") for c in s["candidates"] if "held_out_fit_percent" in c]
    return rows


def creep_metrics_rows(creep, output_unit="µm"):
    """Rows ``(case, channel, metric, value, unit)`` of an identified creep.

    Parameters
    ----------
    creep : hammerstein.identification.creep_identification.CreepIdentifier
        Fitted.
    output_unit : str
        Unit of the outputs.

    Returns
    -------
    list of tuple
        Case ``creep``, channel the output: ``drift_0p1_to_10s_percent`` [%],
        ``instantaneous`` [-], ``residual_rms`` and
        ``residual_rms_without_creep`` [output unit], and
        ``weight_tau_<tau>s`` [-] per lag.
    """
    rows = []
    for l, out in enumerate(creep.output_names_):
        rows += [("creep", out, "drift_0p1_to_10s_percent", 100 * creep.drift_[l], "%"),
                 ("creep", out, "instantaneous", creep.instantaneous_[l], ""),
                 ("creep", out, "residual_rms", creep.residual_rms_[l], output_unit),
                 ("creep", out, "residual_rms_without_creep", creep.residual_rms_no_creep_[l],
                  output_unit)]
        rows += [("creep", out, f"weight_tau_{tau:.4g}s", w, "")
                 for tau, w in zip(creep.time_constants_, creep.weights_[l])]
    return rows


def cut_note(n_samples, whole):
    """The report's clause on a record fitted on fewer samples than were read, or "".

    Parameters
    ----------
    n_samples : int
        Samples the fit used.
    whole : int
        Samples read from the file (after the ``--delay`` shift).

    Returns
    -------
    str

    Examples
    --------
    >>> cut_note(103257, 105000)[:10]
    ' (of 10500'
    >>> cut_note(100, 100)
    ''
    """
    if n_samples >= whole:
        return ""
    return (f" (of {whole}: what follows the last amplitude level, the ramp back to rest or "
            f"reversal curves, is left out of the fit)")
