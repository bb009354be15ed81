"""The autopilot's law (probing.sim.autopilot) without an aircraft: made-up measurements, a
made-up trim and actuator map, the commands checked against the module docstring's PID by
hand and the record of the probed surface's command against the trim it is taken from."""

from __future__ import annotations

import pytest

from probing.sim.autopilot import Autopilot, AutopilotTrim, ControlPower
from probing.sim.flight import Control

DT_S = 0.01
POWER = ControlPower(pitch_rad_s2_per_deg=-0.7, roll_rad_s2_per_norm=-2.0, speed_fps2_per_norm=5.0)
TRIMMED = {"theta_rad": 0.05, "q_rad_s": 0.0, "phi_rad": 0.0, "p_rad_s": 0.0, "vt_fps": 120.0}
#: The trimmed commands, and each surface's made-up command -> position map (its unit).
TRIM = {"elevator": 1.5, "aileron": 0.1, "throttle": 0.6}
MAPS = {
    "elevator": lambda deg: deg,
    "aileron": lambda norm: 25.0 * norm + 0.3,  # deg: 2.8 at the trim
    "throttle": lambda norm: 0.9 * norm + 0.05,  # 0.59 at the trim
}


def _autopilot(surface: str, control: Control, measured: dict[str, float]) -> Autopilot:
    """An autopilot probing ``surface``, its references read from ``measured`` now."""
    position_of = MAPS[surface]
    trim = AutopilotTrim(
        TRIM["elevator"],
        TRIM["aileron"],
        TRIM["throttle"],
        surface,
        position_of(TRIM[surface]),
        position_of,
    )
    reads = {c: (lambda c=c: measured[c]) for c in TRIMMED}
    return Autopilot(control, POWER, trim, reads, DT_S)


def _bank_and_speed_commands(e_phi: float, p: float, e_v: float) -> tuple[float, float]:
    """The aileron and throttle of the first step of a bank error ``e_phi`` (rad) with roll
    rate ``p`` (rad/s) and a speed error ``e_v`` (ft/s), by the module docstring's laws."""
    c = Control()
    wb, wv, ti, zeta = c.bank_bandwidth_rad_s, c.speed_bandwidth_rad_s, c.integral_time_s, 0.8
    ell, x = POWER.roll_rad_s2_per_norm, POWER.speed_fps2_per_norm
    u_ail = (wb**2 * e_phi + 2 * zeta * wb * p + wb**2 / ti * e_phi * DT_S) / ell
    u_thr = (wv * e_v + wv / ti * e_v * DT_S) / x
    return TRIM["aileron"] - u_ail, TRIM["throttle"] - u_thr


@pytest.mark.parametrize("surface", ["aileron", "throttle"])
def test_the_probed_surfaces_command_is_recorded_as_its_change_from_trim(surface):
    """Probing the aileron or the throttle with its loop closed: a step at the trim records
    0 (not the trimmed position); off trim the record is the map's position of the loop's
    command, computed here, less the trimmed position, and what the law demands of the
    surface is that record plus the trim plus the probe, step by step."""
    measured = dict(TRIMMED)
    autopilot = _autopilot(surface, Control(bank_hold=True, speed_hold=True), measured)
    probe = [0.2, -0.2, 0.2]
    law = autopilot.law(0, 3, probe, record_control=True)
    demands = [law(0)]  # at the trim: every error 0
    measured.update(phi_rad=0.02, p_rad_s=0.01, vt_fps=121.0)
    demands.append(law(1))
    measured.update(phi_rad=-0.03, p_rad_s=0.0, vt_fps=119.0)
    demands.append(law(2))
    record = autopilot.control_record
    position_of, trim_position = MAPS[surface], MAPS[surface](TRIM[surface])
    assert record[0] == 0.0 and trim_position != 0.0
    # step 1: the integrators hold the error of one step (step 0's was 0)
    aileron, throttle = _bank_and_speed_commands(0.02, 0.01, 1.0)
    command = aileron if surface == "aileron" else throttle
    assert record[1] == pytest.approx(position_of(command) - trim_position, rel=1e-12)
    assert record[1] != 0.0
    for k, (asked, _, aileron_norm, throttle_norm) in enumerate(demands):
        assert asked == pytest.approx(trim_position + record[k] + probe[k], rel=1e-12, abs=1e-15)
        # the probed surface's loop writes through the probe path, the other on its own
        written = {"aileron": aileron_norm, "throttle": throttle_norm}
        assert written.pop(surface) is None and None not in written.values()


@pytest.mark.parametrize("surface", ["aileron", "throttle"])
def test_a_probed_surface_no_loop_drives_records_0_and_is_held_at_trim(surface):
    """Its loop open, the probed surface is held at its trim: the record is 0 at every step
    and the demand is the trimmed position plus the probe, whatever is measured."""
    measured = dict(TRIMMED)
    autopilot = _autopilot(surface, Control(pitch_hold=True), measured)
    law = autopilot.law(0, 2, [0.1, -0.1], record_control=True)
    measured.update(phi_rad=0.02, vt_fps=125.0, theta_rad=0.06)
    demands = [law(0), law(1)]
    trim_position = MAPS[surface](TRIM[surface])
    assert autopilot.control_record == [0.0, 0.0]
    assert [d[0] for d in demands] == [trim_position + 0.1, trim_position - 0.1]


def test_the_elevators_record_is_the_pitch_loops_command_from_trim():
    """Probing the elevator: the record is the pitch loop's command (deg from trim), 0 at
    the trim, -(kp e + ki e dt) / M_de at a pitch error e without pitch rate."""
    measured = dict(TRIMMED)
    autopilot = _autopilot("elevator", Control(pitch_hold=True), measured)
    law = autopilot.law(0, 2, None, record_control=True)
    first = law(0)
    measured["theta_rad"] = TRIMMED["theta_rad"] + 0.01
    second = law(1)
    c = Control()
    w, ti, m = c.pitch_bandwidth_rad_s, c.integral_time_s, POWER.pitch_rad_s2_per_deg
    u_el = -(w**2 * 0.01 + w**2 / ti * 0.01 * DT_S) / m
    assert autopilot.control_record[0] == 0.0
    assert autopilot.control_record[1] == pytest.approx(u_el, rel=1e-12)
    assert (first[0], second[0]) == (TRIM["elevator"], pytest.approx(TRIM["elevator"] + u_el))
