"""The monitoring study's scoring, on made-up flights whose alarms are known by construction."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from analysis.monitoring import evaluate, false_alarm_rate, fault_table, load_study, roc
from analysis.monitoring_plots import detection_figure, verdict_figure

T = 2.0  # period, s


def _flight(
    root: Path, sweep: str, pid: str, onset: float, alarms: dict[int, str], n: int = 40
) -> dict:
    """A flight's folder: periods 2..n-1, tested from 12 on; ``alarms``: period -> verdict.
    The statistic is 2x the threshold where alarmed, 0.5x elsewhere."""
    folder = root / sweep / "points" / f"point_id={pid}"
    folder.mkdir(parents=True)
    periods = np.arange(2, n)
    tested = periods >= 12
    alarm = np.array([p in alarms for p in periods])
    stat = np.where(alarm, 20.0, 5.0)
    table = pa.table(
        {
            "period": periods.astype(np.int32),
            "time_s": (periods + 1) * T,
            "channel": ["theta_rad"] * len(periods),
            "statistic": np.where(tested, stat, np.nan),
            "threshold": np.full(len(periods), 10.0),
            "alarm": alarm,
            "gain_change": np.ones(len(periods)),
            "shape_change": np.zeros(len(periods)),
            "verdict": [alarms.get(p, "none") for p in periods],
        }
    )
    meta = {b"probing.detector": json.dumps({"verdict_periods": 3}).encode()}
    pq.write_table(table.replace_schema_metadata(meta), folder / "monitor.parquet")
    return {
        "point_id": pid,
        "status": "done",
        "drift": "reference",
        "fault_onset_s": onset,
        "period_s": T,
        "disturbance.seed": int(pid[-1]),
    }


@pytest.fixture
def study(tmp_path: Path) -> pd.DataFrame:
    rows = {
        "monitor-none": [
            # two false-alarm events (periods 20-21 and 30), healthy from 12 to 39
            _flight(
                tmp_path,
                "monitor-none",
                "h1",
                math.nan,
                {20: "actuator", 21: "actuator", 30: "airframe"},
            ),
            _flight(tmp_path, "monitor-none", "h2", math.nan, {}),
        ],
        "monitor-deadband": [
            # onset 41 s (period 20 runs 40-42 s): first alarm at the end of period 22 (46 s)
            _flight(
                tmp_path,
                "monitor-deadband",
                "d1",
                41.0,
                {22: "actuator", 23: "actuator", 24: "airframe"},
            ),
            # a false alarm before the onset (15), then detected at period 28 (58 s)
            _flight(
                tmp_path,
                "monitor-deadband",
                "d2",
                41.0,
                {15: "airframe", 28: "airframe", 29: "actuator"},
            ),
            _flight(tmp_path, "monitor-deadband", "d3", 41.0, {}),  # never detected
        ],
    }
    for sweep, flights in rows.items():
        pd.DataFrame(flights).to_parquet(tmp_path / sweep / "summary.parquet")
    return evaluate(load_study(tmp_path))


def test_false_alarms_are_events_in_healthy_monitored_periods(study):
    h1 = study.set_index("point_id").loc["h1"]
    assert h1.false_alarms == 2 and h1.healthy_h == pytest.approx(28 * T / 3600)
    d2 = study.set_index("point_id").loc["d2"]
    # tested periods 12..19 end by 40 s <= 41 s: healthy; the alarm at 15 is one event
    assert d2.false_alarms == 1 and d2.healthy_h == pytest.approx(8 * T / 3600)


def test_delay_and_verdict_after_the_onset(study):
    s = study.set_index("point_id")
    assert s.loc["d1"].delay_s == pytest.approx(46.0 - 41.0)
    assert s.loc["d1"].delay_periods == pytest.approx(2.5)
    assert s.loc["d1"].verdict_after == "actuator"  # 2 of the first 3
    assert s.loc["d2"].delay_s == pytest.approx(58.0 - 41.0)
    assert s.loc["d2"].verdict_after == "airframe"  # tie of 1 and 1: airframe
    assert math.isnan(s.loc["d3"].delay_s) and s.loc["d3"].verdict_after == "none"


def test_fault_table_counts_and_goal(study):
    table = fault_table(study).set_index("fault").loc["dead band, a~/a = 0.8"]
    assert table.flights == 3
    assert table.p_detect == pytest.approx(2 / 3)
    assert table.p_detect_goal == pytest.approx(1 / 3)  # 5 T = 10 s: only d1 (5 s)
    assert (table.actuator, table.airframe, table.none) == (1, 1, 1)
    assert table.verdict_right == pytest.approx(0.5)  # of the detected ones


def test_false_alarm_rate_has_poissons_exact_interval(study):
    none = study[study.fault == "none"]
    events, hours, low, high = false_alarm_rate(none)
    assert events == 2 and hours == pytest.approx(56 * T / 3600)
    # Poisson, 2 events: 95 % interval 0.2422 .. 7.2247 events (Garwood)
    assert low * hours == pytest.approx(0.2422, abs=1e-3)
    assert high * hours == pytest.approx(7.2247, abs=1e-3)
    zero = false_alarm_rate(study[study.point_id == "h2"])
    assert zero[0] == 0 and zero[2] == 0 and zero[3] * zero[1] == pytest.approx(3.6889, abs=1e-3)


def test_roc_at_factor_one_is_the_monitors_own_operating_point(study):
    fa, p = roc(study, "deadband", "reference", [1.0, 3.0])
    hours = study.healthy_h.sum()
    assert fa[0] == pytest.approx(3 / hours) and p[0] == pytest.approx(1 / 3)
    assert fa[1] == 0 and p[1] == 0  # nothing exceeds 3x the threshold


def test_figures_show_the_scored_flights(study):
    fig = detection_figure(study)
    line = fig.axes[0].get_lines()[0]  # dead band, reference
    x, y = line.get_xdata(), line.get_ydata()
    assert y[np.searchsorted(x, 2.4)] == pytest.approx(0.0)
    assert y[np.searchsorted(x, 2.5)] == pytest.approx(1 / 3)  # d1 at 2.5 T
    assert y[np.searchsorted(x, 8.5)] == pytest.approx(2 / 3)  # d2 at 8.5 T
    assert y[-1] == pytest.approx(2 / 3)  # d3 never
    fig = verdict_figure(study)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert texts == ["1", "1", "1"]
