"""The ``[feedback]`` table of a scenario (``kind = "feedback"``): keys, checks, the spec.

A feedback scenario is a cases scenario (``[plant]``, ``[compensator]`` as
the feedforward, ``[[cases]]``, ``[[sweeps]]``) plus a ``[feedback]`` table;
each reference case runs three ways, feedforward alone, feedback alone and
both (docs/feedback.md)::

    [feedback]
    method = "tustin"                 # discretisation (control.sample_system)
    anti_windup = "back-calculation"  # | "clamping" | "none"
    tracking_time = 0.002             # s, back-calculation (optional)
    modes = ["feedforward", "feedback", "both"]
    sensor = { noise_nm = 40.0, bandwidth_hz = 5000.0, delay = 1 }
    amplifier = { range = [-10.0, 10.0], slew_rate = 1e6 }

    [feedback.axes.x]                 # one table per output, or [feedback.mimo]
    kind = "pi-notch"                 # integral | pi | pi-notch | ppf | irc
    crossover_hz = 120.0              # | transfer-function | state-space
    notch_hz = 450.0

:func:`validate_feedback` checks every key and collects every problem; the
cases part is checked by the cases validator it is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from hammerstein.compensation.feedback import ANTI_WINDUP, AXIS_KINDS, METHODS
from hammerstein.core.schema import did_you_mean
from hammerstein.exceptions import ScenarioError
from hammerstein.io.sensor import check_sensor_table

__all__ = ["FeedbackScenario", "validate_feedback", "MODES", "LTI_KINDS", "MIMO_KINDS"]

#: the three runs of every case
MODES = ("feedforward", "feedback", "both")
#: controllers given as coefficients, per axis or MIMO
LTI_KINDS = ("transfer-function", "state-space")
#: MIMO controllers
MIMO_KINDS = ("state-space", "mixsyn")

_AXIS_NUMBERS = {"gain": "µm/V", "crossover_hz": "Hz", "zero_hz": "Hz", "notch_hz": "Hz",
                 "notch_damping": "-", "notch_width": "-", "mode_hz": "Hz", "ppf_gain": "-",
                 "ppf_damping": "-", "feedthrough_ratio": "-", "damping_hz": "Hz"}
_MIXSYN_NUMBERS = {"bandwidth_hz": "Hz", "max_sensitivity": "-", "effort": "-"}


@dataclass
class FeedbackScenario:
    """A validated feedback scenario.

    Parameters
    ----------
    name, title, description : str
    seed : int
        Seed of the sensor noise (case i uses ``seed + i``).
    path : pathlib.Path
    cases_spec : hammerstein.scenario.validate.ScenarioSpec
        The cases part (plant, feedforward compensator, cases and sweeps).
    table : dict
        The validated ``[feedback]`` table, defaults filled.
    kind : str
        ``"feedback"`` (the runner's registry key).
    """

    name: str
    title: str
    description: str
    seed: int
    path: Path
    cases_spec: Any
    table: dict = field(default_factory=dict)
    kind: str = "feedback"

    @property
    def cases(self):
        """The validated cases (list of CaseSpec), as a cases scenario's."""
        return self.cases_spec.cases


def _positive(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _matrix(v):
    return isinstance(v, list) and all(
        isinstance(r, list) and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                    and math.isfinite(a) for a in r) for r in v) and \
        len({len(r) for r in v}) <= 1


def _vector(v):
    return isinstance(v, list) and len(v) > 0 and all(
        isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a) for a in v)


def _check_lti(t, where, problems):
    kind = t.get("kind")
    allowed = {"kind", "discrete"}
    if kind == "transfer-function":
        allowed |= {"num", "den"}
        for k in ("num", "den"):
            if not _vector(t.get(k)):
                problems.append(f"{where}.{k}: expected a list of coefficients (highest power "
                                f"first), found {t.get(k)!r}")
    else:
        allowed |= {"A", "B", "C", "D"}
        for k in ("A", "B", "C", "D"):
            if k not in t and k != "A":
                problems.append(f"{where}.{k}: required for kind = \"state-space\"")
            elif k in t and not _matrix(t[k]):
                problems.append(f"{where}.{k}: expected a matrix (list of rows), found {t[k]!r}")
    if "discrete" in t and not isinstance(t["discrete"], bool):
        problems.append(f"{where}.discrete: expected true or false, found {t['discrete']!r}")
    return allowed


