"""``probing monitor``: a flight probed continuously, with a change detector after every period.

The flight is the scenario's run (:func:`probing.experiment.run.run_scenario`), with its
fault if it has one.  The monitor knows nothing of the fault: it learns its baseline from the
flight's own first settled periods, and with ``drift = "reference"`` its reference twin is the
*nominal* aircraft flying the same commands (:attr:`probing.sim.flight.Flight.nominal`), not a
twin that knows the damage.  ``drift = "detrend"`` needs no model at all.

After every completed period each channel's :class:`~probing.core.monitor.ChangeDetector`
tests the period's estimate; ``monitor.parquet`` gets one row per period and channel, and its
metadata the first alarm and the flight's verdict (``docs/monitoring.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from probing.core.monitor import ChangeDetector, MonitorSettings, flight_verdict
from probing.experiment.run import RunResult, run_scenario
from probing.experiment.scenario import Scenario
from probing.experiment.storage import MONITOR_SCHEMA, AtomicParquetWriter, OutputFolder, metadata
from probing.sim.fork import TrimmedAircraft

__all__ = ["MonitorResult", "monitor_scenario"]


@dataclass
class MonitorResult:
    """What a monitored flight found.

    Attributes
    ----------
    run : RunResult
        The flight's run.
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
    """

    run: RunResult
    first_alarm_s: float | None
    first_alarm_period: int | None
    verdict: str
    alpha: float
    ended: str | None = None

    def facts(self) -> dict[str, float | int | str | None]:
        """The result as plain JSON values (a sweep point's record)."""
        return {
            "first_alarm_s": self.first_alarm_s,
            "first_alarm_period": self.first_alarm_period,
            "verdict": self.verdict,
            "alpha_per_period": self.alpha,
            "ended": self.ended,
        }

    def line(self) -> str:
        """The two facts on one line, as the command prints them."""
        when = "none" if self.first_alarm_s is None else f"{self.first_alarm_s:.2f} s"
        line = f"first alarm: {when} (period {self.first_alarm_period}); verdict: {self.verdict}"
        return line if self.ended is None else f"{line}; the flight ended: {self.ended}"


class _Monitor:
    """The detectors of a flight's channels, fed by the run (a :class:`RunObserver`)."""

    def __init__(self, scn: Scenario, settings: MonitorSettings) -> None:
        self.scn, self.settings = scn, settings
        self.period_s = scn.period_s
        channels = list(scn.channels)
        self.surface = channels.index(scn.surface_channel) if settings.surface else None
        self.monitored = [(j, c) for j, c in enumerate(channels) if j != self.surface]
        self.alpha = settings.alpha(self.period_s, len(self.monitored))
        m = scn.bits_per_period
        self.detectors = [
            ChangeDetector.from_settings(m, settings, self.alpha) for _ in self.monitored
        ]
        self.first = max(scn.settle_periods, scn.first_estimated_period)
        self.first_alarm: int | None = None  # the first alarmed period, any channel
        #: each monitored channel's verdict: decided once its isolation periods are in, the
        #: latest alarmed row's until then ("none": no alarm yet)
        self.verdicts = ["none"] * len(self.monitored)
        self.decided = [False] * len(self.monitored)
        self.writer: AtomicParquetWriter | None = None

    def open(self, outputs: OutputFolder) -> None:
        self.writer = outputs.writer("monitor.parquet", [c for _, c in self.monitored])

    def update(self, periods: np.ndarray, h: np.ndarray, z: np.ndarray) -> None:
        cols: dict[str, list] = {f.name: [] for f in MONITOR_SCHEMA}
        for i, p in enumerate(periods.tolist()):
            if p < self.first:
                continue
            surface = None if self.surface is None else h[i, self.surface]
            for c, ((j, channel), det) in enumerate(
                zip(self.monitored, self.detectors, strict=True)
            ):
                d = det.update(h[i, j], surface)
                if not self.decided[c] and d.verdict != "none":
                    self.verdicts[c] = d.verdict
                if not self.decided[c] and det.isolated:
                    self.verdicts[c] = "airframe" if d.shape_change > 1.0 else "actuator"
                    self.decided[c] = True
                for name, value in (
                    ("period", p),
                    ("time_s", (p + 1) * self.period_s),
                    ("channel", channel),
                    ("statistic", d.statistic),
                    ("threshold", d.threshold),
                    ("alarm", d.alarm),
                    ("gain_change", d.gain_change),
                    ("shape_change", d.shape_change),
                    ("verdict", d.verdict),
                ):
                    cols[name].append(value)
                if d.alarm and self.first_alarm is None:
                    self.first_alarm = p
        if cols["period"] and self.writer is not None:
            self.writer.write(cols)

    def finish(self) -> None:
        """The first alarm and the verdict into the file's footer."""
        assert self.writer is not None
        self.writer.add_metadata(
            metadata(
                first_alarm_s=self._first_alarm_s(),
                first_alarm_period=self.first_alarm,
                verdict=flight_verdict(self.verdicts),
                detector={
                    **self.settings.to_dict(),
                    "alpha_per_period": self.alpha,
                    "period_s": self.period_s,
                    "threshold": self.detectors[0].threshold,
                    "shape_threshold": self.detectors[0].shape_threshold,
                },
            )
        )

    def _first_alarm_s(self) -> float | None:
        """The end of the first alarmed period after the trim, s."""
        return None if self.first_alarm is None else (self.first_alarm + 1) * self.period_s

    def result(self, run: RunResult) -> MonitorResult:
        return MonitorResult(
            run,
            self._first_alarm_s(),
            self.first_alarm,
            flight_verdict(self.verdicts),
            self.alpha,
            run.ended,
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
        As for :func:`probing.experiment.run.run_scenario`.
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
    monitor = _Monitor(scn, scn.monitor_settings())
    run = run_scenario(
        scn,
        out,
        progress=progress,
        stream=stream,
        folder=folder,
        twin_cache=twin_cache,
        aircraft=aircraft,
        observer=monitor,
        timeseries=timeseries,
        nominal_twin=True,
        stop_on_divergence=True,
    )
    return monitor.result(run)
