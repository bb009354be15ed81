"""The monitoring study's scoring, on made-up flights whose alarms are known by construction."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from probing.analysis.monitoring import evaluate, false_alarm_rate, fault_table, load_study, roc
from probing.analysis.monitoring_plots import detection_figure, verdict_figure

T = 2.0  # period, s


def _flight(
    root: Path,
    sweep: str,
    pid: str,
    onset: float,
    alarms: dict[int, str],
    verdict: str = "none",
    n: int = 40,
) -> dict:
    """A flight's folder: periods 2..n-1, tested from 12 on; ``alarms``: period -> verdict;
    ``verdict``: the monitor's own for the flight.  The statistic is 2x the threshold where
    alarmed, 0.5x elsewhere."""
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
    first = (min(alarms) + 1) * T if alarms else None
    meta = {
        b"probing.detector": json.dumps({"verdict_periods": 3}).encode(),
        b"probing.first_alarm_s": json.dumps(first).encode(),
        b"probing.verdict": verdict.encode(),
    }
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
                "actuator",
            ),
            # a false alarm before the onset (15), then detected at period 28 (58 s): its
            # verdict was the false alarm's, so none for the fault
            _flight(
                tmp_path,
                "monitor-deadband",
                "d2",
                41.0,
                {15: "airframe", 28: "airframe", 29: "actuator"},
                "airframe",
            ),
            # detected at 23 (48 s) and called airframe
            _flight(tmp_path, "monitor-deadband", "d4", 41.0, {23: "airframe"}, "airframe"),
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


def test_the_first_false_alarm_rate_counts_each_flight_up_to_its_first(study):
    """h1 first alarms at period 20, its 9th tested (12..20); h2 never, in 28 periods; d2
    at 15, its 4th.  The flights without a fault: one first alarm in 9 + 28 periods."""
    s = study.set_index("point_id")
    assert s.loc["h1"].first_false_alarm and s.loc["h1"].hours_to_first == pytest.approx(
        9 * T / 3600
    )
    assert not s.loc["h2"].first_false_alarm
    assert s.loc["h2"].hours_to_first == pytest.approx(28 * T / 3600)
    assert s.loc["d2"].hours_to_first == pytest.approx(4 * T / 3600)
    healthy = study[study.fault == "none"]
    events, hours, _, _ = false_alarm_rate(healthy, first=True)
    assert (events, hours) == (1, pytest.approx(37 * T / 3600))


def test_delay_and_verdict_after_the_onset(study):
    s = study.set_index("point_id")
    assert s.loc["d1"].delay_s == pytest.approx(46.0 - 41.0)
    assert s.loc["d1"].delay_periods == pytest.approx(2.5)
    assert s.loc["d1"].verdict_after == "actuator"  # the monitor's, its first alarm after
    assert s.loc["d2"].delay_s == pytest.approx(58.0 - 41.0)
    assert s.loc["d2"].verdict_after == "none"  # the first alarm was a false one
    assert s.loc["d4"].verdict_after == "airframe"
    assert math.isnan(s.loc["d3"].delay_s) and s.loc["d3"].verdict_after == "none"


def test_fault_table_counts_and_goal(study):
    table = fault_table(study).set_index("fault").loc["dead band, a~/a = 0.8"]
    assert table.flights == 4
    assert table.p_detect == pytest.approx(3 / 4)
    assert table.p_detect_goal == pytest.approx(2 / 4)  # 5 T = 10 s: d1 (5 s), d4 (7 s)
    assert (table.actuator, table.airframe, table.none) == (1, 1, 2)
    assert table.verdict_right == pytest.approx(1 / 3)  # of the detected ones


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
    fa, p = roc(study, "deadband", "oracle", [1.0, 3.0])
    hours = study.healthy_h.sum()
    assert fa[0] == pytest.approx(3 / hours) and p[0] == pytest.approx(2 / 4)
    assert fa[1] == 0 and p[1] == 0  # nothing exceeds 3x the threshold


def test_figures_show_the_scored_flights(study):
    fig = detection_figure(study)
    line = fig.axes[0].get_lines()[0]  # dead band, oracle
    x, y = line.get_xdata(), line.get_ydata()
    assert y[np.searchsorted(x, 2.4)] == pytest.approx(0.0)
    assert y[np.searchsorted(x, 2.5)] == pytest.approx(1 / 4)  # d1 at 2.5 T
    assert y[np.searchsorted(x, 3.5)] == pytest.approx(2 / 4)  # d4 at 3.5 T
    assert y[np.searchsorted(x, 8.5)] == pytest.approx(3 / 4)  # d2 at 8.5 T
    assert y[-1] == pytest.approx(3 / 4)  # d3 never
    fig = verdict_figure(study)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert texts == ["1", "1", "2"]


def test_the_fault_figure_draws_the_monitored_channel_only(tmp_path):
    """probing.parquet holds the monitored output and the surface (an instrument): the
    before/after curves are the output's mean h_est over the four periods each side."""
    from probing.analysis.monitoring_plots import fault_figure

    flight = _flight(tmp_path, "monitor-deadband", "f1", 41.0, {22: "actuator"}, "actuator")
    folder = tmp_path / "monitor-deadband" / "points" / "point_id=f1"
    taps = np.arange(5)
    rows = []
    for period in range(2, 40):
        for channel, scale in (("theta_rad", 1.0), ("elevator_deg", 100.0)):
            h = scale * (taps + 1) * (0.5 if period > 20 else 1.0)
            rows.append(
                pd.DataFrame(
                    {
                        "channel": channel,
                        "period": period,
                        "tap": taps,
                        "lag_s": taps * 0.01,
                        "h_est": h,
                    }
                )
            )
    pd.concat(rows).to_parquet(folder / "probing.parquet")
    pd.DataFrame([flight]).to_parquet(tmp_path / "monitor-deadband" / "summary.parquet")
    flights = evaluate(load_study(tmp_path))
    fig = fault_figure(flights, "deadband")
    before, after = fig.axes[0].get_lines()[:2]
    np.testing.assert_allclose(before.get_ydata(), taps + 1)  # periods 16-19
    np.testing.assert_allclose(after.get_ydata(), 0.5 * (taps + 1))  # periods 21-24


