"""Saving what a run identified: model and dynamics files in the report directory.

The case results carry their identifications (``result.spec.identified``:
:class:`hammerstein.scenario.identification.IdentifiedModel` and
:class:`hammerstein.scenario.identification.IdentifiedDynamics` records), so
the report saves them without identifying anything again:
``models/identified-<f>Hz-<method>.toml`` (:func:`save_identified_models`,
loadable by ``model = "<file>"``) and ``models/hammerstein-<i>-<class>.toml``
(``pi`` for a classical PI) / ``models/hammerstein-<i>-dynamics.toml`` (:func:`save_identified_dynamics`,
loadable by ``dynamics = "<file>"``). A model identified from records
(``records = "excitation"`` or ``"files"``) is saved as the preset
``hammerstein identify`` writes, ``[creep]`` and ``[amplifier]`` (and
``[dynamics]`` for kind hammerstein) included, so that ``model = "<file>"``
builds the same compensator.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import tomli_w

from hammerstein.compensation.model_classes import model_class
from hammerstein.core.files import safe_write
from hammerstein.io.presets import save_dynamics, save_model

__all__ = ["model_file_name", "save_identified_models", "save_identified_dynamics"]


def model_file_name(spec):
    """The file name of the model an ``identify`` table identified.

    ``identified-<frequency>Hz-<method>.toml`` for the sine route of the
    paper; for the route of ``hammerstein identify`` (``records =
    "excitation"`` or ``"files"``, which may have no ``frequency``)
    ``identified-<records>-<model>.toml``.

    Parameters
    ----------
    spec : dict
        The ``identify`` table: ``frequency`` [Hz] and, optionally,
        ``method`` (default ``"closed-form"``); or ``records`` and ``model``
        (default ``"auto"``).

    Returns
    -------
    str
        The file name, frequency formatted with ``:g``.

    Examples
    --------
    >>> model_file_name({"frequency": 50.0, "method": "least-squares"})
    'identified-50Hz-least-squares.toml'
    >>> model_file_name({"records": "files", "model": "preisach"})
    'identified-files-preisach.toml'
    >>> model_file_name({"frequency": 5.0, "model": "preisach", "method": "closed-form"})
    'identified-5Hz-preisach.toml'
    """
    if "records" in spec:
        return f"identified-{spec['records']}-{spec.get('model', 'auto')}.toml"
    if spec.get("model", "classical") != "classical":     # a Preisach or auto fit: its class
        return f"identified-{spec['frequency']:g}Hz-{spec['model']}.toml"
    return f"identified-{spec['frequency']:g}Hz-{spec.get('method', 'closed-form')}.toml"


def _save(rec, model, path, metadata):
    """Write the model file of an identification record.

    A ``records`` identification is saved as the preset ``hammerstein
    identify`` wrote (its ``[creep]``, ``[amplifier]`` and, for kind
    hammerstein, ``[dynamics]`` with the model): ``model = "<file>"`` then
    builds the same compensator, as ``compensate`` on it does. Otherwise
    ``[model]`` and ``[identification]``.
    """
    if getattr(rec, "preset_text", None) is None:
        save_model(model, path, metadata)
    else:
        safe_write(path, rec.preset_text, "model file")


def _records(results, kind):
    """[(case name, record)] of the identifications of ``kind`` ("pi", "hammerstein") the results carry."""
    return [(r.name, rec) for r in results for rec in r.spec.identified if rec.kind == kind]


def save_identified_models(results, directory):
    """Save every identified PI model the cases used into ``directory/models/``.

    File names are :func:`model_file_name`; a second, different model with
    the same name gets the plant label (``-static`` / ``-hammerstein``), then
    ``-2``, ``-3``... before ``.toml``.

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult
        Every case's result (sweep cases included).
    directory : pathlib.Path
        The report directory being written.

    Returns
    -------
    list of dict
        One row per case and role: ``case``, ``role`` ('compensator' or
        'comparison'), ``file`` (relative to ``directory``), ``plant``,
        ``identify`` (the table that identified the model).
    """
    directory = Path(directory)
    files, names, rows = {}, set(), []
    for case_name, rec in _records(results, "pi"):
        if rec.key not in files:
            base = model_file_name(rec.identify)[:-len(".toml")]
            label = "hammerstein" if not rec.plant.is_static else "static"
            name, i = f"{base}.toml", 1
            if name in names:
                name = f"{base}-{label}.toml"
            while name in names:
                i += 1
                name = f"{base}-{label}-{i}.toml"
            names.add(name)
            files[rec.key] = f"models/{name}"
            _save(rec, rec.model, directory / files[rec.key], rec.metadata)
        rows.append({"case": case_name, "role": rec.role, "file": files[rec.key],
                     "plant": rec.metadata["plant"], "identify": rec.identify})
    return rows


def save_identified_dynamics(results, directory):
    """Save the PI models and dynamics that ``kind = "hammerstein"`` cases identified.

    Files ``models/hammerstein-<i>-<class>.toml`` (model file, when the
    hysteresis was identified; ``pi`` for a classical PI, else its class:
    ``preisach``, ``generalized``) and ``models/hammerstein-<i>-dynamics.toml`` (``[dynamics]
    kind = "state_space"``, continuous ZOH equivalent: loadable by
    ``dynamics = "<file>"``), one pair per distinct identification.

    Parameters
    ----------
    results : list of hammerstein.scenario.execute.CaseResult
    directory : pathlib.Path

    Returns
    -------
    list of dict
        One per distinct identification: ``cases``, ``pi_file``,
        ``dynamics_file``, ``identifier`` (DynamicsIdentifier), ``plant``
        (HammersteinPlant), ``metadata`` (of the dynamics), ``summary`` (the
        search of a ``records`` table's identification, or None).
    """
    directory = Path(directory)
    out, index = [], {}
    for name, rec in _records(results, "hammerstein"):
        if rec.key not in index:
            i = len(out) + 1
            row = {"cases": [], "pi_file": None, "dynamics_file": f"models/hammerstein-{i}-dynamics.toml",
                   "identifier": rec.identifier, "plant": rec.plant, "metadata": rec.metadata,
                   "summary": getattr(rec, "summary", None)}
            if rec.pi_metadata is not None:
                # named by its class (a Preisach model was saved as -pi.toml); "pi" for the
                # classical PI, as the files of earlier reports
                entry = model_class(rec.pi)
                classical = entry.name == "classical"
                row["pi_class"] = "PI" if classical else f"{entry.label} model"
                row["pi_file"] = f"models/hammerstein-{i}-{'pi' if classical else entry.name}.toml"
                _save(rec, rec.pi, directory / row["pi_file"], rec.pi_metadata)
            if rec.preset_text is None:
                save_dynamics(rec.identifier.system_, directory / row["dynamics_file"], rec.metadata)
            else:     # the [dynamics] the compensator was read from, and the [creep] it inverts
                preset = tomllib.loads(rec.preset_text)
                doc = {"identification": rec.metadata, "dynamics": preset["dynamics"],
                       **({"creep": preset["creep"]} if "creep" in preset else {})}
                safe_write(directory / row["dynamics_file"], tomli_w.dumps(doc), "dynamics file")
            index[rec.key] = row
            out.append(row)
        index[rec.key]["cases"].append(name)
    return out