def _check_axis(t, where, problems):
    if not isinstance(t, dict):
        problems.append(f"{where}: expected a table, found {t!r}")
        return
    kind = t.get("kind")
    if isinstance(kind, str) and kind in AXIS_KINDS:
        allowed = {"kind", "internal_model_hz", "internal_model_decay"} | set(_AXIS_NUMBERS) | \
            ({"irc_reference"} if kind == "irc" else set())
        im = t.get("internal_model_hz", [1.0])
        if not (_vector(im) and all(f > 0 for f in im)):
            problems.append(f"{where}.internal_model_hz: expected a list of positive frequencies "
                            f"[Hz] (the reference's fundamental and harmonics), found {im!r}")
        if "internal_model_decay" in t and not _positive(t["internal_model_decay"]):
            problems.append(f"{where}.internal_model_decay: expected a positive number of "
                            f"periods, found {t['internal_model_decay']!r}")
        if t.get("irc_reference", "error") not in ("error", "static"):
            problems.append(f"{where}.irc_reference: expected \"error\" or \"static\", found "
                            f"{t['irc_reference']!r}")
        if "crossover_hz" not in t:
            problems.append(f"{where}.crossover_hz: required (the integral action's crossover "
                            f"[Hz])")
        if kind == "pi-notch" and "notch_hz" not in t:
            problems.append(f"{where}.notch_hz: required for kind = \"pi-notch\" [Hz]")
        if kind in ("ppf", "irc") and "mode_hz" not in t:
            problems.append(f"{where}.mode_hz: required for kind = {kind!r} (the mode to "
                            f"damp [Hz])")
        for k, unit in _AXIS_NUMBERS.items():
            if k in t and not _positive(t[k]):
                problems.append(f"{where}.{k}: expected a positive number [{unit}], found "
                                f"{t[k]!r}")
    elif isinstance(kind, str) and kind in LTI_KINDS:
        allowed = _check_lti(t, where, problems)
    else:
        problems.append(f"{where}.kind: expected one of {', '.join(AXIS_KINDS + LTI_KINDS)}, "
                        f"found {kind!r}")
        return
    for k in sorted(set(t) - allowed):
        problems.append(f"{where}.{k}: unknown key{did_you_mean(k, allowed)}")


def _check_mimo(t, where, problems):
    if not isinstance(t, dict):
        problems.append(f"{where}: expected a table, found {t!r}")
        return
    kind = t.get("kind")
    if kind == "state-space":
        allowed = _check_lti(t, where, problems)
    elif kind == "mixsyn":
        allowed = {"kind"} | set(_MIXSYN_NUMBERS)
        if "bandwidth_hz" not in t:
            problems.append(f"{where}.bandwidth_hz: required for kind = \"mixsyn\" [Hz]")
        for k, unit in _MIXSYN_NUMBERS.items():
            if k in t and not _positive(t[k]):
                problems.append(f"{where}.{k}: expected a positive number [{unit}], found "
                                f"{t[k]!r}")
    else:
        problems.append(f"{where}.kind: expected one of {', '.join(MIMO_KINDS)}, found {kind!r}")
        return
    for k in sorted(set(t) - allowed):
        problems.append(f"{where}.{k}: unknown key{did_you_mean(k, allowed)}")


