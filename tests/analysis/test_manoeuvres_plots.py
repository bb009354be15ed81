"""The figures of manoeuvre runs (``probing plot manoeuvres``), from small synthetic runs:
no simulation."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis import manoeuvres
from probing.analysis.figure_checks import (
    clipped_texts,
    figure_problems,
    labels_without_unit,
    legends_over_data,
)

CHANNELS = ("q_rad_s", "nz_g")
SETTLE = 2


def _run(rate: float) -> tuple[pd.DataFrame, dict]:
    """A run whose response grows faster period by period; its error is largest in the
    first, slowest periods, so the points fill the upper left of each panel, where the
    legend used to sit."""
    lag = np.arange(50) * 0.02
    shape = np.exp(-lag / 0.2) * np.sin(lag / 0.05)
    frames = []
    for channel in CHANNELS:
        for period in range(12):
            peak = 1.0 + rate * 1e-3 * period**2
            error = 0.3 / (1 + period) + 1e-3 * rate
            pulse = peak * shape
            frames.append(
                pd.DataFrame(
                    {
                        "channel": channel,
                        "period": period,
                        "time_mid_s": 2.5 * period + 1.25,
                        "reference": rate * period,
                        "achieved": 0.9 * rate * period,
                        "lag_s": lag,
                        "h_pulse": pulse,
                        "h_est": pulse * (1 + error),
                    }
                )
            )
    scenario = {
        "aircraft": {"model": "gtm_t2"},
        "probe": {"settle_periods": SETTLE},
        "manoeuvre": {"hold": "speed", "start_s": 5.0, "change_kt": 20.0, "rate_kt_s": rate},
    }
    return pd.concat(frames, ignore_index=True), scenario


def _runs() -> dict[str, tuple[pd.DataFrame, dict]]:
    return {f"speed-{r:g}kt-s": _run(r) for r in (0.1, 0.5, 2.0, 4.0)}


def test_rate_figure_plots_every_settled_period() -> None:
    runs = _runs()
    figs = manoeuvres.figures(runs)
    assert set(figs) == {"periods", "rate", "snapshot"}
    ax = figs["rate"].axes[0]
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == "0.1 kt/s"]
    per = manoeuvres.period_table(runs["speed-0.1kt-s"][0])
    per = per[(per.channel == CHANNELS[0]) & (per.period >= SETTLE)]
    np.testing.assert_allclose(line.get_xdata(), 100 * per.moving)
    np.testing.assert_allclose(line.get_ydata(), 100 * per.error)
    for fig in figs.values():
        plt.close(fig)


def test_rate_figure_has_a_title_and_its_legend_hides_nothing() -> None:
    """The legend used to sit in the first panel's upper left, over its points, and the
    figure had no title."""
    figs = manoeuvres.figures(_runs())
    fig = figs["rate"]
    assert legends_over_data(fig) == []
    assert clipped_texts(fig) == []
    title = fig.get_suptitle()
    assert "gtm_t2" in title and "speed reference ramped by +20 kt" in title
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    (legend,) = fig.legends
    assert not legend.get_window_extent(renderer).overlaps(
        fig._suptitle.get_window_extent(renderer)
    )
    for fig in figs.values():
        plt.close(fig)


def test_no_manoeuvre_figure_has_a_legend_over_data_or_clipped_text() -> None:
    """Every manoeuvre figure: no legend hides a point or a line, no text runs off the edge
    (the periods figure's legend lay over the 0.1 kt/s line in its first panel)."""
    figs = manoeuvres.figures(_runs())
    for name, fig in figs.items():
        assert figure_problems(fig) == [], name  # the periods figure's styles were unnamed
    for fig in figs.values():
        plt.close(fig)


def test_the_snapshot_names_the_pulse_response_and_its_unit() -> None:
    """Each panel of the snapshot (a channel's row) says what its curves are and in which
    unit (they had no y label)."""
    fig = manoeuvres.figures(_runs())["snapshot"]
    assert [ax.get_ylabel() for ax in fig.axes] == [
        "pulse response (rad/s per deg)",
        "pulse response (rad/s per deg)",
        "pulse response (g per deg)",
        "pulse response (g per deg)",
    ]
    assert labels_without_unit(fig) == []
    assert figure_problems(fig) == []
    plt.close(fig)
