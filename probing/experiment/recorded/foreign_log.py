"""A log recorded elsewhere (a Simulink model, a flight test; CSV or Parquet) translated into
the form a monitored flight's own log has, so that ``probing monitor --replay LOG --map MAP``
monitors it through the one replay (:func:`probing.experiment.flight.monitor.replay_monitor`).

The map (TOML, ``docs/formats.md``) names, for each of the project's columns (``time_s``,
``probe_<unit>``, the channels such as ``theta_rad``), the file's column and a scale factor
to the project's unit, and how the sensors' reading of the trim is found: given, or the mean
of the log's rows before the probe starts (time <= 0), which the flight computer has before
it probes.  The translated table holds the project's columns in the project's units and, in
its schema's metadata, what a log's footer holds: the scenario (its periods those the log
holds) and the trim reading.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from probing.core.time_grid import off_grid
from probing.experiment.flight.flight_log import probe_column, replay_columns, wrong_probe
from probing.experiment.flight.monitor import ReplayError
from probing.experiment.output.layouts import AUTOPILOT_COLUMNS
from probing.experiment.output.storage import provenance
from probing.experiment.recorded.record import not_numbers
from probing.experiment.scenario import Scenario, ScenarioError
from probing.experiment.scenario.references import REFERENCES, realisable_drifts
from probing.sim.channels import CHANNEL_NAMES

__all__ = ["Column", "LogMap", "foreign_log", "read_map"]


@dataclass(frozen=True)
class Column:
    """Where a project column is in the file: the file's column ``name`` and ``scale``, the
    factor that takes the file's unit to the project's (pi/180 for deg -> rad)."""

    name: str
    scale: float = 1.0


@dataclass(frozen=True)
class LogMap:
    """A map file (``--map``): the columns, and how the trim reading is found.

    Attributes
    ----------
    columns : dict
        Project column -> :class:`Column`; a project column the map does not name is the
        file's column of the same name, unscaled.
    trim_measured : dict or None
        The sensors' reading of the trim per channel, in the channel's unit (given).
    trim_mean_before_s : float or None
        Else: the trim reading is the mean of the log's rows with -this < time_s <= 0, s.
    text : str
        The map as written (kept in the outputs' metadata).
    """

    columns: dict[str, Column]
    trim_measured: dict[str, float] | None
    trim_mean_before_s: float | None
    text: str


def _column(path: Path, name: str, value: Any) -> Column:
    if isinstance(value, str) and value:
        return Column(value)
    if isinstance(value, dict) and set(value) <= {"column", "scale"} and "column" in value:
        scale = value.get("scale", 1.0)
        ok = isinstance(scale, int | float) and not isinstance(scale, bool)
        if isinstance(value["column"], str) and ok and math.isfinite(scale) and scale != 0:
            return Column(value["column"], float(scale))
    raise ReplayError(
        f"{path}: columns.{name}: give the file's column name, or "
        '{ column = "NAME", scale = FACTOR } (a finite, nonzero factor)'
    )


def read_map(path: str | Path) -> LogMap:
    """Read a map file (``docs/formats.md``); ReplayError names what is wrong with it."""
    path = Path(path)
    try:
        text = path.read_text()
        data = tomllib.loads(text)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ReplayError(f"{path}: cannot read the map ({exc})") from None
    unknown = set(data) - {"columns", "trim"}
    if unknown:
        raise ReplayError(f"{path}: unknown section {', '.join(sorted(unknown))}")
    known = {"time_s", "probe_deg", "probe_norm", *AUTOPILOT_COLUMNS, *CHANNEL_NAMES}
    columns = {}
    for name, value in data.get("columns", {}).items():
        if name not in known:
            raise ReplayError(f"{path}: columns.{name}: not a channel or column of a log")
        columns[name] = _column(path, name, value)
    trim = data.get("trim", {})
    measured, before = trim.get("measured"), trim.get("mean_before_s")
    if set(trim) - {"measured", "mean_before_s"} or (measured is None) == (before is None):
        raise ReplayError(f"{path}: [trim]: give measured = {{...}} or mean_before_s = S")
    if before is not None and not (isinstance(before, int | float) and before > 0):
        raise ReplayError(f"{path}: trim.mean_before_s: must be a number > 0 (s)")
    if measured is not None:
        if not isinstance(measured, dict) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in measured.values()
        ):
            raise ReplayError(f"{path}: trim.measured: give channel = value (its unit)")
        measured = {k: float(v) for k, v in measured.items()}
    return LogMap(columns, measured, None if before is None else float(before), text)


def _read_table(log: Path) -> pa.Table:
    """The file as read (CSV, or Parquet by its ``.parquet`` suffix)."""
    try:
        if log.suffix == ".parquet":
            return pq.read_table(log)
        return pacsv.read_csv(log)
    except (OSError, pa.ArrowException) as exc:
        raise ReplayError(f"{log}: cannot read it ({' '.join(str(exc).split())})") from None


def _values(log: Path, table: pa.Table, name: str, column: Column) -> np.ndarray:
    """The project column ``name`` in the project's unit (ReplayError if the column is
    missing, does not hold numbers (:func:`~probing.experiment.recorded.record.not_numbers`),
    or holds a NaN or infinity)."""
    if column.name not in table.column_names:
        if column.name == name:  # not in the map: the file's column of the same name
            raise ReplayError(f"{log}: no column {name!r}, and the map names none for it")
        raise ReplayError(f"{log}: no column {column.name!r} (the map's for {name})")
    raw = table.column(column.name).to_numpy(zero_copy_only=False)
    held = not_numbers(raw)
    if held is not None:
        raise ReplayError(f"{log}: column {column.name!r} (for {name}): {held}, not numbers")
    raw = raw.astype(np.float64)
    bad = ~np.isfinite(raw)
    if bad.any():
        row = int(np.argmax(bad))
        raise ReplayError(f"{log}: column {column.name!r} (for {name}): no value at row {row}")
    return raw * column.scale if column.scale != 1.0 else raw


def _check_time(log: Path, time_s: np.ndarray, dt_s: float) -> None:
    """Time on the scenario's grid, ``k dt_s`` after the trim, from the first row
    (:func:`probing.core.time_grid.off_grid`): the first row after time 0 is the probe's
    first step, at ``dt_s`` (a log that starts later starts there)."""
    start = dt_s * min(1, round(float(time_s[0]) / dt_s))
    wrong = off_grid(time_s, dt_s, start)
    if wrong is not None:
        raise ReplayError(
            f"{log}: {wrong.reason} (a log is replayed on the scenario's steps of dt_s = "
            f"{dt_s!r} s after the trim, not resampled)"
        )


def _trim(log: Path, how: LogMap, scn: Scenario, cols: dict[str, np.ndarray]) -> dict:
    """The sensors' reading of the trim, per channel (realisable: given, or the mean of the
    rows before the probe starts)."""
    if how.trim_measured is not None:
        missing = [c for c in scn.channels if c not in how.trim_measured]
        if missing:
            raise ReplayError(f"{log}: the map's trim.measured lacks {', '.join(missing)}")
        return {c: how.trim_measured[c] for c in scn.channels}
    assert how.trim_mean_before_s is not None
    t = cols["time_s"]
    before = (t <= 0) & (t > -how.trim_mean_before_s)
    if not before.any():
        raise ReplayError(
            f"{log}: no row in the {how.trim_mean_before_s:g} s before the probe starts "
            "(time <= 0) to take the trim reading from"
        )
    return {c: float(np.mean(cols[c][before])) for c in scn.channels}


def foreign_log(log: str | Path, how: LogMap, scn: Scenario) -> pa.Table:
    """The log recorded elsewhere as a monitored flight's log, in memory.

    Parameters
    ----------
    log : path
        The file: CSV (a header line of column names), or Parquet (``.parquet``).
    how : LogMap
        The map (:func:`read_map`).
    scn : Scenario
        The aircraft, probe and monitor settings; its drift must be one of
        :func:`~probing.experiment.scenario.references.realisable_drifts`.

    Returns
    -------
    pyarrow.Table
        ``time_s`` (s after the trim, the end of each step), the probe and the columns
        the replay reads, float64 in the project's units, the rows after time 0 in whole
        periods; its schema's metadata: the scenario (``probe.periods`` the log's) and
        ``probing.trim_measured``, as in a flight's own ``sensors.parquet``.

    Raises
    ------
    ReplayError
        No rows, a missing column, one of text, a NaN, time off the grid of ``dt_s`` (the
        first wrong row named), a probe that is not the scenario's
        (:func:`probing.experiment.flight.flight_log.wrong_probe`), a log shorter than the
        monitor's baseline needs.
    """
    log = Path(log)
    if not REFERENCES[scn.drift].realisable:
        raise ReplayError(
            f"{log}: drift {scn.drift} needs the simulation; a log recorded elsewhere is "
            f"monitored with {', '.join(realisable_drifts())}"
        )
    table = _read_table(log)
    if table.num_rows == 0:
        raise ReplayError(f"{log}: it holds no rows")
    probe = probe_column(scn)
    cols = {n: _values(log, table, n, how.columns.get(n, Column(n))) for n in replay_columns(scn)}
    _check_time(log, cols["time_s"], scn.dt_s)
    trim = _trim(log, how, scn, cols)
    period_steps = scn.period_steps
    first = int(np.searchsorted(cols["time_s"], 0.0, side="right"))
    periods = (cols["time_s"].size - first) // period_steps
    try:
        scn = scn.replace({"probe.periods": periods})
        scn.monitor_settings()
    except ScenarioError as exc:
        raise ReplayError(f"{log}: {periods} whole probe periods after time 0: {exc}") from None
    kept = slice(first, first + periods * period_steps)
    cols = {n: v[kept] for n, v in cols.items()}
    name = how.columns.get(probe, Column(probe)).name
    wrong = wrong_probe(name, cols[probe], scn, rows_before=first)
    if wrong is not None:
        raise ReplayError(f"{log}: {wrong.reason}")
    meta = provenance(
        scenario_toml=scn.text,
        scenario=scn.to_dict(),
        scenario_digest=scn.digest(),
        trim_measured=trim,
        log=str(log),
        log_map=how.text,
    )
    return pa.table(cols).replace_schema_metadata(meta)
