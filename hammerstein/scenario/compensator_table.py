"""A scenario's compensator tables: merged, checked, and checked as their kind.

A case's ``compensator`` table is merged with the top-level one
(:func:`merge_compensator`), checked field by field against its kind's schema
(:func:`check_compensator`, a misspelt kind checked as the kind it spells),
and, where a value is wrong, its other keys still get the kind's own checks
(:func:`clean_keys_problems`), so that ``hammerstein validate`` names every
problem at once.
"""

from __future__ import annotations

from hammerstein.core.schema import closest
from hammerstein.scenario.registry import COMPENSATORS, model_file_dynamics
from hammerstein.scenario.schema import Field, check_table, kind_problem, known_kind

__all__ = ["check_compensator", "clean_keys_problems", "merge_compensator", "option_problems"]

#: Keys whose check reads another key's value (or its default): not judged when that one is
#: wrong (``identify_dynamics`` goes with ``dynamics = "identified"``).
DEPENDS_ON = {"identify_dynamics": "dynamics"}


def merge_compensator(top, case):
    """A case's compensator table over the top-level one.

    Parameters
    ----------
    top : dict or None
        The scenario's ``[compensator]`` table.
    case : dict or None
        The case's own ``compensator`` table.

    Returns
    -------
    dict
        ``case`` alone when it names another ``kind`` (the top table's options
        are another kind's), else the top table updated with the case's keys.
    """
    top = dict(top or {})
    case = dict(case or {})
    if "kind" in case and case["kind"] != top.get("kind", "none"):
        return case
    return {**top, **case}


def check_compensator(spec, where, problems, source, own=None):
    """Check a merged compensator table against its kind's schema.

    Parameters
    ----------
    spec : dict
        The merged table (:func:`merge_compensator`).
    where : str
        Its key path (``cases[0].compensator``).
    problems : list of str
        Receives ``source: key: message`` lines: unknown kind (the rest checked
        as the kind it spells), unknown keys, bad values, options given for a
        setting that is not selected.
    source : str
        The scenario file's name.
    own : dict, optional
        The keys written in the table being checked (default: all of ``spec``).

    Returns
    -------
    dict or None
        The checked table, defaults filled in, without the keys whose values
        failed; None when the kind is unknown or missing.
    """
    kind = spec.get("kind", "none")
    if not known_kind(kind, COMPENSATORS):
        problems += [f"{source}: {where}.kind: {msg}" for msg in kind_problem(kind, COMPENSATORS)]
        meant = meant_kind(kind)
        if meant is not None:   # the rest of the table is checked as the kind it spells
            rest = {k: v for k, v in spec.items() if k != "kind"}
            clean = check_table(rest, COMPENSATORS[meant].fields, where, problems, source)
            problems.extend(f"{source}: {where}.{msg}" for msg in option_problems(clean, own))
        return None
    if "kind" not in spec and any(k != "kind" for k in spec):
        # `model = ...` without a kind read "unknown key (valid keys: kind)": the default kind
        # "none" takes no option
        takes = sorted(n for n, e in COMPENSATORS.items() if set(spec) <= set(e.fields))
        problems.append(f"{source}: {where}.kind: missing: the default 'none' (no compensator) "
                        f"takes no {', '.join(sorted(spec))}; give a kind"
                        + (f" ({', '.join(takes)} take them)" if takes else ""))
        return None
    schema = {"kind": Field(lambda v: v), **COMPENSATORS[kind].fields}
    clean = check_table(spec, schema, where, problems, source)
    if clean is not None:
        problems.extend(f"{source}: {where}.{msg}" for msg in option_problems(clean, own))
        if "gain" not in spec:
            # no gain written: the builder takes the kind's own when it converges, else the
            # convergent one, as `compensate --kind KIND` does (registry._law_options); the
            # report shows the gain that ran (resolve.shown_spec)
            clean.pop("gain", None)
    return clean


def clean_keys_problems(spec, clean, plant, base, files, settle, period_samples):
    """The kind's own checks of the keys of a compensator table that passed their field checks.

    A table with a bad value (``identify.creep = "yes"``) has no clean form to
    check as a whole; its other keys (``dynamics = "guessed"``) are still
    checked, so that one run of ``validate`` names every problem. Nothing is
    checked when ``kind`` or ``model`` is wrong (the other keys' defaults
    depend on them), and only messages about keys written in the table are
    kept, less those that depend on a wrong key (:data:`DEPENDS_ON`).

    Parameters
    ----------
    spec : dict
        The merged compensator table as written.
    clean : dict or None
        Its checked form, without the keys that failed.
    plant : Plant or None
        The case's plant (None: not loaded; nothing is checked).
    base : pathlib.Path
        The scenario's directory.
    files : dict
        Model and dynamics files already read, with their problems.
    settle : float
        The case's settling periods.
    period_samples : int
        Samples per period of the case's reference.

    Returns
    -------
    list of str
        ``key: message`` strings.
    """
    kind = spec.get("kind", "none")
    if clean is None or plant is None or not known_kind(kind, COMPENSATORS) \
            or COMPENSATORS[kind].check is None:
        return []
    bad = {k for k in spec if k not in clean}
    if bad & {"kind", "model"}:
        return []
    judged = set(spec) - bad - {k for k, on in DEPENDS_ON.items() if on in bad}
    more = COMPENSATORS[kind].check(model_file_dynamics(clean, base), plant, base, files,
                                    settle, period_samples)
    return [m for m in more if m.split(":", 1)[0].split(".", 1)[0] in judged]


def meant_kind(kind):
    """The compensator kind closest to a misspelt ``kind``.

    Parameters
    ----------
    kind : object
        The ``kind`` value read from the file (``"hamerstein"``).

    Returns
    -------
    str or None
        The closest known kind (``"hammerstein"``), or None when none is close.
    """
    return closest(kind, COMPENSATORS)


def option_problems(spec, own=None):
    """Keys given for an option that is not selected.

    Parameters
    ----------
    spec : dict
        The merged, checked table.
    own : dict, optional
        The keys written in the table being checked (a case that overrides
        ``model`` may inherit an ``identify``); default: all of ``spec``.

    Returns
    -------
    list of str
        ``key: message`` strings (``cutoff_hz`` without ``feedback = "lowpass"``,
        ``identify`` without ``model = "identified"``, a low-pass without its
        cut-off).
    """
    own = spec if own is None else own
    out = []
    feedback = spec.get("feedback", "delay")
    if "cutoff_hz" not in spec:     # not a key of this kind (said so: unknown key)
        own = {k: v for k, v in own.items() if k != "cutoff_hz"}
    if "cutoff_hz" in own and feedback != "lowpass":
        out.append(f"cutoff_hz: only used with feedback = 'lowpass' (feedback is {feedback!r}); "
                   f"remove it or set feedback = 'lowpass'")
    if feedback == "lowpass" and "cutoff_hz" not in spec:
        out.append("cutoff_hz: missing (feedback='lowpass' needs a cut-off frequency [Hz])")
    if "identify" in own and spec.get("model", "plant") != "identified":
        out.append(f"identify: only used with model = 'identified' (model is "
                   f"{spec.get('model', 'plant')!r})")
    return out
