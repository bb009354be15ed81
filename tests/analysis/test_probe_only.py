"""What only the probe sees (probing.analysis.probe_only): each detector's detection within
the goal, the probe-only share and the delay saved, counted by hand on made-up flights."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pandas as pd
import pytest

from probing.analysis.figure_checks import figure_problems
from probing.analysis.probe_only import probe_only_figure, probe_only_markdown, probe_only_table

PERIOD_S = 2.0  # the dead band's goal: 5 periods, 10 s; the damage case's: 3 periods, 6 s


def _flights(rows: list[tuple]) -> pd.DataFrame:
    columns = ["fault", "drift", "turbulence", "amplitude_deg", "delay_probing_s",
               "delay_trajectory_s"]  # fmt: skip
    frame = pd.DataFrame(rows, columns=columns)
    return frame.assign(period_s=PERIOD_S)


STUDY = _flights(
    [
        # the dead band at 1 deg: the probe within 10 s in all three, the trajectory in one
        ("deadband", "gust", "light", 1.0, 4.0, 12.0),
        ("deadband", "gust", "light", 1.0, 10.0, np.nan),  # the goal's last instant: in
        ("deadband", "gust", "light", 1.0, 6.0, 8.0),
        # case 5: the trajectory first in two, the probe in one; 6.0 s is in, 6.01 s not
        ("damage5", "gust", "light", 0.2, 2.0, 1.0),
        ("damage5", "gust", "light", 0.2, 6.01, 3.0),
        ("damage5", "gust", "light", 0.2, 3.0, 6.0),
        # another reference, and a flight without a fault: not counted
        ("deadband", "oracle", "light", 1.0, 1.0, np.nan),
        ("none", "gust", "light", 1.0, np.nan, np.nan),
    ]
)


def test_each_detector_the_probe_only_share_and_the_delay_saved():
    table = probe_only_table(STUDY).set_index("fault")
    assert list(table.index) == ["deadband", "damage5"]
    band, case5 = table.loc["deadband"], table.loc["damage5"]
    assert band.flights == 3 and case5.flights == 3
    assert band.p_probing == 1.0 and band.p_trajectory == pytest.approx(1 / 3)
    assert band.probe_only == pytest.approx(2 / 3)  # 12 s is past the goal: the first too
    assert band.saved_median_s == 8.0  # 12 - 4, inf, 8 - 6: the median of (8, inf, 2)
    assert band.saved_median_T == 4.0
    assert case5.p_probing == pytest.approx(2 / 3) and case5.p_trajectory == 1.0
    assert case5.probe_only == 0.0
    assert case5.saved_median_s == pytest.approx(1.0)  # (1 - 2, 6 - 3): median 1


def test_the_oracle_is_its_own_table():
    table = probe_only_table(STUDY, drift="oracle")
    assert len(table) == 1 and table.iloc[0].probe_only == 1.0
    assert math.isinf(table.iloc[0].saved_median_s)


def test_the_section_and_the_figure():
    text = probe_only_markdown(STUDY)
    assert "## What only the probe sees (gust reference)" in text
    assert "| dead band, a~/a = 0.8 | light | 1 | 3 | 0.9 within 5 T | 1.00 | 0.33 | 0.67 |" in text
    assert "never" not in text.split("dead band")[1].split("\n")[0]
    assert probe_only_markdown(STUDY[STUDY.drift == "detrend"]) == ""
    fig = probe_only_figure(STUDY)
    assert isinstance(fig, matplotlib.figure.Figure)
    assert figure_problems(fig) == []
    bars = fig.axes[0].patches
    assert len(bars) == 3 * 2  # probing, trajectory and probe-only bars of each fault
