"""The checks that keep the project's figures readable, read from the laid-out figure; every
figure's tests run them.

:func:`legends_over_data` (a legend that hides plotted data), :func:`clipped_texts` (a text
that runs off the figure), :func:`overlapping_texts` (texts of two panels over each other),
:func:`undefined_texts` ("nan" in a title), :func:`low_contrast_texts` (WCAG 2's contrast
ratio of a text against what is under it, a heatmap's cell), :func:`unexplained_lines` (a
curve no legend names), :func:`hidden_lines` (a named curve mostly under others, from the
rendered pixels) and :func:`labels_without_unit`; :func:`figure_problems` runs the cheap
ones at once.  The drawing rules that keep them are in :mod:`probing.analysis.figures`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import RendererAgg
from matplotlib.collections import QuadMesh
from matplotlib.colors import to_rgb, to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.transforms import Bbox

from probing.analysis.figures import contrast_ratio, covers_data, layout_renderer

__all__ = [
    "MIN_CONTRAST",
    "clipped_texts",
    "figure_problems",
    "hidden_lines",
    "labels_without_unit",
    "legends_over_data",
    "low_contrast_texts",
    "overlapping_texts",
    "undefined_texts",
    "unexplained_lines",
]


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
    renderer = layout_renderer(fig)
    out = []
    for legend in _legends(fig):
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
    renderer = layout_renderer(fig)
    edge = fig.bbox.padded(0.5)  # half a pixel of rounding
    out = []
    for text in _labels(fig):
        if not text.get_visible() or not text.get_text().strip():
            continue
        box = text.get_window_extent(renderer)
        if not (edge.contains(box.x0, box.y0) and edge.contains(box.x1, box.y1)):
            out.append(text.get_text())
    return out


#: WCAG 2's least contrast ratio for text (level AA): text against what is under it.
MIN_CONTRAST = 4.5


def _over(top: Any, bottom: Any) -> tuple[float, float, float]:
    """The colour ``top`` (with its alpha) composited over the opaque ``bottom``."""
    r, g, b, a = to_rgba(top)
    base = np.array(to_rgb(bottom))
    return tuple(a * np.array([r, g, b]) + (1.0 - a) * base)  # type: ignore[return-value]


def _cell_colour(artist: Any, x: float, y: float) -> tuple[float, ...] | None:
    """The RGBA of the cell of an image (``imshow``) or a rectilinear mesh (``pcolormesh``)
    at data coordinates (x, y), or None outside it or where it is blank."""
    values = np.ma.asarray(artist.get_array())
    if isinstance(artist, QuadMesh):
        coords = artist.get_coordinates()
        xs, ys = coords[0, :, 0], coords[:, 0, 1]
        values = values.reshape(len(ys) - 1, len(xs) - 1)
        col = int(np.searchsorted(np.sort(xs), x)) - 1
        row = int(np.searchsorted(np.sort(ys), y)) - 1
        col = col if xs[0] < xs[-1] else len(xs) - 2 - col
        row = row if ys[0] < ys[-1] else len(ys) - 2 - row
    else:
        left, right, bottom, top = artist.get_extent()
        rows, cols = values.shape[:2]
        col = int(np.floor((x - left) / (right - left) * cols))
        row = int(np.floor((top - y) / (top - bottom) * rows))
        if artist.origin == "lower":
            row = rows - 1 - row
    if not (0 <= row < values.shape[0] and 0 <= col < values.shape[1]):
        return None
    if np.ma.is_masked(values[row, col]):
        return None
    return artist.to_rgba(values[row, col], alpha=artist.get_alpha())


def _background(text: Any, renderer: Any) -> tuple[float, float, float]:
    """The colour under the centre of ``text``: its own box if it has one, else the cell
    of an image or a mesh it lies on (a heatmap), else its axes' face, else the figure's."""
    fig = text.get_figure(root=True)
    colour = _over(fig.get_facecolor(), "white")
    ax = text.axes
    if ax is not None:
        colour = _over(ax.get_facecolor(), colour)
    if ax is not None and text in ax.texts:  # a note on the data (not a title, a label)
        box = text.get_window_extent(renderer)
        x, y = ax.transData.inverted().transform(((box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2))
        grids = [*ax.get_images(), *(c for c in ax.collections if isinstance(c, QuadMesh))]
        for grid in sorted(grids, key=lambda a: a.get_zorder()):
            cell = _cell_colour(grid, x, y)
            if cell is not None:
                colour = _over(cell, colour)
    patch = text.get_bbox_patch()
    if patch is not None and patch.get_visible():
        colour = _over(patch.get_facecolor(), colour)
    return colour


def low_contrast_texts(fig: Any, minimum: float = MIN_CONTRAST) -> list[str]:
    """The readable texts of ``fig`` (:func:`clipped_texts`' and the notes in its axes)
    whose colour has less than ``minimum`` contrast ratio (WCAG 2) with what is under them:
    their own box, else a heatmap's cell (``imshow``, ``pcolormesh``), else the axes' or
    the figure's face.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, laid out here as it will be saved.
    minimum : float
        The least contrast ratio (WCAG AA for text: 4.5).

    Returns
    -------
    list of str
        Those texts, each with its ratio: ``"50 (1.9)"``.
    """
    renderer = layout_renderer(fig)
    out = []
    for text in _labels(fig):
        if not text.get_visible() or not text.get_text().strip():
            continue
        ratio = contrast_ratio(_over(text.get_color(), "white"), _background(text, renderer))
        if ratio < minimum:
            out.append(f"{text.get_text()} ({ratio:.1f})")
    return out


#: A number that is not one, written as a word: ``nan``, ``inf`` (any case, any sign).
_UNDEFINED = re.compile(r"(?<![\w.])[-+]?(nan|inf)(?![\w])", re.IGNORECASE)


def undefined_texts(fig: Any) -> list[str]:
    """The readable texts of ``fig`` (titles, labels, notes, legends) that print an
    undefined number, ``nan`` or ``inf``, where a sentence ("no alarm") belongs.

    Returns
    -------
    list of str
    """
    return [t.get_text() for t in _labels(fig) if _UNDEFINED.search(t.get_text())]


def _tick_labels(ax: Any) -> list[Any]:
    """The tick labels ``ax`` draws (in its view, on a visible axis)."""
    out = []
    for axis in (ax.xaxis, ax.yaxis):
        if not axis.get_visible():
            continue
        for tick in axis._update_ticks():
            out += [t for t in (tick.label1, tick.label2) if t.get_visible() and t.get_text()]
    return out


def _owned_texts(fig: Any) -> list[tuple[Any, list[Any]]]:
    """Each drawn axes with its texts (titles, axis labels, tick labels, legend), and the
    figure with its own (suptitle, figure labels and texts, figure legends)."""
    groups = []
    own = [*fig.texts, *fig.legends]
    for name in ("_suptitle", "_supxlabel", "_supylabel"):
        if getattr(fig, name, None) is not None:
            own.append(getattr(fig, name))
    groups.append((fig, own))
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        texts = [ax.title, ax._left_title, ax._right_title, *ax.texts]
        if ax.axison:
            texts += [
                *(a.label for a in (ax.xaxis, ax.yaxis) if a.get_visible()),
                *_tick_labels(ax),
            ]
        if ax.get_legend() is not None:
            texts.append(ax.get_legend())
        groups.append((ax, texts))
    return groups


def _name(artist: Any) -> str:
    if hasattr(artist, "get_text"):
        return artist.get_text()
    texts = artist.get_texts()  # a legend
    return f"legend '{texts[0].get_text()}'" if texts else "legend"


def overlapping_texts(fig: Any) -> list[tuple[str, str]]:
    """Texts of two different panels (or of a panel and the figure) drawn over each other:
    titles, axis labels, tick labels, notes and legends, as laid out for saving.

    Returns
    -------
    list of (str, str)
        The two texts of each such pair.
    """
    renderer = layout_renderer(fig)
    boxes = []
    for owner, artists in _owned_texts(fig):
        for artist in artists:
            if not artist.get_visible() or (hasattr(artist, "get_text") and not artist.get_text()):
                continue
            boxes.append((owner, artist, artist.get_window_extent(renderer).shrunk(0.98, 0.98)))
    out = []
    for i, (owner, artist, box) in enumerate(boxes):
        for other_owner, other, other_box in boxes[i + 1 :]:
            if owner is not other_owner and box.overlaps(other_box):
                out.append((_name(artist), _name(other)))
    return out


def _legends(fig: Any) -> list[Any]:
    return [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]


def _style(artist: Any) -> tuple[tuple[float, ...], str, str]:
    """A line's (colour, line style, marker), as a legend handle shows them."""
    colour = tuple(round(c, 3) for c in to_rgb(artist.get_color()))
    return colour, str(artist.get_linestyle()), str(artist.get_marker())


def _is_reference_line(line: Any) -> bool:
    """An ``axhline`` or ``axvline`` (drawn across the axes, on an axis's blend of data and
    axes coordinates): a threshold, an onset, a goal, which the axis labels and the caption
    explain."""
    ax = line.axes
    return line.get_transform() in (ax.get_xaxis_transform(), ax.get_yaxis_transform())


_NO_LINE = ("None", "none", "", " ")  # a marker-only curve: no line style to name
_NO_MARKER = ("None", "none", "", " ")  # a curve without markers: no marker to name


def unexplained_lines(fig: Any) -> list[str]:
    """The curves and markers of ``fig`` that no legend explains: neither their label is a
    legend's entry, nor a legend shows their colour, line style and marker (one entry for
    all three, or entries for the colour, the style and the marker apart, as a legend of
    faults by colour and references by style does; a curve without markers needs no
    marker named, dots without a line no line style).  Straight reference lines
    (``axhline``, ``axvline``) are not counted, nor the one curve of a panel without a
    legend (its axis label names it); a panel with a legend names every curve.

    Returns
    -------
    list of str
        Each such line's label (matplotlib's ``_child<n>`` where it has none) and panel.
    """
    legends = _legends(fig)
    named = {t.get_text() for leg in legends for t in leg.get_texts()}
    handles = [h for leg in legends for h in leg.legend_handles if isinstance(h, Line2D)]
    styles = {_style(h) for h in handles}
    patches = {  # a bar's or a band's colour names the curves of that colour
        tuple(round(c, 3) for c in to_rgb(h.get_facecolor()))
        for leg in legends
        for h in leg.legend_handles
        if isinstance(h, Patch)
    }
    colours, linestyles, markers = (
        (set(x) for x in zip(*styles, strict=True)) if styles else ((), (), ())
    )
    out = []
    for ax in fig.axes:
        curves = [
            line
            for line in ax.get_lines()
            if line.get_visible()
            and np.isfinite(np.asarray(line.get_xydata(), float)).all(axis=1).any()
            and not _is_reference_line(line)
        ]
        if len(curves) == 1 and ax.get_legend() is None:
            continue  # a panel's one curve, without a legend: its axis label names it
        for line in curves:
            if line.get_label() in named:
                continue
            colour, style, marker = _style(line)
            if (colour, style, marker) in styles:
                continue
            if (
                colour in {*colours, *patches}
                and style in (*linestyles, *_NO_LINE)
                and marker in (*markers, *_NO_MARKER)
            ):
                continue
            title = ax.get_title() or ax.get_title(loc="left")
            out.append(f"{line.get_label()} in '{title}'")
    return out


def _pixels(fig: Any, axes: Sequence[Any], dpi: float) -> np.ndarray:
    """``axes`` of ``fig`` (laid out) drawn alone by Agg at ``dpi``: (height, width, 4)."""
    saved = fig.dpi
    try:
        fig.dpi = dpi
        width, height = fig.bbox.size
        renderer = RendererAgg(int(width), int(height), dpi)
        fig.patch.draw(renderer)
        for ax in sorted(axes, key=lambda a: a.get_zorder()):
            ax.patch.draw(renderer)  # the background an axes without its axis leaves out
            ax.draw(renderer)
        box = Bbox.union([ax.bbox for ax in axes])  # what they draw in: the rest is blank
        x0, x1 = max(int(box.x0) - 2, 0), int(np.ceil(box.x1)) + 2
        y0, y1 = max(int(height - box.y1) - 2, 0), int(np.ceil(height - box.y0)) + 2
        return np.asarray(renderer.buffer_rgba())[y0:y1, x0:x1, :3].astype(np.int16)
    finally:
        fig.dpi = saved


def _near(a: np.ndarray, b: np.ndarray, within: float = 40.0) -> np.ndarray:
    """The pixels (RGB of 0-255) whose colours are within ``within`` in every channel."""
    return (np.abs(a - b) <= within).all(axis=-1)


def hidden_lines(fig: Any, minimum: float = 0.4, dpi: float = 200) -> list[str]:
    """The curves a legend names that show less than ``minimum`` of themselves: of the
    pixels a curve drawn alone paints in its own colour, fewer than that share look more
    like it than like what is under it in the figure, the curves, markers, bands and notes
    drawn over it taking the rest.  A curve under a dashed one of its width (a measurement
    under the prediction it matches) keeps about 0.3, as does an onset line 2 pixels from a
    wider first alarm drawn over it; a curve drawn three times as wide as the one lying on
    it about 0.5 or more; a translucent curve keeps the pixels where it tints what is under
    it.

    Rendered by Agg at ``dpi`` (that of the saved figures) as laid out for saving, the
    curve's panel (and its twins) only, without legends and axes (they neither move nor
    count): four drawings per curve.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    minimum : float
        The least share of its pixels a named curve keeps (0.4: between the examples).
    dpi : float
        Resolution of the drawings.

    Returns
    -------
    list of str
        Each such curve's label and the share it keeps: ``"measured (0.31)"``.
    """
    named = {t.get_text() for leg in _legends(fig) for t in leg.get_texts()}
    fig.draw_without_rendering()  # the layout it is saved with, kept while drawn here
    engine, shown = fig.get_layout_engine(), [ax for ax in fig.axes if ax.get_visible()]
    data = [
        a
        for ax in shown
        for a in (*ax.lines, *ax.collections, *ax.patches, *ax.images, *ax.texts)
        if a.get_visible()
    ]
    hidden = [*_legends(fig), *(ax for ax in shown if ax.axison)]  # neither moves nor counts
    lines = [ln for ax in shown for ln in ax.lines if ln in data and ln.get_label() in named]
    out = []
    try:
        fig.set_layout_engine("none")
        for artist in hidden:
            artist.set_axis_off() if artist in shown else artist.set_visible(False)
        for line in lines:
            group = [ax for ax in shown if ax.bbox.overlaps(line.axes.bbox)]  # twins too
            full = _pixels(fig, group, dpi)
            for a in data:
                a.set_visible(a is line)
            alone = _pixels(fig, group, dpi)
            line.set_visible(False)
            empty = _pixels(fig, group, dpi)
            for a in data:
                a.set_visible(a is not line)
            without = _pixels(fig, group, dpi)
            line.set_visible(True)
            alpha = 1.0 if line.get_alpha() is None else line.get_alpha()
            ink = 255.0 * alpha * np.array(to_rgb(line.get_color()))
            # its own pixels: where, drawn alone, it paints its colour over the empty axes
            own = _near(alone, ink + (1.0 - alpha) * empty) & ~_near(alone, empty, 0)
            # kept: the pixel looks more like the curve over what is under it than like that
            expected = ink + (1.0 - alpha) * without
            kept = own & (np.abs(full - expected).max(-1) < np.abs(full - without).max(-1))
            share = kept.sum() / max(own.sum(), 1)
            if share < minimum:
                out.append(f"{line.get_label()} ({share:.2f})")
    finally:
        for artist in hidden:
            artist.set_axis_on() if artist in shown else artist.set_visible(True)
        for a in data:
            a.set_visible(True)
        fig.set_layout_engine(engine)
    return out


#: A unit in parentheses: ``(s)``, ``(rad/s per deg)``, ``(mrad)``.
_UNIT = re.compile(r"\([^()]*\w[^()]*\)")


def labels_without_unit(fig: Any, axis: str = "y") -> list[str]:
    """The panels of ``fig`` with data whose ``axis`` (``"x"`` or ``"y"``) label is empty or
    names no unit in parentheses; a panel without its own label has the figure's
    (``supylabel``, ``supxlabel``), if any.

    Returns
    -------
    list of str
        Each such panel's title and its label.
    """
    out = []
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        if not (ax.lines or ax.collections or ax.images or ax.patches):
            continue
        label = ax.get_ylabel() if axis == "y" else ax.get_xlabel()
        shared = getattr(fig, "_supylabel" if axis == "y" else "_supxlabel", None)
        if not label and shared is not None:
            label = shared.get_text()
        if not _UNIT.search(label):
            title = ax.get_title() or ax.get_title(loc="left")
            out.append(f"'{title}': '{label}'")
    return out


def figure_problems(fig: Any) -> list[str]:
    """Every cheap readability check of ``fig`` at once, each problem one line: legends
    over data, texts off the figure or over another panel's, undefined numbers in texts,
    texts of too little contrast, curves no legend explains.  (:func:`hidden_lines` renders
    the figure and :func:`labels_without_unit` does not apply to every figure: run them
    where they do.)

    Returns
    -------
    list of str
        Empty for a readable figure.
    """
    return [
        *(f"legend over data: {t}" for t in legends_over_data(fig)),
        *(f"off the figure: {t}" for t in clipped_texts(fig)),
        *(f"texts over each other: {a} / {b}" for a, b in overlapping_texts(fig)),
        *(f"undefined number: {t}" for t in undefined_texts(fig)),
        *(f"low contrast: {t}" for t in low_contrast_texts(fig)),
        *(f"not in a legend: {t}" for t in unexplained_lines(fig)),
    ]
