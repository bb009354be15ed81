"""The isolation checks on the study's flight (GTM, NASA's T2 sensors on which the autopilot
flies, light turbulence, the gust reference): each fault class gets its verdict, the checks'
rows are in ``monitor.parquet``, and a replay of the log gives them bit for bit."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

from probing.experiment.flight.monitor import monitor_scenario, replay_monitor
from probing.experiment.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
ONSET_S = 160.3  # inside period 62 (2.55 s periods), after the 50-period baseline

#: Fault -> its class and its fields.  Case 6 sends the autopilot's command 3 deg down in
#: a second: a check that ignored the servo's lag called it an actuator fault.
FAULTS = {
    "case5": ("airframe", {"fault.type": "gtm_damage", "fault.case": 5}),
    "case6": ("airframe", {"fault.type": "gtm_damage", "fault.case": 6}),
    "effectiveness": ("actuator", {"fault.type": "effectiveness", "fault.scale": 0.5}),
    "sensor_bias": (
        "sensor",
        {
            "fault.type": "sensor_bias",
            "fault.channel": "theta_rad",
            "fault.bias": math.radians(0.5),
        },
    ),
}


@pytest.fixture(scope="module", params=sorted(FAULTS))
def flown(request, tmp_path_factory):
    base = tmp_path_factory.mktemp(f"isolation-{request.param.replace(' ', '-')}")
    expected, fields = FAULTS[request.param]
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(
        {"probe.periods": 72, "fault.onset_s": ONSET_S, **fields}
    )
    result = monitor_scenario(scn, base / "here", progress=False)
    again = replay_monitor(result.out_dir / "sensors.parquet", base / "replay", progress=False)
    return expected, result, again


def test_each_fault_class_gets_its_verdict(flown):
    expected, result, _ = flown
    assert result.first_alarm_period is not None and result.first_alarm_period >= 62
    assert result.verdict == expected


def test_the_checks_alarm_only_for_their_own_class(flown):
    """The actuator check alarms after an actuator fault and the kinematic one after a
    sensor fault, from the onset's period on; neither before it, nor for the other classes."""
    expected, result, _ = flown
    monitor = pd.read_parquet(result.out_dir / "monitor.parquet")
    for check, verdict, channel in (
        ("actuator", "actuator", "elevator_deg"),
        ("kinematics", "sensor", "theta_rad"),
    ):
        rows = monitor[monitor.detector == check]
        assert len(rows) > 0 and set(rows.channel) == {channel}
        alarmed = rows[rows.alarm].period
        if verdict == expected:
            assert alarmed.min() in (62, 63)
        else:
            assert alarmed.empty or alarmed.min() > result.first_alarm_period + 3


def test_a_flight_whose_reference_diverges_ends_there_and_replays_so(tmp_path):
    """The pitch attitude's sensor stuck: the autopilot flies the aircraft away on it, and
    the gust twin, fed the stuck attitude, leaves its tables first.  The flight's monitoring
    ends at that chunk, says why, keeps the periods before and its verdict (sensor); the
    replay of its log ends at the same chunk with the same files."""
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(
        {
            "probe.periods": 90,
            "fault.onset_s": ONSET_S,
            "fault.type": "sensor_stuck",
            "fault.channel": "theta_rad",
        }
    )
    result = monitor_scenario(scn, tmp_path / "here", progress=False)
    assert result.ended is not None and result.ended.startswith("the reference: alpha")
    assert result.verdict == "sensor"
    estimated = pd.read_parquet(result.out_dir / "probing.parquet").period.max()
    assert result.first_alarm_period <= estimated < scn.periods - 1
    again = replay_monitor(result.out_dir / "sensors.parquet", tmp_path / "again", progress=False)
    assert again.ended == result.ended and again.verdict == "sensor"
    for name in ("monitor.parquet", "probing.parquet"):
        a = pd.read_parquet(result.out_dir / name)
        assert a.equals(pd.read_parquet(again.out_dir / name)), name


def test_a_replay_gives_the_checks_bit_for_bit(flown):
    _, result, again = flown
    for name in ("monitor.parquet", "probing.parquet"):
        a = pd.read_parquet(result.out_dir / name)
        b = pd.read_parquet(again.out_dir / name)
        assert len(a) > 0 and a.equals(b), name
    assert again.verdict == result.verdict


def test_a_reference_that_diverges_in_the_onsets_chunk_keeps_the_periods_before_it(tmp_path):
    """The study's flight of a stuck pitch sensor whose gust twin hits the ground 50 s after
    the onset, in the chunk that holds the onset (chunks of 32 periods): the whole periods
    before the twin's divergence are still monitored, so the fault is found within a period
    and called a sensor's; monitoring then ends, and a replay ends the same way with the same
    files.  (Before, the whole chunk was dropped: no alarm, verdict none.)"""
    onset_s = 179.003  # period 70 (2.55 s periods)
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(
        {
            "probe.periods": 100,
            "disturbance.seed": 1,
            "fault.onset_s": onset_s,
            "fault.type": "sensor_stuck",
            "fault.channel": "theta_rad",
            "monitor.false_alarms_per_hour": 0.025,
            "monitor.trajectory_false_alarms_per_hour": 0.025,
        }
    )
    result = monitor_scenario(scn, tmp_path / "here", progress=False)
    assert result.ended is not None and result.ended.startswith("the reference: aircraft hit")
    assert result.first_alarm_period in (70, 71)
    assert result.verdict == "sensor"
    monitor = pd.read_parquet(result.out_dir / "monitor.parquet")
    diverged_s = float(result.ended.rsplit("t = ", 1)[1].split()[0])
    assert monitor.time_s.max() <= diverged_s < monitor.time_s.max() + 2 * 2.55
    again = replay_monitor(result.out_dir / "sensors.parquet", tmp_path / "again", progress=False)
    assert again.ended == result.ended and again.verdict == "sensor"
    for name in ("monitor.parquet", "probing.parquet"):
        assert pd.read_parquet(result.out_dir / name).equals(
            pd.read_parquet(again.out_dir / name)
        ), name
