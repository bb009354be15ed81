"""Figures of the Fig. 4 reproduction, drawn from :class:`probing.analysis.fig4.Fig4Data`
(no simulation).

Kept apart from :mod:`probing.analysis.fig4` so that computing the numbers never imports
matplotlib; this module imports that one, never the other way round.  :func:`figures` builds the
figures (inspectable: tests read the plotted data back), :func:`draw` saves them.

With ``bounds`` the panel and compensated figures shade each estimate's 95 % confidence
bounds: per tap, the two-sided Student-t interval of the mean over the settled periods
(:func:`probing.core.recorded.tap_bounds`), in the plotted line's colour and scale (mrad).
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from probing.analysis.fig4 import Fig4Data, PanelResult
from probing.analysis.figures import (
    LW_DASHED_OVER,
    LW_OVER,
    LW_UNDER,
    RC,
    place_clear_of_data,
    save_figure,
)
from probing.core.forked import can_fork, forked_map
from probing.core.nonlinearities import RateLimit
from probing.core.recorded import tap_bounds
from probing.experiment.output.layouts import BOUNDS_LEVEL

__all__ = ["draw", "figures"]
MRAD = 1e3  # rad -> mrad
C_BASE, C_NL, C_PRED, C_FIX = "0.55", "tab:red", "k", "tab:blue"
Z_PRED = 2.5  # a prediction's dashed line is drawn over the solid curves (2) that it matches
BAND_ALPHA = 0.25  # opacity of a confidence band


def _band(ax: Any, lag: np.ndarray, periods: np.ndarray, color: str, bounds: bool) -> None:
    """With ``bounds``: shade the 95 % bounds of the mean of ``periods`` (P, M; rad), in
    mrad over ``lag`` (s); nothing with fewer than 2 periods (no scatter to bound)."""
    if not bounds or periods.shape[0] < 2:
        return
    _, low, high, _ = tap_bounds(periods, BOUNDS_LEVEL)
    ax.fill_between(lag, low * MRAD, high * MRAD, color=color, alpha=BAND_ALPHA, lw=0)


def _title(p: PanelResult, measured_gain: float | None) -> str:
    """A panel's title: the nonlinearity, then a~/a predicted and ``measured_gain``, the
    least-squares gain of the z drawn against the baseline's (None: the panel has none)."""
    head = f"({p.letter}) {p.nonlinearity}: {p.parameters}"
    scn = p.run.scenario
    nl = scn.build_nonlinearity()
    if isinstance(nl, RateLimit):
        ratio = nl.ratio(scn.amplitude_deg, scn.bit_duration_s)
        verdict = "meets" if ratio >= 1 - 1e-12 else "below"
        return f"{head}\nr_l / (2a/t0) = {ratio:.2f}: {verdict} the bound (21)"
    a = scn.amplitude_deg
    b = p.predicted_offset_deg / a
    b_txt = "0" if b == 0 else f"{b:+.3g}a"
    pred = f"a~ = {p.predicted_gain:.3g}a, b~ = {b_txt}"
    if p.key != "b_saturation":
        return f"{head}\n{pred}; measured a~/a {measured_gain:.3f}"
    # The saturated run's own gain counts the leaked step of b~ (-5.3 on the GTM's h_est):
    # a~/a is measured on the offset twin subtracted (blue), or not at all.
    if measured_gain is None:
        return f"{head}\n{pred} (b~ DC)\na~/a unreadable: the offset's step leaks into z"
    return f"{head}\n{pred} (b~ DC)\nmeasured a~/a {measured_gain:.3f} (offset twin subtracted)"


def _measured_gain(p: PanelResult, data: Fig4Data) -> float | None:
    """The gain a panel's title states: of its z against the baseline's; for the saturation,
    of the run with the offset twin subtracted (None without that twin)."""
    if p.key != "b_saturation":
        return p.measured_gain_z
    return None if data.remedy_row is None else data.remedy_row.measured_gain_z


def _predicted_z(p: PanelResult, z0: np.ndarray) -> np.ndarray:
    """Eq. (11): z_bar = (a~/a) z0 + b~ S, with S = sum h0 = sum(z0) / a."""
    a = p.run.scenario.amplitude_deg
    s = z0.sum() / a
    return p.predicted_gain * z0 + p.predicted_offset_deg * s


