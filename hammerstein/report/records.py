"""Report directory of an identification scenario on a measured record.

:func:`write_identification_report` writes ``metrics.csv`` (cases ``train``
and ``validation``), ``timeseries-<case>.csv``, the model file
``models/identified-<method>.toml``, the overlay figure ``record-fit.png``
and ``report.md`` of a scenario of kind ``"identification"``
(:mod:`hammerstein.scenario.records`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.compensation.model_classes import model_class
from hammerstein.core.files import safe_write
from hammerstein.io.presets import save_model
from hammerstein.report.model_figures import record_fit_figure
from hammerstein.report.render import FigureJobs
from hammerstein.report.tables import markdown_table, metrics_frame, write_signals_csv

__all__ = ["write_identification_report"]


def write_identification_report(scenario, results, directory, jobs=None):
    """Write metrics.csv, the time series, the model file, the figure and report.md.

    Parameters
    ----------
    scenario : RecordScenario
    results : list of RecordResult
        From :func:`run_identification_scenario`.
    directory : pathlib.Path
        Existing (temporary) report directory.
    jobs : hammerstein.report.render.FigureJobs, optional
        Collects the figure (the caller waits for it); default: drawn here.
    """
    directory = Path(directory)
    jobs = FigureJobs() if jobs is None else jobs
    spec, dat = scenario.identification, scenario.data
    fit = results[0].fit
    iu, ou = dat["input_unit"], dat["output_unit"]
    model = fit.model
    frame = metrics_frame(results)
    safe_write(directory / "metrics.csv", frame.to_csv(index=False), "metrics file")
    rec, split, pred = fit.records[0], fit.splits[0], fit.predictions[0]
    iu_tag, ou_tag = iu.replace("µ", "u"), ou.replace("µ", "u")   # ASCII column names
    for r, mask in (("train", split.train), ("validation", split.held_out)):
        cols = {"time_s": rec.timepts[mask]}
        for k, name in enumerate(model.input_names):
            cols[f"{name}_{iu_tag}"] = rec.u[k][mask]
        for l, name in enumerate(model.output_names):
            cols[f"{name}_{ou_tag}"] = rec.y[l][mask]
            cols[f"{name}_model_{ou_tag}"] = pred[l][mask]
        write_signals_csv(directory / f"timeseries-{r}.csv", cols, float_format="%.7g")
    # the class fitted: a scenario's model = "preisach" / "generalized" / "auto" is fitted by
    # least squares whatever its method; named by the class, not by "least-squares" alone
    cls = model_class(model)
    fitted = spec["method"] if cls.name == "classical" else cls.name
    model_file = f"models/identified-{fitted}.toml"
    val = fit.validation
    save_model(model, directory / model_file, {
        "method": spec["method"],
        "sources": [str(f) for f in dat.get("files", [dat.get("file")])],
        "partition": fit.partition, "bounds": spec["bounds"],
        "components": [" ".join(row) for row in fit.structure],
        "held_out": [s.description for s in fit.splits], "notes": list(fit.notes),
        "sampling_period_s": rec.sampling_period,
        "validation_rms": [v["rms"] for v in val],
        "validation_rms_percent_of_range": max(v["rms_percent"] for v in val)}, iu, ou)
    train_idx, held_idx = np.flatnonzero(split.train), np.flatnonzero(split.held_out)
    jobs.add(directory / "record-fit.png", record_fit_figure, rec.timepts,
             rec.u[split.excitation], rec.y[0], pred[0],
             int(train_idx[0]), int(held_idx[0]) if held_idx.size else rec.n_samples,
             f"{model.input_names[split.excitation]} [{iu}]", f"{model.output_names[0]} [{ou}]",
             f"{scenario.title}: measured vs identified {cls.label} model")
    structure = "; ".join(f"{out} <- {inp}: {fit.structure[l][k]}"
                          for l, out in enumerate(model.output_names)
                          for k, inp in enumerate(model.input_names))
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description.strip(), ""]
    lines += [f"Scenario `{scenario.path}` (name `{scenario.name}`, kind identification).", ""]
    for r, s in zip(fit.records, fit.splits):
        lines += [f"- Record `{r.source}`: {r.n_samples} samples, T = {r.sampling_period:.6g} s; "
                  f"{s.description}."]
    how = (spec["method"] if cls.name == "classical" else
           f"{cls.label} (least squares{', chosen by auto' if spec.get('model') == 'auto' else ''})")
    # a generalised PI's fit.partition is its threshold spacing, a Preisach model's its grid
    part = ("partition" if cls.name == "classical" else
            "threshold spacing" if cls.name == "generalized" else "grid")
    lines += ["", f"Identification: {how}, {part} {fit.partition}, bounds "
              f"{spec['bounds']}; components {structure}; output offset "
              f"{[round(float(c), 6) for c in (model.output_offset if model.output_offset is not None else np.zeros(model.n_outputs))]} {ou}."]
    lines += [f"- {note}" for note in fit.notes]
    lines += ["", f"Model file: [`{model_file}`]({model_file}).", "",
              "## Figures", "", "### Measured vs model", "",
              "![Measured vs model](record-fit.png)", "",
              "## Metrics", "", f"RMS error in {ou} and in % of the measured output range "
              "(peak to peak) of each window.", "", markdown_table(frame), ""]
    safe_write(directory / "report.md", "\n".join(lines), "report")
