"""`hammerstein list --scenarios DIR` sorts files by what they are: scenario, preset or
dynamics file, model file (identify --out, saved identified models)."""

import shutil
from pathlib import Path

import pytest

import hammerstein as hs
from hammerstein.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def folder(tmp_path):
    shutil.copy(ROOT / "scenarios" / "default.toml", tmp_path / "a-scenario.toml")
    shutil.copy(ROOT / "scenarios" / "presets" / "coupled-2dof.toml", tmp_path / "a-preset.toml")
    pi = hs.PrandtlIshlinskii([0.0, 1.0, 2.0], [1.0, 0.5, 0.25])
    model = hs.MultivariablePI([[pi, 0.1], [None, pi]], input_names=["ux", "uy"],
                               output_names=["x", "y"])
    hs.save_model(model, tmp_path / "identified.toml", metadata={"method": "closed-form"})
    # identify writes the records' limits (and the creep) beside the model
    (tmp_path / "with-limits.toml").write_text(
        (tmp_path / "identified.toml").read_text(encoding="utf-8")
        + '\n[amplifier]\nsource = "records"\nrange = [-10.0, 10.0]\nslew_rate = 2e4\n',
        encoding="utf-8")
    (tmp_path / "broken.toml").write_text("[model\n", encoding="utf-8")
    return tmp_path


def _sections(text):
    """Section heading (first words) -> the file names listed under it."""
    out, current = {}, None
    for line in text.splitlines():
        if not line.startswith(" "):
            current = line.split(" under ")[0].split(":")[0]
            out[current] = []
        elif current is not None:
            out[current].append(Path(line.strip().split(";")[0]).name)
    return out


def test_model_files_are_listed_apart_from_scenarios(folder, capsys):
    assert main(["list", "--scenarios", str(folder)]) == 0
    sections = _sections(capsys.readouterr().out)
    assert sections["scenarios"] == ["a-scenario.toml", "broken.toml"]   # validate says why
    assert sections["preset and dynamics files"] == ["a-preset.toml"]
    assert sections["model files"] == ["identified.toml", "with-limits.toml"]


def test_a_model_files_line_gives_its_size(folder, capsys):
    assert main(["list", "--scenarios", str(folder)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "identified.toml" in ln)
    assert line.endswith("2x2 PI (ux, uy -> x, y), 6 hysterons")         # 2 PIs of 3 plays


def test_a_preisach_or_generalised_pi_model_file_is_listed_with_its_size(tmp_path, capsys):
    # the classes identify writes by default: listing one raised AttributeError
    # ('MultivariableHysteresis' object has no attribute 'size_text'), exit 1
    model = hs.load_plant("realistic-2dof").hysteresis
    hs.save_model(model, tmp_path / "preisach.toml", metadata={"method": "preisach"})
    assert main(["list", "--scenarios", str(tmp_path)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "preisach.toml" in ln)
    assert line.endswith(f"2x2 Preisach (ux, uy -> x, y), {model.n_hysterons} states")
