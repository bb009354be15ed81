"""The monitor's two detectors, named apart: the probing detector (the pulse response
changed, the paper's method) and the trajectory detector (the output left the reference's).
A biased alpha vane moves the measured trajectory but not the pulse response."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from probing.experiment.flight.monitor import DETECTORS, monitor_scenario
from probing.experiment.scenario import load_scenario

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
PERIOD_S = 2.55  # M = 255 bits of 0.01 s
ONSET_PERIOD = 25
ONSET_S = ONSET_PERIOD * PERIOD_S  # at a period's start: the bias is constant in each period


def _flight(fault: dict | None):
    """The study's flight in calm air, NASA's sensors, the calm nominal twin, 40 periods."""
    base = load_scenario(ROOT / "scenarios" / "monitor" / "base.toml")
    changes = {
        "probe.periods": 40,
        "monitor.baseline_periods": 20,
        "output.drift": "nominal",
        "output.channels": ["theta_rad", "alpha_rad", "elevator_deg"],
        "disturbance.turbulence": "none",
        "disturbance.sensor_noise": {},
        "sensors": {"suite": "nasa_t2"},
    }
    if fault is not None:
        changes["fault"] = {**fault, "onset_s": ONSET_S}
    return base.replace(changes)


@pytest.fixture(scope="module")
def flights(tmp_path_factory):
    out = tmp_path_factory.mktemp("detectors")
    bias = {"type": "sensor_bias", "channel": "alpha_rad", "bias": 0.001}
    return {
        "healthy": monitor_scenario(_flight(None), out / "h", progress=False),
        "biased": monitor_scenario(_flight(bias), out / "b", progress=False),
    }


def test_every_period_and_channel_has_a_row_of_each_detector(flights):
    """Each monitored channel a row of each detector per period, and with the sensor suite
    each isolation check a row on its own channel, after them."""
    table = pq.read_table(flights["healthy"].out_dir / "monitor.parquet").to_pandas()
    detected = table[table.detector.isin(DETECTORS)]
    counts = detected.groupby(["period", "channel"]).detector.apply(tuple)
    assert set(counts) == {DETECTORS}
    assert set(detected.channel) == {"theta_rad", "alpha_rad"}
    checks = table[~table.detector.isin(DETECTORS)]
    per_period = checks.groupby("period").apply(
        lambda g: tuple(zip(g.detector, g.channel, strict=True)), include_groups=False
    )
    assert set(per_period) == {(("actuator", "elevator_deg"), ("kinematics", "theta_rad"))}
    assert set(per_period.index) == set(counts.index.get_level_values("period"))
    assert table.period.is_monotonic_increasing


def test_a_biased_vane_is_the_trajectorys_alarm_first(flights):
    """From the start of period 25 the measured alpha is 0.001 rad (about 2 of the vane's
    noise sigmas) off the reference's, and nothing flies on it: the trajectory detector
    alarms in that very period and not before.  The probing detector sees it later and
    faintly: an offset c constant over a period shifts every tap of the ``ac`` estimate by
    -c / (a (M + 1)) (the m-sequence sums to -1), 2e-5 per tap here, which its windows sum
    up over the periods it averages."""
    result = flights["biased"]
    assert result.alarm_detector == "trajectory"
    assert result.first_probing_alarm_s > result.first_trajectory_alarm_s
    assert result.first_trajectory_alarm_s == pytest.approx((ONSET_PERIOD + 1) * PERIOD_S)
    assert result.first_alarm_s == result.first_trajectory_alarm_s
    table = pq.read_table(result.out_dir / "monitor.parquet").to_pandas()
    alpha = table[(table.channel == "alpha_rad") & (table.detector == "trajectory")]
    assert not alpha[alpha.period == ONSET_PERIOD - 1].alarm.any()
    assert alpha[alpha.period == ONSET_PERIOD].alarm.all()
    meta = pq.read_metadata(result.out_dir / "monitor.parquet").metadata
    assert meta[b"probing.alarm_detector"] == b"trajectory"
    assert json.loads(meta[b"probing.first_probing_alarm_s"]) == pytest.approx(
        result.first_probing_alarm_s
    )
    assert json.loads(meta[b"probing.first_trajectory_alarm_s"]) == pytest.approx(
        result.first_trajectory_alarm_s
    )


def test_a_healthy_calm_flight_alarms_on_neither(flights):
    result = flights["healthy"]
    assert result.first_alarm_s is None and result.alarm_detector is None
    meta = pq.read_metadata(result.out_dir / "monitor.parquet").metadata
    assert json.loads(meta[b"probing.first_trajectory_alarm_s"]) is None
    assert meta[b"probing.verdict"] == b"none"
