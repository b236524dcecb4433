"""Models identified from the bundled measured record are exported and match Python;
what cannot be exported is refused with one message naming it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from hammerstein import (InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                         StaticGainCompensator)
from hammerstein.cli.main import main
from hammerstein.io.presets import load_model, load_plant
from hammerstein.exceptions import ExportError
from hammerstein.export import STATUS_RANGE, AmplifierLimits, export_c
from hammerstein.export.build import limits_from_table

from conftest import Harness, needs_cc
from test_c_equivalence import python_voltages, rel_error

DATA = Path(__file__).resolve().parents[2] / "hammerstein" / "data" / "piezo-stack-150V-1Hz.csv"
T_DATA = 2e-4                 # s, the record's 5 kHz


_MODELS = {}


def identified(label, tmp_path_factory):
    """A model file identified by the CLI: plain (with the sensor offset) or with an output map."""
    if label not in _MODELS:
        extra = ["--output-map", "deadzone"] if label == "deadzone" else []
        path = tmp_path_factory.mktemp("identified") / f"{label}.toml"
        assert main(["identify", str(DATA), "--input", "2", "--output", "1", "--time", "0",
                     "--out", str(path), *extra]) == 0
        _MODELS[label] = path
    return _MODELS[label]


def reference_um(n):
    """A 1 Hz-ish triangle-and-sine mix inside the identified ±19 µm range."""
    t = np.arange(n) * T_DATA
    return (12 * np.sin(2 * np.pi * 3 * t) + 5 * np.sin(2 * np.pi * 17 * t + 0.3))[None, :]


@needs_cc
@pytest.mark.parametrize("label", ["plain", pytest.param("deadzone", marks=pytest.mark.slow)])
@pytest.mark.parametrize("kind", [InverseMultiplicativeCompensator, PerAxisInverseCompensator,
                                  StaticGainCompensator])
def test_identified_models_export(label, kind, tmp_path, tmp_path_factory, capsys):
    """(The output-map identification takes ~20 s: slow.)"""
    model = load_model(identified(label, tmp_path_factory))
    if label == "plain":
        assert model.output_offset is not None            # the sensor zero of the record
    else:
        assert model.output_map is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comp = kind(model)
    code = export_c(comp, "idm", T_DATA)
    yr = reference_um(5000)
    u_c, status, _ = Harness(code, tmp_path / "h").run(yr)
    assert np.all((status & ~STATUS_RANGE) == 0)   # the range bit: voltages beyond the model's input range
    assert rel_error(u_c, python_voltages(comp, yr)) <= 1e-12


class _Preisach:                      # a model class the C generator does not know
    n_inputs = n_outputs = 1


class _OtherCompensator:
    name = "other"


@pytest.mark.parametrize("obj, match", [
    (_OtherCompensator(), "compensator: a _OtherCompensator cannot be exported"),
    (type("C", (InverseMultiplicativeCompensator,), {"__post_init__": lambda self: None})(_Preisach()),
     "model: a _Preisach cannot be exported"),
])
def test_unknown_classes_are_refused(obj, match):
    with pytest.raises(ExportError, match=match):
        export_c(obj, "x", 1e-4)


@pytest.mark.parametrize("kwargs, match", [
    ({"name": "double"}, "name:"), ({"name": "a-b"}, "name:"), ({"name": "x" * 41}, "name:"),
    ({"precision": "half"}, "precision:"), ({"sampling_period": 0.0}, "sampling_period:"),
    ({"sampling_period": float("nan")}, "sampling_period:"),
    ({"limits": AmplifierLimits(1.0, -1.0)}, "amplifier.range"),
    ({"limits": AmplifierLimits(-1.0, 1.0, 0.0)}, "amplifier.slew_rate"),
    ({"limits": AmplifierLimits([-1.0, -1.0, -1.0], 1.0)}, "amplifier.range"),
])
def test_bad_options_name_the_field(kwargs, match):
    comp = StaticGainCompensator(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis)
    args = {"name": "ok", "sampling_period": 5e-5, **kwargs}
    with pytest.raises(ExportError, match=match):
        export_c(comp, args.pop("name"), args.pop("sampling_period"), **args)


@pytest.mark.parametrize("table, expected", [
    ({"range": [-10.0, 150.0]}, ([-10.0, -10.0], [150.0, 150.0], [np.inf, np.inf])),
    ({"range": [-10.0, 150.0], "slew_rate": 1e5, "bandwidth_hz": 5e3, "uy": {"range": [0.0, 100.0]}},
     ([-10.0, 0.0], [150.0, 100.0], [1e5, 1e5])),
    ({"ux": {"slew_rate": 2e5}}, ([-np.inf, -np.inf], [np.inf, np.inf], [2e5, np.inf])),
    ({"range": [1.0, 2.0, 3.0]}, "range"),
    ({"range": "wide"}, "range"),
    ({"range": [2.0, 1.0]}, "range"),
    ({"range": [0.0, 1.0], "slew_rate": -3.0}, "slew_rate"),
    ({"gain": 3.0}, "amplifier.gain: unknown key"),
    ({"uz": {"range": [0.0, 1.0]}}, "amplifier.uz: not an input"),
])
def test_amplifier_table(table, expected):
    """The [amplifier] table of a preset (range, slew_rate, bandwidth_hz, per-input tables)."""
    if isinstance(expected, tuple):
        got = limits_from_table(table, ["ux", "uy"]).arrays(2)
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)
    else:
        with pytest.raises(ExportError, match=expected):
            limits_from_table(table, ["ux", "uy"])


def test_a_model_of_an_unknown_class_is_refused(tmp_path):
    """A model class that is neither a classical PI nor a MultivariableHysteresis is refused by
    name (Preisach and generalised-PI models are exported: test_exact_export.py)."""
    from hammerstein.export.build import ExportSource, compensator_from_source
    source = ExportSource(tmp_path / "preset.toml", "preset", _Preisach(), 5e-5, None, None)
    with pytest.raises(ExportError, match="_Preisach is none of the model classes"):
        compensator_from_source(source, "multivariable")


def test_the_header_and_the_source_are_replaced_together_or_not_at_all(tmp_path, monkeypatch):
    # a signal after the header was renamed into place left the float header of a new export
    # beside the double source of the old one (they compiled together without a warning)
    from hammerstein.export import build
    marker = b"/* generated by hammerstein export */\n"
    build.write_files(tmp_path, {"p.h": marker + b"old h", "p.c": marker + b"old c"}, marker)
    real, calls = build.safe_write, []

    def interrupted_at_the_second(*args, **kwargs):
        calls.append(args[0])
        if len(calls) == 2:
            raise KeyboardInterrupt          # Ctrl-C while the source is being written
        return real(*args, **kwargs)

    monkeypatch.setattr(build, "safe_write", interrupted_at_the_second)
    with pytest.raises(KeyboardInterrupt):
        build.write_files(tmp_path, {"p.h": marker + b"new h", "p.c": marker + b"new c"}, marker)
    assert (tmp_path / "p.h").read_bytes().endswith(b"old h")
    assert (tmp_path / "p.c").read_bytes().endswith(b"old c")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.c", "p.h"]     # no temporary left
