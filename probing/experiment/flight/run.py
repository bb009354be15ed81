"""One probing run: scenario -> trimmed plant -> probe + nonlinearity -> correlator -> Parquet.

Timing conventions (documented in ``docs/method.md``):

* Step k applies probe sample k (the probed surface's command is written, then
  ``run()``); output sample k is read right after that step.
* A bit spanning several steps becomes one correlator sample: the output read after the
  *last* step of the bit (end-of-bit sampling).  This is exactly the zero-order-hold
  discretisation at the bit duration, so the taps are the pulse response sampled at t0.

The run is four pieces, each small: :class:`_Rig` (set-up: probe, nonlinearity, trimmed
plant, twin, metadata), :func:`_chunks` (stepping, period by period, handed on in chunks of
whole periods), a drift correction per ``output.drift`` mode
(:func:`probing.experiment.flight.drift.drift_correction`) that turns a chunk into per-period
estimates, and :class:`probing.experiment.output.settled.SettledMean` (the average over the
settled periods, and their per-tap bounds for ``bounds.parquet``).
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from probing.core.forked import INTERRUPTS
from probing.core.measuring import ChannelNoise
from probing.core.prbs import Probe
from probing.experiment.flight.flight_computer import (
    FlightComputer,
    ReferenceDiverged,
    RunObserver,
    flight_autopilot,
    folder_of,
)
from probing.experiment.flight.onboard import (
    Estimated,
    calm_nominal,
    open_reference_twin,
    reference_source,
)
from probing.experiment.flight.runners import runner_of
from probing.experiment.output.progress import progress_bar
from probing.experiment.output.storage import (
    OutputFolder,
    Settled,
    output_folder,
    provenance,
    timeseries_schema,
)
from probing.experiment.scenario import Scenario
from probing.experiment.scenario.references import REFERENCE_FIELDS, REFERENCES
from probing.sim.autopilot import Autopilot
from probing.sim.control import control_power
from probing.sim.errors import DivergenceError
from probing.sim.fork import TrimmedAircraft, trim_key, trim_spec
from probing.sim.plant import Plant, TrimResult, make_plant
from probing.sim.sensing import Sensing
from probing.sim.surfaces import SURFACES
from probing.sim.twins import ReferenceTwin
from probing.sim.world import JSBSimWorld

__all__ = ["Companion", "RunObserver", "RunResult", "chunk_periods", "flight_key", "run_scenario"]

#: Steps post-processed together (noise, correlation, Parquet rows): whole periods, at
#: least one; the plant is still stepped and checked period by period.
CHUNK_STEPS = 8192


def chunk_periods(period_steps: int) -> int:
    """Periods estimated together here: about :data:`CHUNK_STEPS` steps, at least one."""
    return max(1, CHUNK_STEPS // period_steps)


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
        :func:`probing.experiment.output.storage.read_settled` reads them back from the file.
    ended : str or None
        With ``stop_on_divergence``: why the flight ended before its last period (the
        divergence), None if it flew them all.
    companions : list of RunResult
        What each :class:`Companion` of the run computed, in their order; their
        ``steps_simulated`` count their own reference's steps only (the aircraft's are the
        run's), their ``wall_s`` is the whole call's.
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
    companions: list[RunResult] = field(default_factory=list)


@dataclass(frozen=True)
class Companion:
    """A scenario computed from the flight of another: the two differ only in their reference
    (``output.drift``, :func:`flight_key`), so the aircraft, its turbulence, sensors,
    autopilot and probe fly the same steps.  Its own flight computer reads the flight's log
    chunk by chunk, with its own reference, estimates, monitor and files, exactly as if it had
    flown them (``tests/sweep/test_flight_families.py``): a study's references of one flight
    fly it once (:mod:`probing.sweep.tasks`).

    Attributes
    ----------
    scn : Scenario
        Its scenario.
    folder : pathlib.Path
        Where its files go.
    observer : RunObserver, optional
        Its monitor.
    """

    scn: Scenario
    folder: Path
    observer: RunObserver | None = None


def flight_key(scn: Scenario) -> str:
    """What makes two scenarios one flight (a :class:`Companion` of each other): everything
    of the scenario but its reference and the reference's settings (:data:`REFERENCE_FIELDS`),
    which only the flight computer's estimates read."""
    resolved = scn.to_dict()
    output = {k: v for k, v in resolved["output"].items() if k not in REFERENCE_FIELDS}
    return json.dumps({**resolved, "output": output}, sort_keys=True)