def test_a_lateral_study_is_scored_per_probed_surface(tmp_path: Path):
    """Sweeps named after their probed surface (monitor-rudder-damage1) are scored per
    surface: the same flights under two probes give two rows, and the tables say which."""
    from probing.analysis.monitoring import summary_markdown

    for probe, detected in (("rudder", {24: "airframe"}), ("aileron", {})):
        sweep = f"monitor-{probe}-damage1"
        flights = [_flight(tmp_path, sweep, f"{probe[0]}1", 41.0, detected, "airframe")]
        flights.append(_flight(tmp_path, f"monitor-{probe}-none", f"{probe[0]}0", math.nan, {}))
        for name, rows in ((sweep, flights[:1]), (f"monitor-{probe}-none", flights[1:])):
            pd.DataFrame(rows).to_parquet(tmp_path / name / "summary.parquet")
    flights = evaluate(load_study(tmp_path))
    assert set(zip(flights.probe, flights.fault, strict=True)) == {
        ("rudder", "damage1"),
        ("rudder", "none"),
        ("aileron", "damage1"),
        ("aileron", "none"),
    }
    table = fault_table(flights).set_index("probe")
    assert table.loc["rudder", "fault"] == "case 1: rudder off"
    assert table.loc["rudder", "p_detect"] == 1.0 and table.loc["aileron", "p_detect"] == 0.0
    text = summary_markdown(flights)
    assert "| rudder | case 1: rudder off | oracle (upper bound: knows the gusts) | 1 |" in text
    assert "| aileron | oracle (upper bound: knows the gusts) | 2 |" in text  # per probe


@pytest.fixture
def on_the_edge(tmp_path: Path) -> pd.DataFrame:
    """Dead band flights with the onset at 40 s, the end of period 19 (T = 2 s, goal 5 T)."""
    flights = [
        # alarmed in period 19, which ends at the onset: a false alarm; then period 24, which
        # ends 5 T after the onset, at the edge of the goal
        _flight(
            tmp_path, "monitor-deadband", "e1", 40.0, {19: "airframe", 24: "actuator"}, "airframe"
        ),
        # first alarm in period 20, the first to end after the onset
        _flight(tmp_path, "monitor-deadband", "e2", 40.0, {20: "actuator"}, "actuator"),
        # first alarm in period 25, one period past the goal
        _flight(tmp_path, "monitor-deadband", "e3", 40.0, {25: "airframe"}, "airframe"),
    ]
    pd.DataFrame(flights).to_parquet(tmp_path / "monitor-deadband" / "summary.parquet")
    return evaluate(load_study(tmp_path))


