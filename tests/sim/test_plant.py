"""The JSBSim plant: exact elevator, trim, sanitised models, linearisation, single pulse."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from probing.core.prbs import Probe
from probing.sim.errors import TrimError
from probing.sim.flight import Flight
from probing.sim.truth import linear_pulse_response, single_pulse_response
from probing.sim.world import JSBSimWorld

pytestmark = pytest.mark.jsbsim

FLIGHT_737 = Flight("737", 15000.0, "speed_kcas", 280.0, 0.01)
CHANNELS = ("theta_rad", "q_rad_s", "alpha_rad")


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# --------------------------------------------------------------- the plant
@pytest.mark.parametrize("model", ["737", "A320"])
def test_elevator_deflection_is_exact(model: str, new_plant) -> None:
    """trim + NL(probe) reaches the surface exactly, also through the A320's asymmetric map."""
    plant = new_plant(model, 0.01)
    trim = plant.trim(15000, speed_kcas=280)
    lo, hi = plant.drive().range
    # The stock maps are piecewise linear and (for the A320) asymmetric about zero.
    assert lo < trim.elevator_deg < hi
    rng = np.random.default_rng(1)
    surface = trim.elevator_deg + np.concatenate(
        (0.005 * Probe(6, 0.01, 1.0).bits(2), rng.uniform(-3, 3, 50))
    )
    surface = np.concatenate((surface, [lo + 0.5, hi - 0.5, trim.elevator_deg]))
    realised = np.empty(surface.size)
    out = np.empty((surface.size, 1))
    JSBSimWorld(plant).fly_commands(
        plant.drive().command(surface), plant.channel_nodes(["theta_rad"]), out, realised
    )
    np.testing.assert_allclose(realised, surface, rtol=0, atol=1e-12)


def test_a320_map_is_asymmetric(new_plant) -> None:
    plant = new_plant("A320", 0.01)
    plant.trim(15000, speed_kcas=280)
    up = plant.drive().command(np.array([10.0])) - plant.drive().command(np.array([0.0]))
    down = plant.drive().command(np.array([0.0])) - plant.drive().command(np.array([-10.0]))
    assert abs(up[0] - down[0]) > 0.01 * abs(up[0])


def test_elevator_outside_range_is_refused(new_plant) -> None:
    plant = new_plant("737", 0.01)
    plant.trim(15000, speed_kcas=280)
    with pytest.raises(ValueError, match="outside the model's range"):
        plant.drive().command(np.array([plant.drive().range[1] + 1.0]))


def test_trim_failure_names_the_condition(new_plant) -> None:
    plant = new_plant("737", 0.01)
    with pytest.raises(TrimError, match=r"737 at altitude_ft = 15000, speed_kcas = 40"):
        plant.trim(15000, speed_kcas=40)


#: The trimmed state compared bit for bit: attitude, body velocity and rates, controls.
TRIM_STATE = (
    "aero/alpha-rad",
    "aero/beta-rad",
    "attitude/phi-rad",
    "attitude/theta-rad",
    "attitude/psi-rad",
    "velocities/u-fps",
    "velocities/v-fps",
    "velocities/w-fps",
    "velocities/p-rad_sec",
    "velocities/q-rad_sec",
    "velocities/r-rad_sec",
    "fcs/pitch-trim-cmd-norm",
    "fcs/aileron-cmd-norm",
    "fcs/rudder-cmd-norm",
    "fcs/throttle-cmd-norm[0]",
    "fcs/throttle-cmd-norm[1]",
    "fcs/elevator-pos-deg",
    "accelerations/vdot-ft_sec2",
    "accelerations/rdot-rad_sec2",
)


@pytest.mark.parametrize(("case", "gamma_deg"), [(0, 0.0), (0, 3.0), (4, 0.0)])
def test_a_straight_trim_is_jsbsims_own_full_trim_to_the_bit(
    new_plant, case: int, gamma_deg: float
) -> None:
    """Straight flight (level, climbing, damaged) is trimmed by JSBSim's full trim and nothing
    else: the same bits as FGTrim run by hand on a bare FGFDMExec, and no zero-sideslip turn
    solve (that one is for turns only, ``test_gtm_damage``)."""
    plant = new_plant("gtm_t2", 1.0 / 200.0)
    plant.damage(case)
    plant.trim(800.0, speed_keas=75.0, gamma_deg=gamma_deg)
    assert plant.turn_trim is None
    bare = fgtrim_alone(
        new_plant("gtm_t2", 1.0 / 200.0).fdm, 800.0, ("ic/ve-kts", 75.0), gamma_deg, case
    )
    for prop in TRIM_STATE:
        assert plant.fdm[prop] == bare[prop], prop


