"""The words that define a report's metrics, settling window and terms, in one place.

Every ``report.md`` (``hammerstein run``'s reports of cases and sweeps,
``hammerstein evaluate``'s) ends its introduction with a "Definitions"
section written by :func:`definitions_lines`: the paper cited in full
(:data:`PAPER`), how the settled window is counted, and a short definition
of each metric the report shows (:data:`METRIC_WORDS`), no other. The
percentages say what they are a percentage of, for the reference kinds of
the report (:data:`SCALE_WORDS`, as
:mod:`hammerstein.signals.references` sets the ``scale``). docs/metrics.md
holds the same definitions at length.
"""

from __future__ import annotations

import re

from hammerstein.signals.metrics import unit_label

__all__ = ["PAPER", "METRIC_WORDS", "SCALE_WORDS", "TERM_WORDS", "metric_words",
           "definitions_lines", "plural"]

#: The paper the package implements, cited in full once in every report that refers to it.
PAPER = ('M. Rakotondrabe, "Multivariable classical Prandtl-Ishlinskii hysteresis modeling and '
         'compensation and sensorless control of a nonlinear 2-dof piezoactuator", '
         '*Nonlinear Dynamics*, 2017')

#: What the percent metrics of a reference kind divide by (the ``scale`` its generator sets).
SCALE_WORDS = {
    "sine": "the amplitude of a sine reference (half its peak-to-peak)",
    "triangle": "the amplitude of a triangle reference (half its peak-to-peak)",
    "circle": "the radius of a circle",
    "spiral": "the radius a spiral starts from",
    "lissajous": "the larger amplitude of a Lissajous figure",
    "raster": ("the larger scan extent of a raster, its whole size (not half of it): 40 µm "
               "for a 40 × 40 µm raster"),
}

#: One-line definitions of the metrics (``metrics.csv``'s ``metric`` column), with their unit.
METRIC_WORDS = {
    "peak_to_peak": "H = max y − min y of an output over the last full period [µm].",
    "hysteresis_width": (
        "h, the largest vertical gap between the ascending and the descending branch of the "
        "last full period of an output plotted against the driven voltage (open-loop drive) "
        "or against its reference (compensated single-axis sine or triangle) [µm]; 0 for a "
        "map without hysteresis."),
    "hysteresis_ratio": ("100 h / H: the hysteresis width as a percentage of the same output's "
                         "peak-to-peak H over the last period (the paper's measure of "
                         "hysteresis) [%]."),
    "cross_coupling_peak_to_peak": (
        "max − min over the settled window of an output that is not the driven input's own "
        "output (open loop), or whose reference is zero throughout (compensated: the residual "
        "cross-coupling) [µm]."),
    "rms_error": ("√(mean e²) of the tracking error e = y_r − y of one output over the settled "
                  "window [µm] (the paper's RMS error, Fig. 9)."),
    "max_abs_error": "max |e| of one output over the settled window [µm].",
    "max_abs_error_percent": ("100 max_abs_error / A_l, A_l half the peak-to-peak of that "
                              "output's own reference over the settled window (each axis on its "
                              "own scale: a stage whose axes differ 5x) [%]."),
    "rms_error_percent": ("100 rms_error / A, A the amplitude of the single-axis sine or "
                          "triangle reference (half its peak-to-peak) [%]."),
    "max_euclidean_error": (
        "the largest Euclidean tracking error ‖Y_r − Y‖ = √(Σ_l e_l²) over the settled window, "
        "all outputs together (channel x+y) [µm]."),
    "rms_euclidean_error": "the RMS of ‖Y_r − Y‖ over the settled window [µm].",
    "max_euclidean_error_percent": "100 max_euclidean_error / S, S {scale} [%].",
    "line_rms_error": (
        "per scan line of a raster (channel line-j: one period of the fast axis, trace and "
        "retrace), the RMS of ‖Y_r − Y‖ over the whole line [µm]. Every line is measured "
        "whole, the first one too, start-up included (no settled window): line 1 holds the "
        "start-up transient."),
    "line_max_error": "the largest ‖Y_r − Y‖ on a scan line, measured as line_rms_error [µm].",
    "peak_input": ("max |u| of an input's commanded voltage over the whole record from rest "
                   "(start-up and fade-in included, not only the settled window) [V]."),
    "peak_slew": ("max |u[k] − u[k−1]| / T of an input over the whole record, the first step "
                  "counted from 0 V at rest (a drive that starts away from 0 V shows that "
                  "step here) [V/s]."),
    "diverged_at_time": ("the time at which the compensator diverged (its voltages became "
                         "non-finite or exceeded their bound); reported instead of the other "
                         "metrics of the case [s]."),
    "model_rms_error": ("RMS over the settled window of the plant's output minus the model's, "
                        "both driven by the same voltages from rest (the paper's "
                        "RMS_error_model, Section 5.3) [µm]."),
    "model_max_abs_error": "the largest |plant − model| over the settled window [µm].",
    "output_range": "max − min of the measured output [µm].",
    "delay_samples": ("the delay of the measurement behind the reference, estimated by "
                      "cross-correlation over the settled window [samples]."),
    "delay": "that delay in seconds [s].",
    "judged": ("the error a trial is judged by: the settled max Euclidean error with the "
               "estimated measurement noise removed [µm]."),
}

