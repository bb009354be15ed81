"""What makes a file a flight's log: the rules a ``sensors.parquet`` meets before it is
replayed (:func:`probing.experiment.flight.monitor.logged_scenario`), and a log recorded
elsewhere before it is translated into one (:mod:`probing.experiment.recorded.foreign_log`).

A flight's log is what its flight computer recorded (:meth:`FlightComputer.log
<probing.experiment.flight.flight_computer.FlightComputer.log>`), and a replay takes its rows
to be that: step ``k`` of the flight in row ``k``, whole probe periods of them.  So a log is
the flight's only if

* its columns hold the types the flight writes (:func:`wrong_type`; the layout
  :func:`probing.experiment.output.layouts.sensors_schema`);
* its time is the flight's grid, ``k dt_s`` after the trim, the probe's first step ending
  at ``dt_s`` in the first row, increasing by ``dt_s`` row by row (:func:`wrong_time`): a
  row reordered, repeated, dropped or moved is not;
* its probe is the scenario's, the flight computer's own m-sequence times its amplitude
  from its first bit (:func:`wrong_probe`): the flight computer injects nothing else, so a
  log whose probe is another (another sign, amplitude, order, bit duration or phase) is
  another flight's, or none;
* it holds whole probe periods, at least one and at most the scenario's
  (:func:`wrong_length`), as the flight computer logs them.

Each rule names the first column or row that breaks it (None: none does); the callers
raise their own error with it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import pyarrow as pa

from probing.core.time_grid import WrongRow, off_grid
from probing.experiment.flight.onboard import log_columns
from probing.experiment.output.layouts import sensors_schema
from probing.experiment.scenario import Scenario
from probing.sim.channels import CHANNEL_NAMES

__all__ = [
    "PROBE_RTOL",
    "probe_column",
    "replay_columns",
    "wrong_length",
    "wrong_probe",
    "wrong_rows",
    "wrong_time",
    "wrong_type",
]

#: The tolerance of a logged probe against the scenario's, relative to its amplitude: a
#: flight's own log holds it exactly; a log recorded elsewhere may have been scaled.
PROBE_RTOL = 1e-6


def probe_column(scn: Scenario) -> str:
    """The log's column of the probe the flight computer injected (``probe_deg``, or
    ``probe_norm`` for the throttle)."""
    return f"probe_{scn.surface_unit}"


def replay_columns(scn: Scenario) -> tuple[str, ...]:
    """The columns a replay of ``scn``'s log needs: the time, the probe (checked against
    the scenario's) and what the flight computer reads
    (:func:`probing.experiment.flight.onboard.log_columns`)."""
    return tuple(dict.fromkeys(["time_s", probe_column(scn), *log_columns(scn)]))


def wrong_type(schema: pa.Schema, scn: Scenario) -> str | None:
    """The first column of ``schema`` (in its order) of another type than the flight
    writes it with, as a phrase naming it and both types; None if there is none.  A column
    the flight does not write (an index pandas added) is not looked at."""
    channels = [n for n in schema.names if n in CHANNEL_NAMES]
    written = sensors_schema(channels, True, scn.surface)
    for found in schema:
        index = written.get_field_index(found.name)
        if index < 0:
            continue
        expected = written.field(index).type
        if found.type != expected:
            return f"column {found.name} holds {found.type}, not {expected} as the flight writes it"
    return None


def wrong_time(
    time_s: np.ndarray, scn: Scenario, first_row: int = 0, before_s: float | None = None
) -> WrongRow | None:
    """The first row of a log's time (``time_s``: its rows from ``first_row`` on, the row
    before at ``before_s``) off the flight's grid, ``dt_s`` from ``dt_s`` at row 0
    (:func:`probing.core.time_grid.off_grid`); None if there is none."""
    found = off_grid(time_s, scn.dt_s, scn.dt_s, first_row=first_row, before_s=before_s)
    if found is None:
        return None
    dt = f"{scn.dt_s:g} s"
    reason = f"{found.reason} (a flight logs every step of dt_s = {dt}, the first at {dt})"
    return WrongRow(found.row, reason)


def wrong_probe(
    name: str, logged: np.ndarray, scn: Scenario, first_step: int = 0, rows_before: int = 0
) -> WrongRow | None:
    """The first row whose probe (``logged``, the column ``name``: the probe of the
    flight's steps from ``first_step`` on, in rows from ``rows_before + first_step`` on)
    differs from the scenario's by more than :data:`PROBE_RTOL` of its amplitude; None if
    there is none."""
    period = scn.probe.samples(scn.dt_s, 1)  # what the flight computer injects, period by period
    logged = np.asarray(logged, dtype=float)
    flown = period[(first_step + np.arange(logged.size)) % period.size]
    off = ~(np.abs(logged - flown) <= PROBE_RTOL * scn.amplitude_deg)
    if not off.any():
        return None
    i = int(np.argmax(off))
    row = rows_before + first_step + i
    return WrongRow(
        row,
        f"its probe ({name}) is not the scenario's from row {row} on (logged "
        f"{float(logged[i])!r}, the scenario's {float(flown[i])!r}): another sign, "
        "amplitude, order, bit duration or phase",
    )


def wrong_length(rows: int, scn: Scenario) -> str | None:
    """Why a log of ``rows`` rows is not whole probe periods of ``scn``'s flight, at least
    one and at most its ``probe.periods``; None if it is."""
    period = scn.period_steps
    if rows == 0:
        return "it holds no rows"
    if rows % period:
        return (
            f"{rows} row{'s' if rows > 1 else ''}, not whole probe periods of {period} steps "
            "(a flight logs whole periods)"
        )
    if rows > scn.total_steps:
        return (
            f"{rows} rows, more than its scenario's {scn.periods} periods ({scn.total_steps} steps)"
        )
    return None


def wrong_rows(
    batches: Iterable[pa.RecordBatch], scn: Scenario, names: Sequence[str]
) -> str | None:
    """Why a log's rows are not the flight's, or None: the first row (of the batches, in
    order) of the columns ``names`` without a finite number, off the flight's time grid
    (:func:`wrong_time`) or with another probe (:func:`wrong_probe`), then a count of rows
    that is no whole number of the flight's periods (:func:`wrong_length`)."""
    probe = probe_column(scn)
    first, before = 0, None
    for batch in batches:
        found = [_missing_value(name, batch.column(name), first) for name in names]
        time_s = batch.column("time_s").to_numpy(zero_copy_only=False)
        found.append(wrong_time(time_s, scn, first, before))
        logged = batch.column(probe).to_numpy(zero_copy_only=False)
        found.append(wrong_probe(probe, logged, scn, first))
        wrong = min((f for f in found if f is not None), key=lambda f: f.row, default=None)
        if wrong is not None:
            return wrong.reason
        if batch.num_rows:
            before = float(time_s[-1])
        first += batch.num_rows
    return wrong_length(first, scn)


def _missing_value(name: str, column: pa.Array, first: int) -> WrongRow | None:
    """The first row of a chunk (from row ``first`` on) of the column ``name`` without a
    finite number: empty (null), NaN or an infinity."""
    empty = column.is_null().to_numpy(zero_copy_only=False)
    values = column.to_numpy(zero_copy_only=False)
    bad = np.flatnonzero(empty | ~np.isfinite(values))
    if not bad.size:
        return None
    i = int(bad[0])
    what = "no value" if empty[i] else "NaN" if np.isnan(values[i]) else "an infinity"
    return WrongRow(first + i, f"column {name} has {what} at row {first + i}")
