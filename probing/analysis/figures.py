"""What every figure of the project shares: the style, the one way figures are saved and
the checks that keep them readable.

Figures are saved without a creation date, so the same results give byte-identical files
(the committed figures stay unchanged when a documented command redraws them).
:func:`covers_data`, :func:`legends_over_data` and :func:`clipped_texts` say, from the
laid-out figure, whether a box (a legend, a note) hides plotted data and whether a text
runs off the figure; :func:`place_clear_of_data` puts a note where it hides none.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.path import Path as MplPath
from matplotlib.transforms import Bbox

__all__ = [
    "RC",
    "clipped_texts",
    "covers_data",
    "detached_figure",
    "legends_over_data",
    "place_clear_of_data",
    "save_figure",
]

#: Style of the project's figures (matplotlib rc parameters).
RC = {
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "legend.fontsize": 7,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "lines.linewidth": 1.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
}


def detached_figure(**kwargs: Any) -> Any:
    """A new figure made by pyplot's backend, then let go of by pyplot: a figure a function
    returns, which a notebook shows once (as the cell's result) and a script keeps until
    it drops it, with no window and no figure left in pyplot's list.

    ``kwargs`` go to :func:`matplotlib.pyplot.figure` (``figsize``, ``layout``).
    """
    fig = plt.figure(**kwargs)
    canvas = type(fig.canvas)  # the backend's: Agg, or a notebook's inline one
    plt.close(fig)  # which leaves the figure a bare canvas
    canvas(fig)  # drawn by the backend's again (a renderer, the notebook's formatter)
    return fig


def save_figure(
    fig: Any, stem: Path, formats: Sequence[str] = ("png",), dpi: int = 200
) -> list[Path]:
    """Save ``fig`` as ``<stem>.<format>`` for each format, then close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    stem : pathlib.Path
        File name without extension; its folder is created.
    formats : sequence of str
        ``"png"``, ``"pdf"``, ...
    dpi : int
        Resolution of raster formats.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of ``formats``.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in formats:
        path = stem.with_name(f"{stem.name}.{ext}")
        meta = {"CreationDate": None} if ext == "pdf" else None  # same results, same bytes
        fig.savefig(path, dpi=dpi, metadata=meta)
        paths.append(path)
    plt.close(fig)
    return paths


def _renderer(fig: Any) -> Any:
    """The renderer of ``fig`` once laid out as it will be saved (constrained layout run)."""
    fig.draw_without_rendering()
    return fig.canvas.get_renderer()


def covers_data(ax: Any, box: Bbox) -> bool:
    """Whether the display-space ``box`` hides a line or marker drawn in ``ax``.

    Only what is drawn inside ``ax`` counts (lines are clipped to the axes).  Lay the
    figure out first (:meth:`matplotlib.figure.Figure.draw_without_rendering`): display
    coordinates depend on the layout.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes whose lines are checked.
    box : matplotlib.transforms.Bbox
        A box in display coordinates, e.g. a legend's window extent.

    Returns
    -------
    bool
        True if a line crosses the box or a marker lies in it.
    """
    box = Bbox.intersection(box, ax.bbox)
    if box is None or box.width <= 0 or box.height <= 0:
        return False
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = line.get_transform().transform(line.get_xydata())
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) == 0:
            continue
        if line.get_linestyle() not in ("None", "none", "", " ") and len(xy) > 1:
            if MplPath(xy).intersects_bbox(box, filled=False):
                return True
        if line.get_marker() not in (None, "None", "none", "", " "):
            pad = line.get_markersize() * ax.figure.dpi / 72.0 / 2.0
            (x0, y0), (x1, y1) = box.get_points()
            inside = (
                (xy[:, 0] >= x0 - pad)
                & (xy[:, 0] <= x1 + pad)
                & (xy[:, 1] >= y0 - pad)
                & (xy[:, 1] <= y1 + pad)
            )
            if inside.any():
                return True
    return False


def _labels(fig: Any) -> list[Any]:
    """The texts of ``fig`` a reader reads, tick labels aside: suptitle, figure texts and
    legends, and of every axes drawn its titles, notes and legend, with its axis labels if
    its axes are on."""
    texts = [*fig.texts]
    if fig._suptitle is not None:
        texts.append(fig._suptitle)
    for legend in fig.legends:
        texts += [legend.get_title(), *legend.get_texts()]
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        texts += [ax.title, ax._left_title, ax._right_title, *ax.texts]
        if ax.axison:
            texts += [ax.xaxis.label, ax.yaxis.label]
        if ax.get_legend() is not None:
            texts += [ax.get_legend().get_title(), *ax.get_legend().get_texts()]
    return texts


def legends_over_data(fig: Any) -> list[str]:
    """The legends of ``fig`` (its own and its axes') that hide data of an axes, each named
    by its first entry.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, laid out here as it will be saved.

    Returns
    -------
    list of str
        The first entry of each legend that crosses a line or marker.
    """
    renderer = _renderer(fig)
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
    out = []
    for legend in legends:
        box = legend.get_window_extent(renderer)
        if any(covers_data(ax, box) for ax in fig.axes):
            out.append(legend.get_texts()[0].get_text() if legend.get_texts() else "")
    return out


def clipped_texts(fig: Any) -> list[str]:
    """The visible, non-empty texts of ``fig`` (titles, axis labels, notes, legends' entries;
    not tick labels) that run past the figure's edge when it is saved.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, laid out here as it will be saved.

    Returns
    -------
    list of str
        Those texts, in the order the figure holds them.
    """
    renderer = _renderer(fig)
    edge = fig.bbox.padded(0.5)  # half a pixel of rounding
    out = []
    for text in _labels(fig):
        if not text.get_visible() or not text.get_text().strip():
            continue
        box = text.get_window_extent(renderer)
        if not (edge.contains(box.x0, box.y0) and edge.contains(box.x1, box.y1)):
            out.append(text.get_text())
    return out


def place_clear_of_data(
    ax: Any, text: Any, positions: Sequence[tuple[float, float, str, str]], margin: float = 3.0
) -> bool:
    """Move ``text`` (placed in axes coordinates) to the first of ``positions`` where it hides
    neither the data of ``ax`` nor its legend, with ``margin`` points to spare.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes holding the text (``transform=ax.transAxes``).
    text : matplotlib.text.Text
        The note.
    positions : sequence of (x, y, ha, va)
        Candidate anchors in axes coordinates with their alignments, the preferred first.
    margin : float
        Clearance around the text, in points.

    Returns
    -------
    bool
        True if a clear position was found; otherwise the text is left at the first.
    """
    renderer = _renderer(ax.figure)
    legend = ax.get_legend()
    for x, y, ha, va in positions:
        text.set_position((x, y))
        text.set_horizontalalignment(ha)
        text.set_verticalalignment(va)
        box = text.get_window_extent(renderer).padded(margin * ax.figure.dpi / 72.0)
        if covers_data(ax, box):
            continue
        if legend is not None and box.overlaps(legend.get_window_extent(renderer)):
            continue
        return True
    x, y, ha, va = positions[0]
    text.set_position((x, y))
    text.set_horizontalalignment(ha)
    text.set_verticalalignment(va)
    return False
