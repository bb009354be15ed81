"""``probing live``: the flight computer against a JSBSim process that runs apart from it.

The simulator is started separately (:func:`probing.sim.live_sim.write_sim` writes what it
needs) and driven through its input socket
(:class:`~probing.experiment.flight.sim_socket.SimSocket`)
in lock step, one message per frame, as ArduPilot's SITL flies JSBSim.  The simulator
process is the world (:class:`SocketWorld`): the aircraft, its turbulence (switched on, and
seeded as in this process, in the first frame) and a damage case (switched on in the frame of
its onset); on this side of the socket the world also holds what a hardware-in-the-loop rig
models beside the simulator: the probed surface's actuator fault and the sensors (the suite's,
seeded as a flight in this process seeds them, with the sensor fault).  The flight computer is
the same :class:`~probing.experiment.flight.flight_computer.FlightComputer` as ``probing monitor``'s
and ``--replay``'s: the probe path (with its fault), the autopilot on the measurements, the
reference (``gust``, ``nominal``, ``follow``, ``detrend``, ``none``), the estimators and the
monitor.

Each frame is two messages (:meth:`~probing.experiment.flight.sim_socket.SimSocket.held_get`, then
:meth:`~probing.experiment.flight.sim_socket.SimSocket.resume_with`): the first holds the frame
after JSBSim integrated its state and reads the channels (the integrator's states,
:data:`STATE_PREFIXES`, are the frame's own; what JSBSim computes after the commands, air
data, load factors, the surfaces, is still the frame before's and completes the row
before), the second writes the frame's commands and lets it go on.  So the flight computer
computes a step's commands from the whole row before, as in this process.

Each period (:data:`LIVE_CHUNK_PERIODS`) becomes the rows of ``sensors.parquet`` once its
last row is complete, and a line reports it; the log's footer records the chunk
(``probing.chunk_periods``) and ``probing monitor --replay`` of the log chunks it alike, so it
gives the same tables bit for bit.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from probing.core.errors import ProbingError
from probing.core.faults import onset_step
from probing.core.measuring import ChannelNoise, SensorBank
from probing.experiment.flight.flight_computer import FlightComputer, flight_autopilot, folder_of
from probing.experiment.flight.monitor import Monitor, MonitorResult
from probing.experiment.flight.onboard import calm_nominal, open_reference_twin, reference_source
from probing.experiment.flight.run import scenario_provenance
from probing.experiment.flight.runners import runner_of
from probing.experiment.flight.sim_socket import SimConnectionLost, SimSocket
from probing.experiment.output.progress import Progress, progress_bar
from probing.experiment.output.storage import output_folder
from probing.experiment.scenario import Scenario
from probing.experiment.scenario.references import REFERENCES, realisable_drifts
from probing.sim.autopilot import LOOP_CHANNELS, Autopilot, Demand
from probing.sim.channels import CHANNELS
from probing.sim.control import control_power, trim_of
from probing.sim.errors import DivergenceError, SimulatorLostError
from probing.sim.flight import disturbance_properties
from probing.sim.plant import DAMAGE_PROPERTY, Plant, make_plant
from probing.sim.surfaces import SURFACES
from probing.sim.world import JSBSimWorld, flight_plan

__all__ = [
    "LIVE_CHUNK_PERIODS",
    "LiveError",
    "LiveResult",
    "SocketWorld",
    "at_trim_frame",
    "check_live",
    "live_monitor",
]

#: The periods a live flight logs and estimates at a time: one, so each period's estimate and
#: the monitor's state are known (and reported) as the period ends.  The log's footer records
#: it (``probing.chunk_periods``): its replay chunks the rows alike, so its tables are equal
#: bit for bit (a flight in this process chunks by ``probing.experiment.flight.run.CHUNK_STEPS``).
LIVE_CHUNK_PERIODS = 1


def supported() -> str:
    """What a live flight supports, for its refusals."""
    return (
        "probing live flies every scenario probing monitor flies with a realisable reference "
        f"(output.drift {', '.join(realisable_drifts())}), trimmed without damage"
    )


def at_trim_frame(time_s: float, dt_s: float) -> bool:
    """True if a simulator whose time is ``time_s`` (s, stepping at ``dt_s``, s) is still at
    the frame of its trim: the written script trims in its first frame (``time_s`` = dt) and
    ``--suspend`` holds it there.  Past it, the aircraft has flown (the probe of a flight
    before, or freely without a client) and its trim is gone."""
    return time_s < 1.5 * dt_s


class LiveError(ProbingError, ValueError):
    """A scenario or a simulator a live flight cannot fly with; the message says why."""


def check_live(scn: Scenario) -> None:
    """Refuse (:class:`LiveError`, one line) what a live flight does not support: another
    runner's scenario (:func:`probing.experiment.flight.runners.runner_of`), a reference that knows
    the simulator's turbulence, an aircraft trimmed damaged."""
    refusal = runner_of(scn).refuses("live")
    if refusal is not None:
        raise LiveError(f"{scn.name}: {refusal}")
    reasons = []
    if not REFERENCES[scn.drift].realisable:
        reasons.append(f"output.drift is {scn.drift}")
    if scn.flight.trimmed_damage:
        reasons.append(f"it is trimmed with damage case {scn.flight.trimmed_damage}")
    if reasons:
        raise LiveError(f"{scn.name}: {'; '.join(reasons)}: {supported()}")


