"""Incremental probing through manoeuvres: the table and figures of the stored runs.

Reads the ``manoeuvre.parquet`` of runs of ``[manoeuvre]`` scenarios (``make manoeuvres``):
per period and channel the probing output's pulse response (``h_est``) and the single pulse
on the unprobed twin at the period's middle (``h_pulse``), with the manoeuvre's reference and
the state the twin reached.  The error of a period is ||h_est - h_pulse|| / ||h_pulse|| over
the taps; how fast the response moves is the change of the truth's peak from the period
before to the period after, per period.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from probing.analysis.figures import RC, legends_in_margins, response_unit, save_figure
from probing.core.fixedorder import norm
from probing.experiment.output.storage import read_table
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = ["draw", "figures", "load_runs", "period_table", "summary_markdown"]


def load_runs(results: Path) -> dict[str, tuple[pd.DataFrame, dict]]:
    """Run name -> (its rows, its scenario), for every ``<results>/<name>/manoeuvre.parquet``,
    ordered by the manoeuvre's rate.

    Raises
    ------
    FileNotFoundError
        If no such run is there.
    """
    runs = []
    for path in sorted(Path(results).glob("*/manoeuvre.parquet")):
        table = read_table(path)
        scenario = json.loads((table.schema.metadata or {})[b"probing.scenario"])
        runs.append((path.parent.name, table.to_pandas(), scenario))
    if not runs:
        raise FileNotFoundError(f"{results}: no manoeuvre run (manoeuvre.parquet)")
    runs.sort(key=lambda r: _rate(r[2]))
    return {name: (table, scenario) for name, table, scenario in runs}


def _rate(scenario: dict) -> float:
    man = scenario["manoeuvre"]
    return float(next(v for k, v in man.items() if k.startswith("rate_")))


def _unit(scenario: dict) -> str:
    return next(k for k in scenario["manoeuvre"] if k.startswith("rate_"))[len("rate_") :]


def period_table(table: pd.DataFrame) -> pd.DataFrame:
    """Per period and channel: time, reference, achieved, the error against the single pulse,
    the truth's peak and how much it moves per period (relative, central difference)."""
    rows = []
    for (channel, period), g in table.groupby(["channel", "period"], sort=True):
        est, pulse = g.h_est.to_numpy(), g.h_pulse.to_numpy()
        rows.append(
            {
                "channel": channel,
                "period": period,
                "time_mid_s": g.time_mid_s.iloc[0],
                "reference": g.reference.iloc[0],
                "achieved": g.achieved.iloc[0],
                "error": norm(est - pulse) / norm(pulse),
                "peak_pulse": np.abs(pulse).max(),
                "peak_est": np.abs(est).max(),
            }
        )
    out = pd.DataFrame(rows)
    out["moving"] = out.groupby("channel").peak_pulse.transform(
        lambda s: np.abs(np.gradient(s.to_numpy())) / s.to_numpy()
    )
    return out


def summary_markdown(runs: dict[str, tuple[pd.DataFrame, dict]]) -> str:
    """One row per run and channel: the error while the response moves and once it is still."""
    lines = [
        "<!-- written by probing plot manoeuvres (make manoeuvres); do not edit -->",
        "",
        "| run | rate | channel | response change per period (largest) | median error while "
        "the reference moves | largest error after settling | error in the last period |",
        "|---|---:|---|---:|---:|---:|---:|",
    ]
    for name, (table, scenario) in runs.items():
        settle = scenario["probe"]["settle_periods"]
        man = scenario["manoeuvre"]
        start = man["start_s"]
        end = start + abs(next(v for k, v in man.items() if k.startswith("change_"))) / _rate(
            scenario
        )
        per = period_table(table)
        for channel, g in per[per.period >= settle].groupby("channel", sort=False):
            moving = g[(g.time_mid_s >= start) & (g.time_mid_s <= end)]
            lines.append(
                f"| {name} | {_rate(scenario):g} {_unit(scenario).replace('_s', '/s')} | "
                f"{channel} | {100 * g.moving.max():.1f} % | {100 * moving.error.median():.1f} % "
                f"| {100 * g.error.max():.1f} % | {100 * g.error.iloc[-1]:.2f} % |"
            )
    return "\n".join(lines) + "\n"