#: Definitions of the words of the case tables (gains, inversions, plant labels).
TERM_WORDS = {
    "secant gain": ("secant gain: the diagonal gain K of the multivariable law, K_ll the secant "
                    "slope of the direct transfer l over the identified amplitude [µm/V]."),
    "midpoint gain": ("midpoint gain: the diagonal gain K of the multivariable law, K_ll the "
                      "mean of the smallest and the largest slope of the direct transfer l, "
                      "which makes that transfer's fixed-point iteration contract fastest "
                      "[µm/V]."),
    "identity gain": "identity gain: K = I, the law as printed in the paper.",
    "ZPETC": ("ZPETC: zero-phase-error tracking control, the causal inverse of the identified "
              "linear dynamics G, which reads the reference a few samples ahead."),
    "stable inversion": ("stable inversion: the exact inverse of G over a record known in "
                         "advance (the reference read ahead)."),
    "hammerstein plant": ("(hammerstein) plant: the hysteresis followed by the linear dynamics "
                          "(bending modes) of the actuator; (static): the hysteresis alone."),
}

_ILC = re.compile(r"^(max_abs_error|rms_error)_(.+)$")


def plural(n, word, words=None):
    """``"1 case"``, ``"3 cases"``.

    Parameters
    ----------
    n : int
    word : str
        Singular.
    words : str, optional
        Plural (default ``word + "s"``).

    Returns
    -------
    str

    Examples
    --------
    >>> plural(1, "case"), plural(2, "case"), plural(2, "period")
    ('1 case', '2 cases', '2 periods')
    """
    return f"{n} {word if n == 1 else (words or word + 's')}"


def metric_words(metric, kinds=()):
    """The definition of one metric, or None for a metric without one.

    Parameters
    ----------
    metric : str
        A ``metrics.csv`` metric name.
    kinds : iterable of str
        Reference kinds of the cases holding it (for the scale of the
        percentages); every kind when empty.

    Returns
    -------
    str or None
    """
    if metric in METRIC_WORDS:
        text = METRIC_WORDS[metric]
        if "{scale}" in text:
            scales = [SCALE_WORDS[k] for k in dict.fromkeys(kinds) if k in SCALE_WORDS] \
                or list(SCALE_WORDS.values())
            text = text.format(scale=", or ".join(scales))
        return text
    m = _ILC.match(metric)
    if m:
        what = "RMS" if m.group(1) == "rms_error" else "largest absolute value"
        return (f"per learning trial (channel iteration-k), the {what} of the tracking error "
                f"of output {m.group(2)} over the settled window [µm].")
    return None


def definitions_lines(metrics, kinds=None, settle=None, terms=(), paper=None,
                      units=("V", "µm")):
    """The "Definitions" section of a ``report.md``.

    Parameters
    ----------
    metrics : iterable of str
        The metrics the report shows (each defined once, in this order).
    kinds : dict of str to iterable of str, optional
        Metric -> reference kinds of the cases that hold it (what its
        percentage divides by).
    settle : str, optional
        How the settled window is counted (default: the scenario
        convention, ``settle_periods`` periods from t = 0).
    terms : iterable of str
        Keys of :data:`TERM_WORDS` the report uses.
    paper : bool, optional
        Cite :data:`PAPER` ("the paper" of the report); by default when a
        definition written here refers to it.
    units : tuple of str
        ``(input unit, output unit)`` of the values: the definitions' ``[µm]``,
        ``[V]``, ``[V/s]`` and ``[µm/V]`` name them
        (:func:`hammerstein.signals.metrics.unit_label`).

    Returns
    -------
    list of str
        Markdown lines, ending with an empty line.

    Examples
    --------
    >>> lines = definitions_lines(["rms_error"], paper=False)
    >>> lines[0], lines[-2].startswith("- `rms_error`")
    ('## Definitions', True)
    """
    kinds = kinds or {}
    lines = ["## Definitions", ""]
    body = []
    if settle is None:
        settle = ("Settled window: the metrics skip the first `settle_periods` periods of each "
                  "record, counted from its first sample (t = 0, at rest), so a fade-in, which "
                  "starts at t = 0, lies inside them; the window starts at sample "
                  "round(settle_periods × P), P the samples per period (a raster's period is "
                  "one line), and runs to the end of the record (given in seconds for each "
                  "case below). Loop metrics use the last full period. The tracking error "
                  "is e = y_r − y per output; the Euclidean error ‖Y_r − Y‖ takes all outputs "
                  "together (the paper's ε = sgn(θ)√|θ|, θ = (x_r + y_r)² − (x + y)², is not "
                  "a distance and is not used).")
    body += [settle, ""]
    for metric in dict.fromkeys(metrics):
        words = metric_words(metric, kinds.get(metric, ()))
        if words and tuple(units) != ("V", "µm"):
            words = re.sub(r"\[([^\]]+)\]", lambda m: f"[{unit_label(m.group(1), units)}]", words)
        if words:
            body.append(f"- `{metric}`: {words}")
    known = [t for t in dict.fromkeys(terms) if t in TERM_WORDS]
    if known:
        body += ["", "Terms:", ""] + [f"- {TERM_WORDS[t]}" for t in known]
    if paper is None:
        paper = any("paper" in line for line in body)
    if paper:
        lines += [f"\"The paper\" is {PAPER}.", ""]
    return lines + body + [""]