@dataclass
class LiveResult:
    """A live flight: the monitor's result and the timing.

    Attributes
    ----------
    monitor : MonitorResult
        First alarm and verdict, ``out_dir``.
    steps : int
        Frames flown.
    wall_s : float
        Wall time of the flight (set-up excluded), s.
    wait_s : float
        Of it, time waiting: for the simulator's replies, and (``realtime``) for the wall
        clock, s.
    """

    monitor: MonitorResult
    steps: int
    wall_s: float
    wait_s: float
    period_s: float
    steps_per_period: int
    chunk_s: float = 0.0

    @property
    def compute_per_period_s(self) -> float:
        """Time in the flight computer's own code per probe period, s: the wall time less
        the waits, over the periods flown."""
        return (self.wall_s - self.wait_s) / (self.steps / self.steps_per_period)

    def headroom_line(self) -> str:
        """The timing as the command prints it."""
        own = self.compute_per_period_s
        return (
            f"{self.steps} steps in {self.wall_s:.2f} s ({1e3 * self.wall_s / self.steps:.3f} "
            f"ms a step, {1e3 * self.wait_s / self.steps:.3f} ms of it waiting for the "
            f"simulator or the clock); the flight computer's own time per period "
            f"{1e3 * own:.2f} ms of "
            f"{1e3 * self.period_s:.0f} ms ({own / self.period_s:.1%}); a chunk's estimates "
            f"and files at most {1e3 * self.chunk_s:.1f} ms"
        )


#: The properties JSBSim's integrator (``FGPropagate``) owns: in a frame of a blocking input
#: socket they are already the frame's when the message is answered; every other (air data,
#: load factors, surfaces) is still the frame before's, read with the next frame's message.
STATE_PREFIXES = (
    "attitude/",
    "position/",
    *(f"velocities/{v}" for v in ("p-rad_sec", "q-rad_sec", "r-rad_sec", "u-fps", "v-fps")),
    "velocities/w-fps",
    "velocities/h-dot-fps",
    *(f"velocities/v-{d}-fps" for d in ("north", "east", "down")),
)


