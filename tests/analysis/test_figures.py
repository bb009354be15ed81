"""The drawing rules of :mod:`probing.analysis.figures` on hand-made figures: what a box
hides, where a note or a legend goes, which text colour reads on a background."""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.transforms import Bbox

from probing.analysis.figure_checks import legends_over_data
from probing.analysis.figures import (
    contrast_ratio,
    covers_data,
    legends_in_margins,
    lift_legends,
    place_clear_of_data,
    text_colour_on,
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


def test_contrast_ratio_is_wcags() -> None:
    """WCAG 2's published values: black on white 21, a colour on itself 1, #777777 on white
    4.48 (just under AA's 4.5) and #767676 4.54 (just over)."""
    assert contrast_ratio("black", "white") == pytest.approx(21.0)
    assert contrast_ratio("white", "black") == pytest.approx(21.0)
    assert contrast_ratio("C0", "C0") == pytest.approx(1.0)
    assert contrast_ratio("#777777", "white") == pytest.approx(4.48, abs=0.005)
    assert contrast_ratio("#767676", "white") == pytest.approx(4.54, abs=0.005)


def test_text_colour_on_picks_the_higher_contrast() -> None:
    """Black and white contrast equally with a grey of relative luminance 0.179 (sRGB
    0.4603): white text just below it, black just above; white on navy, black on white."""
    assert text_colour_on((0.45, 0.45, 0.45)) == "white"
    assert text_colour_on((0.47, 0.47, 0.47)) == "black"
    assert text_colour_on("#08306b") == "white"  # the darkest of matplotlib's Blues
    assert text_colour_on("white") == "black"


@pytest.mark.parametrize("scale", ["linear", "log"])
def test_a_legend_in_its_margin_hides_no_curve(scale: str) -> None:
    """Curves that fill the axes up to the top and a vertical line: the legend at the top
    lies over them; in its margin it hides none (on a log axis too), on the twin's curve
    neither, and the vertical line stops under it."""
    fig, ax = plt.subplots(figsize=(4, 3), layout="constrained")
    x = np.linspace(1, 10, 100)
    ax.plot(x, x, label="rising")
    ax.plot(x, 11 - x, label="falling")
    ax.set_yscale(scale)
    twin = ax.twinx()
    twin.plot(x, np.cos(x), color="C3", label="twin")
    onset = ax.axvline(5.0, color="k", ls="--")
    legend = twin.legend(
        [*ax.get_lines()[:2], *twin.get_lines()],
        ["rising", "falling", "twin"],
        loc="upper center",
        ncol=3,
    )
    assert legends_over_data(fig) == ["rising"]
    legends_in_margins([(ax, legend, [twin])])
    assert legends_over_data(fig) == []
    renderer = _renderer(fig)
    assert onset.get_window_extent(renderer).y1 < legend.get_window_extent(renderer).y0
    plt.close(fig)


def test_lift_legends_moves_only_a_legend_that_hides_data() -> None:
    fig, (a, b) = plt.subplots(1, 2, figsize=(6, 3), layout="constrained")
    x = np.linspace(0, 1, 50)
    a.plot(x, 1 - x, label="falling")
    a.plot(x, x, label="rising")
    a.legend(loc="lower right")  # over the rising line
    b.plot(x, 0 * x, label="low")
    b.set_ylim(-0.1, 1)
    b.legend(loc="upper right")  # over nothing
    lift_legends(fig)
    assert legends_over_data(fig) == []
    assert a.get_legend()._loc == 9 and b.get_legend()._loc == 1  # upper center; as it was
    assert [t.get_text() for t in a.get_legend().get_texts()] == ["falling", "rising"]
    plt.close(fig)
