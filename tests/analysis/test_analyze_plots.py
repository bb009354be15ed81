"""The pulse-response figure of a ``bounds.parquet`` (``probing analyze``'s and a flight's):
units on the y axis, the convention in each title, the legend off the data, the lag axis
zoomed to a short response or to a given last lag, and a band wider than its estimate
explained on its panel."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from probing.analysis import analyze_plots
from probing.analysis.analyze_plots import ZOOM_WHEN, auto_max_lag_s, draw_bounds
from probing.analysis.figure_checks import figure_problems, legends_over_data


def _capture(monkeypatch: pytest.MonkeyPatch) -> dict:
    """Keep the figure save_figure is handed (and still save it)."""
    seen: dict = {}
    real = analyze_plots.save_figure

    def keep(fig, stem):
        seen["texts"] = [t.get_text() for t in fig.texts] + [
            ax.get_title(loc="left") for ax in fig.axes
        ]
        seen["ylabels"] = [ax.get_ylabel() for ax in fig.axes]
        seen["xlabel"] = fig.axes[-1].get_xlabel()
        seen["xlim"] = fig.axes[-1].get_xlim()
        seen["covered"] = legends_over_data(fig)
        seen["problems"] = figure_problems(fig)
        return real(fig, stem)

    monkeypatch.setattr(analyze_plots, "save_figure", keep)
    return seen


def _record(tmp_path: Path, pole: float) -> Path:
    import pandas as pd
    from scipy import signal

    from probing.cli import main

    seq = 2.0 * signal.max_len_seq(8)[0] - 1.0
    u = 0.5 * np.tile(seq, 6)
    y = signal.dlsim(([0.3], [1.0, -pole], 0.02), u)[1][:, 0]
    y += 1e-4 * np.random.default_rng(0).standard_normal(y.size)
    path = tmp_path / "rec.csv"
    pd.DataFrame({"t_s": np.arange(u.size) * 0.02, "u_deg": u, "q_rad_s": y}).to_csv(
        path, index=False
    )
    args = ["analyze", str(path), "--input", "u_deg", "--output", "q_rad_s", "--time", "t_s"]
    assert (
        main([*args, "--order", "8", "--bit-duration-s", "0.02", "--out", str(tmp_path / "o")]) == 0
    )
    return tmp_path / "o" / "bounds.parquet"


def test_units_convention_zoom_and_legend(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bounds = _record(tmp_path, 0.8)  # settled within 0.5 s of the 5.1 s period
    seen = _capture(monkeypatch)
    draw_bounds(bounds, tmp_path / "fig")
    assert seen["ylabels"] == ["rad/s per deg"]
    assert any("the response (constant pinned by the settled tail)" in t for t in seen["texts"])
    assert seen["xlabel"].startswith("lag (s): zoomed to 0-")
    assert seen["xlim"][1] < ZOOM_WHEN * 5.1
    assert seen["covered"] == []
    assert seen["problems"] == []
    draw_bounds(bounds, tmp_path / "fig2", max_lag_s=2.0)
    assert seen["xlim"] == (0.0, 2.0)  # it said "(--max-lag-s)", in Python too
    assert seen["xlabel"] == "lag (s): 0-2 s shown of the period's 5.1 s"
    assert not any("band" in t for t in seen["texts"])  # a narrow band says nothing


def test_long_response_shows_the_whole_period(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bounds = _record(tmp_path, 0.995)  # never settles within the period
    seen = _capture(monkeypatch)
    draw_bounds(bounds, tmp_path / "fig")
    assert seen["xlabel"] == "lag (s)"
    assert seen["xlim"][1] == pytest.approx(255 * 0.02)
    assert any("tail not settled" in t for t in seen["texts"])


def test_zoom_rule_both_sides_of_half_the_period() -> None:
    lag = np.arange(100) * 0.1  # a 10 s period
    h = np.zeros((1, 100))
    half = np.full((1, 100), 1e-3)
    h[0, :34] = 1.0  # stands out to tap 33 (3.3 s): 1.5 x 3.3 = 4.95 s <= 5 s
    assert auto_max_lag_s(lag, h, half) == pytest.approx(4.95)
    h[0, :35] = 1.0  # to 3.4 s: 5.1 s > 5 s, the whole period
    assert auto_max_lag_s(lag, h, half) is None


@pytest.mark.jsbsim
def test_a_flights_bounds_draw_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A run's bounds.parquet has no probing.input: the scenario names the figure."""
    from conftest import base_scenario

    from probing.experiment.flight.run import run_scenario
    from probing.experiment.scenario import parse_scenario

    scn = parse_scenario(base_scenario()).replace(
        **{"probe.order": 5, "probe.periods": 3, "probe.settle_periods": 1}
    )
    result = run_scenario(scn, tmp_path / "run", progress=False)
    seen = _capture(monkeypatch)
    draw_bounds(result.out_dir / "bounds.parquet", tmp_path / "fig")
    assert seen["ylabels"][0] == "rad per deg" and "rad/s per deg" in seen["ylabels"]
    assert any("the response (a reference carries the baseline)" in t for t in seen["texts"])


def test_a_band_wider_than_its_estimate_says_why_on_both_sides_of_each_rule() -> None:
    """The quickstart's first figure showed theta within a band of +-0.017 around 0.005:
    a failed method, to a newcomer.  A band whose median half-width is more than the
    largest |h| says why on its panel; one flat over the lags (largest half-width at most
    FLAT_BAND times the smallest) is the periods differing by a level."""
    from probing.analysis.analyze_plots import FLAT_BAND, wide_band_note

    h = np.array([0.5, -1.0, 0.25, 0.0])
    assert wide_band_note(h, np.full(4, 1.0)) is None  # median half-width = the peak
    flat = wide_band_note(h, np.full(4, 1.0 + 1e-9))
    assert flat is not None and flat.startswith("band wide and flat: the periods differ by a level")
    edge = np.array([1.01, 1.01, 1.01 * FLAT_BAND, 1.01])
    assert wide_band_note(h, edge) == flat
    uneven = wide_band_note(h, edge * np.array([1, 1, 1 + 1e-9, 1]))
    assert uneven == "band wider than the estimate: the periods disagree by more than the response"


def test_the_figure_puts_the_wide_band_note_in_its_panel() -> None:
    """bounds_figure: a flat band three times the estimate gets the note in its panel's
    title, over the lags drawn only; a narrow one none."""
    import pandas as pd

    from probing.analysis.analyze_plots import bounds_figure

    lag = np.arange(100) * 0.05
    rows = []
    for channel, half in (("theta_rad", 3.0), ("q_rad_s", 0.1)):
        h = np.exp(-lag)
        rows.append(
            pd.DataFrame(
                {
                    "channel": channel,
                    "lag_s": lag,
                    "h_est": h,
                    "h_low": h - half,
                    "h_high": h + half,
                }
            )
        )
    fig = bounds_figure(pd.concat(rows), {})
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert "band wide and flat" in titles[0] and "band" not in titles[1], titles