class SocketWorld:
    """JSBSim in a separate process, one message per frame, with the probed surface's
    actuator fault and the sensors on this side of the socket (module docstring).

    Parameters
    ----------
    scn : Scenario
        The flight's scenario.
    sim : SimSocket
        The simulator, held at its trim.
    plant : Plant
        A trimmed copy of the aircraft in this process: the actuators' command-to-position
        maps (what the rig knows of the aircraft's actuators).
    realtime : bool
        Pace the frames at the wall clock.
    """

    def __init__(self, scn: Scenario, sim: SimSocket, plant: Plant, realtime: bool) -> None:
        self.scn, self.sim, self.realtime = scn, sim, realtime
        suite = scn.sensors
        self.logged = list(suite.sensors) if suite is not None else list(scn.channels)
        extra = [] if suite is not None else [c for c in LOOP_CHANNELS if c not in self.logged]
        self.channels = [*self.logged, *extra]  # what is read: the logged, the loops' others
        engines = plant.engine_count()
        surface = SURFACES[scn.surface]
        self.drive, self.elevator = plant.drive(scn.surface), plant.drive()
        self.names = {
            "probed": surface.command_properties(engines),
            "elevator": SURFACES["elevator"].command_properties(engines),
            "throttle": SURFACES["throttle"].command_properties(engines),
        }
        props = [CHANNELS[c].prop for c in self.channels] + [surface.position]
        self.state = [j for j, p in enumerate(props) if p.startswith(STATE_PREFIXES)]
        self.later = [j for j in range(len(props)) if j not in self.state]
        self.ask = [props[j] for j in (*self.state, *self.later)]
        self.later_props = [props[j] for j in self.later]
        true = sim.get(props)  # held: the trimmed aircraft
        self.row = list(true)  # the latest row: its state this frame's, the rest the last's
        n_log = len(self.logged)
        fault = scn.build_fault("sensor")
        self.bank = None
        if suite is not None:
            self.bank = SensorBank(suite, scn.dt_s, scn.seed, true[:n_log], fault)
        #: The latest measurement of each channel read (the loops' inputs).
        self.current = list(self.bank.current) if self.bank is not None else true[:n_log]
        self.current += true[n_log : len(self.channels)]
        self.noise = None
        if self.bank is None:
            sigma = [scn.sensor_noise.get(c, 0.0) for c in self.logged]
            self.noise = ChannelNoise(self.logged, sigma, scn.seed, fault, scn.dt_s)
        self.fault = scn.actuator_fault
        self.fault_onset = onset_step(self.fault.onset_s, scn.dt_s) if self.fault else -1
        self.held: float | None = None
        flight = scn.flight
        self.damage = None
        if flight.damage_onset_step is not None:
            self.damage = (flight.damage_onset_step, float(flight.damage_case))
        self.first_frame = (
            disturbance_properties(flight.turbulence, flight.seed)
            if flight.turbulence != "none"
            else {}
        )
        self.steps = 0  # frames flown
        self.true_rows: list[list[float]] = []  # rows complete but for the last one's later
        self.measured_rows: list[list[float]] = []
        self.noise_rows: list[list[float]] = []
        self.start = time.perf_counter()
        self.slept_s = 0.0  # the pacing's sleeps (realtime), s

    @property
    def dt_s(self) -> float:
        """The step, s."""
        return self.scn.dt_s

    def reader(self, channel: str) -> Callable[[], float]:
        """A callable giving the latest measurement of ``channel`` (NaN if nothing measures
        it: a loop flying on it is refused when the scenario is read)."""
        if channel not in self.channels:
            return lambda: math.nan
        current, j = self.current, self.channels.index(channel)
        return lambda: current[j]

    @property
    def trim_measured(self) -> np.ndarray:
        """The scenario's channels as measured at the trim (before the first frame)."""
        return np.array([self.current[self.channels.index(c)] for c in self.scn.channels])

    def fly(
        self,
        n: int,
        law: Callable[[int], Demand] | None = None,
        commands: np.ndarray | None = None,
    ) -> None:
        """Fly ``n`` frames: the flight computer's ``law`` step by step, or the probed
        surface's normalised ``commands`` ``(n,)``."""
        probed, elevator = self.names["probed"], self.names["elevator"]
        cmds = commands.tolist() if commands is not None else None
        for k in range(n):
            reply = self.sim.held_get(self.ask)  # the frame's state, the row before's rest
            if self.steps:
                self._complete(reply[len(self.state) :])
            values = dict(self.first_frame) if self.steps == 0 else {}
            if cmds is not None:
                values.update(dict.fromkeys(probed, cmds[k]))
            else:
                assert law is not None
                values.update(self._demand(law(k), probed, elevator))
            if self.damage is not None and self.steps == self.damage[0]:
                values[DAMAGE_PROPERTY] = self.damage[1]
            self._start(reply[: len(self.state)])
            self.sim.resume_with(values)
            if self.realtime:
                due = self.start + self.steps * self.scn.dt_s
                pause = max(0.0, due - time.perf_counter())
                time.sleep(pause)
                self.slept_s += pause

    def fly_probe(
        self, autopilot: Autopilot | None, probe: np.ndarray, commands: np.ndarray | None = None
    ) -> None:
        """Fly the steps of ``probe`` (the probe path's deflection of each step): through
        ``autopilot`` step by step, or where the aircraft has none, the probed surface at its
        trim plus the probe (:func:`probing.sim.world.flight_plan`, the choice
        :meth:`probing.sim.world.JSBSimWorld.fly_probe` makes); ``commands`` ``(n, 3)``
        receives the autopilot's commands."""
        n = len(probe)
        law, asked = flight_plan(
            autopilot, self.drive, self.steps, n, probe, record_commands=commands is not None
        )
        self.fly(n, law=law, commands=asked)
        if commands is not None:
            commands[:] = autopilot.commands_record

    def _demand(self, demand: Demand, probed: list[str], elevator: list[str]) -> dict:
        """The property writes of one step's demands, through the actuator and its fault."""
        surface, elevator_deg, ail, thr = demand
        if self.steps >= self.fault_onset >= 0:
            if self.held is None:  # the last position measured before the onset
                self.held = self.row[-1]
            surface = self.fault.position(surface, self.drive.trim_position, self.held)
        values = {}
        if ail is not None:
            values[SURFACES["aileron"].command] = ail
        if thr is not None:
            values.update(dict.fromkeys(self.names["throttle"], thr))
        if elevator_deg is not None:
            values.update(dict.fromkeys(elevator, self.elevator.command_clipped(elevator_deg)))
        values.update(dict.fromkeys(probed, self.drive.command_clipped(surface)))
        return values

    def _start(self, now: list[float]) -> None:
        """The frame's row, with its state channels (``now``) measured."""
        row = self.row
        for j, v in zip(self.state, now, strict=True):
            row[j] = v
        if self.bank is not None:
            draws = self.bank.noise(1)[0]
            self.noise_rows.append(draws)
            measured = [math.nan] * len(self.logged)
            self._measure(measured, self.state, row, self.steps, draws)
            self.measured_rows.append(measured)
        else:
            for j in self.state:
                if j < len(self.current):
                    self.current[j] = row[j]
        self.true_rows.append(list(row))
        self.steps += 1

    def _complete(self, before: list[float]) -> None:
        """The row before, completed with what JSBSim computed after its commands."""
        last = self.true_rows[-1]
        for j, v in zip(self.later, before, strict=True):
            last[j] = self.row[j] = v
        if self.bank is not None:
            measured, draws = self.measured_rows[-1], self.noise_rows[-1]
            self._measure(measured, self.later, last, self.steps - 1, draws)
        else:
            for j in self.later:
                if j < len(self.current):
                    self.current[j] = last[j]

    def _measure(
        self, out: list[float], columns: list[int], row: list[float], step: int, draws: list
    ) -> None:
        """The suite's sensors measure ``columns`` of ``row``, the row of frame ``step`` (the
        sensor fault added), into ``out`` and :attr:`current`."""
        bank = self.bank
        assert bank is not None
        for j in columns:
            if j >= len(self.logged):
                continue  # the probed surface's position: the actuator's, not logged
            value = bank.sensors[j].step(row[j], draws[j])
            if j == bank.fault_channel:
                value = bank.fault.measure(value, step, bank.fault_onset)
            out[j] = self.current[j] = value

    def finish(self) -> None:
        """After the last frame: its row completed (the simulator holds)."""
        self._complete(self.sim.held_get(self.later_props))

    def take(self, rows: int, first_step: int) -> dict[str, np.ndarray]:
        """The first ``rows`` complete rows, measured: what the sensors logged."""
        true = np.array(self.true_rows[:rows], dtype=np.float64)
        del self.true_rows[:rows]
        if not np.all(np.isfinite(true)):
            raise DivergenceError("the simulator's outputs are not finite")
        n_log = len(self.logged)
        if self.bank is not None:
            measured = np.array(self.measured_rows[:rows], dtype=np.float64)
            del self.measured_rows[:rows], self.noise_rows[:rows]
        else:
            assert self.noise is not None
            measured = self.noise.measure(true[:, :n_log], first_step)
        return dict(zip(self.logged, measured.T, strict=True))


