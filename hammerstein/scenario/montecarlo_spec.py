"""Monte-Carlo studies: the ``[[sweeps]] kind = "monte-carlo"`` tables, their checks, the study.

:func:`validate_montecarlo` checks a scenario whose sweeps are all Monte-Carlo
studies (every problem listed at once, naming the field) and returns a
:class:`MonteCarloScenario` of :class:`MonteCarloStudy` objects; the budgets
(:data:`MAX_RUNS`, :data:`MAX_RUN_SAMPLES`, :func:`max_study_samples`) are
enforced here, before anything runs. The study's syntax and semantics:
:mod:`hammerstein.scenario.montecarlo`, which re-exports every public name.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hammerstein.signals import references as refs
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.core.files import confined_path
from hammerstein.exceptions import PresetError
from hammerstein.io.presets import (dynamics_from_table, load_model, load_plant, read_toml,
                                    resolve_preset)
from hammerstein.core.schema import (Field, Invalid, check_table, choice, integer, kind_problem,
                                     known_kind, name_field, number, short_repr, string)
from hammerstein.scenario.feedback_table import check_feedback_table
from hammerstein.scenario.montecarlo_draw import oscillating_modes
from hammerstein.compensation.model_classes import kind_problem as class_kind_problem
from hammerstein.scenario.registry import COMPENSATORS, class_problems, model_file_dynamics
from hammerstein.scenario.schema import MAX_NAME, NAME, ScenarioError, TOP


__all__ = ["MonteCarloStudy", "MonteCarloScenario", "is_montecarlo", "validate_montecarlo",
           "max_study_samples", "MAX_RUNS", "MAX_RUN_SAMPLES"]

#: Budget: runs (cases x frequencies) per study.
MAX_RUNS = 100_000_000
#: Budget: samples of one run (reference length).
MAX_RUN_SAMPLES = 200_000
#: Budget: samples of a whole study (cases x the runs' samples), about 13 min of CPU at the
#: batch kernel's ~40 ns a sample; raised with the environment variable below. Off the batch
#: kernel the budget is the same CPU time (:func:`sample_cost`).
DEFAULT_STUDY_SAMPLES = 20_000_000_000
STUDY_SAMPLES_ENV = "HAMMERSTEIN_MAX_STUDY_SAMPLES"


#: CPU time [s] of one sample on the fused batch kernel (a classical multivariable PI plant
#: under an inverse multiplicative compensator).
KERNEL_SAMPLE_S = 40e-9
#: CPU time [s] of one sample of a plant the batch kernel cannot step, per 1000 states of its
#: hysteresis (measured about 0.9 us a sample for a 2x2 Preisach plant of 1046 states), at least
#: :data:`DRIVE_SAMPLE_S`.
STATE_SAMPLE_S = 1e-6
DRIVE_SAMPLE_S = 0.3e-6


def sample_cost(plant, compensator):
    """CPU time [s] a study spends on one sample of one run (for its budget).

    Parameters
    ----------
    plant : HammersteinPlant
        The nominal plant.
    compensator : dict
        The ``[compensator]`` table.

    Returns
    -------
    float
        :data:`KERNEL_SAMPLE_S` on the fused batch kernel (a classical
        multivariable PI plant under a batchable kind), else
        ``max(DRIVE_SAMPLE_S, STATE_SAMPLE_S * n_hysterons / 1000)``: each
        drawn plant steps the nominal drive on its own.
    """
    kind = compensator.get("kind", "multivariable") if isinstance(compensator, dict) else None
    entry = COMPENSATORS.get(kind)
    if plant.packable and isinstance(plant.hysteresis, MultivariablePI) and entry is not None \
            and entry.batchable:
        return KERNEL_SAMPLE_S
    return max(DRIVE_SAMPLE_S, STATE_SAMPLE_S * plant.hysteresis.n_hysterons / 1000)


def max_study_samples():
    """Largest number of samples one Monte-Carlo study may simulate.

    Returns
    -------
    int
        ``HAMMERSTEIN_MAX_STUDY_SAMPLES`` when it is a positive integer (ASCII
        digits), else :data:`DEFAULT_STUDY_SAMPLES`.
    """
    text = os.environ.get(STUDY_SAMPLES_ENV, "").strip()
    if text.isascii() and text.isdigit() and int(text) > 0:
        return int(text)
    return DEFAULT_STUDY_SAMPLES
DISTRIBUTIONS = ("normal", "uniform", "lognormal")
VARIED = ("weights", "cross_coupling", "natural_frequency", "damping_ratio")


#: Largest relative sd of a varied quantity, per distribution: beyond 100 % a normal or
#: uniform factor is often negative (clipped at the smallest factor); a lognormal one of 10
#: (sigma 2.15) already spans five decades at three sigma. An outside check's 50 and 1e6 ran,
#: and the report quoted 5000 % and 1e+08 %.
MAX_RELATIVE_SD = {"normal": 1.0, "uniform": 1.0, "lognormal": 10.0}
#: Largest sensor noise sd [µm] of a study (1e9 µm ran, its quantiles about 1e9 µm).
MAX_NOISE_SD = 1000.0


def _noise_sd(v):
    x = number("µm", 0, exclusive=False)(v)
    if x > MAX_NOISE_SD:
        raise Invalid(f"expected a sensor noise sd from 0 to {MAX_NOISE_SD:g} µm, found "
                      f"{short_repr(v)}")
    return x


# -- validation --------------------------------------------------------------------------
def _distribution(v):
    problems = []
    c = check_table(v, {"relative_sd": Field(number("", 0, exclusive=False), required=True),
                        "distribution": Field(choice(*DISTRIBUTIONS), default="normal")},
                    "", problems, "")
    if problems:
        raise Invalid("; ".join(q.lstrip(": ") for q in problems))
    cap = MAX_RELATIVE_SD[c["distribution"]]
    if c["relative_sd"] > cap:
        raise Invalid(f"relative_sd: expected a relative sd from 0 to {cap:g} for a "
                      f"{c['distribution']} factor (a fraction: 0.05 is 5 %), found "
                      f"{short_repr(v['relative_sd'])}")
    return c


def _noise(v):
    problems = []
    c = check_table(v, {"sd": Field(_noise_sd, required=True)}, "", problems, "")
    if problems:
        raise Invalid("; ".join(q.lstrip(": ") for q in problems))
    return c


VARY = {**{k: Field(_distribution) for k in VARIED}, "noise": Field(_noise)}


def _loop_noise(data):
    """Whether a study's [feedback] table gives its loop a sensor noise, seeded per case
    (what makes its cases differ with nothing in [sweeps.vary])."""
    fb = data.get("feedback")
    sensor = fb.get("sensor") if isinstance(fb, dict) else None
    noise = sensor.get("noise_nm", 0.0) if isinstance(sensor, dict) else 0.0
    return isinstance(noise, (int, float)) and not isinstance(noise, bool) and noise > 0


def _frequencies(v):
    if (isinstance(v, list) and v and all(isinstance(f, (int, float)) and not isinstance(f, bool)
                                          and math.isfinite(f) and f > 0 for f in v)
            and len(set(v)) == len(v)):
        return [float(f) for f in v]
    raise Invalid(f"expected a non-empty list of distinct positive frequencies [Hz], found {v!r}")


SWEEP = {
    "kind": Field(choice("monte-carlo"), required=True),
    "name": Field(name_field(), required=True),
    "description": Field(string()),
    "cases": Field(integer(1, MAX_RUNS), required=True),
    "frequencies": Field(_frequencies, required=True),
    "reference": Field(lambda v: v, required=True),
    "settle_periods": Field(number("periods", 0, exclusive=False), default=1.0),
    "vary": Field(lambda v: v, default={}),
    "chunk": Field(integer(1, 100_000)),
}


def is_montecarlo(data):
    """Whether a parsed scenario file is a Monte-Carlo study.

    Parameters
    ----------
    data : dict
        The parsed TOML file.

    Returns
    -------
    bool
        True when it has ``[[sweeps]]`` tables, one of them with
        ``kind = "monte-carlo"``.
    """
    sweeps = data.get("sweeps")
    return isinstance(sweeps, list) and any(isinstance(s, dict) and s.get("kind") == "monte-carlo"
                                            for s in sweeps)


@dataclass
class MonteCarloStudy:
    """One ``[[sweeps]] kind = "monte-carlo"`` table, ready to run (picklable).

    Parameters
    ----------
    name : str
    description : str
    cases : int
        Number of drawn plants.
    seed : int
        The scenario's ``seed``.
    frequencies : list of float
        [Hz].
    references : list of numpy.ndarray, each shape (p, n_samples_j)
        Reference per frequency [µm].
    period_samples : list of int
        Samples per period, per frequency.
    settle_periods : float
    vary : dict
        Validated ``[sweeps.vary]``: ``{quantity: {relative_sd,
        distribution}}`` and optionally ``noise = {sd}``.
    plant : HammersteinPlant
        The nominal plant.
    modes : tuple or None
        ``(natural_frequency [Hz], damping_ratio)`` arrays of shape (n_modes,) of
        the nominal bending modes, or the oscillating modes of state-space
        dynamics (:func:`~hammerstein.scenario.montecarlo_draw.oscillating_modes`);
        None for a static plant.
    modal : bool
        True when ``modes`` are those of state-space dynamics (varied mode
        by mode in their eigenbasis,
        :func:`~hammerstein.scenario.montecarlo_draw.scaled_modes`).
    compensator : object or None
        Built by :func:`run_montecarlo_scenario` from the nominal model.
    chunk : int or None
        Plants per chunk (the sweep's ``chunk``; None: :data:`CHUNK_CASES`
        here, :func:`auto_chunk` on dask).
    loop : tuple or None
        With ``[feedback]``: the arguments of
        :class:`hammerstein.compensation.feedback.FeedbackLoop` after the
        plant (controller with its reference filter, sensor, amplifier,
        anti-windup, tracking time, ``reference_filter=False``), designed on
        the nominal plant.
    feedforward : list of numpy.ndarray or None
        With ``[feedback]``: the compensator's voltages per frequency, shape
        (m, n_samples_j) [V] (the same for every drawn plant).
    """

    name: str
    description: str
    cases: int
    seed: int
    frequencies: list
    references: list
    period_samples: list
    settle_periods: float
    vary: dict
    plant: object
    modes: tuple | None
    modal: bool = False
    compensator: object = None
    chunk: int | None = None
    loop: tuple | None = None
    feedforward: list | None = None

    @property
    def columns(self):
        """``(channel, metric)`` of the metric axis of :func:`run_chunk`'s arrays."""
        names = list(self.plant.hysteresis.output_names)
        cols = [(n, m) for n in names for m in ("rms_error", "max_abs_error")]
        allch = "+".join(names)
        return cols + [(allch, "rms_euclidean_error"), (allch, "max_euclidean_error")]


