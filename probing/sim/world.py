"""The world in this process: a trimmed JSBSim aircraft with its actuator, damage, turbulence
and sensors, stepped by the one stepping function of the project.

The flight computer (:class:`probing.sim.autopilot.Autopilot`, owned by
:class:`probing.experiment.flight.flight_computer.FlightComputer`) and the world meet once per step,
as ArduPilot's flight code meets its simulator: the computer hands the step's demands
(:data:`probing.sim.autopilot.Demand`), the world realises them through its actuator (the
probed surface's fault, :class:`~probing.sim.flight.ActuatorFault`, from its onset on; the
model's command-to-position map, :class:`~probing.sim.drive.SurfaceDrive`), switches a
scheduled damage case on at its onset step (:meth:`probing.sim.plant.Plant.schedule`), flies
one step through its turbulence (:meth:`probing.sim.plant.Plant.disturb`) and measures the
step with its sensors (:class:`probing.sim.sensing.Sensing`: noise, lag, the sensor fault),
which the computer reads before its next step (:meth:`JSBSimWorld.reader`).

:meth:`JSBSimWorld.fly` is the only caller of JSBSim's ``run()`` besides the trim and the
surfaces' calibration: a flight with its flight computer, a reference twin flying its own
autopilot or another aircraft's commands, the gust twin, the probe of several surfaces at
once and an open-loop surface history all go through it.  Its loop is written for speed
(every lookup bound to a local beforehand; one call of the computer's law per step).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from probing.core.faults import apply_sensor_fault, onset_step
from probing.sim.autopilot import Autopilot, Demand
from probing.sim.drive import SurfaceDrive
from probing.sim.flight import ActuatorFault
from probing.sim.plant import Plant
from probing.sim.sensing import Sensing
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = ["INTEGRATORS", "JSBSimWorld", "actuator_pulse_response", "flight_plan"]

_AILERON = SURFACES["aileron"].command


def flight_plan(
    autopilot: Autopilot | None,
    drive: SurfaceDrive,
    first_step: int,
    n: int,
    probe: np.ndarray | None,
    *,
    record_control: bool = False,
    record_commands: bool = False,
) -> tuple[Callable[[int], Demand] | None, np.ndarray | None]:
    """How a flight computer's demands for ``n`` steps from ``first_step`` on are flown, in
    every world: ``(law, None)``, its autopilot's law step by step
    (:meth:`Autopilot.law`, keeping what ``record_*`` ask), or where the aircraft has none
    ``(None, commands)``, the probed surface's normalised commands for the span at once
    (its trim plus ``probe`` through its map; None without a probe: the commands held)."""
    if autopilot is None:
        asked = None if probe is None else drive.command(drive.trim_position + probe)
        return None, asked
    law = autopilot.law(
        first_step,
        n,
        probe.tolist() if probe is not None else None,
        record_control=record_control,
        record_commands=record_commands,
    )
    return law, None


class JSBSimWorld:
    """A trimmed (and disturbed, scheduled) plant with its actuator and sensors.

    Parameters
    ----------
    plant : Plant
        The aircraft; it is stepped.
    surface : str
        The probed surface, whose demanded position passes through the actuator's fault.
    fault : ActuatorFault or None
        A fault of the probed surface's actuator from its onset on.
    sensing : Sensing or None
        The aircraft's sensors: what the flight computer reads.  None: it reads JSBSim's
        states as they are (perfect sensors).
    """

    def __init__(
        self,
        plant: Plant,
        surface: str = DEFAULT_SURFACE,
        *,
        fault: ActuatorFault | None = None,
        sensing: Sensing | None = None,
    ) -> None:
        assert plant.trim_result is not None, "trim first"
        self.plant, self.fault, self.sensing = plant, fault, sensing
        self.drive = plant.drive(surface)
        self.elevator = plant.drive()
        pm = plant.fdm.get_property_manager()
        self.aileron_node = pm.get_node(_AILERON)
        throttles = SURFACES["throttle"].command_properties(plant.engine_count())
        self.throttle_nodes = [pm.get_node(p) for p in throttles]
        self._held: float | None = None  # the probed surface's position at the fault's onset

    @property
    def dt_s(self) -> float:
        """The step, s."""
        return self.plant.dt_s

    def reader(self, channel: str) -> Callable[[], float]:
        """A callable giving the latest measurement of ``channel``: its sensor's (NaN if the
        suite has none: a loop flying on it is refused when the scenario is read), or without
        sensors JSBSim's value."""
        sensing = self.sensing
        if sensing is None:
            return self.plant.channel_nodes([channel])[0].get_double_value
        if channel not in sensing.channels:
            return lambda: math.nan
        current, j = sensing.current, sensing.index(channel)
        sensing.live.add(j)  # measured after every step; the others after each block
        return lambda: current[j]

    def trimmed_commands(self) -> tuple[float, float, float]:
        """The elevator's trimmed position (deg) and the aileron and throttle commands."""
        trim = self.plant.trim_result
        assert trim is not None
        return trim.elevator_deg, self.aileron_node.get_double_value(), trim.throttle_norm

    def command_setters(self) -> list[Callable[[float], None]]:
        """Writers of the elevator (normalised command), aileron and each engine's throttle:
        the columns of :meth:`replay_table`."""
        set_thr = [t.set_double_value for t in self.throttle_nodes]
        return [self.elevator.set, self.aileron_node.set_double_value, *set_thr]

    def replay_table(self, commands: np.ndarray) -> np.ndarray:
        """Another aircraft's autopilot commands ``(n, 3)`` (elevator deg from trim, aileron,
        throttle) as the rows :meth:`command_setters` write, through this aircraft's healthy
        actuator."""
        trim_deg = self.plant.trim_result.elevator_deg
        command = self.elevator.command_clipped
        engines = len(self.throttle_nodes)
        rows = [
            [command(trim_deg + u_el), ail, *([thr] * engines)]
            for u_el, ail, thr in commands.tolist()
        ]
        return np.array(rows, dtype=np.float64).reshape(len(rows), 2 + engines)

    def fly_commands(
        self,
        commands: np.ndarray | None,
        nodes: list,
        out: np.ndarray,
        position: np.ndarray | None = None,
    ) -> None:
        """Fly an open-loop history of the probed surface's normalised commands ``(n,)``
        (None: hold the commands the plant has, ``n = out.shape[0]``) through :meth:`fly`."""
        n = out.shape[0]
        if commands is None:
            self.fly(n, nodes, out, position=position)
            return
        table = np.asarray(commands, dtype=np.float64).reshape(-1, 1)
        self.fly(n, nodes, out, table=table, setters=[self.drive.set], position=position)

    def fly_probe(
        self,
        autopilot: Autopilot | None,
        probe: np.ndarray | None,
        nodes: list,
        out: np.ndarray,
        *,
        position: np.ndarray | None = None,
        control: np.ndarray | None = None,
        commands: np.ndarray | None = None,
        measured: np.ndarray | None = None,
        inputs: tuple[list, np.ndarray] | None = None,
    ) -> None:
        """Fly ``out.shape[0]`` steps of the flight computer's demands: through ``autopilot``
        step by step (:meth:`Autopilot.law`), or, where the aircraft has none, the probed
        surface at its trim plus ``probe`` a period at a time (:meth:`fly_commands`): the one
        place this choice is made (a flight, a twin, a single pulse).

        Parameters
        ----------
        autopilot : Autopilot or None
            The flight computer's law, flying on this world's measurements.
        probe : numpy.ndarray or None
            ``(n,)``: the probe path's deflection of each step, the probed surface's unit;
            None: no probe (a twin).
        nodes, out, position, measured
            As for :meth:`fly`.
        control, commands : numpy.ndarray, optional
            ``(n,)`` and ``(n, 3)``: receive the autopilot's command of the probed surface and
            the commands it flew (:attr:`Autopilot.control_record`, ``commands_record``).
        inputs : (list, numpy.ndarray), optional
            Property nodes and their values ``(n, len(nodes))``, written before each step
            (a gust twin's wind and rotational gusts).
        """
        n = out.shape[0]
        law, asked = flight_plan(
            autopilot,
            self.drive,
            self.plant.steps_run,
            n,
            probe,
            record_control=control is not None,
            record_commands=commands is not None,
        )
        if law is None:
            if inputs is not None or control is not None or commands is not None:
                raise ValueError("inputs, control and commands need an autopilot")
            self.fly_commands(asked, nodes, out, position)
            return
        table, setters = None, []
        if inputs is not None:
            setters = [node.set_double_value for node in inputs[0]]
            table = inputs[1]
        self.fly(
            n, nodes, out, law=law, table=table, setters=setters, position=position,
            measured=measured,
        )  # fmt: skip
        if control is not None:
            control[:] = autopilot.control_record
        if commands is not None:
            commands[:] = autopilot.commands_record

    # The one stepping function: over 60 lines on purpose, its loops run once per
    # simulation step (docs/benchmarks.md, "Step-loop efficiency").
    def fly(
        self,
        n: int,
        nodes: list,
        out: np.ndarray,
        *,
        law: Callable[[int], Demand] | None = None,
        table: np.ndarray | None = None,
        setters: Sequence[Callable[[float], None]] = (),
        position: np.ndarray | None = None,
        measured: np.ndarray | None = None,
    ) -> None:
        """Fly ``n`` steps; ``out[k, j]`` is channel j read right after step k.

        Parameters
        ----------
        n : int
            Steps.
        nodes : list
            Property nodes of the channels (:meth:`Plant.channel_nodes`).
        out : numpy.ndarray
            ``(n, len(nodes))``, filled in place.
        law : callable, optional
            The flight computer's law (:meth:`probing.sim.autopilot.Autopilot.law`): before
            step k, ``law(k)`` gives its demands, after the sensors measured step k - 1.
            None: nothing is demanded (the commands of ``table``, or those the plant has).
        table : numpy.ndarray, optional
            ``(n, len(setters))``: values written by ``setters`` before each step (normalised
            commands of an open-loop history or of another aircraft's autopilot, a gust twin's
            wind and gusts).
        setters : sequence of callables
            The writers of ``table``'s columns.
        position : numpy.ndarray, optional
            ``(n,)``, receives the probed surface's realised position after each step.
        measured : numpy.ndarray, optional
            ``(n, sensors)``, receives the sensors' measurements after each step (needs
            sensors and a ``law``).
        """
        plant = self.plant
        first = plant.steps_run
        damage_step = plant.damage_onset_step  # a scheduled damage (Plant.schedule), if any
        if damage_step is not None and damage_step < first:  # its onset has passed
            plant.start_scheduled_damage()
            damage_step = None
        getters = [node.get_double_value for node in nodes]
        rows = table.tolist() if table is not None else None
        if rows is not None and (len(rows) != n or (n and len(rows[0]) != len(setters))):
            raise ValueError(f"table {table.shape} for {n} steps of {len(setters)} writers")
        values: list[float] = []
        append = values.append
        realised: list[float] = []
        get_pos = self.drive.pos_node.get_double_value
        run = plant.fdm.run
        sensed: list[list[float]] = []
        if law is None:
            if self.sensing is not None or self.fault is not None:
                raise ValueError("sensors and an actuator fault need the flight computer's law")
            for k in range(n):
                if rows is not None:
                    for put, value in zip(setters, rows[k], strict=True):
                        put(value)
                if first + k == damage_step:
                    plant.start_scheduled_damage()
                    damage_step = None
                run()
                for get in getters:
                    append(get())
                if position is not None:
                    realised.append(get_pos())
        else:
            fault = self.fault
            onset = onset_step(fault.onset_s, plant.dt_s) if fault is not None else -1
            trim_pos = self.drive.trim_position
            set_el, el_command = self.elevator.set, self.elevator.command_clipped
            set_probed, probed_command = self.drive.set, self.drive.command_clipped
            set_ail = self.aileron_node.set_double_value
            set_thr = [t.set_double_value for t in self.throttle_nodes]
            sensing = self.sensing
            if sensing is not None:  # the true values after each step; the law's inputs
                current, draws = sensing.current, sensing.draws(n)  # measured at once
                true_of = sensing.getters
                fault_at, fault_onset = sensing.fault_channel, sensing.fault_onset
                faulty = sensing.fault.measure if sensing.fault is not None else None
                stepped: dict[int, list[float]] = {j: [] for j in sorted(sensing.live)}
                live = [
                    (j, sensing.sensors[j].step, draws[:, j].tolist(), kept, j == fault_at)
                    for j, kept in stepped.items()
                ]
            for k in range(n):
                step = first + k
                if rows is not None:
                    for put, value in zip(setters, rows[k], strict=True):
                        put(value)
                surface, elevator_deg, ail, thr = law(k)
                if ail is not None:
                    set_ail(ail)
                if thr is not None:
                    for s in set_thr:
                        s(thr)
                if step >= onset >= 0:
                    if self._held is None:  # the position at the onset, before the fault acts
                        self._held = get_pos()
                    surface = fault.position(surface, trim_pos, self._held)
                if elevator_deg is not None:
                    set_el(el_command(elevator_deg))
                set_probed(probed_command(surface))
                if step == damage_step:
                    plant.start_scheduled_damage()
                    damage_step = None
                run()
                if sensing is not None:
                    true = [get() for get in true_of]
                    sensed.append(true)
                    for j, sense, noise, kept, is_faulty in live:
                        value = sense(true[j], noise[k])
                        if is_faulty:
                            value = faulty(value, step, fault_onset)
                        current[j] = value
                        kept.append(value)
                for get in getters:
                    append(get())
                if position is not None:
                    realised.append(get_pos())
        plant.count_steps(n)
        out[:] = np.array(values, dtype=np.float64).reshape(n, len(getters))
        if position is not None:
            position[:] = realised
        if self.sensing is not None and law is not None:
            block = self._measured(np.array(sensed).reshape(n, -1), draws, stepped, first)
            if measured is not None:
                measured[:] = block

    def _measured(
        self, true: np.ndarray, draws: np.ndarray, stepped: dict[int, list[float]], first: int
    ) -> np.ndarray:
        """The sensors' block of ``true`` values from step ``first`` on, the columns read step
        by step already measured (``stepped``); a sensor fault on a column measured here acts
        here, in order (:func:`probing.core.faults.apply_sensor_fault`)."""
        sensing = self.sensing
        assert sensing is not None
        block = sensing.complete(true, draws, stepped)
        if sensing.fault is not None and sensing.fault_channel not in stepped:
            apply_sensor_fault(sensing.fault, block, sensing.channels, first, self.plant.dt_s)
        if len(block):
            sensing.current[:] = block[-1].tolist()
        return block