# ------------------------------------------------------------------ set-up
@dataclass
class _Rig:
    """Everything a run steps with, built from the scenario: the world in this process (the
    aircraft, its actuator, damage, turbulence and sensors) and what the flight computer
    knows of it (its autopilot, flying on the world's sensors)."""

    scn: Scenario
    probe: Probe
    plant: Plant
    world: JSBSimWorld
    autopilot: Autopilot | None  # stepping one step at a time: a loop, a fault, sensors
    nodes: list
    y_trim: np.ndarray
    stop_on_divergence: bool = False
    ended: str | None = None  # why the flight ended early (stop_on_divergence)
    periods_flown: int = 0
    record: bool = False  # write sensors.parquet: the autopilot's commands are kept then

    @classmethod
    def build(cls, scn: Scenario, aircraft: TrimmedAircraft | None) -> _Rig:
        flight = scn.flight
        power = control_power(flight) if flight.closed_loop else None
        plant = aircraft.plant_for(flight) if aircraft else make_plant(flight)
        sensing = None
        if scn.sensors is not None:
            sensing = Sensing(plant, scn.sensors, scn.seed, scn.build_fault("sensor"))
        world = JSBSimWorld(plant, scn.surface, fault=scn.actuator_fault, sensing=sensing)
        autopilot = flight_autopilot(scn, world, power)
        nodes = plant.channel_nodes(list(scn.channels))
        if sensing is not None:  # the sensors' reading of the trim
            y_trim = np.array([sensing.current[sensing.index(c)] for c in scn.channels])
        else:
            y_trim = np.array([n.get_double_value() for n in nodes])
        return cls(scn, scn.probe, plant, world, autopilot, nodes, y_trim)

    @property
    def lag_s(self) -> np.ndarray:
        """The estimates' lags: one per bit of a period, s."""
        return np.arange(self.probe.length) * self.probe.bit_duration_s


@dataclass
class _Reader:
    """A flight computer reading the flight, with what its reference flies and its files: the
    flown scenario's, or a :class:`Companion`'s."""

    scn: Scenario
    folder: Path
    computer: FlightComputer
    twin: ReferenceTwin | None
    follower: Plant | None  # a log reference's own aircraft (``follow``, ``gust``)
    nominal_twin: bool
    outputs: OutputFolder | None = None
    diverged: str | None = None  # why its reference ended its reading (stop_on_divergence)
    periods: int = 0  # periods it read

    def metadata(self, trim: TrimResult) -> dict[bytes, bytes]:
        """The key-value metadata of its files."""
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
        return scenario_provenance(scn, trim, **meta)

    def read(self, c: _Chunk, stop_on_divergence: bool) -> Estimated | None:
        """Its flight computer's reading of a chunk; None once its reference has diverged
        (with ``stop_on_divergence``, else that raises)."""
        if self.diverged is not None:
            return None
        self.periods = c.first + c.count
        try:
            return self.computer.consume(c.log, c.first)
        except ReferenceDiverged as exc:
            if not stop_on_divergence:
                raise
            self.diverged = str(exc)  # the periods before this chunk are kept
            return None


def _reader(
    stack: ExitStack,
    rig: _Rig,
    companion: Companion,
    options: tuple[bool, TrimmedAircraft | None, bool],
    taken: set[str],
) -> _Reader:
    """A reader of ``rig``'s flight for ``companion``: its twin (closed with ``stack``) and its
    follower (``taken``: the kinds of second aircraft already handed out), its flight
    computer (with the autopilot for the flown scenario only).  ``options``: the run's
    ``twin_cache``, ``aircraft`` and ``nominal_twin``."""
    twin_cache, aircraft, nominal_twin = options
    scn = companion.scn
    twin = open_reference_twin(scn, nominal=nominal_twin, use_cache=twin_cache)
    if twin is not None:
        stack.enter_context(twin)  # a simulated twin is stored, or dropped
    follower = None
    flies = REFERENCES[scn.drift].flies  # a trimmed nominal aircraft the reference flies
    if flies:
        gust_inputs = flies == "gust_ready"
        calm = calm_nominal(scn.flight)  # a model of the aircraft knows no gusts
        if aircraft is not None and aircraft.key == trim_key(calm) and flies not in taken:
            follower = aircraft.second_for(calm, gust_inputs)
        taken.add(flies)
        follower = follower or make_plant(calm, gust_inputs=gust_inputs)
    source = reference_source(scn, twin, follower)
    autopilot = rig.autopilot if scn is rig.scn else None
    computer = FlightComputer(
        scn, autopilot, rig.y_trim, source, chunk_periods(rig.scn.period_steps), companion.observer
    )
    return _Reader(scn, companion.folder, computer, twin, follower, nominal_twin)


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


