"""The readability checks of :mod:`probing.analysis.figure_checks` on hand-made figures,
each seen to find its fault and to pass once it is mended."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from probing.analysis.figure_checks import (
    clipped_texts,
    hidden_lines,
    labels_without_unit,
    legends_over_data,
    low_contrast_texts,
    overlapping_texts,
    undefined_texts,
    unexplained_lines,
)
from probing.analysis.figures import text_colour_on


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


def test_numbers_on_a_heatmap_are_checked_against_their_cell() -> None:
    fig, ax = plt.subplots(figsize=(3, 2))
    values = np.array([[0.0, 50.0], [25.0, 10.0]])
    image = ax.imshow(values, cmap="Blues")
    for (i, j), v in np.ndenumerate(values):
        ax.text(j, i, f"{v:.0f}", ha="center", va="center", color="black")
    assert [t.split()[0] for t in low_contrast_texts(fig)] == ["50"]  # black on navy
    for t in ax.texts:
        i, j = round(t.get_position()[1]), round(t.get_position()[0])
        t.set_color(text_colour_on(image.to_rgba(values[i, j])))
    assert low_contrast_texts(fig) == []
    ax.text(0.5, 0.5, "pale", color="0.8", transform=ax.transAxes)  # off the image: on white
    ax.set_xlim(-0.5, 3.5)
    assert low_contrast_texts(fig) == ["pale (1.6)"]
    plt.close(fig)


def test_undefined_numbers_in_texts_are_found() -> None:
    fig, ax = plt.subplots()
    ax.set_title("seed 1: first alarm nan s after the onset")
    ax.set_xlabel("delay (s): -inf")
    ax.set_ylabel("information (nanometre, infinite)")
    assert undefined_texts(fig) == [ax.get_title(), ax.get_xlabel()]
    ax.set_title("seed 1: no alarm after the onset")
    ax.set_xlabel("delay (s)")
    assert undefined_texts(fig) == []
    plt.close(fig)


def test_labels_of_two_rows_over_each_other_are_found() -> None:
    """A y label taller than its row runs into the next row's; one label for the figure
    does not."""
    fig, axes = plt.subplots(2, 1, figsize=(3, 2.4), layout="constrained")
    for ax in axes:
        ax.plot([0, 1], [0, 1])
        ax.set_ylabel("a label far taller than its own row (unit)")
    assert overlapping_texts(fig) == [(axes[0].get_ylabel(), axes[1].get_ylabel())]
    for ax in axes:
        ax.set_ylabel("")
    fig.supylabel("a label far taller than its own row (unit)")
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_every_curve_is_named_by_a_legend_or_its_style() -> None:
    """A curve without a label is unexplained; one whose colour and style a legend of faults
    (colour) and references (style) shows is explained; a threshold (axhline) is not a
    curve."""
    fig, ax = plt.subplots()
    x = np.linspace(0, 1, 20)
    ax.plot(x, x, color="C0")
    ax.axhline(0.5, color="0.5")
    ax.legend(handles=[Line2D([], [], color="C1", label="fault")])
    assert unexplained_lines(fig) == ["_child0 in ''"]
    ax.plot(x, x**2, "--", color="C1")  # the fault's colour, a reference's style
    ax.legend(
        handles=[
            Line2D([], [], color="C0", label="fault 0"),
            Line2D([], [], color="C1", label="fault 1"),
            Line2D([], [], color="0.3", ls="--", label="reference"),
        ]
    )
    assert unexplained_lines(fig) == []
    ax.plot([0.5], [0.5], "o", color="C1")  # a marker no legend shows
    assert unexplained_lines(fig) == ["_child3 in ''"]
    plt.close(fig)


def test_a_curve_under_the_dashed_one_it_matches_is_hidden() -> None:
    """A curve under a dashed one of its width keeps a third of its pixels (the gaps);
    drawn wider under a thinner dashed line it keeps most of them, and the dashed line all
    of its own; a translucent band over the curves leaves them their colour, tinted, an
    opaque one hides them."""
    fig, ax = plt.subplots(figsize=(4, 3))
    x = np.linspace(0, 5, 200)
    ax.plot(x, np.sin(x), color="C0", lw=0.8, label="measured")
    ax.plot(x, np.sin(x), "k--", lw=0.8, label="predicted")
    ax.legend()
    assert [h.split()[0] for h in hidden_lines(fig)] == ["measured"]
    ax.lines[0].set_linewidth(2.0)
    ax.lines[1].set_linewidth(0.7)
    assert hidden_lines(fig) == []
    assert [h.split()[0] for h in hidden_lines(fig, minimum=0.99)] == ["measured"]
    band = ax.fill_between(x, -1, 1, color="C1", alpha=0.3, zorder=3)  # over both
    assert hidden_lines(fig) == []  # they show through it, tinted
    band.set_alpha(1.0)  # an opaque one hides both
    assert [h.split()[0] for h in hidden_lines(fig)] == ["measured", "predicted"]
    plt.close(fig)


def test_a_label_without_a_unit_is_found() -> None:
    fig, (a, b, c) = plt.subplots(1, 3)
    for ax in (a, b, c):
        ax.plot([0, 1], [0, 1])
    a.set_ylabel("z of pitch (mrad)")
    b.set_ylabel("pulse response")
    assert labels_without_unit(fig) == ["'': 'pulse response'", "'': ''"]
    assert labels_without_unit(fig, axis="x") == ["'': ''"] * 3
    plt.close(fig)


def test_a_panels_one_curve_needs_no_legend_unless_the_panel_has_one() -> None:
    """A panel with one curve and no legend is named by its axis label; give it a legend
    that names only its threshold and the curve is unexplained (the oracle study's
    statistic panels named the threshold and the onset, not the statistic)."""
    fig, ax = plt.subplots()
    ax.plot([0, 1, 2], [1, 3, 2])
    ax.set_ylabel("statistic")
    assert unexplained_lines(fig) == []
    ax.axhline(2.5, color="C3", label="threshold")
    ax.legend()
    assert unexplained_lines(fig) == ["_child0 in ''"]
    plt.close(fig)


def test_a_number_on_a_mesh_cell_or_in_its_own_box_is_checked_against_that() -> None:
    """pcolormesh cells count as an image's do; a text with a box (a label on a hatched
    cell) is read against its box."""
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.pcolormesh(np.array([[0.0, 1.0]]), cmap="Greys", vmin=0, vmax=1)
    ax.text(0.5, 0.5, "on white", ha="center", va="center", color="white")
    ax.text(1.5, 0.5, "on black", ha="center", va="center", color="white")
    assert [t.split(" (")[0] for t in low_contrast_texts(fig)] == ["on white"]
    ax.texts[0].set_bbox({"fc": "black", "ec": "none"})
    assert low_contrast_texts(fig) == []
    plt.close(fig)