#: Where the note on the saturation offset may go (axes coordinates, alignments): the
#: lower right corner first, then up the right side, then up the left, below the legend.
_NOTE_POSITIONS = [
    (x, y / 100, ha, "bottom")
    for x, ha in ((0.98, "right"), (0.02, "left"))
    for y in range(4, 42, 2)
]


def _plot_prediction(ax: Any, p: PanelResult, z0: np.ndarray, lag: np.ndarray) -> Any:
    """The predicted curve of a panel; for the saturation, also the note on its offset.

    Returns that note (a matplotlib text) or None.
    """
    if p.key == "b_saturation":
        ax.plot(
            lag,
            p.predicted_gain * z0 * MRAD,
            color=C_PRED,
            ls="--",
            lw=LW_DASHED_OVER,
            zorder=Z_PRED,
            label="(a~/a) x no nonlinearity",
        )
        offset = (_predicted_z(p, z0) - p.predicted_gain * z0).mean()
        return ax.text(
            0.98,
            0.04,
            f"steady-state offset\nb~·Σh of eq. (11):\n{offset * MRAD:+.2f} mrad (off scale)",
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            fontsize=7,
        )
    if not isinstance(p.run.scenario.build_nonlinearity(), RateLimit):
        ax.plot(
            lag,
            _predicted_z(p, z0) * MRAD,
            color=C_PRED,
            ls="--",
            lw=LW_DASHED_OVER,
            zorder=Z_PRED,
            label="predicted, eq. (11)",
        )
    return None


def _draw_panel(
    ax: Any, p: PanelResult, data: Fig4Data, z0: np.ndarray, lag: np.ndarray, bounds: bool
) -> Any:
    """One nonlinearity's panel (``bounds``: with its estimates' confidence bands); returns
    the note on the saturation offset or None."""
    ax.plot(lag, z0 * MRAD, color=C_BASE, lw=LW_UNDER, label="no nonlinearity")
    _band(ax, lag, data.baseline.z, C_BASE, bounds)
    note = _plot_prediction(ax, p, z0, lag)
    if p.key == "b_saturation" and data.remedy is not None:
        _band(ax, lag, data.remedy.z, C_FIX, bounds)
        ax.plot(  # under the dashed (a~/a) z0 it recovers: wide, and under the red curve
            lag,
            data.remedy.z.mean(axis=0) * MRAD,
            color=C_FIX,
            lw=LW_UNDER,
            label="offset twin subtracted",
        )
    # eq. (11)'s dashed line lies on the red curve it predicts: that one is drawn wide
    predicted = p.key != "b_saturation" and not isinstance(
        p.run.scenario.build_nonlinearity(), RateLimit
    )
    ax.plot(
        lag,
        p.run.z.mean(axis=0) * MRAD,
        color=C_NL,
        lw=LW_UNDER if predicted else LW_OVER,
        label="with nonlinearity",
    )
    _band(ax, lag, p.run.z, C_NL, bounds)
    ax.set_title(_title(p, _measured_gain(p, data)), loc="left")
    ax.set_ylabel("z of pitch θ (mrad)")
    if p.key == "b_saturation":
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.7 * (hi - lo))
        ax.legend(loc="upper center", ncol=2, frameon=False, fontsize=6.5)
    else:
        ax.legend(loc="best", frameon=False)
    return note


def _label_lag(axes: np.ndarray) -> None:
    """Name the lag and show its tick labels under every panel with no panel below it (the
    bottom row's, and one above an empty slot), however ``sharex`` hid them."""
    grid = np.atleast_2d(axes)
    rows = grid.shape[0]
    for r, c in np.ndindex(grid.shape):
        ax = grid[r, c]
        if ax.axison and (r == rows - 1 or not grid[r + 1, c].axison):
            ax.tick_params(axis="x", labelbottom=True)
            ax.set_xlabel("lag (s)")


