"""One probing run: scenario -> trimmed plant -> probe + nonlinearity -> correlator -> Parquet.

Timing conventions (documented in ``docs/method.md``):

* Step k applies probe sample k (the probed surface's command is written, then
  ``run()``); output sample k is read right after that step.
* A bit spanning several steps becomes one correlator sample: the output read after the
  *last* step of the bit (end-of-bit sampling).  This is exactly the zero-order-hold
  discretisation at the bit duration, so the taps are the pulse response sampled at t0.

The run is four pieces, each small: :class:`_Rig` (set-up: probe, nonlinearity, trimmed
plant, twin, metadata), :func:`_chunks` (stepping, period by period, handed on in chunks of
whole periods), a drift correction per ``output.drift`` mode (:class:`_Streaming`,
:class:`_Detrended`) that turns a chunk into per-period estimates, and :class:`SettledMean`
(the average over the settled periods, and their per-tap bounds for ``bounds.parquet``).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, TextIO

import numpy as np

from probing.core.faults import onset_step
from probing.core.forked import INTERRUPTS
from probing.core.nonlinearities import Nonlinearity
from probing.core.prbs import Probe
from probing.experiment.bounds import EstimatesFile
from probing.experiment.layouts import AUTOPILOT_COLUMNS, sensors_schema
from probing.experiment.onboard import (
    Onboard,
    calm_nominal,
    open_reference_twin,
    reference_source,
)
from probing.experiment.progress import progress_bar
from probing.experiment.runners import runner_of
from probing.experiment.scenario import Scenario
from probing.experiment.settled import SettledMean
from probing.experiment.storage import (
    OutputFolder,
    Settled,
    metadata,
    output_folder,
    provenance,
    timeseries_schema,
)
from probing.sim.control import ClosedLoop, control_power
from probing.sim.errors import DivergenceError
from probing.sim.flight import Control
from probing.sim.fork import TrimmedAircraft, trim_spec
from probing.sim.plant import Plant, SurfaceDrive, TrimResult, make_plant
from probing.sim.sensing import Sensing
from probing.sim.surfaces import SURFACES
from probing.sim.twins import ReferenceTwin

__all__ = ["RunObserver", "RunResult", "SettledMean", "run_scenario"]

#: Steps post-processed together (noise, correlation, Parquet rows): whole periods, at
#: least one; the plant is still stepped and checked period by period.
CHUNK_STEPS = 8192


@dataclass
class RunResult:
    """What a run produced.

    Attributes
    ----------
    out_dir : pathlib.Path
        The folder holding the Parquet files.
    trim : TrimResult
        The trimmed state of the probed aircraft.
    h_est : dict
        Channel -> mean of ``h_est`` over the settled periods (output units per deg).
    steps_simulated : int
        JSBSim steps actually simulated: the probed aircraft's, plus the reference twin's
        unless it was read from the cache (trim and calibration not counted).
    wall_s : float
        Wall time of the whole call (s).
    twin_cached : bool
        True if the reference twin was read from the cache instead of simulated.
    twin_key : str or None
        The twin's cache key (:func:`probing.sim.twins.twin_key`); None without a twin.
    settled : Settled or None
        With ``keep_settled``: the settled periods of the first channel, exactly as
        :func:`probing.experiment.storage.read_settled` reads them back from the file.
    ended : str or None
        With ``stop_on_divergence``: why the flight ended before its last period (the
        divergence), None if it flew them all.
    """

    out_dir: Path
    trim: TrimResult
    h_est: dict[str, np.ndarray]
    steps_simulated: int
    wall_s: float
    twin_cached: bool = False
    twin_key: str | None = None
    settled: Settled | None = None
    ended: str | None = None


class RunObserver(Protocol):
    """What follows a run period by period (the monitor): it may write files of its own
    into the run's folder, which appear with the run's files or not at all."""

    def open(self, outputs: OutputFolder) -> None:
        """Called once, with the run's output folder, before the first period."""

    def update(
        self,
        periods: np.ndarray,
        h: np.ndarray,
        z: np.ndarray,
        trajectory: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """Called with each chunk's periods (P,) and their estimates h, z (P, C, M), and
        its whole periods with their deviation's features (:class:`Onboard`'s)."""

    def finish(self) -> None:
        """Called after the last period, before the run's files are closed."""


# ------------------------------------------------------------------ set-up
@dataclass
class _Rig:
    """Everything a run steps with, built from the scenario."""

    scn: Scenario
    probe: Probe
    nl: Nonlinearity | None
    plant: Plant
    nodes: list
    y_trim: np.ndarray
    twin: ReferenceTwin | None
    drive: SurfaceDrive | None = None  # the probed surface, driven by its position
    loop: ClosedLoop | None = None  # stepping one step at a time: autopilot, actuator fault
    fault_nl: Nonlinearity | None = None  # a nonlinearity that appears on the probe path
    nominal_twin: bool = False
    stop_on_divergence: bool = False
    ended: str | None = None  # why the flight ended early (stop_on_divergence)
    follower: ClosedLoop | None = None  # drift "follow": the nominal twin flying our commands
    follower_nodes: list | None = None
    periods_flown: int = 0
    sensing: Sensing | None = None  # the aircraft's sensors ([sensors]): what it measures
    record: bool = False  # write sensors.parquet: the autopilot's commands are kept then

    @classmethod
    def build(
        cls,
        scn: Scenario,
        twin_cache: bool,
        aircraft: TrimmedAircraft | None,
        nominal_twin: bool = False,
    ) -> _Rig:
        probe = scn.probe
        flight = scn.flight
        power = control_power(flight) if flight.closed_loop else None
        plant = aircraft.plant_for(flight) if aircraft else make_plant(flight)
        loop = sensing = None
        if scn.sensors is not None:
            sensing = Sensing(plant, scn.sensors, scn.seed, scn.build_fault("sensor"))
        if scn.stepped_one_by_one or sensing is not None:
            loop = ClosedLoop(
                plant,
                scn.control or Control(),
                power,
                scn.actuator_fault,
                scn.surface,
                sensing=sensing,
            )
        nodes = plant.channel_nodes(list(scn.channels))
        if sensing is not None:  # the sensors' reading of the trim
            y_trim = np.array([sensing.current[sensing.index(c)] for c in scn.channels])
        else:
            y_trim = np.array([n.get_double_value() for n in nodes])
        twin = open_reference_twin(scn, nominal=nominal_twin, use_cache=twin_cache)
        follower = follower_nodes = None
        if scn.follows:
            try:
                calm = calm_nominal(flight)  # a model flying our commands knows no gusts
                second = aircraft.second_for(calm) if aircraft else None
                second = second or make_plant(calm)
            except BaseException:
                if twin is not None:
                    twin.close(success=False)  # its temporary file goes
                raise
            follower = ClosedLoop(second, Control())  # healthy, its loops open: it replays
            follower_nodes = second.channel_nodes(list(scn.channels))
        return cls(
            scn,
            probe,
            scn.build_nonlinearity(),
            plant,
            nodes,
            y_trim,
            twin,
            plant.drive(scn.surface),
            loop,
            scn.build_fault_nonlinearity(),
            nominal_twin,
            follower=follower,
            follower_nodes=follower_nodes,
            sensing=sensing,
        )

    @property
    def period_steps(self) -> int:
        """Simulation steps of one probe period."""
        return self.probe.length * self.probe.steps_per_bit(self.scn.dt_s)

    @property
    def chunk_periods(self) -> int:
        """Periods post-processed together: about :data:`CHUNK_STEPS` steps, at least one."""
        return max(1, CHUNK_STEPS // self.period_steps)

    def metadata(self) -> dict[bytes, bytes]:
        """The key-value metadata of the run's files."""
        scn = self.scn
        meta: dict[str, object] = {
            "drift": scn.drift,
            "sampling": "one correlator sample per bit: the output read after the last step "
            "of the bit",
        }
        if self.twin:
            meta["twin"] = {"key": self.twin.key}  # not whether it was cached: same bytes
            if self.nominal_twin:
                meta["twin"]["nominal"] = True  # the fault-free model, not the flown one
        return scenario_provenance(scn, self.plant.trim_result, **meta)


def scenario_provenance(scn: Scenario, trim: TrimResult, **items: Any) -> dict[bytes, bytes]:
    """The key-value metadata of a run's files: the scenario as written and resolved, its
    digest, what the trim depends on (model files' digest, condition, JSBSim) and the trim
    found, then ``items``, with the versions and git revision (:func:`provenance`)."""
    return provenance(
        scenario_toml=scn.text,
        scenario=scn.to_dict(),
        scenario_digest=scn.digest(),
        aircraft=trim_spec(scn.flight),
        trim=trim.to_dict(),
        **items,
    )


# ------------------------------------------------------------------ stepping
@dataclass
class _Chunk:
    """Whole periods ``first .. first + count - 1`` as stepped."""

    first: int
    count: int
    nl_out: np.ndarray  # (rows,) probe after the nonlinearity, the surface's unit
    surface: np.ndarray  # (rows,) realised position of the probed surface, its unit
    control: np.ndarray | None  # (rows,) the autopilot's command of the surface (closed loop)
    log: dict[str, np.ndarray]  # what the flight computer recorded (sensors.parquet's rows)
    flown_reference: np.ndarray | None  # (rows, C) the twin flying our commands ("follow")


def _chunks(rig: _Rig) -> Iterator[_Chunk]:
    """Step the plant (and a twin flying our commands) period by period, checking the state
    after each; yield the periods in chunks of about :data:`CHUNK_STEPS` steps with what the
    flight computer recorded (sensor noise added)."""
    scn, n_steps = rig.scn, rig.period_steps
    x_period = rig.probe.samples(scn.dt_s, 1)
    sigma = np.array([scn.sensor_noise.get(c, 0.0) for c in scn.channels])
    rng = np.random.default_rng(scn.seed)
    chunk = rig.chunk_periods
    out, ref, surface, nl_out, control, commands, sensed = _buffers(rig, chunk * n_steps)
    nl_state = rig.nl.initial_state() if rig.nl else None
    probe_path = _FaultOnset(rig.fault_nl, scn.fault_onset_s, scn.dt_s, n_steps)
    sensor_fault = scn.build_fault("sensor")
    drive = rig.drive
    trim = drive.trim_position
    for first in range(0, scn.periods, chunk):
        k = min(chunk, scn.periods - first)
        rows = k * n_steps
        for i in range(k):
            span = slice(i * n_steps, (i + 1) * n_steps)
            if rig.nl:
                q, nl_state = rig.nl.process(x_period, scn.dt_s, nl_state)
            else:
                q = x_period
            q = probe_path.apply(q, first + i)
            nl_out[span] = q
            if rig.loop:
                measured = sensed[span] if sensed is not None else None
                flown = commands[span] if commands is not None else None
                rig.loop.step(
                    q, rig.nodes, out[span], surface[span], control[span], flown, measured
                )
            else:
                cmd = drive.command(trim + q)
                rig.plant.step(cmd, rig.nodes, out[span], surface[span], drive)
            try:
                _check_period(rig, commands, ref, span)
            except DivergenceError as exc:
                if not rig.stop_on_divergence:
                    raise
                rig.ended = str(exc)  # the periods before this one are kept
                k, rows = i, i * n_steps
                break
        if k == 0:
            return
        rig.periods_flown = first + k
        if rig.sensing is not None:  # what the sensors measured, the sensor fault included
            recorded = dict(zip(rig.sensing.channels, sensed[:rows].T, strict=True))
        else:  # the outputs with disturbance.sensor_noise and the sensor fault added
            measured = _measured(out[:rows], rng, sigma, sensor_fault, scn, first * n_steps)
            recorded = dict(zip(scn.channels, measured.T, strict=True))
        yield _Chunk(
            first,
            k,
            nl_out[:rows],
            surface[:rows],
            None if control is None else control[:rows],
            _log(scn, first * n_steps, x_period, k, commands, recorded, rows),
            ref[:rows] if rig.follower else None,
        )
        if rig.ended:
            return


def _buffers(rig: _Rig, rows: int) -> tuple:
    """A chunk's arrays, filled in place: the outputs ``(rows, C)``, the follower's
    ``(rows, C)``, the surface's realised position and the probe path's ``(rows,)``; with the
    autopilot its command of the surface ``(rows,)``, and its commands ``(rows, 3)`` where a
    twin flies them or the log records them (the step loop keeps them only then); with
    sensors their measurements ``(rows, sensors)``."""
    n_ch = len(rig.scn.channels)
    control = np.empty(rows) if rig.loop else None
    commands = np.empty((rows, 3)) if rig.loop and (rig.follower or rig.record) else None
    sensed = np.empty((rows, len(rig.sensing.channels))) if rig.sensing else None
    outputs = (np.empty((rows, n_ch)), np.empty((rows, n_ch)), np.empty(rows), np.empty(rows))
    return (*outputs, control, commands, sensed)


def _log(
    scn: Scenario,
    first_step: int,
    x_period: np.ndarray,
    count: int,
    commands: np.ndarray | None,
    recorded: dict[str, np.ndarray],
    rows: int,
) -> dict[str, np.ndarray]:
    """A chunk's rows of ``sensors.parquet`` (:func:`probing.experiment.layouts.sensors_schema`)."""
    u = scn.surface_unit
    log = {
        "time_s": (first_step + np.arange(1, rows + 1)) * scn.dt_s,
        f"probe_{u}": np.tile(x_period, count),
    }
    if commands is not None:
        for j, name in enumerate(AUTOPILOT_COLUMNS):
            log[name] = commands[:rows, j]
    log.update(recorded)
    return log


def _measured(
    out: np.ndarray,
    rng: np.random.Generator,
    sigma: np.ndarray,
    sensor_fault: Any,
    scn: Scenario,
    first_step: int,
) -> np.ndarray:
    """A chunk's outputs ``(rows, C)`` with sensor noise and the sensor fault (on what the
    aircraft measures, not on its reference) from step ``first_step`` on."""
    rows, n_ch = out.shape
    measured = out + rng.standard_normal((rows, n_ch)) * sigma
    if sensor_fault is not None:
        sensor_fault.apply(measured, scn.channels, first_step, scn.dt_s)
    return measured


def _check_period(rig: _Rig, commands: np.ndarray | None, ref: np.ndarray, span: slice) -> None:
    """After a period: check the plant's state; with a follower, have it replay the period's
    commands into ``ref`` and check its state too (raises DivergenceError)."""
    rig.plant.check_state()
    if rig.follower:
        rig.follower.replay(commands[span], rig.follower_nodes, ref[span])
        try:
            rig.follower.plant.check_state()
        except DivergenceError as exc:
            raise DivergenceError(f"the nominal twin flying our commands: {exc}") from None


class _FaultOnset:
    """A nonlinearity that appears on the probe path at a step: from the onset on, the probe
    after the scenario's nonlinearity passes through it too (its state starts there)."""

    def __init__(self, nl: Nonlinearity | None, onset_s: float, dt_s: float, n_steps: int):
        self.nl, self.dt_s, self.n_steps = nl, dt_s, n_steps
        self.onset = onset_step(onset_s, dt_s) if nl is not None else None
        self.state = nl.initial_state() if nl is not None else None

    def apply(self, q: np.ndarray, period: int) -> np.ndarray:
        """The period's probe path ``q`` (deg) with the fault from its onset on."""
        if self.nl is None:
            return q
        start = self.onset - period * self.n_steps
        if start >= self.n_steps:
            return q
        start = max(start, 0)
        out = q.copy()
        out[start:], self.state = self.nl.process(q[start:], self.dt_s, self.state)
        return out


# ------------------------------------------------------------------ the run
def run_scenario(
    scn: Scenario,
    out: str | Path,
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
    folder: str | Path | None = None,
    twin_cache: bool = True,
    aircraft: TrimmedAircraft | None = None,
    keep_settled: bool = False,
    observer: RunObserver | None = None,
    timeseries: bool = True,
    nominal_twin: bool = False,
    stop_on_divergence: bool = False,
    record: bool = False,
) -> RunResult:
    """Simulate a scenario and write ``out/<name>/probing.parquet``, ``bounds.parquet``
    (:func:`~.bounds.write_settled_bounds`) and ``timeseries.parquet``.

    Parameters
    ----------
    scn : Scenario
        A validated scenario.
    out : path
        Output folder; results go to ``out/<scn.name>/``.
    progress : bool, optional
        Force the progress bar on or off; default: on when ``stream`` is a TTY.
    stream : file, optional
        Where the progress bar goes (default stderr).
    folder : path, optional
        Write into exactly this folder instead of ``out/<scn.name>/`` (used by sweeps).
    twin_cache : bool
        With ``drift = "reference"``: read the unprobed twin from the cache
        (:mod:`probing.sim.twins`) when it is stored, and store it when simulated.  The
        results are bit-identical either way; False simulates the twin and stores nothing.
    aircraft : TrimmedAircraft, optional
        Step this trimmed aircraft (disturbed as the scenario asks) instead of loading and
        trimming one: pass it in a child forked from the aircraft's owner only
        (:mod:`probing.experiment.batch`), whose copy this run then steps.  The results are
        bit-identical either way.
    keep_settled : bool
        Also hand back the first channel's settled periods (``RunResult.settled``), so a
        caller need not read them back from the file.
    observer : RunObserver, optional
        Told every chunk's estimates as they come (the monitor).
    timeseries : bool
        Write ``timeseries.parquet`` (False: only ``probing.parquet``, for long flights).
    nominal_twin : bool
        With ``drift = "reference"``: the twin flies the nominal aircraft, without the
        scenario's damage (what a monitor may know), instead of the same flight.
    stop_on_divergence : bool
        End the flight at a divergence of the probed aircraft and keep the periods flown
        before it (``RunResult.ended`` and the files' ``probing.ended`` say why), instead of
        raising and writing nothing: a monitored flight that departs is still a record.
    record : bool
        Also write ``sensors.parquet``, what the flight computer recorded (a monitored
        flight's log, which ``probing monitor --replay`` reads).

    Returns
    -------
    RunResult
        Trim, averaged pulse-response estimates and timing.

    Raises
    ------
    probing.sim.errors.TrimError, probing.sim.errors.DivergenceError
        On trim failure or divergence; no output file is left behind.
    """
    if runner_of(scn).name != "steady":
        raise ValueError("a [simultaneous] or [manoeuvre] scenario has its own runner")
    t_start = time.perf_counter()
    rig = _Rig.build(scn, twin_cache, aircraft, nominal_twin)
    with rig.twin or nullcontext():  # a simulated twin is stored, or dropped
        rig.stop_on_divergence, rig.record = stop_on_divergence, record
        probe, channels = rig.probe, list(scn.channels)
        m = probe.length
        onboard = Onboard(scn, reference_source(scn, rig.twin), rig.y_trim, rig.chunk_periods * m)
        lag_s = np.arange(m) * probe.bit_duration_s
        folder = Path(folder) if folder is not None else Path(out) / scn.name
        x_period = probe.samples(scn.dt_s, 1)
        with_reference = rig.twin is not None or rig.follower is not None or scn.drift == "gust"
        ts_schema = timeseries_schema(channels, with_reference, rig.loop is not None, scn.surface)
        with output_folder(folder, rig.metadata()) as outputs:
            estimates = EstimatesFile(outputs, scn, lag_s, keep_settled)
            w_ts = _timeseries_writer(outputs, scn, channels, ts_schema, timeseries)
            w_log = _log_writer(outputs, rig) if record else None
            if observer is not None:
                observer.open(outputs)
            with progress_bar(scn.periods, scn.name, "periods", stream, progress) as bar:
                for c in _chunks(rig):
                    if w_log is not None:
                        w_log.write(c.log)
                    done = onboard.estimates(c.log, c.first, c.flown_reference)
                    est, measured, reference = done.estimates, done.measured, done.reference
                    estimates.write(est)
                    if observer is not None:
                        observer.update(est.periods, est.h, est.z, done.trajectory)
                    if w_ts is not None:
                        w_ts.write(
                            _timeseries_rows(c, measured, reference, x_period, scn, channels)
                        )
                    bar.advance(c.count)
                    INTERRUPTS.check()  # a SIGTERM or Ctrl-C held in an import: stop here
            estimates.finish()
            if rig.ended:
                for writer in outputs.writers:
                    writer.add_metadata(metadata(ended=rig.ended))
            if observer is not None:
                observer.finish()
    return _run_result(rig, folder, estimates.settled, lag_s, t_start)


def _timeseries_writer(
    outputs: OutputFolder, scn: Scenario, channels: list[str], ts_schema: Any, timeseries: bool
) -> Any:
    """The writer of ``timeseries.parquet`` (None without ``timeseries``)."""
    if not timeseries:
        return None
    return outputs.writer("timeseries.parquet", channels, scn.surface_unit, schema=ts_schema)


def _log_writer(outputs: OutputFolder, rig: _Rig) -> Any:
    """The writer of ``sensors.parquet``, its footer holding the sensors' reading of the trim
    (``probing.trim_measured``: the baseline of the drift modes without a model)."""
    scn = rig.scn
    channels = rig.sensing.channels if rig.sensing is not None else scn.channels
    schema = sensors_schema(channels, rig.loop is not None, scn.surface)
    writer = outputs.writer("sensors.parquet", channels, scn.surface_unit, schema=schema)
    trim = dict(zip(scn.channels, rig.y_trim.tolist(), strict=True))
    writer.add_metadata(metadata(trim_measured=trim))
    return writer


def _run_result(
    rig: _Rig, folder: Path, settled: SettledMean, lag_s: np.ndarray, t_start: float
) -> RunResult:
    """What a finished run hands back (``t_start``: when it began, for ``wall_s``)."""
    return RunResult(
        out_dir=folder,
        trim=rig.plant.trim_result,
        h_est=settled.mean(),
        steps_simulated=rig.periods_flown * rig.period_steps * (2 if rig.follower else 1)
        + (rig.twin.steps_simulated if rig.twin else 0),
        wall_s=time.perf_counter() - t_start,
        twin_cached=bool(rig.twin and rig.twin.cached),
        twin_key=rig.twin.key if rig.twin else None,
        settled=settled.first_channel(lag_s),
        ended=rig.ended,
    )


def _timeseries_rows(
    c: _Chunk,
    measured: np.ndarray,
    reference: np.ndarray | None,
    x_period: np.ndarray,
    scn: Scenario,
    channels: list[str],
) -> dict[str, np.ndarray]:
    u = scn.surface_unit
    cols = {
        "time_s": c.log["time_s"],
        f"probe_{u}": c.log[f"probe_{u}"],
        f"nl_out_{u}": c.nl_out,
        SURFACES[scn.surface].position_column: c.surface,
    }
    if c.control is not None:
        cols[f"control_{u}"] = c.control
    for j, name in enumerate(channels):
        cols[name] = measured[:, j]
        if reference is not None:
            cols[f"{name}_reference"] = reference[:, j]
    return cols
