"""save() updates each axis' ticks once per draw: the pixels must not change.

Reference: the same figure drawn by matplotlib alone (ticks updated and tick
labels measured as often as matplotlib does). Figures with shared axes, log
axes, a colorbar, a twin axis and axis labels (which make matplotlib update
the ticks again to place them).
"""

import numpy as np
import pytest
from matplotlib.axis import Axis
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hammerstein.report import figures


def _shared_grid():
    fig = Figure(figsize=(6, 4), dpi=figures.DPI)
    axes = fig.subplots(3, 2, sharex="col", sharey="row", squeeze=False)
    t = np.linspace(0.0, 1.0, 300)
    for i, ax in enumerate(axes.flat):
        ax.plot(t, np.sin(2 * np.pi * (i + 1) * t) * 10.0 ** i)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("x [µm]")
    return fig


def _log_and_colorbar():
    fig = Figure(figsize=(6, 4), dpi=figures.DPI)
    ax1, ax2 = fig.subplots(1, 2)
    f = np.logspace(0, 3, 200)
    ax1.loglog(f, 1.0 / (1.0 + (f / 80.0) ** 2))
    ax1.set_xlabel("frequency [Hz]")
    ax1.set_ylabel("|G|")
    image = ax2.imshow(np.outer(np.arange(20.0), np.arange(30.0)) - 100.0, aspect="auto")
    fig.colorbar(image, ax=ax2, label="error [µm]")
    ax2.set_xlabel("sample")
    return fig


def _twin():
    fig = Figure(figsize=(5, 3), dpi=figures.DPI)
    ax = fig.subplots()
    t = np.linspace(0.0, 0.02, 400)
    ax.plot(t, 50.0 * np.sin(2 * np.pi * 50.0 * t))
    ax.set_ylabel("x [µm]")
    other = ax.twinx()
    other.plot(t, 80.0 * np.cos(2 * np.pi * 50.0 * t), color="C1")
    other.set_ylabel("u [V]")
    ax.set_xlabel("time [s]")
    fig.suptitle("twin")
    return fig


FIGURES = {"shared grid": _shared_grid, "log axes and colorbar": _log_and_colorbar,
           "twin axes": _twin}


def _pixels(fig, memo):
    canvas = FigureCanvasAgg(fig)
    if memo:
        with figures._ticks_updated_once():
            canvas.draw()
    else:
        canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


def _counting(monkeypatch):
    calls = []
    original = Axis._update_ticks

    def counted(axis):
        calls.append((id(axis), tuple(axis.get_view_interval())))
        return original(axis)

    monkeypatch.setattr(Axis, "_update_ticks", counted)
    return calls


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_updating_ticks_once_keeps_every_pixel(name):
    reference = _pixels(FIGURES[name](), memo=False)
    assert np.array_equal(_pixels(FIGURES[name](), memo=True), reference)


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_each_axis_updates_its_ticks_once_per_view(name, monkeypatch):
    calls = _counting(monkeypatch)
    _pixels(FIGURES[name](), memo=False)
    plain = list(calls)
    calls.clear()
    _pixels(FIGURES[name](), memo=True)
    assert len(calls) == len(set(calls))                  # never twice for one axis and view
    assert len(calls) < len(plain)                        # matplotlib alone does it more often


def test_matplotlib_is_restored_after_the_draw_even_on_error():
    update, bboxes = Axis._update_ticks, Axis._get_ticklabel_bboxes
    with pytest.raises(RuntimeError):
        with figures._ticks_updated_once():
            assert Axis._update_ticks is not update
            raise RuntimeError("drawing failed")
    assert Axis._update_ticks is update and Axis._get_ticklabel_bboxes is bboxes


def test_a_view_changed_between_draws_gets_new_ticks():
    fig = Figure(figsize=(4, 3), dpi=figures.DPI)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    canvas = FigureCanvasAgg(fig)
    with figures._ticks_updated_once():
        canvas.draw()
        ax.set_xlim(0.0, 100.0)
        canvas.draw()
        labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert "100" in labels


@pytest.mark.slow  # end-to-end; default pytest stays fast, .ci/run runs -m slow
def test_figures_saved_from_threads_equal_those_saved_one_by_one():
    import io
    from concurrent.futures import ThreadPoolExecutor

    def png(name):
        buffer = io.BytesIO()
        figures.save(FIGURES[name](), buffer)
        return buffer.getvalue()

    names = sorted(FIGURES) * 3
    one_by_one = {name: png(name) for name in sorted(FIGURES)}   # each figure drawn once
    serial = [one_by_one[name] for name in names]
    with ThreadPoolExecutor(max_workers=3) as pool:
        threaded = list(pool.map(png, names))
    assert threaded == serial
    assert Axis._update_ticks.__qualname__ == "Axis._update_ticks"     # matplotlib's, restored
