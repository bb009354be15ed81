"""The flight computer's control law: the autopilot on measurements, and the probe added on
the probed surface.

An :class:`Autopilot` is what the aircraft's computer does between two steps: it reads the
latest measurement of the channels its loops fly on (:data:`probing.sim.flight.LOOP_SENSORS`),
closes the loops :class:`~probing.sim.flight.Control` asks for, and hands the world
(:mod:`probing.sim.world`) the step's demands:

* the probed surface's position (its unit): the position its loop asks (the trim's where no
  loop drives it) plus the probe path's deflection of the step;
* the elevator's position (deg), where the pitch loop drives it and it is not the probed one;
* the aileron and throttle commands (normalised), where their loops drive them and they are
  not the probed one.

Each loop is a PID that places the poles of its axis modelled as a double integrator (pitch,
bank: ``x'' = K u``) or an integrator (speed: ``V' = K u``), with K the aircraft's control
power at the trim (JSBSim's linearisation, :func:`probing.sim.control.control_power`):

    u_pitch = -(w^2 e + 2 zeta w q + w^2 / T_i * integral(e)) / M_de,   e = theta - theta_trim

and alike for bank (phi, p, L_da) and speed (V, first order: u = -(w e + w / T_i integral(e))
/ X_th).  One set of bandwidths therefore suits the sub-scale GTM (M_de = -0.73 rad/s^2 per
deg) and a 737 (-0.036) alike; the aircraft's own stiffness and damping add to the loop's.

It knows only what a flight computer knows: its measurements (read through the callables it
is given), its trim (:class:`AutopilotTrim`) and its actuator's command-to-position map.  No
JSBSim here: the same object flies an aircraft in this process, in a separate JSBSim process
and (recomputing its commands) a recorded log.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import astuple, dataclass

from probing.sim.flight import Control, Manoeuvre

__all__ = [
    "COMMAND_COLUMNS",
    "LOOP_CHANNELS",
    "Autopilot",
    "AutopilotTrim",
    "ControlPower",
    "Demand",
    "Gains",
    "gains",
]

#: The commands the autopilot flies, as a log records them (elevator deg from trim, before the
#: probe and the actuator; aileron and throttle normalised): :attr:`Autopilot.commands_record`.
COMMAND_COLUMNS = ("autopilot_elevator_deg", "autopilot_aileron_norm", "autopilot_throttle_norm")

#: The channels the loops read, in the order :meth:`Autopilot.law` reads them.
LOOP_CHANNELS = ("theta_rad", "q_rad_s", "phi_rad", "p_rad_s", "vt_fps")

#: One step's demands: the probed surface's position (its unit), the elevator's position
#: (deg) or None, the aileron and throttle commands (normalised) or None (not written).
Demand = tuple[float, float | None, float | None, float | None]


@dataclass(frozen=True)
class ControlPower:
    """The aircraft's control power at a trim, from JSBSim's linearisation.

    Attributes
    ----------
    pitch_rad_s2_per_deg : float
        d(q')/d(elevator), rad/s^2 per deg of surface deflection.
    roll_rad_s2_per_norm : float
        d(p')/d(aileron command), rad/s^2 per unit of normalised command.
    speed_fps2_per_norm : float
        d(V')/d(throttle command on every engine), ft/s^2 per unit.
    """

    pitch_rad_s2_per_deg: float
    roll_rad_s2_per_norm: float
    speed_fps2_per_norm: float


@dataclass(frozen=True)
class AutopilotTrim:
    """What the flight computer knows of its trim and of the probed surface's actuator.

    Attributes
    ----------
    elevator_deg : float
        The elevator's trimmed position, deg.
    aileron_norm, throttle_norm : float
        The trimmed aileron and throttle commands (normalised).
    surface : str
        The probed surface (:data:`probing.sim.surfaces.SURFACES`).
    surface_trim : float
        The probed surface's trimmed position, its unit.
    position_of : callable
        The probed surface's command -> position map (its actuator's, as calibrated).
    """

    elevator_deg: float
    aileron_norm: float
    throttle_norm: float
    surface: str
    surface_trim: float
    position_of: Callable[[float], float]


@dataclass(frozen=True)
class Gains:
    """The PID gains of the three loops (see the module docstring)."""

    kp_pitch: float
    kd_pitch: float
    ki_pitch: float
    kp_bank: float
    kd_bank: float
    ki_bank: float
    kp_speed: float
    ki_speed: float


def gains(control: Control, power: ControlPower) -> Gains:
    """The gains that place each closed loop's poles (module docstring)."""
    wp, wb, wv = (
        control.pitch_bandwidth_rad_s,
        control.bank_bandwidth_rad_s,
        control.speed_bandwidth_rad_s,
    )
    zeta = control.damping
    ti = control.integral_time_s
    m, ell, x = power.pitch_rad_s2_per_deg, power.roll_rad_s2_per_norm, power.speed_fps2_per_norm
    inv_ti = 1.0 / ti if ti > 0 else 0.0
    return Gains(
        kp_pitch=wp**2 / m,
        kd_pitch=2 * zeta * wp / m,
        ki_pitch=wp**2 * inv_ti / m,
        kp_bank=wb**2 / ell,
        kd_bank=2 * zeta * wb / ell,
        ki_bank=wb**2 * inv_ti / ell,
        kp_speed=wv / x,
        ki_speed=wv * inv_ti / x,
    )


class Autopilot:
    """The autopilot on measurements, with the probe added on the probed surface.

    Parameters
    ----------
    control : Control
        The loops to close (all open is allowed: the probed surface is then held at its trim
        plus the probe).
    power : ControlPower or None
        The aircraft's control power; needed when a loop is closed.
    trim : AutopilotTrim
        The trim and the probed surface's actuator map.
    reads : mapping
        Channel -> a callable giving its latest measurement, for :data:`LOOP_CHANNELS`: what
        the loops fly on.  Their values now are the loops' references (the trim's
        measurements).
    dt_s : float
        The step, s.
    manoeuvre : Manoeuvre or None
        Moves one loop's reference along its schedule (the loop must be closed).

    Raises
    ------
    ValueError
        If a loop is closed without ``power``, or the manoeuvre's loop is open.
    """

    def __init__(
        self,
        control: Control,
        power: ControlPower | None,
        trim: AutopilotTrim,
        reads: Mapping[str, Callable[[], float]],
        dt_s: float,
        manoeuvre: Manoeuvre | None = None,
    ) -> None:
        if control.active and power is None:
            raise ValueError("a closed loop needs the aircraft's control power")
        if manoeuvre is not None and not getattr(control, f"{manoeuvre.hold}_hold"):
            raise ValueError(f"a {manoeuvre.hold} manoeuvre needs {manoeuvre.hold}_hold")
        self.control, self.trim, self.dt_s, self.manoeuvre = control, trim, float(dt_s), manoeuvre
        self.reads = tuple(reads[c] for c in LOOP_CHANNELS)
        self.references = tuple(read() for read in self.reads)
        self.gains = gains(control, power) if control.active and power is not None else None
        self.integral = [0.0, 0.0, 0.0]  # pitch, bank, speed
        self.now = [trim.aileron_norm, trim.throttle_norm]  # the last aileron, throttle
        #: After :meth:`law`'s steps: the command of the probed surface (its unit, from trim;
        #: 0 where no loop drives it) and the commands flown (elevator deg from trim, aileron,
        #: throttle), where asked for.
        self.control_record: list[float] = []
        self.commands_record: list[tuple[float, float, float]] = []

    # The per-step law is a closure with every lookup bound to a local: it runs once per
    # simulation step (~20 us each), where a method's attribute lookups would cost more than
    # its arithmetic (docs/benchmarks.md, "Step-loop efficiency").
    def law(
        self,
        first: int,
        n: int,
        probe: list[float] | None,
        *,
        record_control: bool = False,
        record_commands: bool = False,
    ) -> Callable[[int], Demand]:
        """The demands of steps ``first .. first + n - 1``: ``law(k)`` for the k-th of them,
        called once per step, in order, after the measurements of the step before.

        Parameters
        ----------
        first : int
            The index of the first step since the trim (the manoeuvre's schedule).
        n : int
            Steps.
        probe : list of float or None
            The probe path's deflection of each step (the probe after its nonlinearity),
            in the probed surface's unit; None: no probe.
        record_control, record_commands : bool
            Keep the steps' command of the probed surface (:attr:`control_record`) and the
            commands flown (:attr:`commands_record`), both cleared here.
        """
        get_theta, get_q, get_phi, get_p, get_v = self.reads
        base = (self.references[0], self.references[2], self.references[4])  # theta, phi, v
        moving = self.manoeuvre.offsets(first, n, self.dt_s).tolist() if self.manoeuvre else None
        c, g, integral, dt, now = self.control, self.gains, self.integral, self.dt_s, self.now
        holds = (c.pitch_hold, c.bank_hold, c.speed_hold)
        pitch_on, bank_on, speed_on = (g is not None and hold for hold in holds)
        # the PIDs' gains as locals: the laws below are the module docstring's, a step each
        kp_p, kd_p, ki_p, kp_b, kd_b, ki_b, kp_v, ki_v = astuple(g) if g else (0.0,) * 8
        trim = self.trim
        probed, position_of, trim_pos = trim.surface, trim.position_of, trim.surface_trim
        trim_deg, aileron0, throttle0 = trim.elevator_deg, trim.aileron_norm, trim.throttle_norm
        # the loop whose surface is the probed one writes through the probe path
        write_el = probed != "elevator" and pitch_on
        write_ail = probed != "aileron" and bank_on
        write_thr = probed != "throttle" and speed_on
        # which loop's command is the probed surface's position
        by_elevator = probed == "elevator"
        by_aileron = probed == "aileron" and bank_on
        by_throttle = probed == "throttle" and speed_on
        kept = self.control_record if record_control else None
        flown = self.commands_record if record_commands else None
        for record in (kept, flown):
            if record is not None:
                record.clear()

        def law(k: int) -> Demand:
            theta_ref, phi_ref, v_ref = base
            if moving is not None:
                theta_ref, phi_ref, v_ref = (r + o for r, o in zip(base, moving[k], strict=True))
            u_el = 0.0
            ail, thr = now
            if pitch_on:
                e = get_theta() - theta_ref
                integral[0] += e * dt
                u_el = -(kp_p * e + kd_p * get_q() + ki_p * integral[0])
            if bank_on:
                e = get_phi() - phi_ref
                integral[1] += e * dt
                u_ail = kp_b * e + kd_b * get_p() + ki_b * integral[1]
                ail = min(max(aileron0 - u_ail, -1.0), 1.0)
            if speed_on:
                e = get_v() - v_ref
                integral[2] += e * dt
                thr = min(max(throttle0 - (kp_v * e + ki_v * integral[2]), 0.0), 1.0)
            now[0], now[1] = ail, thr
            if by_elevator:
                asked = trim_deg + u_el
            elif by_aileron:
                asked = position_of(ail)
            elif by_throttle:
                asked = position_of(thr)
            else:
                asked = trim_pos
            if kept is not None:
                kept.append(u_el if by_elevator else asked - trim_pos)
            if flown is not None:
                flown.append((u_el, ail, thr))
            return (
                asked + (probe[k] if probe is not None else 0.0),
                trim_deg + u_el if write_el else None,
                ail if write_ail else None,
                thr if write_thr else None,
            )

        return law
