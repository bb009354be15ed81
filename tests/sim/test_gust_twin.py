"""The gust-ready aircraft and the gust twin against JSBSim's own turbulence: flown through
the wind and rotational gusts JSBSim's MIL-spec turbulence produced, the calm gust-ready
model flies what the turbulent aircraft flew."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from probing.core.gust import ned_to_body
from probing.sim.aircraft import GUST_INPUTS
from probing.sim.control import ClosedLoop, control_power
from probing.sim.flight import Control, Flight
from probing.sim.gust_twin import WIND_PROPERTIES, GustTwin
from probing.sim.plant import make_plant

STEPS = 1500  # 15 s at 0.01 s
CONTROL = Control(pitch_hold=True, bank_hold=True, speed_hold=True)
TURBULENT = Flight(
    "gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, turbulence="light", seed=3, control=CONTROL
)
CALM = dataclasses.replace(TURBULENT, turbulence="none", seed=0)
TRUTH = [
    "atmosphere/total-wind-north-fps",
    "atmosphere/total-wind-east-fps",
    "atmosphere/total-wind-down-fps",
    "atmosphere/p-turb-rad_sec",
    "atmosphere/q-turb-rad_sec",
    "atmosphere/r-turb-rad_sec",
]
CHANNELS = ["theta_rad", "q_rad_s", "phi_rad", "p_rad_s", "alpha_rad"]


@pytest.fixture(scope="module")
def turbulent_flight():
    """JSBSim's turbulent flight under the autopilot: its outputs and the wind and
    rotational turbulence JSBSim applied in each step."""
    plant = make_plant(TURBULENT)
    loop = ClosedLoop(plant, CONTROL, control_power(TURBULENT))
    nodes = plant.channel_nodes(CHANNELS)
    truth_nodes = [plant.fdm.get_property_manager().get_node(p) for p in TRUTH]
    out, truth = np.empty((STEPS, len(CHANNELS))), np.empty((STEPS, len(TRUTH)))
    row = np.empty((1, len(CHANNELS)))
    for k in range(STEPS):
        loop.step(None, nodes, row)
        out[k] = row[0]
        truth[k] = [n.get_double_value() for n in truth_nodes]
    return out, truth


def _fly_gust_ready(values: np.ndarray, names: list[str]) -> np.ndarray:
    plant = make_plant(CALM, gust_inputs=True)
    loop = ClosedLoop(plant, CONTROL, control_power(CALM))
    nodes = plant.channel_nodes(CHANNELS)
    pm = plant.fdm.get_property_manager()
    out = np.empty((values.shape[0], len(CHANNELS)))
    loop.step(None, nodes, out, inputs=([pm.get_node(n) for n in names], values))
    return out


def test_the_gust_ready_model_flown_through_jsbsims_gusts_flies_the_turbulent_flight(
    turbulent_flight,
):
    out, truth = turbulent_flight
    names = [*WIND_PROPERTIES, *(GUST_INPUTS[f"{a}_gust_rad_s"] for a in "pqr")]
    twin = _fly_gust_ready(truth, names)
    response = np.abs(out - out[0]).max(axis=0)
    assert np.all(response > 1e-4)  # the gusts move every channel
    np.testing.assert_allclose(twin, out, rtol=0, atol=1e-6 * response.max())


def test_without_the_rotational_gusts_it_does_not(turbulent_flight):
    """The rotational part matters: the wind alone leaves the pitch response off."""
    out, truth = turbulent_flight
    twin = _fly_gust_ready(truth[:, :3], list(WIND_PROPERTIES))
    err = np.abs(twin[:, 0] - out[:, 0]).max()
    assert err > 0.05 * np.abs(out[:, 0] - out[0, 0]).max()


def test_with_nothing_set_it_steps_as_the_plain_model_bit_for_bit():
    plain, ready = make_plant(CALM), make_plant(CALM, gust_inputs=True)
    assert plain.trim_result.to_dict() == ready.trim_result.to_dict()
    for plant in (plain, ready):
        for k in range(300):
            plant.fdm["fcs/elevator-cmd-norm"] = 0.02 * np.sin(k / 20.0)
            plant.fdm.run()
    for prop in ("attitude/theta-rad", "velocities/q-rad_sec", "aero/alpha-rad"):
        assert plain.fdm[prop] == ready.fdm[prop]


def test_the_roll_observer_pulls_the_twin_to_the_measured_roll():
    """Told the aircraft rolls at 0.02 rad/s from wings level, the twin rolls with it within
    a fraction of a second (the observer's gain 30/s) and its bank follows the measured one;
    told the aircraft holds its wings level, it stays put."""
    twin = GustTwin(CALM, CONTROL, control_power(CALM), ["p_rad_s", "phi_rad"])
    n = 100
    phi0 = twin.plant.fdm["attitude/phi-rad"]
    phi = phi0 + 0.02 * 0.01 * np.arange(n)
    out = twin.next(np.zeros((n, 3)), np.zeros((n, 3)), np.full(n, 0.02), phi)
    assert abs(out[-1, 0] - 0.02) < 0.004
    assert out[5, 0] < out[-1, 0]  # it got there, not started there
    assert abs(out[-1, 1] - phi[-1]) < 0.1 * (phi[-1] - phi0)
    still = GustTwin(CALM, CONTROL, control_power(CALM), ["p_rad_s", "phi_rad"])
    held = still.next(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.full(n, phi0))
    assert np.abs(held[:, 0]).max() < 1e-4


def test_a_gust_twin_refuses_turbulence_and_damage():
    with pytest.raises(ValueError, match="calm air"):
        GustTwin(TURBULENT, CONTROL, control_power(CALM), ["theta_rad"])
    damaged = dataclasses.replace(CALM, damage_case=5)
    with pytest.raises(ValueError, match="calm air"):
        GustTwin(damaged, CONTROL, control_power(CALM), ["theta_rad"])


def test_each_rotational_gust_reaches_its_own_axis_of_the_model():
    """The columns of ``rates_rad_s`` are body p, q, r: each goes to the model's gust input
    of its axis, and a pitch gust pitches the twin (it does not yaw or roll it)."""
    channels = ["p_rad_s", "q_rad_s", "r_rad_s"]
    n = 100
    flown = []
    for gust in ([0.0, 0.0, 0.0], [0.01, 0.02, 0.03], [0.0, 0.01, 0.0]):
        twin = GustTwin(CALM, CONTROL, control_power(CALM), channels)
        phi0 = twin.plant.fdm["attitude/phi-rad"]
        rates = np.tile(gust, (n, 1))
        out = twin.next(np.zeros((n, 3)), rates, np.zeros(n), np.full(n, phi0))
        held = [twin.plant.fdm[GUST_INPUTS[f"{a}_gust_rad_s"]] for a in "pqr"]
        assert held == gust
        flown.append(out)
    moved = np.abs(flown[2] - flown[0]).max(axis=0)  # the pitch gust alone: p, q, r
    assert moved[1] > 1e-3
    assert moved[1] > 20 * max(moved[0], moved[2])


def test_the_observed_roll_gust_lies_along_the_turbulences_north_axis():
    """JSBSim's MIL-spec roll gust lies along the turbulence's axes (north: the mean wind's
    azimuth, 0 in calm air), so a banked, pitched or turning aircraft feels part of it in
    pitch and yaw.  Each step, the rate the twin's aerodynamics see on each body axis is its
    own less the set gust less the observer's roll gust times that axis's component of
    north, the first column of the local-to-body matrix (:func:`probing.core.gust.
    ned_to_body`) at the step's attitude: exact to rounding."""
    twin = GustTwin(CALM, CONTROL, control_power(CALM), ["p_rad_s"])
    fdm = twin.plant.fdm
    n = 400
    phi = fdm["attitude/phi-rad"] + np.minimum(np.arange(n) * 0.002, 0.4)  # it banks, turns
    gusts = np.tile([0.001, -0.002, 0.003], (n, 1))
    worst, leak = 0.0, np.zeros(3)
    for k in range(n):
        twin.next(np.zeros((1, 3)), gusts[k : k + 1], np.array([0.05]), phi[k : k + 1])
        angles = [fdm[f"attitude/{a}-rad"] for a in ("phi", "theta", "psi")]
        observed = fdm["probing/gust/p-observed-rad_sec"]
        north = ned_to_body(*(np.array([a]) for a in angles), np.array([[observed, 0, 0]]))[0]
        for i, a in enumerate("pqr"):
            seen = fdm[f"probing/gust/{a}-aero-rad_sec"]
            expected = fdm[f"velocities/{a}-aero-rad_sec"] - gusts[k, i] - north[i]
            worst = max(worst, abs(seen - expected))
        leak = np.maximum(leak, np.abs(north))
    assert np.all(leak > 1e-3)  # the observer's gust reached every axis
    assert worst < 1e-12
