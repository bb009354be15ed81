"""``probing monitor``: a flight probed continuously, with a change detector after every period.

The flight is the scenario's run (:func:`probing.experiment.flight.run.run_scenario`), with its
fault if it has one.  The monitor knows nothing of the fault: it learns its baseline from the
flight's own first settled periods, and with ``drift = "reference"`` its reference twin is the
*nominal* aircraft flying the same commands (:attr:`probing.sim.flight.Flight.nominal`), not a
twin that knows the damage.  ``drift = "detrend"`` needs no model at all.

After every completed period each channel's :class:`~probing.core.monitor.ChangeDetector`
tests the period's estimate; ``monitor.parquet`` gets one row per period and channel, and its
metadata the first alarm and the flight's verdict (``docs/monitoring.md``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Sequence
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from probing.core.errors import ProbingError
from probing.core.isolation import DETECTORS, ISOLATION_CHECKS, isolated_verdict
from probing.core.monitor import ChangeDetector, MonitorSettings, flight_verdict
from probing.core.trajectory import TrajectoryDetector
from probing.experiment.flight.flight_computer import FlightComputer, ReferenceDiverged, folder_of
from probing.experiment.flight.flight_log import replay_columns, wrong_rows, wrong_type
from probing.experiment.flight.onboard import (
    isolation_columns,
    open_reference_twin,
    reference_source,
)
from probing.experiment.flight.run import Companion, RunResult, chunk_periods, run_scenario
from probing.experiment.output.progress import progress_bar
from probing.experiment.output.storage import (
    MONITOR_SCHEMA,
    AtomicParquetWriter,
    OutputFolder,
    metadata,
    output_folder,
    read_footer,
    read_schema,
)
from probing.experiment.scenario import Scenario, ScenarioError, parse_scenario
from probing.sim.fork import TrimmedAircraft

__all__ = [
    "Monitor",
    "MonitorResult",
    "ReplayError",
    "logged_chunk_periods",
    "logged_scenario",
    "monitor_flight",
    "monitor_scenario",
    "replay_monitor",
]


@dataclass
class MonitorResult:
    """What a monitored flight found.

    Attributes
    ----------
    run : RunResult or None
        The flight's run (None for a replay of its log).
    first_alarm_s : float or None
        Time after the trim of the end of the first alarmed period, s (None: no alarm).
    first_alarm_period : int or None
        That period.
    verdict : str
        ``"none"``, ``"actuator"`` or ``"airframe"``.
    alpha : float
        False-alarm probability per period and channel the thresholds are set for.
    ended : str or None
        Why the flight ended before its last period (a divergence), or None.
    out_dir : pathlib.Path or None
        The folder of ``monitor.parquet``.
    alarm_detector : str or None
        The detector that alarmed first, ``"probing"`` or ``"trajectory"`` (None: no alarm).
    first_probing_alarm_s, first_trajectory_alarm_s : float or None
        Each detector's first alarm, s after the trim (None: it never alarmed).
    """

    run: RunResult | None
    first_alarm_s: float | None
    first_alarm_period: int | None
    verdict: str
    alpha: float
    ended: str | None = None
    out_dir: Path | None = None
    alarm_detector: str | None = None
    first_probing_alarm_s: float | None = None
    first_trajectory_alarm_s: float | None = None

    def facts(self) -> dict[str, float | int | str | None]:
        """The result as plain JSON values (a sweep point's record)."""
        return {
            "first_alarm_s": self.first_alarm_s,
            "first_alarm_period": self.first_alarm_period,
            "verdict": self.verdict,
            "alpha_per_period": self.alpha,
            "ended": self.ended,
            "alarm_detector": self.alarm_detector,
            "first_probing_alarm_s": self.first_probing_alarm_s,
            "first_trajectory_alarm_s": self.first_trajectory_alarm_s,
        }

    def line(self) -> str:
        """The two facts on one line, as the command prints them."""
        if self.first_alarm_s is None:
            when = "none"
        else:
            by = "" if self.alarm_detector is None else f", {self.alarm_detector}"
            when = f"{self.first_alarm_s:.2f} s (period {self.first_alarm_period}{by})"
        line = f"first alarm: {when}; verdict: {self.verdict}"
        return line if self.ended is None else f"{line}; the flight ended: {self.ended}"


#: Every row's ``detector``, in the order of a period's rows: the detectors, then the
#: isolation checks (:mod:`probing.core.isolation`, with a sensor suite), which raise no
#: alarm of the flight's but decide its verdict.
ROW_DETECTORS = (*DETECTORS, *ISOLATION_CHECKS)


class Monitor:
    """The detectors of a flight's channels, fed by the run (a :class:`RunObserver`): per
    monitored channel a probing detector (:class:`~probing.core.monitor.ChangeDetector`)
    and a trajectory detector (:class:`~probing.core.trajectory.TrajectoryDetector`)."""

    def __init__(self, scn: Scenario, settings: MonitorSettings) -> None:
        self.scn, self.settings = scn, settings
        self.period_s = scn.period_s
        channels = list(scn.channels)
        self.surface = channels.index(scn.surface_channel) if settings.surface else None
        self.monitored = [(j, c) for j, c in enumerate(channels) if j != self.surface]
        self.alpha = settings.alpha(self.period_s, len(self.monitored))
        self.trajectory_alpha = settings.trajectory_alpha(self.period_s, len(self.monitored))
        m = scn.bits_per_period
        self.detectors = [
            ChangeDetector.from_settings(m, settings, self.alpha) for _ in self.monitored
        ]
        self.trajectories = [
            TrajectoryDetector(
                settings.baseline_periods, self.trajectory_alpha, settings.baseline_gap_periods
            )
            for _ in self.monitored
        ]
        #: each isolation check's row channel (the first column it reads), its detector, and
        #: its alarmed periods; its false-alarm probability per period shares the shape test's
        #: over the periods the verdict looks at (:func:`isolated_verdict`)
        self.isolation_checks = isolation_columns(scn)
        checks = self.isolation_checks
        self.check_channels = {check: columns[0] for check, columns in checks.items()}
        self.lookback = settings.window_periods + 1
        span = self.lookback + settings.verdict_periods + 1
        self.isolation_alpha = settings.shape_false_alarm / span
        gap = settings.baseline_gap_periods
        self.isolators = {
            c: TrajectoryDetector(settings.baseline_periods, self.isolation_alpha, gap)
            for c in checks
        }
        self.isolation_alarms: dict[str, list[int]] = {c: [] for c in checks}
        self.first = max(scn.settle_periods, scn.first_estimated_period)
        #: the first alarmed period of each detector, any channel (None: no alarm yet)
        self.first_alarms: dict[str, int | None] = dict.fromkeys(DETECTORS)
        #: each monitored channel's verdict: decided once its isolation periods are in, the
        #: latest alarmed row's until then ("none": no alarm yet)
        self.verdicts = ["none"] * len(self.monitored)
        self.decided = [False] * len(self.monitored)
        self.writer: AtomicParquetWriter | None = None

    def open(self, outputs: OutputFolder) -> None:
        channels = [c for _, c in self.monitored]
        channels += [c for c in self.check_channels.values() if c not in channels]
        self.writer = outputs.writer("monitor.parquet", channels)

    def update(
        self,
        periods: np.ndarray,
        h: np.ndarray,
        z: np.ndarray,
        trajectory: tuple[np.ndarray, np.ndarray] | None = None,
        isolation: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    ) -> None:
        rows: list[tuple] = []
        for i, p in enumerate(periods.tolist()):
            if p >= self.first:
                rows += self._probing(p, h[i])
        if trajectory is not None:
            for p, features in zip(trajectory[0].tolist(), trajectory[1], strict=True):
                if p >= self.first:
                    rows += self._trajectory(p, features)
        for check, (whole, features) in (isolation or {}).items():
            for p, f in zip(whole.tolist(), features, strict=True):
                if p >= self.first:
                    rows.append(self._isolation(check, p, f[0]))
        rows.sort(key=lambda r: (r[0], ROW_DETECTORS.index(r[3])))  # by period, then detector
        if rows and self.writer is not None:
            names = [f.name for f in MONITOR_SCHEMA]
            self.writer.write({n: [r[k] for r in rows] for k, n in enumerate(names)})

    def _probing(self, p: int, h: np.ndarray) -> list[tuple]:
        """The probing detectors' rows of period ``p`` (its estimates ``h`` (C, M))."""
        rows = []
        surface = None if self.surface is None else h[self.surface]
        for c, ((j, channel), det) in enumerate(zip(self.monitored, self.detectors, strict=True)):
            d = det.update(h[j], surface)
            if not self.decided[c] and d.verdict != "none":
                self.verdicts[c] = d.verdict
            if not self.decided[c] and det.isolated:
                self.verdicts[c] = "airframe" if d.shape_change > 1.0 else "actuator"
                self.decided[c] = True
            row = self._row(p, channel, "probing", d.statistic, d.threshold, d.alarm)
            rows.append((*row[:-3], d.gain_change, d.shape_change, d.verdict))
        return rows

    def _trajectory(self, p: int, features: np.ndarray) -> list[tuple]:
        """The trajectory detectors' rows of period ``p`` (its features ``(C, 2)``)."""
        rows = []
        for (j, channel), det in zip(self.monitored, self.trajectories, strict=True):
            d = det.update(features[j])
            rows.append(self._row(p, channel, "trajectory", d.statistic, d.threshold, d.alarm))
        return rows

    def _isolation(self, check: str, p: int, features: np.ndarray) -> tuple:
        """The row of isolation check ``check`` for period ``p`` (its features ``(2,)``)."""
        d = self.isolators[check].update(features)
        if d.alarm:
            self.isolation_alarms[check].append(p)
        return self._row(p, self.check_channels[check], check, d.statistic, d.threshold, d.alarm)

    @property
    def verdict(self) -> str:
        """The flight's verdict: with isolation checks theirs around the first alarm
        (:func:`probing.core.isolation.isolated_verdict`), else the channels' majority
        (:func:`probing.core.monitor.flight_verdict`)."""
        if not self.isolators:
            return flight_verdict(self.verdicts)
        return isolated_verdict(
            self.first_alarm,
            self.isolation_alarms,
            self.lookback,
            self.settings.verdict_periods,
        )

    def _row(
        self, p: int, channel: str, detector: str, statistic: float, threshold: float, alarm: bool
    ) -> tuple:
        """A row of ``monitor.parquet`` (the isolation's columns empty: a trajectory row's)."""
        if alarm and detector in DETECTORS and self.first_alarms[detector] is None:
            self.first_alarms[detector] = p
        time_s = (p + 1) * self.period_s
        return (
            p,
            time_s,
            channel,
            detector,
            statistic,
            threshold,
            alarm,
            math.nan,
            math.nan,
            "none",
        )

    @property
    def first_alarm(self) -> int | None:
        """The first alarmed period of either detector."""
        found = [p for p in self.first_alarms.values() if p is not None]
        return min(found) if found else None

    @property
    def alarm_detector(self) -> str | None:
        """The detector that alarmed first (the probing one on a tie), None if neither."""
        first = self.first_alarm
        return (
            None if first is None else next(d for d in DETECTORS if self.first_alarms[d] == first)
        )

    def finish(self) -> None:
        """The first alarms and the verdict into the file's footer."""
        assert self.writer is not None
        self.writer.add_metadata(
            metadata(
                first_alarm_s=self._end_of(self.first_alarm),
                first_alarm_period=self.first_alarm,
                alarm_detector=self.alarm_detector,
                first_probing_alarm_s=self._end_of(self.first_alarms["probing"]),
                first_trajectory_alarm_s=self._end_of(self.first_alarms["trajectory"]),
                verdict=self.verdict,
                detector={
                    **self.settings.to_dict(),
                    "alpha_per_period": self.alpha,
                    "trajectory_alpha_per_period": self.trajectory_alpha,
                    "period_s": self.period_s,
                    "threshold": self.detectors[0].threshold,
                    "shape_threshold": self.detectors[0].shape_threshold,
                    "trajectory_threshold": self.trajectories[0].threshold,
                    **self._isolation_settings(),
                },
            )
        )

    def _isolation_settings(self) -> dict[str, object]:
        """The isolation checks' settings for the footer (none without checks)."""
        if not self.isolators:
            return {}
        return {
            "isolation_checks": list(self.isolators),
            "isolation_alpha_per_period": self.isolation_alpha,
            "isolation_lookback_periods": self.lookback,
        }

    def _end_of(self, period: int | None) -> float | None:
        """The end of ``period`` after the trim, s (None for None)."""
        return None if period is None else (period + 1) * self.period_s

    def result(self, run: RunResult | None, out_dir: Path, ended: str | None) -> MonitorResult:
        return MonitorResult(
            run,
            self._end_of(self.first_alarm),
            self.first_alarm,
            self.verdict,
            self.alpha,
            ended,
            out_dir,
            self.alarm_detector,
            self._end_of(self.first_alarms["probing"]),
            self._end_of(self.first_alarms["trajectory"]),
        )


def monitor_scenario(
    scn: Scenario,
    out: str | Path,
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
    folder: str | Path | None = None,
    twin_cache: bool = True,
    aircraft: TrimmedAircraft | None = None,
    timeseries: bool = False,
) -> MonitorResult:
    """Fly a scenario with the monitor: ``out/<name>/monitor.parquet`` and ``probing.parquet``.

    Parameters
    ----------
    scn : Scenario
        A validated scenario; its ``[monitor]`` section (or the defaults) sets the detector.
    out, progress, stream, folder, twin_cache, aircraft
        As for :func:`probing.experiment.flight.run.run_scenario`.
    timeseries : bool
        Also write ``timeseries.parquet`` (large for long flights).

    Returns
    -------
    MonitorResult
        First alarm and verdict.  A flight that diverges ends there, its periods before kept
        (``MonitorResult.ended``): a departure is a record too.

    Raises
    ------
    probing.experiment.scenario.ScenarioError
        If the run is too short for the baseline (checked before anything runs).
    """
    folder = folder_of(out, scn.name, folder)
    options = {"progress": progress, "stream": stream, "twin_cache": twin_cache}
    return monitor_flight([scn], [folder], aircraft=aircraft, timeseries=timeseries, **options)[0]


def monitor_flight(
    scenarios: Sequence[Scenario],
    folders: Sequence[str | Path],
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
    twin_cache: bool = True,
    aircraft: TrimmedAircraft | None = None,
    timeseries: bool = False,
) -> list[MonitorResult]:
    """Fly the first scenario with the monitor, and monitor the others from the same flight:
    scenarios that differ from it only in their reference (``output.drift``), each into its
    folder, with the files and results it would have had flown alone
    (:class:`~probing.experiment.flight.run.Companion`).  The aircraft flies once.

    ``scenarios``: one flight (:func:`~probing.experiment.flight.run.flight_key`), each with
    its reference and the reference's settings; ``folders``: each one's; the rest as for
    :func:`monitor_scenario` (``timeseries``: the first scenario's).  Returns each
    scenario's result, in order.

    Raises
    ------
    probing.experiment.scenario.ScenarioError
        If the run is too short for a baseline (checked before anything runs).
    ValueError
        If the scenarios are not one flight.
    """
    monitors = [Monitor(s, s.monitor_settings()) for s in scenarios]
    paths = [Path(f) for f in folders]
    others = zip(scenarios[1:], paths[1:], monitors[1:], strict=True)
    run = run_scenario(
        scenarios[0],
        paths[0].parent,
        progress=progress,
        stream=stream,
        folder=paths[0],
        twin_cache=twin_cache,
        aircraft=aircraft,
        observer=monitors[0],
        timeseries=timeseries,
        nominal_twin=True,
        stop_on_divergence=True,
        record=True,
        companions=[Companion(s, f, m) for s, f, m in others],
    )
    runs = [run, *run.companions]
    return [m.result(r, r.out_dir, r.ended) for m, r in zip(monitors, runs, strict=True)]


class ReplayError(ProbingError, ValueError):
    """A log that cannot be replayed; the message names it and why."""


class NotAFlightLog(ReplayError):
    """A file without the metadata of a monitored flight's log: the message names the first
    key it lacks (a log recorded elsewhere needs a map: ``docs/formats.md``)."""


#: The metadata keys a replay needs in a log (the scenario, its digest, the trim reading).
LOG_KEYS = (b"probing.scenario", b"probing.scenario_digest", b"probing.trim_measured")


#: The metadata of a log that belongs to the log alone, not to what is computed from it.
_LOG_ONLY = (
    b"probing.description",
    b"probing.units",
    b"probing.trim_measured",
    b"probing.chunk_periods",
)


def logged_chunk_periods(meta: dict[bytes, bytes], period_steps: int) -> int:
    """The periods a log's flight estimated at a time: its footer's ``probing.chunk_periods``
    (a live flight's: :data:`probing.experiment.flight.live.LIVE_CHUNK_PERIODS`), else a flight's
    in this process (about :data:`~probing.experiment.flight.run.CHUNK_STEPS` steps)."""
    recorded = meta.get(b"probing.chunk_periods")
    if recorded is not None:
        return int(json.loads(recorded))
    return chunk_periods(period_steps)


def replay_monitor(
    log: str | Path,
    out: str | Path,
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
    folder: str | Path | None = None,
    twin_cache: bool = True,
    table: pa.Table | None = None,
) -> MonitorResult:
    """Recompute a monitored flight's ``monitor.parquet`` and ``probing.parquet`` from its
    log (``sensors.parquet``) alone, into ``out/<name>/`` (or ``folder``).

    ``table``: the log already in memory, its schema's metadata the footer (a log recorded
    elsewhere, translated by :func:`probing.experiment.recorded.foreign_log.foreign_log`); ``log``
    then only names it.

    The log's own metadata gives the scenario and the sensors' reading of the trim; its
    rows go through the same flight computer
    (:class:`~probing.experiment.flight.flight_computer.FlightComputer`: its reference, estimators
    and detectors), in the same chunks as the flight's (:func:`logged_chunk_periods`), so
    the tables are equal bit for bit.  An ``oracle`` reference needs the simulated
    atmosphere: it is flown again from the scenario (simulation only).

    Raises
    ------
    ReplayError
        If the file is not a monitored flight's log, lacks a column its reference reads
        (``follow``: the autopilot's commands), or is not that flight's (:func:`logged_scenario`),
        before any folder is made.
    probing.experiment.output.storage.StoredFileError
        If the file cannot be read.
    """
    log = Path(log)
    meta = read_footer(log) if table is None else dict(table.schema.metadata or {})
    scn, baseline = logged_scenario(log, meta, table)
    settings = scn.monitor_settings()
    monitor = Monitor(scn, settings)
    period_steps = scn.period_steps
    chunk_periods = logged_chunk_periods(meta, period_steps)  # the flight's own chunks
    folder = Path(folder) if folder is not None else Path(out) / scn.name
    lag_s = np.arange(scn.bits_per_period) * scn.probe.bit_duration_s
    ended = meta.get(b"probing.ended")
    kept = {k: v for k, v in meta.items() if k.startswith(b"probing.") and k not in _LOG_ONLY}
    twin = open_reference_twin(scn, nominal=True, use_cache=twin_cache)
    with twin or nullcontext():
        source = reference_source(scn, twin)
        computer = FlightComputer(scn, None, baseline, source, chunk_periods, monitor)
        with output_folder(folder, kept) as outputs:
            computer.open(outputs, lag_s)
            rows = _batches(log, table, chunk_periods * period_steps)
            with progress_bar(scn.periods, scn.name, "periods", stream, progress) as bar:
                first = 0
                for batch in rows:
                    chunk = {c: batch.column(c).to_numpy() for c in batch.schema.names}
                    count = batch.num_rows // period_steps
                    try:
                        computer.consume(chunk, first)
                    except ReferenceDiverged:
                        break  # as the flight's did: its footer's probing.ended says so
                    first += count
                    bar.advance(count)
            computer.finish(outputs, ended)
    return monitor.result(None, folder, None if ended is None else ended.decode())


def _batches(log: Path, table: pa.Table | None, rows: int) -> Iterator[pa.RecordBatch]:
    """The log's rows in batches of ``rows`` (the last one shorter): from the file, or from
    ``table`` when given."""
    if table is None:
        return pq.ParquetFile(log).iter_batches(batch_size=rows)
    return iter(table.combine_chunks().to_batches(max_chunksize=rows))


def _check_rows(log: Path, table: pa.Table | None, scn: Scenario, names: Sequence[str]) -> None:
    """The rows of the columns ``names`` are the flight's (ReplayError: the first that is
    not, :func:`probing.experiment.flight.flight_log.wrong_rows`)."""
    batches = (
        pq.ParquetFile(log).iter_batches(columns=list(names))
        if table is None
        else table.select(list(names)).to_batches()
    )
    wrong = wrong_rows(batches, scn, names)
    if wrong is not None:
        raise ReplayError(f"{log}: {wrong}")


def logged_scenario(
    log: Path, meta: dict[bytes, bytes], table: pa.Table | None = None
) -> tuple[Scenario, np.ndarray]:
    """The scenario a log was flown with and the sensors' reading of the trim, once the log
    is that flight's (``table``: the log in memory, else read from the file): it holds every
    column the replay needs (:func:`probing.experiment.flight.flight_log.replay_columns`), of
    the type the flight writes, a number in every row, its time on the flight's grid, its
    probe the scenario's, and whole probe periods (:mod:`probing.experiment.flight.flight_log`).

    Raises
    ------
    ReplayError
        A key, a column or a value missing, a column of another type, a row off the
        flight's time grid or with another probe, a log of no whole period or more than the
        scenario's (one line naming the file, the column or the first wrong row).
    """
    lacking = [k.decode() for k in LOG_KEYS if k not in meta]
    if lacking:
        raise NotAFlightLog(
            f"{log}: not the sensors.parquet of a monitored flight (no metadata "
            f"{', '.join(lacking)})"
        )
    resolved, digest, trim = (meta[k] for k in LOG_KEYS)
    try:
        scn = parse_scenario(json.loads(resolved), source=str(log))
    except (ScenarioError, ValueError) as exc:
        raise ReplayError(f"{log}: its scenario: {exc}") from None
    if scn.digest() != digest.decode():
        raise ReplayError(f"{log}: its scenario does not match its digest")
    schema = read_schema(log) if table is None else table.schema
    needed = replay_columns(scn)
    missing = [c for c in needed if c not in schema.names]
    if missing:
        raise ReplayError(f"{log}: no column {', '.join(missing)}")
    wrong = wrong_type(schema, scn)
    if wrong is not None:
        raise ReplayError(f"{log}: {wrong}")
    _check_rows(log, table, scn, needed)
    measured = json.loads(trim)
    return scn, np.array([measured[c] for c in scn.channels], dtype=float)