@dataclass
class MonteCarloScenario:
    """A validated Monte-Carlo scenario (top-level ``kind`` ``"monte-carlo"``).

    Parameters
    ----------
    name, title, description : str
    seed : int
    path : pathlib.Path
    studies : list of MonteCarloStudy
    compensator_spec : dict
        The ``[compensator]`` table (built once per study, on the nominal plant).
    kind : str
        ``"monte-carlo"``.
    feedback : dict or None
        The checked ``[feedback]`` table: every drawn plant runs in the loop
        designed on the nominal plant, the compensator as feedforward.
    """

    name: str
    title: str
    description: str
    seed: int
    path: Path
    studies: list
    compensator_spec: dict = field(default_factory=dict)
    kind: str = "monte-carlo"
    feedback: dict | None = None

    @property
    def cases(self):
        """``range`` over the drawn plants of all studies (``len`` = their number).

        Returns
        -------
        range
        """
        return range(sum(s.cases for s in self.studies))


def _nominal_modes(preset, base, outputs):
    """``(natural_frequency, damping_ratio)`` of a preset's bending modes, or None."""
    path = resolve_preset(preset, base)
    dyn = read_toml(path, "preset file").get("dynamics", {})
    if not isinstance(dyn, dict) or dyn.get("kind", "bending_modes") != "bending_modes":
        return None
    got = dynamics_from_table(dyn, outputs, str(path), build=False)
    if not isinstance(got, tuple):
        return None
    p = len(outputs)
    fn = np.broadcast_to(np.asarray(got[1], dtype=float), (p,)).copy()
    zeta = np.broadcast_to(np.asarray(got[2], dtype=float), (p,)).copy()
    return fn, zeta


