"""The figure of one monitored flight, from its ``monitor.parquet`` alone: each detector's
statistic period by period against its threshold, the first alarm and the fault's onset
(:meth:`probing.Flight.plot_monitor`)."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import pandas as pd
from matplotlib.figure import Figure

from probing.analysis.figures import RC, detached_figure
from probing.core.isolation import DETECTORS

__all__ = ["monitor_figure"]


def monitor_figure(
    monitor: pd.DataFrame,
    first_alarm_s: float | None,
    verdict: str | None,
    onset_s: float | None = None,
) -> Figure:
    """Each detector's statistic (-log10 p of no change) per period, the largest over the
    channels, against its threshold; the first alarm and the fault's onset marked, both
    visible however close (the alarm a pale band, the onset a dashed line over it), the
    legend under the panel.

    Parameters
    ----------
    monitor : pandas.DataFrame
        A ``monitor.parquet`` (period, time_s, channel, detector, statistic, threshold).
    first_alarm_s : float or None
        The end of the first alarmed period, s after the trim (None or NaN: no alarm).
    verdict : str or None
        The flight's verdict, for the title.
    onset_s : float, optional
        The fault's onset, s after the trim (simulation knows it; drawn for the reader).

    Returns
    -------
    matplotlib.figure.Figure
    """
    alarmed = first_alarm_s is not None and math.isfinite(first_alarm_s)
    fig = detached_figure(figsize=(6.0, 3.6), layout="constrained")  # before the context
    with plt.rc_context(RC):  # (analyze_plots.bounds_figure says why)
        ax = fig.subplots()
        alarming = monitor[monitor.detector.isin(DETECTORS)]  # not the isolation checks
        for k, (detector, rows) in enumerate(alarming.groupby("detector", sort=False)):
            worst = rows.groupby("time_s")[["statistic", "threshold"]].max().reset_index()
            ax.plot(worst["time_s"], worst["statistic"], color=f"C{k}", label=f"{detector}")
            ax.plot(
                worst["time_s"],
                worst["threshold"],
                color=f"C{k}",
                linestyle=(k * 2.0, (2.0, 2.0)),  # short dashes, each threshold's offset
                label=f"{detector} threshold",
            )
        # The onset and the first alarm can be a fraction of a second apart, less than a
        # line's width: the alarm is a wide pale band under the curves, the onset a thin
        # dark dashed line over them; the legend gives both times.
        if alarmed:
            ax.axvline(
                first_alarm_s,
                color="C3",
                alpha=0.35,
                linewidth=5,
                zorder=1.6,
                label=f"first alarm, {first_alarm_s:.2f} s",
            )
        if onset_s is not None:
            ax.axvline(
                onset_s,
                color="0.1",
                linestyle="--",
                linewidth=0.9,
                zorder=3,
                label=f"fault onset (simulated), {onset_s:.2f} s",
            )
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("time after trim (s)")
        ax.set_ylabel("-log10 p of no change\n(largest over the channels)")
        when = f"first alarm {first_alarm_s:.2f} s" if alarmed else "no alarm"
        ax.set_title(f"{when}; verdict: {verdict if verdict is not None else 'none'}", loc="left")
        fig.legend(fontsize="small", ncols=3, loc="outside lower center", frameon=False)
        ax.set_xlim(left=0.0)
    return fig
