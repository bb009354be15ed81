"""A simple autopilot for closed-loop flights, with the probe between it and the surface.

The paper's Fig. 1 injects the probe between the command and the surface.  A
:class:`ClosedLoop` steps a trimmed :class:`~probing.sim.plant.Plant` one step at a time:
before each step it reads the aircraft's state, computes the loops that
:class:`~probing.sim.flight.Control` closes, and writes

* elevator: trim + pitch-hold command (deg of surface);
* aileron: trim + bank-hold command (normalised);
* throttle: trim + speed-hold command, on every engine (normalised, clipped to 0..1);
* and on the *probed* surface (:mod:`probing.sim.surfaces`, the elevator by default) the
  position its loop asks (trim where no loop drives it) + the probe path's deflection (the
  probe after its nonlinearity), through the actuator fault if one has begun, as the exact
  position (the plant's calibrated map, :class:`~probing.sim.plant.SurfaceDrive`).

Each loop is a PID that places the poles of its axis modelled as a double integrator (pitch,
bank: ``x'' = K u``) or an integrator (speed: ``V' = K u``), with K the aircraft's control
power at the trim (JSBSim's linearisation, :func:`control_power`):

    u_pitch = -(w^2 e + 2 zeta w q + w^2 / T_i * integral(e)) / M_de,   e = theta - theta_trim

and alike for bank (phi, p, L_da) and speed (V, first order: u = -(w e + w / T_i integral(e))
/ X_th).  One set of bandwidths therefore suits the sub-scale GTM (M_de = -0.73 rad/s^2 per
deg) and a 737 (-0.036) alike; the aircraft's own stiffness and damping add to the loop's.

With every loop open and no actuator fault, :meth:`ClosedLoop.step` steps exactly as
:meth:`Plant.step` does with the same surface deflections (tested bit for bit).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from probing.core.faults import onset_step
from probing.sim.flight import ActuatorFault, Control, Flight, Manoeuvre
from probing.sim.fork import trim_key
from probing.sim.plant import Plant, SurfaceDrive, trim_flight
from probing.sim.sensing import Sensing
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = ["ClosedLoop", "ControlPower", "control_power"]

_THETA, _Q = "attitude/theta-rad", "velocities/q-rad_sec"
_PHI, _P = "attitude/phi-rad", "velocities/p-rad_sec"
_VT = "velocities/vt-fps"
#: The channel that measures each state the loops fly on (with a :class:`Sensing`).
_SENSED = {_THETA: "theta_rad", _Q: "q_rad_s", _PHI: "phi_rad", _P: "p_rad_s", _VT: "vt_fps"}
_AILERON = SURFACES["aileron"].command


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


@functools.lru_cache(maxsize=8)
def _control_power(key: str, flight: Flight) -> ControlPower:
    plant = Plant(flight.model, flight.dt_s)  # a throwaway copy: linearising moves the state
    trim_flight(plant, flight)
    lin = plant.linearise()
    b, x, u = lin["B"], lin["x_names"], lin["u_names"]
    return ControlPower(
        pitch_rad_s2_per_deg=float(b[x.index("Q"), u.index("DeCmd")])
        / plant.drive().gain_per_norm(),
        roll_rad_s2_per_norm=float(b[x.index("P"), u.index("DaCmd")]),
        speed_fps2_per_norm=float(b[x.index("Vt"), u.index("ThtlCmd")]),
    )


def control_power(flight: Flight) -> ControlPower:
    """The control power of ``flight``'s aircraft at its trim (remembered per trimmed state).

    Computed on a copy of the aircraft loaded and trimmed for the purpose, because JSBSim's
    linearisation leaves the state it linearised about moved by ~1e-8; call it before
    forking runs so that they inherit it.

    Raises
    ------
    probing.sim.errors.TrimError
        If the aircraft does not trim.
    ValueError
        If a control has no power (a loop on it could not be closed).
    """
    power = _control_power(trim_key(flight), flight)
    for name, value in vars(power).items():
        if not np.isfinite(value) or value == 0.0:
            raise ValueError(f"{flight.condition}: no control power ({name} = {value})")
    return power


class ClosedLoop:
    """A trimmed plant flown by the autopilot, with the probe path on one surface.

    Parameters
    ----------
    plant : Plant
        Trimmed (and disturbed, scheduled) plant; it is stepped.
    control : Control
        The loops to close (all open is allowed: the plant is then flown open loop one step
        at a time, with the actuator fault applied).
    power : ControlPower or None
        The aircraft's control power (:func:`control_power`); needed when a loop is closed.
    fault : ActuatorFault or None
        A fault of the probed surface's actuator from its onset on.
    surface : str
        The probed surface (:data:`probing.sim.surfaces.SURFACES`).
    manoeuvre : Manoeuvre or None
        Moves one loop's reference along its schedule (the loop must be closed); None holds
        every reference at its trimmed value.
    sensing : Sensing or None
        The aircraft's sensors: the loops fly on their measurements (the references are the
        trim's measurements), and :meth:`step` can hand them out.  None: the loops read
        JSBSim's states.
    """

    def __init__(
        self,
        plant: Plant,
        control: Control,
        power: ControlPower | None = None,
        fault: ActuatorFault | None = None,
        surface: str = DEFAULT_SURFACE,
        manoeuvre: Manoeuvre | None = None,
        sensing: Sensing | None = None,
    ) -> None:
        if control.active and power is None:
            raise ValueError("a closed loop needs the aircraft's control power")
        trim = plant.trim_result
        assert trim is not None, "trim first"
        self.plant, self.control, self.fault = plant, control, fault
        pm = plant.fdm.get_property_manager()
        self._get = {k: pm.get_node(k).get_double_value for k in (_THETA, _Q, _PHI, _P, _VT)}
        self.sensing = sensing
        if sensing is not None:
            self._get = {k: _measured(sensing, c) for k, c in _SENSED.items()}
        self._ref = {k: get() for k, get in self._get.items()}
        self._aileron = pm.get_node(_AILERON)
        self._aileron0 = self._aileron.get_double_value()
        throttle = SURFACES["throttle"].command_properties(plant.engine_count())
        self._throttles = [pm.get_node(p) for p in throttle]
        self._throttle0 = trim.throttle_norm
        self._trim_deg = trim.elevator_deg
        self._gains = _gains(control, power) if control.active else None
        self._integral = [0.0, 0.0, 0.0]  # pitch, bank, speed
        self._held: float | None = None  # the probed surface's position at the fault's onset
        self._aileron_now, self._throttle_now = self._aileron0, self._throttle0
        self.dt_s = plant.dt_s
        self.drive: SurfaceDrive = plant.drive(surface)
        if manoeuvre is not None and not getattr(control, f"{manoeuvre.hold}_hold"):
            raise ValueError(f"a {manoeuvre.hold} manoeuvre needs {manoeuvre.hold}_hold")
        self.manoeuvre = manoeuvre

    # The one function over 60 lines of code, on purpose: its loop runs once per simulation
    # step (~20 us each), so the loops, the fault and the damage onset are inlined with every
    # lookup bound to a local beforehand; a call per loop per step would cost more than the
    # step's own Python work (docs/benchmarks.md, "Step-loop efficiency").
    def step(
        self,
        probe: np.ndarray | None,
        nodes: list,
        out: np.ndarray,
        position: np.ndarray | None = None,
        control: np.ndarray | None = None,
        commands: np.ndarray | None = None,
        measured: np.ndarray | None = None,
        inputs: tuple[list, np.ndarray] | None = None,
    ) -> None:
        """Run ``out.shape[0]`` steps; ``out[k, j]`` is channel j read right after step k.

        Parameters
        ----------
        probe : numpy.ndarray or None
            The probe path's deflection (the probe after its nonlinearity) added to the
            probed surface at each step, in its unit, shape ``(n,)``; None: no probe (a
            reference twin).
        nodes : list
            Property nodes of the channels (:meth:`Plant.channel_nodes`).
        out : numpy.ndarray
            ``(n, len(nodes))``, filled in place.
        position : numpy.ndarray, optional
            ``(n,)``, receives the probed surface's realised position after each step.
        control : numpy.ndarray, optional
            ``(n,)``, receives the autopilot's command of the probed surface at each step
            (its unit, from trim; 0 where no loop drives it).
        commands : numpy.ndarray, optional
            ``(n, 3)``, receives the autopilot's commands at each step: elevator (deg from
            trim, before the probe and the actuator), aileron and throttle (normalised), for
            a twin that flies them (:meth:`replay`).
        measured : numpy.ndarray, optional
            ``(n, len(sensing.channels))``, receives the sensors' measurements after each
            step (needs ``sensing``).
        inputs : (list, numpy.ndarray), optional
            Property nodes and their values ``(n, len(nodes))``, written before each step
            (a gust twin's wind and rotational gusts).
        """
        plant, fdm = self.plant, self.plant.fdm
        n = out.shape[0]
        first = plant.steps_run
        damage_step = plant.damage_onset_step  # a scheduled damage (Plant.schedule), if any
        fault = self.fault
        onset = onset_step(fault.onset_s, self.dt_s) if fault is not None else -1
        g = self._get
        get_theta, get_q, get_phi, get_p, get_v = (g[k] for k in (_THETA, _Q, _PHI, _P, _VT))
        theta0, phi0, v0 = self._ref[_THETA], self._ref[_PHI], self._ref[_VT]
        gains, integral, dt = self._gains, self._integral, self.dt_s
        moving = self.manoeuvre.offsets(first, n, dt).tolist() if self.manoeuvre else None
        base = (theta0, phi0, v0)
        c = self.control
        elevator, drive = plant.drive(), self.drive
        probed = drive.surface.name
        set_el, command = elevator.set, elevator.command_clipped
        set_probed, probed_command = drive.set, drive.command_clipped
        get_pos = drive.pos_node.get_double_value
        position_of, trim_pos = drive.position_of, drive.trim_position
        # the loop whose command the probed surface carries writes it through the probe path
        set_ail = self._aileron.set_double_value if probed != "aileron" else None
        set_thr = [t.set_double_value for t in self._throttles] if probed != "throttle" else []
        write_el = probed != "elevator" and c.pitch_hold and gains is not None
        getters = [node.get_double_value for node in nodes]
        probe_list = probe.tolist() if probe is not None else None
        trim_deg, aileron0, throttle0 = self._trim_deg, self._aileron0, self._throttle0
        values: list[float] = []
        append = values.append
        realised: list[float] = []
        commanded: list[float] = []
        flown: list[tuple[float, float, float]] = []
        ail, thr = self._aileron_now, self._throttle_now
        run = fdm.run
        sensing = self.sensing
        if sensing is not None:  # the sensors after each step, the loops' inputs next step
            current, noise = sensing.current, sensing.noise(n)
            sense = list(zip([s.step for s in sensing.sensors], sensing.getters, strict=True))
            bias_at, bias, bias_onset = (
                sensing.fault_channel,
                sensing.fault_bias,
                sensing.fault_onset,
            )
        sensed: list[list[float]] = []
        if inputs is not None:
            setters = [node.set_double_value for node in inputs[0]]
            written = inputs[1].tolist()
        for k in range(n):
            step = first + k
            if inputs is not None:
                for put, value in zip(setters, written[k], strict=True):
                    put(value)
            u_el = 0.0
            if moving is not None:
                theta0, phi0, v0 = (r + o for r, o in zip(base, moving[k], strict=True))
            if gains is not None:
                if c.pitch_hold:
                    e = get_theta() - theta0
                    integral[0] += e * dt
                    u_el = gains.pitch(e, get_q(), integral[0])
                if c.bank_hold:
                    e = get_phi() - phi0
                    integral[1] += e * dt
                    ail = min(max(aileron0 + gains.bank(e, get_p(), integral[1]), -1.0), 1.0)
                    if set_ail is not None:
                        set_ail(ail)
                if c.speed_hold:
                    e = get_v() - v0
                    integral[2] += e * dt
                    thr = min(max(throttle0 + gains.speed(e, integral[2]), 0.0), 1.0)
                    for s in set_thr:
                        s(thr)
            if probed == "elevator":
                asked = trim_deg + u_el
            elif probed == "aileron" and gains is not None and c.bank_hold:
                asked = position_of(ail)
            elif probed == "throttle" and gains is not None and c.speed_hold:
                asked = position_of(thr)
            else:
                asked = trim_pos
            surface = asked + (probe_list[k] if probe_list is not None else 0.0)
            if step >= onset >= 0:
                if self._held is None:  # the position at the onset, before the fault acts
                    self._held = get_pos()
                surface = fault.position(surface, trim_pos, self._held)
            if write_el:
                set_el(command(trim_deg + u_el))
            set_probed(probed_command(surface))
            if step == damage_step:
                plant.start_scheduled_damage()
                damage_step = None
            run()
            if sensing is not None:
                row = [st(get(), e) for (st, get), e in zip(sense, noise[k], strict=True)]
                if bias_at is not None and step >= bias_onset:
                    row[bias_at] += bias
                current[:] = row
                sensed.append(row)
            for get in getters:
                append(get())
            if position is not None:
                realised.append(get_pos())
            if control is not None:
                commanded.append(u_el if probed == "elevator" else asked - trim_pos)
            if commands is not None:
                flown.append((u_el, ail, thr))
        self._aileron_now, self._throttle_now = ail, thr
        plant.count_steps(n)
        out[:] = np.array(values, dtype=np.float64).reshape(n, len(getters))
        if position is not None:
            position[:] = realised
        if control is not None:
            control[:] = commanded
        if commands is not None:
            commands[:] = flown
        if measured is not None:
            measured[:] = sensed

    def replay(self, commands: np.ndarray, nodes: list, out: np.ndarray) -> None:
        """Fly another aircraft's autopilot commands (:meth:`step`'s ``commands``) through
        this plant's healthy actuator, one step at a time: the nominal twin of
        ``drift = "follow"``, which then differs from the probed aircraft only by what the
        probe and a fault did.

        Parameters
        ----------
        commands : numpy.ndarray
            ``(n, 3)``: elevator (deg from trim), aileron and throttle (normalised).
        nodes : list
            Property nodes of the channels.
        out : numpy.ndarray
            ``(n, len(nodes))``, filled in place.
        """
        plant = self.plant
        n = out.shape[0]
        elevator = plant.drive()
        set_el = elevator.set
        set_ail = self._aileron.set_double_value
        set_thr = [t.set_double_value for t in self._throttles]
        getters = [node.get_double_value for node in nodes]
        trim_deg, command = self._trim_deg, elevator.command_clipped
        values: list[float] = []
        append = values.append
        run = plant.fdm.run
        for u_el, ail, thr in commands.tolist():
            set_el(command(trim_deg + u_el))
            set_ail(ail)
            for s in set_thr:
                s(thr)
            run()
            for get in getters:
                append(get())
        plant.count_steps(n)
        out[:] = np.array(values, dtype=np.float64).reshape(n, len(getters))


def _measured(sensing: Sensing, channel: str) -> Callable[[], float]:
    """A getter of the latest measurement of ``channel`` (NaN if no sensor measures it: a
    loop that flies on it is refused when the scenario is read)."""
    if channel not in sensing.channels:
        return lambda: math.nan
    current, j = sensing.current, sensing.index(channel)
    return lambda: current[j]


@dataclass(frozen=True)
class _Gains:
    """The PID gains of the three loops (see the module docstring)."""

    kp_pitch: float
    kd_pitch: float
    ki_pitch: float
    kp_bank: float
    kd_bank: float
    ki_bank: float
    kp_speed: float
    ki_speed: float

    def pitch(self, e: float, rate: float, integral: float) -> float:
        return -(self.kp_pitch * e + self.kd_pitch * rate + self.ki_pitch * integral)

    def bank(self, e: float, rate: float, integral: float) -> float:
        return -(self.kp_bank * e + self.kd_bank * rate + self.ki_bank * integral)

    def speed(self, e: float, integral: float) -> float:
        return -(self.kp_speed * e + self.ki_speed * integral)


def _gains(control: Control, power: ControlPower) -> _Gains:
    wp, wb, wv = (
        control.pitch_bandwidth_rad_s,
        control.bank_bandwidth_rad_s,
        control.speed_bandwidth_rad_s,
    )
    zeta = control.damping
    ti = control.integral_time_s
    m, ell, x = power.pitch_rad_s2_per_deg, power.roll_rad_s2_per_norm, power.speed_fps2_per_norm
    inv_ti = 1.0 / ti if ti > 0 else 0.0
    return _Gains(
        kp_pitch=wp**2 / m,
        kd_pitch=2 * zeta * wp / m,
        ki_pitch=wp**2 * inv_ti / m,
        kp_bank=wb**2 / ell,
        kd_bank=2 * zeta * wb / ell,
        ki_bank=wb**2 * inv_ti / ell,
        kp_speed=wv / x,
        ki_speed=wv * inv_ti / x,
    )
