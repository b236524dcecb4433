"""``hammerstein export``: files written, refusals as one line, ownership of files."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from hammerstein import InverseMultiplicativeCompensator
from hammerstein.cli.main import main
from hammerstein.io.presets import load_plant, save_model
from hammerstein.export import MARKER

from conftest import Harness, needs_cc
from test_c_equivalence import T, python_voltages, rel_error, sine


def run(capsys, *argv):
    code = main(["export", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_c_files_written_then_replaced(tmp_path, capsys):
    out = tmp_path / "gen"
    code, stdout, err = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out),
                            "--kind", "hammerstein")
    assert code == 0 and err == ""
    h, c = out / "rakotondrabe_2dof_hammerstein.h", out / "rakotondrabe_2dof_hammerstein.c"
    lines = stdout.splitlines()
    assert lines[:2] == [f"wrote {h}", f"wrote {c}"]
    assert len(lines) == 4 and lines[2].startswith("state: ")
    assert lines[3].startswith("limits: none (the voltages are not clamped")
    for f in (h, c):
        assert f.read_text().startswith(MARKER)
    text = h.read_text()
    for macro in ("N_INPUTS 2", "N_OUTPUTS 2", "PREVIEW 2", "SAMPLING_PERIOD 5e-05"):
        assert f"#define rakotondrabe_2dof_hammerstein_{macro}" in text
    # a second export replaces its own files
    assert run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out), "--kind",
               "hammerstein")[0] == 0


def test_the_stable_inversion_is_exported(tmp_path, capsys):
    # G of the bundled preset has no zero outside the unit circle: the look-ahead is its
    # relative degree (1), the stable modes run forward (tests/export/test_stable_export.py)
    out = tmp_path / "o"
    code, stdout, _ = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out),
                          "--kind", "hammerstein", "--inversion", "stable", "--name", "st")
    assert code == 0 and "#define st_PREVIEW 1" in (out / "st.h").read_text()
    assert "stable inversion of G over a look-ahead of 1 sample (" in (out / "st.h").read_text()


@pytest.mark.parametrize("argv, status, needle", [
    (["--kind", "hammerstein", "--inversion", "stable", "--precision", "float"], 1,
     "precision: 'float'"),
    (["--kind", "multivariable", "--gain", "identity"], 1, "rho(I - K^-1 J)"),
    (["--kind", "per-axis", "--iterations", "3"], 1, "takes no gain"),
    (["--amplifier-range", "5", "-5"], 2, "--amplifier-range: expected MIN MAX"),
    (["--slew-rate", "100"], 2, "--slew-rate needs"),
    (["--amplifier-range", "-5", "5", "--slew-rate", "1,2,3"], 2,
     "--slew-rate: expected 1 or 2 rates [V/s] (one per input: ux, uy), found 3"),
    (["--amplifier-range", "-5", "5", "--slew-rate", "1,-2"], 2, "--slew-rate: expected a number > 0"),
    (["--closed-loop", "--amplifier-range", "-5", "5", "--slew-rate", "1,2"], 2,
     "--closed-loop: the [feedback] amplifier takes one --slew-rate for every input, found 2"),
    (["--name", "int"], 2, "--name"),
    (["--name", "9lives"], 2, "--name"),
    (["--iterations", "0"], 2, "--iterations"),
    (["--kind", "multivariable", "--feedback", "lowpass"], 2,
     "--feedback lowpass needs --cutoff-hz HZ"),
    (["--kind", "preisach-inverse"], 1, "classical PI model, which kind 'preisach-inverse' does not take; the kinds that export it: hammerstein, multivariable"),
])
def test_refusals_are_one_line(tmp_path, capsys, argv, status, needle):
    code, stdout, err = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out",
                            str(tmp_path / "o"), *argv)
    assert code == status and stdout == ""
    assert len(err.strip().splitlines()) == 1 and needle in err and "Traceback" not in err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


@pytest.mark.parametrize("argv", [["--gain", "identity"], ["--iterations", "9"],
                                  ["--feedback", "lowpass", "--cutoff-hz", "5"]])
def test_the_exact_hammerstein_kind_refuses_the_laws_options(tmp_path, capsys, argv):
    """An outside check: over a Preisach model the default kind (hammerstein, its static part
    the exact per-sample inverse) exported a byte-identical C with --gain, --iterations or
    --feedback, which it ignored; preisach-inverse refused them."""
    code, stdout, err = run(capsys, "realistic-2dof", "--target", "c", "--out",
                            str(tmp_path / "o"), *argv)
    assert code == 1 and stdout == "" and len(err.strip().splitlines()) == 1
    assert "over a Preisach model inverts it exactly per sample and takes no gain" in err
    assert not (tmp_path / "o").exists()


def test_the_default_name_of_a_long_preset_keeps_the_kind(tmp_path, capsys):
    """An outside check: the default ``<preset>_<kind>`` was cut at 40 characters, which on a
    long preset name dropped the kind: a second kind's export replaced the first's files."""
    model = tmp_path / "my-xy-stage-2026-11-identified-classical-model.toml"
    save_model(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis, model)
    names = []
    for kind in ("multivariable", "per-axis"):
        code, _, err = run(capsys, str(model), "--target", "c", "--out", str(tmp_path / "o"),
                           "--kind", kind, "--sampling-period", "1e-4")
        assert code == 0, err
        names.append(sorted(p.name for p in (tmp_path / "o").glob("*.h")))
    assert names[0] == ["my_xy_stage_2026_11_identi_multivariable.h"]
    assert names[1] == ["my_xy_stage_2026_11_identi_multivariable.h",
                        "my_xy_stage_2026_11_identified_per_axis.h"]
    assert all(len(n) <= 40 + 2 for n in names[1])


def test_model_file_needs_a_sampling_period(tmp_path, capsys):
    model = tmp_path / "model.toml"
    save_model(load_plant("rakotondrabe-2dof", dynamics=False).hysteresis, model)
    code, _, err = run(capsys, str(model), "--target", "c", "--out", str(tmp_path / "o"))
    assert code == 1 and "--sampling-period" in err
    code, _, err = run(capsys, str(model), "--target", "c", "--out", str(tmp_path / "o"),
                       "--kind", "hammerstein", "--sampling-period", "1e-4")
    assert code == 1 and "no dynamics to invert; the kinds that export it: multivariable" in err
    code, stdout, _ = run(capsys, str(model), "--target", "c", "--out", str(tmp_path / "o"),
                          "--kind", "per-axis", "--sampling-period", "1e-4", "--name", "pa")
    assert code == 0 and "#define pa_SAMPLING_PERIOD 0.0001" in (tmp_path / "o" / "pa.h").read_text()


def test_never_overwrites_a_file_it_did_not_write(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    mine = out / "mine.c"
    mine.write_text("int main(void) { return 0; }\n")
    code, _, err = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out), "--name", "mine")
    assert code == 2 and "not written by hammerstein export" in err and "--force" in err
    assert err.startswith("hammerstein export: error: ") and len(err.strip().splitlines()) == 1
    assert mine.read_text() == "int main(void) { return 0; }\n"
    assert not (out / "mine.h").exists()                     # nothing written at all
    fmu = out / "mine.fmu"
    fmu.write_bytes(b"not a zip")
    code, _, err = run(capsys, "rakotondrabe-2dof", "--target", "fmu", "--out", str(out),
                       "--name", "mine", "--no-binary")
    assert code == 2 and fmu.read_bytes() == b"not a zip"
    code, _, _ = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out), "--name",
                     "mine", "--force")
    assert code == 0 and mine.read_text().startswith(MARKER)


def test_out_is_a_file_is_a_usage_error(tmp_path, capsys):
    f = tmp_path / "f"
    f.write_text("x")
    code, _, err = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(f))
    assert code == 2 and len(err.splitlines()) == 1


def test_fmu_written_and_replaced(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["rakotondrabe-2dof", "--target", "fmu", "--out", str(out), "--kind", "static-gain",
            "--name", "sg", "--no-binary"]
    assert run(capsys, *argv)[0] == 0
    names = zipfile.ZipFile(out / "sg.fmu").namelist()
    assert "sources/sg.c" in names and "modelDescription.xml" in names
    assert run(capsys, *argv)[0] == 0                          # its own FMU is replaced


@needs_cc
def test_cli_limits_and_float_compile(tmp_path, capsys):
    """The command's amplifier options reach the code; its float export compiles -Werror clean."""
    out = tmp_path / "o"
    code, _, _ = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out), "--name", "fl",
                     "--precision", "float", "--amplifier-range", "-1", "1", "--slew-rate", "1e4")
    assert code == 0
    assert "typedef float fl_real;" in (out / "fl.h").read_text()

    class Code:                       # the harness needs only the name and the sizes
        name, n_inputs = "fl", 2

        @staticmethod
        def files():
            return {f.name: f.read_text() for f in (out / "fl.h", out / "fl.c")}
    u, status, _ = Harness(Code, tmp_path / "h").run(sine(1000))
    assert np.all(np.abs(u) <= 1.0) and np.any(status & 1)
    assert np.all(np.abs(np.diff(u, axis=1)) <= 1e4 * T * (1 + 1e-6))


