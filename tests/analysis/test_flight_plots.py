"""The figure of one monitored flight (:meth:`probing.Flight.plot_monitor`), drawn from a
made-up ``monitor.parquet``: no simulation."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from probing.analysis.figure_checks import figure_problems, hidden_lines
from probing.analysis.flight_plots import monitor_figure


def _monitor(onset_s: float) -> pd.DataFrame:
    """Two detectors on two channels over 300 s, periods of 2.55 s; their statistics
    scatter under the thresholds (4.7 and 5) and rise twentyfold after ``onset_s``."""
    time_s = np.arange(1, 120) * 2.55
    rng = np.random.default_rng(0)
    rows = []
    for detector, threshold in (("probing", 4.7), ("trajectory", 5.0)):
        for channel in ("theta_rad", "q_rad_s"):
            statistic = 10 ** rng.uniform(-2.0, 0.5, time_s.size)
            statistic[time_s > onset_s] *= 20.0
            rows.append(
                pd.DataFrame(
                    {
                        "period": np.arange(time_s.size),
                        "time_s": time_s,
                        "channel": channel,
                        "detector": detector,
                        "statistic": statistic,
                        "threshold": threshold,
                    }
                )
            )
    return pd.concat(rows, ignore_index=True)


def test_the_onset_and_a_first_alarm_a_moment_later_both_show() -> None:
    """Onset 160 s, first alarm 160.65 s: two pixels apart on the saved figure.  The alarm's
    line covered two thirds of the onset's; now each keeps most of its pixels, each has its
    legend entry with its time, and the legend lies under the panel (it lay over the
    curves)."""
    fig = monitor_figure(_monitor(160.0), 160.65, "actuator", 160.0)
    assert hidden_lines(fig) == []
    assert figure_problems(fig) == []
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "first alarm, 160.65 s" in labels and "fault onset (simulated), 160.00 s" in labels
    onset, alarm = (
        next(ln for ln in fig.axes[0].get_lines() if ln.get_label() == label)
        for label in ("fault onset (simulated), 160.00 s", "first alarm, 160.65 s")
    )
    assert onset.get_linestyle() != alarm.get_linestyle() and onset.get_color() != alarm.get_color()
    plt.close(fig)


@pytest.mark.parametrize("first_alarm_s", [None, math.nan])
def test_a_flight_without_an_alarm_says_so(first_alarm_s: float | None) -> None:
    """No first alarm (None, or NaN from a table): the title says "no alarm", no number
    that is not one, and no alarm is drawn."""
    fig = monitor_figure(_monitor(1e9), first_alarm_s, "none", None)
    assert fig.axes[0].get_title(loc="left") == "no alarm; verdict: none"
    assert figure_problems(fig) == []
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert not any("alarm" in label for label in labels)
    plt.close(fig)