def _study_kinds(plant):
    """The compensating kinds a study takes (not ``ilc``), those of the plant's model class."""
    kinds = [k for k, e in COMPENSATORS.items() if e.compensates and k != "ilc"]
    if plant is None:
        return kinds
    dynamics = getattr(plant, "dynamics", None) is not None
    return [k for k in kinds if not class_kind_problem(plant.hysteresis, k, dynamics)]


def _class_problems(comp, plant, base):
    """``kind: ...`` when the compensator's model is of a class its kind does not take.

    A Monte-Carlo study of ``preisach-inverse`` over a classical PI model file
    validated "ok (20 cases)", then the run stopped on it; in ``[[cases]]``
    validate names it.
    """
    name = comp.get("model", "plant")
    files = {}
    if isinstance(name, str) and name not in ("plant", "identified"):
        try:
            path = confined_path(name, base, PresetError)
            files[path] = load_model(path)
        except PresetError:
            return []           # the model file's own problem is named when it is built
    among = [k for k in COMPENSATORS if k != "ilc"]      # a study refuses ilc (below)
    return class_problems(name, comp.get("kind"), plant, base, files, comp.get("identify"), among)


def validate_montecarlo(path, data):
    """Validate a Monte-Carlo scenario file (nothing built or simulated).

    Parameters
    ----------
    path : pathlib.Path
        Scenario TOML file.
    data : dict
        Its parsed content.

    Returns
    -------
    MonteCarloScenario

    Raises
    ------
    ScenarioError
        Every problem, one ``file: key: message`` line each (an unknown key,
        a missing preset, ordinary ``[[cases]]`` mixed with the study, a
        varied natural frequency of a preset without bending modes, a budget
        exceeded, ...).
    """
    source, base, problems = str(path), Path(path).parent, []
    own = {**{k: f for k, f in TOP.items() if k in ("name", "title", "description", "seed")},
           "kind": Field(choice("cases", "monte-carlo"))}
    top = check_table({k: v for k, v in data.items() if k not in ("plant", "compensator", "sweeps",
                                                                 "cases", "feedback")},
                      own, "", problems, source) or {}
    if "cases" in data:
        problems.append(f"{source}: cases: a Monte-Carlo study (sweeps of kind 'monte-carlo') "
                        f"cannot hold [[cases]]; put them in another scenario file")
    plant_t = data.get("plant")
    plant = None
    if not isinstance(plant_t, dict) or not isinstance(plant_t.get("preset"), str):
        problems.append(f"{source}: plant.preset: expected the nominal plant's preset name or file")
    else:
        unknown = [k for k in plant_t if k not in ("preset", "dynamics")]
        if unknown:
            problems.append(f"{source}: plant.{unknown[0]}: unknown key (expected preset, dynamics)")
        try:
            plant = load_plant(plant_t["preset"], dynamics=bool(plant_t.get("dynamics", True)),
                               base_dir=base)
        except PresetError as exc:
            problems.append(f"{source}: plant.preset: {exc}")
    comp = data.get("compensator", {"kind": "multivariable"})
    if not isinstance(comp, dict) or not known_kind(comp.get("kind", "none"), COMPENSATORS):
        kind = comp.get("kind") if isinstance(comp, dict) else comp
        problems += [f"{source}: compensator.kind: {m}" for m in kind_problem(kind, COMPENSATORS)]
    elif not COMPENSATORS[comp.get("kind", "none")].compensates:
        problems.append(f"{source}: compensator.kind: a Monte-Carlo study needs a compensator, "
                        f"found {comp.get('kind', 'none')!r}")
    elif comp.get("kind") == "ilc":
        problems.append(f"{source}: compensator.kind: a Monte-Carlo study applies one drive per "
                        f"frequency, built from the nominal model, to every drawn plant; kind "
                        f"'ilc' learns on a plant (run it in [[cases]] of another scenario); "
                        f"the kinds a study takes{' for this plant' if plant is not None else ''}: "
                        f"{', '.join(_study_kinds(plant))}")
    elif plant is not None:     # a kind the model's class does not take: as in [[cases]]
        problems += [f"{source}: compensator.{m}" for m in _class_problems(comp, plant, base)]
    feedback = _check_feedback(data, comp, plant, source, problems)
    studies, seen = [], set()
    seed = top.get("seed", 0)
    for i, raw in enumerate(data.get("sweeps", [])):
        where = f"sweeps[{i}]"
        if not isinstance(raw, dict) or raw.get("kind") != "monte-carlo":
            problems.append(f"{source}: {where}.kind: expected 'monte-carlo' (a study's sweeps are "
                            f"all Monte-Carlo sweeps; put frequency sweeps in another file)")
            continue
        n0 = len(problems)
        c = check_table(raw, SWEEP, where, problems, source)
        if c is None or len(problems) > n0:
            if isinstance(raw.get("vary"), dict) and not any(
                    f"{where}.vary" in line for line in problems[n0:]):
                # its own mistakes too: `cases = 2.5` hid `vary.bogus` until it was fixed
                check_table(raw["vary"], VARY, f"{where}.vary", problems, source)
            continue
        if c["name"] in seen:
            problems.append(f"{source}: {where}.name: duplicate sweep name {c['name']!r}")
        seen.add(c["name"])
        vary = check_table(c["vary"], VARY, f"{where}.vary", problems, source)
        if vary is None or plant is None or len(problems) > n0:
            continue
        modes = _nominal_modes(plant_t["preset"], base, list(plant.hysteresis.output_names)) \
            if plant_t.get("dynamics", True) else None
        modal = modes is None and plant.sampled_dynamics is not None
        if modal:                       # state-space dynamics: their oscillating modes
            modes = oscillating_modes(plant.sampled_dynamics)
            if not len(modes[0]):
                modes, modal = None, False
        if not vary and not _loop_noise(data):
            # 200 cases of one plant, each the nominal one, ran without a word: a forgotten
            # [sweeps.vary] table spent the study's budget on one result
            problems.append(f"{source}: {where}.vary: nothing varies: each of the {c['cases']} "
                            f"cases would be the nominal plant; give one or more of "
                            f"{', '.join(VARY)} in [sweeps.vary] (one nominal run is a "
                            f"[[cases]] scenario)")
        if "feedback" in data and "noise" in vary:
            problems.append(f"{source}: {where}.vary.noise: with [feedback] the sensor noise is in "
                            f"the loop; give it as feedback.sensor.noise_nm")
        for q in ("natural_frequency", "damping_ratio"):
            if q in vary and modes is None:
                problems.append(f"{source}: {where}.vary.{q}: the nominal plant has no bending "
                                f"or oscillating modes (a static plant, or dynamics = false) to "
                                f"vary")
        if len(c["frequencies"]) * c["cases"] > MAX_RUNS:
            problems.append(f"{source}: {where}.cases: {c['cases']} cases x "
                            f"{len(c['frequencies'])} frequencies exceed the budget of "
                            f"{MAX_RUNS:.3g} runs per study")
        sig = c["reference"]
        if not isinstance(sig, dict) or not known_kind(sig.get("kind"), refs.REFERENCE_KINDS):
            problems += [f"{source}: {where}.reference.kind: {m}"
                         for m in kind_problem(sig.get("kind") if isinstance(sig, dict) else sig,
                                               refs.REFERENCE_KINDS)]
            continue
        if "frequency" in sig:
            problems.append(f"{source}: {where}.reference.frequency: given by the sweep's "
                            f"frequencies; remove it from the template")
            continue
        entry = refs.REFERENCE_KINDS[sig["kind"]]
        references, periods = [], []
        T = plant.sampling_period
        for f in c["frequencies"]:
            tab = {**sig, "frequency": f}
            rc = check_table(tab, {"kind": Field(lambda v: v), **entry.fields},
                             f"{where}.reference", problems, source)
            if rc is None or len(problems) > n0:
                break
            try:
                _, r, period, _ = entry.generate({k: v for k, v in rc.items() if k != "kind"}, T,
                                                 list(plant.hysteresis.output_names), base)
            except refs.SignalError as exc:
                problems.append(f"{source}: {where}.reference.{exc}")
                break
            P = max(int(round(period / T)), 1)
            if r.shape[1] > MAX_RUN_SAMPLES:
                problems.append(f"{source}: {where}.reference: {r.shape[1]} samples at {f:g} Hz; "
                                f"expected at most {MAX_RUN_SAMPLES} per run")
                break
            if r.shape[1] < c["settle_periods"] * P + 1:
                problems.append(f"{source}: {where}.settle_periods: {c['settle_periods']:g} periods "
                                f"leave no sample of the {r.shape[1]}-sample record at {f:g} Hz")
                break
            references.append(np.ascontiguousarray(r, dtype=float))
            periods.append(P)
        if len(problems) > n0:
            continue
        total = c["cases"] * sum(r.shape[1] for r in references)
        cost = sample_cost(plant, comp)
        if total * cost > max_study_samples() * KERNEL_SAMPLE_S:
            problems.append(
                f"{source}: {where}.cases: {c['cases']} cases x {sum(r.shape[1] for r in references)}"
                f" samples of the {len(references)} frequencies = {total:.3g} samples to simulate "
                f"(about {total * cost / 60:.3g} min of CPU at {cost * 1e9:.3g} ns a sample); "
                f"expected at most {max_study_samples() * KERNEL_SAMPLE_S / cost:.3g} "
                f"(raise it with {STUDY_SAMPLES_ENV}=N)")
            continue
        studies.append(MonteCarloStudy(
            name=c["name"], description=c.get("description", ""), cases=c["cases"], seed=seed,
            frequencies=c["frequencies"], references=references, period_samples=periods,
            settle_periods=float(c["settle_periods"]), vary=vary, plant=plant, modes=modes,
            modal=modal,
            chunk=c.get("chunk")))
    if not data.get("sweeps"):
        problems.append(f"{source}: sweeps: expected one or more [[sweeps]] kind = 'monte-carlo'")
    if "name" not in data and not (len(Path(path).stem) <= MAX_NAME
                                   and re.fullmatch(NAME, Path(path).stem)):
        problems.append(f"{source}: name: missing, and the file name is not usable as a report "
                        f"directory name; give name = \"...\"")
    if problems:
        raise ScenarioError(problems)
    return MonteCarloScenario(name=top.get("name", Path(path).stem),
                              title=top.get("title", Path(path).stem),
                              description=top.get("description", ""), seed=seed, path=Path(path),
                              studies=studies,
                              # the creep and G the compensator takes, named by the report
                              compensator_spec=model_file_dynamics(dict(comp), Path(path).parent),
                              feedback=feedback)


