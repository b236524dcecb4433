"""Identification of p x m PI models from measured records, split by periods.

:func:`identify_records` identifies a multivariable classical PI model
(:class:`~hammerstein.models.hysteresis.MultivariablePI`) from one or more
measured records (:class:`~hammerstein.io.datafiles.MultiRecord`), each
holding every input and every output column. Typically there is one record per
excited input (Steps 1-4 of Section 3.3 of the paper), but least squares
accepts any excitation: all components of an output are fitted together.

What it does, in order:

1. **Split by periods.** The excitation of each record (its input of largest
   relative span) is cut at its reversal points into branches; a branch is
   *complete* when it travels at least 90 % of the input span. The held-out
   part is a run of trailing complete branches (about a third of the
   periods, at least one branch); the rest trains. A record holding a single
   closed loop (one ascending and one descending branch, ending where it
   started) is rotated to start at its minimum and its play states start on
   the steady loop; least squares trains on both branches and holds out
   every third of 30 blocks of each (a loop that is not point-symmetric
   cannot be told from one branch), the closed form trains on the ascending branch and holds
   out the descending one. Before the first complete branch the play states depend on
   an unknown history: those samples only warm up the play states (burn-in).
2. **Thresholds** per input: ``time`` (Remark 5.1 of the paper, the instants
   that split the first complete branch into n + 1 equal parts), ``input``
   (uniform in input, ``r_1 = 0`` a linear term) or ``auto``: both are
   fitted and the one with the smaller held-out error is kept.
3. **Fit**: least squares of every output on the play outputs of every input
   plus one output offset, on the triangular factor of the regression
   (:func:`hammerstein.identification.lsq.r_factor`; :func:`scipy.linalg.lstsq`, or
   :func:`hammerstein.identification.lsq.bounded_lstsq` with bounds on the direct
   transfers),
   or the closed form of the paper's Appendix per component.
4. **Structure**: each component is a PI, a pure gain or absent. With
   ``components="auto"`` a component is simplified (PI -> absent, else PI ->
   gain) when the simplified fit's training RMS error of its output grows by
   at most 5 %, i.e. when its contribution is below the noise and mismatch
   of that output.
5. **Fit report** on the training and held-out samples per output (RMS,
   RMS in % of the measured output range, largest absolute error), the model
   simulated with its output offset.

The module is the public face of three private ones, split by concept:
``_record_split`` (periods, levels, windows and their errors),
``_record_regression`` (the least-squares and closed-form engines, the output
map) and ``_record_dynamics`` (G and the creep behind a fitted model); the
names they define that this module lists in ``__all__`` are re-exported here
and documented as this module's.

References
----------
.. [1] M. Rakotondrabe, "Multivariable classical Prandtl-Ishlinskii hysteresis
   modeling and compensation and sensorless control of a nonlinear 2-dof
   piezoactuator", Section 3.3, Remark 5.1 and Appendix.
.. [2] K. Kuhnen, "Modeling, identification and compensation of complex
   hysteretic nonlinearities", Eur. J. Control 9 (2003) (least squares on
   play outputs, monotone PI via cumulative weights).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d

from hammerstein.core.numbers import MAX_HYSTERONS, check_integer
from hammerstein.models.hysteresis import HysteresisError, MultivariablePI, PrandtlIshlinskii
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification._record_split import (
    ASYMMETRY_NOTE_PERCENT, COMPLETE_TRAVEL, HOLD_OUT_BLOCKS, NOISE_FACTOR, REVERSAL_BAND, Split,
    _as_records, _asymmetry_notes, _one_branch_held, _window_metrics, amplitude_levels,
    held_out_level_error, level_errors, level_weights, levels_end, levels_part, loop_asymmetry,
    noise_level,
    reversal_points, simulate_on_record,
    split_level_records, split_record)
from hammerstein.identification._record_regression import (
    MAP_GAIN, MAP_KNOTS, OUTPUT_MAPS, _ClosedForm, _fit_output_maps, _LeastSquares, _thresholds)
from hammerstein.identification._record_dynamics import (
    DYNAMICS_DEFAULTS, RecordDynamics, dynamics_tables, identify_record_creep,
    identify_record_dynamics)


__all__ = [
    "HOLD_OUT_BLOCKS",
    "REVERSAL_BAND",
    "COMPLETE_TRAVEL",
    "PRUNE_TOLERANCE",
    "Split",
    "RecordFit",
    "reversal_points",
    "split_record",
    "parse_components",
    "identify_records",
    "identify_record",
    "identify_record_creep",
    "dynamics_tables",
    "noise_level",
    "split_level_records",
    "weak_couplings",
    "amplitude_levels",
    "level_errors",
    "level_weights",
    "held_out_level_error",
    "NOISE_FACTOR",
    "SIGNIFICANCE_Z",
    "SIGNIFICANCE_BLOCKS",
    "LOOP_WARN_FACTOR",
    "identify_record_dynamics",
    "RecordDynamics",
    "DYNAMICS_DEFAULTS",
    "loop_asymmetry",
    "ASYMMETRY_NOTE_PERCENT",
    "OUTPUT_MAPS",
    "MAP_KNOTS",
]


for _name in ("Split", "reversal_points", "split_record", "noise_level", "split_level_records",
              "amplitude_levels", "level_errors", "held_out_level_error", "loop_asymmetry",
              "identify_record_dynamics",
              "RecordDynamics", "dynamics_tables", "identify_record_creep"):
    globals()[_name].__module__ = __name__      # documented (and pickled) as this module's
del _name

#: Relative growth of an output's training RMS error accepted when a component is simplified.
PRUNE_TOLERANCE = 0.05
#: Component kinds.
KINDS = ("pi", "gain", "none")
#: A cross-coupling stays when removing it raises the held-out squared error by this many
#: standard errors (one-sided, about 1 in 740 for a component fitted to noise alone).
SIGNIFICANCE_Z = 3.0
#: Contiguous blocks of the held-out samples whose sums estimate that standard error.
SIGNIFICANCE_BLOCKS = 40
#: A dropped cross-coupling spanning more than this multiple of the noise gets a warning.
LOOP_WARN_FACTOR = 4.0


# -- structure -------------------------------------------------------------------------
def parse_components(spec, input_names, output_names):
    """Component kinds from ``"auto"``, ``"all"`` or ``"OUT:IN=pi|gain|none,..."``.

    Parameters
    ----------
    spec : None, str or dict
        ``None`` or ``"auto"`` (every component a PI, all prunable),
        ``"all"`` (every component a PI, none prunable), a comma-separated
        string ``"OUT:IN=kind,..."`` or a dict ``{"OUT:IN" or (OUT, IN):
        kind}``; the components not named stay automatic.
    input_names : sequence of str
        The m input names of the model.
    output_names : sequence of str
        The p output names of the model.

    Returns
    -------
    (kinds, auto) : (list of list of str, numpy.ndarray of bool)
        Kinds per (output, input) and which ones the automatic pruning may
        simplify (those not given explicitly, unless ``"all"``).

    Raises
    ------
    IdentificationError
        On an unknown output, input or kind (the known ones are listed).
    """
    p, m = len(output_names), len(input_names)
    kinds = [["pi"] * m for _ in range(p)]
    auto = np.ones((p, m), dtype=bool)
    if spec is None or spec == "auto":
        return kinds, auto
    if spec == "all":
        return kinds, np.zeros((p, m), dtype=bool)
    items = spec.items() if isinstance(spec, dict) else [
        tuple(part.split("=", 1)) if "=" in part else (part, None)
        for part in str(spec).split(",") if part.strip()]
    for key, kind in items:
        key = key if isinstance(key, tuple) else tuple(str(key).strip().split(":", 1))
        if len(key) != 2 or kind is None:
            raise IdentificationError(
                f"components: expected OUTPUT:INPUT=pi|gain|none entries, found {key!r}")
        out, inp = (str(v).strip() for v in key)
        kind = str(kind).strip()
        if out not in output_names:
            raise IdentificationError(f"components: unknown output {out!r} (outputs: "
                                      f"{', '.join(output_names)})")
        if inp not in input_names:
            raise IdentificationError(f"components: unknown input {inp!r} (inputs: "
                                      f"{', '.join(input_names)})")
        if kind not in KINDS:
            raise IdentificationError(f"components: {out}:{inp}: expected pi, gain or none, "
                                      f"found {kind!r}")
        l, k = output_names.index(out), input_names.index(inp)
        kinds[l][k] = kind
        auto[l, k] = False
    return kinds, auto


# -- driver ------------------------------------------------------------------------------
@dataclass
class RecordFit:
    """Result of :func:`identify_records`.

    Parameters
    ----------
    model : MultivariablePI
        Identified model, ``output_offset`` included, ``input_amplitude`` the
        half span of each input over the training samples.
    method : str
    partition : str
        Threshold partition used (``"time"``, ``"input"`` or ``"explicit"``).
    partition_scores : dict of str to float
        Mean held-out (or training, without held-out samples) RMS error in %
        of the output range for each partition tried.
    structure : list of list of str
        ``"pi"``, ``"gain"`` or ``"none"`` per (output, input).
    notes : list of str
        What was decided automatically (partition, pruned components).
    records : list of MultiRecord
        The records as used (closed loops rotated to start at their minimum).
    splits : list of Split
    train, validation : list of dict
        Per output: ``rms``, ``rms_percent`` (of the measured range of the
        window), ``max_abs``, ``range``, ``n_samples``; ``validation`` is
        ``None`` when nothing is held out.
    predictions : list of numpy.ndarray, shape (p, n_samples)
        Model outputs over each record (offset included).
    output_map : {"none", "deadzone"}
        Whether the model has a static output map (modified PI).
    levels : list of dict
        Per amplitude level of multi-amplitude records (:func:`level_errors`).
    """

    model: MultivariablePI
    method: str
    partition: str
    partition_scores: dict
    structure: list
    notes: list
    records: list
    splits: list
    train: list
    validation: list | None
    predictions: list = field(repr=False)
    output_map: str = "none"
    levels: list = field(default_factory=list)

    def record(self):
        """What the fit decided and how well it fits: the ``[identification]`` record of a model file.

        Returns
        -------
        dict
            ``method``, ``partition`` and ``partition_scores_percent``,
            ``components`` (output -> input -> ``pi``/``gain``/``none``),
            ``output_map``, ``held_out`` (the windows held out), ``notes``,
            ``train_rms`` [output unit, per output] and
            ``train_rms_percent_of_range``, with held-out samples
            ``validation_rms``, ``validation_rms_percent_by_output``,
            ``validation_rms_percent_of_range`` and ``validation_max_abs``,
            with amplitude levels ``levels``: plain numbers and strings, as
            ``hammerstein identify`` and a scenario's records route write them.
        """
        val = self.validation
        out = {"method": self.method, "partition": self.partition,
               "partition_scores_percent": {k: float(v) for k, v in self.partition_scores.items()},
               "components": {o: {i: self.structure[l][k]
                                  for k, i in enumerate(self.model.input_names)}
                              for l, o in enumerate(self.model.output_names)},
               "output_map": self.output_map,
               "held_out": [s.description for s in self.splits],
               "notes": list(self.notes),
               "train_rms": [r["rms"] for r in self.train],
               "train_rms_percent_of_range": max(r["rms_percent"] for r in self.train)}
        if val is not None:
            out.update(validation_rms=[r["rms"] for r in val],
                       validation_rms_percent_by_output=[r["rms_percent"] for r in val],
                       validation_rms_percent_of_range=max(r["rms_percent"] for r in val),
                       validation_max_abs=[r["max_abs"] for r in val])
        if self.levels:
            out["levels"] = [{k: (float(v) if isinstance(v, float) else v) for k, v in r.items()}
                             for r in self.levels]
        return out

    @property
    def minor_loop_error(self):
        """Mean RMS Euclidean error of the held-out amplitude levels [% of each level's range].

        The minor loops the fit never saw (:func:`held_out_level_error`): the
        error of all outputs together in % of the level's largest output
        range; what ``identify --model auto`` and the generalised PI's
        ``threshold_spacing="auto"`` compare. None without held-out levels.
        """
        return held_out_level_error(self.levels)


def _fit_structure(engine, kinds, auto, names_out, names_in, prune):
    """Fit every output; simplify components where allowed. Returns (grid, offsets, notes)."""
    p = len(kinds)
    grid, offsets, notes = [], [], []
    for l in range(p):
        row = list(kinds[l])
        comps, off, rms = engine.fit_output(l, row)
        if prune:
            base = rms
            order = sorted((k for k in range(len(row)) if auto[l, k] and row[k] != "none"),
                           key=lambda k: _contribution(comps[k], engine, k))
            for k in order:
                for simpler in ("none", "gain"):
                    if KINDS.index(simpler) <= KINDS.index(row[k]):
                        continue
                    trial = list(row)
                    trial[k] = simpler
                    if not any(t == "pi" for r_ in ([trial] + [g for g in kinds[l + 1:]]) for t in r_) \
                            and not any(isinstance(c, PrandtlIshlinskii) for g in grid for c in g):
                        continue          # keep at least one hysteresis component in the model
                    c2, o2, rms2 = engine.fit_output(l, trial)
                    if rms2 <= (1 + PRUNE_TOLERANCE) * base + 1e-12 * max(abs(o2), 1.0):
                        above = _above_noise(engine, l, k, comps[k], simpler)
                        if above is not None:
                            notes.append(
                                f"{names_out[l]} <- {names_in[k]}: kept, not "
                                f"{'absent' if simpler == 'none' else 'a pure gain'} (its "
                                f"{'contribution' if simpler == 'none' else 'hysteresis'} "
                                f"{above[0]:.3g} RMS is above the noise {above[1]:.3g}, though "
                                f"the training RMS grows only from {base:.3g} to {rms2:.3g})")
                            continue
                        notes.append(f"{names_out[l]} <- {names_in[k]}: "
                                     f"{'absent' if simpler == 'none' else 'a pure gain'} "
                                     f"(training RMS {rms2:.3g} vs {base:.3g} as a PI)")
                        row, comps, off, rms = trial, c2, o2, rms2
                        break
        kinds[l] = row
        grid.append(comps)
        offsets.append(off)
    return grid, offsets, notes


def weak_couplings(records, auto, components, contribution, input_names, output_names,
                   splits=None, predictions=None):
    """Cross-couplings that the data do not support, dropped by ``components = "auto"``.

    With held-out samples (``splits`` and ``predictions`` given, some
    ``held_out`` sample), a cross-coupling (l, k) chosen automatically stays
    when removing it raises the held-out sum of squared errors of output l by
    more than the noise can explain: with ``e`` the held-out residual of the
    model and ``c`` the component's contribution (less its mean over each
    record's held-out samples: a shift between records is no coupling), the
    rise is
    ``D = sum(2 e c + c^2)``, and the component stays when
    ``D > SIGNIFICANCE_Z * SE``, SE the standard error of ``sum(2 e c)``
    from :data:`SIGNIFICANCE_BLOCKS` contiguous blocks of the held-out
    samples (batch means: the residual's serial correlation, model mismatch
    included, counts; white noise alone would give ``2 sigma |c|``). A
    contribution fitted to noise alone does not lower the error of samples
    it was not fitted on (its expected ``D`` is ``-sum(c^2)``), and a real one
    of RMS ``r`` over N samples gives ``D ~ N r^2``: 0.06 µm against 0.03 µm
    noise is decided by the whole record, not by one sample.

    Without held-out samples the RMS of the contribution over the records is
    compared with :data:`NOISE_FACTOR` times the output's measurement noise
    (:func:`noise_level`, median over the records): absent at or below it.

    A dropped coupling whose output moves more than :data:`LOOP_WARN_FACTOR`
    times the noise (peak to peak of the measured output smoothed over 1/400
    of the record) in the records exciting its input adds a ``warning:``
    note: the model leaves that loop on the output.

    Parameters
    ----------
    records : list of Record
        Inputs shape (m, n_samples) [V], outputs shape (p, n_samples) [µm].
    auto : numpy.ndarray of bool, shape (p, m)
        Components whose presence is decided here (:func:`parse_components`).
    components : list of list
        The fitted components, ``components[l][k]`` (None when absent).
    contribution : callable
        ``contribution(component, u)`` -> output [µm] of a component for the
        input samples ``u`` (shape (n_samples,)).
    input_names, output_names : sequence of str
    splits : list of Split, optional
        Training and held-out samples per record (and the input each
        excites; without, the input of largest span).
    predictions : list of numpy.ndarray, shape (p, n_samples), optional
        The model's outputs over each record [µm], every component included.

    Returns
    -------
    absent : list of (int, int)
        The (output, input) pairs to drop.
    notes : list of str
        One line per judged cross-coupling (and a ``warning:`` line per
        dropped one leaving a loop above the noise).
    """
    held = (splits is not None and predictions is not None
            and any(s.held_out.any() for s in splits))
    absent, notes = [], []
    for l in range(len(output_names)):
        noise = float(np.median([noise_level(r.y[l]) for r in records]))
        for k in range(len(input_names)):
            c = components[l][k]
            if k == l or not auto[l, k] or c is None:
                continue
            cs = [contribution(c, r.u[k]) for r in records]
            rms = float(np.std(np.concatenate(cs)))
            name = f"{output_names[l]} <- {input_names[k]}"
            if held:
                rise, se, n = _held_out_rise(records, splits, predictions, l, cs)
                keep = rise > SIGNIFICANCE_Z * se
                numbers = (f"without it the held-out sum of squared errors of "
                           f"{output_names[l]} would change by {rise:.3g} over {n} samples, "
                           f"{rise / se if se > 0 else float('inf'):.3g} standard errors; "
                           f"contribution {rms:.3g} RMS, noise {noise:.3g}")
                notes.append(f"{name}: {'kept' if keep else 'absent'} ({numbers}; kept above "
                             f"{SIGNIFICANCE_Z:g})")
            else:
                keep = rms > NOISE_FACTOR * noise
                notes.append(f"{name}: kept (contribution {rms:.3g} RMS, noise {noise:.3g})"
                             if keep else
                             f"{name}: absent (its contribution {rms:.3g} RMS is below twice "
                             f"the noise {noise:.3g}; nothing held out to test it on)")
            if not keep:
                absent.append((l, k))
                loop = _measured_loop(records, splits, l, k)
                if loop > LOOP_WARN_FACTOR * noise:
                    notes.append(f"warning: {name} dropped, yet {output_names[l]} moves "
                                 f"{loop:.3g} peak to peak ({loop / noise:.3g} times the noise "
                                 f"{noise:.3g}) in the records exciting {input_names[k]}: keep "
                                 f"it with --components {output_names[l]}:{input_names[k]}=pi "
                                 f"if that is a coupling")
    return absent, notes


def _measured_loop(records, splits, l, k):
    """Peak to peak of output l, smoothed over 1/400 of a record, in the records exciting k."""
    loop = 0.0
    for i, rec in enumerate(records):
        spans = np.ptp(rec.u, axis=1)
        exc = splits[i].excitation if splits is not None else int(np.argmax(spans))
        if exc != k or not spans[k] > 0:
            continue
        y = np.asarray(rec.y[l], dtype=float)
        loop = max(loop, float(np.ptp(uniform_filter1d(y, max(1, y.size // 400),
                                                       mode="nearest"))))
    return loop


def _held_out_rise(records, splits, predictions, l, cs):
    """(D, SE, n): rise of output l's held-out squared error without contribution ``cs``.

    Each record's contribution is taken less its mean over that record's
    held-out samples: what varies with the input within a record, not a
    level shift between records (the other paths' mismatch at rest, which a
    cross-coupling could otherwise absorb record by record).
    """
    cross, square, n_all = [], [], 0
    for rec, s, pred, c in zip(records, splits, predictions, cs):
        mask = s.held_out
        if not mask.any():
            continue
        e = rec.y[l][mask] - pred[l][mask]
        cc = c[mask] - float(np.mean(c[mask]))
        cross.append(2.0 * e * cc)
        square.append(cc * cc)
        n_all += int(mask.sum())
    cross, square = np.concatenate(cross), np.concatenate(square)
    rise = float(np.sum(cross) + np.sum(square))
    blocks = np.array_split(cross, min(SIGNIFICANCE_BLOCKS, cross.size))
    sums = np.array([b.sum() for b in blocks])
    nb = sums.size
    se = float(np.sqrt(nb * np.var(sums, ddof=1))) if nb > 1 else float("inf")
    return rise, se, n_all


def _above_noise(engine, l, k, comp, simpler):
    """(RMS, noise) when simplifying component (l, k) would drop more than the noise, else None."""
    if not hasattr(engine, "phi") or comp is None:
        return None
    if isinstance(comp, PrandtlIshlinskii):
        c = engine.phi[k] @ comp.weights
    else:
        c = comp * engine.lin[k]
    if simpler == "gain":
        if not isinstance(comp, PrandtlIshlinskii):
            return None
        X = np.column_stack([engine.lin[k], np.ones_like(engine.lin[k])])
        c = c - X @ np.linalg.lstsq(X, c, rcond=None)[0]
    rms = float(np.std(c))
    noise = noise_level(engine.y[l])
    return (rms, noise) if rms > NOISE_FACTOR * noise else None


def _contribution(comp, engine, k):
    if comp is None:
        return 0.0
    if isinstance(comp, PrandtlIshlinskii):
        c = engine.phi[k] @ comp.weights if hasattr(engine, "phi") else comp.weights
        return float(np.std(c))
    return float(np.std(comp * engine.lin[k])) if hasattr(engine, "lin") else abs(comp)


def identify_records(records, method="least-squares", n_hysterons=15, thresholds=None,
                     partition="auto", bounds=None, components="auto", hold_out="auto",
                     train_fraction=None, skip_seconds=None, input_names=None, output_names=None,
                     output_map="auto"):
    """Identify a p x m PI model from records, validated on held-out periods.

    Parameters
    ----------
    records : MultiRecord, Record or sequence of them
        Each with all m inputs (shape (m, n_samples), input unit) and all p
        outputs (shape (p, n_samples), output unit).
    method : {"least-squares", "closed-form"}
    n_hysterons : int
        Hysterons per component, 1 to 100 (``MAX_HYSTERONS``, the bound of
        the command line and of the scenario files).
    thresholds : array_like, shape (n,), optional
        Explicit thresholds (input unit) for every component.
    partition : {"auto", "time", "input"}
        Threshold partition; ``"auto"`` keeps the one with the smaller
        held-out error.
    bounds : None, "nonnegative" or "monotone"
        Least-squares constraints on the direct transfers (output l from
        input l): ``w >= 0``, or cumulative weights ``|S_j| >= 10 %`` of the
        secant slope (a strictly monotone, invertible PI). Cross-couplings are
        unconstrained.
    components : "auto", "all", str or dict
        ``"auto"``: every component starts as a PI and is simplified to absent
        or a pure gain where that costs at most 5 % of the output's training
        RMS error; ``"all"``: every component a PI; or explicit kinds
        ``"OUT:IN=pi|gain|none,..."`` (the others automatic).
    hold_out, train_fraction, skip_seconds
        See :func:`split_record` (``skip_seconds`` is the burn-in [s]).
    input_names, output_names : sequence of str, optional
        Names in the model (default: the column names of the first record).
    output_map : {"auto", "none", "deadzone"}
        Static output map per output after the PI, the modified PI of
        Kuhnen (K. Kuhnen, Eur. J. Control 9(4), 2003): ``y = S(Gamma(u)) + c``
        with S a monotone superposition of one-sided dead zones (knots at
        quantiles of the PI output), fitted by alternating least squares on
        the structure of the classical fit. ``"deadzone"`` always fits it,
        ``"none"`` never; ``"auto"`` keeps it when it lowers the held-out
        (else training) error and the measured loop is not point-symmetric
        (:func:`loop_asymmetry` above ``ASYMMETRY_NOTE_PERCENT``), or when
        it lowers that error by more than 10 %. A note says which was chosen.
        Least squares only.

    Returns
    -------
    RecordFit

    Raises
    ------
    IdentificationError
        On records that cannot be split or identified (the message names
        the record and the option that helps).
    """
    records = _as_records(records)
    if thresholds is None:
        n_hysterons = check_integer(n_hysterons, "n_hysterons", 1, MAX_HYSTERONS,
                                    IdentificationError)
    if method not in ("least-squares", "closed-form"):
        raise IdentificationError(
            f"method: expected 'least-squares' or 'closed-form', found {method!r}")
    if partition not in ("auto", "time", "input"):
        raise IdentificationError(f"partition: expected 'auto', 'time' or 'input', found {partition!r}")
    if bounds not in (None, "none", "nonnegative", "monotone"):
        raise IdentificationError(
            f"bounds: expected 'none', 'nonnegative' or 'monotone', found {bounds!r}")
    if bounds is not None and bounds != "none" and method == "closed-form":
        raise IdentificationError("bounds: only used by the least-squares method")
    bounds = None if bounds == "none" else bounds
    if output_map not in OUTPUT_MAPS:
        raise IdentificationError(f"output_map: expected one of {', '.join(OUTPUT_MAPS)}, "
                                  f"found {output_map!r}")
    if method == "closed-form":
        if output_map == "deadzone":
            raise IdentificationError("output_map: deadzone needs --method least-squares")
        output_map = "none"
    in_names = list(input_names or records[0].input_names)
    out_names = list(output_names or records[0].output_names)
    kinds0, auto = parse_components(components, in_names, out_names)
    pairs = [split_record(rec, method, hold_out, train_fraction, skip_seconds) for rec in records]
    records = [r for r, _ in pairs]
    splits = [s for _, s in pairs]
    for l, name in enumerate(out_names):  # a fit to it is meaningless, its % error infinite
        if not any(np.ptp(r.y[l][s.train]) > 0 for r, s in zip(records, splits) if s.train.any()):
            raise IdentificationError(
                f"{records[0].source}: output column {name!r}: the output is constant over the "
                f"training samples; expected the response to the excitation: add a record that "
                f"excites an input it depends on, or leave it out of --outputs")
    m = records[0].u.shape[0]
    tried = ["time", "input"] if partition == "auto" and thresholds is None else [partition]
    results, errors = {}, {}
    for part in tried:
        try:
            results[part] = _one_partition(records, splits, method, n_hysterons, thresholds, part,
                                           bounds, [list(r) for r in kinds0], auto,
                                           in_names, out_names, m)
        except (IdentificationError, HysteresisError) as exc:
            errors[part] = str(exc)
    if not results:
        raise IdentificationError(next(iter(errors.values())))
    scores = {part: res[1] for part, res in results.items()}
    best = min(scores, key=scores.get)
    fit, _ = results[best]
    if len(tried) > 1:
        basis = "held-out" if fit.validation is not None else "training"
        fit.notes.insert(0, "partition auto: chose " + best + " (" + ", ".join(
            f"{p} {scores[p]:.3g} %" if p in scores else f"{p} failed: {errors[p]}"
            for p in tried) + f" mean {basis} RMS of the output range)")
    fit.partition_scores = scores
    asym = _asymmetry_notes(records, splits, out_names)
    fit.output_map = "none"
    if output_map != "none":
        fit = _with_output_map(fit, output_map, bounds, scores[best], bool(asym))
    if fit.output_map == "none":
        fit.notes += asym
    fit.levels = level_errors(fit)
    return fit


def _with_output_map(fit, output_map, bounds, classical, asymmetric):
    """Fit the modified PI on the structure of ``fit``; keep it as ``output_map`` says."""
    try:
        model, _ = _fit_output_maps(fit, bounds)
    except (IdentificationError, HysteresisError) as exc:
        if output_map == "deadzone":
            raise IdentificationError(f"output map: {exc}") from None
        fit.notes.append(f"output map auto: none (the fit failed: {exc})")
        return fit
    predictions = [simulate_on_record(model, rec, s) for rec, s in zip(fit.records, fit.splits)]
    train = _window_metrics(fit.records, fit.splits, predictions, "train")
    val = _window_metrics(fit.records, fit.splits, predictions, "held_out")
    score = float(np.mean([v["rms_percent"] for v in (val or train)]))
    basis = "held-out" if val is not None else "training"
    numbers = (f"mean {basis} RMS {score:.3g} % of the output range with the map, "
               f"{classical:.3g} % without")
    if output_map == "auto":
        keep = score < classical and (asymmetric or score < (1 - MAP_GAIN) * classical)
        if not keep:
            fit.notes.append(f"output map auto: none ({numbers})")
            return fit
        why = "the loop is not point-symmetric; " if asymmetric else ""
        fit.notes.append(f"output map auto: chose deadzone, a monotone map after the PI "
                         f"(modified PI; {why}{numbers})")
    else:
        fit.notes.append(f"output map: deadzone ({numbers})")
    if val is not None and any(s.periodic and _one_branch_held(s) for s in fit.splits):
        fit.notes.append("output map: one closed loop trains on its ascending branch only, on "
                         "which the PI and the map can be traded against each other; the "
                         "held-out branch is extrapolated: record two periods or more, or train "
                         "on both branches with --hold-out none (hold_out = \"none\" in a "
                         "scenario)")
    fit.model, fit.predictions, fit.train, fit.validation = model, predictions, train, val
    fit.output_map = "deadzone"
    return fit


def _one_partition(records, splits, method, n, thresholds, partition, bounds, kinds, auto,
                   in_names, out_names, m):
    if partition == "auto":
        partition = "time"
    notes = []
    if method == "least-squares":
        r, used = zip(*[_thresholds(records, splits, k, n, partition, thresholds) for k in range(m)])
        if thresholds is None and any(u != partition for u in used):
            notes.append("inputs " + ", ".join(in_names[k] for k in range(m) if used[k] != partition)
                         + ": no complete branch, thresholds uniform in input")
        engine = _LeastSquares(records, splits, list(r), bounds)
    else:
        engine = _ClosedForm(records, splits, n, thresholds if thresholds is not None else partition)
    grid, offsets, prune_notes = _fit_structure(engine, kinds, auto, out_names, in_names,
                                                prune=bool(auto.any()))
    notes += prune_notes
    amplitude = np.zeros(m)
    low, high = np.full(m, np.inf), np.full(m, -np.inf)
    for rec, s in zip(records, splits):
        amplitude = np.maximum(amplitude, np.ptp(rec.u[:, s.train], axis=1) / 2.0)
        if s.train.any():
            low = np.minimum(low, rec.u[:, s.train].min(axis=1))
            high = np.maximum(high, rec.u[:, s.train].max(axis=1))
    amplitude = np.where(amplitude > 0, amplitude, 1.0)
    # the range's centre, where it is off 0 V by more than 1 % of the amplitude (a unipolar
    # stack's 0..100 V: 50 V), as the demagnetising cycle's (models/demagnetisation.py)
    centre = np.where(np.isfinite(low) & np.isfinite(high), 0.5 * (low + high), 0.0)
    centre = np.where(np.abs(centre) > 0.01 * amplitude, centre, 0.0)
    model = MultivariablePI(grid, in_names, out_names, amplitude, output_offset=offsets,
                            input_centre=centre)
    predictions = [simulate_on_record(model, rec, s) for rec, s in zip(records, splits)]
    train = _window_metrics(records, splits, predictions, "train")
    val = _window_metrics(records, splits, predictions, "held_out")
    score = float(np.mean([v["rms_percent"] for v in (val or train)]))
    structure = [["pi" if isinstance(c, PrandtlIshlinskii) else "none" if c is None else "gain"
                  for c in row] for row in grid]
    return RecordFit(model, method, "explicit" if thresholds is not None else partition, {},
                     structure, notes, records, splits, train, val, predictions), score


def identify_record(record, method="least-squares", n_hysterons=15, thresholds=None,
                    partition="auto", bounds=None, train_fraction=None, skip_seconds=None,
                    hold_out="auto", components="auto", output_map="auto"):
    """Single-record form of :func:`identify_records` (same options and result).

    Parameters
    ----------
    record : MultiRecord or Record
        The record, all m inputs and p outputs.
    method : {"least-squares", "closed-form"}
        Identification method.
    n_hysterons : int
        Hysterons per component.
    thresholds : array_like, shape (n,), optional
        Explicit thresholds (input unit, e.g. [V]) for every component.
    partition : {"auto", "time", "input"}
        Threshold partition.
    bounds : None, "nonnegative" or "monotone"
        Least-squares constraints on the direct transfers.
    train_fraction : float, optional
        Split at the reversal nearest to this fraction of the samples.
    skip_seconds : float, optional
        Burn-in [s].
    hold_out : {"auto", "none"}
        Whether trailing complete branches are held out for validation.
    components : "auto", "all", str or dict
        Component kinds, see :func:`parse_components`.
    output_map : {"auto", "none", "deadzone"}
        Static output map after the PI (modified PI), see :func:`identify_records`.

    Returns
    -------
    RecordFit
        As :func:`identify_records`.

    Raises
    ------
    IdentificationError
        As :func:`identify_records`.
    """
    return identify_records([record], method, n_hysterons, thresholds, partition, bounds,
                            components, hold_out, train_fraction, skip_seconds,
                            output_map=output_map)