def test_a_period_ending_at_the_onset_is_healthy(on_the_edge):
    """Period 19 ends at 40 s = the onset: it is healthy (monitored periods 12..19, 8 x T),
    its alarm a false one; the delay counts from the first alarm after it (period 24, 50 s)."""
    e1 = on_the_edge.set_index("point_id").loc["e1"]
    assert e1.healthy_h == pytest.approx(8 * T / 3600)
    assert e1.false_alarms == 1
    assert e1.delay_s == pytest.approx(50.0 - 40.0)
    e2 = on_the_edge.set_index("point_id").loc["e2"]
    assert e2.false_alarms == 0 and e2.delay_s == pytest.approx(42.0 - 40.0)


def test_a_first_alarm_at_the_onset_gives_no_verdict_for_the_fault(on_the_edge):
    """The monitor's first alarm at 40 s = the onset came before the fault could show: its
    verdict is not the fault's ("none"); a first alarm at 42 s, after it, gives the
    monitor's."""
    s = on_the_edge.set_index("point_id")
    assert s.loc["e1"].verdict_after == "none"
    assert s.loc["e2"].verdict_after == "actuator"
    assert s.loc["e3"].verdict_after == "airframe"


def test_the_goal_includes_the_period_ending_exactly_at_its_edge(on_the_edge):
    """Goal 5 T = 10 s after the onset: an alarm in the period ending at 50 s is within it
    (score = its statistic over threshold, 2; detected in the goal), one ending at 52 s is
    not (score of the unalarmed periods, 0.5)."""
    s = on_the_edge.set_index("point_id")
    assert s.loc["e1"].score == pytest.approx(2.0)
    assert s.loc["e2"].score == pytest.approx(2.0)
    assert s.loc["e3"].score == pytest.approx(0.5)
    table = fault_table(on_the_edge).set_index("fault").loc["dead band, a~/a = 0.8"]
    assert table.p_detect == pytest.approx(1.0)
    assert table.p_detect_goal == pytest.approx(2 / 3)  # delays 10 s and 2 s, not 12 s


def test_the_roc_counts_a_ratio_equal_to_its_factor_as_no_alarm(on_the_edge):
    """The monitor alarms on statistic > threshold: at c = 2, a ratio of exactly 2 is neither
    a false alarm nor a detection; at c = 1 the false alarm at the onset and two detections
    within the goal count."""
    fa, p = roc(on_the_edge, "deadband", "oracle", [1.0, 2.0])
    hours = on_the_edge.healthy_h.sum()
    assert fa[0] == pytest.approx(1 / hours) and p[0] == pytest.approx(2 / 3)
    assert fa[1] == 0 and p[1] == 0


def test_an_alarm_in_the_first_tested_period_is_an_event(tmp_path: Path):
    """A healthy flight alarmed in its first tested period (12) and again in 13: one event,
    counted although no tested period precedes it; 28 monitored periods."""
    flight = _flight(tmp_path, "monitor-none", "f1", math.nan, {12: "airframe", 13: "airframe"})
    pd.DataFrame([flight]).to_parquet(tmp_path / "monitor-none" / "summary.parquet")
    f1 = evaluate(load_study(tmp_path)).iloc[0]
    assert f1.false_alarms == 1 and f1.healthy_h == pytest.approx(28 * T / 3600)