#: What the first step of a trimmed aircraft shows: the pitch rate and the load factor (which
#: JSBSim computes from the previous frame's forces), and the accelerations.
FIRST_STEP = (
    "velocities/q-rad_sec",
    "accelerations/Nz",
    "accelerations/wdot-ft_sec2",
    "accelerations/qdot-rad_sec2",
)


@pytest.mark.parametrize(
    ("model", "dt_s", "altitude_ft", "speed_kcas"),
    [("737", 0.01, 15000.0, 280.0), ("gtm_t2", 1.0 / 200.0, 800.0, 75.0)],
)
def test_the_first_step_is_the_trims_own(
    new_plant, model: str, dt_s: float, altitude_ft: float, speed_kcas: float
) -> None:
    """Calibrating the elevator (and another surface) leaves the trimmed aircraft as JSBSim's
    trim left it: before the first step and after it, stepped with the trim command, q, Nz
    and the accelerations are those of the same aircraft trimmed by FGTrim alone, to the bit
    (the calibration in place gave the 737 Nz = 1.165 before the first step and
    q = 5.6e-5 rad/s after it)."""
    plant = new_plant(model, dt_s)
    plant.trim(altitude_ft, speed_kcas=speed_kcas, surface="aileron")
    bare = fgtrim_alone(new_plant(model, dt_s).fdm, altitude_ft, ("ic/vc-kts", speed_kcas))
    assert [plant.fdm[p] for p in FIRST_STEP] == [bare[p] for p in FIRST_STEP]
    drive = plant.drive()
    out = np.empty((1, 0))
    JSBSimWorld(plant).fly_commands(np.array([drive.trim_command]), [], out)
    bare.run()
    assert [plant.fdm[p] for p in FIRST_STEP] == [bare[p] for p in FIRST_STEP]
    assert abs(plant.fdm["velocities/q-rad_sec"]) < 1e-8


def fgtrim_alone(
    fdm,
    altitude_ft: float,
    speed: tuple[str, float],
    gamma_deg: float = 0.0,
    case: int | None = None,
):
    """``fdm`` (a fresh plant's JSBSim, untouched by the project) trimmed by JSBSim's FGTrim
    alone at the condition (``speed``: its ``ic/`` property and value), gear up, engines
    running, wings level; ``case``: NASA's damage case set first (the GTM's ``damage/case``)."""
    if case is not None:
        fdm["damage/case"] = case
    for prop, value in (
        ("ic/h-sl-ft", altitude_ft),
        speed,
        ("ic/gamma-deg", gamma_deg),
        ("ic/beta-deg", 0.0),
        ("ic/phi-deg", 0.0),
        ("gear/gear-cmd-norm", 0.0),
        ("propulsion/set-running", -1),
    ):
        fdm[prop] = value
    assert fdm.run_ic()
    fdm.do_trim(1)  # FGTrim's tFull
    return fdm