def live_monitor(
    scn: Scenario,
    host: str,
    port: int,
    out: str | Path,
    *,
    realtime: bool = False,
    progress: bool | None = None,
    stream: TextIO | None = None,
    folder: str | Path | None = None,
    timeout_s: float = 10.0,
) -> LiveResult:
    """Fly ``scn`` on the simulator at ``host:port`` with the monitor: ``out/<name>/``
    gets ``sensors.parquet``, ``probing.parquet``, ``bounds.parquet`` and ``monitor.parquet``.

    Raises
    ------
    LiveError
        For a scenario :func:`check_live` refuses, or a simulator at another step or past
        its trim.
    probing.experiment.flight.sim_socket.SimConnectionError
        If the simulator cannot be reached or answers something else (nothing written).
    probing.sim.errors.SimulatorLostError
        If the simulator closes the connection once the flight has begun (it was killed, it
        crashed): a flight that failed, the message says at what simulated time; nothing
        is written.

    The simulator's run is ended when the flight is done, and on any error
    (:meth:`~probing.experiment.flight.sim_socket.SimSocket.close`): it cannot fly a second time.
    """
    check_live(scn)
    sim = SimSocket(host, port, timeout_s)
    try:
        plant = make_plant(calm_nominal(scn.flight))  # the actuators' maps, as the rig knows
        sim.hold()
        dt_sim, time_sim = sim.get(["simulation/dt", "simulation/sim-time-sec"])
        if not math.isclose(dt_sim, scn.dt_s, rel_tol=1e-5):
            raise LiveError(f"{sim.where} steps at dt {dt_sim:g} s, the scenario at {scn.dt_s:g} s")
        if not at_trim_frame(time_sim, dt_sim):
            raise LiveError(
                f"{sim.where} has flown already (its time is {time_sim:g} s; one started with "
                f"--suspend waits at {dt_sim:g} s, its trim's frame): start it again"
            )
        world = SocketWorld(scn, sim, plant, realtime)  # held: the trimmed aircraft
        sim.resume()  # it runs the frame's rest at the trim, then waits in the next frame
        target = folder_of(out, scn.name, folder)
        try:
            return _fly(scn, plant, world, target, progress, stream)
        except SimConnectionLost as exc:
            why = f" ({exc.reason})" if exc.reason else ""
            raise SimulatorLostError(
                f"the simulator at {exc.where} closed the connection at "
                f"t = {world.steps * scn.dt_s:.2f} s{why}"
            ) from None
    finally:
        sim.close()