def test_a_damaged_flight_file_is_one_line_naming_it_and_nothing_written(study, tmp_path, capsys):
    """probing plot monitor on a study with one damaged monitor.parquet: exit 2, one line on
    stderr naming the file, no summary and no figure written (it was pyarrow's traceback)."""
    from probing.cli import main

    damaged = tmp_path / "monitor-none" / "points" / "point_id=h2" / "monitor.parquet"
    damaged.write_bytes(b"not a parquet file")
    summary, figures = tmp_path / "out" / "summary.md", tmp_path / "figs"
    code = main(
        ["plot", "monitor", str(tmp_path), "--figures", str(figures), "--summary", str(summary)]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("probing: error: ") and str(damaged) in err
    assert not summary.exists() and not figures.exists()


def test_each_study_faults_right_verdict_is_its_types_class_in_the_registry():
    from probing.analysis.monitoring import FAULTS
    from probing.core.faults import FAULTS as REGISTRY

    truths = {key: fault.truth for key, fault in FAULTS.items()}
    damage = {f"damage{k}": "airframe" for k in range(1, 7)}
    actuator = ("deadband", "backlash", "rate-limit", "effectiveness-0.8", "effectiveness-0.5")
    assert truths == {
        "none": "none",
        **damage,
        **dict.fromkeys((*actuator, "stuck"), "actuator"),
        **dict.fromkeys(("sensor-bias", "sensor-scale", "sensor-stuck"), "sensor"),
    }
    for fault in FAULTS.values():
        if fault.fault_type != "none":
            assert fault.truth == REGISTRY[fault.fault_type].fault_class


def test_a_flight_whose_fault_type_is_not_its_sweeps_is_refused(tmp_path: Path):
    """The study fault's class comes from its [fault] type; the summary's own fault_type
    must agree with it (no flight is scored against another fault's verdict)."""
    rows = {
        "monitor-deadband": ("nonlinearity", 41.0, "d1"),
        "monitor-stuck": ("stuck", 41.0, "s1"),
        "monitor-none": ("none", math.nan, "h1"),
    }
    summaries = {}
    for sweep, (kind, onset, pid) in rows.items():
        summaries[sweep] = {**_flight(tmp_path, sweep, pid, onset, {}), "fault_type": kind}
        pd.DataFrame([summaries[sweep]]).to_parquet(tmp_path / sweep / "summary.parquet")
    assert sorted(load_study(tmp_path).fault) == ["deadband", "none", "stuck"]
    wrong = pd.DataFrame([{**summaries["monitor-stuck"], "fault_type": "effectiveness"}])
    wrong.to_parquet(tmp_path / "monitor-stuck" / "summary.parquet")
    with pytest.raises(ValueError, match="fault_type effectiveness in the sweep of stuck"):
        load_study(tmp_path)


def _two_detectors(root: Path, pid: str, onset: float, probing: set, trajectory: set) -> dict:
    """A flight whose monitor.parquet has a probing and a trajectory row per period (2..39,
    tested from 12), alarmed in the given periods; probe amplitude 0.02 deg."""
    folder = root / "monitor-deadband" / "points" / f"point_id={pid}"
    folder.mkdir(parents=True)
    periods = np.repeat(np.arange(2, 40), 2)
    detector = ["probing", "trajectory"] * (len(periods) // 2)
    alarm = np.array(
        [
            p in (probing if d == "probing" else trajectory)
            for p, d in zip(periods, detector, strict=True)
        ]
    )
    table = pa.table(
        {
            "period": periods.astype(np.int32),
            "time_s": (periods + 1) * T,
            "channel": ["theta_rad"] * len(periods),
            "detector": detector,
            "statistic": np.where(periods >= 12, np.where(alarm, 20.0, 5.0), np.nan),
            "threshold": np.full(len(periods), 10.0),
            "alarm": alarm,
            "gain_change": np.ones(len(periods)),
            "shape_change": np.zeros(len(periods)),
            "verdict": ["none"] * len(periods),
        }
    )
    found = sorted(p for p in probing | trajectory if (p + 1) * T > onset)
    meta = {
        b"probing.detector": json.dumps({"verdict_periods": 3}).encode(),
        b"probing.first_alarm_s": json.dumps((found[0] + 1) * T if found else None).encode(),
        b"probing.verdict": b"actuator",
    }
    pq.write_table(table.replace_schema_metadata(meta), folder / "monitor.parquet")
    return {
        "point_id": pid,
        "status": "done",
        "drift": "gust",
        "fault_onset_s": onset,
        "period_s": T,
        "disturbance.seed": 1,
        "probe.amplitude_deg": 0.02,
    }


def test_two_detectors_fold_per_period_and_each_keeps_its_own_delay(tmp_path):
    """A healthy period alarmed by both detectors is one false-alarm event; after the onset
    (41 s) the trajectory detector alarms at period 22 (46 s), the probing one at 24 (50 s):
    the flight's delay is the earlier, each detector keeps its own, and the detection is not
    the probe's."""
    rows = [
        _two_detectors(tmp_path, "a1", 41.0, {15, 24, 25}, {15, 22}),
        _two_detectors(tmp_path, "a2", 41.0, {23}, {30}),  # the probe's, at 48 s
    ]
    pd.DataFrame(rows).to_parquet(tmp_path / "monitor-deadband" / "summary.parquet")
    flights = evaluate(load_study(tmp_path)).set_index("point_id")
    a1 = flights.loc["a1"]
    assert a1.false_alarms == 1
    assert a1.false_alarms_probing == 1 and a1.false_alarms_trajectory == 1
    assert a1.delay_s == pytest.approx(46.0 - 41.0)
    assert a1.delay_trajectory_s == pytest.approx(46.0 - 41.0)
    assert a1.delay_probing_s == pytest.approx(50.0 - 41.0)
    table = fault_table(flights.reset_index())
    (row,) = table.to_dict("records")
    assert row["by_probing"] == pytest.approx(0.5) and row["amplitude_deg"] == 0.02


def test_the_amplitude_figure_plots_each_amplitudes_detection_within_the_goal(tmp_path):
    """Three amplitudes in light turbulence, detection within the goal 0, 1/2 and 1: the left
    line has those values, the right one the median delays, and the goal's star sits at the
    first amplitude that reaches 0.9; in moderate turbulence nothing is detected: no star,
    the median drawn at the top (three times the goal)."""
    from probing.analysis.monitoring_plots import amplitude_figure

    rows = []
    cases = {
        "light": {0.05: (9, 9), 0.1: (2, 9), 0.2: (1, 2)},
        "moderate": {0.05: (math.nan,) * 2, 0.1: (math.nan,) * 2, 0.2: (math.nan,) * 2},
    }
    for level, by_amp in cases.items():
        for i, (amp, delays) in enumerate(by_amp.items()):
            for j, d in enumerate(delays):
                rows.append(
                    {
                        "fault": "deadband",
                        "drift": "gust",
                        "turbulence": level,
                        "amplitude_deg": amp,
                        "delay_periods": float(d),
                        "point_id": f"{level}{i}{j}",
                    }
                )
    fig = amplitude_figure(pd.DataFrame(rows))
    left, right = fig.axes[0], fig.axes[1]
    (line,) = [ln for ln in left.get_lines() if ln.get_label() == "gust, light"]
    assert list(line.get_xdata()) == [0.05, 0.1, 0.2]
    assert list(line.get_ydata()) == [0.0, 0.5, 1.0]
    stars = [ln for ln in left.get_lines() if ln.get_marker() == "*"]
    assert len(stars) == 1 and list(stars[0].get_xdata()) == [0.2]
    medians = [list(ln.get_ydata()) for ln in right.get_lines() if ln.get_marker() == "o"]
    assert medians == [[9.0, 5.5, 1.5], [15.0, 15.0, 15.0]]


def test_the_threshold_law_counts_periods_over_the_check_rates_threshold(tmp_path):
    """Flights without a fault: each tested period whose statistic is strictly over
    -log10 of the check rate's probability per period counts (one on the edge does not),
    against the tested periods times that probability; the table says so per detector."""
    from probing.analysis.monitoring import CHECK_RATE_PER_HOUR, summary_markdown

    row = _flight(tmp_path, "monitor-none", "h1", math.nan, {})
    path = tmp_path / "monitor-none" / "points" / "point_id=h1" / "monitor.parquet"
    table = pq.read_table(path)
    alpha = CHECK_RATE_PER_HOUR * T / 3600.0  # one channel
    edge = -math.log10(alpha)
    stat = table.column("statistic").to_numpy(zero_copy_only=False).copy()
    tested = np.flatnonzero(np.isfinite(stat))  # 28 periods
    stat[tested] = edge - 0.5
    stat[tested[:3]] = np.nextafter(edge, math.inf)  # just over
    stat[tested[3]] = edge  # on the edge: not over
    meta = table.schema.metadata
    table = table.set_column(3, "statistic", pa.array(stat))
    pq.write_table(table.replace_schema_metadata(meta), path)
    pd.DataFrame([row]).to_parquet(tmp_path / "monitor-none" / "summary.parquet")
    flights = evaluate(load_study(tmp_path))
    f = flights.iloc[0]
    assert f.alpha_check == pytest.approx(alpha)
    assert (f.tested_probing, f.over_check_probing) == (28, 3)
    text = summary_markdown(flights)
    promised = 28 * alpha
    assert f"| oracle (upper bound: knows the gusts) | probing | 28 | 3 | {promised:.1f} |" in text


def test_the_threshold_laws_false_alarm_budget_is_shared_by_the_monitored_channels(tmp_path):
    """Two monitored channels share the check rate: each period and channel gets half the
    one-channel probability, so its threshold is log10(2) higher.  Statistics between the
    one-channel and the two-channel thresholds are not over; those above both are; the
    promise over the 2 x 28 tested rows is that of 28 periods at the one-channel rate."""
    from probing.analysis.monitoring import CHECK_RATE_PER_HOUR

    row = _flight(tmp_path, "monitor-none", "h1", math.nan, {})
    path = tmp_path / "monitor-none" / "points" / "point_id=h1" / "monitor.parquet"
    table = pq.read_table(path)
    theta = table.to_pandas()
    both = pd.concat([theta, theta.assign(channel="q_rad_s")], ignore_index=True)
    one = CHECK_RATE_PER_HOUR * T / 3600.0  # the probability of one channel alone
    shared = one / 2
    edge_one, edge_shared = -math.log10(one), -math.log10(shared)
    tested = np.flatnonzero(both.statistic.notna())  # 2 x 28 rows
    both.loc[tested, "statistic"] = edge_one - 0.5
    both.loc[tested[:4], "statistic"] = (edge_one + edge_shared) / 2  # over one's, not shared
    both.loc[tested[-2:], "statistic"] = edge_shared + 0.1  # over both
    out = pa.Table.from_pandas(both, schema=table.schema, preserve_index=False)
    pq.write_table(out.replace_schema_metadata(table.schema.metadata), path)
    pd.DataFrame([row]).to_parquet(tmp_path / "monitor-none" / "summary.parquet")
    f = evaluate(load_study(tmp_path)).iloc[0]
    assert f.alpha_check == pytest.approx(shared)
    assert (f.tested_probing, f.over_check_probing) == (56, 2)
    assert f.tested_probing * f.alpha_check == pytest.approx(28 * one)


def test_a_verdict_is_right_when_it_is_the_faults_class():
    """Each class only by its own verdict: a sensor fault called none (the trajectory
    detector alone) or actuator is wrong, as an airframe change called actuator is."""
    from probing.analysis.monitoring import _right

    verdicts = pd.Series(["actuator", "airframe", "sensor", "none"])
    assert list(_right(verdicts, "sensor")) == [False, False, True, False]
    assert list(_right(verdicts, "airframe")) == [False, True, False, False]
    assert list(_right(verdicts, "actuator")) == [True, False, False, False]


@pytest.mark.parametrize(
    ("sweep", "fault"),
    [
        ("monitor-none", "none"),
        ("monitor-none-gust", "none"),
        ("monitor-none-bounds", "none"),
        ("monitor-damage5", "damage5"),
        ("monitor-sensor-bias", "sensor-bias"),
        ("monitor-rate-limit", "rate-limit"),
        ("monitor-aileron-damage1", "damage1"),
    ],
)
def test_a_sweep_names_its_fault_with_a_suffix_telling_sweeps_apart(sweep, fault):
    from probing.analysis.monitoring import _fault_key

    assert _fault_key(sweep, pd.Series(dtype=object)) == fault


@pytest.mark.parametrize("sweep", ["monitor-effectiveness", "monitor-effectiveness-chirp"])
def test_effectiveness_is_told_by_its_scale_with_or_without_a_suffix(sweep):
    from probing.analysis.monitoring import _fault_key

    assert _fault_key(sweep, pd.Series({"fault.scale": 0.8})) == "effectiveness-0.8"


def test_the_threshold_law_stops_at_the_detectors_first_alarm(study):
    """h1 alarms first at period 20: its law counts the tested periods 12..20 (the baseline
    freezes there), all over the check's threshold (statistics 5 and 20 > 2.56)."""
    h1 = study.set_index("point_id").loc["h1"]
    assert (h1.tested_probing, h1.over_check_probing) == (9, 9)
    h2 = study.set_index("point_id").loc["h2"]
    assert h2.tested_probing == 28


def test_the_cost_of_the_thresholds_is_the_first_period_after_the_onset_over_the_laxer_one(
    tmp_path,
):
    """The delay at COST_RATE_PER_HOUR: the first period after the onset whose statistic is
    strictly over -log10 of that rate's probability per period (one on the edge is not;
    one over it before the onset is a false alarm, not a detection), while the flight's own
    delay is at its own threshold; the summary's cost table shows both."""
    from probing.analysis.monitoring import COST_RATE_PER_HOUR, summary_markdown

    onset = 15 * T + 0.5  # in period 15, which ends at 16 T
    row = _flight(tmp_path, "monitor-stuck", "s1", onset, {18: "actuator"}, "actuator")
    path = tmp_path / "monitor-stuck" / "points" / "point_id=s1" / "monitor.parquet"
    table = pq.read_table(path)
    lax = -math.log10(COST_RATE_PER_HOUR * T / 3600.0)  # one channel
    stat = table.column("statistic").to_numpy(zero_copy_only=False).copy()
    periods = table.column("period").to_numpy()
    tested = np.isfinite(stat)
    stat[tested & (periods != 18)] = 1.0  # under both thresholds
    stat[periods == 13] = lax + 1.0  # before the onset
    stat[periods == 15] = lax  # the onset's period, on the edge: not over
    stat[periods == 16] = np.nextafter(lax, math.inf)  # just over
    probing = table.to_pandas().assign(statistic=stat, detector="probing")
    # the trajectory detector's rows: over the laxer threshold from period 17 on
    trajectory = probing.assign(
        detector="trajectory", statistic=np.where(tested & (periods >= 17), lax + 1.0, 1.0)
    )
    trajectory.loc[~tested, "statistic"] = math.nan
    both = pd.concat([probing, trajectory], ignore_index=True)
    pq.write_table(
        pa.Table.from_pandas(both, preserve_index=False).replace_schema_metadata(
            table.schema.metadata
        ),
        path,
    )
    pd.DataFrame([row]).to_parquet(tmp_path / "monitor-stuck" / "summary.parquet")
    f = evaluate(load_study(tmp_path)).iloc[0]
    assert f.delay_s == pytest.approx(19 * T - onset)  # the study's threshold: period 18
    assert f.delay_cost_probing_s == pytest.approx(17 * T - onset)  # the laxer: period 16
    assert f.delay_cost_trajectory_s == pytest.approx(18 * T - onset)  # period 17
    assert f.delay_cost_s == pytest.approx(17 * T - onset)  # the earlier of the two
    text = summary_markdown(evaluate(load_study(tmp_path)))
    cost_T, own_T = (17 * T - onset) / T, (19 * T - onset) / T
    assert f"| 1.00 | 1.00 | {own_T:.1f} | {cost_T:.1f} |" in text


def test_the_verdict_figure_has_a_sensor_column_where_a_sensor_fault_was_flown(tmp_path):
    """A study with a sensor fault: the figure's columns are actuator, airframe, sensor and
    none, the sensor fault's count under sensor, in bold; without one there is no such
    column (test_figures_show_the_scored_flights)."""
    rows = [
        _flight(tmp_path, "monitor-sensor-bias", "b1", 41.0, {22: "sensor"}, "sensor"),
        _flight(tmp_path, "monitor-sensor-bias", "b2", 41.0, {22: "sensor"}, "sensor"),
        _flight(tmp_path, "monitor-sensor-bias", "b3", 41.0, {22: "actuator"}, "actuator"),
    ]
    pd.DataFrame(rows).to_parquet(tmp_path / "monitor-sensor-bias" / "summary.parquet")
    fig = verdict_figure(evaluate(load_study(tmp_path)))
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == [
        "actuator",
        "airframe",
        "sensor",
        "none",
    ]
    texts = ax.texts
    assert [t.get_text() for t in texts] == ["1", "0", "2", "0"]
    assert [t.get_fontweight() for t in texts][2] == "bold"


def test_the_threshold_law_names_the_probe_where_a_study_has_several(tmp_path):
    """Two probed surfaces, one healthy flight each: the threshold law's rows say which
    probe they are (else the two would read alike)."""
    from probing.analysis.monitoring import summary_markdown

    for sweep in ("monitor-aileron-none", "monitor-rudder-none"):
        row = _flight(tmp_path, sweep, "h1", math.nan, {})
        pd.DataFrame([row]).to_parquet(tmp_path / sweep / "summary.parquet")
    text = summary_markdown(evaluate(load_study(tmp_path)))
    for probe in ("aileron", "rudder"):
        assert f"| {probe} probe, oracle (upper bound: knows the gusts) | probing | 28 |" in text


def _probing_table(folder: Path, onset_period: int) -> None:
    """A probing.parquet whose pulse response halves after ``onset_period``."""
    taps = np.arange(64)
    shape = np.exp(-taps / 10.0) * np.sin(taps / 3.0)
    rows = [
        pd.DataFrame(
            {
                "channel": "theta_rad",
                "period": period,
                "tap": taps,
                "lag_s": taps * 0.04,
                "h_est": shape * (0.5 if period > onset_period else 1.0),
            }
        )
        for period in range(2, 40)
    ]
    pd.concat(rows).to_parquet(folder / "probing.parquet")


@pytest.fixture
def crowded(tmp_path: Path) -> pd.DataFrame:
    """Three faults under two references, six flights each, detected 1 to 12 periods after
    the onset (41 s) or never, so that the curves fill the figures; the dead band's first
    seed under the gust reference is never detected, its statistic scattered from 0.01 to
    8; healthy flights with false alarms."""
    onset = 41.0
    for f, fault in enumerate(("deadband", "stuck", "damage5")):
        rows = []
        verdict = "airframe" if fault == "damage5" else "actuator"
        for d, drift in enumerate(("gust", "detrend")):
            delays = [None if fault == "deadband" else 1 + f, 2 + f + d, 3 + 2 * f, 5 + d]
            delays += [8 + f, 12 + d] if f else [None, None]  # the dead band's: half by 12 T
            for seed, k in enumerate(delays, start=1):
                alarms = {} if k is None else {20 + k: verdict, 21 + k: verdict}
                pid = f"{fault[:2]}{d}{seed}"
                row = _flight(tmp_path, f"monitor-{fault}", pid, onset, alarms, verdict)
                rows.append({**row, "drift": drift})
        pd.DataFrame(rows).to_parquet(tmp_path / f"monitor-{fault}" / "summary.parquet")
    folder = tmp_path / "monitor-deadband" / "points" / "point_id=de01"
    _probing_table(folder, 20)
    # its statistic scattered over the whole axis, under the threshold (10), as flown
    table = pq.read_table(folder / "monitor.parquet")
    spread = 10 ** np.random.default_rng(1).uniform(-2.0, 0.9, table.num_rows)
    spread[~np.isfinite(table["statistic"].to_numpy(zero_copy_only=False))] = np.nan
    table = table.set_column(table.schema.get_field_index("statistic"), "statistic", [spread])
    pq.write_table(table, folder / "monitor.parquet")
    rows = []
    for d, drift in enumerate(("gust", "detrend")):
        for seed, alarms in enumerate(({}, {15: "airframe"}, {30: "actuator", 33: "none"}), 1):
            row = _flight(tmp_path, "monitor-none", f"h{d}{seed}", math.nan, alarms)
            rows.append({**row, "drift": drift})
    pd.DataFrame(rows).to_parquet(tmp_path / "monitor-none" / "summary.parquet")
    return evaluate(load_study(tmp_path))


@pytest.mark.parametrize("name", ["detection_figure", "roc_figure", "verdict_figure"])
def test_the_study_figures_hide_no_curve_and_read_on_every_cell(crowded, name):
    """The detection and ROC figures' legends lay over their curves (loc="center right",
    "lower right"); the verdict figure's counts were black on navy cells: now each legend
    is beside its panels, each count in the colour that reads on its cell, every curve named
    by a legend (faults by colour, references by line style, the dot of c = 1)."""
    from probing.analysis import monitoring_plots
    from probing.analysis.figure_checks import figure_problems

    fig = getattr(monitoring_plots, name)(crowded)
    assert figure_problems(fig) == []
    plt.close(fig)


def test_the_panels_name_the_references_the_flights_have(study):
    """Flights stored when the oracle was called "reference": the panels say oracle (the
    oracle study's said "drift = reference" and "nominal twin")."""
    from probing.analysis.figure_checks import figure_problems
    from probing.analysis.monitoring_plots import roc_figure

    for draw in (roc_figure, verdict_figure):
        fig = draw(study)
        (title,) = [ax.get_title() for ax in fig.axes if ax.get_title()]
        assert "reference: oracle" in title and figure_problems(fig) == []
        plt.close(fig)
    fig = detection_figure(study)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["dead band, a~/a = 0.8", "reference: oracle (upper bound: knows the gusts)"]
    plt.close(fig)


def test_the_fault_figure_says_when_no_alarm_came_and_hides_no_curve(crowded):
    """The dead band's first flight under the gust reference was never detected: the title
    says so (it said "first alarm nan s after the onset") and names the reference; the
    legends lie above the curves, every curve named, the response's unit on its axis."""
    from probing.analysis.figure_checks import figure_problems
    from probing.analysis.monitoring_plots import fault_figure

    fig = fault_figure(crowded, "deadband")
    assert fig.axes[1].get_title() == "seed 1, gust reference: no alarm after onset"
    assert figure_problems(fig) == []
    assert fig.axes[0].get_ylabel() == "h_est of theta_rad (rad per deg)"
    plt.close(fig)


def test_the_amplitude_figure_legend_hides_no_curve():
    """Nine lines (three references, three turbulence levels) rising from 0 to 1 across the
    amplitudes, their delays falling from the top: the legend, which lay in the first
    panel's upper left over the lines, is under the panels, with the goal's star."""
    from probing.analysis.figure_checks import figure_problems
    from probing.analysis.monitoring_plots import amplitude_figure

    rows = []
    amplitudes = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
    for d, drift in enumerate(("gust", "oracle", "detrend")):
        for t, level in enumerate(("none", "light", "moderate")):
            for a, amp in enumerate(amplitudes):
                detected = min(max(a - 1 - (d + t) // 2, 0), 4)  # of 4 flights
                for seed in range(4):
                    delay = 1.0 + 6.0 / (a + 1) if seed < detected else math.nan
                    rows.append(
                        {
                            "fault": "deadband",
                            "drift": drift,
                            "turbulence": level,
                            "amplitude_deg": amp,
                            "delay_periods": delay,
                            "point_id": f"{d}{t}{a}{seed}",
                        }
                    )
    fig = amplitude_figure(pd.DataFrame(rows))
    assert figure_problems(fig) == []
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[-1] == "where a line first reaches the goal" and len(labels) == 10
    plt.close(fig)
