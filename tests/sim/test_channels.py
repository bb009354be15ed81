"""The output channels' table: every sensor of a suite is a channel, and the channels added
for the sensors (heading, longitudinal load factor, INS velocities) read real values."""

from __future__ import annotations

import math

import pytest

from probing.core.gust import GUST_SENSORS
from probing.core.sensors import SENSOR_SUITES
from probing.sim.channels import CHANNEL_NAMES, CHANNELS, Channel

NEW = ("psi_rad", "nx_g", "v_north_fps", "v_east_fps", "v_down_fps")


@pytest.mark.parametrize("suite", sorted(SENSOR_SUITES))
def test_every_sensor_of_a_suite_is_a_channel(suite: str) -> None:
    assert set(SENSOR_SUITES[suite].sensors) <= set(CHANNELS)


def test_the_gust_sensors_are_channels() -> None:
    assert set(GUST_SENSORS) <= set(CHANNELS)


def test_the_new_channels_come_last() -> None:
    """Appended: the channels' order of stored outputs before them is unchanged."""
    assert tuple(CHANNEL_NAMES)[-len(NEW) :] == NEW
    assert tuple(CHANNEL_NAMES)[:3] == ("theta_rad", "q_rad_s", "alpha_rad")


def test_the_channel_names_are_the_tables_own(monkeypatch) -> None:
    """A view of CHANNELS, not a copy: a channel added to the table is a name at once (the
    scenario checks ``[output] channels`` against them)."""
    monkeypatch.setitem(CHANNELS, "qbar_psf", Channel("qbar_psf", "aero/qbar-psf", "psf", "q"))
    assert "qbar_psf" in CHANNEL_NAMES and tuple(CHANNEL_NAMES)[-1] == "qbar_psf"


@pytest.mark.parametrize(
    ("model", "altitude_ft", "kcas"), [("737", 15000, 280), ("gtm_t2", 800, 75)]
)
def test_the_new_channels_read_real_values(new_plant, model, altitude_ft, kcas) -> None:
    plant = new_plant(model, 0.01)
    plant.trim(altitude_ft, speed_kcas=kcas)
    for name in NEW:
        assert plant._pm.hasNode(CHANNELS[name].prop), name
    names = [*NEW, "vt_fps", "gamma_rad", "theta_rad"]
    nodes = plant.channel_nodes(names)
    values = {name: node.get_double_value() for name, node in zip(names, nodes, strict=True)}
    assert all(math.isfinite(v) for v in values.values())
    vn, ve, vd, vt = (values[k] for k in ("v_north_fps", "v_east_fps", "v_down_fps", "vt_fps"))
    # calm air: the velocity over the ground is the true airspeed, along the heading and
    # the flight path (straight and level: north, as the trim starts at psi = 0)
    assert math.hypot(vn, ve, vd) == pytest.approx(vt, rel=1e-6)
    assert vd == pytest.approx(-vt * math.sin(values["gamma_rad"]), abs=1e-3)
    heading = math.atan2(ve, vn) % (2 * math.pi)
    psi = values["psi_rad"] % (2 * math.pi)
    assert min(abs(heading - psi), 2 * math.pi - abs(heading - psi)) < 1e-3
    # the accelerometer's x: the thrust's excess over drag, small at a level trim
    assert 0.0 < abs(values["nx_g"]) < 0.2