def _info_text(data: Fig4Data) -> str:
    """The text of the last (information) panel: the set, the flight condition, the probe."""
    base = data.baseline
    scn = base.scenario
    return (
        f"Fig. 4 reproduction, set '{data.set_name}'\n"
        f"aircraft {scn.model}, {scn.altitude_ft:g} ft, {scn.speed:g} "
        f"{scn.speed_kind.removeprefix('speed_')}\n"
        f"PRBS order {scn.order} (M = {scn.bits_per_period}), t0 = {scn.bit_duration_s:g} s,\n"
        f"dt = {scn.dt_s:g} s, a = {scn.amplitude_deg:g} deg elevator\n"
        f"z: probing output (eq. 5) of pitch angle θ,\n"
        f"mean over {len(base.z)} settled periods; unprobed twin\n"
        f"subtracted (drift reference)."
        + (
            "\nElevator through the GTM's 5 Hz servo (kept).\n\n"
            if scn.model == "gtm_t2"
            else "\n\n"
        )
        + "(b) the offset b~ is a step input: its transient\n"
        "leaks into z.  Blue: the same run minus a twin\n"
        "that receives only the constant b~ (no probe):\n"
        "the scaled pulse response (a~/a) z0 is recovered.\n\n"
        "A dashed prediction is drawn thin over the wide\n"
        "curve it predicts: where the two coincide, the\n"
        "curve shows on both sides of the dashes."
    )


def _panels(data: Fig4Data, bounds: bool = False) -> Any:
    base = data.baseline
    z0 = base.z.mean(axis=0)
    lag = base.lag_s
    fig, axes = plt.subplots(4, 2, figsize=(7.0, 9.0), sharex=True, constrained_layout=True)
    offset_note = None
    for ax, p in zip(axes.flat, data.panels, strict=False):
        note = _draw_panel(ax, p, data, z0, lag, bounds)
        if note is not None:
            offset_note = note
    info = axes.flat[-1]
    info.axis("off")
    _label_lag(axes)
    if offset_note is not None:  # once every panel is drawn: the layout is final
        place_clear_of_data(offset_note.axes, offset_note, _NOTE_POSITIONS)
    info.text(
        0.0,
        1.0,
        _info_text(data),
        va="top",
        ha="left",
        transform=info.transAxes,
        fontsize=7.5,
    )
    return fig


def _compensated(data: Fig4Data, bounds: bool = False) -> Any:
    z0 = data.baseline.z.mean(axis=0)
    lag = data.baseline.lag_s
    items = [p for p in data.panels if p.compensated_z is not None]
    if data.remedy_row is not None:
        items.append(data.remedy_row)
    rows = (len(items) + 1) // 2
    fig, axes = plt.subplots(
        rows, 2, figsize=(7.0, 2.0 * rows + 0.4), sharex=True, constrained_layout=True
    )
    for ax, p in zip(axes.flat, items, strict=False):
        ax.plot(lag, z0 * MRAD, color=C_BASE, lw=LW_UNDER, label="no nonlinearity")
        _band(ax, lag, data.baseline.z, C_BASE, bounds)
        ax.plot(lag, p.compensated_z * MRAD, color=C_FIX, lw=LW_OVER, label="compensated")
        if p.compensated_periods is not None:
            _band(ax, lag, p.compensated_periods, C_FIX, bounds)
        if p.letter == "b'":
            title = "(b') saturation, offset twin subtracted, / (a~/a)"
        else:
            title = f"({p.letter}) {p.nonlinearity}: {p.parameters}"
        ax.set_title(f"{title}\n||z_c - z0|| / ||z0|| = {p.compensation_error:.2e}", loc="left")
        ax.set_ylabel("z of θ (mrad)")
        ax.legend(loc="best", frameon=False)
    for ax in axes.flat[len(items) :]:
        ax.axis("off")
    _label_lag(axes)
    fig.suptitle(
        f"Compensated probing output, eq. (11) undone per settled period ({data.set_name})",
        fontsize=8,
    )
    return fig


