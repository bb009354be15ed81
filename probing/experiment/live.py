"""``probing live``: the flight computer against a JSBSim process that runs apart from it.

The simulator is started separately (:func:`probing.sim.live_sim.write_sim` writes what it
needs) and driven through its input socket (:class:`~probing.experiment.sim_socket.SimSocket`)
in lock step: held, then per step the probed surface's command written (trim plus the
probe after the scenario's nonlinearity, through the model's command-to-position map),
one frame iterated, the channels read.  Each period (:data:`LIVE_CHUNK_PERIODS`) becomes
the rows of ``sensors.parquet`` (:func:`probing.experiment.run._log`, sensor noise added as
a flight adds it) and is fed to the same :class:`~probing.experiment.onboard.Onboard` and
monitor (:class:`probing.experiment.monitor._Monitor`) as ``probing monitor``'s, and a line
per period reports it; the log's footer records the chunk (``probing.chunk_periods``) and
``probing monitor --replay`` of the log chunks it alike, so it gives the same tables bit for
bit.

With a ``[sensors]`` suite the values read are the true states: the suite's sensors
(:class:`probing.sim.sensing.SensorBank`, seeded as a flight in this process seeds them) are
applied on the flight computer's side before the rows are logged and estimated.

Supported: open loop (no ``[control]``), calm air, no ``[fault]``, ``output.drift``
``none`` or ``detrend`` (:func:`check_live`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from probing.experiment.bounds import EstimatesFile
from probing.experiment.layouts import sensors_schema
from probing.experiment.monitor import MonitorResult, _Monitor
from probing.experiment.onboard import Onboard
from probing.experiment.progress import Progress, progress_bar
from probing.experiment.run import _log, _measured, scenario_provenance
from probing.experiment.scenario import Scenario
from probing.experiment.sim_socket import SimSocket
from probing.experiment.storage import metadata, output_folder
from probing.sim.channels import CHANNELS
from probing.sim.errors import DivergenceError
from probing.sim.plant import Plant, make_plant
from probing.sim.sensing import SensorBank
from probing.sim.surfaces import SURFACES

__all__ = [
    "LIVE_CHUNK_PERIODS",
    "LIVE_DRIFTS",
    "LiveError",
    "LiveResult",
    "at_trim_frame",
    "check_live",
    "live_monitor",
]

#: The drift modes a live flight supports: no model of the aircraft flies beside it.
LIVE_DRIFTS = ("none", "detrend")

#: The periods a live flight logs and estimates at a time: one, so each period's estimate and
#: the monitor's state are known (and reported) as the period ends.  The log's footer records
#: it (``probing.chunk_periods``): its replay chunks the rows alike, so its tables are equal
#: bit for bit (a flight in this process chunks by ``probing.experiment.run.CHUNK_STEPS``).
LIVE_CHUNK_PERIODS = 1

SUPPORTED = (
    "probing live supports open-loop scenarios (no [control]) in calm air, without [fault], "
    "with output.drift none or detrend"
)


def at_trim_frame(time_s: float, dt_s: float) -> bool:
    """True if a simulator whose time is ``time_s`` (s, stepping at ``dt_s``, s) is still at
    the frame of its trim: the written script trims in its first frame (``time_s`` = dt) and
    ``--suspend`` holds it there.  Past it, the aircraft has flown (the probe of a flight
    before, or freely without a client) and its trim is gone."""
    return time_s < 1.5 * dt_s


class LiveError(ValueError):
    """A scenario or a simulator a live flight cannot fly with; the message says why."""


def check_live(scn: Scenario) -> None:
    """Refuse (:class:`LiveError`, one line) what a live flight does not support."""
    reasons = []
    if scn.control is not None or scn.stepped_one_by_one:
        reasons.append("it flies closed loop")
    if scn.drift not in LIVE_DRIFTS:
        reasons.append(f"output.drift is {scn.drift}")
    if scn.turbulence != "none":
        reasons.append(f"turbulence is {scn.turbulence}")
    if scn.fault_type != "none":
        reasons.append(f"it has a [fault] ({scn.fault_type})")
    if scn.simultaneous is not None or scn.manoeuvre is not None:
        reasons.append("it has a [simultaneous] or [manoeuvre] section")
    if reasons:
        raise LiveError(f"{scn.name}: {'; '.join(reasons)}: {SUPPORTED}")


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


class _Actuator:
    """The probed surface's command per step: trim plus the probe after the scenario's
    nonlinearity, through the model's command-to-position map (a trimmed copy of the
    aircraft in this process knows the map, as the flight computer knows its actuator)."""

    def __init__(self, scn: Scenario, plant: Plant) -> None:
        self.scn, self.drive = scn, plant.drive(scn.surface)
        self.names = SURFACES[scn.surface].command_properties(plant.engine_count())
        self.nl = scn.build_nonlinearity()
        self.nl_state = self.nl.initial_state() if self.nl else None
        self.x_period = scn.probe.samples(scn.dt_s, 1)

    def period(self) -> np.ndarray:
        """The next period's normalised commands."""
        q = self.x_period
        if self.nl:
            q, self.nl_state = self.nl.process(self.x_period, self.scn.dt_s, self.nl_state)
        return self.drive.command(self.drive.trim_position + q)


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


