"""The flight computer: everything the aircraft's computer does, from measurements to surface
demands, estimates and alarms, in one object that flies against any world.

A :class:`FlightComputer` holds

* the probe and its command path: the scenario's nonlinearity and, from its onset on, a
  fault on that path (:meth:`probe_path`);
* the autopilot flying on measurements, with the probe added on the probed surface
  (:class:`probing.sim.autopilot.Autopilot`; None where nothing is computed step by step);
* the reference and the estimators (:class:`probing.experiment.flight.onboard.Onboard`) and the
  monitor (a :class:`RunObserver`);
* its record (``sensors.parquet``), its estimates (``probing.parquet``, ``bounds.parquet``):
  :meth:`consume` is the one consumer of a chunk of measurements.

It sees what a sensors log holds and nothing else of the simulation.  The world it flies
against is JSBSim in this process (:mod:`probing.experiment.flight.run`), JSBSim as a separate
process (:mod:`probing.experiment.flight.live`), or a recorded log
(:func:`probing.experiment.flight.monitor.replay_monitor`): the same class in all three (tested).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from probing.core.faults import onset_step
from probing.core.nonlinearities import Nonlinearity
from probing.experiment.flight.onboard import Estimated, Onboard, ReferenceSource
from probing.experiment.output.bounds import EstimatesFile
from probing.experiment.output.layouts import AUTOPILOT_COLUMNS, sensors_schema
from probing.experiment.output.storage import OutputFolder, metadata
from probing.experiment.scenario import Scenario
from probing.sim.autopilot import Autopilot, AutopilotTrim, ControlPower
from probing.sim.control import autopilot_for
from probing.sim.errors import DivergenceError
from probing.sim.flight import Control

__all__ = ["FlightComputer", "ProbePathFault", "ReferenceDiverged", "RunObserver"]


class ReferenceDiverged(DivergenceError):
    """The flight computer's reference model left its meaningful region (a gust twin fed
    with a failed sensor's measurements, say): the flight's monitoring ends there, as a
    flight whose aircraft diverges does."""


class RunObserver(Protocol):
    """What follows a flight period by period (the monitor): it may write files of its own
    into the flight's folder, which appear with the flight's files or not at all."""

    def open(self, outputs: OutputFolder) -> None:
        """Called once, with the flight's output folder, before the first period."""

    def update(
        self,
        periods: np.ndarray,
        h: np.ndarray,
        z: np.ndarray,
        trajectory: tuple[np.ndarray, np.ndarray] | None = None,
        isolation: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    ) -> None:
        """Called with each chunk's periods (P,) and their estimates h, z (P, C, M), its
        whole periods with their deviation's features, and each isolation check's
        (:class:`Onboard`'s :class:`Estimated`)."""

    def finish(self) -> None:
        """Called after the last period, before the flight's files are closed."""

    @property
    def isolation_checks(self) -> Mapping[str, tuple[str, ...]]:
        """The isolation checks it reads (:func:`probing.experiment.flight.onboard.
        isolation_columns`), each with its log columns: the flight computer computes those."""


class ProbePathFault:
    """A nonlinearity that appears on the probe path at a step: from the onset on, the probe
    after the scenario's nonlinearity passes through it too (its state starts there)."""

    def __init__(self, nl: Nonlinearity | None, onset_s: float, dt_s: float, n_steps: int):
        self.nl, self.dt_s, self.n_steps = nl, dt_s, n_steps
        self.onset = onset_step(onset_s, dt_s) if nl is not None else None
        self.state = nl.initial_state() if nl is not None else None

    def apply(self, q: np.ndarray, period: int) -> np.ndarray:
        """The period's probe path ``q`` (its unit) with the fault from its onset on."""
        if self.nl is None:
            return q
        start = self.onset - period * self.n_steps
        if start >= self.n_steps:
            return q
        start = max(start, 0)
        out = q.copy()
        out[start:], self.state = self.nl.process(q[start:], self.dt_s, self.state)
        return out