def _rate_limit(data: Fig4Data, bounds: bool = False) -> Any:
    """The rate-limit sweep (its points are means: ``bounds`` draws nothing more)."""
    sweep = data.sweep
    a = data.baseline.scenario.amplitude_deg
    dt = data.baseline.scenario.dt_s
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.0, 3.5), constrained_layout=True)
    floor = 1e-7
    for i, (t0, grp) in enumerate(sweep.groupby("bit_duration_s")):
        color = f"C{i}"
        bound = RateLimit.bound(a, t0)
        label = f"t0 = {t0:g} s ({round(t0 / dt)} step/bit), 2a/t0 = {bound:g} deg/s"
        ax1.loglog(
            grp["ratio"],
            np.maximum(grp["shape_error_z"], floor),
            "o-",
            ms=3,
            color=color,
            label=f"{label}: z",
        )
        ax1.loglog(
            grp["ratio"],
            np.maximum(grp["shape_error"], floor),
            "s--",
            ms=2.5,
            lw=0.7,
            color=color,
            label="     h_est",
        )
        ax2.semilogx(grp["ratio"], grp["gain_z"], "o-", ms=3, color=color, label=f"{label}: z")
        ax2.semilogx(
            grp["ratio"], grp["gain"], "s--", ms=2.5, lw=0.7, color=color, label="     h_est"
        )
    ticks = [0.25, 0.5, 1, 2, 4]
    for ax in (ax1, ax2):
        ax.axvline(1.0, color="k", ls=":", lw=0.8)
        ax.set_xlabel("r_l / (2a/t0)")
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
        ax.set_xticks([], minor=True)
    ax1.set_ylim(floor / 2, 1.0)
    ax1.text(2.0, floor * 1.6, "at floor: error exactly 0", fontsize=6.5, ha="center")
    ax1.set_ylabel("shape error ||x - g x0|| / ||g x0||")
    ax2.set_ylabel("least-squares gain g")
    handles, labels = ax2.get_legend_handles_labels()  # under the panels: it hides no curve
    fig.legend(handles, labels, loc="outside lower center", ncol=2, frameon=False, fontsize=6.5)
    fig.suptitle(
        f"Rate limit against the bound of eq. (21), a = {a:g} deg ({data.set_name})", fontsize=8
    )
    return fig


#: The figures, by the suffix of their file stem, with their builders and formats.
_FIGURES = {
    "": (_panels, ("png", "pdf")),
    "_compensated": (_compensated, ("png",)),
    "_rate_limit": (_rate_limit, ("png",)),
}


def _suffixes(data: Fig4Data) -> list[str]:
    """The figures ``data`` has: the rate-limit figure only with a rate-limit sweep."""
    return [k for k in _FIGURES if k != "_rate_limit" or not data.sweep.empty]


def figures(data: Fig4Data, bounds: bool = False) -> dict[str, Any]:
    """The figures, by the suffix of their file stem: ``""`` (the panels), ``"_compensated"``
    and, with a rate-limit sweep, ``"_rate_limit"``.  Close them (or :func:`draw` them).
    ``bounds``: shade the estimates' 95 % confidence bounds (module docstring)."""
    with plt.rc_context(RC):
        return {suffix: _FIGURES[suffix][0](data, bounds) for suffix in _suffixes(data)}


def _draw_one(
    task: tuple[str, tuple[str, ...]], data: Fig4Data, folder: Path, stem: str, bounds: bool
) -> list[Path]:
    suffix, formats = task
    with plt.rc_context(RC):
        fig = _FIGURES[suffix][0](data, bounds)
    return save_figure(fig, Path(folder) / f"{stem}{suffix}", formats)


def draw(
    data: Fig4Data, folder: Path, stem: str, jobs: int | None = None, bounds: bool = False
) -> list[Path]:
    """Save ``<stem>.png/.pdf``, ``<stem>_compensated.png`` and ``<stem>_rate_limit.png``;
    with ``bounds`` the first two shade the estimates' 95 % confidence bounds.

    The figures are drawn side by side in ``jobs`` forked children (default: one per core;
    1 draws them here, one after the other); the bytes are the same either way.  A figure's
    formats are saved by one child, in order: the PDF is laid out as the PNG drawn first
    left it, so drawn alone it would differ.
    """
    tasks = [(s, _FIGURES[s][1]) for s in _suffixes(data)]
    jobs = jobs or os.cpu_count() or 1
    if jobs == 1 or not can_fork():
        return [p for t in tasks for p in _draw_one(t, data, folder, stem, bounds)]
    draw_one = functools.partial(_draw_one, data=data, folder=folder, stem=stem, bounds=bounds)
    done = {o.index: o.get() for o in forked_map(draw_one, tasks, jobs)}
    return [p for i in range(len(tasks)) for p in done[i]]