def _inet_sockets_of(code: str) -> list[tuple[str, str]]:
    """Run ``code`` in a child process and list the TCP/UDP sockets it holds open."""
    code += "\nimport os, sys\nprint(os.getpid()); sys.stdout.flush(); sys.stdin.read()\n"
    env = {**os.environ, "JSBSIM_DEBUG": "0"}
    proc = subprocess.Popen(
        [sys.executable, "-c", code],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        pid = proc.stdout.readline().strip()
        assert pid.isdigit(), "child failed before reporting its pid"
        inodes = set()
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except FileNotFoundError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
        found = []
        for table in ("/proc/net/tcp", "/proc/net/tcp6", "/proc/net/udp", "/proc/net/udp6"):
            for line in Path(table).read_text().splitlines()[1:]:
                fields = line.split()
                if fields[9] in inodes:
                    found.append((table, fields[1]))
        return found
    finally:
        proc.communicate("", timeout=60)


def test_no_listening_socket() -> None:
    """The stock 737 declares <input port="5137"/>; the sanitised copy must not open it."""
    sanitised = (
        "from probing.sim.plant import Plant\n"
        "p = Plant('737', 0.01); p.trim(15000, speed_kcas=280)\n"
        "p2 = Plant('c172x', 0.01); p2.fdm.run_ic(); p2.fdm.run()\n"  # input port, socket outputs
    )
    assert _inet_sockets_of(sanitised) == []
    # The unsanitised stock model does listen, so the check above can fail.
    stock = (
        "import jsbsim\n"
        "f = jsbsim.FGFDMExec(jsbsim.get_default_root_dir()); f.set_debug_level(0)\n"
        "f.load_model('737'); f.run_ic()\n"  # FGInput opens its socket at run_ic
    )
    assert any(local.endswith(":1411") for _, local in _inet_sockets_of(stock))  # 5137 = 0x1411


# ------------------------------------------------------------ the outputs
def test_single_pulse_matches_linearisation() -> None:
    """The two truths of the 737 (Fig. 4's set-up: t0 = dt = 0.01 s, 511 taps) agree within
    2 % on every channel: the linearisation stepped as JSBSim steps the aircraft, the first
    tap zero in both (the airframe answers one step after the surface moves).  Without
    that one-step delay q is 18 % off (docs/truth.md)."""
    lin = linear_pulse_response(FLIGHT_737, CHANNELS, 0.01, 511)
    pulse = single_pulse_response(FLIGHT_737, CHANNELS, 0.005, 1, 511)
    for c in CHANNELS:
        assert pulse[c][0] == 0.0 and abs(lin[c][0]) < 1e-12 * np.abs(lin[c]).max(), c
        assert rel_l2(pulse[c], lin[c]) < 0.02, (c, rel_l2(pulse[c], lin[c]))
    assert rel_l2(pulse["q_rad_s"][1:], lin["q_rad_s"][:-1]) > 0.1  # a tap early: far off


def test_elevator_gain_matches_a_finite_difference_of_the_realised_surface(new_plant) -> None:
    """The slope used to scale FGLinearization's DeCmd column, checked on the FCS itself."""
    plant = new_plant("A320", 0.01)
    trim = plant.trim(15000, speed_kcas=280)
    plant.fdm.suspend_integration()
    try:
        plant.fdm["fcs/elevator-cmd-norm"] = trim.elevator_cmd_norm - 1e-4
        plant.fdm.run()
        below = plant.fdm["fcs/elevator-pos-deg"]
    finally:
        plant.fdm["fcs/elevator-cmd-norm"] = trim.elevator_cmd_norm
        plant.fdm.run()
        plant.fdm.resume_integration()
    slope = (trim.elevator_deg - below) / 1e-4
    assert plant.drive().gain_per_norm() == pytest.approx(slope, rel=1e-9)


def test_a320_elevator_is_exact_across_the_kink_at_zero_deflection(new_plant) -> None:
    """The A320 scales nose-up and nose-down commands differently, so its surface map has a
    kink at 0 deg: the calibration grid must hold that point, or deflections near 0 are off
    by a hundredth of a degree."""
    plant = new_plant("A320", 0.01)
    plant.trim(15000, speed_kcas=280)
    asked = np.array([-0.0004, -0.0001, 0.0, 0.0001, 0.0004, 0.003, -0.003])
    realised = np.empty(asked.size)
    out = np.empty((asked.size, 1))
    world, node = JSBSimWorld(plant), plant.channel_nodes(["theta_rad"])[0]
    for k in range(asked.size):  # one step each, from wherever the last left the surface
        world.fly_commands(plant.drive().command(asked[k : k + 1]), [node],
                           out[k : k + 1], realised[k : k + 1])  # fmt: skip
    np.testing.assert_allclose(realised, asked, rtol=0, atol=1e-12)


@pytest.mark.parametrize("chunks", [(60,), (29, 1, 30), (30, 30), (31, 29)])
def test_a_scheduled_damage_is_switched_on_at_the_step_that_starts_at_its_onset(chunks) -> None:
    """GTM, NASA's case 5 at 0.3 s = step 30 (dt 0.01 s): JSBSim's own ``damage/case`` read
    after each step is 0 up to step 29 and 5 from step 30 on, whether the steps come in one
    call or in calls that end just before, at or just after the onset."""
    from probing.sim.plant import make_plant

    flight = Flight("gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, damage_case=5, damage_onset_s=0.3)
    plant = make_plant(flight)
    node = plant.fdm.get_property_manager().get_node("damage/case")
    out = np.empty((sum(chunks), 1))
    start = 0
    for n in chunks:
        JSBSimWorld(plant).fly_commands(None, [node], out[start : start + n])
        start += n
    assert np.array_equal(out[:, 0], np.where(np.arange(60) >= 30, 5.0, 0.0))


@pytest.mark.parametrize(
    ("onset_s", "step"), [(None, None), (0.0, 0), (0.5, 50), (0.504, 50), (0.506, 51)]
)
def test_the_damage_onset_is_the_step_that_starts_there(onset_s, step):
    """The first damaged step of a damage in flight, counted from the trim in steps of
    0.01 s: the step that starts at (the nearest to) the onset; none without one.  Both
    JSBSim worlds switch the damage on at it (the plant's schedule, the live world's frame)."""
    flight = Flight(
        "gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, damage_case=2, damage_onset_s=onset_s
    )
    assert flight.damage_onset_step == step
