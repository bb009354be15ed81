"""The aircraft's sensors on a flight (probing.sim.sensing) and the autopilot flying on
them: the measurement is the truth through NASA's numbers, and a biased sensor moves the
aircraft, since the autopilot holds what it measures."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.faults import SensorBias
from probing.core.measuring import SensorBank
from probing.core.sensors import SENSOR_SUITES
from probing.sim.control import ClosedLoop, control_power
from probing.sim.flight import Control, Flight
from probing.sim.plant import make_plant
from probing.sim.sensing import Sensing

pytestmark = pytest.mark.jsbsim

CONTROL = Control(pitch_hold=True, bank_hold=True, speed_hold=True)
FLIGHT = Flight("gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, control=CONTROL)
SUITE = SENSOR_SUITES["nasa_t2"]
STEPS = 3000


def _fly(fault: SensorBias | None = None, seed: int = 1):
    plant = make_plant(FLIGHT)
    sensing = Sensing(plant, SUITE, seed, fault)
    loop = ClosedLoop(plant, CONTROL, control_power(FLIGHT), sensing=sensing)
    nodes = plant.channel_nodes(list(sensing.channels))
    true, measured = np.empty((STEPS, len(nodes))), np.empty((STEPS, len(nodes)))
    loop.step(None, nodes, true, measured=measured)
    return plant, sensing, true, measured


@pytest.fixture(scope="module")
def flight():
    return _fly()


@pytest.mark.parametrize("channel", ["theta_rad", "q_rad_s", "alpha_rad", "vt_fps", "nz_g"])
def test_each_measurement_is_the_truth_with_nasas_bias_and_noise(flight, channel):
    _, sensing, true, measured = flight
    j = sensing.index(channel)
    spec = SUITE.sensors[channel]
    error = measured[:, j] - true[:, j]
    assert abs(error.std() / spec.noise_sigma - 1.0) < 0.05
    assert abs(error.mean() - spec.bias) < 4 * spec.noise_sigma / np.sqrt(STEPS)


def test_the_autopilot_flies_on_the_measurements(flight):
    """With sensor noise the loops move the elevator; the same flight without sensors (the
    loops on JSBSim's states) barely moves it (calm air, no probe: only its settling)."""
    _, sensing, true, _ = flight
    still = make_plant(FLIGHT)
    quiet = ClosedLoop(still, CONTROL, control_power(FLIGHT))
    nodes = still.channel_nodes(["elevator_deg"])
    out = np.empty((STEPS, 1))
    quiet.step(None, nodes, out)
    moved = true[:, sensing.index("elevator_deg")]
    assert np.ptp(moved) > 20 * np.ptp(out[:, 0])


def test_a_biased_pitch_sensor_pitches_the_aircraft_by_minus_its_bias():
    """From its onset the pitch hold holds the *measured* attitude at its reference, so the
    true attitude settles one bias below where it was."""
    bias = np.radians(0.5)
    _, sensing, true, measured = _fly(SensorBias("theta_rad", bias, onset_s=5.0))
    j = sensing.index("theta_rad")
    before = true[400:500, j].mean()
    after = true[-500:, j].mean()
    assert abs((after - before) / -bias - 1.0) < 0.1
    step = round(5.0 / 0.01)
    jump = measured[step, j] - measured[step - 1, j]  # the first step after the onset
    assert abs(jump - bias) < 6 * SUITE.sensors["theta_rad"].noise_sigma


def test_the_same_seed_measures_the_same_bits_and_another_seed_does_not(flight):
    _, _, _, measured = flight
    again = _fly(seed=1)[3]
    other = _fly(seed=2)[3]
    assert np.array_equal(measured, again)
    assert not np.array_equal(measured, other)


def test_a_sensor_bank_on_the_same_true_values_measures_the_same_bits():
    """What a live flight does on the flight computer's side (probing.experiment.flight.live): the
    suite's sensors, seeded alike and started at the same true trim, on the true values
    handed in (in chunks of any size) measure what the sensors on the plant measured."""
    plant = make_plant(FLIGHT)
    sensing = Sensing(plant, SUITE, 3)
    trim = [get() for get in sensing.getters]
    loop = ClosedLoop(plant, CONTROL, control_power(FLIGHT), sensing=sensing)
    nodes = plant.channel_nodes(list(sensing.channels))
    true, measured = np.empty((500, len(nodes))), np.empty((500, len(nodes)))
    loop.step(None, nodes, true[:300], measured=measured[:300])
    loop.step(None, nodes, true[300:], measured=measured[300:])
    bank = SensorBank(SUITE, plant.dt_s, 3, trim)
    got = np.vstack([bank.measure(true[:123]), bank.measure(true[123:])])
    assert np.array_equal(got, measured)
    assert bank.current == sensing.current
