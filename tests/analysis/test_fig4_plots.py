"""The Fig. 4 figures' confidence bands, drawn from a small synthetic :class:`Fig4Data`
(the set's scenario files, made-up probing outputs: no simulation)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection

from analysis import fig4, fig4_plots
from probing.core.nonlinearities import compensate
from probing.core.recorded import tap_bounds
from probing.experiment.fig4_set import PANELS
from probing.experiment.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SET = ROOT / "scenarios" / "fig4-737"
M = 511
LAG = np.arange(M) * 0.01


def _run(name: str, scale: float, seed: int) -> fig4.RunData:
    """Four settled periods of a made-up pitch response (rad) with period-to-period scatter."""
    rng = np.random.default_rng(seed)
    shape = 1e-4 * np.sin(LAG) * np.exp(-LAG / 2.0)
    z = scale * shape + 2e-6 * rng.standard_normal((4, M))
    return fig4.RunData(load_scenario(SET / f"{name}.toml"), LAG, z, z / (0.005 * (M + 1)))


@pytest.fixture(scope="module")
def data() -> fig4.Fig4Data:
    base = _run("baseline", 1.0, 0)
    z0, h0 = base.z.mean(axis=0), base.h.mean(axis=0)
    panels = [
        fig4._panel_result(key, letter, _run(key, 0.6, i + 1), h0, z0)
        for i, (key, letter) in enumerate(PANELS.items())
    ]
    remedy = _run("b_saturation", 0.5, 99)
    remedy_row = fig4._remedy_row(remedy, panels, h0, z0)
    return fig4.Fig4Data("synthetic", base, panels, remedy, remedy_row, pd.DataFrame())


def _bands(ax: Any) -> list[PolyCollection]:
    return [c for c in ax.collections if isinstance(c, PolyCollection)]


def _assert_band(band: PolyCollection, periods: np.ndarray) -> None:
    """The band's outline runs through (lag, low) and (lag, high) of every tap, in mrad."""
    _, low, high, _ = tap_bounds(periods, 0.95)
    (path,) = band.get_paths()
    corners = {tuple(v) for v in path.vertices}
    for y in (low, high):
        assert {(x, v) for x, v in zip(LAG, 1e3 * y, strict=True)} <= corners
    y = path.vertices[:, 1]
    assert (y.min(), y.max()) == (1e3 * low.min(), 1e3 * high.max())


def test_without_bounds_the_figures_draw_no_band(data: fig4.Fig4Data) -> None:
    figs = fig4_plots.figures(data)
    assert set(figs) == {"", "_compensated"}
    for fig in figs.values():
        assert all(_bands(ax) == [] for ax in fig.axes)
        plt.close(fig)


def test_bounds_shade_each_estimates_tap_bounds_and_change_no_line(
    data: fig4.Fig4Data,
) -> None:
    plain = fig4_plots.figures(data)
    figs = fig4_plots.figures(data, bounds=True)
    for suffix, fig in figs.items():
        for ax, before in zip(fig.axes, plain[suffix].axes, strict=True):
            lines = [(ln.get_label(), ln.get_ydata()) for ln in ax.get_lines()]
            for (label, y), ln in zip(lines, before.get_lines(), strict=True):
                assert label == ln.get_label()
                np.testing.assert_array_equal(y, ln.get_ydata())
    for ax, p in zip(figs[""].axes, data.panels, strict=False):
        bands = _bands(ax)
        runs = [data.baseline.z, p.run.z]
        if p.key == "b_saturation":
            runs.append(data.remedy.z)  # the offset twin subtracted
        assert len(bands) == len(runs), p.key
        for band, periods in zip(bands, runs, strict=True):
            _assert_band(band, periods)
    comp = figs["_compensated"]
    items = [p for p in data.panels if p.compensated_z is not None] + [data.remedy_row]
    for ax, p in zip(comp.axes, items, strict=False):
        base_band, band = _bands(ax)
        _assert_band(base_band, data.baseline.z)
        _assert_band(band, p.compensated_periods)
    deadband = data.panels[0]
    scn = deadband.run.scenario
    np.testing.assert_array_equal(
        deadband.compensated_periods,
        compensate(deadband.run.z, scn.build_nonlinearity(), scn.amplitude_deg),
    )
    np.testing.assert_array_equal(
        data.remedy_row.compensated_periods, data.remedy.z / data.remedy_row.predicted_gain
    )
    for fig in (*figs.values(), *plain.values()):
        plt.close(fig)


def test_draw_hands_bounds_to_every_figure(
    data: fig4.Fig4Data, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``draw(..., bounds=True)`` (``--bounds``) draws the bands in the saved figures."""
    seen = []
    monkeypatch.setattr(fig4_plots, "save_figure", lambda fig, *a: seen.append(fig) or [])
    fig4_plots.draw(data, tmp_path, "synthetic", jobs=1, bounds=True)
    assert len(seen) == 2 and all(any(_bands(ax) for ax in f.axes) for f in seen)
    for fig in seen:
        plt.close(fig)
