"""``hammerstein export`` on models identified from actuators outside the model classes.

Records of the independent actuators of ``tests/outside_actuator.py`` (Preisach-type loops,
creep, three coupled modes, 40 nm noise) and ``tests/gpi_actuator.py`` (generalised-PI
loops), made by ``hammerstein excitation``; ``hammerstein identify --dynamics
--creep-records`` with ``--model preisach``, ``generalized`` and ``classical``. Each model
file is exported with the defaults (no ``--kind``) and with explicit kinds; the written C,
compiled against its header (``-Werror -pedantic``), equals the Python compensator that
``hammerstein export`` builds (:func:`hammerstein.export.build.compensator_from_source`) to 1e-12
relative on a faded-in circle. Slow: the identifications take minutes.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.export import STATUS_RANGE, export_c
from hammerstein.compensation.kind_choice import choose_kind
from hammerstein.export.build import compensator_from_source, limits_from_table, load_source

from conftest import Harness, needs_cc
from outside_actuator import OutsideActuator, write_csv
from test_c_equivalence import python_voltages, rel_error

T = 5e-5


def records(d, actuator):
    """``hammerstein excitation`` files played through an actuator: kind -> paths."""
    rec = d / "records"
    assert main(["excitation", "--inputs", "ux,uy", "--amplitude", "10", "--sampling-period",
                 repr(T), "--out", str(rec)]) == 0
    rng = np.random.default_rng(11)
    files = {}
    for path in sorted(rec.glob("*.csv")):
        data = np.loadtxt(path, delimiter=",", skiprows=1)
        write_csv(path, data[:, 0], data[:, 1:3].T, actuator.simulate(data[:, 1:3].T, rng=rng))
        kind = path.stem.split("-")[0] + ("-validation" if "validation" in path.stem else "")
        files.setdefault(kind, []).append(str(path))
    return files


def identify(files, out, model):
    assert main(["identify", *files["hysteresis"], "--inputs", "ux,uy", "--outputs", "x,y",
                 "--time", "t", "--dynamics", "--dynamics-records", *files["multisine"],
                 *files["multisine-validation"], "--creep-records", *files["creep"],
                 "--model", model, "--out", str(out)]) == 0
    return out


def faded_circle(n=3000, radius=8.0, f=100.0):
    t = np.arange(n) * T
    w = np.minimum(t / (2 / f), 1.0) ** 2
    return radius * w * np.vstack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])


def check_export(path, kind, workdir):
    """Export one kind of one model file through the CLI, compile, compare; the error."""
    argv = ["export", str(path), "--target", "c", "--out", str(workdir), "--name", "act"]
    if kind is not None:
        argv += ["--kind", kind]
    # a wide amplifier range replaces the records' (identify writes their range and slew):
    # this test is about C = Python, which the amplifier's clamps would not be
    assert main(argv + ["--check", "warn", "--amplifier-range", "-1000", "1000"]) == 0, \
        (path.name, kind)
    source = load_source(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        choice = None if kind is not None else choose_kind(
            source.model, source.dynamics is not None, None)
        gain = None if choice is None else choice.options.get("gain")
        if gain is not None and not isinstance(gain, str):
            gain = [list(map(float, row)) for row in gain]     # K [µm/V], as the CLI passes it
        comp, Ts = compensator_from_source(source, kind or choice.kind, gain=gain, check="warn")
        limits = limits_from_table({"range": [-1000.0, 1000.0]}, list(source.model.input_names),
                                   "--amplifier-range/--slew-rate")
        code = export_c(comp, "act", Ts, limits=limits)
    # what the CLI wrote (its first line adds the version)
    assert code.source.split("\n", 1)[1] == (workdir / "act.c").read_text().split("\n", 1)[1]
    h = Harness(code, workdir / "h")
    yr = faded_circle()
    u_c, status, size = h.run(yr)
    u_py = python_voltages(comp, yr)
    assert np.all((status & ~STATUS_RANGE) == 0)
    return rel_error(u_c, u_py), size


@pytest.fixture(scope="module")
def outside_models(tmp_path_factory):
    d = tmp_path_factory.mktemp("outside-export")
    files = records(d, OutsideActuator(creep=True))
    return {m: identify(files, d / f"{m}.toml", m) for m in ("preisach", "generalized", "classical")}


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("model, kind", [
    ("preisach", None), ("preisach", "hammerstein"), ("preisach", "per-axis"),
    ("generalized", None), ("generalized", "hammerstein"),
    ("classical", None), ("classical", "hammerstein"), ("classical", "per-axis"),
])
def test_identified_models_export_and_equal_python(outside_models, model, kind, tmp_path, capsys):
    err, size = check_export(outside_models[model], kind, tmp_path / "out")
    print(f"{model} {kind or 'default'}: max relative error {err:.2e}, state {size} B")
    assert err <= 1e-12
