"""The autopilot (probing.sim.control): one step at a time it flies exactly as the plant's own
stepping does when every loop is open, and its loops hold what they hold."""

from __future__ import annotations

import numpy as np
import pytest

from probing.sim.control import ClosedLoop, control_power
from probing.sim.flight import ActuatorFault, Control, Flight
from probing.sim.plant import make_plant
from probing.sim.world import JSBSimWorld

pytestmark = pytest.mark.jsbsim

GTM = Flight("gtm_t2", 800.0, "speed_kcas", 75.0, 0.01)
CHANNELS = ["theta_rad", "q_rad_s"]


def _square(n: int, amplitude: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return amplitude * np.repeat(np.sign(rng.standard_normal(n // 10)), 10)


@pytest.mark.parametrize("flight", [GTM, Flight("A320", 10000.0, "speed_kcas", 250.0, 0.01)])
def test_open_loop_one_step_at_a_time_is_the_plants_own_stepping_bit_for_bit(flight):
    """Every loop open, no fault: the same outputs and elevator, to the bit, as the world's
    open-loop history (JSBSimWorld.fly_commands) with the calibrated map applied to the whole
    array (the A320's map has a kink at 0)."""
    q = _square(3000, 0.01)
    a, b = make_plant(flight), make_plant(flight)
    out_a, out_b = np.empty((3000, 2)), np.empty((3000, 2))
    el_a, el_b = np.empty(3000), np.empty(3000)
    JSBSimWorld(a).fly_commands(
        a.drive().command(a.trim_result.elevator_deg + q), a.channel_nodes(CHANNELS), out_a, el_a
    )
    ClosedLoop(b, Control()).step(q, b.channel_nodes(CHANNELS), out_b, el_b)
    assert np.array_equal(out_a, out_b) and np.array_equal(el_a, el_b)


def test_control_power_has_the_signs_of_the_aircraft():
    """Elevator trailing edge down pitches nose down on both; the GTM's and the 737's aileron
    commands roll opposite ways (their FCS conventions differ), which the gains follow."""
    gtm = control_power(GTM)
    b737 = control_power(Flight("737", 15000.0, "speed_kcas", 280.0, 0.01))
    assert gtm.pitch_rad_s2_per_deg < 0 and b737.pitch_rad_s2_per_deg < 0
    assert gtm.roll_rad_s2_per_norm < 0 < b737.roll_rad_s2_per_norm
    assert gtm.speed_fps2_per_norm > 0 and b737.speed_fps2_per_norm > 0
    # the sub-scale GTM has about 18x the pitch control power per deg of a 737
    assert 10 < gtm.pitch_rad_s2_per_deg / b737.pitch_rad_s2_per_deg < 30


@pytest.mark.parametrize("model", ["gtm_t2", "737"])
def test_the_loops_hold_pitch_bank_and_speed_after_an_elevator_step(model):
    """A 0.5 deg elevator step added to the pitch loop's command: open loop the pitch drifts
    away (phugoid), closed loop the integrator brings pitch, bank and speed back to trim."""
    flight = GTM if model == "gtm_t2" else Flight("737", 15000.0, "speed_kcas", 280.0, 0.01)
    control = Control(pitch_hold=True, bank_hold=True, speed_hold=True)
    n = 6000  # 60 s
    step = np.full(n, 0.5)
    drift = {}
    for closed in (False, True):
        plant = make_plant(flight)
        theta0 = plant.trim_result.theta_deg
        loop = ClosedLoop(plant, control if closed else Control(), control_power(flight))
        out = np.empty((n, 3))
        plant_nodes = plant.channel_nodes(["theta_rad", "vt_fps", "q_rad_s"])
        v0 = plant.fdm["velocities/vt-fps"]
        loop.step(step, plant_nodes, out)
        last = slice(n - 2000, n)  # the last 20 s
        drift[closed] = (
            np.sqrt(np.mean((np.degrees(out[last, 0]) - theta0) ** 2)),
            np.sqrt(np.mean((out[last, 1] - v0) ** 2)),
            abs(plant.fdm["attitude/phi-deg"]),
        )
    theta, speed, bank = drift[True]
    assert theta < 0.02 * drift[False][0], drift  # open loop: the phugoid takes pitch away
    assert speed < 0.02 * drift[False][1] and bank < 0.1, drift


def test_effectiveness_scales_the_surface_about_trim_and_stuck_holds_it():
    """From the onset on the realised elevator is trim + scale x (asked - trim); a stuck one
    stays where it was at the onset whatever is asked."""
    n, onset = 400, 2.0
    q = _square(n, 0.05, seed=1)
    realised = {}
    for fault in (None, ActuatorFault("effectiveness", onset, 0.4), ActuatorFault("stuck", onset)):
        plant = make_plant(GTM)
        el = np.empty(n)
        ClosedLoop(plant, Control(), None, fault).step(q, [], np.empty((n, 0)), el)
        realised[fault.kind if fault else "healthy"] = el
        trim = plant.trim_result.elevator_deg
    k = round(onset / GTM.dt_s)
    healthy, weak, stuck = realised["healthy"], realised["effectiveness"], realised["stuck"]
    assert np.array_equal(healthy[:k], weak[:k]) and np.array_equal(healthy[:k], stuck[:k])
    # the GTM's 5 Hz servo is linear: the deviation after the onset settles to 0.4 x
    settled = slice(k + 60, n)
    ratio = (weak[settled] - trim) / (healthy[settled] - trim)
    assert np.median(ratio) == pytest.approx(0.4, abs=0.02)
    assert np.ptp(stuck[k + 30 :]) < 1e-3 * np.ptp(healthy[k + 30 :])


@pytest.mark.parametrize("kind", ["effectiveness", "stuck"])
def test_an_actuator_fault_acts_from_the_exact_step_of_its_onset(kind):
    """Onset 0.5 s = step 50 (dt 0.01 s): JSBSim's own elevator command property and the
    realised position, read after each step, are the healthy flight's up to step 49 and
    differ from step 50 on.  At step 50 the command is the map's for trim + 0.4 x probe
    (effectiveness); a stuck surface holds, from step 50 on, the position it had after step
    49."""
    n, onset = 80, 0.5
    k = round(onset / GTM.dt_s)
    q = _square(n, 0.05, seed=1)
    runs = {}
    for name, fault in (
        ("healthy", None),
        (kind, ActuatorFault(kind, onset, 0.4 if kind == "effectiveness" else 1.0)),
    ):
        plant = make_plant(GTM)
        pm = plant.fdm.get_property_manager()
        nodes = [pm.get_node("fcs/elevator-cmd-norm")]
        out, realised = np.empty((n, 1)), np.empty(n)
        ClosedLoop(plant, Control(), None, fault).step(q, nodes, out, realised)
        runs[name] = (out[:, 0], realised)
    (cmd, pos), (cmd_h, pos_h) = runs[kind], runs["healthy"]
    assert np.flatnonzero(cmd != cmd_h)[0] == k
    assert np.flatnonzero(pos != pos_h)[0] == k
    if kind == "stuck":
        np.testing.assert_allclose(pos[k:], pos_h[k - 1], rtol=0, atol=1e-12)
    else:
        trim = plant.trim_result.elevator_deg
        assert cmd[k] == pytest.approx(plant.drive().command(np.array([trim + 0.4 * q[k]]))[0])


def test_a_stuck_fault_at_zero_holds_the_trimmed_surface_from_the_first_step():
    """Onset 0 s: the first step is already faulted; the elevator stays at its trimmed
    position (JSBSim's own property after the trim) whatever the probe asks."""
    n = 40
    plant = make_plant(GTM)
    trimmed = plant.fdm["fcs/elevator-pos-deg"]
    realised = np.empty(n)
    loop = ClosedLoop(plant, Control(), None, ActuatorFault("stuck", 0.0))
    loop.step(_square(n, 0.05, seed=2), [], np.empty((n, 0)), realised)
    np.testing.assert_allclose(realised, trimmed, rtol=0, atol=1e-12)


def test_a_scheduled_damage_acts_from_its_onset_step_in_closed_loop():
    """NASA's case 5 at 0.3 s = step 30, the pitch loop closed: JSBSim's own ``damage/case``
    read after each step is 0 up to step 29 and 5 from step 30 on."""
    flight = Flight("gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, damage_case=5, damage_onset_s=0.3)
    plant = make_plant(flight)
    node = plant.fdm.get_property_manager().get_node("damage/case")
    out = np.empty((60, 1))
    loop = ClosedLoop(plant, Control(pitch_hold=True), control_power(flight.nominal))
    loop.step(None, [node], out)
    assert np.array_equal(out[:, 0], np.where(np.arange(60) >= 30, 5.0, 0.0))