@needs_cc
def test_cli_code_equals_python(tmp_path, capsys):
    """What the command writes is what export_c writes: same voltages as Python."""
    out = tmp_path / "o"
    assert run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out), "--name", "mv",
               "--kind", "multivariable", "--iterations", "2", "--gain", "midpoint")[0] == 0

    class Code:
        name, n_inputs = "mv", 2

        @staticmethod
        def files():
            return {f.name: f.read_text() for f in (out / "mv.h", out / "mv.c")}
    u, _, _ = Harness(Code, tmp_path / "h").run(sine(1500))
    comp = InverseMultiplicativeCompensator(load_plant("rakotondrabe-2dof").hysteresis,
                                            gain="midpoint", iterations=2)
    assert rel_error(u, python_voltages(comp, sine(1500))) <= 1e-12


@needs_cc
@pytest.mark.parametrize("kind, precision", [("hammerstein", "double"), ("per-axis", "float")])
def test_the_state_line_gives_the_struct_size_before_padding(tmp_path, capsys, kind, precision):
    """``export`` says the state's size: its reals and ints, within padding of sizeof."""
    import re
    import subprocess
    from conftest import COMPILERS
    out = tmp_path / "gen"
    code, stdout, _ = run(capsys, "rakotondrabe-2dof", "--target", "c", "--out", str(out),
                          "--kind", kind, "--precision", precision, "--name", "act")
    assert code == 0
    line = next(ln for ln in stdout.splitlines() if ln.startswith("state: "))
    reals, ints, size = map(int, re.search(r"state: (\d+) reals \(\w+\) and (\d+) ints, "
                                           r"(\d+) B before padding", line).groups())
    header = (out / "act.h").read_text()
    assert f"#define act_STATE_REALS {reals}\n" in header
    assert size == reals * (8 if precision == "double" else 4) + 4 * ints
    main_c = tmp_path / "size.c"
    main_c.write_text('#include <stdio.h>\n#include "act.h"\n'
                      'int main(void) { printf("%u", (unsigned)sizeof(act_state)); return 0; }\n')
    exe = tmp_path / "size"
    subprocess.run([COMPILERS[0], "-std=c99", "-I", str(out), "-o", str(exe), str(main_c)],
                   check=True)
    sizeof = int(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout)
    assert size <= sizeof <= size + 8          # what alignment adds
    preview = re.search(r"act_PREVIEW (\d+)", header).group(1)
    assert f"preview {preview} sample(s)" in line


