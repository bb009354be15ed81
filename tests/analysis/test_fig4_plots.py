"""The Fig. 4 figures (their confidence bands, titles, tick labels and the order of their
lines), drawn from a small synthetic :class:`Fig4Data` (the set's scenario files, made-up
probing outputs: no simulation)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection

from probing.analysis import fig4, fig4_plots
from probing.analysis.figure_checks import hidden_lines
from probing.core.metrics import gain_and_shape
from probing.core.nonlinearities import compensate
from probing.core.recorded import tap_bounds
from probing.experiment.scenario import load_scenario
from probing.experiment.studies.fig4_set import PANELS

ROOT = Path(__file__).resolve().parents[2]
SET = ROOT / "scenarios" / "fig4-737"
M = 511
LAG = np.arange(M) * 0.01


def _run(name: str, scale: float, seed: int, h_dc: float = 0.0) -> fig4.RunData:
    """Four settled periods of a made-up pitch response (rad) with period-to-period scatter;
    ``h_dc`` (rad/deg) is added to every tap of h_est (the saturation's leaked step)."""
    rng = np.random.default_rng(seed)
    shape = 1e-4 * np.sin(LAG) * np.exp(-LAG / 2.0)
    z = scale * shape + 2e-6 * rng.standard_normal((4, M))
    h = z / (0.005 * (M + 1)) + h_dc
    return fig4.RunData(load_scenario(SET / f"{name}.toml"), LAG, z, h)


@pytest.fixture(scope="module")
def data() -> fig4.Fig4Data:
    base = _run("baseline", 1.0, 0)
    z0, h0 = base.z.mean(axis=0), base.h.mean(axis=0)
    # the saturation's offset step leaks into h_est as a large DC term (on the GTM its
    # least-squares gain of h came out at -5.29 where a~/a = 0.5)
    panels = [
        fig4._panel_result(
            key, letter, _run(key, 0.6, i + 1, -3e-4 if key == "b_saturation" else 0.0), h0, z0
        )
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
            runs.insert(1, data.remedy.z)  # the offset twin subtracted, under the red curve
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


def _ydata(ax: Any, label: str) -> np.ndarray:
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == label]
    return np.asarray(line.get_ydata(), float)


def _title_gains(ax: Any) -> tuple[float, float]:
    """The predicted a~/a and the measured gain a panel's title states."""
    title = ax.get_title(loc="left")
    predicted = re.search(r"a~ = (-?[\d.]+)a", title)
    measured = re.search(r"measured (?:gain|a~/a) (-?[\d.]+)", title)
    assert predicted and measured, title
    return float(predicted.group(1)), float(measured.group(1))


def test_each_title_states_the_gain_of_the_curve_its_panel_draws(data: fig4.Fig4Data) -> None:
    """The measured a~/a in a panel's title is the least-squares gain of the curve drawn
    against the baseline drawn: in (b) the blue curve (the offset twin subtracted), whose
    gain is a~/a; the saturated run's own gain counts the leaked offset (-5.29 on the GTM)."""
    fig = fig4_plots.figures(data)[""]
    for ax, p in zip(fig.axes, data.panels, strict=False):
        if p.key in ("e_rate_limit", "f_rate_limit"):
            continue  # no apparent form: the title states the rate bound instead
        z0 = _ydata(ax, "no nonlinearity")
        measured = "offset twin subtracted" if p.key == "b_saturation" else "with nonlinearity"
        gain, _ = gain_and_shape(_ydata(ax, measured), z0)
        predicted, stated = _title_gains(ax)
        assert stated == pytest.approx(gain, abs=5e-4), p.key
        assert predicted == pytest.approx(p.predicted_gain, abs=5e-4), p.key
    sat = next(p for p in data.panels if p.key == "b_saturation")
    assert abs(sat.measured_gain - 0.5) > 0.1  # the leak: the number the title must not give
    plt.close(fig)


def test_without_the_offset_twin_panel_b_states_no_measured_gain(data: fig4.Fig4Data) -> None:
    """Without the offset twin the saturated run's gain is the leak's, not a~/a: not printed."""
    bare = fig4.Fig4Data(data.set_name, data.baseline, data.panels, None, None, data.sweep)
    fig = fig4_plots.figures(bare)[""]
    sat = next(ax for ax in fig.axes if ax.get_title(loc="left").startswith("(b) saturation"))
    title = sat.get_title(loc="left")
    assert "a~ = 0.5a" in title and "measured" not in title
    plt.close(fig)


def _x_tick_texts(ax: Any) -> list[str]:
    return [t.get_text() for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]


@pytest.mark.parametrize("remedy", [True, False])
def test_every_panel_with_nothing_below_it_has_x_tick_labels(
    data: fig4.Fig4Data, remedy: bool
) -> None:
    """The lowest panel of each column (and one above an empty slot: (f) above the note)
    shows the lag's tick labels and name; a panel with a panel below it shows neither."""
    if not remedy:  # the compensated figure then has an empty last slot too
        data = fig4.Fig4Data(data.set_name, data.baseline, data.panels, None, None, data.sweep)
    for suffix, fig in fig4_plots.figures(data).items():
        fig.draw_without_rendering()
        grid = fig.axes[0].get_subplotspec().get_gridspec()
        rows = grid.get_geometry()[0]
        shown = {}
        for ax in fig.axes:
            spec = ax.get_subplotspec()
            shown[spec.rowspan.start, spec.colspan.start] = ax if ax.axison else None
        for (row, col), ax in shown.items():
            if ax is None:
                continue
            alone = row == rows - 1 or shown.get((row + 1, col)) is None
            assert bool(_x_tick_texts(ax)) == alone, (suffix, ax.get_title(loc="left"))
            assert (ax.get_xlabel() == "lag (s)") == alone, (suffix, ax.get_title(loc="left"))
        plt.close(fig)


def _drawn_above(ax: Any, upper: Any, lower: Any) -> bool:
    """Whether ``upper`` is drawn after ``lower`` (higher z-order, or equal and added later)."""
    lines = list(ax.get_lines())
    return (upper.get_zorder(), lines.index(upper)) > (lower.get_zorder(), lines.index(lower))


def test_the_dashed_prediction_is_drawn_over_the_curve_it_predicts(data: fig4.Fig4Data) -> None:
    """In (b) the dashed (a~/a) z0 lies on the blue curve; elsewhere eq. (11) lies on the red
    one: the dashed line is drawn over every solid curve, so both stay visible."""
    fig = fig4_plots.figures(data)[""]
    checked = 0
    for ax in fig.axes:
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        solid = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"]
        for d in dashed:
            for s in solid:
                assert _drawn_above(ax, d, s), (ax.get_title(loc="left"), s.get_label())
                checked += 1
    assert checked == 3 + 4 * 2  # (b): over the baseline, red and blue; (a c d g): two each
    plt.close(fig)


@pytest.fixture(scope="module")
def exact() -> fig4.Fig4Data:
    """Panels whose runs are exactly what eq. (11) predicts, as the paper's are to the
    last digit: a~/a times the baseline's periods (the hysteresis relay's and the relay's
    b~ = 0), the offset twin subtracted (b') at a~/a, the rate limit that meets its bound
    equal to the baseline, the one below it not."""
    base = _run("baseline", 1.0, 0)
    z0, h0 = base.z.mean(axis=0), base.h.mean(axis=0)
    panels = []
    for key, letter in PANELS.items():
        scn = load_scenario(SET / f"{key}.toml")
        gain = fig4._panel_result(key, letter, _run(key, 1.0, 1), h0, z0).predicted_gain
        if key == "b_saturation":
            run = _run(key, 0.6, 2, -3e-4)  # the leaked step: no curve it matches
        elif key == "e_rate_limit":
            run = _run(key, 0.8, 3)
        else:
            scale = 1.0 if key == "f_rate_limit" else gain
            run = fig4.RunData(scn, LAG, scale * base.z, scale * base.h)
        panels.append(fig4._panel_result(key, letter, run, h0, z0))
    sat = load_scenario(SET / "b_saturation.toml")
    remedy = fig4.RunData(sat, LAG, 0.5 * base.z, 0.5 * base.h)
    remedy_row = fig4._remedy_row(remedy, panels, h0, z0)
    return fig4.Fig4Data("synthetic", base, panels, remedy, remedy_row, pd.DataFrame())


def test_a_curve_its_prediction_lies_on_stays_visible(exact: fig4.Fig4Data) -> None:
    """Where the dashed prediction lies exactly on the measured curve ((b): the blue curve,
    the offset twin subtracted, under (a~/a) x no nonlinearity; (a c d g): the red one under
    eq. (11)) and where a curve lies on the baseline ((f), and every compensated curve),
    each curve keeps at least half of its own pixels: the lower one is drawn wider."""
    figs = fig4_plots.figures(exact)
    for suffix, fig in figs.items():
        assert hidden_lines(fig) == [], suffix
        plt.close(fig)
