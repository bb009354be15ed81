"""What makes a file a flight's log (probing.experiment.flight.flight_log), and the replay's
refusal of one that is not (logged_scenario), on logs made here row by row as the flight
computer writes them: no flight flown."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from probing.experiment.flight.flight_log import (
    PROBE_RTOL,
    replay_columns,
    wrong_length,
    wrong_probe,
    wrong_type,
)
from probing.experiment.flight.monitor import ReplayError, logged_scenario
from probing.experiment.output.layouts import sensors_schema
from probing.experiment.output.storage import metadata
from probing.experiment.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
#: The monitor study's flight without a sensor suite (no isolation check reads the probe),
#: short: 12 periods of 255 steps.
SCN = load_scenario(ROOT / "scenarios" / "monitor" / "base.toml").replace(
    {"probe.periods": 12, "monitor.baseline_periods": 8, "output.drift": "detrend"}
)
PERIOD = 255


def flight_log(scn=SCN, periods: int = 12) -> pa.Table:
    """A log as the flight computer writes it (its layout, time and probe; the channels at
    zero), with the metadata a replay reads."""
    rows = periods * PERIOD
    columns = {
        "time_s": np.arange(1, rows + 1) * scn.dt_s,
        "probe_deg": scn.probe.samples(scn.dt_s, periods),
        **{c: np.zeros(rows) for c in scn.channels},
    }
    schema = sensors_schema(list(scn.channels), False, scn.surface)
    meta = metadata(
        scenario=scn.to_dict(),
        scenario_digest=scn.digest(),
        trim_measured=dict.fromkeys(scn.channels, 0.0),
    )
    return pa.table(columns, schema=schema).replace_schema_metadata(meta)


def test_a_flights_log_is_one() -> None:
    table = flight_log()
    scn, baseline = logged_scenario(Path("log.parquet"), dict(table.schema.metadata), table)
    assert scn.digest() == SCN.digest() and baseline.tolist() == [0.0, 0.0]


def test_the_probe_is_a_column_a_replay_needs_without_a_check_that_reads_it() -> None:
    """Without a sensor suite no isolation check reads the probe, and a log without it was
    replayed; it is the flight computer's own, so a log without it is not a flight's."""
    assert SCN.sensors is None and "probe_deg" in replay_columns(SCN)
    table = flight_log().drop_columns(["probe_deg"])
    with pytest.raises(ReplayError, match=r"^log\.parquet: no column probe_deg$"):
        logged_scenario(Path("log.parquet"), dict(table.schema.metadata), table)


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda c: c | {"probe_deg": -c["probe_deg"]}, "the scenario's from row 0 on (logged 0.2"),
        (lambda c: c | {"time_s": np.roll(c["time_s"], 1)}, "time at row 0 is 30.6 s, not 0.01 s"),
        (lambda c: {k: v[:-1] for k, v in c.items()}, "3059 rows, not whole probe periods of 255"),
    ],
)
def test_a_log_that_is_not_its_flights_is_one_line(edit, needle: str) -> None:
    table = flight_log()
    columns = edit({n: table.column(n).to_numpy() for n in table.column_names})
    table = pa.table(columns, schema=table.schema)
    with pytest.raises(ReplayError) as err:
        logged_scenario(Path("log.parquet"), dict(table.schema.metadata), table)
    line = str(err.value)
    assert line.startswith("log.parquet: ") and needle in line and "\n" not in line, line


def test_a_probe_within_its_tolerance_is_the_scenarios_and_past_it_not() -> None:
    probe = SCN.probe.samples(SCN.dt_s, 4)
    tol = PROBE_RTOL * SCN.amplitude_deg
    assert wrong_probe("probe_deg", probe, SCN) is None
    for shift, wrong in [(0.9 * tol, False), (-0.9 * tol, False), (1.1 * tol, True)]:
        moved = probe.copy()
        moved[600] += shift
        found = wrong_probe("probe_deg", moved, SCN)
        assert (found is not None) == wrong, (shift, found)
    assert found is not None and found.row == 600 and "from row 600 on" in found.reason


def test_a_probe_checked_in_chunks_keeps_its_phase_and_rows() -> None:
    """A chunk from step 300 on is the probe's steps from 300 (not from its first bit); a log
    recorded elsewhere with 40 rows before the probe names the file's row."""
    probe = SCN.probe.samples(SCN.dt_s, 4)
    assert wrong_probe("probe_deg", probe[300:], SCN, first_step=300) is None
    assert wrong_probe("probe_deg", probe[300:], SCN) is not None
    flipped = -probe
    found = wrong_probe("Elev", flipped, SCN, rows_before=40)
    assert found is not None and found.row == 40 and "its probe (Elev)" in found.reason


@pytest.mark.parametrize(
    ("rows", "why"),
    [
        (0, "it holds no rows"),
        (1, "1 row, not whole probe periods of 255 steps"),
        (PERIOD - 1, "254 rows, not whole"),
        (PERIOD, None),
        (12 * PERIOD, None),
        (12 * PERIOD + 1, "3061 rows, not whole"),
        (13 * PERIOD, "3315 rows, more than its scenario's 12 periods (3060 steps)"),
    ],
)
def test_a_log_holds_whole_periods_one_at_least_and_no_more_than_its_scenarios(
    rows: int, why: str | None
) -> None:
    found = wrong_length(rows, SCN)
    assert found == why if why is None else why in found


def test_a_column_of_another_type_than_written_is_named_first_in_the_logs_order() -> None:
    written = flight_log().schema
    assert wrong_type(written, SCN) is None
    theta = written.get_field_index("theta_rad")
    strings = written.set(theta, pa.field("theta_rad", pa.large_string()))
    assert wrong_type(strings, SCN) == (
        "column theta_rad holds large_string, not double as the flight writes it"
    )
    both = strings.set(0, pa.field("time_s", pa.float32()))
    assert wrong_type(both, SCN) == "column time_s holds float, not double as the flight writes it"
    index = written.append(pa.field("__index_level_0__", pa.int64()))
    assert wrong_type(index, SCN) is None  # pandas' index: not the flight's column