def _periods(runs: dict[str, tuple[pd.DataFrame, dict]], tables: dict[str, pd.DataFrame]) -> Any:
    """The manoeuvre, the response's peak and the error period by period, every run."""
    channels = list(dict.fromkeys(next(iter(runs.values()))[0].channel))
    colours = {name: f"C{i}" for i, name in enumerate(runs)}
    fig, axes = plt.subplots(
        1 + len(channels),
        2,
        figsize=(8, 2.0 * (1 + len(channels))),
        sharex=True,
        constrained_layout=True,
    )
    for name, per in tables.items():
        settle = runs[name][1]["probe"]["settle_periods"]
        c0 = per[per.channel == channels[0]]
        axes[0, 0].plot(c0.time_mid_s, c0.reference, ":", color=colours[name])
        axes[0, 0].plot(c0.time_mid_s, c0.achieved, color=colours[name], label=name)
        for i, channel in enumerate(channels, start=1):
            g = per[(per.channel == channel) & (per.period >= settle)]
            axes[i, 0].plot(g.time_mid_s, g.peak_pulse, color=colours[name])
            axes[i, 0].plot(g.time_mid_s, g.peak_est, "o", ms=2, color=colours[name])
            axes[i, 1].semilogy(g.time_mid_s, 100 * g.error, "o-", ms=2, color=colours[name])
            axes[i, 0].set_ylabel(f"peak |h|, {channel}")
            axes[i, 1].set_ylabel(f"error (%), {channel}")
        axes[0, 1].plot(c0.time_mid_s, 100 * c0.moving, color=colours[name])
    unit = _unit(next(iter(runs.values()))[1])
    axes[0, 0].set_ylabel(f"change ({unit.split('_')[0]})")
    axes[0, 0].set_title("reference (dotted), twin reached (line)")
    axes[0, 1].set_ylabel("response change / period (%)")
    axes[0, 1].set_title(f"how fast {channels[0]}'s response moves")
    axes[1, 0].set_title("single pulse at mid-period (line), probing output (dots)")
    axes[1, 1].set_title("||h_est - h_pulse|| / ||h_pulse||")
    handles, labels = axes[0, 0].get_legend_handles_labels()  # under the panels: hides no line
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), title="run")
    for ax in axes[-1]:
        ax.set_xlabel("time after trim (s)")
    styles = []  # what the line styles are, in a band above the curves of two panels
    for ax, entries in (
        (axes[0, 0], (("reference", ":", "None"), ("twin reached", "-", "None"))),
        (axes[1, 0], (("single pulse at mid-period", "-", "None"), ("probing output", "", "o"))),
    ):
        proxies = [
            Line2D([], [], color="0.3", ls=ls, marker=m, ms=2, label=label)
            for label, ls, m in entries
        ]
        styles.append((ax, ax.legend(handles=proxies, loc="upper center", ncols=2, fontsize=6), []))
    legends_in_margins(styles)
    return fig


