"""identify warns when an output falls as its own input rises (an inverted sensor sign),
sits at its extreme value on many samples (a saturated sensor), or leads its input (loops
that run clockwise: a time column shifted against the inputs).

The model written then cannot be inverted: a classical PI fitted on it has
cumulative weight sums S_i <= 0, and ``compensate`` refused it with a message
about S_i. The slope is the least-squares one of output k on input k over
every record: closed form here, y = a u + b v + noise-free offsets.
"""

import re
from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.cli.identify import _falling_direct_paths
from hammerstein.cli.main import main


def _records(a_x, a_y):
    t = np.linspace(0, 1, 2001)
    u = np.vstack([10 * np.sin(2 * np.pi * t), np.zeros_like(t)])
    v = np.vstack([np.zeros_like(t), 10 * np.sin(2 * np.pi * t)])
    out = []
    for w in (u, v):       # x = a_x ux + 0.1 uy + 3, y = a_y uy + 0.2 ux
        out.append(SimpleNamespace(u=w, y=np.vstack([a_x * w[0] + 0.1 * w[1] + 3.0,
                                                     a_y * w[1] + 0.2 * w[0]])))
    return out


@pytest.mark.parametrize("a_x, a_y, falling", [(1.5, 2.0, []), (-1.665, 2.0, ["x"]),
                                              (-1.0, -0.5, ["x", "y"])])
def test_a_falling_direct_path_is_named_with_its_slope(a_x, a_y, falling):
    lines = _falling_direct_paths(_records(a_x, a_y), ["ux", "uy"], ["x", "y"], "µm", "V")
    assert [ln.split()[0] for ln in lines] == falling
    for ln in lines:
        slope = a_x if ln.startswith("x") else a_y
        assert f"slope {slope:.4g} µm/V" in ln and "inverted sign" in ln


@pytest.mark.parametrize("clip, said", [(None, []), (8.0, ["x"])])
def test_an_output_flat_at_its_extreme_is_named(clip, said):
    """A sensor clipped at 12 µm on 9.9 % of the samples was identified without a word. A
    noisy unclipped record repeats its extreme on a sample or two."""
    from hammerstein.cli.identify import _flat_extremes
    records = _records(1.5, 2.0)
    rng = np.random.default_rng(0)
    for r in records:
        r.y = r.y + rng.normal(0, 0.03, r.y.shape)
        if clip is not None:
            r.y[0] = np.minimum(r.y[0], clip)
    lines = _flat_extremes(records, ["x", "y"], "µm")
    assert [ln.split()[0] for ln in lines] == said
    if said:
        n = sum(int(np.count_nonzero(r.y[0] == clip)) for r in records)
        assert f"exactly 8 µm, its largest value, on {n} samples" in lines[0]


@pytest.mark.parametrize("shift, said", [(-10, False), (10, True)])
def test_an_output_shifted_ahead_of_its_input_is_named_with_its_loop_opening(
        tmp_path, capsys, shift, said):
    """u = A sin(2 pi i / N), x = B sin(2 pi (i + shift) / N) + c over whole cycles: an ellipse
    opening by sin(phi) of x's span at u = 0, phi = 2 pi shift / N (shift > 0: x leads, the
    loops run clockwise). Sampled N times a cycle, the shoelace area of each cycle is the
    inscribed polygon's, pi A B sin(phi) times sin(2 pi / N) / (2 pi / N); with N a multiple of
    4 the samples meet both signals' peaks, so the travel is exactly 4 A a cycle and the span
    2 B. The share printed (3 significant digits) is therefore 100 sin(phi) times that factor,
    to half a unit of its last digit."""
    n, cycles, a, b = 500, 8, 10.0, 5.0
    i = np.arange(n * cycles + 1)
    u = a * np.sin(2 * np.pi * i / n)
    x = b * np.sin(2 * np.pi * (i + shift) / n) + 3.0
    path = tmp_path / "r.csv"
    np.savetxt(path, np.column_stack([1e-3 * i, u, x]), delimiter=",", header="t,u,x",
               comments="", fmt="%.17g")
    assert main(["identify", str(path), "--inputs", "u", "--outputs", "x", "--time", "t",
                 "--model", "classical", "--out", str(tmp_path / "m.toml"), "--force"]) == 0
    err = capsys.readouterr().err
    found = re.findall(r"warning: x's loops over u run clockwise \(the output leads its input: "
                       r"loops opening by about ([0-9.]+) % of x's span", err)
    assert len(found) == int(said), err
    assert (tmp_path / "m.toml").exists()          # a warning: the model is still written
    if said:
        # np.sinc(z) = sin(pi z) / (pi z): sinc(2 / n) = sin(2 pi / n) / (2 pi / n)
        opening = 100 * np.sin(2 * np.pi * shift / n) * np.sinc(2 / n)
        assert float(found[0]) == pytest.approx(opening, abs=0.05)   # 12.53: "12.5"
        assert len([ln for ln in err.splitlines() if "run clockwise" in ln]) == 1   # one line