def _check_feedback(data, comp, plant, source, problems):
    """The study's ``[feedback]`` table (checked, defaults filled), or None without one."""
    if "feedback" not in data:
        return None
    raw = data["feedback"]
    where = f"{source}: feedback"
    n0 = len(problems)
    table = check_feedback_table(raw, where, problems)
    if isinstance(raw, dict) and "modes" in raw:
        problems.append(f"{where}.modes: a Monte-Carlo study runs feedforward + feedback on every "
                        f"drawn plant; remove modes")
    axes = raw.get("axes") if isinstance(raw, dict) else None
    if plant is not None and isinstance(axes, dict):
        names = list(plant.hysteresis.output_names)
        problems += [f"{where}.axes.{n}: not an output of the plant (expected {', '.join(names)})"
                     for n in axes if n not in names]
        missing = [n for n in names if n not in axes]
        if missing:
            problems.append(f"{where}.axes: no controller for {', '.join(missing)}")
    kind = comp.get("kind", "none") if isinstance(comp, dict) else None
    if isinstance(kind, str) and kind in COMPENSATORS and COMPENSATORS[kind].look_ahead:
        problems.append(f"{where}: the feedforward of a Monte-Carlo study with feedback runs "
                        f"without look-ahead; compensator.kind {kind!r} looks ahead")
    return table if len(problems) == n0 else None


# -- drawing ---------------------------------------------------------------------------------
