"""Files of the records route, for tests: records written as ``identify`` reads them, and
model files compared number by number."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.cli.main import main


def write_record(path, rec):
    """Write a simulated record as a CSV file ``identify`` reads (t, inputs, outputs).

    Parameters
    ----------
    path : str or pathlib.Path
        File to write.
    rec : object
        A record with ``timepts`` (n_samples,) [s], ``u`` (n_inputs, n_samples) [V],
        ``y`` (n_outputs, n_samples) [µm], ``input_names`` and ``output_names``.

    Returns
    -------
    str
        ``path`` as text (a command-line argument); every value is written with 17
        significant digits (read back bit for bit).
    """
    cols = ["t", *rec.input_names, *rec.output_names]
    data = np.column_stack([rec.timepts, rec.u.T, rec.y.T])
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return str(path)


def toml_numbers(table):
    """Every number of a (nested) TOML table, in a stable order.

    Parameters
    ----------
    table : dict, list or scalar
        A table as :mod:`tomllib` reads it.

    Returns
    -------
    list of float
        The numbers (booleans excluded), keys in sorted order, list items in theirs.
    """
    out = []
    if isinstance(table, dict):
        for k in sorted(table):
            out += toml_numbers(table[k])
    elif isinstance(table, list):
        for v in table:
            out += toml_numbers(v)
    elif isinstance(table, (int, float)) and not isinstance(table, bool):
        out.append(float(table))
    return out


def run_files_scenario(directory, plant_text, compensator, identify, circle):
    """Write and run a one-case scenario whose compensator identifies from files.

    Parameters
    ----------
    directory : pathlib.Path
        Holds the records; the plant (``plant.toml``), the scenario (``s.toml``) and its
        report (``out/s``) are written there.
    plant_text : str
        The plant preset's text.
    compensator : str
        The ``[compensator]`` table's lines (kind, model, dynamics), TOML.
    identify : str
        The ``[compensator.identify]`` table's lines, TOML.
    circle : str
        The case's reference circle, an inline TOML table.

    Returns
    -------
    pathlib.Path
        The report's directory ``out/s``; ``hammerstein run`` exited 0 (asserted).
    """
    directory = Path(directory)
    (directory / "plant.toml").write_text(plant_text, encoding="utf-8")
    dynamics = "true" if "dynamics" in compensator else "false"
    (directory / "s.toml").write_text(
        f'name = "s"\n[plant]\npreset = "plant.toml"\ndynamics = {dynamics}\n'
        f"[compensator]\n{compensator.strip()}\n[compensator.identify]\n{identify.strip()}\n"
        f'[[cases]]\nname = "c"\nreference = {circle}\n', encoding="utf-8")
    assert main(["run", str(directory / "s.toml"), "--out", str(directory / "out"), "-q",
                 "--figures", "none"]) == 0
    return directory / "out" / "s"