def check_feedback_table(table, where, problems):
    """Check a ``[feedback]`` table, appending ``where.key: message`` problems.

    Parameters
    ----------
    table : object
        The parsed table.
    where : str
        Prefix of the messages (``"file: feedback"``).
    problems : list of str
        Receives the problems.

    Returns
    -------
    dict
        The table with its defaults filled (meaningful when no problem was added).
    """
    if not isinstance(table, dict):
        problems.append(f"{where}: expected a table, found {table!r}")
        return {}
    out = {"method": "tustin", "anti_windup": "back-calculation", "modes": list(MODES),
           "sensor": {}, "amplifier": {}, **table}
    known = {"method", "anti_windup", "tracking_time", "modes", "sensor", "amplifier", "axes",
             "mimo"}
    for k in sorted(set(table) - known):
        problems.append(f"{where}.{k}: unknown key (expected {', '.join(sorted(known))})")
    if out["method"] not in METHODS:
        problems.append(f"{where}.method: expected one of {', '.join(METHODS)}, found "
                        f"{out['method']!r}")
    if out["anti_windup"] not in ANTI_WINDUP:
        problems.append(f"{where}.anti_windup: expected one of {', '.join(ANTI_WINDUP)}, found "
                        f"{out['anti_windup']!r}")
    if "tracking_time" in table and not _positive(table["tracking_time"]):
        problems.append(f"{where}.tracking_time: expected a positive time [s], found "
                        f"{table['tracking_time']!r}")
    modes = out["modes"]
    if not (isinstance(modes, list) and modes and all(m in MODES for m in modes)):
        problems.append(f"{where}.modes: expected a list of {', '.join(MODES)}, found {modes!r}")
    check_sensor_table(out["sensor"], f"{where}.sensor", problems)   # hammerstein.io.sensor
    amp = out["amplifier"]
    if not isinstance(amp, dict):
        problems.append(f"{where}.amplifier: expected a table, found {amp!r}")
    else:
        for k in sorted(set(amp) - {"range", "slew_rate"}):
            problems.append(f"{where}.amplifier.{k}: unknown key (expected range, slew_rate)")
        r = amp.get("range")
        if r is not None and not (_vector(r) and len(r) == 2 and r[0] < r[1]):
            problems.append(f"{where}.amplifier.range: expected [min, max] in V, min < max, "
                            f"found {r!r}")
        if "slew_rate" in amp and not _positive(amp["slew_rate"]):
            problems.append(f"{where}.amplifier.slew_rate: expected a positive rate [V/s], "
                            f"found {amp['slew_rate']!r}")
    axes, mimo = table.get("axes"), table.get("mimo")
    if (axes is None) == (mimo is None):
        problems.append(f"{where}: expected either [feedback.axes.<output>] tables (one "
                        f"controller per axis) or one [feedback.mimo] table")
    elif axes is not None:
        if not isinstance(axes, dict) or not axes:
            problems.append(f"{where}.axes: expected one table per output, found {axes!r}")
        else:
            for name, t in axes.items():
                _check_axis(t, f"{where}.axes.{name}", problems)
    else:
        _check_mimo(mimo, f"{where}.mimo", problems)
    return out


def validate_feedback(path, data, validate_cases: Callable):
    """Validate a ``kind = "feedback"`` scenario: its cases, then its ``[feedback]`` table.

    Parameters
    ----------
    path : pathlib.Path
        The scenario file.
    data : dict
        Its parsed TOML.
    validate_cases : callable
        ``(path, data) -> ScenarioSpec``, the cases validator
        (:data:`hammerstein.scenario.validate.VALIDATORS` ``["cases"]``).

    Returns
    -------
    FeedbackScenario

    Raises
    ------
    ScenarioError
        Every problem, one ``file: key: message`` per line (the cases'
        problems and the table's together).
    """
    rest = {k: v for k, v in data.items() if k not in ("kind", "feedback")}
    problems = []
    spec = None
    try:
        spec = validate_cases(path, rest)
    except ScenarioError as exc:
        problems.extend(exc.problems if hasattr(exc, "problems") else str(exc).splitlines())
    if "feedback" not in data:
        problems.append(f"{path}: feedback: required for kind = \"feedback\"")
        table = {}
    else:
        table = check_feedback_table(data["feedback"], f"{path}: feedback", problems)
    if spec is not None:
        for case in spec.cases[:1]:
            if getattr(case.plant.hysteresis, "has_output_map", False):
                problems.append(
                    f"{path}: plant.preset: a classical PI with an output map (the modified PI "
                    f"`identify` may choose) cannot run in the closed-loop kernel; identify with "
                    f"--output-map none, or --model preisach or generalized")
    if spec is not None and table.get("axes"):
        names = list(spec.cases[0].plant.hysteresis.output_names) if spec.cases else []
        for name in table["axes"]:
            if names and name not in names:
                problems.append(f"{path}: feedback.axes.{name}: not an output of the plant "
                                f"(expected {', '.join(names)})")
        missing = [n for n in names if n not in table["axes"]]
        if missing:
            problems.append(f"{path}: feedback.axes: no controller for {', '.join(missing)}")
    if problems:
        raise ScenarioError(problems)
    return FeedbackScenario(spec.name, spec.title, spec.description, spec.seed, spec.path, spec,
                            table)
