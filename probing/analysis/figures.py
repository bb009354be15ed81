"""What every figure of the project shares: the style, the one way figures are saved and
the drawing rules that keep them readable.

Figures are saved without a creation date, so the same results give byte-identical files
(the committed figures stay unchanged when a documented command redraws them).
:func:`covers_data` says whether a box (a legend, a note) hides plotted data;
:func:`place_clear_of_data` puts a note where it hides none, :func:`legends_in_margins`
reserves a band at the top of axes for their legends (:func:`lift_legends` for every legend
that hides data), :func:`text_colour_on` picks black or white text for a background (by
WCAG's :func:`contrast_ratio`), and :data:`LW_UNDER` over :data:`LW_OVER` keeps two curves
that coincide both visible.  :mod:`probing.analysis.figure_checks` holds the checks every
figure's tests run.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import to_rgb
from matplotlib.path import Path as MplPath
from matplotlib.transforms import Bbox

from probing.sim.channels import unit_of

__all__ = [
    "LW_DASHED_OVER",
    "LW_OVER",
    "LW_UNDER",
    "RC",
    "contrast_ratio",
    "covers_data",
    "detached_figure",
    "layout_renderer",
    "legends_in_margins",
    "lift_legends",
    "place_clear_of_data",
    "response_unit",
    "save_figure",
    "text_colour_on",
]

#: Line widths (pt) that keep two curves visible where one lies exactly on the other (a
#: measurement and the prediction it matches, a compensated curve and the baseline): the
#: lower curve wide, the one on it thin, a dashed prediction thinner still (hidden_lines).
LW_UNDER, LW_OVER, LW_DASHED_OVER = 2.4, 0.8, 0.7

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


def response_unit(channel: str, per: str = "deg") -> str:
    """The unit of a pulse response of ``channel`` per ``per`` of probe, for an axis label:
    ``"rad/s per deg"`` for ``q_rad_s``.

    Examples
    --------
    >>> response_unit("q_rad_s"), response_unit("nz_g", "norm")
    ('rad/s per deg', 'g per norm')
    """
    return f"{unit_of(channel)} per {per}"


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


def layout_renderer(fig: Any) -> Any:
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
    renderer = layout_renderer(ax.figure)
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


def legends_in_margins(
    legends: Sequence[tuple[Any, Any, Sequence[Any]]], pad_pt: float = 3.0, tries: int = 4
) -> None:
    """For each ``(ax, legend, twins)``: raise the top of ``ax``'s y range (and its
    ``twins``', on its x axis) so that ``legend``, placed at the top of the axes, sits in a
    band above every curve, and stop the vertical reference lines (``axvline``) under it.

    For axes whose curves fill them, where no corner is free (``loc="best"`` then lays the
    legend over data).  Linear and logarithmic y axes alike: the band is a share of the
    axes' height.  A legend that hides nothing is left where it is.  Call it once the
    figure is drawn, for all its legends at once (each try lays the figure out).

    Parameters
    ----------
    legends : sequence of (Axes, Legend, sequence of Axes)
        An axes, its legend (with an upper ``loc``: ``"upper center"``, ``"upper left"``)
        and the axes drawn over it on the same x axis (``ax.twinx()``; their ranges grow too).
    pad_pt : float
        Clearance between a legend and the highest curve, in points.
    tries : int
        Layouts to settle the bands (a new range can change the tick labels and the layout).
    """
    tops = {a: a.get_ylim() for ax, _, twins in legends for a in (ax, *twins)}
    spans = {  # the axvlines: x fixed, y over the axes (0 to 1), drawn on the x-axis blend
        a: [
            line
            for line in a.get_lines()
            if line.get_transform() == a.get_xaxis_transform()
            and list(line.get_ydata()) == [0, 1]
            and len(set(line.get_xdata())) == 1
        ]
        for a in tops
    }
    for _ in range(tries):
        renderer = layout_renderer(legends[0][0].figure) if legends else None
        moved = False
        for ax, legend, twins in legends:
            box = legend.get_window_extent(renderer)
            group = (ax, *twins)
            if not any(covers_data(a, box) for a in group):
                continue
            moved = True
            pad = pad_pt * ax.figure.dpi / 72.0
            share = min((ax.bbox.y1 - box.y0 + pad) / ax.bbox.height, 0.8)
            for a in group:
                scale = a.yaxis.get_transform()
                low, high = scale.transform(np.array(tops[a], float))
                top = low + (high - low) / (1.0 - share)
                a.set_ylim(tops[a][0], float(scale.inverted().transform(np.array([top]))[0]))
                for line in spans[a]:
                    line.set_ydata([0.0, 1.0 - share])
        if not moved:
            return


def lift_legends(fig: Any) -> None:
    """Move every legend of ``fig``'s axes that hides data to the top of its axes, in a
    band above the curves (:func:`legends_in_margins`; axes drawn over it, twins, count).
    Legends that hide nothing stay where they are."""
    renderer = layout_renderer(fig)
    moved = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        twins = [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds]
        if any(covers_data(a, legend.get_window_extent(renderer)) for a in (ax, *twins)):
            texts = legend.get_texts()
            lifted = ax.legend(  # the same entries, in two columns: a low band
                handles=legend.legend_handles,
                labels=[t.get_text() for t in texts],
                loc="upper center",
                ncols=2 if len(texts) > 2 else 1,
                frameon=legend.get_frame_on(),
                fontsize=texts[0].get_fontsize() if texts else None,
                title=legend.get_title().get_text() or None,
            )
            moved.append((ax, lifted, twins))
    if moved:
        legends_in_margins(moved)


def _luminance(colour: Any) -> float:
    """WCAG 2's relative luminance of a colour (sRGB, linearised)."""
    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return float(linear @ [0.2126, 0.7152, 0.0722])


def contrast_ratio(foreground: Any, background: Any) -> float:
    """WCAG 2's contrast ratio of two colours, (L1 + 0.05) / (L2 + 0.05) with L1 the
    lighter's relative luminance: 1 (the same) to 21 (black on white).

    Parameters
    ----------
    foreground, background : matplotlib colour
        Any colour matplotlib reads (``"k"``, ``"C0"``, an RGB tuple).

    Returns
    -------
    float
    """
    light, dark = sorted((_luminance(foreground), _luminance(background)), reverse=True)
    return (light + 0.05) / (dark + 0.05)


def text_colour_on(background: Any) -> str:
    """``"black"`` or ``"white"``, whichever contrasts more with ``background`` (black on a
    tie): the colour of a number written on a heatmap's cell."""
    black, white = contrast_ratio("black", background), contrast_ratio("white", background)
    return "black" if black >= white else "white"
