"""What a figure fit for a report must hold: its legends off the data, a unit on every axis.

:func:`problems` inspects a drawn matplotlib figure and lists what is wrong, in words:

- a legend whose window covers data: a drawn line passing through it (the segments between
  its points, not only its vertices), a marker or a scatter point inside it, a bar it overlaps;
- an axis showing numbers whose label has no unit in brackets (``[mm]``, ``[-]`` for a ratio
  or a count). An axis without tick labels (shared, hidden) or labelled by names (categories,
  variable names) needs none.

:func:`capture` records every figure saved while a block of code runs (``Figure.savefig``),
so a test draws each figure with the code a command runs and checks what it saved.
"""

from __future__ import annotations

import contextlib
import re

import numpy as np

#: a unit in an axis label: [mm], [MPa], [-], [cc/rev], [% of range]
UNIT = re.compile(r"\[[^\]]+\]")
#: a tick label that is a number (with a sign, exponent, percent, the minus sign matplotlib draws)
NUMBER = re.compile(r"^[\s\u2212+\-]*[\d.,]+(e[\u2212+\-]?\d+)?\s*%?$|^\$.*\$$", re.I)


def _renderer(fig):
    """Draw the figure (on an Agg canvas if it has none) and return its renderer."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not hasattr(fig.canvas, "get_renderer"):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _legends(fig) -> list:
    out = list(fig.legends)
    for ax in fig.axes:
        if ax.get_legend() is not None:
            out.append(ax.get_legend())
    return [lg for lg in out if lg.get_visible()]


def _data_paths(ax):
    """(name, display-coordinate points, joined) of every line and scatter of an axes, clipped to its window."""
    from matplotlib.collections import PathCollection
    from matplotlib.lines import Line2D

    box = ax.get_window_extent()
    for line in ax.get_lines():
        if not isinstance(line, Line2D) or not line.get_visible() or line.get_label() == "_nolegend_grid":
            continue
        xy = np.asarray(line.get_transform().transform(np.column_stack(line.get_data(orig=False))), dtype=float)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) == 0:
            continue
        joined = line.get_linestyle() not in ("None", "none", "", " ") and len(xy) > 1
        # a straight guide across the whole axes (axhline, axvline) is no data
        if joined and _is_guide(line):
            continue
        yield line.get_label(), xy, joined, box
    for coll in ax.collections:
        if isinstance(coll, PathCollection) and coll.get_visible():
            xy = coll.get_offset_transform().transform(coll.get_offsets())
            yield coll.get_label(), np.asarray(xy, dtype=float), False, box


def _bars(ax):
    """(label, display box) of every drawn bar of an axes (``ax.bar``, ``ax.barh``), clipped to its window."""
    from matplotlib.transforms import Bbox

    box = ax.get_window_extent()
    for container in ax.containers:
        for rect in getattr(container, "patches", ()):
            if rect.get_visible() and rect.get_width() and rect.get_height():
                clipped = Bbox.intersection(rect.get_window_extent(), box)
                if clipped is not None and clipped.width > 1 and clipped.height > 1:
                    yield container.get_label(), clipped


def _overlaps(bbox, bar) -> bool:
    """Whether a legend's window (shrunk by a pixel at each side) overlaps a bar's box."""
    from matplotlib.transforms import Bbox

    inner = Bbox.from_extents(bbox.x0 + 1, bbox.y0 + 1, bbox.x1 - 1, bbox.y1 - 1)
    both = Bbox.intersection(inner, bar)
    return both is not None and both.width > 0 and both.height > 0


def _is_guide(line) -> bool:
    """An axhline/axvline: two points in axes coordinates along one direction."""
    x, y = line.get_data(orig=False)
    return len(x) == 2 and (x[0] == 0 and x[1] == 1 or y[0] == 0 and y[1] == 1) and \
        line.get_transform() != line.axes.transData


def _covers(bbox, xy: np.ndarray, joined: bool, clip) -> bool:
    """Whether a legend's window (shrunk by a pixel at each side) holds a point, or a segment crosses it."""
    from matplotlib.path import Path
    from matplotlib.transforms import Bbox

    inner = Bbox.from_extents(bbox.x0 + 1, bbox.y0 + 1, bbox.x1 - 1, bbox.y1 - 1)
    visible = Bbox.intersection(inner, clip)       # what of the legend lies over the axes' data window
    if visible is None:
        return False
    inside = (xy[:, 0] > visible.x0) & (xy[:, 0] < visible.x1) & (xy[:, 1] > visible.y0) & (xy[:, 1] < visible.y1)
    if inside.any():
        return True
    return bool(joined and Path(xy).intersects_bbox(visible, filled=False))


def _needs_unit(axis) -> bool:
    """An axis showing numbers (not hidden, not labelled by names)."""
    if not axis.get_visible():
        return False
    labels = [t.get_text() for t in axis.get_ticklabels() if t.get_visible() and t.get_text().strip()]
    if not labels:
        return False
    return all(NUMBER.match(t.replace(",", "")) for t in labels)


def problems(fig, name: str = "figure") -> list[str]:
    """What keeps a drawn figure out of a report.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    name : str
        Named in each problem.

    Returns
    -------
    list of str
        One line per legend covering data and per numeric axis without a unit (empty: fit for a report).
    """
    renderer = _renderer(fig)
    found = []
    for lg in _legends(fig):
        bbox = lg.get_window_extent(renderer)
        for ax in fig.axes:
            for label, xy, joined, clip in _data_paths(ax):
                if _covers(bbox, xy, joined, clip):
                    title = ax.get_title() or ax.get_ylabel() or "an axes"
                    found.append(f"{name}: the legend covers {label!r} on {title!r}")
            for label in dict.fromkeys(label for label, bar in _bars(ax) if _overlaps(bbox, bar)):
                title = ax.get_title() or ax.get_ylabel() or "an axes"
                found.append(f"{name}: the legend covers the bars {label!r} on {title!r}")
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison or ax.name != "rectilinear":
            continue
        if not (ax.get_lines() or ax.collections or ax.images or ax.patches):
            continue
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if _needs_unit(axis) and not UNIT.search(label):
                found.append(f"{name}: the {axis.axis_name} axis of {ax.get_title() or 'an axes'!r} has no unit "
                             f"in its label {label!r}")
    return found


@contextlib.contextmanager
def capture():
    """Record every figure saved (``Figure.savefig``) inside the block: yields the list of (path, figure)."""
    from matplotlib.figure import Figure

    saved = []
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        saved.append((str(fname), self))
        return original(self, fname, *args, **kwargs)

    Figure.savefig = savefig
    try:
        yield saved
    finally:
        Figure.savefig = original
