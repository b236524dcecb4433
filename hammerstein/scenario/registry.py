"""The registry of compensator kinds: ``[compensator] kind = ...`` -> builder.

Compensators are built by :func:`build_compensator` from the registry
:data:`COMPENSATORS` (kind -> :class:`CompensatorKind`); add a kind by adding
an entry (its ``fields`` are checked by ``hammerstein validate``, its
``build`` runs when the scenario is resolved). A compensator is any object
with ``.name`` and ``.simulate(reference (m, N), initial_state=None) ->
(inputs (m, N), final_state)``. The model a kind is built from
(``model = "plant" | "identified" | <file>``) is resolved by
:func:`hammerstein.scenario.identified.resolve_model`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from hammerstein.core.compensators import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                           StaticGainCompensator, diagonal_compensator)
from hammerstein.core.hammerstein_compensator import INVERSIONS, HammersteinCompensator
from hammerstein.core.preisach_inverse import PreisachInverseCompensator
from hammerstein.scenario.identified import (hammerstein_identify_table, identify_dynamics_table,
                                             identify_table, resolve_dynamics, resolve_model)
from hammerstein.scenario.schema import MAX_ITERATIONS, Field, Invalid, choice, integer, number, string

__all__ = ["CompensatorKind", "COMPENSATORS", "RATE_INDEPENDENT", "build_compensator",
           "resolve_model"]


@dataclass
class CompensatorKind:
    """An entry of the compensator registry.

    Parameters
    ----------
    build : callable
        ``build(spec: dict, plant, base_dir: Path) -> compensator or None``;
        ``spec`` is the validated ``[compensator]`` table (defaults filled).
    fields : dict of str to hammerstein.scenario.schema.Field
        The keys this kind accepts besides ``kind`` (validated by
        ``hammerstein validate``).
    description : str
        One line for ``hammerstein list`` and the README.
    """

    build: Callable[[dict, Any, Path], Any]
    fields: dict = field(default_factory=dict)
    description: str = ""


def _gain(v):
    if v in ("secant", "midpoint", "identity"):
        return v
    if isinstance(v, list) and v and all(isinstance(r, list) and len(r) == len(v) and
                                         all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                             and np.isfinite(a) for a in r) for r in v):
        return v
    raise Invalid(f"expected 'secant', 'midpoint', 'identity' or a square matrix [[..],[..]] of "
                  f"finite numbers [µm/V], found {v!r}")


def _build_none(spec, plant, base_dir):
    return None


def _build_multivariable(spec, plant, base_dir):
    model = resolve_model(spec.get("model", "plant"), plant, base_dir, spec.get("identify"))
    return InverseMultiplicativeCompensator(
        model, gain=spec.get("gain", "secant"), iterations=spec.get("iterations", 1),
        check=spec.get("check", "error"), **_feedback_options(spec, plant))


def _spec_model(spec, plant, base_dir):
    """The model of a compensator table (every kind resolves it like "multivariable")."""
    return resolve_model(spec.get("model", "plant"), plant, base_dir, spec.get("identify"))


def _feedback_options(spec, plant):
    """feedback = "lowpass" needs the cut-off [Hz] and the plant's sampling period [s]."""
    if spec.get("feedback", "delay") == "delay":
        return {}
    return {"feedback": spec["feedback"], "cutoff_hz": spec.get("cutoff_hz"),
            "sampling_period": plant.sampling_period}


def _build_diagonal(spec, plant, base_dir):
    return diagonal_compensator(
        _spec_model(spec, plant, base_dir), gain=spec.get("gain", "secant"),
        iterations=spec.get("iterations", 1), check=spec.get("check", "error"),
        **_feedback_options(spec, plant))


def _build_per_axis(spec, plant, base_dir):
    return PerAxisInverseCompensator(_spec_model(spec, plant, base_dir))


def _build_static_gain(spec, plant, base_dir):
    return StaticGainCompensator(_spec_model(spec, plant, base_dir))


