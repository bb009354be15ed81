"""The readability checks of :mod:`probing.analysis.figures` on hand-made figures."""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.transforms import Bbox

from probing.analysis.figures import (
    clipped_texts,
    covers_data,
    legends_over_data,
    place_clear_of_data,
)


def _renderer(fig: Any) -> Any:
    fig.draw_without_rendering()
    return fig.canvas.get_renderer()


def test_covers_data_sees_lines_and_markers_inside_the_axes_only() -> None:
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0.9, 0.9])  # a line along the top
    ax.plot([0.1], [0.1], "o")  # a marker in the lower left corner
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    _renderer(fig)

    def box(x0: float, y0: float, x1: float, y1: float) -> Bbox:
        return ax.transAxes.transform_bbox(Bbox([[x0, y0], [x1, y1]]))

    assert covers_data(ax, box(0.4, 0.8, 0.6, 0.95))  # across the line
    assert covers_data(ax, box(0.05, 0.05, 0.12, 0.12))  # over the marker
    assert not covers_data(ax, box(0.4, 0.3, 0.6, 0.5))  # in between
    assert not covers_data(ax, box(1.1, 0.8, 1.3, 0.95))  # outside the axes
    plt.close(fig)


def test_legend_over_a_line_and_a_title_off_the_edge_are_found() -> None:
    fig, (a, b) = plt.subplots(1, 2, figsize=(4, 2), constrained_layout=True)
    x = np.linspace(0, 1, 50)
    a.plot(x, np.ones_like(x), label="flat")
    a.legend(loc="center")
    b.plot(x, 0 * x, label="low")
    b.set_ylim(-0.1, 1)
    b.legend(loc="upper left")  # over nothing: the line runs along the bottom
    b.set_title("a title far too long to fit in the right half of so narrow a figure", loc="left")
    assert legends_over_data(fig) == ["flat"]
    assert clipped_texts(fig) == [b.get_title(loc="left")]
    plt.close(fig)


def test_a_note_goes_to_the_first_clear_position() -> None:
    fig, ax = plt.subplots(figsize=(4, 3))
    x = np.linspace(0, 1, 50)
    ax.plot(x, 0.05 + 0.0 * x)  # along the bottom
    ax.set_ylim(0, 1)
    note = ax.text(0.98, 0.02, "note", transform=ax.transAxes)
    positions = [(0.98, y, "right", "bottom") for y in (0.02, 0.3, 0.6)]
    assert place_clear_of_data(ax, note, positions)
    assert note.get_position() == (0.98, 0.3)
    assert not covers_data(ax, note.get_window_extent(_renderer(fig)))
    ax.plot(x, 0.3 + 0.4 * x)  # now every position is crossed: the first one is kept
    ax.plot([0.9, 0.9], [0, 1])
    assert not place_clear_of_data(ax, note, positions)
    assert note.get_position() == (0.98, 0.02)
    plt.close(fig)