class _Read:
    """What the flight computer reads of the simulator, taken at the trim: the channels it
    logs (the suite's, with ``[sensors]``, else the scenario's), their properties, the
    sensors (None without a suite) and the trim as measured (the scenario's channels).

    Without a suite the values read are what is measured; with one they are the true values,
    and the suite's sensors, started in steady state at the trim's true values, measure them.
    """

    def __init__(self, scn: Scenario, sim: SimSocket) -> None:
        suite = scn.sensors
        self.channels = list(suite.sensors) if suite is not None else list(scn.channels)
        self.props = [CHANNELS[c].prop for c in self.channels]
        true = sim.get(self.props)
        self.sensors = None if suite is None else SensorBank(suite, scn.dt_s, scn.seed, true)
        measured = self.sensors.current if self.sensors is not None else true
        trim = dict(zip(self.channels, measured, strict=True))
        self.y_trim = np.array([trim[c] for c in scn.channels])


class _Lockstep:
    """The simulator one frame per message: the surface's command written and the channels
    read; the channels JSBSim computes after the command (not :data:`STATE_PREFIXES`) come
    with the next frame's message, so each row is the frame's own, as after ``run()``
    in this process."""

    def __init__(self, sim: SimSocket, props: list[str], names: list[str]) -> None:
        self.sim, self.props, self.names = sim, props, names
        self.state = [j for j, p in enumerate(props) if p.startswith(STATE_PREFIXES)]
        self.later = [j for j in range(len(props)) if j not in self.state]
        self.ask = [props[j] for j in (*self.state, *self.later)]

    def frame(self, command: float) -> tuple[list[float], list[float]]:
        """One frame with ``command``: (its state channels, the frame before's others)."""
        values = self.sim.exchange(dict.fromkeys(self.names, command), self.ask)
        return values[: len(self.state)], values[len(self.state) :]

    def last(self) -> list[float]:
        """The last frame's other channels (the simulator flies one more frame, then holds)."""
        values = self.sim.get([self.props[j] for j in self.later])
        self.sim.hold()
        return values


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
    gets ``sensors.parquet``, ``probing.parquet`` and ``monitor.parquet``.

    Raises
    ------
    LiveError
        For a scenario :func:`check_live` refuses.
    probing.experiment.sim_socket.SimConnectionError
        If the simulator cannot be reached or answers something else (nothing written).

    The simulator's run is ended when the flight is done, and on any error
    (:meth:`~probing.experiment.sim_socket.SimSocket.close`): it cannot fly a second time.
    """
    check_live(scn)
    sim = SimSocket(host, port, timeout_s)
    try:
        plant = make_plant(scn.flight)  # the actuator's map, as the flight computer knows it
        sim.hold()
        dt_sim, time_sim = sim.get(["simulation/dt", "simulation/sim-time-sec"])
        if not math.isclose(dt_sim, scn.dt_s, rel_tol=1e-5):
            raise LiveError(f"{sim.where} steps at dt {dt_sim:g} s, the scenario at {scn.dt_s:g} s")
        if not at_trim_frame(time_sim, dt_sim):
            raise LiveError(
                f"{sim.where} has flown already (its time is {time_sim:g} s; one started with "
                f"--suspend waits at {dt_sim:g} s, its trim's frame): start it again"
            )
        read = _Read(scn, sim)  # held: the trimmed aircraft
        sim.resume()  # it runs the frame's rest at the trim, then waits in the next frame
        target = Path(folder) if folder is not None else Path(out) / scn.name
        return _fly(scn, plant, sim, read, target, realtime, progress, stream)
    finally:
        sim.close()


def _fly(
    scn: Scenario,
    plant: Plant,
    sim: SimSocket,
    read: _Read,
    folder: Path,
    realtime: bool,
    progress: bool | None,
    stream: TextIO | None,
) -> LiveResult:
    """The flight after the connection: chunks of whole periods stepped, logged, estimated."""
    monitor = _Monitor(scn, scn.monitor_settings())
    actuator = _Actuator(scn, plant)
    lock = _Lockstep(sim, read.props, actuator.names)
    flown = _Chunks(scn, actuator, lock, read.sensors, realtime)
    m, channels = scn.bits_per_period, list(scn.channels)
    onboard = Onboard(scn, None, read.y_trim, flown.chunk * m)
    lag_s = np.arange(m) * scn.probe.bit_duration_s
    wait0, start, chunk_s = sim.wait_s, time.perf_counter(), 0.0
    meta = scenario_provenance(scn, plant.trim_result, drift=scn.drift, live=sim.where)
    with output_folder(folder, meta) as outputs, _bar(scn, stream, progress) as bar:
        schema = sensors_schema(read.channels, False, scn.surface)
        w_log = outputs.writer("sensors.parquet", read.channels, scn.surface_unit, schema=schema)
        trim = dict(zip(channels, read.y_trim.tolist(), strict=True))
        w_log.add_metadata(metadata(trim_measured=trim, chunk_periods=flown.chunk))
        estimates = EstimatesFile(outputs, scn, lag_s)
        monitor.open(outputs)
        for first, log in flown.logs():
            begun = time.perf_counter()
            w_log.write(log)
            done = onboard.estimates(log, first)
            est = done.estimates
            estimates.write(est)
            monitor.update(est.periods, est.h, est.z, done.trajectory)
            _report(bar, monitor, est, first, len(log["time_s"]) // flown.n_steps)
            chunk_s = max(chunk_s, time.perf_counter() - begun)
        estimates.finish()
        monitor.finish()
    wall = time.perf_counter() - start
    result = monitor.result(None, folder, None)
    steps = scn.periods * flown.n_steps
    wait = sim.wait_s - wait0 + flown.slept_s
    return LiveResult(result, steps, wall, wait, scn.period_s, flown.n_steps, chunk_s)


class _Chunks:
    """The flight in chunks of whole periods, as ``probing monitor`` and its replay chunk it:
    each chunk's rows of ``sensors.parquet`` (the suite's sensors applied, or
    ``disturbance.sensor_noise`` added, as a flight in this process does)."""

    def __init__(
        self,
        scn: Scenario,
        actuator: _Actuator,
        lock: _Lockstep,
        sensors: SensorBank | None,
        realtime: bool,
    ) -> None:
        self.scn, self.actuator, self.lock, self.realtime = scn, actuator, lock, realtime
        self.sensors = sensors
        self.n_steps = scn.probe.length * scn.steps_per_bit
        self.chunk = LIVE_CHUNK_PERIODS
        self.sigma = np.array([scn.sensor_noise.get(c, 0.0) for c in scn.channels])
        self.rng = np.random.default_rng(scn.seed)
        self.slept_s = 0.0  # the pacing's sleeps (--realtime), s

    def logs(self) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(first period, the chunk's log) for every chunk; a chunk is handed on once its
        last row is complete (in the next chunk's first frame)."""
        scn, n, lock = self.scn, self.n_steps, self.lock
        state, later = lock.state, lock.later
        done: tuple[int, np.ndarray] | None = None
        start = time.perf_counter()
        for first in range(0, scn.periods, self.chunk):
            k = min(self.chunk, scn.periods - first)
            out = np.full((k * n, len(lock.props)), np.nan)
            for i in range(k):
                for step, command in enumerate(self.actuator.period().tolist()):
                    row = i * n + step
                    now, before = lock.frame(command)
                    out[row, state] = now
                    if row:
                        out[row - 1, later] = before
                    elif done is not None:
                        done[1][-1, later] = before
                        yield done[0], self._log(*done)
                    if self.realtime:
                        due = start + ((first + i) * n + step + 1) * scn.dt_s
                        pause = max(0.0, due - time.perf_counter())
                        time.sleep(pause)
                        self.slept_s += pause
            done = (first, out)
        if done is not None:
            done[1][-1, later] = lock.last()
            yield done[0], self._log(*done)

    def _log(self, first: int, out: np.ndarray) -> dict[str, np.ndarray]:
        """The rows of ``sensors.parquet`` of the chunk from period ``first`` on."""
        scn, n = self.scn, self.n_steps
        if not np.all(np.isfinite(out)):
            raise DivergenceError("the simulator's outputs are not finite")
        if self.sensors is not None:  # the true values, measured by the suite's sensors
            recorded = dict(zip(self.sensors.channels, self.sensors.measure(out).T, strict=True))
        else:
            measured = _measured(out, self.rng, self.sigma, None, scn, first * n)
            recorded = dict(zip(scn.channels, measured.T, strict=True))
        count = out.shape[0] // n
        return _log(scn, first * n, self.actuator.x_period, count, None, recorded, len(out))


def _bar(scn: Scenario, stream: TextIO | None, progress: bool | None) -> Any:
    """The periods' progress: a line per period (none with ``progress`` False)."""
    label = f"{scn.name} live"
    return progress_bar(scn.periods, label, "periods", stream, False, lines=progress is not False)


def _report(bar: Progress, monitor: _Monitor, est: Any, first: int, count: int) -> None:
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