# -- registry of compensator kinds: add entries here ---------------------------------
COMPENSATORS: dict[str, CompensatorKind] = {
    "none": CompensatorKind(_build_none, {}, "no compensator (open-loop drives only)"),
    "multivariable": CompensatorKind(
        _build_multivariable,
        {"model": Field(string(), default="plant"),
         "identify": Field(identify_table),
         "gain": Field(_gain, default="secant"),
         "iterations": Field(integer(1, MAX_ITERATIONS), default=1),
         "check": Field(choice("error", "warn", "ignore"), default="error"),
         "feedback": Field(choice("delay", "lowpass")),  # default: the one-sample delay
         "cutoff_hz": Field(number("Hz", 0))},
        "inverse multiplicative compensator of Theorem 4.1, normalised by K (docs/compensator.md)"),
}
_MODEL_KEYS = ("model", "identify")  # the model fields every kind shares with "multivariable"
COMPENSATORS["diagonal"] = CompensatorKind(
    _build_diagonal, dict(COMPENSATORS["multivariable"].fields),
    "the multivariable law on the direct transfers only (cross-couplings left)")
COMPENSATORS["per-axis"] = CompensatorKind(
    _build_per_axis, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "per-axis analytic inverse PI of Kuhnen & Janocha, direct transfers only (docs/per-axis-inverse.md)")
COMPENSATORS["static-gain"] = CompensatorKind(
    _build_static_gain, {k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k in _MODEL_KEYS},
    "no hysteresis compensation: U = K^-1 Yr, K the direct secant gains (reference)")


def _build_hammerstein(spec, plant, base_dir):
    model = None
    if spec.get("model", "plant") != "identified":
        model = _spec_model(spec, plant, base_dir)
    pi, G = resolve_dynamics(spec, plant, base_dir, model)
    comp = HammersteinCompensator(
        pi, G, inversion=spec.get("inversion", "zpetc"), gain=spec.get("gain", "midpoint"),
        iterations=spec.get("iterations", 3), check=spec.get("check", "error"),
        feedback=spec.get("feedback", "delay"), cutoff_hz=spec.get("cutoff_hz"),
        sampling_period=plant.sampling_period)
    comp.fade_in = spec.get("fade_in")
    return comp


COMPENSATORS["hammerstein"] = CompensatorKind(
    _build_hammerstein,
    {**{k: f for k, f in COMPENSATORS["multivariable"].fields.items() if k != "identify"},
     "identify": Field(hammerstein_identify_table),
     "gain": Field(_gain, default="midpoint"),     # smallest rho(I - K^-1 J) for identified PIs
     "iterations": Field(integer(1, MAX_ITERATIONS), default=3),
     "dynamics": Field(string()),          # default: "identified" with model = "identified", else "plant"
     "identify_dynamics": Field(identify_dynamics_table),
     "inversion": Field(choice(*INVERSIONS), default="zpetc"),
     "fade_in": Field(number("s", 0, exclusive=False))},   # default: one period (<= settling)
    "Hammerstein compensator U = Gamma^c(G^-1 Yr): inverse of the linear dynamics (ZPETC, "
    "reference P samples ahead, or whole-record stable inversion) then the multivariable law "
    "(docs/hammerstein-plant.md)")


def _build_preisach_inverse(spec, plant, base_dir):
    return PreisachInverseCompensator(_spec_model(spec, plant, base_dir),
                                      method=spec.get("method", "root"))


COMPENSATORS["preisach-inverse"] = CompensatorKind(
    _build_preisach_inverse,
    {"model": Field(string(), default="plant"),
     "method": Field(choice("root", "multiplicative"), default="root")},
    "exact per-sample inverse of a Preisach model (monotone root per direct path), or its "
    "inverse multiplicative law; rate independent (docs/plants.md)")
#: kinds that compensate the hysteresis only (rate independent): warned about dynamics
RATE_INDEPENDENT = ("multivariable", "diagonal", "per-axis", "static-gain")


def build_compensator(spec, plant, base_dir):
    """Build the compensator of a ``[compensator]`` table.

    Parameters
    ----------
    spec : dict
        Validated table; ``kind`` selects the :data:`COMPENSATORS` entry
        (default ``"none"``).
    plant : HammersteinPlant
        The simulated plant (its PI model is ``model = "plant"``).
    base_dir : pathlib.Path
        Directory of the scenario file (relative model paths).

    Returns
    -------
    object or None
        A compensator, or None for ``kind = "none"``.

    Raises
    ------
    ValueError
        Unknown kind; or the builder's own errors (CompensatorError,
        PresetError), e.g. a law refused by the convergence check.
    """
    kind = spec.get("kind", "none")
    if kind not in COMPENSATORS:
        raise ValueError(f"kind: expected one of {', '.join(COMPENSATORS)}, found {kind!r}")
    return COMPENSATORS[kind].build(spec, plant, Path(base_dir))