def _chunks(rig: _Rig, computer: FlightComputer) -> Iterator[_Chunk]:
    """Fly the flight computer against the world period by period, checking the state after
    each; yield the periods in chunks of about
    :data:`CHUNK_STEPS` steps with what the flight computer recorded."""
    scn, n_steps = rig.scn, rig.scn.period_steps
    noise = ChannelNoise(
        scn.channels,
        [scn.sensor_noise.get(c, 0.0) for c in scn.channels],
        scn.seed,
        scn.build_fault("sensor"),
        scn.dt_s,
    )
    chunk = computer.chunk_periods  # the periods the flight computer estimates together
    out, surface, nl_out, control, commands, sensed = _buffers(rig, chunk * n_steps)
    for first in range(0, scn.periods, chunk):
        k = min(chunk, scn.periods - first)
        rows = k * n_steps
        for i in range(k):
            span = slice(i * n_steps, (i + 1) * n_steps)
            nl_out[span] = q = computer.probe_path(first + i)
            _fly_period(rig, computer, q, span, out, surface, control, commands, sensed)
            try:
                rig.plant.check_state()
            except DivergenceError as exc:
                if not rig.stop_on_divergence:
                    raise
                rig.ended = str(exc)  # the periods before this one are kept
                k, rows = i, i * n_steps
                break
        if k == 0:
            return
        rig.periods_flown = first + k
        if rig.world.sensing is not None:  # what the sensors measured, the fault included
            recorded = dict(zip(rig.world.sensing.channels, sensed[:rows].T, strict=True))
        else:  # the outputs with disturbance.sensor_noise and the sensor fault added
            measured = noise.measure(out[:rows], first * n_steps)
            recorded = dict(zip(scn.channels, measured.T, strict=True))
        yield _Chunk(
            first,
            k,
            nl_out[:rows],
            surface[:rows],
            None if control is None else control[:rows],
            computer.log(first * n_steps, k, commands, recorded),
        )
        if rig.ended:
            return


def _fly_period(
    rig: _Rig,
    computer: FlightComputer,
    q: np.ndarray,
    span: slice,
    out: np.ndarray,
    surface: np.ndarray,
    control: np.ndarray | None,
    commands: np.ndarray | None,
    sensed: np.ndarray | None,
) -> None:
    """One period of the flight computer's demands, flown by the world."""
    measured = sensed[span] if sensed is not None else None
    flown = commands[span] if commands is not None else None
    rig.world.fly_probe(
        computer.autopilot,
        q,
        rig.nodes,
        out[span],
        position=surface[span],
        control=control[span] if control is not None else None,
        commands=flown,
        measured=measured,
    )


