"""The gust reference's twin follows the measured altitude slowly (ALTITUDE_FOLLOW_S), and
nothing else moves it: told the aircraft flies 100 ft above its trim in calm air, the twin
climbs there with the follower's time constant; without the follower it stays."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import probing.experiment.flight.onboard as onboard
from probing.experiment.flight.monitor import monitor_scenario
from probing.experiment.scenario import load_scenario

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
PERIODS = 60


@pytest.fixture(scope="module")
def calm(tmp_path_factory):
    """A calm gust-reference flight with NASA's sensors, and its log."""
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(
        {
            "probe.periods": PERIODS,
            "monitor.baseline_periods": 20,
            "disturbance.turbulence": "none",
            "output.channels": ["theta_rad", "h_ft", "elevator_deg"],
        }
    )
    result = monitor_scenario(scn, tmp_path_factory.mktemp("calm"), progress=False)
    return scn, pq.read_table(result.out_dir / "sensors.parquet").to_pandas()


def _twin_altitude(scn, log) -> np.ndarray:
    source = onboard.GustSource(scn)
    chunk = {c: log[c].to_numpy() for c in log.columns}
    return source.next(chunk)[:, 1]


def test_the_twin_climbs_to_the_measured_altitude_with_the_followers_time_constant(calm):
    scn, log = calm
    log = log.assign(h_ft=log.h_ft + 100.0)
    h = _twin_altitude(scn, log)
    t = PERIODS * 2.55
    climbed = h[-1] - h[0]
    assert climbed == pytest.approx(
        100.0 * (1 - math.exp(-t / onboard.ALTITUDE_FOLLOW_S)), rel=0.15
    )


def test_without_the_follower_it_keeps_its_own(calm, monkeypatch):
    scn, log = calm
    log = log.assign(h_ft=log.h_ft + 100.0)
    monkeypatch.setattr(onboard, "ALTITUDE_FOLLOW_S", math.inf)
    h = _twin_altitude(scn, log)
    assert abs(h[-1] - h[0]) < 5.0