class FlightComputer:
    """The aircraft's computer (module docstring).

    Parameters
    ----------
    scn : Scenario
        The flight's scenario.
    autopilot : Autopilot or None
        The control law, flying on the world's measurements (:func:`flight_autopilot`);
        None: the probed surface is demanded at its trim plus the probe, a period at a time.
    baseline : numpy.ndarray
        ``(channels,)``: the trim as measured (what is subtracted without a reference).
    source : ReferenceSource or None
        The reference (:func:`probing.experiment.flight.onboard.reference_source`).
    chunk_periods : int
        Periods estimated together (the streaming correlator's block).
    monitor : RunObserver, optional
        The detectors, told every chunk's estimates.
    """

    def __init__(
        self,
        scn: Scenario,
        autopilot: Autopilot | None,
        baseline: np.ndarray,
        source: ReferenceSource | None,
        chunk_periods: int,
        monitor: RunObserver | None = None,
    ) -> None:
        self.scn, self.autopilot, self.monitor = scn, autopilot, monitor
        self.chunk_periods = int(chunk_periods)
        self.period_steps = scn.period_steps
        self.x_period = scn.probe.samples(scn.dt_s, 1)
        self.nl = scn.build_nonlinearity()
        self._nl_state = self.nl.initial_state() if self.nl else None
        self.fault = ProbePathFault(
            scn.build_fault_nonlinearity(), scn.fault_onset_s, scn.dt_s, self.period_steps
        )
        self.baseline = baseline
        checks = monitor.isolation_checks if monitor is not None else None
        push_bits = self.chunk_periods * scn.bits_per_period
        self.onboard = Onboard(scn, source, baseline, push_bits, checks)
        self.estimates: EstimatesFile | None = None
        self._log_writer: Any = None

    # ------------------------------------------------------------ per step
    def probe_path(self, period: int) -> np.ndarray:
        """The probe path's deflection of every step of ``period`` (the probe after the
        scenario's nonlinearity and a probe-path fault), the probed surface's unit; call it
        once per period, in order."""
        q = self.x_period
        if self.nl:
            q, self._nl_state = self.nl.process(self.x_period, self.scn.dt_s, self._nl_state)
        return self.fault.apply(q, period)

    # ------------------------------------------------------------ per chunk
    def log(
        self,
        first_step: int,
        count: int,
        commands: np.ndarray | None,
        recorded: Mapping[str, np.ndarray],
    ) -> dict[str, np.ndarray]:
        """A chunk's rows of ``sensors.parquet`` (:func:`sensors_schema`): the time, the probe,
        the autopilot's commands (``(rows, 3)`` or None) and what the sensors measured."""
        u = self.scn.surface_unit
        rows = count * self.period_steps
        log = {
            "time_s": (first_step + np.arange(1, rows + 1)) * self.scn.dt_s,
            f"probe_{u}": np.tile(self.x_period, count),
        }
        if commands is not None:
            for j, name in enumerate(AUTOPILOT_COLUMNS):
                log[name] = commands[:rows, j]
        log.update(recorded)
        return log

    def open(
        self,
        outputs: OutputFolder,
        lag_s: np.ndarray,
        *,
        log_channels: list[str] | None = None,
        keep_settled: bool = False,
        commanded: bool | None = None,
        **log_meta: Any,
    ) -> None:
        """Open the flight's files in ``outputs``: the estimates, the monitor's, and with
        ``log_channels`` the log of those channels (its footer: the trim as measured and
        ``log_meta``); ``commanded``: the log holds the autopilot's commands (default: this
        computer flies one; a computer reading another's flight has none of its own)."""
        scn = self.scn
        self.estimates = EstimatesFile(outputs, scn, lag_s, keep_settled)
        if log_channels is not None:
            if commanded is None:
                commanded = self.autopilot is not None
            schema = sensors_schema(log_channels, commanded, scn.surface)
            writer = outputs.writer(
                "sensors.parquet", log_channels, scn.surface_unit, schema=schema
            )
            trim = dict(zip(scn.channels, self.baseline.tolist(), strict=True))
            writer.add_metadata(metadata(trim_measured=trim, **log_meta))
            self._log_writer = writer
        if self.monitor is not None:
            self.monitor.open(outputs)

    def consume(self, log: Mapping[str, np.ndarray], first: int) -> Estimated:
        """A chunk of whole periods from period ``first`` on: logged, estimated, written and
        told to the monitor.

        Raises
        ------
        ReferenceDiverged
            If the reference diverged in the chunk: the chunk is logged, and its whole periods
            before the one the reference diverged in are estimated, written and told to the
            monitor (a flight's detection does not wait for the chunk's end).
        """
        assert self.estimates is not None, "open first"
        if self._log_writer is not None:
            self._log_writer.write(log)
        try:
            done = self.onboard.estimates(log, first)
        except DivergenceError as exc:
            raise ReferenceDiverged(f"the reference: {exc}") from None
        est = done.estimates
        self.estimates.write(est)
        if self.monitor is not None:
            self.monitor.update(est.periods, est.h, est.z, done.trajectory, done.isolation)
        if done.ended is not None:
            raise ReferenceDiverged(f"the reference: {done.ended}")
        return done

    def finish(self, outputs: OutputFolder, ended: str | bytes | None = None) -> None:
        """After the last chunk: the settled mean and bounds, why the flight ended early
        (``probing.ended`` on every file) and the monitor's last rows."""
        assert self.estimates is not None
        self.estimates.finish()
        if ended is not None:  # as a flight wrote it (a replay), or a divergence's message
            meta = {b"probing.ended": ended} if isinstance(ended, bytes) else metadata(ended=ended)
            for writer in outputs.writers:
                writer.add_metadata(meta)
        if self.monitor is not None:
            self.monitor.finish()


def flight_autopilot(
    scn: Scenario,
    world: Any,
    power: ControlPower | None,
    trim: AutopilotTrim | None = None,
) -> Autopilot | None:
    """The flight computer's autopilot, flying on ``world``'s measurements
    (:func:`probing.sim.control.autopilot_for`), or None where it computes nothing step by
    step: the one rule, for every world (a loop, an actuator fault or sensors act between
    the probe and the surface).  ``trim``: its trim and actuator map where the world is not
    a :class:`~probing.sim.world.JSBSimWorld` that knows them."""
    if not (scn.stepped_one_by_one or scn.sensors is not None):
        return None
    return autopilot_for(world, scn.control or Control(), power, trim=trim)


def folder_of(out: str | Path, name: str, folder: str | Path | None) -> Path:
    """The flight's folder: ``folder``, else ``out/<name>``."""
    return Path(folder) if folder is not None else Path(out) / name