def _buffers(rig: _Rig, rows: int) -> tuple:
    """A chunk's arrays, filled in place: the outputs ``(rows, C)``, the surface's realised
    position and the probe path's ``(rows,)``; with the autopilot its command of the surface
    ``(rows,)``, and its commands ``(rows, 3)`` where a twin flies them or the log records
    them (the step loop keeps them only then); with sensors their measurements
    ``(rows, sensors)``."""
    n_ch = len(rig.scn.channels)
    stepped = rig.autopilot is not None
    sensing = rig.world.sensing
    control = np.empty(rows) if stepped else None
    commands = np.empty((rows, 3)) if stepped and (rig.scn.follows or rig.record) else None
    sensed = np.empty((rows, len(sensing.channels))) if sensing else None
    outputs = (np.empty((rows, n_ch)), np.empty(rows), np.empty(rows))
    return (*outputs, control, commands, sensed)


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
    companions: Sequence[Companion] = (),
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
        (:mod:`probing.experiment.flight.batch`), whose copy this run then steps.  The results are
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
    companions : sequence of Companion
        Scenarios computed from this flight with references of their own
        (:class:`Companion`, needs ``stop_on_divergence``): one flight instead of one each,
        the same files.  A companion's reference that diverges ends its reading only; the
        aircraft's divergence ends all.

    Returns
    -------
    RunResult
        Trim, averaged pulse-response estimates and timing (the companions' in
        ``RunResult.companions``).

    Raises
    ------
    probing.sim.errors.TrimError, probing.sim.errors.DivergenceError
        On trim failure or divergence; no output file is left behind.
    ValueError
        If a companion is not this flight with another reference.
    """
    if runner_of(scn).name != "steady":
        raise ValueError("a [simultaneous] or [manoeuvre] scenario has its own runner")
    _check_companions(scn, companions, stop_on_divergence)
    t_start = time.perf_counter()
    folder = folder_of(out, scn.name, folder)
    with ExitStack() as stack:
        rig = _Rig.build(scn, aircraft)
        rig.stop_on_divergence, rig.record = stop_on_divergence, record
        options, taken = (twin_cache, aircraft, nominal_twin), set()
        flown = Companion(scn, folder, observer)
        readers = [_reader(stack, rig, c, options, taken) for c in (flown, *companions)]
        _open_files(stack, rig, readers, keep_settled)
        w_ts = _timeseries_writer(readers[0], rig, timeseries)
        channels = list(scn.channels)
        with progress_bar(scn.periods, scn.name, "periods", stream, progress) as bar:
            for c in _chunks(rig, readers[0].computer):
                done = [r.read(c, stop_on_divergence) for r in readers]
                if w_ts is not None and done[0] is not None:
                    w_ts.write(
                        _timeseries_rows(c, done[0].measured, done[0].reference, scn, channels)
                    )
                bar.advance(c.count)
                INTERRUPTS.check()  # a SIGTERM or Ctrl-C held in an import: stop here
                if all(r.diverged for r in readers):
                    break
        for r in readers:
            assert r.outputs is not None
            r.computer.finish(r.outputs, r.diverged or rig.ended)
    results = [_run_result(rig, r, t_start, r is readers[0]) for r in readers]
    results[0].companions = results[1:]
    return results[0]


def _check_companions(
    scn: Scenario, companions: Sequence[Companion], stop_on_divergence: bool
) -> None:
    """Raise ValueError unless every companion is ``scn``'s flight (:func:`flight_key`; its
    reference and the reference's settings its own), and a reference's divergence ends only
    its own reading (``stop_on_divergence``)."""
    if not companions:
        return
    if not stop_on_divergence:
        raise ValueError("companions read a flight that stops on a divergence only")
    key = flight_key(scn)
    if any(flight_key(c.scn) != key for c in companions):
        raise ValueError(f"{scn.name}: a companion must be the same flight with another reference")


def _open_files(stack: ExitStack, rig: _Rig, readers: list[_Reader], keep_settled: bool) -> None:
    """Open each reader's folder (closed with ``stack``: all files appear at the end, or
    none) and its flight computer's files; with ``rig.record`` each logs what the sensors
    measured."""
    sensing = rig.world.sensing
    logged = list(sensing.channels if sensing is not None else rig.scn.channels)
    for r in readers:
        r.outputs = stack.enter_context(output_folder(r.folder, r.metadata(rig.plant.trim_result)))
        r.computer.open(
            r.outputs,
            rig.lag_s,
            log_channels=logged if rig.record else None,
            keep_settled=keep_settled,
            commanded=rig.autopilot is not None,
        )


def _timeseries_writer(flown: _Reader, rig: _Rig, timeseries: bool) -> Any:
    """The writer of the flown scenario's ``timeseries.parquet`` (None without
    ``timeseries``)."""
    if not timeseries:
        return None
    scn, channels = rig.scn, list(rig.scn.channels)
    with_reference = flown.computer.onboard.source is not None  # what it subtracts, if a model
    stepped = rig.autopilot is not None
    schema = timeseries_schema(channels, with_reference, stepped, scn.surface)
    assert flown.outputs is not None
    return flown.outputs.writer("timeseries.parquet", channels, scn.surface_unit, schema=schema)


def _run_result(rig: _Rig, reader: _Reader, t_start: float, flown: bool) -> RunResult:
    """What a finished run hands back for one reader (``flown``: the flown scenario's, which
    counts the aircraft's steps; ``t_start``: when the run began, for ``wall_s``)."""
    estimates = reader.computer.estimates
    assert estimates is not None
    settled = estimates.settled
    twin = reader.twin
    steps = rig.periods_flown * rig.scn.period_steps if flown else 0
    steps += reader.periods * rig.scn.period_steps if reader.follower else 0
    return RunResult(
        out_dir=reader.folder,
        trim=rig.plant.trim_result,
        h_est=settled.mean(),
        steps_simulated=steps + (twin.steps_simulated if twin else 0),
        wall_s=time.perf_counter() - t_start,
        twin_cached=bool(twin and twin.cached),
        twin_key=twin.key if twin else None,
        settled=settled.first_channel(rig.lag_s),
        ended=reader.diverged or rig.ended,
    )


def _timeseries_rows(
    c: _Chunk,
    measured: np.ndarray,
    reference: np.ndarray | None,
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
