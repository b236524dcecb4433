"""What a person looking at a report's figure expects, as checks on the Figure and its PNG.

``figure_problems(fig)`` lists, per axes: a panel without any data drawn inside its
limits (a line, markers, a mesh, an image, bars), a data line drawn entirely outside
its limits, and a legend entry naming no artist that is drawn; and a title (the
figure's or a panel's) cut off at the figure's edges (``title_problems``). A panel that says
"no data" in words is not empty. ``png_problems(path)`` opens a PNG with
``matplotlib.image.imread`` and reports a blank (single-colour) image.
``CheckingRenderer`` stands in for the report's figure renderer: it draws each figure
job in this process, checks the Figure, writes the PNG and checks it.
"""

from __future__ import annotations

import io
from concurrent.futures import Future

import matplotlib.image as mpimg
import numpy as np
from matplotlib.collections import Collection
from matplotlib.image import AxesImage
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text

from hammerstein.report.figures import save


def _inside(ax, xy):
    """Boolean mask of the finite points of ``xy`` (n, 2, data coordinates) inside the limits."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    ok = np.isfinite(xy).all(axis=1)
    return ok & (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)


def _in_data_coordinates(artist, ax):
    return artist.get_transform().contains_branch(ax.transData)


def _visible_points(artist, ax):
    """How many of ``artist``'s points lie inside ``ax``'s limits (None: not a data artist)."""
    if not artist.get_visible():
        return None
    if isinstance(artist, Line2D):
        if not _in_data_coordinates(artist, ax):       # axhline/axvline: a reference, not data
            return None
        if artist.get_linestyle() in ("None", "", " ") and artist.get_marker() in (None, "None", ""):
            return None
        return int(_inside(ax, artist.get_xydata()).sum())
    if isinstance(artist, AxesImage):
        x0, x1, y0, y1 = artist.get_extent()           # drawn when its centre is inside
        return int(_inside(ax, [[(x0 + x1) / 2, (y0 + y1) / 2]]).sum()) * artist.get_array().size
    if isinstance(artist, Collection):
        offsets = artist.get_offsets()
        n = 0
        if len(offsets) and artist.get_offset_transform().contains_branch(ax.transData):
            n += int(_inside(ax, offsets).sum())
        if _in_data_coordinates(artist, ax):
            for path in artist.get_paths():
                n += int(_inside(ax, path.vertices).sum())
        return n
    if isinstance(artist, Patch) and artist is not ax.patch \
            and artist.get_data_transform().contains_branch(ax.transData):
        verts = artist.get_patch_transform().transform(artist.get_path().vertices)
        return int(_inside(ax, verts).sum()) if verts.size else None
    return None


def _says_no_data(ax):
    return any(isinstance(t, Text) and "no data" in t.get_text().lower() for t in ax.texts)


def figure_problems(fig, name="figure"):
    """Problems a reader would see in ``fig``: empty panels, lost curves, empty legend entries.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    name : str
        Prefix of each message.

    Returns
    -------
    list of str
        Empty when every panel shows data inside its limits and every legend entry
        names a drawn artist.
    """
    problems = []
    drawn_labels = set()
    for i, ax in enumerate(fig.axes):
        where = f"{name}: axes {i} ({ax.get_title() or ax.get_ylabel() or 'untitled'})"
        counts = []
        for artist in ax.get_children():
            n = _visible_points(artist, ax)
            if n is None:
                if isinstance(artist, (Line2D, Patch)) and artist is not ax.patch \
                        and artist.get_visible():
                    drawn_labels.add(artist.get_label())    # a reference line or span (axhline,
                    #                                          axvspan) may be in a legend
                continue
            counts.append(n)
            label = artist.get_label()
            if n > 0 and label and not label.startswith("_"):
                drawn_labels.add(label)
            if n == 0 and isinstance(artist, Line2D) and artist.get_xydata().size:
                if np.isfinite(artist.get_xydata()).all(axis=1).any():   # points, not all NaN
                    problems.append(f"{where}: line {label!r} lies entirely outside the limits")
        if not any(counts) and not _says_no_data(ax):
            problems.append(f"{where}: no data drawn inside the limits")
    problems += title_problems(fig, name)
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    for legend in legends:
        if legend is None:
            continue
        for text in legend.get_texts():
            if text.get_text() not in drawn_labels:
                problems.append(f"{name}: legend entry {text.get_text()!r} names no drawn artist")
    return problems


def title_problems(fig, name="figure"):
    """Titles (the figure's, every panel's) that do not fit inside the figure.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Drawn (the layout and the title positions are final).
    name : str
        Prefix of each message.

    Returns
    -------
    list of str
        One message per title whose window extent leaves the figure.
    """
    get = getattr(fig.canvas, "get_renderer", None)     # after save(): a plain canvas
    renderer = get() if get is not None else fig._get_renderer()
    box = fig.bbox
    titles = [t for t in fig.texts if t.get_text()]
    sup = getattr(fig, "_suptitle", None)
    if sup is not None and sup.get_text() and all(t is not sup for t in titles):
        titles.append(sup)
    for ax in fig.axes:
        titles += [t for t in (ax.title, ax._left_title, ax._right_title)
                   if t.get_visible() and t.get_text()]
    problems = []
    for t in titles:
        e = t.get_window_extent(renderer)
        if e.x0 < box.x0 - 0.5 or e.x1 > box.x1 + 0.5 or e.y0 < box.y0 - 0.5 \
                or e.y1 > box.y1 + 0.5:
            problems.append(f"{name}: title {t.get_text()[:60]!r} leaves the figure "
                            f"(extent x {e.x0:.0f}..{e.x1:.0f}, y {e.y0:.0f}..{e.y1:.0f} px; "
                            f"figure {box.x1:.0f} x {box.y1:.0f} px)")
    return problems


def png_problems(path):
    """Problems of a PNG file: does not open, or is blank (one colour).

    Parameters
    ----------
    path : str, pathlib.Path or file-like

    Returns
    -------
    list of str
    """
    try:
        image = mpimg.imread(path)
    except Exception as exc:  # the problem is the message
        return [f"{path}: does not open: {exc}"]
    if image.ndim < 2 or image.shape[0] < 10 or image.shape[1] < 10:
        return [f"{path}: image of shape {image.shape}"]
    rgb = image[..., :3] if image.ndim == 3 else image
    if float(np.ptp(rgb)) == 0.0:
        return [f"{path}: blank (a single colour)"]
    if np.mean(np.any(rgb < 0.9, axis=-1) if rgb.ndim == 3 else rgb < 0.9) < 0.005:
        return [f"{path}: almost blank (under 0.5 % of the pixels are not white)"]
    return []


class CheckingRenderer:
    """A figure renderer (``submit(jobs)``) that draws inline and checks every figure.

    ``problems`` collects the messages of :func:`figure_problems` and
    :func:`png_problems`; ``names`` the PNG files drawn.
    """

    def __init__(self):
        self.problems = []
        self.names = []

    def selects(self, path):
        """Every figure is drawn and checked (``FigureRenderer.selects`` with no selection)."""
        return True

    def submit(self, jobs):
        futures = []
        for job in jobs:
            f = Future()
            try:
                fig = job.function(*job.args, **job.kwargs)
                buffer = io.BytesIO()
                save(fig, buffer)                       # drawn: the limits are final
                self.problems += figure_problems(fig, job.path.name)
                job.path.write_bytes(buffer.getvalue())
                self.problems += png_problems(job.path)
                self.names.append(job.path.name)
            except Exception as exc:
                f.set_exception(exc)
            else:
                f.set_result(buffer.getvalue())
            futures.append(f)
        return futures