def flight_computer(
    scn: Scenario, plant: Plant, world: SocketWorld, monitor: Monitor
) -> FlightComputer:
    """The flight computer of a live flight: the same as a flight in this process builds,
    its autopilot flying on ``world``'s measurements, its actuator's maps and trim those of
    ``plant`` (a trimmed copy in this process)."""
    power = control_power(scn.flight) if scn.flight.closed_loop else None
    trim = trim_of(JSBSimWorld(plant, scn.surface))  # the rig's copy knows the maps
    autopilot = flight_autopilot(scn, world, power, trim)
    twin = open_reference_twin(scn, nominal=True)
    source = reference_source(scn, twin)
    return FlightComputer(scn, autopilot, world.trim_measured, source, LIVE_CHUNK_PERIODS, monitor)


def _fly(
    scn: Scenario,
    plant: Plant,
    world: SocketWorld,
    folder: Path,
    progress: bool | None,
    stream: TextIO | None,
) -> LiveResult:
    """The flight after the connection: chunks of whole periods flown, logged, estimated."""
    monitor = Monitor(scn, scn.monitor_settings())
    computer = flight_computer(scn, plant, world, monitor)
    lag_s = np.arange(scn.bits_per_period) * scn.probe.bit_duration_s
    wait0, start, chunk_s = world.sim.wait_s, time.perf_counter(), 0.0
    meta = scenario_provenance(scn, plant.trim_result, drift=scn.drift, live=world.sim.where)
    n_steps = computer.period_steps
    with output_folder(folder, meta) as outputs, _bar(scn, stream, progress) as bar:
        computer.open(outputs, lag_s, log_channels=world.logged, chunk_periods=LIVE_CHUNK_PERIODS)
        for first, log in _chunks(world, computer):
            begun = time.perf_counter()
            est = computer.consume(log, first).estimates
            _report(bar, monitor, est, first, len(log["time_s"]) // n_steps)
            chunk_s = max(chunk_s, time.perf_counter() - begun)
        computer.finish(outputs)
    wall = time.perf_counter() - start
    result = monitor.result(None, folder, None)
    steps = scn.periods * n_steps
    wait = world.sim.wait_s - wait0 + world.slept_s
    return LiveResult(result, steps, wall, wait, scn.period_s, n_steps, chunk_s)


def _chunks(world: SocketWorld, computer: FlightComputer) -> Iterator[tuple[int, dict]]:
    """(first period, the chunk's log) for every chunk of :data:`LIVE_CHUNK_PERIODS`; a chunk
    is handed on once its last row is complete (after the next chunk's frames)."""
    scn, n = world.scn, computer.period_steps
    done: tuple[int, int, np.ndarray | None] | None = None  # (first, count, commands)
    for first in range(0, scn.periods, LIVE_CHUNK_PERIODS):
        count = min(LIVE_CHUNK_PERIODS, scn.periods - first)
        commands = np.empty((count * n, 3)) if computer.autopilot is not None else None
        for i in range(count):
            flown = commands[i * n : (i + 1) * n] if commands is not None else None
            world.fly_probe(computer.autopilot, computer.probe_path(first + i), flown)
        if done is not None:
            yield done[0], _log(world, computer, *done)
        done = (first, count, commands)
    if done is not None:
        world.finish()
        yield done[0], _log(world, computer, *done)


def _log(
    world: SocketWorld, computer: FlightComputer, first: int, count: int, commands: Any
) -> dict[str, np.ndarray]:
    """The rows of ``sensors.parquet`` of the chunk of ``count`` periods from ``first`` on."""
    n = computer.period_steps
    recorded = world.take(count * n, first * n)
    return computer.log(first * n, count, commands, recorded)


def _bar(scn: Scenario, stream: TextIO | None, progress: bool | None) -> Any:
    """The periods' progress: a line per period (none with ``progress`` False)."""
    label = f"{scn.name} live"
    return progress_bar(scn.periods, label, "periods", stream, False, lines=progress is not False)


def _report(bar: Progress, monitor: Monitor, est: Any, first: int, count: int) -> None:
    """``count`` periods from ``first`` on done: one line with the last one's end time, the
    latest estimate's largest tap of the first monitored channel and the first alarm."""
    j, channel = monitor.monitored[0]
    end_s = (first + count) * monitor.scn.period_s
    h = est.h[-1, j] if est.periods.size else None
    if h is not None and np.isfinite(h).all():
        peak = int(np.argmax(np.abs(h)))
        latest = f"{channel} h peak {h[peak]:.4g} at tap {peak} (period {int(est.periods[-1])})"
    else:  # no row yet, or the streaming estimator's NaN row before its first estimate
        latest = "no estimate yet"
    alarm = monitor.first_alarm
    first_alarm = "none" if alarm is None else f"period {alarm}"
    text = f"period {first + count - 1} at {end_s:.2f} s: {latest}; first alarm: {first_alarm}"
    bar.advance(count, message=text)
