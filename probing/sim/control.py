"""The autopilot's control power, and an aircraft in this process flown by its autopilot.

:func:`control_power` measures the aircraft's control power at its trim (JSBSim's
linearisation), from which :class:`probing.sim.autopilot.Autopilot` places its loops' poles.
A :class:`ClosedLoop` is a :class:`~probing.sim.world.JSBSimWorld` flown by an
:class:`~probing.sim.autopilot.Autopilot` that knows it (its trim, its actuator's map, its
sensors): what a reference twin, the gust twin, the single-pulse truth and a manoeuvre's
aircraft fly, through the one stepping function (:meth:`JSBSimWorld.fly`).

With every loop open and no actuator fault, :meth:`ClosedLoop.step` steps exactly as an
open-loop history of the same surface deflections does (tested bit for bit).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from probing.sim.autopilot import LOOP_CHANNELS, Autopilot, AutopilotTrim, ControlPower
from probing.sim.flight import ActuatorFault, Control, Flight, Manoeuvre
from probing.sim.fork import trim_key
from probing.sim.plant import Plant, trim_flight
from probing.sim.sensing import Sensing
from probing.sim.surfaces import DEFAULT_SURFACE
from probing.sim.world import JSBSimWorld

__all__ = ["ClosedLoop", "ControlPower", "autopilot_for", "control_power", "trim_of"]


#: Control power by :func:`~probing.sim.fork.trim_key`: the trimmed state is all it depends
#: on, so flights that differ in turbulence, seed, fault or reference share one entry (keyed
#: by the flight itself, each new seed measured it again, in every forked run).
_POWER: dict[str, ControlPower] = {}


def _control_power(key: str, flight: Flight) -> ControlPower:
    power = _POWER.get(key)
    if power is None:
        power = _POWER[key] = _measured_power(flight)
    return power


def _measured_power(flight: Flight) -> ControlPower:
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


def trim_of(world: JSBSimWorld) -> AutopilotTrim:
    """What the flight computer knows of ``world``'s trim and of its probed surface's
    actuator (the calibrated map)."""
    elevator_deg, aileron_norm, throttle_norm = world.trimmed_commands()
    drive = world.drive
    return AutopilotTrim(
        elevator_deg,
        aileron_norm,
        throttle_norm,
        drive.surface.name,
        drive.trim_position,
        drive.position_of,
    )


def autopilot_for(
    world: Any,
    control: Control,
    power: ControlPower | None,
    manoeuvre: Manoeuvre | None = None,
    *,
    trim: AutopilotTrim | None = None,
) -> Autopilot:
    """The autopilot of ``world``'s aircraft, flying on its sensors (its ``reader(channel)``,
    a :class:`JSBSimWorld`'s or a separate simulator's), its references read now (at the
    trim); its trim and probed surface's map ``trim``, by default the world's own
    (:func:`trim_of`)."""
    reads = {c: world.reader(c) for c in LOOP_CHANNELS}
    trim = trim if trim is not None else trim_of(world)
    return Autopilot(control, power, trim, reads, world.dt_s, manoeuvre)


class ClosedLoop:
    """A trimmed plant flown by its autopilot, with the probe path on one surface.

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
        trim's measurements).  None: the loops read JSBSim's states.
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
        self.plant, self.control, self.fault, self.sensing = plant, control, fault, sensing
        self.world = JSBSimWorld(plant, surface, fault=fault, sensing=sensing)
        self.autopilot = autopilot_for(self.world, control, power, manoeuvre)
        self.dt_s = plant.dt_s
        self.drive = self.world.drive

    def step(
        self,
        probe: np.ndarray | None,
        nodes: list,
        out: np.ndarray,
        position: np.ndarray | None = None,
        **options: Any,
    ) -> None:
        """Run ``out.shape[0]`` steps of this autopilot with ``probe`` on its surface
        (``out[k, j]`` is channel j read right after step k): :meth:`JSBSimWorld.fly_probe`
        with this loop's autopilot, its ``options`` (``control``, ``commands``, ``measured``,
        ``inputs``) passed on."""
        self.world.fly_probe(self.autopilot, probe, nodes, out, position=position, **options)

    def replay(self, commands: np.ndarray, nodes: list, out: np.ndarray) -> None:
        """Fly another aircraft's autopilot commands (:meth:`step`'s ``commands``) through
        this plant's healthy actuator: the nominal twin of ``drift = "follow"``, which then
        differs from the probed aircraft only by what the probe and a fault did.

        Parameters
        ----------
        commands : numpy.ndarray
            ``(n, 3)``: elevator (deg from trim), aileron and throttle (normalised).
        nodes : list
            Property nodes of the channels.
        out : numpy.ndarray
            ``(n, len(nodes))``, filled in place.
        """
        world = self.world
        table = world.replay_table(commands)
        world.fly(len(table), nodes, out, table=table, setters=world.command_setters())
