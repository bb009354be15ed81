"""The figure of one monitored flight, from its ``monitor.parquet`` alone: each detector's
statistic period by period against its threshold, the first alarm and the fault's onset
(:meth:`probing.Flight.plot_monitor`)."""

from __future__ import annotations

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
    channels, against its threshold; the first alarm and the fault's onset marked.

    Parameters
    ----------
    monitor : pandas.DataFrame
        A ``monitor.parquet`` (period, time_s, channel, detector, statistic, threshold).
    first_alarm_s : float or None
        The end of the first alarmed period, s after the trim (None: no alarm).
    verdict : str or None
        The flight's verdict, for the title.
    onset_s : float, optional
        The fault's onset, s after the trim (simulation knows it; drawn for the reader).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = detached_figure(figsize=(6.0, 3.2), layout="constrained")  # before the context
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
                linestyle=":",
                label=f"{detector} threshold",
            )
        if onset_s is not None:
            onset = "fault onset (simulated)"
            ax.axvline(onset_s, color="0.3", linestyle="--", linewidth=1, label=onset)
        if first_alarm_s is not None:
            ax.axvline(first_alarm_s, color="C3", linewidth=1.5, label="first alarm")
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("time after trim (s)")
        ax.set_ylabel("-log10 p of no change\n(largest over the channels)")
        when = "no alarm" if first_alarm_s is None else f"first alarm {first_alarm_s:.2f} s"
        ax.set_title(f"{when}; verdict: {verdict}", loc="left")
        ax.legend(fontsize="small", ncols=2, loc="upper left")
        ax.set_xlim(left=0.0)
    return fig