#: JSBSim's integrator choices, one per kind of state (0 holds the state still).
INTEGRATORS = tuple(
    f"simulation/integrator/{kind}"
    for kind in (
        "rate/rotational",
        "rate/translational",
        "position/rotational",
        "position/translational",
    )
)


def actuator_pulse_response(
    plant: Plant, n_steps: int = 200, height: float = 1e-3, surface: str = DEFAULT_SURFACE
) -> np.ndarray:
    """The realised surface after each step for a one-step pulse of the asked position,
    per unit asked (1 at step 0 and 0 after for a surface without actuator dynamics; the
    GTM's 5 Hz servos spread it over about 0.2 s).

    The pulse is small (``height``, in the surface's unit) so a rate limit does not act.
    The aircraft is held still while it is measured (JSBSim's integrators off), so that
    what the flight-control system does with the aircraft's motion (the 737's yaw damper
    on the rudder) is not counted as the actuator's: the linearisation sees that through
    the states.  ``plant`` (a :class:`~probing.sim.plant.Plant`) is stepped: use it for
    nothing else afterwards.
    """
    for integrator in INTEGRATORS:
        plant.fdm[integrator] = 0  # eNone: the state stays, the flight-control system runs
    drive = plant.drive(surface)
    position = np.full(n_steps, drive.trim_position)
    position[0] += height
    out = np.empty((n_steps, 0))
    realised = np.empty(n_steps)
    JSBSimWorld(plant, surface).fly(
        n_steps,
        [],
        out,
        table=drive.command(position)[:, None],
        setters=[drive.set],
        position=realised,
    )
    return (realised - drive.trim_position) / height