def test_a_model_the_c_emitters_do_not_know_is_refused_by_name():
    """A compensator over a model of a class the C emitters do not know (a new class added
    to the registry without its emitter) is refused naming the model's type and where its
    emitter goes; it raised AttributeError inside an emitter."""
    from types import SimpleNamespace
    from hammerstein.compensation.compensators import StaticGainCompensator
    from hammerstein.exceptions import ExportError
    from hammerstein.export import export_c
    comp = StaticGainCompensator.__new__(StaticGainCompensator)
    object.__setattr__(comp, "model", SimpleNamespace(n_inputs=1, n_outputs=1))
    with pytest.raises(ExportError, match=r"a SimpleNamespace cannot be exported to C: .*"
                                          r"hammerstein/export/c_\*\.py"):
        export_c(comp, "x", 5e-5)


def test_the_limits_built_into_the_step_are_said_and_a_records_slew_is_named(tmp_path, capsys):
    # an outside check: a model identified without dynamics records took the 1 Hz hysteresis
    # records' slew (1885 V/s over +-100 V) into its step, and nothing said so: a 50 Hz
    # circle then returned STATUS_LIMIT, the only trace a comment in the header
    plant = load_plant("rakotondrabe-2dof")
    path = tmp_path / "m.toml"
    save_model(plant.hysteresis, path, {"note": "test"}, extra={"amplifier": {
        "source": "records", "ux": {"range": [-100.0, 100.0], "slew_rate": 1884.956},
        "uy": {"range": [-50.0, 100.0], "slew_rate": 3000.0}}})
    base = ["export", str(path), "--sampling-period", "5e-5", "--kind", "multivariable"]
    assert main([*base, "--out", str(tmp_path / "a")]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("limits: ")]
    # a sine of amplitude A at f needs 2 pi f A V/s: over the whole range A = span / 2
    assert lines == ["limits: ux [-100, 100] V, 1885 V/s; uy [-50, 100] V, 3000 V/s (the range "
                     "and largest slew of the records identify read, not the amplifier's: a sine "
                     f"over the whole range is slew-limited above {1884.956 / (np.pi * 200):.3g} "
                     "Hz; --slew-rate gives your amplifier's)"]
    header = (tmp_path / "a" / "m_multivariable.h").read_text()
    assert "[-100, 100] V, [-50, 100] V; slew rate 1884.96 V/s, 3000 V/s" in header
    # the amplifier's own: said as such
    assert main([*base, "--slew-rate", "2e5", "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "limits: ux [-100, 100] V, 2e+05 V/s; uy [-50, 100] V, 2e+05 V/s\n" in out
    # one rate per input (the rates a drive's start-up limit names): each built into its input
    assert main([*base, "--slew-rate", "2e5,123.25", "--out", str(tmp_path / "d")]) == 0
    assert "limits: ux [-100, 100] V, 2e+05 V/s; uy [-50, 100] V, 123.2 V/s\n" in \
        capsys.readouterr().out
    code = (tmp_path / "d" / "m_multivariable.c").read_text()
    assert f"m_multivariable_u_step0 = {2e5 * 5e-5!r};" in code
    assert f"m_multivariable_u_step1 = {123.25 * 5e-5!r};" in code
    assert main(["export", "rakotondrabe-2dof", "--kind", "multivariable", "--out",
                 str(tmp_path / "c")]) == 0
    assert "limits: none (the voltages are not clamped" in capsys.readouterr().out