def _rate_figure(
    runs: dict[str, tuple[pd.DataFrame, dict]], tables: dict[str, pd.DataFrame]
) -> Any:
    """The error of every settled period against how fast the response moves, every run; the
    legend (the runs' rates) under the panels, where it hides no point."""
    channels = list(dict.fromkeys(next(iter(runs.values()))[0].channel))
    colours = {name: f"C{i}" for i, name in enumerate(runs)}
    fig, axes = plt.subplots(
        1,
        len(channels),
        figsize=(3.2 * len(channels), 3.3),
        constrained_layout=True,
        squeeze=False,
    )
    for name, per in tables.items():
        scenario = runs[name][1]
        settle = scenario["probe"]["settle_periods"]
        rate = f"{_rate(scenario):g} {_unit(scenario).replace('_s', '/s')}"
        for j, channel in enumerate(channels):
            g = per[(per.channel == channel) & (per.period >= settle)]
            axes[0, j].loglog(
                100 * g.moving, 100 * g.error, "o", ms=3, color=colours[name], label=rate
            )
            axes[0, j].set_title(channel)
            axes[0, j].set_xlabel("response change per period (%)")
    axes[0, 0].set_ylabel("error against the single pulse (%)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), title="ramp rate")
    scenario = next(iter(runs.values()))[1]
    man = scenario["manoeuvre"]
    change = next((k, v) for k, v in man.items() if k.startswith("change_"))
    fig.suptitle(
        "Error of the probing output against how fast the response moves, every settled "
        f"period\n({scenario['aircraft']['model']}: {man['hold']} reference ramped by "
        f"{change[1]:+g} {change[0].removeprefix('change_')} at each rate)"
    )
    return fig


def _snapshot(runs: dict[str, tuple[pd.DataFrame, dict]], tables: dict[str, pd.DataFrame]) -> Any:
    """One period in the middle of the fastest ramp (its worst) and the last."""
    channels = list(dict.fromkeys(next(iter(runs.values()))[0].channel))
    name = list(runs)[-1]
    table, scenario = runs[name]
    per = tables[name]
    settle = scenario["probe"]["settle_periods"]
    g0 = per[(per.channel == channels[0]) & (per.period >= settle)]
    worst = int(g0.loc[g0.error.idxmax(), "period"])
    last = int(per.period.max())
    probed = SURFACES[scenario["probe"].get("surface", DEFAULT_SURFACE)].unit  # h is per this
    fig, axes = plt.subplots(
        len(channels),
        2,
        figsize=(7, 2.2 * len(channels)),
        constrained_layout=True,
        squeeze=False,
    )
    for i, channel in enumerate(channels):
        for j, period in enumerate((worst, last)):
            g = table[(table.channel == channel) & (table.period == period)]
            ax = axes[i, j]
            ax.plot(g.lag_s, g.h_pulse, color="0.5", lw=2, label="single pulse, mid-period")
            ax.plot(g.lag_s, g.h_est, "--", color="C1", label="probing output")
            ax.set_title(f"{name}, period {period} ({g.time_mid_s.iloc[0]:.1f} s): {channel}")
            ax.set_xlabel("lag (s)")
            ax.set_ylabel(f"pulse response ({response_unit(channel, probed)})")
    axes[0, 0].legend()
    return fig


#: The figures, by the suffix of their file name (``manoeuvres_<suffix>``).
_FIGURES = {"periods": _periods, "rate": _rate_figure, "snapshot": _snapshot}


def figures(runs: dict[str, tuple[pd.DataFrame, dict]]) -> dict[str, Any]:
    """The figures, by the suffix of their file name: ``"periods"``, the manoeuvre, the
    response's peak and the error period by period, every run; ``"rate"``, the error against
    how fast the response moves; ``"snapshot"``, one period in the middle of the fastest
    ramp and the last.  Close them (or :func:`draw` them)."""
    tables = {name: period_table(t) for name, (t, _) in runs.items()}
    with plt.rc_context(RC):
        return {suffix: build(runs, tables) for suffix, build in _FIGURES.items()}


def draw(runs: dict[str, tuple[pd.DataFrame, dict]], figures: Path) -> list[Path]:
    """Save the :func:`figures` as ``<figures>/manoeuvres_<suffix>.png``."""
    tables = {name: period_table(t) for name, (t, _) in runs.items()}
    paths = []
    with plt.rc_context(RC):
        for suffix, build in _FIGURES.items():
            paths += save_figure(build(runs, tables), Path(figures) / f"manoeuvres_{suffix}")
    return paths
