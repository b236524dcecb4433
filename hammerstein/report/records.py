"""Report directory of an identification scenario on a measured record.

:func:`write_identification_report` writes ``metrics.csv`` (cases ``train``
and ``validation``), ``timeseries-<case>.csv``, the model file
``models/identified-<method>.toml``, the overlay figure ``record-fit.png``
and ``report.md`` of a scenario of kind ``"identification"``
(:mod:`hammerstein.scenario.records`).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hammerstein.core.hysteresis import MultivariablePI
from hammerstein.core.presets import save_model
from hammerstein.report import figures as plots
from hammerstein.report.model_figures import record_fit_figure
from hammerstein.report.tables import markdown_table, metrics_frame
from hammerstein.scenario.records import _names as channel_names

__all__ = ["write_identification_report"]


def write_identification_report(scenario, results, directory):
    """Write metrics.csv, the time series, the model file, the figure and report.md.

    Parameters
    ----------
    scenario : hammerstein.scenario.records.RecordScenario
    results : list of RecordResult
        From :func:`hammerstein.scenario.records.run_identification_scenario`.
    directory : pathlib.Path
        Existing (temporary) report directory.
    """
    directory = Path(directory)
    rec, spec = scenario.record, scenario.identification
    uname, yname = channel_names(scenario)
    ident = results[0].identifier
    frame = metrics_frame(results)
    frame.to_csv(directory / "metrics.csv", index=False)
    for r in results:
        w = r.window
        pd.DataFrame({"time_s": rec.timepts[w], f"{uname}_V": rec.u[w], f"{yname}_um": rec.y[w],
                      f"{yname}_model_um": r.model_output[w]}).to_csv(
            directory / f"timeseries-{r.name}.csv", index=False, float_format="%.7g")
    model = MultivariablePI([[ident.model_]], [uname], [yname], [ident.amplitude_])
    model_file = f"models/identified-{spec['method']}.toml"
    val = {row["metric"]: row["value"] for row in results[1].metrics}
    save_model(model, directory / model_file, {
        "method": spec["method"], "source": str(scenario.data["file"]),
        "n_hysterons": int(ident.thresholds_.size),
        "partition": "explicit" if "thresholds" in spec else spec["partition"],
        "bounds": spec["bounds"], "train_fraction": spec["train_fraction"],
        "sampling_period_s": rec.sampling_period, "amplitude_V": ident.amplitude_,
        "offset_um": ident.offset_, "validation_rms_um": val["rms_error"],
        "validation_rms_percent_of_range": val["rms_error_percent"]})
    split = rec.timepts[results[1].window.start]
    fig = record_fit_figure(rec.timepts, rec.u, rec.y, results[0].model_output,
                            results[0].window.start, results[1].window.start,
                            f"{uname} [V]", f"{yname} [µm]",
                            f"{scenario.title}: measured vs identified PI model")
    plots.save(fig, directory / "record-fit.png")
    lines = [f"# {scenario.title}", ""]
    if scenario.description:
        lines += [scenario.description.strip(), ""]
    lines += [f"Scenario `{scenario.path}` (name `{scenario.name}`, kind identification).", "",
              f"Record `{rec.source}`: {rec.n_samples} samples, T = {rec.sampling_period:.6g} s, "
              f"input `{rec.input_name}` [V] -> output `{rec.output_name}` [µm].", "",
              f"Identification: {spec['method']}, {ident.thresholds_.size} hysterons (thresholds "
              f"{ident.thresholds_[0]:.4g} to {ident.thresholds_[-1]:.4g} V), partition "
              f"{'explicit' if 'thresholds' in spec else spec['partition']}, bounds {spec['bounds']}, "
              f"output offset {ident.offset_:.4g} µm. Trained on samples "
              f"{results[0].window.start}..{results[0].window.stop - 1} (the start-up / virgin "
              f"curve before them only warms up the play states); validated on the held-out "
              f"samples from t = {split:.4g} s on. Model file: [`{model_file}`]({model_file}).", "",
              "## Figures", "", "### Measured vs model", "",
              "![Measured vs model](record-fit.png)", "",
              "## Metrics", "", "RMS error in µm and in % of the measured output range "
              "(peak to peak) of each window.", "", markdown_table(frame), ""]
    (directory / "report.md").write_text("\n".join(lines), encoding="utf-8")
