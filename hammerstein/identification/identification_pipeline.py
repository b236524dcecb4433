"""The identification pipeline from records: hysteresis, dynamics, creep, refit, dynamics again.

One function, :func:`identify_pipeline`, runs what ``hammerstein identify``
runs and what a scenario's ``identify = { records = "excitation", ... }``
table runs, with the same options (:class:`PipelineOptions`, the defaults of
``hammerstein identify``):

1. the hysteresis of the class ``model`` (``auto``: the classical PI, the
   Preisach model and the generalised PI are fitted, side by side in worker
   processes (:func:`~hammerstein.identification.concurrent_fits.fit_concurrently`,
   ``HAMMERSTEIN_WORKERS=1``: one after the other), and the one with the
   lowest held-out minor-loop error kept, the staircases' step levels joining
   the score when creep records are given; :func:`identify_hysteresis`);
2. with dynamics records, the linear dynamics G on the model's outputs
   (:func:`hammerstein.identification.record_identification.identify_record_dynamics`);
3. with creep records, the creep after the hysteresis and G
   (:func:`hammerstein.identification.record_identification.identify_record_creep`),
   the hysteresis refitted on the records with the creep removed
   (``v = (I + C)^-1 y``, ``creep_refits`` times) and the creep again;
4. with creep and dynamics, G again on the model's outputs through the
   identified creep (``G (I + C)`` has G(0) = I for G).

The result (:class:`IdentificationResult`) carries the fit, G and the creep,
and the tables a preset stores besides ``[model]`` (:meth:`IdentificationResult.tables`).

Length: the one pipeline both routes call, with the warnings it prints on what it fitted
(minor loops, dynamics, static gain, auto's ties); splitting it would split the defaults.
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from dataclasses import dataclass, field

import numpy as np

from hammerstein.models.amplifier import (amplifier_from_table, records_amplifier_table,
                                          records_input_range)
from hammerstein.models.creep import creep_to_table
from hammerstein.models.demagnetisation import (DEMAGNETISING_PERIODS,
                                                demagnetising_cycle_of_range)
from hammerstein.models.dynamics import discretize
from hammerstein.models.plant import HammersteinPlant
from hammerstein.identification.concurrent_fits import fit_concurrently, worker_count
from hammerstein.identification.defaults import PREISACH_LEVELS
from hammerstein.identification.creep_identification import remove_creep, step_level_errors
from hammerstein.identification.gpi_identification import identify_gpi_records
from hammerstein.models.hysteresis import MultivariablePI, play
from hammerstein.identification.preisach_identification import (SMOOTHING_START,
                                                                identify_preisach_records,
                                                                refit_on_every_level)
from hammerstein.identification._broadband_check import dynamics_advice
from hammerstein.identification.record_identification import (identify_record_creep, identify_record_dynamics,
                                                     identify_records, levels_part, split_record)
from hammerstein.exceptions import HysteresisError, IdentificationError
from hammerstein.simulation import linear_steps, preisach_steps

__all__ = ["PipelineOptions", "IdentificationResult", "identify_hysteresis", "identify_pipeline",
           "CLASS_LABEL", "GPI_PLAYS", "fit_class", "MINOR_LOOP_WARN_PERCENT", "minor_loop_warning",
           "DYNAMICS_FIT_WARN_PERCENT", "dynamics_fit_warning", "STATIC_GAIN_WARN",
           "static_gain_warning", "auto_tie_note", "AUTO_TIE", "classical_start_note"]

#: Words of each class in the notes.
CLASS_LABEL = {"classical": "classical PI", "generalized": "generalized PI"}
#: Play operators per component of ``model = "generalized"`` (and of auto's third class).
GPI_PLAYS = 16


@dataclass
class PipelineOptions:
    """The options of the pipeline, named and defaulted as ``hammerstein identify``'s.

    Parameters
    ----------
    method : {'least-squares', 'closed-form'}
        Classical PI fit.
    n : int or None
        Hysterons per component (None with explicit ``thresholds``).
    thresholds : list of float or None
        Explicit thresholds [input unit].
    partition : {'auto', 'time', 'input'}
    bounds : {'none', 'nonnegative', 'monotone'}
    components : str
        ``auto``, ``all`` or ``OUT:IN=KIND,...``.
    model : {'auto', 'classical', 'preisach', 'generalized'}
        The class (``auto``: the best on held-out data).
    threshold_spacing : {'uniform', 'power', 'auto'}
        Generalised PI thresholds.
    level_weighting : {'amplitude', 'none'}
        Generalised PI fit's rows: each amplitude level's weighted by
        ``A_max / A_level`` (default), or all alike.
    record_start : {'demagnetised', 'rest'}
        Generalised PI and Preisach: every record starts after the
        demagnetising cycle (default), or at rest (the plays at their rest
        value; the Preisach model's ideal demagnetised state).
    preisach_levels : int
        Levels of each input's Preisach grid.
    preisach_smoothing : 'auto' or float
        The Preisach density's smoothing weight lambda [-]: searched on the
        held-out records (``"auto"``, the least smoothing among tied
        scores), or this one.
    hold_out : {'auto', 'none'}
    output_map : {'auto', 'none', 'deadzone'}
    train_fraction, skip : float or None
        Held-out fraction; burn-in [s].
    order, max_order : int or None
        Order of G (None: chosen on held-out records).
    creep_refits : int or None
        Refits without the creep (None: 1 for a Preisach or generalised PI, 0
        for a classical PI).
    output_unit : str
        For the notes.
    name : str
        Name of the identified dynamics.
    """

    method: str = "least-squares"
    n: int | None = 15
    thresholds: list | None = None
    partition: str = "auto"
    bounds: str = "none"
    components: str = "auto"
    model: str = "auto"
    threshold_spacing: str = "uniform"
    level_weighting: str = "amplitude"
    record_start: str = "demagnetised"
    preisach_levels: int = PREISACH_LEVELS
    preisach_smoothing: object = "auto"
    hold_out: str = "auto"
    output_map: str = "auto"
    train_fraction: float | None = None
    skip: float | None = None
    order: int | None = None
    max_order: int | None = None
    creep_refits: int | None = None
    output_unit: str = "µm"
    name: str = "identified"


@dataclass
class IdentificationResult:
    """What :func:`identify_pipeline` identified.

    Parameters
    ----------
    fit : object
        The hysteresis fit (``model``, ``notes``, ``validation``, ``levels``,
        ``method``...) of :func:`identify_hysteresis`.
    dynamics : object or None
        The identified G (``identifier.system_``, ``tables``, ``summary``),
        the last one fitted (through the creep when there is one).
    creep : hammerstein.identification.creep_identification.CreepIdentifier or None
        The identified creep (``creeps_`` one per output).
    first_dynamics : object or None
        G fitted before the creep (the same as ``dynamics`` without creep).

    Attributes
    ----------
    model : MultivariablePI or MultivariableHysteresis
        The identified hysteresis model.
    """

    fit: object
    dynamics: object = None
    creep: object = None
    first_dynamics: object = field(default=None, repr=False)

    @property
    def model(self):
        """The identified hysteresis model (any class of :mod:`hammerstein.compensation.model_classes`)."""
        return self.fit.model

    def tables(self):
        """The preset tables besides ``[model]``: ``[dynamics]`` and ``[creep]`` when identified.

        Returns
        -------
        dict or None
            Tables for :func:`hammerstein.io.presets.save_model`'s ``extra``.
        """
        if self.dynamics is None and self.creep is None:
            return None
        extra = dict(self.dynamics.tables) if self.dynamics is not None else {}
        if "preset" in extra:      # the class identified, not always a PI
            kinds = {type(c).__name__ for row in getattr(self.model, "components", [])
                     for c in row if c is not None and not isinstance(c, (int, float))}
            label = ("Preisach" if "PreisachModel" in kinds and "GeneralizedPI" not in kinds
                     else "generalised-PI" if "GeneralizedPI" in kinds
                     and "PreisachModel" not in kinds
                     else "mixed" if {"PreisachModel", "GeneralizedPI"} <= kinds
                     else "classical PI")
            extra["preset"] = {**extra["preset"], "description": (
                f"{label} hysteresis identified from records + identified linear dynamics"
                + (" + identified creep" if self.creep is not None else ""))}
        if self.creep is not None:
            extra["creep"] = creep_to_table(self.creep.creeps_, self.model.output_names)
        return extra

    def plant(self, sampling_period, records=None, name="identified"):
        """The identified actuator as a plant, without writing and reading a preset.

        The plant :func:`hammerstein.io.presets.load_plant` builds from the
        file ``identify`` writes: the model, its creep (one
        :class:`~hammerstein.models.creep.Creep` per output) and its dynamics
        (the continuous G sampled at ``sampling_period``, zero-order hold).
        Given the records, the inputs' range and largest slew over them become
        the plant's ``amplifier`` (``source = "records"``) and the exact
        inverse's bound (``model.input_range``), as ``identify`` writes them.

        Parameters
        ----------
        sampling_period : float
            T [s] of the plant.
        records : sequence of MultiRecord, optional
            Every record identified on (hysteresis, broadband, staircases).
        name : str
            Plant name.

        Returns
        -------
        HammersteinPlant

        Raises
        ------
        HysteresisError
            On a sampling period that is not positive.

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> from hammerstein.io.presets import load_plant
        >>> res = IdentificationResult(SimpleNamespace(model=load_plant("rakotondrabe-2dof",
        ...                            dynamics=False).hysteresis))
        >>> res.plant(5e-5).is_static
        True
        """
        T = float(sampling_period)
        lin = None if self.dynamics is None else discretize(self.dynamics.continuous, T)
        creep = None if self.creep is None else list(self.creep.creeps_)
        plant = HammersteinPlant(self.model, T, lin, name=name, creep=creep)
        if records:
            names = list(self.model.input_names)
            table = records_amplifier_table(list(records), names)
            plant.amplifier = amplifier_from_table(table, names)
            self.model.input_range = records_input_range(table, names)
        return plant


#: a direct path's loop amplitude missed by more than this [%] on a level of the records (trained
#: or held out) gets :func:`minor_loop_warning`. Measured (30 level records per family): the
#: Preisach- and generalised-PI-type actuators' models miss by at most 0.55 %, a Bouc-Wen
#: family's (a memory no class identify fits) by 2.6-7.0 %, whose feedforward circles then
#: missed by 2.3-16 % of their radius
MINOR_LOOP_WARN_PERCENT = 1.5
#: ``identify`` warns when the identified dynamics fit the held-out broadband records below
#: this [%] (:func:`dynamics_fit_warning`; measured fits of records an actuator played as
#: written: 97-99 %).
DYNAMICS_FIT_WARN_PERCENT = 90.0
#: ``identify`` warns when the multisines' own static gain (the dynamics' unconstrained G(0))
#: departs from the identity by more than this [-] (:func:`static_gain_warning`; the outside
#: family's twenty actuators, records made together: 0.1-2.3 %; day-1 hysteresis and creep
#: records beside day-2 multisines of an actuator 4 % stronger on x: 8.5 %).
STATIC_GAIN_WARN = 0.05
#: ``auto``'s two best scores within this share of each other are a tie that the records'
#: noise decides: said, with how to choose (an outside Bouc-Wen stage scored 0.628 % and
#: 0.628 %, and records made again chose the other class, a 30 µm circle 7.75 vs 13.8 %).
AUTO_TIE = 0.02


def minor_loop_warning(fit, input_names, output_names):
    """A warning when the model misses the records' own loops: the actuator's class is none of
    identify's.

    The worst loop amplitude error (:func:`hammerstein.identification.record_identification.level_errors`)
    over the direct paths' levels (each output in the record of its own input), when above
    :data:`MINOR_LOOP_WARN_PERCENT`. ``hammerstein identify`` prints it on stderr, a scenario's
    ``identify = { records = "excitation" }`` as a warning of its cases.

    Parameters
    ----------
    fit : RecordFit
        With ``levels`` and ``splits`` (``excitation``: the input each record moves).
    input_names, output_names : list of str
        The model's names, in order; output l is driven by input l.

    Returns
    -------
    str or None
        One line without the ``warning:`` prefix; None when within the threshold or without
        levels.
    """
    source_input = {rec.source: input_names[s.excitation]
                    for rec, s in zip(fit.records, fit.splits)}
    worst = None
    for row in fit.levels:
        inp = source_input.get(row["source"])
        if inp is None or output_names.index(row["output"]) != input_names.index(inp):
            continue
        if worst is None or abs(row["amplitude_error_percent"]) > abs(worst["amplitude_error_percent"]):
            worst = row
    if worst is None or abs(worst["amplitude_error_percent"]) <= MINOR_LOOP_WARN_PERCENT:
        return None
    return (f"the model misses the loop amplitude of {Path(worst['source']).name}'s "
            f"{worst['percent']:.0f} % level by {worst['amplitude_error_percent']:+.3g} % on "
            f"{worst['output']} (its RMS error {worst['rms_percent']:.3g} % of the level's range; "
            f"above {MINOR_LOOP_WARN_PERCENT:g} %): the actuator's minor loops are none that the "
            f"model classes draw, and drives will miss loops of that size by as much or more "
            f"(smaller loops, and where a loop sits, are extrapolated); "
            f"`hammerstein learn` corrects a repeating reference on the measured response "
            f"(docs/hardware.md)")


def fit_class(fit):
    """The class name of a fit (``"classical"``, ``"preisach"`` or ``"generalized"``).

    Parameters
    ----------
    fit : object
        A fit of :func:`identify_hysteresis`.

    Returns
    -------
    str
    """
    return {"preisach": "preisach", "generalized-pi": "generalized"}.get(fit.method, "classical")


def _fit_rms(fit):
    """Largest held-out RMS error of an output (training when nothing is held out)."""
    reps = fit.validation or fit.train
    return max(float(r["rms"]) for r in reps) if reps else float("nan")


def _step_level_error(fit, recs):
    """Held-out step levels of the staircases: (RMS [% of range], RMS, largest [unit]).

    The model is simulated once on the staircases, for its creep and its levels;
    its outputs stay with the fit (``fit.staircase_outputs``, with the model they
    belong to; a worker hands them back with the fit) for the creep fitted after
    that model if ``auto`` chooses it.
    """
    outs = [fit.model.simulate(np.asarray(r.u, dtype=float))[0] for r in recs]
    fit.staircase_outputs = (fit.model, outs)
    creep = identify_record_creep(fit, recs, outputs=outs)
    errs = step_level_errors(fit.model, recs, creep.creeps_, outputs=outs)
    span = np.max([np.ptp(np.asarray(r.y, dtype=float), axis=1) for r in recs], axis=0)
    rel = np.concatenate([(e / span[:, None]).ravel() for e in errs])
    ab = np.concatenate([e.ravel() for e in errs])
    rel, ab = rel[np.isfinite(rel)], ab[np.isfinite(ab)]
    return (100 * float(np.sqrt(np.mean(rel ** 2))), float(np.sqrt(np.mean(ab ** 2))),
            float(np.max(np.abs(ab))))


def _fit_one_class(name, records, options, names, previous=None, provisional=False):
    """The fit of one class (``"classical"``, ``"preisach"`` or ``"generalized"``).

    ``previous``: a fit of the same class on similar records (the refit after the
    creep is removed); the Preisach smoothing search starts at its lambda.
    ``provisional``: the fit only serves to identify the creep, and the refit
    on the records with the creep removed replaces it; the Preisach model's
    lambda is then not searched but :data:`SMOOTHING_START` (the refit
    searches it from there).
    """
    if name == "classical":
        # the PI's plays fit the amplitude levels; the reversal curves after them serve the
        # Preisach density (and cost the classical fit a second on 20 s records, measured)
        records = _levels_records(records, options)
        return identify_records(
            records, options.method, options.n, options.thresholds,
            "time" if options.thresholds is not None and options.partition == "auto"
            else options.partition, options.bounds, options.components, options.hold_out,
            options.train_fraction, options.skip, *names, output_map=options.output_map)
    if name == "preisach":
        return identify_preisach_records(
            records, options.preisach_levels,
            options.preisach_smoothing if options.preisach_smoothing != "auto" else
            SMOOTHING_START if provisional else "auto",
            options.components, options.hold_out,
            options.train_fraction, options.skip, *names,
            smoothing_start=getattr(previous, "smoothing", None),
            record_start=options.record_start)
    return identify_gpi_records(
        records, GPI_PLAYS, options.components, options.hold_out, options.train_fraction,
        options.skip, *names, threshold_spacing=options.threshold_spacing,
        level_weighting=options.level_weighting, record_start=options.record_start)


def _levels_records(records, options):
    """The records cut after their amplitude levels (:func:`levels_part`); as given when a
    record cannot be split (the fit then says what is wrong with it)."""
    try:
        pairs = [split_record(r, options.method, options.hold_out, options.train_fraction,
                              options.skip) for r in records]
    except (IdentificationError, HysteresisError, ValueError, TypeError, AttributeError):
        return records
    cut, _, _ = levels_part([r for r, _ in pairs], [s for _, s in pairs])
    # a record left whole is passed on as given (split_record may have rotated a closed loop)
    return [c if c.u.shape[1] < r.u.shape[1] else r for r, c in zip(records, cut)]


def _class_and_stairs(name, records, options, names, creep_records):
    """One class of ``auto`` and its staircase score (or the exception that score raised)."""
    fit = _fit_one_class(name, records, options, names)
    stairs = None
    if creep_records:
        try:
            stairs = _step_level_error(fit, creep_records)
        except Exception as exc:      # noqa: BLE001 - raised by the caller if the score is used
            stairs = exc
    return fit, stairs


def _held_out_levels(records, options):
    """Whether the classical fit's split of the records holds out amplitude levels."""
    try:
        return any(lv["held_out"] for r in records for lv in split_record(
            r, options.method, options.hold_out, options.train_fraction, options.skip)[1].levels)
    except (IdentificationError, HysteresisError, ValueError, TypeError, AttributeError):
        return True           # the fits report what is wrong with the records


def _load_shared_kernels():
    """Load the compiled kernels several classes use (numba's on-disk cache) in this process.

    Called before the classes are forked into workers: each worker inherits
    them (and numba's code generator, initialised once) instead of loading
    them again; measured, a worker loaded the state-space and Preisach
    kernels a second and third time otherwise (10 cache loads instead of 7).
    """
    u = np.zeros(3)
    play(u, np.array([0.0, 1.0]))
    one = np.zeros((1, 1))
    linear_steps(np.zeros((1, 3)), (one, one, one, one), np.zeros(1))
    preisach_steps(u, np.array([-1.0, 0.0, 1.0]), np.array([1, 1, 1]), np.array([0, 1, 0]),
                   np.ones(3), np.zeros(3))


def _run(tasks):
    """:func:`fit_concurrently`, here when this process may not start others or a worker died."""
    # a daemonic process (a multiprocessing.Pool worker) may not start processes
    daemon = multiprocessing.current_process().daemon
    if not daemon and worker_count(len(tasks)) > 1:
        _load_shared_kernels()
    out = fit_concurrently(tasks, 1 if daemon else None)
    if any(isinstance(r, BrokenProcessPool) for r in out.values()):
        out = fit_concurrently(tasks, workers=1)
    return out


def _auto_fits(records, options, names, creep_records):
    """``auto``'s three classes fitted side by side (:func:`fit_concurrently`).

    The classes are independent: each worker fits one and scores it on the
    staircases. Records without held-out amplitude levels (one amplitude) fit
    the classical PI alone, as before. As one after the other, the Preisach
    model and the generalised PI are kept only when the classical fit holds
    out amplitude levels, and
    their identification errors are notes, not failures; any other error is
    raised. Returns ``(fits, stairs, errors)``.
    """
    tasks = {k: (_class_and_stairs, (k, records, options, names, creep_records), {})
             for k in ("classical", "preisach", "generalized")}
    if _held_out_levels(records, options):
        out = _run(tasks)
    else:         # records of one amplitude: the classical PI alone (the others would be dropped)
        out = _run({"classical": tasks["classical"]})
        if not isinstance(out["classical"], Exception) and \
                any(r["held_out"] for r in out["classical"][0].levels):
            out.update(_run({k: tasks[k] for k in ("preisach", "generalized")}))
    if isinstance(out["classical"], Exception):
        raise out["classical"]
    fits, stairs, errors = {}, {}, {}
    fits["classical"], stairs["classical"] = out["classical"]
    if any(r["held_out"] for r in fits["classical"].levels):
        for k in ("preisach", "generalized"):
            if isinstance(out[k], (IdentificationError, HysteresisError)):
                errors[k] = str(out[k])
            elif isinstance(out[k], Exception):
                raise out[k]
            else:
                fits[k], stairs[k] = out[k]
    return fits, stairs, errors


def identify_hysteresis(records, options, names, model_class=None, creep_records=None,
                        previous=None, provisional=False):
    """The hysteresis fit of ``options.model``: one class, or the best on held-out data.

    ``auto`` judges the classes on the held-out minor loops of the
    multi-amplitude records and, with ``creep_records``, also on the step
    levels of the staircases (held out: the hysteresis is not fitted on
    them), by the geometric mean of the two; ``model_class`` forces one class
    (a refit keeps the chosen one).

    Parameters
    ----------
    records : list of hammerstein.io.datafiles.MultiRecord
        The hysteresis records.
    options : PipelineOptions
    names : (list of str, list of str)
        Input and output names of the model.
    model_class : str, optional
        Forces a class.
    creep_records : list of MultiRecord, optional
        Staircases (``auto``'s second score).
    previous : object, optional
        A fit of ``model_class`` on similar records (the refit after the creep
        is removed): the Preisach model's smoothing search starts at its lambda
        (:class:`~hammerstein.identification.preisach_identification.PreisachIdentifier`
        ``smoothing_start``).
    provisional : bool
        A fit of one class that the refit after the creep is removed will
        replace (``auto`` ignores it: it compares the classes on these fits).
        The Preisach model's lambda is then not searched (:func:`_fit_one_class`).

    Returns
    -------
    object
        The fit (:func:`hammerstein.identification.record_identification.identify_records`,
        :func:`~hammerstein.identification.preisach_identification.identify_preisach_records`
        or :func:`~hammerstein.identification.gpi_identification.identify_gpi_records`),
        its notes starting with the choice of ``auto``.

    Raises
    ------
    IdentificationError, HysteresisError
        Records no class can be fitted on.
    """
    choice = model_class or options.model
    if choice == "auto":
        fits, stairs, errors = _auto_fits(records, options, names, creep_records)
    else:
        fits, stairs, errors = {choice: _fit_one_class(choice, records, options, names,
                                                        previous, provisional)}, {}, {}
    if len(fits) == 1:
        fit = next(iter(fits.values()))
        if choice == "auto":
            why = ("; ".join(f"{k} failed: {v}" for k, v in errors.items()) if errors else
                   "no held-out amplitude level (minor loop) to compare the classes on")
            fit.notes.insert(0, f"model auto: {CLASS_LABEL.get(next(iter(fits)), next(iter(fits)))} "
                                f"({why})")
        return fit
    loops = {k: f.minor_loop_error for k, f in fits.items()}
    stairs = {k: v for k, v in stairs.items() if k in fits} if creep_records else {}
    for k in stairs:
        if isinstance(stairs[k], Exception):
            raise stairs[k]
    if stairs:   # both held out; the geometric mean weighs each by its ratio between classes
        scores = {k: float(np.sqrt(loops[k] * stairs[k][0])) for k in fits}
        rule = ("lowest geometric mean of the held-out minor-loop RMS error (Euclidean, all "
                "outputs, % of each level's range) and the staircases' step-level RMS error "
                "(% of each output's range; --creep-records, not used to fit the hysteresis)")
    else:
        scores = loops
        rule = ("lowest mean held-out minor-loop RMS error (Euclidean, all outputs, % of each "
                "level's range)")
    best = min(scores, key=lambda k: scores[k])
    fit = fits[best]
    lines = [f"model auto: chose {best} ({rule})"]
    tie = auto_tie_note(scores)
    if tie:
        lines.append(tie)
    for k, f in fits.items():
        worst = max(v["rms_percent"] for v in f.validation) if f.validation else float("nan")
        text = (f"model auto: {k} {loops[k]:.3g} % mean held-out minor-loop RMS, Euclidean "
                f"(largest held-out RMS of an output {worst:.3g} % of its range)")
        if stairs:
            pct, rms, big = stairs[k]
            text += (f"; staircase step levels (model + its creep, from rest) RMS "
                     f"{rms:.3g} {options.output_unit} = {pct:.3g} % of the range, largest "
                     f"{big:.3g} {options.output_unit}; score {scores[k]:.3g} %")
        lines.append(text)
    fit.notes[:0] = lines
    return fit


def auto_tie_note(scores):
    """The note on ``auto``'s choice when its two best classes tie, or None.

    Parameters
    ----------
    scores : dict of str to float
        Each class's score (lower is better) [% of the range].

    Returns
    -------
    str or None
        One line when the second-best score is within :data:`AUTO_TIE` of
        the best (relative).

    Examples
    --------
    >>> auto_tie_note({"preisach": 0.628, "generalized": 0.629}).split(",")[0]
    'model auto: preisach and generalized score within 2 % of each other'
    >>> auto_tie_note({"preisach": 0.60, "generalized": 0.70}) is None
    True
    """
    ranked = sorted(scores, key=lambda k: scores[k])
    if len(ranked) < 2 or not scores[ranked[1]] <= scores[ranked[0]] * (1 + AUTO_TIE):
        return None
    return (f"model auto: {ranked[0]} and {ranked[1]} score within {100 * AUTO_TIE:g} % of "
            f"each other, a tie that the records' noise decides (records made again may choose "
            f"the other): their drives can differ by more than their scores; identify both "
            f"with --model and compare them on the actuator (hammerstein evaluate)")


def _dynamics(options, fit, dynamics_records, creep=None, first=None):
    """G on the model's outputs (through ``creep`` when given).

    With ``first`` (G fitted before the creep) and no order given, the order
    searched there is kept: the creep changes G's inputs by a few % at low
    frequency, below the broadband band the order is chosen on, so the search
    is not repeated; the summary keeps the first search's candidates.
    """
    search = lambda order: identify_record_dynamics(  # noqa: E731
        fit, dynamics_records, name=options.name, creep=creep, order=order,
        max_order=options.max_order)
    if first is None or options.order is not None:
        return search(options.order)
    try:
        dyn = search(int(first.summary["candidate_order"]))
    except IdentificationError:         # that order rejected through the creep: search again
        return search(None)
    dyn.summary["candidates"] = first.summary["candidates"]
    dyn.summary["chosen_on"] = (f"{first.summary['chosen_on']} (order searched on the model "
                                f"outputs before the creep was identified, then kept)")
    return dyn


def _creep(fit, creep_records, dyn):
    """The creep after ``fit``'s model and G, on its staircase outputs if ``auto`` scored it."""
    model, outs = getattr(fit, "staircase_outputs", (None, None))   # auto's score's
    if model is not fit.model or outs is None or \
            [np.shape(o) for o in outs] != [np.shape(r.y) for r in creep_records]:
        outs = None
    return identify_record_creep(fit, creep_records,
                                 None if dyn is None else dyn.identifier.system_, outputs=outs)


def _creep_refits(options, classical):
    """``options.creep_refits``, or its default: none for a classical PI, one otherwise."""
    if options.creep_refits is not None:
        return options.creep_refits
    return 0 if classical else 1


def _refit_without_creep(options, records, names, fit, creep, dyn, creep_records):
    """Hysteresis refitted on the records with the identified creep removed, then creep again.

    The hysteresis records carry creep (y = (I + C) v, v = H(u)); a first
    fit takes it for hysteresis. With the creep identified from the
    staircases, v = (I + C)^-1 y is computed exactly from the records
    (:func:`hammerstein.identification.creep_identification.remove_creep`), the
    hysteresis is refitted on v, and the creep is fitted again after the new
    model; ``creep_refits`` times.
    """
    refits = _creep_refits(options, isinstance(fit.model, MultivariablePI))
    if options.creep_refits is None:
        if refits == 0:
            fit.notes.append("creep refit: none for a classical PI (the default; --creep-refits N "
                             "refits it on the records with the creep removed)")
    for i in range(refits):
        before = _fit_rms(fit)
        clean = remove_creep(records, creep.creeps_, fit.model.output_offset)
        chosen = [note for note in fit.notes if note.startswith("model auto")]
        fit = identify_hysteresis(clean, options, names, fit_class(fit), creep_records, fit)
        fit.notes[:0] = chosen
        if i == refits - 1:          # the model kept: on every level (the creep after it)
            fit = refit_on_every_level(fit, options.preisach_levels)
        creep = _creep(fit, creep_records, dyn)
        fit.notes.append(f"creep refit {i + 1}: hysteresis refitted on the records with the "
                         f"identified creep removed (v = (I + C)^-1 y); held-out RMS "
                         f"{before:.3g} -> {_fit_rms(fit):.3g} {options.output_unit} (largest output)")
    return fit, creep


def identify_pipeline(records, options=None, names=None, dynamics_records=None, creep_records=None,
                      progress=None):
    """Hysteresis, dynamics and creep from records: what ``hammerstein identify`` writes.

    Parameters
    ----------
    records : list of hammerstein.io.datafiles.MultiRecord
        Hysteresis records (e.g. the decreasing-amplitude sines of
        ``hammerstein excitation``), inputs [V], outputs [µm].
    options : PipelineOptions, optional
        Default: ``hammerstein identify``'s defaults.
    names : (list of str, list of str), optional
        Input and output names (default the records').
    dynamics_records : list of MultiRecord, optional
        Broadband records (multisines, the last ones held out to choose the
        order): G is identified when given.
    creep_records : list of MultiRecord, optional
        Staircases: the creep is identified when given.
    progress : callable, optional
        Called with one line as each phase starts (the fits take from seconds to minutes on
        long records: the command line says where it is on a terminal).

    Returns
    -------
    IdentificationResult

    Raises
    ------
    IdentificationError, HysteresisError, DynamicsError
        Records that cannot be fitted.
    """
    options = PipelineOptions() if options is None else options
    if names is None:
        names = (list(records[0].input_names), list(records[0].output_names))
    creep_records = list(creep_records) if creep_records else None
    # a single class refitted after the creep: its first fit only serves the creep's
    provisional = (bool(creep_records) and options.model != "auto"
                   and _creep_refits(options, options.model == "classical") > 0)
    say = progress or (lambda line: None)
    n = sum(r.n_samples for r in records)
    say(f"fitting the hysteresis ({'every model class' if options.model == 'auto' else options.model}"
        f") on {len(records)} record(s), {n} samples")
    fit = identify_hysteresis(records, options, names, creep_records=creep_records,
                              provisional=provisional)
    if not (creep_records and _creep_refits(options, isinstance(fit.model, MultivariablePI))):
        fit = refit_on_every_level(fit, options.preisach_levels)   # the model kept: every level
    dyn = creep = None
    if dynamics_records:
        say(f"identifying the dynamics G from {len(dynamics_records)} broadband record(s)")
        dyn = _dynamics(options, fit, dynamics_records)
    first = dyn
    if creep_records:
        say(f"identifying the creep from {len(creep_records)} staircase(s), then the hysteresis "
            f"again without it")
        creep = _creep(fit, creep_records, dyn)
        fit, creep = _refit_without_creep(options, records, names, fit, creep, dyn, creep_records)
        if dyn is not None:   # G again, on the model outputs through the creep: G(0) = I for G (I + C)
            say("identifying the dynamics G again, through the creep")
            dyn = _dynamics(options, fit, dynamics_records, creep.creeps_, first)
    note = classical_start_note(fit.model, fit.records, options.record_start)
    if note:
        fit.notes.append(note)
    return IdentificationResult(fit, dyn, creep, first)


def classical_start_note(model, records, record_start="demagnetised"):
    """Where a classical PI model's plays start after the demagnetising cycle, or None.

    The Preisach and generalised-PI models start where ``demagnetise.csv`` leaves their
    hysterons (``record_start``); a classical PI identified from records keeps its plays
    at 0. The cycle's crests, decreasing by ``A / P`` per period, leave an actuator's play
    of threshold r on a sawtooth in r of period ``A / P`` within ``A / (4 P)`` of 0 (0.25 V
    at 20 V in 20 periods, :func:`~hammerstein.models.hysteresis.cycle_play_states`).
    Each of the model's plays stands for the actuator's thresholds around its own (15
    over the range: cells about 1.3 V wide at 20 V), over which the sawtooth averages to
    within 0.04 V of 0; the exact state at the model's thresholds would be another
    sawtooth's sample, and measured on a classical-type actuator whose thresholds are not
    the model's, it moved a 15 µm circle's error from 2.60 to 2.79 % of the radius.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        The kept model.
    records : list of MultiRecord
        The hysteresis records (inputs [V]: each input's range is the cycle's).
    record_start : {'demagnetised', 'rest'}
        What the records started from.

    Returns
    -------
    str or None
        One line for the fit's notes, for a classical PI after the cycle.
    """
    if not isinstance(model, MultivariablePI) or record_start != "demagnetised":
        return None
    lo = np.min([r.u.min(axis=1) for r in records], axis=0)
    hi = np.max([r.u.max(axis=1) for r in records], axis=0)
    shifts = [f"{name} {a / (4 * DEMAGNETISING_PERIODS):.3g} V"
              for name, (a, _) in zip(model.input_names,
                                      (demagnetising_cycle_of_range(l, h) for l, h in zip(lo, hi)))
              if a > 0]
    if not shifts:
        return None
    return ("classical PI: its plays start at 0; demagnetise.csv leaves an actuator's plays "
            f"on a sawtooth over the threshold within A / (4 P) of 0 ({', '.join(shifts)}), "
            "which averages to about 0 over each of the model's threshold cells "
            "(docs/identification.md, 'Every record starts demagnetised')")


def _static_gain_departure(summary):
    """``(G, G - I, l, k)`` of the largest entry of the unconstrained G(0) beyond
    :data:`STATIC_GAIN_WARN` from the identity, where identify imposed G(0) = I; else None."""
    G = summary.get("dc_gain_unconstrained") if summary else None
    if G is None or not summary.get("unit_dc_gain", True):
        return None
    G = np.asarray(G, dtype=float)
    if G.ndim != 2 or G.shape[0] != G.shape[1] or not np.all(np.isfinite(G)):
        return None
    dev = G - np.eye(G.shape[0])
    l, k = np.unravel_index(int(np.argmax(np.abs(dev))), dev.shape)
    return None if abs(dev[l, k]) <= STATIC_GAIN_WARN else (G, dev, l, k)


def dynamics_fit_warning(summary, conditions=None, unit="µm"):
    """A warning when the identified dynamics do not fit the held-out broadband records.

    The fit is ``100 (1 - ||y - y_model|| / ||y - mean y||)`` on the records held out from
    the order's choice (``held_out_fit_percent`` of the dynamics' summary, the fit of
    Ljung, *System Identification*, 2nd ed., 1999, Section 16.4). Below
    :data:`DYNAMICS_FIT_WARN_PERCENT` the warning names what the records show
    (``conditions``, :func:`hammerstein.identification._broadband_check.dynamics_advice`):
    a noise that caps the fit of any model, a first mode close to the Nyquist frequency,
    or, when neither shows and the multisines were not scaled down to a slew rate, an
    amplifier slower than them (it slew-limits them) or one that clipped them; but when
    the unconstrained G(0) shows the hysteresis model's gain on the multisines off
    (:func:`static_gain_warning`), that instead. ``compensate`` would then invert dynamics
    that are not the actuator's.

    Parameters
    ----------
    summary : dict
        The identified dynamics' summary (``held_out_fit_percent`` [%], ``modes``).
    conditions : dict, optional
        :func:`hammerstein.identification._broadband_check.broadband_conditions` of the
        broadband records (without it: the amplifier's limits are the advice).
    unit : str
        Output unit.

    Returns
    -------
    str or None
        One line without the ``warning:`` prefix; None when the fit reaches the threshold or
        was not measured.

    Examples
    --------
    >>> dynamics_fit_warning({"held_out_fit_percent": 98.2}) is None
    True
    >>> dynamics_fit_warning({"held_out_fit_percent": 16.0})[:40]
    'the identified dynamics fit the held-out'
    >>> dynamics_fit_warning({"held_out_fit_percent": 89.6, "unit_dc_gain": True,
    ...                       "dc_gain_unconstrained": [[0.96, 0.0], [0.0, 0.835]]})[154:210]
    "the hysteresis model draws the multisines' small reversa"
    """
    fit = summary.get("held_out_fit_percent") if summary else None
    if fit is None or not np.isfinite(fit) or fit >= DYNAMICS_FIT_WARN_PERCENT:
        return None
    head = (f"the identified dynamics fit the held-out broadband records at only {fit:.3g} % "
            f"(below {DYNAMICS_FIT_WARN_PERCENT:g} %), and compensate would invert dynamics "
            f"that are not the actuator's: ")
    advice = dynamics_advice(summary, conditions, unit) if conditions is not None else []
    generic = ("the records may not hold what the actuator received (an amplifier slower than "
               "the multisines, or one that clipped them); record again within the amplifier's "
               "limits (hammerstein excitation --slew-rate, docs/records.md)")
    if _static_gain_departure(summary) is not None and advice in ([], [generic]):
        # the hysteresis model's gain on the multisines is off (the static-gain warning): that,
        # not the amplifier, is what the records show (a Bouc-Wen stage outside the model
        # classes fitted at 89.6 % with exact records and G(0) unconstrained 0.835)
        return head + ("the hysteresis model draws the multisines' small reversals with "
                       "another gain than the records' loops (the static-gain warning below), "
                       "which G cannot correct at every frequency; the loops of such an "
                       "actuator are none the model classes draw, and learn corrects a "
                       "repeating reference on the measured response")
    if not advice:
        return head + generic
    return head + "; ".join(advice)


def static_gain_warning(summary, output_names, input_names):
    """A warning when the multisines' static gain is not the hysteresis model's.

    The dynamics G are fitted on the hysteresis model's outputs for the
    multisines' inputs, so that the records' own G(0) (unconstrained, in the
    summary) is the identity when the multisines and the hysteresis records
    show the same actuator; identify then imposes ``G(0) = I`` (the static
    gain belongs to the hysteresis model). An entry of the unconstrained G(0)
    more than :data:`STATIC_GAIN_WARN` from the identity's is an actuator
    that changed between the records (temperature, load, another session's
    records mixed with these), or multisines played through another gain.

    Parameters
    ----------
    summary : dict
        The identified dynamics' summary (``dc_gain_unconstrained``, (p, p)
        [-], rows outputs, columns the hysteresis model's outputs through the
        inputs; ``unit_dc_gain``).
    output_names, input_names : sequence of str
        Names for the line.

    Returns
    -------
    str or None
        One line without the ``warning:`` prefix; None within the tolerance,
        or when G(0) was kept as identified (not imposed).

    Examples
    --------
    >>> static_gain_warning({"dc_gain_unconstrained": [[1.012, 0.0], [0.0, 0.994]],
    ...                      "unit_dc_gain": True}, ["x", "y"], ["ux", "uy"]) is None
    True
    >>> static_gain_warning({"dc_gain_unconstrained": [[1.085, 0.0], [0.0, 1.015]],
    ...                      "unit_dc_gain": True}, ["x", "y"], ["ux", "uy"])[:83]
    'the multisines show 8.5 % more static gain on x from ux than the hysteresis records'
    >>> static_gain_warning({"dc_gain_unconstrained": [[1.0, 0.0], [-0.326, 1.0]],
    ...                      "unit_dc_gain": True}, ["x", "y"], ["ux", "uy"])[47:112]
    '-0.326 from ux to y that the hysteresis records do not show (G(0)'
    """
    found = _static_gain_departure(summary)
    if found is None:
        return None
    G, dev, l, k = found
    if l == k:
        what = (f"{100 * abs(dev[l, k]):.3g} % {'more' if dev[l, k] > 0 else 'less'} static "
                f"gain on {output_names[l]} from {input_names[k]} than the hysteresis records")
    else:
        what = (f"a static cross-coupling of {dev[l, k]:.3g} from {input_names[k]} to "
                f"{output_names[l]} that the hysteresis records do not show")
    return (f"the multisines show {what} (G(0) unconstrained "
            f"{G[l, k]:.4g}, more than {100 * STATIC_GAIN_WARN:g} % from the identity): either "
            f"the actuator changed between the records (temperature, load, another session: "
            f"record them all again together, hammerstein excitation), or, on records made "
            f"together, the hysteresis model draws the multisines' many small reversals with "
            f"another gain than the actuator's (the level errors above show how it draws small "
            f"loops); identify imposes G(0) = I, the hysteresis records' gain, and `learn` "
            f"corrects what that leaves on a repeating reference")
