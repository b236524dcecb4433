"""Every figure shows its data: the checker itself, the sweep figures, every bundled report."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from figure_checks import figure_problems, png_problems  # noqa: E402

from hammerstein.report.sweeps import sweep_figure  # noqa: E402
from hammerstein.scenario.sweeps import SweepSpec  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = sorted([*(ROOT / "scenarios").glob("*.toml"), *(ROOT / "scenarios" / "paper").glob("*.toml")])


# -- the checker finds what a reader would see -------------------------------------------
def _figure(*draw):
    fig, ax = plt.subplots()
    for d in draw:
        d(ax)
    return fig


@pytest.mark.parametrize("draw, expected", [
    ([lambda ax: ax.plot([0, 1], [0, 1], label="a"), lambda ax: ax.legend()], []),
    ([lambda ax: ax.scatter([1, 2], [3, 4])], []),
    ([lambda ax: ax.imshow(np.eye(3))], []),
    ([lambda ax: ax.bar([1, 2], [3, 4])], []),
    ([], ["no data drawn"]),                                       # an empty panel
    ([lambda ax: ax.axhline(1.0)], ["no data drawn"]),             # a reference line is no data
    ([lambda ax: ax.plot([0, 1], [np.nan, np.nan])], ["no data drawn"]),
    ([lambda ax: ax.text(0.5, 0.5, "no data: every case diverged")], []),
    ([lambda ax: ax.plot([0, 1], [0, 1]), lambda ax: ax.plot([5, 6], [5, 6], label="far"),
      lambda ax: ax.set_xlim(0, 1), lambda ax: ax.set_ylim(0, 1)],
     ["line 'far' lies entirely outside"]),
    ([lambda ax: ax.plot([0, 1], [0, 1], label="drawn"),
      lambda ax: ax.legend([ax.lines[0], plt.Line2D([], [], linestyle="--")], ["drawn", "(dashed)"])],
     ["legend entry '(dashed)' names no drawn artist"]),
])
def test_checker_reports_what_a_reader_would_see(draw, expected):
    fig = _figure(*draw)
    fig.canvas.draw()
    problems = figure_problems(fig)
    plt.close(fig)
    assert len(problems) == len(expected)
    for p, e in zip(problems, expected):
        assert e in p


def test_png_checker_finds_blank_and_broken_files(tmp_path):
    blank = _figure(lambda ax: ax.set_axis_off())
    blank.savefig(tmp_path / "blank.png")
    drawn = _figure(lambda ax: ax.plot([0, 1], [0, 1]))
    drawn.savefig(tmp_path / "drawn.png")
    plt.close("all")
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nnot a png")
    assert png_problems(tmp_path / "drawn.png") == []
    assert "blank" in png_problems(tmp_path / "blank.png")[0]
    assert "does not open" in png_problems(tmp_path / "broken.png")[0]


# -- sweep figures: every metric and channel ---------------------------------------------
def _sweep(metric, axes, mode="reference"):
    """A sweep table as sweep_table writes it: 2 outputs x, y, their Euclidean channel x+y."""
    freqs = [10.0, 50.0, 100.0]
    cases, rows = [], []
    for axis in axes:
        for f in freqs:
            case = f"{axis}-{f:g}"
            cases.append({"case": case, "frequency_hz": f, "compensator": "-", "axis": axis})
            for ch in ("x", "y"):
                rows.append({"frequency_hz": f, "compensator": "-", "axis": axis or "-",
                             "channel": ch, "rms_error": 0.01 * f, "max_abs_error": 0.02 * f})
            rows.append({"frequency_hz": f, "compensator": "-", "axis": axis or "-",
                         "channel": "x+y", "max_euclidean_error": 0.03 * f,
                         "rms_euclidean_error": 0.015 * f})
    spec = SweepSpec(name="s", mode=mode, metric=metric, frequencies=freqs, labels=["-"],
                     axes=list(axes), cases=cases)
    return pd.DataFrame(rows), spec


@pytest.mark.parametrize("metric, axes, channels", [
    ("rms_error", ["x", "y"], ["x", "y"]),
    ("max_abs_error", [None], ["x", "y"]),
    ("max_euclidean_error", [None], ["x+y"]),
    ("rms_euclidean_error", ["x", "y"], ["x+y"]),
])
def test_sweep_figure_draws_the_channels_holding_the_metric(metric, axes, channels):
    table, spec = _sweep(metric, axes)
    fig = sweep_figure(table, spec, ["x", "y"], "t")
    fig.canvas.draw()
    assert figure_problems(fig) == []
    assert len(fig.axes) == len(channels) * len(axes)
    for ax, (ch, axis) in zip(fig.axes, [(c, a) for c in channels for a in axes]):
        assert ax.get_ylabel().endswith(f", {ch} [µm]")
        assert ch in ax.get_title()
        (line,) = ax.lines
        expected = table[(table.channel == ch) & (table.axis == (axis or "-"))][metric]
        np.testing.assert_allclose(line.get_ydata(), expected.to_numpy())
    if metric == "rms_error":     # the direct transfer on the diagonal, cross-coupling off it
        titles = [ax.get_title() for ax in fig.axes]
        assert "direct: x vs x_r" in titles[0] and "cross-coupling: x vs y_r" in titles[1]
    plt.close(fig)


def test_sweep_figure_says_so_when_no_case_has_a_value():
    table, spec = _sweep("max_euclidean_error", [None])
    table["max_euclidean_error"] = np.nan                    # every case diverged
    fig = sweep_figure(table, spec, ["x", "y"], "t")
    fig.canvas.draw()
    assert figure_problems(fig) == []
    assert all("no data" in ax.texts[0].get_text() for ax in fig.axes)
    plt.close(fig)


# -- every bundled scenario's report -----------------------------------------------------
# The reports are those of the one `hammerstein run` of every bundled scenario that
# tests/cli/test_cli.py checks too (tests/conftest.py, bundled_reports): each figure job
# was also drawn in this process from a pickled copy and checked there (figure_problems,
# png_problems), as CheckingRenderer does; the PNG files are those the runner's pool drew.
@pytest.mark.slow
@pytest.mark.xdist_group("bundled-reports")   # one run of them all (conftest.py)
@pytest.mark.parametrize("path", BUNDLED, ids=[p.relative_to(ROOT / "scenarios").as_posix()
                                               for p in BUNDLED])
def test_every_figure_of_every_bundled_report_shows_its_data(path, bundled_reports):
    out_dir = bundled_reports.out / path.stem          # the scenario's name is its file's
    assert (out_dir / "metrics.csv").is_file(), \
        f"{path.name} failed in the run (its error is in the first test's stderr)"
    checked = bundled_reports.figures[path.resolve()]
    pngs = sorted(p.name for p in out_dir.glob("*.png"))
    assert pngs and sorted(checked.names) == pngs
    assert checked.problems == []
    for name in pngs:
        assert png_problems(out_dir / name) == []


# -- single figures: what they draw is what they say ---------------------------------------
def test_trajectory_figure_keeps_every_output_in_time_and_error_panels():
    from hammerstein.report.trajectories import trajectory_figure
    t = np.arange(2000) * 5e-5
    th = 2 * np.pi * 50 * t
    ref = np.vstack([10 * np.cos(th), 10 * np.sin(th), 2 * np.sin(2 * th)])
    out = ref + np.vstack([0.1 * np.sin(th), 0.2 * np.cos(th), 0.3 * np.ones_like(t)])
    fig = trajectory_figure(t, ref, out, ["x", "y", "z"], "three outputs", settle_time=0.01,
                            inputs=ref / 5, input_names=["ux", "uy", "uz"])
    fig.canvas.draw()
    assert figure_problems(fig) == []
    by_title = {ax.get_title().split("\n")[0]: ax for ax in fig.axes}
    assert [ln.get_label() for ln in by_title["(b) time domain"].lines] == \
        ["x_r", "x", "y_r", "y", "z_r", "z"]
    errors = by_title["(c) tracking error per axis"].lines
    assert [ln.get_label() for ln in errors] == ["x_r - x", "y_r - y", "z_r - z"]
    np.testing.assert_allclose(errors[2].get_ydata(), -0.3)          # z's error, drawn
    (eu,) = [a for a in fig.axes if a.get_title().startswith("(e)")][0].lines
    # |e|^2 = 0.01 sin^2 + 0.04 cos^2 + 0.09: largest at cos^2 = 1, over x, y and z
    np.testing.assert_allclose(eu.get_ydata().max(), np.sqrt(0.2 ** 2 + 0.3 ** 2), rtol=1e-3)
    plt.close(fig)


@pytest.mark.parametrize("recorded", [True, False])
def test_divergence_title_cites_only_what_is_drawn(recorded):
    from hammerstein.report.trajectories import divergence_figure
    u = np.vstack([10.0 ** np.arange(10), 0.5 * 10.0 ** np.arange(10)])
    if not recorded:
        u[:, 8:] = np.nan                        # the runner records nothing from the sample on
    fig = divergence_figure(u, ["ux", "uy"], 8, "|U| = 1e+08 V exceeds the bound 1e+04 V", "t")
    fig.canvas.draw()
    assert figure_problems(fig) == []
    title = fig.texts[0].get_text() if fig.texts else fig._suptitle.get_text()
    assert ("(not recorded)" in title) is not recorded
    last = max(np.nanmax(np.where(np.isfinite(ln.get_ydata()), ln.get_xdata(), np.nan))
               for ln in fig.axes[0].lines if ln.get_label().startswith("|"))
    assert last == (8 if recorded else 7)
    plt.close(fig)


def test_bode_figure_nyquist_line_is_a_grey_reference_and_the_legend_is_off_the_axes():
    from hammerstein.models.dynamics import bending_modes, discretize
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    T = 5e-5
    G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2]), T)
    fig = dynamics_bode_figure(discretize(bending_modes([300.0, 295.0], [0.15, 0.2]), T), G,
                               labels=("identified", "true G"))
    fig.canvas.draw()
    assert figure_problems(fig) == []
    nyq = [ln for ax in fig.axes for ln in ax.lines if ln.get_label().startswith("Nyquist")]
    assert nyq and all(ln.get_color() == "0.55" and ln.get_linestyle() == ":" for ln in nyq)
    assert all(np.allclose(ln.get_xdata(), 0.5 / T) for ln in nyq)
    assert all(ax.get_legend() is None for ax in fig.axes)
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == \
        ["identified", "true G", f"Nyquist frequency ({0.5 / T:g} Hz)"]
    box = legend.get_window_extent()                 # above every panel: on no curve
    assert all(box.y0 >= ax.get_window_extent().y1 for ax in fig.axes)
    plt.close(fig)


def test_title_checker_finds_a_title_wider_than_the_figure():
    from figure_checks import title_problems
    fig = _figure(lambda ax: ax.plot([0, 1], [0, 1]))
    fig.suptitle("a title " * 40)
    fig.axes[0].set_title("short")
    fig.canvas.draw()
    (problem,) = title_problems(fig)
    assert "leaves the figure" in problem and "a title" in problem
    plt.close(fig)


def test_raster_error_map_title_fits_inside_the_figure():
    from figure_checks import title_problems
    from hammerstein.report.trajectories import raster_error_map
    n_lines, per = 8, 100
    x = np.tile(np.r_[np.linspace(0, 40, per // 2), np.linspace(40, 0, per // 2)], n_lines)
    line = np.repeat(np.arange(n_lines), per)
    trace = np.tile(np.r_[np.ones(per // 2, bool), np.zeros(per // 2, bool)], n_lines)
    e = np.vstack([0.1 * np.sin(x), 0.05 * np.cos(x)])
    title = ("Hammerstein and Preisach-inverse compensators on a Preisach actuator with coupled "
             "modes and creep (realistic-2dof): raster-40um-64-lines-20Hz, tracking error per "
             "scan line")
    fig = raster_error_map(x, e, ["x_r - x (fast)", "y_r - y (slow)"], line, trace, 40.0, "x",
                           title)
    fig.canvas.draw()
    assert title_problems(fig) == []
    assert figure_problems(fig) == []
    plt.close(fig)


def test_bode_figure_draws_no_minor_grid():
    """Regression: python-control's bode_plot drew a grid line on every minor tick of the
    log frequency axis, a dense mesh over the curves."""
    from hammerstein.models.dynamics import bending_modes, discretize
    from hammerstein.report.dynamics_figure import dynamics_bode_figure
    T = 5e-5
    G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2]), T)
    fig = dynamics_bode_figure(G, G)
    fig.canvas.draw()
    for ax in fig.axes:
        if not ax.get_visible() or not ax.lines:
            continue
        minor = [ln for t in ax.xaxis.get_minor_ticks() for ln in [t.gridline] if ln.get_visible()]
        assert minor == []
        assert any(t.gridline.get_visible() for t in ax.xaxis.get_major_ticks())
    plt.close(fig)
