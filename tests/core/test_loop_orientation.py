"""identify warns when a direct path's loops run clockwise (an output that leads its input).

Expectations: the area of an ellipse in closed form, the sign of the loops of a Preisach
actuator's records (counter-clockwise: it lags), and the same records with their samples in
reverse order (every loop then clockwise); a scenario's files table warns as identify does.
"""

import warnings

from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.exceptions import HammersteinWarning
from hammerstein.io.presets import load_plant
from hammerstein.scenario.records_route import identified_from_records
from hammerstein.identification.loop_orientation import (CLOCKWISE_SHARE,
                                                         clockwise_loop_warnings, loop_area_share)
from hysteresis_records import decreasing_sine_records, preisach_actuator, write


@pytest.mark.parametrize("phi", [-0.4, -0.05, 0.05, 0.2, 0.6])
@pytest.mark.parametrize("cycles", [1, 5])
def test_the_share_of_an_ellipse_is_a_quarter_pi_times_sin_phi(phi, cycles):
    """u = a sin t, y = b sin(t - phi) + c: area pi a b sin(phi) per cycle, over half the
    travel (2 a per half cycle) times the span 2 b."""
    t = np.linspace(0.0, 2 * np.pi * cycles, 4000 * cycles + 1)
    rec = SimpleNamespace(u=(3.0 * np.sin(t))[None], y=(0.7 * np.sin(t - phi) + 5.0)[None])
    assert loop_area_share([rec], 0, 0) == pytest.approx(np.pi / 4 * np.sin(phi), rel=1e-4)
    assert bool(clockwise_loop_warnings([rec], ["u"], ["x"])) == (
        np.pi / 4 * np.sin(phi) < -CLOCKWISE_SHARE)


def test_a_path_no_record_moves_has_no_share():
    rec = SimpleNamespace(u=np.zeros((1, 50)), y=np.ones((1, 50)))
    assert loop_area_share([rec], 0, 0) is None
    assert clockwise_loop_warnings([rec], ["u"], ["x"]) == []


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    d = tmp_path_factory.mktemp("orientation")
    lag = decreasing_sine_records(d, preisach_actuator(), 0.04, "lag", 1e-3)
    lead = []
    for k, path in enumerate(lag):          # the same samples in reverse order: leading
        data = np.loadtxt(path, delimiter=",", skiprows=1)
        write(d / f"lead-{k}.csv", data[:, 0], data[::-1, 1:3].T, data[::-1, 3:5].T)
        lead.append(str(d / f"lead-{k}.csv"))
    return d, lag, lead


@pytest.mark.parametrize("which, warned", [("lag", False), ("lead", True)])
def test_identify_warns_of_clockwise_loops(records, capsys, which, warned):
    d, lag, lead = records
    out = d / f"{which}.toml"
    assert main(["identify", *(lag if which == "lag" else lead), "--inputs", "ux,uy",
                 "--outputs", "x,y", "--time", "t", "--model", "classical", "--out",
                 str(out), "--force"]) == 0
    err = capsys.readouterr().err
    for name, inp in (("x", "ux"), ("y", "uy")):
        said = f"warning: {name}'s loops over {inp} run clockwise (the output leads its input"
        assert (said in err) == warned, err
    assert out.exists()                     # a warning: the model is still written


@pytest.mark.parametrize("which, warned", [("lag", False), ("lead", True)])
def test_a_files_table_warns_of_clockwise_loops(records, which, warned):
    """The scenario route reads the same files as identify and says the same (its unit
    warnings did, this one too); the model is identified either way."""
    d, lag, lead = records
    files = [p.rsplit("/", 1)[-1] for p in (lag if which == "lag" else lead)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = identified_from_records(load_plant("realistic-2dof"),
                                        {"records": "files", "model": "classical",
                                         "hysteresis_records": files}, False, base_dir=d)
    said = [str(w.message) for w in caught
            if issubclass(w.category, HammersteinWarning) and "run clockwise" in str(w.message)]
    assert [ln.split(": ", 1)[1].split("'")[0] for ln in said] == (["x", "y"] if warned else [])
    assert all(ln.startswith("identify (records = 'files'): ") for ln in said)
    assert found.preset_text


@pytest.mark.parametrize("phi, warned", [(0.2, False), (-0.2, True)])
def test_a_falling_path_is_judged_against_its_slope(phi, warned):
    """A sensor of inverted sign (identify warns of its slope apart): a lagging output's loops
    run clockwise there, and the output does not lead; a leading one is still named."""
    t = np.linspace(0.0, 6 * np.pi, 12001)
    rec = SimpleNamespace(u=(3.0 * np.sin(t))[None], y=(-0.7 * np.sin(t - phi))[None])
    assert (loop_area_share([rec], 0, 0) < 0) == (phi > 0)       # clockwise when it lags
    lines = clockwise_loop_warnings([rec], ["u"], ["x"])
    assert bool(lines) == warned, lines
    if warned:
        assert lines[0].startswith("x's loops over u run counter-clockwise on its falling path "
                                   "(the output leads its input: loops opening by about 19.9 %")
